"""Fence exports (analysis.formats.fence_files.export_fence, ``export-fence``): each format read back by the
importer gives the same fence within 1e-7 deg; KML parsed as XML; what a format cannot carry is warned about."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from analysis.formats.fence_files import EXPORT_FORMATS, ImportOptions, RallyPoint, export_fence, load_fence_file
from geofence.geometry.fence import Fence, FenceError, KeepOutCircle, VerticalExtent
from geofence.geometry.geodesy import geodesic_distance_m
from tests.support import ROOT, latlon, random_fence

TOL_DEG = 1e-7


def same_polygon(a, b) -> bool:
    return len(a) == len(b) and all(abs(p[0] - q[0]) <= TOL_DEG and abs(p[1] - q[1]) <= TOL_DEG for p, q in zip(a, b))


def read_back(tmp_path, fence: Fence, fmt: str, rally=(), ceiling_m: float | None = None):
    path = tmp_path / f"fence.{fmt}"
    path.write_text(export_fence(fence, fmt, rally).text)
    return load_fence_file(path, ImportOptions(ceiling_m=ceiling_m))


fences = st.builds(random_fence, st.integers(0, 10_000), st.integers(3, 40), st.integers(0, 3), st.integers(0, 2))


@settings(max_examples=30)
@given(fences, st.sampled_from(["qgc_plan", "qgc_wpl_110"]))
def test_mavlink_formats_round_trip(tmp_path_factory, fence, fmt):
    got = read_back(tmp_path_factory.mktemp("x"), fence, fmt, ceiling_m=fence.ceiling_m).fence
    assert same_polygon(got.keep_in, fence.keep_in)
    assert len(got.keep_out_polygons) == len(fence.keep_out_polygons)
    assert all(same_polygon(a, b) for a, b in zip(got.keep_out_polygons, fence.keep_out_polygons))
    assert len(got.keep_out_circles) == len(fence.keep_out_circles)
    for a, b in zip(got.keep_out_circles, fence.keep_out_circles):
        assert abs(a.center_lat_deg - b.center_lat_deg) <= TOL_DEG and abs(a.center_lon_deg - b.center_lon_deg) <= TOL_DEG
        assert a.radius_m == pytest.approx(b.radius_m, abs=1e-9)
    assert got.ceiling_m == fence.ceiling_m


@settings(max_examples=30)
@given(fences, st.floats(20.0, 500.0), st.floats(1.0, 10.0))
def test_geojson_round_trip_keeps_heights(tmp_path_factory, fence, ceiling, floor):
    fence = dataclasses.replace(
        fence, ceiling_m=ceiling, floor_m=floor,
        keep_out_polygon_extents=tuple(VerticalExtent(None, 15.0) for _ in fence.keep_out_polygons),
    )  # fmt: skip
    got = read_back(tmp_path_factory.mktemp("x"), fence, "geojson").fence
    assert same_polygon(got.keep_in, fence.keep_in)
    n = len(fence.keep_out_polygons)
    assert all(same_polygon(a, b) for a, b in zip(got.keep_out_polygons[:n], fence.keep_out_polygons))
    assert got.keep_out_polygon_extents[:n] == fence.keep_out_polygon_extents
    assert (got.ceiling_m, got.floor_m) == (ceiling, floor)
    # a keep-out circle comes back as a polygon around it: every edge's midpoint at or outside the radius
    assert len(got.keep_out_polygons) == n + len(fence.keep_out_circles)
    for poly, c in zip(got.keep_out_polygons[n:], fence.keep_out_circles):
        for (a_lat, a_lon), (b_lat, b_lon) in zip(poly, poly[1:] + poly[:1]):
            mid = geodesic_distance_m(c.center_lat_deg, c.center_lon_deg, (a_lat + b_lat) / 2, (a_lon + b_lon) / 2)
            assert mid >= c.radius_m - 1e-3


@settings(max_examples=20)
@given(fences)
def test_mavproxy_round_trip_keeps_the_keep_in_and_return_point(tmp_path_factory, fence):
    rp = latlon(1.0, 1.0)  # (the random keep-ins are stars about the origin)
    try:
        fence = dataclasses.replace(fence, recovery_point=rp)
    except FenceError:  # a keep-out covers it
        assume(False)
    exported = export_fence(fence, "mavproxy_fence")
    assert bool(fence.keep_out_polygons or fence.keep_out_circles) == any("no keep-outs" in w for w in exported.warnings)
    got = read_back(tmp_path_factory.mktemp("x"), fence, "mavproxy_fence", ceiling_m=fence.ceiling_m)
    assert same_polygon(got.fence.keep_in, fence.keep_in)
    assert got.return_point is not None and same_polygon([got.return_point[:2]], [rp])


def test_plan_carries_circles_return_point_and_rally(tmp_path):
    fence = Fence(
        keep_in=(), keep_in_circle=(-35.3632, 149.1652, 300.0), ceiling_m=60.0,
        keep_out_circles=(KeepOutCircle(-35.3630, 149.1650, 20.0),), recovery_point=(-35.3633, 149.1653, 25.0),
    )  # fmt: skip
    rally = (RallyPoint(-35.3634, 149.1654, 30.0),)
    for fmt in ("qgc_plan", "qgc_wpl_110"):
        got = read_back(tmp_path, fence, fmt, rally, ceiling_m=60.0)
        assert got.inclusion_circles[0].radius_m == 300.0
        assert abs(got.inclusion_circles[0].center_lat_deg + 35.3632) <= TOL_DEG
        assert got.keep_out_circles[0].radius_m == 20.0
        assert got.return_point is not None and got.return_point[:2] == pytest.approx((-35.3633, 149.1653), abs=TOL_DEG)
        assert [(p.lat_deg, p.lon_deg, p.alt_m) for p in got.rally_points] == [(-35.3634, 149.1654, 30.0)]
        assert same_polygon(got.fence.keep_in, fence.keep_in)  # the same inscribed polygon of the circle


def test_kml_is_xml_with_the_fence_coordinates():
    fence = random_fence(7, 12, 2, 1)
    text = export_fence(fence, "kml").text
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    root = ET.fromstring(text)
    rings = [el.text.split() for el in root.iterfind(".//k:Polygon//k:coordinates", ns)]
    assert len(rings) == 1 + len(fence.keep_out_polygons) + len(fence.keep_out_circles)
    for ring, poly in zip(rings, (fence.keep_in, *fence.keep_out_polygons)):
        pts = [tuple(float(v) for v in p.split(",")) for p in ring]
        assert pts[0] == pts[-1]
        assert same_polygon([(lat, lon) for lon, lat, _ in pts[:-1]], poly)
        assert math.isclose(pts[0][2], fence.ceiling_m)


def test_every_format_warns_about_what_it_drops():
    fence = dataclasses.replace(random_fence(3, 8, 1, 1), floor_m=5.0)
    for fmt in EXPORT_FORMATS:
        warnings = export_fence(fence, fmt).warnings
        if fmt in ("qgc_plan", "qgc_wpl_110", "mavproxy_fence"):
            assert any("no ceiling" in w for w in warnings) and any("no floor" in w for w in warnings)
        else:
            assert any("no circle" in w for w in warnings)


def test_export_fence_cli(tmp_path):
    out = tmp_path / "f.plan"
    scenario = ROOT / "scenarios" / "geofence_multicopter_keep_in_circle.yaml"
    cmd = [sys.executable, "-m", "scenarios.app.cli", "export-fence", str(scenario), "--to", "qgc_plan", "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    assert "no ceiling" in proc.stderr
    assert load_fence_file(out, ImportOptions(ceiling_m=50.0)).inclusion_circles[0].radius_m == 80.0
    bad = subprocess.run(
        [*cmd[:-4], "--to", "shapefile", "--out", str(out)], capture_output=True, text=True, timeout=120, cwd=ROOT
    )
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
