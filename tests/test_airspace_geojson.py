"""Airspace-scale fences: the GeoJSON importer, fence files referenced by scenarios, and the city-park generator."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from analysis.formats.fence_files import (
    MAX_FENCE_POLYGONS,
    MAX_FENCE_VERTICES,
    ImportOptions,
    detect_format,
    fence_to_yaml_block,
    load_fence_file,
)
from geofence.geometry.fence import FenceError
from geofence.geometry.geodesy import LocalFrame, geodesic_destination
from geofence.validation import ConfigError
from scenarios.airspace.generate import bounding_rectangle, generate_park, write_geojson
from scenarios.definition.schema import PilotKind, load_scenario, parse_scenario

ROOT = Path(__file__).parents[1]
AIRSPACE = ROOT / "scenarios" / "airspace"

# An asymmetric site: lat 47.39 N, lon 8.54 E. Read in the wrong order it would be a fence in the
# Gulf of Aden (lat 8.54, lon 47.39), so the order is visible in every vertex.
LAT0, LON0 = 47.3975, 8.5450
SQUARE_LL = [(47.3975, 8.5450), (47.3975, 8.5475), (47.3990, 8.5475), (47.3990, 8.5450)]  # (lat, lon), ccw
INNER_LL = [(47.3980, 8.5455), (47.3980, 8.5460), (47.3985, 8.5460), (47.3985, 8.5455)]
OTHER_LL = [(47.3981, 8.5465), (47.3981, 8.5469), (47.3984, 8.5469), (47.3984, 8.5465)]


def ring(latlon) -> list[list[float]]:
    """A closed GeoJSON ring ([lon, lat] positions) from (lat, lon) vertices."""
    pts = [[lon, lat] for lat, lon in latlon]
    return pts + [pts[0]]


def feature(props, gtype, coords, **extra) -> dict:
    return {"type": "Feature", "properties": props, "geometry": {"type": gtype, "coordinates": coords}, **extra}


def collection(*features, **props) -> dict:
    doc = {"type": "FeatureCollection", "features": list(features)}
    if props:
        doc["properties"] = props
    return doc


def keep_in(latlon=SQUARE_LL, holes=(), **props) -> dict:
    return feature({"geofence": "keep_in", **props}, "Polygon", [ring(latlon), *[ring(h) for h in holes]])


def keep_out(latlon=INNER_LL, **props) -> dict:
    return feature({"geofence": "keep_out", **props}, "Polygon", [ring(latlon)])


def write(tmp_path: Path, doc, name: str = "fence.geojson") -> Path:
    p = tmp_path / name
    p.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return p


# =========================================================================== parsing
def test_lon_lat_order_and_exact_floats(tmp_path):
    p = write(tmp_path, collection(keep_in(), ceiling_m=60))
    assert detect_format(p) == "geojson"
    imp = load_fence_file(p)
    assert imp.source_format == "geojson"
    assert imp.fence.keep_in == tuple(SQUARE_LL)  # (lat, lon), closing duplicate dropped, floats exact
    assert imp.fence.ceiling_m == 60 and imp.ceiling_source == "file" and imp.warnings == []
    lat, lon = imp.fence.center()
    assert abs(lat - 47.39825) < 1e-3 and abs(lon - 8.54625) < 1e-3


def test_swapped_order_is_refused_where_it_cannot_be_a_place(tmp_path):
    # Canberra written [lat, lon] instead of [lon, lat]: latitude 149 is impossible
    canberra = [(-35.3636, 149.1640), (-35.3636, 149.1664), (-35.3617, 149.1664), (-35.3617, 149.1640)]
    pts = [[lat, lon] for lat, lon in canberra]
    doc = collection(feature({"geofence": "keep_in"}, "Polygon", [pts + [pts[0]]]))
    p = write(tmp_path, doc)
    with pytest.raises(
        FenceError,
        match=r"features\[0\]: geometry.coordinates\[0\]\[0\] latitude: must be <= 90, got 149.164 "
        r"\(GeoJSON positions are \[lon, lat\]\)",
    ):
        load_fence_file(p)


def test_keep_in_holes_become_keep_outs_and_keep_out_holes_are_ignored(tmp_path):
    holed_keep_out = feature(
        {"geofence": "keep_out"},
        "Polygon",
        [ring(OTHER_LL), ring([(47.39822, 8.54668), (47.39822, 8.54672), (47.39826, 8.54672)])],
    )
    p = write(tmp_path, collection(keep_in(holes=[INNER_LL]), holed_keep_out, ceiling_m=50))
    imp = load_fence_file(p)
    assert imp.fence.keep_out_polygons == (tuple(INNER_LL), tuple(OTHER_LL))
    assert any("features[1]: 1 hole(s) of a keep-out ignored" in w for w in imp.warnings)


def test_multipolygons(tmp_path):
    far = [(47.3000, 8.5000), (47.3000, 8.5010), (47.3010, 8.5010)]
    doc = collection(
        feature({"geofence": "keep_in"}, "MultiPolygon", [[ring(SQUARE_LL)], [ring(far)]]),
        feature({"geofence": "keep_out", "name": "twin towers"}, "MultiPolygon", [[ring(INNER_LL)], [ring(OTHER_LL)]]),
        ceiling_m=50,
    )
    with pytest.raises(FenceError, match="2 inclusion areas"):  # ArduPilot would fly their intersection
        load_fence_file(write(tmp_path, doc))
    imp = load_fence_file(write(tmp_path, doc), ImportOptions(inclusion_polygon=0))
    assert imp.fence.keep_in == tuple(SQUARE_LL) and imp.keep_in_polygons == (tuple(SQUARE_LL), tuple(far))
    assert imp.fence.keep_out_polygons == (tuple(INNER_LL), tuple(OTHER_LL))
    assert any("inclusion area 0 of 2 used" in w for w in imp.warnings)


@pytest.mark.parametrize("restriction", ["PROHIBITED", "REQ_AUTHORISATION", "CONDITIONAL"])
def test_ed269_restrictions_are_keep_outs(tmp_path, restriction):
    zone = feature({"identifier": "ZONE1", "restriction": restriction}, "Polygon", [ring(INNER_LL)])
    ignored = feature({"restriction": "NO_RESTRICTION"}, "Polygon", [ring(OTHER_LL)], id="open-1")
    imp = load_fence_file(write(tmp_path, collection(keep_in(), zone, ignored, ceiling_m=50)))
    assert imp.fence.keep_out_polygons == (tuple(INNER_LL),)
    assert any("features[2] (id 'open-1'): ED-269 restriction NO_RESTRICTION: ignored" in w for w in imp.warnings)


def test_geofence_property_wins_over_restriction(tmp_path):
    zone = feature({"geofence": "keep_in", "restriction": "PROHIBITED"}, "Polygon", [ring(SQUARE_LL)])
    imp = load_fence_file(write(tmp_path, collection(zone, ceiling_m=50)))
    assert imp.fence.keep_in == tuple(SQUARE_LL) and imp.fence.keep_out_polygons == ()


def test_return_point_and_rally_points(tmp_path):
    doc = collection(
        keep_in(),
        keep_out(),
        feature({"geofence": "return_point"}, "Point", [8.5470, 47.3988]),
        feature({"geofence": "rally", "alt_m": 30}, "Point", [8.5452, 47.3977, 512.0]),
        feature({"geofence": "return_point"}, "Point", [8.5453, 47.3977]),
        ceiling_m=50,
    )
    imp = load_fence_file(write(tmp_path, doc))
    assert imp.return_point == (47.3988, 8.5470) and imp.fence.recovery_point == (47.3988, 8.5470)
    assert imp.rally_points[0].lat_deg == 47.3977 and imp.rally_points[0].lon_deg == 8.5452
    assert imp.rally_points[0].alt_m == 30 and imp.rally_points[0].alt_reference == "relative"
    assert any("second return point ignored" in w for w in imp.warnings)
    # a return point inside a keep-out is reported, not used
    inside = collection(keep_in(), keep_out(), feature({"geofence": "return_point"}, "Point", [8.54575, 47.39825]), ceiling_m=50)
    imp = load_fence_file(write(tmp_path, inside, "b.geojson"))
    assert imp.fence.recovery_point is None and any("not used as the recovery point" in w for w in imp.warnings)
    # an explicit recovery point wins
    imp = load_fence_file(write(tmp_path, doc, "c.geojson"), ImportOptions(recovery_point=(47.3977, 8.5452)))
    assert imp.fence.recovery_point == (47.3977, 8.5452) and imp.return_point == (47.3988, 8.5470)


def test_bare_feature_and_bare_geometry(tmp_path):
    imp = load_fence_file(write(tmp_path, keep_in(ceiling_m=40), "f.geojson"))
    assert imp.fence.keep_in == tuple(SQUARE_LL) and imp.fence.ceiling_m == 40
    geom = {"type": "Polygon", "coordinates": [ring(SQUARE_LL), ring(INNER_LL)]}
    imp = load_fence_file(write(tmp_path, geom, "g.geojson"), ImportOptions(ceiling_m=30))
    assert imp.fence.keep_in == tuple(SQUARE_LL) and imp.fence.keep_out_polygons == (tuple(INNER_LL),)
    assert detect_format(tmp_path / "g.geojson") == "geojson"


def test_vertical_limits_file_then_feature_then_arguments(tmp_path):
    p = write(tmp_path, collection(keep_in(ceiling_m=80, floor_m=10), ceiling_m=60, floor_m=5, altitude_reference="AMSL"))
    imp = load_fence_file(p)  # the keep-in feature's values win over the collection's
    f = imp.fence
    assert (f.ceiling_m, f.floor_m, f.altitude_reference, imp.ceiling_source) == (80, 10, "amsl", "file")
    imp = load_fence_file(p, ImportOptions(ceiling_m=70, floor_m=2, altitude_reference="agl"))  # explicit arguments win
    f = imp.fence
    assert (f.ceiling_m, f.floor_m, f.altitude_reference, imp.ceiling_source) == (70, 2, "agl", "argument")
    imp = load_fence_file(write(tmp_path, collection(keep_in()), "n.geojson"))
    assert imp.ceiling_source == "default" and any("default ceiling 120 m AGL" in w for w in imp.warnings)


def test_plan_detection_unchanged(tmp_path):
    plan = {"fileType": "Plan", "geoFence": {"polygons": [{"inclusion": True, "polygon": [list(v) for v in SQUARE_LL]}]}}
    p = write(tmp_path, plan, "a.plan")
    assert detect_format(p) == "qgc_plan"
    assert load_fence_file(p).fence.keep_in == tuple(SQUARE_LL)  # .plan is [lat, lon]


def test_yaml_block_round_trip(tmp_path):
    from geofence.geometry.fence import parse_fence

    imp = load_fence_file(write(tmp_path, collection(keep_in(holes=[INNER_LL]), ceiling_m=45)))
    assert parse_fence(fence_to_yaml_block(imp)["geofence"]["fence"]) == imp.fence


# =========================================================================== errors
SELF_X = [(47.3980, 8.5455), (47.3985, 8.5460), (47.3985, 8.5455), (47.3980, 8.5460)]  # a bow tie
MALFORMED = [
    (
        collection(keep_in(), feature({"height": 3}, "Polygon", [ring(INNER_LL)])),
        "features[1]: no role: give properties.geofence",
    ),
    (
        collection(keep_in(), feature({"geofence": "keepout"}, "Polygon", [ring(INNER_LL)])),
        "features[1]: properties.geofence: 'keepout' is not one of keep_in, keep_out, return_point, rally",
    ),
    (
        collection(keep_in(), feature({"restriction": "FORBIDDEN"}, "Polygon", [ring(INNER_LL)], id=7)),
        "features[1] (id 7): properties.restriction: 'FORBIDDEN' is not an ED-269 restriction",
    ),
    (
        collection(feature({"geofence": "keep_in"}, "Polygon", [ring(SQUARE_LL)[:-1]])),
        "features[0]: geometry.coordinates[0]: ring is not closed",
    ),
    (
        collection(feature({"geofence": "keep_in"}, "Polygon", [[[8.5, 47.3], [8.6, 47.3], [8.5, 47.3], [8.5, 47.3]]])),
        "features[0]: geometry.coordinates[0]: ring needs at least 3 distinct vertices, got 2",
    ),
    (
        collection(feature({"geofence": "keep_in"}, "Polygon", [[[188.5, 47.3], [8.6, 47.3], [8.6, 47.4], [188.5, 47.3]]])),
        "features[0]: geometry.coordinates[0][0] longitude: must be <= 180, got 188.5 (GeoJSON positions are [lon, lat])",
    ),
    (
        collection(feature({"geofence": "keep_in"}, "Polygon", [[[8.5, "47.3"], [8.6, 47.3], [8.6, 47.4], [8.5, "47.3"]]])),
        "features[0]: geometry.coordinates[0][0]: expected a number, got a string '47.3'",
    ),
    (
        collection(feature({"geofence": "keep_in"}, "Polygon", [[[8.5], [8.6, 47.3], [8.6, 47.4], [8.5]]])),
        "features[0]: geometry.coordinates[0][0]: must be a position [lon, lat]",
    ),
    (
        '{"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {"geofence": "keep_in"}, '
        '"geometry": {"type": "Polygon", "coordinates": [[[8.5, NaN], [8.6, 47.3], [8.6, 47.4], [8.5, NaN]]]}}]}',
        "features[0]: geometry.coordinates[0][0]: must be a finite number, got nan",
    ),
    (
        collection(feature({"geofence": "keep_in"}, "Point", [8.5, 47.3])),
        "features[0]: a keep-in area must be a Polygon or MultiPolygon, got 'Point'",
    ),
    (
        collection(keep_in(), feature({"geofence": "return_point"}, "Polygon", [ring(INNER_LL)])),
        "features[1]: a return point must be a Point, got 'Polygon'",
    ),
    (
        collection(keep_in(), feature({"geofence": "keep_out"}, None, None) | {"geometry": None}),
        "features[1]: geometry: must be a GeoJSON geometry object, got null",
    ),
    (collection(keep_in(), keep_out(SELF_X, name="bow tie")), "features[1] (name 'bow tie'): self-intersecting: edge 0"),
    (collection(keep_in(SELF_X)), "features[0]: self-intersecting"),
    (collection(keep_in(holes=[SELF_X])), "features[0] hole 1 (a keep-out): self-intersecting"),
    (collection(keep_out()), "no inclusion polygon or circle (only exclusions)"),
    (collection(), "no fence items"),
    (collection(keep_in(), 42), "features[1]: must be a Feature object, got 42"),
    (collection(keep_in()) | {"features": {"a": 1}}, "features: must be a list of Feature objects"),
    (collection(keep_in()) | {"crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::3857"}}}, "crs: {"),
    (collection(keep_in(), ceiling_m="high"), "properties.ceiling_m: expected a number, got a string 'high'"),
    (collection(keep_in(altitude_reference="msl")), "features[0]: properties.altitude_reference: 'msl' is not one of agl, amsl"),
    ({"type": "LineString", "coordinates": [[8.5, 47.3], [8.6, 47.3]]}, "a bare LineString geometry is not a fence"),
    (
        collection(keep_in(), feature({"geofence": "keep_out"}, "Polygon", "none")),
        "features[1]: geometry.coordinates: must be a non-empty list of linear rings",
    ),
]


@pytest.mark.parametrize("doc, expect", MALFORMED, ids=[m[1][:40] for m in MALFORMED])
def test_malformed_is_one_line_naming_file_and_feature(tmp_path, doc, expect):
    p = write(tmp_path, doc, "bad.geojson")
    with pytest.raises(FenceError) as ei:
        load_fence_file(p, ImportOptions(ceiling_m=50))
    msg = str(ei.value)
    assert "\n" not in msg and msg.startswith(f"{p}: ")
    assert expect in msg, msg


def test_vertex_and_polygon_limits(tmp_path):
    assert MAX_FENCE_VERTICES == 200_000 and MAX_FENCE_POLYGONS == 20_000
    p = write(tmp_path, collection(keep_in(holes=[INNER_LL]), keep_out(OTHER_LL), ceiling_m=50))
    # 3 rings of 5 positions each (closing duplicates count: that is what is read)
    assert len(load_fence_file(p, ImportOptions(max_vertices=15, max_polygons=3)).fence.keep_out_polygons) == 2
    with pytest.raises(FenceError, match=r"fence.geojson: 15 polygon vertices exceed the limit of 14 \(max_vertices\)"):
        load_fence_file(p, ImportOptions(max_vertices=14))
    with pytest.raises(FenceError, match=r"fence.geojson: 3 polygons exceed the limit of 2 \(max_polygons\)"):
        load_fence_file(p, ImportOptions(max_polygons=2))
    # checked before the coordinates are read: a malformed vertex behind the limit is not reached
    bad = collection(keep_in(), feature({"geofence": "keep_out"}, "Polygon", [[[1e9, 0]] * 20]))
    with pytest.raises(FenceError, match="25 polygon vertices exceed the limit of 10"):
        load_fence_file(write(tmp_path, bad, "big.geojson"), ImportOptions(max_vertices=10))
    # the other formats obey the same limits
    plan = {"fileType": "Plan", "geoFence": {"polygons": [{"inclusion": True, "polygon": [list(v) for v in SQUARE_LL]}]}}
    with pytest.raises(FenceError, match="4 polygon vertices exceed the limit of 3"):
        load_fence_file(write(tmp_path, plan, "a.plan"), ImportOptions(max_vertices=3))


# =========================================================================== round trip (hypothesis)
@st.composite
def star_fences(draw):
    """A random star-shaped (so simple) keep-in around a centre, and keep-out squares near the centre, in lat/lon."""
    lat0 = draw(st.floats(-75.0, 75.0))
    lon0 = draw(st.floats(-175.0, 175.0))
    n = draw(st.integers(3, 40))
    jitter = draw(st.lists(st.floats(0.0, 0.4), min_size=n, max_size=n))
    radii = draw(st.lists(st.floats(40.0, 3000.0), min_size=n, max_size=n))
    keep_in_ll = [geodesic_destination(lat0, lon0, (k + j) * 360.0 / n, r) for k, (j, r) in enumerate(zip(jitter, radii))]
    if draw(st.booleans()):
        keep_in_ll.reverse()
    m = draw(st.integers(0, 6))
    sides = draw(st.lists(st.floats(0.5, 3.0), min_size=m, max_size=m))
    frame = LocalFrame(lat0, lon0, 0.0)
    squares = []
    for k, s in enumerate(sides):  # on a ring of radius 8 m: 8 m apart, so never overlapping
        ce, cn = 8.0 * math.cos(2 * math.pi * k / max(m, 1)), 8.0 * math.sin(2 * math.pi * k / max(m, 1))
        squares.append(
            [
                frame.to_geodetic(ce + dx * s, cn + dy * s, 0.0)[:2]
                for dx, dy in ((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5))
            ]
        )
    return keep_in_ll, squares


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=star_fences())
def test_round_trip_through_geojson(tmp_path, data):
    keep_in_ll, squares = data
    p = write(tmp_path, collection(keep_in(keep_in_ll), *[keep_out(s) for s in squares], ceiling_m=100), "rt.geojson")
    imp = load_fence_file(p)
    got = np.array(imp.fence.keep_in)
    assert got.shape == (len(keep_in_ll), 2)
    assert np.abs(got - np.array(keep_in_ll)).max() <= 1e-9
    assert len(imp.keep_out_polygons) == len(squares)
    for read, written in zip(imp.keep_out_polygons, squares):
        assert np.abs(np.array(read) - np.array(written)).max() <= 1e-9
    assert set(imp.fence.keep_out_polygons) <= set(imp.keep_out_polygons)


# =========================================================================== the generator
def _shapes(doc):
    from shapely.geometry import Polygon

    frame = LocalFrame(
        *reversed(next(f for f in doc["features"] if f["geometry"]["type"] == "Point")["geometry"]["coordinates"]), 0.0
    )

    def en(r):
        return [frame.to_enu(lat, lon, 0.0)[:2] for lon, lat in r[:-1]]

    ki = [en(f["geometry"]["coordinates"][0]) for f in doc["features"] if f["properties"]["geofence"] == "keep_in"]
    ko = [en(f["geometry"]["coordinates"][0]) for f in doc["features"] if f["properties"]["geofence"] == "keep_out"]
    assert len(ki) == 1
    return np.array(ki[0]), [Polygon(k) for k in ko], Polygon(ki[0])


def _check_park(doc, n_vertices, n_buildings, clearance_m):
    from shapely.strtree import STRtree

    ki, buildings, park = _shapes(doc)
    assert len(ki) == n_vertices and len(buildings) == n_buildings
    # star-shaped about the centre (strictly increasing angle, gaps < pi): simple by construction
    ang = np.unwrap(np.arctan2(ki[:, 1], ki[:, 0]))
    steps = np.diff(np.append(ang, ang[0] + 2 * math.pi))
    assert (steps > 0).all() and (steps < math.pi).all() and abs(ang[-1] - ang[0]) < 2 * math.pi
    assert park.is_valid
    boundary = park.exterior
    tree = STRtree(buildings)
    for i, b in enumerate(buildings):
        assert b.is_valid and park.contains(b), f"building {i} is not inside the keep-in"
        assert b.distance(boundary) >= clearance_m, f"building {i} is {b.distance(boundary):.2f} m from the boundary"
        for j in tree.query(b.buffer(clearance_m)):
            if j != i:
                assert b.distance(buildings[j]) >= clearance_m, f"buildings {i} and {j} are too close"
        d = max(math.dist(p, q) for p in b.exterior.coords for q in b.exterior.coords)
        assert 10.0 <= d <= 40.0 * math.sqrt(2) + 1e-6


def test_generator_small_instance_is_valid_and_deterministic():
    kw = dict(seed=5, radius_m=500.0, n_vertices=1200, n_buildings=60, meadow_radius_m=80.0, avenue_width_m=60.0)
    doc = generate_park(**kw)
    _check_park(doc, 1200, 60, 30.0)
    assert generate_park(**kw) == doc
    assert generate_park(**{**kw, "seed": 6}) != doc
    assert doc["properties"]["generator"].startswith("python -m scenarios.airspace.generate --seed 5 ")
    rect = bounding_rectangle(doc)
    assert len(rect["features"][0]["geometry"]["coordinates"][0]) == 5 and len(rect["features"]) == 2


def test_generator_refuses_an_impossible_park():
    with pytest.raises(ValueError, match="placed only"):
        generate_park(radius_m=300.0, n_vertices=200, n_buildings=500, meadow_radius_m=50.0)


def test_shipped_city_park_is_the_generators_output_and_loads(tmp_path):
    shipped = json.loads((AIRSPACE / "city_park.geojson").read_text())
    gen = shipped["properties"]["generator"]
    assert gen.startswith("python -m scenarios.airspace.generate ")
    assert shipped == generate_park(generator=gen)  # the defaults; deterministic
    _check_park(shipped, 10_000, 500, 30.0)
    imp = load_fence_file(AIRSPACE / "city_park.geojson")
    f = imp.fence
    assert len(f.keep_in) >= 10_000 and len(f.keep_out_polygons) >= 500 and imp.warnings == []
    assert f.ceiling_m == 120 and imp.ceiling_source == "file" and f.recovery_point == (-35.3632, 149.1652)
    rect = load_fence_file(AIRSPACE / "rectangle.geojson").fence
    assert len(rect.keep_in) == 4 and rect.keep_out_polygons == () and rect.recovery_point == f.recovery_point
    assert json.loads((AIRSPACE / "rectangle.geojson").read_text()) == bounding_rectangle(
        shipped, generator=f"{gen} --rectangle scenarios/airspace/rectangle.geojson"
    )
    # write_geojson writes what it is given
    assert json.loads(write_geojson(shipped, tmp_path / "p.geojson").read_text()) == shipped


def test_generator_cli(tmp_path):
    out = tmp_path / "park.geojson"
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "scenarios.airspace.generate",
            "--seed",
            "3",
            "--radius-m",
            "400",
            "--vertices",
            "500",
            "--buildings",
            "20",
            "--meadow-radius-m",
            "60",
            "--avenue-width-m",
            "40",
            "-o",
            str(out),
            "--rectangle",
            str(tmp_path / "rect.geojson"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert res.returncode == 0, res.stderr
    doc = json.loads(out.read_text())
    assert len(doc["features"]) == 22 and "--seed 3 " in doc["properties"]["generator"]
    assert load_fence_file(out).fence.keep_out_polygons and load_fence_file(tmp_path / "rect.geojson").fence


# =========================================================================== scenarios referencing a fence file
SCENARIO = """
aircraft: F450RD
duration_s: 10
start: {{lat_deg: {lat}, lon_deg: {lon}, ground_alt_m: 400}}
mission:
  items: [{{type: takeoff, agl_m: 5}}, {{type: land}}]
geofence:
  fence: {fence}
"""


def scenario_text(fence: str, lat=47.39775, lon=8.54525) -> str:
    return SCENARIO.format(fence=fence, lat=lat, lon=lon)


@pytest.fixture
def site(tmp_path):
    """A scenario in site/flights/ referencing ../fences/park.geojson (the working directory is elsewhere)."""
    (tmp_path / "site" / "fences").mkdir(parents=True)
    (tmp_path / "site" / "flights").mkdir()
    write(tmp_path / "site" / "fences", collection(keep_in(holes=[INNER_LL]), ceiling_m=50), "park.geojson")
    return tmp_path / "site"


def test_scenario_fence_file_is_relative_to_the_scenario(site):
    assert Path.cwd() != site / "flights"
    path = write(site / "flights", scenario_text("{file: ../fences/park.geojson}"), "s.yaml")
    sc = load_scenario(path)
    assert sc.geofence.fence.keep_in == tuple(SQUARE_LL) and sc.geofence.fence.keep_out_polygons == (tuple(INNER_LL),)
    assert (
        sc.geofence.fence.ceiling_m == 50
        and Path(sc.geofence.fence_file).resolve() == (site / "fences" / "park.geojson").resolve()
    )
    doc = yaml.safe_load(path.read_text())
    # parse_scenario finds it too: from source, from base_dir, or from a `where` naming the file (batches)
    assert parse_scenario(doc, str(path)).geofence.fence == sc.geofence.fence
    assert parse_scenario(doc, "label", base_dir=path.parent).geofence.fence == sc.geofence.fence
    assert parse_scenario(doc, "label", source=path).geofence.fence == sc.geofence.fence


def test_scenario_inline_keys_override_the_file(site):
    gap = [[47.3976, 8.5451], [47.3976, 8.5454], [47.3978, 8.5454], [47.3978, 8.5451]]
    text = scenario_text(
        f"{{file: ../fences/park.geojson, ceiling_m: 40, floor_m: 3, floor_gaps: [{json.dumps(gap)}], "
        f"recovery_point: [47.3988, 8.5470], altitude_reference: agl}}"
    )
    sc = load_scenario(write(site / "flights", text, "s.yaml"))
    f = sc.geofence.fence
    assert (f.ceiling_m, f.floor_m, f.recovery_point) == (40, 3, (47.3988, 8.5470))
    assert f.floor_gaps == (tuple(map(tuple, gap)),)


@pytest.mark.parametrize(
    "fence, expect",
    [
        (
            "{file: ../fences/nope.geojson}",
            "s.yaml: geofence.fence.file: no such file '../fences/nope.geojson' (relative to ",
        ),
        ("{file: ../fences}", "s.yaml: geofence.fence.file: '../fences' is not a file (relative to "),
        ("{file: 42}", "s.yaml: geofence.fence.file: must be a path to a fence file, got 42"),
        (
            "{file: ../fences/park.geojson, keep_in: [[1, 2]]}",
            "s.yaml: geofence.fence: unknown key(s) 'keep_in' with a fence file",
        ),
        (
            "{file: ../fences/park.geojson, ceiling_m: high}",
            "s.yaml: geofence.fence.ceiling_m: expected a number, got a string 'high'",
        ),
        (
            "{file: ../fences/park.geojson, recovery_point: [47.39825, 8.54575]}",
            "s.yaml: geofence.fence.recovery_point: not inside the allowed area",
        ),
        ("{file: ../fences/bad.geojson}", "s.yaml: geofence.fence.file: "),
        (
            "{file: ../fences/no_ceiling.plan}",
            "s.yaml: geofence.fence.ceiling_m: required: the fence file '../fences/no_ceiling.plan' gives no ceiling",
        ),
    ],
)
def test_scenario_fence_file_errors_name_the_scenario_and_field(site, fence, expect):
    write(site / "fences", collection(keep_in(), keep_out(SELF_X, name="bow tie")), "bad.geojson")
    plan = {"fileType": "Plan", "geoFence": {"polygons": [{"inclusion": True, "polygon": [list(v) for v in SQUARE_LL]}]}}
    write(site / "fences", plan, "no_ceiling.plan")
    path = write(site / "flights", scenario_text(fence), "s.yaml")
    with pytest.raises(ConfigError) as ei:
        load_scenario(path)
    msg = str(ei.value)
    assert "\n" not in msg and msg.startswith(str(path)) and expect in msg, msg
    if "bad.geojson" in fence:
        assert "bad.geojson: features[1] (name 'bow tie'): self-intersecting" in msg


def test_any_fence_format_can_be_referenced(site):
    plan = {"fileType": "Plan", "geoFence": {"polygons": [{"inclusion": True, "polygon": [list(v) for v in SQUARE_LL]}]}}
    write(site / "fences", plan, "f.plan")
    sc = load_scenario(write(site / "flights", scenario_text("{file: ../fences/f.plan, ceiling_m: 30}"), "s.yaml"))
    assert sc.geofence.fence.keep_in == tuple(SQUARE_LL) and sc.geofence.fence.ceiling_m == 30


def test_batch_hash_covers_the_referenced_fence_file(site):
    from scenarios.app.batch import plan

    path = write(site / "flights", scenario_text("{file: ../fences/park.geojson}"), "s.yaml")
    fence = site / "fences" / "park.geojson"
    h1 = plan([path])[0].scenario_hash
    assert plan([path])[0].scenario_hash == h1
    fence.write_text(json.dumps(collection(keep_in(holes=[OTHER_LL]), ceiling_m=50)))  # the scenario file is unchanged
    h2 = plan([path])[0].scenario_hash
    assert h2 != h1
    fence.unlink()
    assert plan([path])[0].scenario_hash not in (h1, h2)
    # a scenario without a fence file keeps the plain document hash
    from scenarios.definition.sweep import expand

    inline = write(
        site / "flights", scenario_text(json.dumps({"keep_in": [list(v) for v in SQUARE_LL], "ceiling_m": 50})), "i.yaml"
    )
    assert plan([inline])[0].scenario_hash == expand(yaml.safe_load(inline.read_text()), str(inline), "i")[0].scenario_hash


SHIPPED = sorted(AIRSPACE.glob("airspace_*.yaml"))


def test_shipped_airspace_scenarios_validate():
    """Loaded and validated only (not flown): the CLI's validate accepts all four."""
    assert [p.name for p in SHIPPED] == [
        "airspace_large_fence_fixedwing_wind.yaml",
        "airspace_large_fence_multicopter_wind.yaml",
        "airspace_rectangle_fence_fixedwing_wind.yaml",
        "airspace_rectangle_fence_multicopter_wind.yaml",
    ]
    res = subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "validate", *map(str, SHIPPED)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd="/",
    )
    assert res.returncode == 0, res.stderr
    assert res.stdout.count("ok: ") == 4 and not res.stderr
    large = load_scenario(AIRSPACE / "airspace_large_fence_multicopter_wind.yaml")
    twin = load_scenario(AIRSPACE / "airspace_rectangle_fence_multicopter_wind.yaml")
    assert large.aircraft == "F450RD" and len(large.geofence.fence.keep_in) >= 10_000
    assert len(large.geofence.fence.keep_out_polygons) >= 500 and large.wind.turbulence is not None
    assert len(twin.geofence.fence.keep_in) == 4 and twin.mission == large.mission and twin.wind == large.wind
    fw = load_scenario(AIRSPACE / "airspace_large_fence_fixedwing_wind.yaml")
    fw_twin = load_scenario(AIRSPACE / "airspace_rectangle_fence_fixedwing_wind.yaml")
    assert fw.aircraft == "Tern" and fw.mission == fw_twin.mission and fw.pilot.kind is PilotKind.MISSION


# =========================================================================== the CLI
def test_cli_import_fence_geojson(tmp_path):
    p = write(
        tmp_path,
        collection(keep_in(holes=[INNER_LL]), feature({"restriction": "PROHIBITED"}, "Polygon", [ring(OTHER_LL)]), ceiling_m=55),
    )
    res = subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "import-fence", str(p)], capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 0, res.stderr
    block = yaml.safe_load(res.stdout)["geofence"]["fence"]
    assert block["keep_in"] == [list(v) for v in SQUARE_LL]  # back in the scenario's [lat, lon] order
    assert block["keep_out_polygons"] == [[list(v) for v in INNER_LL], [list(v) for v in OTHER_LL]]
    assert block["ceiling_m"] == 55 and res.stderr == ""
    res = subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "import-fence", str(p), "--ceiling", "30"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert yaml.safe_load(res.stdout)["geofence"]["fence"]["ceiling_m"] == 30
    bad = write(tmp_path, collection(keep_in(), feature({}, "Polygon", [ring(INNER_LL)])), "bad.geojson")
    res = subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "import-fence", str(bad)], capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 2 and res.stderr.strip().splitlines() == [
        f"error: {bad}: features[1]: no role: give properties.geofence (keep_in, keep_out, return_point, rally) "
        f"or an ED-269 properties.restriction"
    ]


def test_run_and_batch_give_a_scenario_with_a_fence_file_the_same_hash(tmp_path):
    """`geofence-testbed run` (the runner's hash) and `batch` both cover the referenced fence file's bytes."""
    import shutil

    from scenarios.app.batch import plan
    from scenarios.definition.schema import load_scenario
    from scenarios.flight.runner import hash_of_source

    src = Path(__file__).parents[1] / "scenarios" / "airspace"
    shutil.copy(src / "airspace_rectangle_fence_multicopter_wind.yaml", tmp_path / "s.yaml")
    shutil.copy(src / "rectangle.geojson", tmp_path / "rectangle.geojson")
    h_run = hash_of_source(load_scenario(tmp_path / "s.yaml"))
    assert h_run is not None and h_run == plan([tmp_path / "s.yaml"])[0].scenario_hash
    doc = json.loads((tmp_path / "rectangle.geojson").read_text())
    doc.setdefault("properties", {})["note"] = "edited"
    (tmp_path / "rectangle.geojson").write_text(json.dumps(doc))
    assert hash_of_source(load_scenario(tmp_path / "s.yaml")) != h_run
