"""Fence/rally file import: every real-world file in ../shared/realworld, malformed inputs, and round trips."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from analysis.formats.fence_files import (
    DEFAULT_CEILING_M,
    ImportOptions,
    circle_to_polygon,
    detect_format,
    fence_to_yaml_block,
    load_fence_file,
    load_rally_file,
)
from geofence.geometry.fence import Fence, FenceError, parse_fence
from geofence.geometry.geodesy import LocalFrame, geodesic_destination, geodesic_distance_m
from geofence.geometry.polygon import signed_area

REALWORLD = Path(__file__).parents[2] / "shared" / "realworld"


def real(name: str) -> Path:
    p = REALWORLD / name
    if not p.is_file():
        pytest.skip(f"real-world file {p} is not available")
    return p


def _extent_m(poly) -> tuple[float, float]:
    """(east-west, north-south) extent of a lat/lon polygon in m."""
    lats = [p[0] for p in poly]
    lons = [p[1] for p in poly]
    mid = 0.5 * (min(lats) + max(lats))
    return (geodesic_distance_m(mid, min(lons), mid, max(lons)), geodesic_distance_m(min(lats), lons[0], max(lats), lons[0]))


def _area_m2(poly) -> float:
    fr = LocalFrame(poly[0][0], poly[0][1], 0.0)
    return abs(signed_area([fr.to_enu(lat, lon, 0.0)[:2] for lat, lon in poly]))


def _is_convex(poly) -> bool:
    fr = LocalFrame(poly[0][0], poly[0][1], 0.0)
    v = np.array([fr.to_enu(lat, lon, 0.0)[:2] for lat, lon in poly])
    d1 = np.roll(v, -1, axis=0) - v
    d2 = np.roll(d1, -1, axis=0)
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    return bool((cross >= 0).all() or (cross <= 0).all())


# =========================================================================== real files
def test_qgc_home_base_plan():
    imp = load_fence_file(real("qgc_ce_geofence_home_base.plan"))
    assert imp.source_format == "qgc_plan"
    assert len(imp.keep_in_polygons) == 1 and len(imp.keep_out_polygons) == 1
    assert len(imp.fence.keep_in) == 4 and len(imp.fence.keep_out_polygons[0]) == 4
    assert not imp.keep_out_circles and not imp.inclusion_circles and not imp.rally_points
    assert _area_m2(imp.fence.keep_in) == pytest.approx(933, rel=0.03)
    assert _area_m2(imp.fence.keep_out_polygons[0]) == pytest.approx(466, rel=0.03)
    assert imp.home == pytest.approx((38.7508, -77.4972, 30), abs=1e-4)
    assert imp.return_point is None and imp.fence.recovery_point is None
    assert imp.fence.ceiling_m == DEFAULT_CEILING_M and imp.fence.altitude_reference == "agl"
    assert any("default ceiling" in w for w in imp.warnings)


def test_qgc_rd_134_plan_shared_edges_accepted():
    imp = load_fence_file(real("qgc_ce_geofence_rd_134.plan"), ImportOptions(ceiling_m=50))
    assert imp.fence.ceiling_m == 50 and not any("ceiling" in w for w in imp.warnings)
    assert len(imp.fence.keep_in) == 4 and len(imp.fence.keep_out_polygons) == 1
    ew, ns = _extent_m(imp.fence.keep_in)
    assert ew == pytest.approx(31, abs=2) and ns == pytest.approx(31, abs=2)
    # the exclusion is the west half: the fence leaves the east half allowed
    local = imp.fence.to_local()
    e, n, r = local.inradius()
    assert e > 0 and r > 5
    assert imp.rally_points == ()


def test_px4_plan_with_exclusion_circle():
    imp = load_fence_file(real("px4_multicopter_mission_geofence_avoid.plan"))
    f = imp.fence
    assert len(f.keep_in) == 4 and len(f.keep_out_polygons) == 1 and len(f.keep_out_polygons[0]) == 4
    assert len(f.keep_out_circles) == 1
    c = f.keep_out_circles[0]
    assert c.radius_m == pytest.approx(111.05, abs=0.01)
    assert (c.center_lat_deg, c.center_lon_deg) == pytest.approx((47.39531, 8.54287), abs=1e-5)
    ew, ns = _extent_m(f.keep_in)
    assert ew == pytest.approx(1276, rel=0.03) and ns == pytest.approx(806, rel=0.03)
    ew, ns = _extent_m(f.keep_out_polygons[0])
    assert ew == pytest.approx(558, rel=0.03) and ns == pytest.approx(260, rel=0.03)
    assert imp.home == pytest.approx((47.3977444, 8.5455918, 489.338))
    assert imp.rally_points == ()


def test_pymavlink_fence_110_concave_with_circles():
    imp = load_fence_file(real("pymavlink_fence-110.txt"))
    assert imp.source_format == "qgc_wpl_110"
    f = imp.fence
    assert len(f.keep_in) == 8 and not _is_convex(f.keep_in)
    assert f.keep_in[0] == (40.071766, -105.230202)
    ew, ns = _extent_m(f.keep_in)
    assert ew == pytest.approx(343, rel=0.03) and ns == pytest.approx(185, rel=0.03)
    assert [c.radius_m for c in f.keep_out_circles] == [20.0, 20.0]
    assert (f.keep_out_circles[0].center_lat_deg, f.keep_out_circles[0].center_lon_deg) == (40.071609, -105.228172)
    assert not f.keep_out_polygons and imp.return_point is None


def test_pymavlink_rally_110():
    path = real("pymavlink_rally-110.txt")
    with pytest.raises(FenceError, match="only rally points"):
        load_fence_file(path)
    pts = load_rally_file(path)
    assert len(pts) == 2
    assert (pts[0].lat_deg, pts[0].lon_deg, pts[0].alt_m) == (40.071766, -105.230202, 0.0)
    assert (pts[1].lat_deg, pts[1].lon_deg) == (40.071014, -105.230247)
    assert pts[0].alt_reference == "amsl"  # frame 0 = MAV_FRAME_GLOBAL


def test_dalby_old_style_fence():
    imp = load_fence_file(real("ardupilot_Dalby-OBC2016-fence.txt"))
    assert imp.source_format == "mavproxy_fence"
    f = imp.fence
    assert len(f.keep_in) == 16  # 18 lines: return point + 16 vertices + closing duplicate (dropped)
    assert f.keep_in[0] == (-27.274988, 151.340408) and f.keep_in[-1] == (-27.284918, 151.338394)
    assert imp.return_point == (-27.302433, 151.332031)
    assert f.recovery_point == (-27.302433, 151.332031)
    assert not _is_convex(f.keep_in)
    ew, ns = _extent_m(f.keep_in)
    assert 8000 < ew < 11000 and 6000 < ns < 9000
    assert not any("not closed" in w for w in imp.warnings)


def test_cmac_old_style_fence_and_rally():
    imp = load_fence_file(real("mavproxy_cmac-foamy-fence.txt"), ImportOptions(rally_path=real("mavproxy_cmac-foamy-rally.txt")))
    f = imp.fence
    assert len(f.keep_in) == 4
    assert imp.return_point == (-35.363720, 149.163651) and f.recovery_point == imp.return_point
    ew, ns = _extent_m(f.keep_in)
    assert ew == pytest.approx(554, rel=0.03) and ns == pytest.approx(1094, rel=0.03)
    (rp,) = imp.rally_points
    assert (rp.lat_deg, rp.lon_deg) == (-35.363160, 149.164101)
    assert rp.alt_m == 60.0 and rp.break_alt_m == 40.0 and rp.land_dir_deg == 0.0 and rp.flags == 0
    assert f.to_local().lateral_margin_m(*f.to_local().horizontal_en(rp.lat_deg, rp.lon_deg)) > 0


def test_cmac_rally_file_alone():
    path = real("mavproxy_cmac-foamy-rally.txt")
    assert detect_format(path) == "mavproxy_rally"
    (rp,) = load_rally_file(path)
    assert (rp.alt_m, rp.break_alt_m) == (60.0, 40.0)
    with pytest.raises(FenceError, match="only rally points"):
        load_fence_file(path)


def test_springvalley_wpl_with_return_point():
    imp = load_fence_file(real("mavproxy_springvalleybottom-foamy-fence.txt"))
    assert imp.source_format == "qgc_wpl_110"
    assert len(imp.fence.keep_in) == 4
    assert imp.return_point == (-35.281086, 149.007370)
    assert imp.fence.recovery_point == imp.return_point
    ew, ns = _extent_m(imp.fence.keep_in)
    assert ew == pytest.approx(521, rel=0.03) and ns == pytest.approx(452, rel=0.03)


REAL_FENCES = [
    "qgc_ce_geofence_home_base.plan",
    "qgc_ce_geofence_rd_134.plan",
    "px4_multicopter_mission_geofence_avoid.plan",
    "pymavlink_fence-110.txt",
    "ardupilot_Dalby-OBC2016-fence.txt",
    "mavproxy_cmac-foamy-fence.txt",
    "mavproxy_springvalleybottom-foamy-fence.txt",
]


@pytest.mark.parametrize("name", REAL_FENCES)
def test_yaml_block_round_trip(name):
    imp = load_fence_file(real(name))
    block = fence_to_yaml_block(imp)
    text = yaml.safe_dump(block)
    back = parse_fence(yaml.safe_load(text)["geofence"]["fence"])
    assert back == imp.fence


def test_agrees_with_pymavlink_loaders():
    """Our parser and pymavlink's mavwp loaders read the same items (pymavlink needs MAVLINK20, so a subprocess)."""
    files = [
        "pymavlink_fence-110.txt",
        "mavproxy_springvalleybottom-foamy-fence.txt",
        "ardupilot_Dalby-OBC2016-fence.txt",
        "mavproxy_cmac-foamy-fence.txt",
    ]
    paths = [real(f) for f in files]
    rally_paths = [real("pymavlink_rally-110.txt"), real("mavproxy_cmac-foamy-rally.txt")]
    code = (
        "import json, sys\nfrom pymavlink import mavwp\nout = {}\n"
        "for f in sys.argv[1:5]:\n"
        "    w = mavwp.MissionItemProtocol_Fence(); w.load(f)\n"
        "    out[f] = [(it.command, float(it.param1), it.x, it.y) for it in w.wpoints]\n"
        "for f in sys.argv[5:]:\n"
        "    w = mavwp.MissionItemProtocol_Rally(); w.load(f)\n"
        "    out[f] = [(it.x, it.y) for it in w.wpoints]\n"
        "print(json.dumps(out))\n"
    )
    env = dict(os.environ, MAVLINK20="1")
    res = subprocess.run(
        [sys.executable, "-c", code, *map(str, paths + rally_paths)], env=env, capture_output=True, text=True, check=True
    )
    theirs = json.loads(res.stdout)
    for p in paths:
        imp = load_fence_file(p)
        items = theirs[str(p)]
        scale = [1e-7 if isinstance(it[2], int) else 1.0 for it in items]  # old format: int 1e7
        ret = [(it[2] * s, it[3] * s) for it, s in zip(items, scale) if it[0] == 5000]
        inc = [(it[2] * s, it[3] * s) for it, s in zip(items, scale) if it[0] == 5001]
        circ = [(it[2] * s, it[3] * s, it[1]) for it, s in zip(items, scale) if it[0] == 5004]
        assert np.allclose(inc, imp.fence.keep_in, atol=1.5e-7, rtol=0)
        if ret:
            assert np.allclose(ret[0], imp.return_point[:2], atol=1.5e-7, rtol=0)
        assert (
            np.allclose(
                circ, [(c.center_lat_deg, c.center_lon_deg, c.radius_m) for c in imp.keep_out_circles], atol=1.5e-7, rtol=0
            )
            if circ
            else not imp.keep_out_circles
        )
    for p in rally_paths:
        ours = [(r.lat_deg, r.lon_deg) for r in load_rally_file(p)]
        t = [(x * 1e-7, y * 1e-7) if isinstance(x, int) else (x, y) for x, y in theirs[str(p)]]
        assert np.allclose(t, ours, atol=1.5e-7, rtol=0)


# =========================================================================== hand-written inputs
SQUARE = [(47.3975, 8.5450), (47.3990, 8.5450), (47.3990, 8.5475), (47.3975, 8.5475)]


def _wpl(items) -> str:
    """QGC WPL 110 text from (cmd, p1, lat, lon[, alt[, frame]]) tuples."""
    lines = ["QGC WPL 110"]
    for i, it in enumerate(items):
        cmd, p1, lat, lon = it[:4]
        alt = it[4] if len(it) > 4 else 0.0
        frame = it[5] if len(it) > 5 else 0
        lines.append(f"{i}\t0\t{frame}\t{cmd}\t{p1:.6f}\t0.000000\t0.000000\t0.000000\t{lat!r}\t{lon!r}\t{alt:.6f}\t1")
    return "\n".join(lines) + "\n"


def _plan(polygons=(), circles=(), rally=(), home=None, version=2) -> str:
    doc = {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "QGroundControl",
        "geoFence": {
            "version": version,
            "polygons": [{"inclusion": inc, "polygon": [list(v) for v in poly], "version": 1} for inc, poly in polygons],
            "circles": [{"inclusion": inc, "circle": {"center": list(c), "radius": r}, "version": 1} for inc, c, r in circles],
        },
        "rallyPoints": {"version": 2, "points": [list(p) for p in rally]},
        "mission": {"version": 2, "items": [], "plannedHomePosition": list(home) if home else [0, 0, 0]},
    }
    return json.dumps(doc, indent=4)


def _old(return_point, verts, close=True) -> str:
    pts = [return_point, *verts] + ([verts[0]] if close else [])
    return "".join(f"{lat!r}\t{lon!r}\n" for lat, lon in pts)


def _write(tmp_path: Path, name: str, text: str | bytes) -> Path:
    p = tmp_path / name
    (p.write_bytes if isinstance(text, bytes) else p.write_text)(text)
    return p


def test_plan_small(tmp_path):
    inner = [(47.3980, 8.5455), (47.3985, 8.5455), (47.3985, 8.5460)]
    p = _write(
        tmp_path,
        "a.plan",
        _plan(
            polygons=[(True, SQUARE), (False, inner)],
            circles=[(False, (47.3985, 8.5470), 20.0)],
            rally=[(47.3982, 8.5462, 30.0)],
            home=(47.3976, 8.5451, 488.0),
        ),
    )
    imp = load_fence_file(p, ImportOptions(ceiling_m=80, floor_m=5))
    assert imp.fence.keep_in == tuple(SQUARE) and imp.fence.keep_out_polygons == (tuple(inner),)
    assert imp.fence.floor_m == 5 and imp.fence.ceiling_m == 80
    assert imp.keep_out_circles[0].radius_m == 20.0
    assert imp.rally_points[0].alt_m == 30.0 and imp.home == (47.3976, 8.5451, 488.0)


def test_plan_several_inclusions_are_refused_unless_one_is_chosen(tmp_path):
    other = [(47.3976, 8.5451), (47.3979, 8.5451), (47.3979, 8.5454)]
    p = _write(tmp_path, "b.plan", _plan(polygons=[(True, SQUARE), (True, other)], circles=[(True, (47.398, 8.546), 50.0)]))
    with pytest.raises(
        FenceError, match=r"b\.plan: inclusion polygons: the file has 3 inclusion areas .*--inclusion-polygon N \(0 to 2"
    ):
        load_fence_file(p)
    for index, expected in ((0, tuple(SQUARE)), (1, tuple(other))):
        imp = load_fence_file(p, ImportOptions(inclusion_polygon=index))
        assert imp.fence.keep_in == expected and len(imp.keep_in_polygons) == 2
        assert any(f"inclusion area {index} of 3 used" in w for w in imp.warnings)
    circle = load_fence_file(p, ImportOptions(inclusion_polygon=2)).fence.keep_in
    assert all(geodesic_distance_m(47.398, 8.546, lat, lon) == pytest.approx(50.0, abs=1e-6) for lat, lon in circle)
    with pytest.raises(FenceError, match="no such inclusion area"):
        load_fence_file(p, ImportOptions(inclusion_polygon=3))


def test_inclusion_circle_becomes_polygon(tmp_path):
    p = _write(tmp_path, "c.plan", _plan(circles=[(True, (47.398, 8.546), 300.0), (False, (47.398, 8.546), 20.0)]))
    imp = load_fence_file(p)
    verts = imp.fence.keep_in
    n = len(verts)
    assert 16 <= n <= 720 and 300.0 * (1 - math.cos(math.pi / n)) <= 0.1
    assert any(f"inscribed {n}-gon" in w for w in imp.warnings)
    assert all(geodesic_distance_m(47.398, 8.546, lat, lon) == pytest.approx(300.0, abs=1e-6) for lat, lon in verts)
    assert len(imp.fence.keep_out_circles) == 1
    # WPL 5003 gives the same
    q = _write(tmp_path, "c.txt", _wpl([(5003, 300.0, 47.398, 8.546)]))
    assert load_fence_file(q).fence.keep_in == verts


def test_circle_to_polygon_bounds():
    for r in (5.0, 100.0, 1000.0, 1e5):
        verts, n, sag = circle_to_polygon(10.0, 20.0, r)
        assert len(verts) == n and 16 <= n <= 720
        assert sag == pytest.approx(r * (1 - math.cos(math.pi / n)))
        assert sag <= 0.1 or n == 720


def test_keep_out_outside_keep_in_is_dropped(tmp_path):
    far = [(47.50, 8.60), (47.51, 8.60), (47.51, 8.61)]
    p = _write(tmp_path, "d.plan", _plan(polygons=[(True, SQUARE), (False, far)], circles=[(False, (47.5, 8.7), 30.0)]))
    imp = load_fence_file(p)
    assert imp.fence.keep_out_polygons == () and imp.fence.keep_out_circles == ()
    assert len(imp.keep_out_polygons) == 1 and len(imp.keep_out_circles) == 1
    assert sum("dropped" in w for w in imp.warnings) == 2


def test_return_point_outside_is_not_recovery(tmp_path):
    p = _write(tmp_path, "e.txt", _wpl([(5000, 0, 47.40, 8.60)] + [(5001, 4, lat, lon) for lat, lon in SQUARE]))
    imp = load_fence_file(p)
    assert imp.return_point == (47.40, 8.60) and imp.fence.recovery_point is None
    assert any("return point" in w for w in imp.warnings)


def test_wpl_two_polygons_and_exclusion(tmp_path):
    inner = [(47.3980, 8.5455), (47.3985, 8.5455), (47.3985, 8.5460)]
    items = [(5001, 4, *v) for v in SQUARE] + [(5001, 3, *v) for v in inner] + [(5002, 3, *v) for v in inner]
    items += [(16, 0, 47.398, 8.546, 50.0), (5100, 0, 47.3982, 8.5462, 40.0, 3)]
    with pytest.raises(FenceError, match="2 inclusion areas"):
        load_fence_file(_write(tmp_path, "f.txt", _wpl(items)))
    imp = load_fence_file(tmp_path / "f.txt", ImportOptions(inclusion_polygon=0))
    assert imp.keep_in_polygons == (tuple(SQUARE), tuple(inner))
    assert imp.fence.keep_out_polygons == (tuple(inner),)
    assert imp.rally_points[0].alt_m == 40.0 and imp.rally_points[0].alt_reference == "relative"
    assert any("cmd 16" in w for w in imp.warnings)


def test_old_style_unclosed_warns(tmp_path):
    p = _write(tmp_path, "g.txt", _old((47.398, 8.546), SQUARE, close=False))
    imp = load_fence_file(p)
    assert imp.fence.keep_in == tuple(SQUARE)
    assert any("not closed" in w for w in imp.warnings)


def test_comments_blank_lines_bom(tmp_path):
    text = "\ufeff# my fence\n\n" + _old((47.398, 8.546), SQUARE).replace("\n", "\r\n")
    imp = load_fence_file(_write(tmp_path, "h.txt", text))
    assert imp.fence.keep_in == tuple(SQUARE)


MALFORMED = [
    ("bad.plan", '{"geoFence": {"polygons": [', "not JSON"),
    ("bad.plan", "[1, 2]", "not a QGroundControl plan"),
    ("bad.plan", _plan(), "no fence items"),
    ("bad.plan", _plan(polygons=[(True, SQUARE[:2])]), "at least 3 vertices"),
    (
        "bad.plan",
        _plan(polygons=[(True, SQUARE[:3] + [SQUARE[0]])[:3]]).replace('"inclusion": true', '"inclusion": 1'),
        "true or false",
    ),
    ("bad.plan", _plan(polygons=[(False, SQUARE)]), "no inclusion"),
    ("bad.plan", _plan(polygons=[(True, SQUARE)], circles=[(False, (47.398, 8.546), -3.0)]), "radius"),
    (
        "bad.plan",
        _plan(polygons=[(True, [(47.3975, 8.5450), (47.3990, 8.5475), (47.3990, 8.5450), (47.3975, 8.5475)])]),
        "self-intersecting",
    ),
    ("bad.plan", _plan(polygons=[(True, [(97.0, 8.5), (47.39, 8.5), (47.39, 8.6)])]), "latitude"),
    ("bad.txt", _wpl([(5001, 4, *v) for v in SQUARE[:3]]), "vertex count mismatch"),
    ("bad.txt", _wpl([(5001, 4, *v) for v in SQUARE[:3]] + [(5004, 20, 47.398, 8.546)]), "vertex count mismatch"),
    ("bad.txt", _wpl([(5001, 4, *v) for v in SQUARE[:2]] + [(5001, 5, *v) for v in SQUARE[2:]]), "vertex count mismatch"),
    ("bad.txt", _wpl([(5001, 2, *v) for v in SQUARE[:2]]), "integer >= 3"),
    ("bad.txt", _wpl([(5003, 0, 47.398, 8.546)]), "radius"),
    ("bad.txt", _wpl([(5001, 4, *v) for v in SQUARE]).replace("\t1\n", "\n", 1), "expected 12 fields"),
    ("bad.txt", _wpl([(5001, 4, *v) for v in SQUARE]).replace("47.399", "4x.399", 1), "not a number"),
    ("bad.txt", _wpl([(5001, 3, 0.0, 0.0), (5001, 3, 1.0, 1.0), (5001, 3, 1.0, 0.0)]), "unset"),
    ("bad.txt", _wpl([(16, 0, 47.398, 8.546, 50.0)]), "no fence items"),
    ("bad.txt", "QGC WPL 100\n0\t1\t0\t16\t0\t0\t0\t0\t47.3\t8.5\t0\t1\n", "unsupported"),
    ("bad.txt", "QGC WPL 110\n", "no fence items"),
    ("bad.txt", _old((47.398, 8.546), SQUARE[:2]), "at least 3 vertices"),
    ("bad.txt", "47.398 8.546\n47.3975 8.5450 12\n", "expected 'lat lon'"),
    ("bad.txt", "RALLY 1 2 3\n", "6 values"),
    ("bad.txt", "hello world\n", "unrecognised"),
    ("bad.txt", "", "empty"),
    ("bad.txt", b"\xa3\x95\x80\x80\xff\xfe", "not UTF-8"),
]


@pytest.mark.parametrize("fname,text,expect", MALFORMED)
def test_malformed_one_line_error_naming_file(tmp_path, fname, text, expect):
    p = _write(tmp_path, fname, text)
    with pytest.raises(FenceError) as ei:
        load_fence_file(p)
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.startswith(str(p) + ": ")
    assert expect in msg


def test_missing_file(tmp_path):
    with pytest.raises(FenceError, match="file not found"):
        load_fence_file(tmp_path / "nope.plan")


def test_bad_rally_file_errors(tmp_path):
    p = _write(tmp_path, "r.txt", "RALLY -35.36 149.16 60 40 0 0.5\n")
    with pytest.raises(FenceError, match=r"r\.txt: line 1: flags"):
        load_rally_file(p)


# =========================================================================== round trip (hypothesis)
@st.composite
def star_polygons(draw):
    """A random simple (star-shaped about its centre) polygon, in lat/lon, and its centre."""
    lat0 = draw(st.floats(-75.0, 75.0))
    lon0 = draw(st.floats(-175.0, 175.0))
    assume(abs(lat0) > 1e-6 or abs(lon0) > 1e-6)  # (0, 0) means "unset" in these formats
    n = draw(st.integers(3, 24))
    jitter = draw(st.lists(st.floats(0.0, 0.4), min_size=n, max_size=n))
    radii = draw(st.lists(st.floats(30.0, 3000.0), min_size=n, max_size=n))
    az = [(k + j) * 360.0 / n for k, j in enumerate(jitter)]
    verts = [geodesic_destination(lat0, lon0, a, r) for a, r in zip(az, radii)]
    if draw(st.booleans()):
        verts.reverse()
    return verts, (lat0, lon0)


def _fmt(x: float) -> str:
    return f"{x:.9f}"


WRITERS = {
    "plan": lambda verts, rp: _plan(polygons=[(True, verts)]).replace(
        '"polygons"', f'"breachReturn": [{rp[0]!r}, {rp[1]!r}, 0], "polygons"'
    ),
    "wpl": lambda verts, rp: (
        "QGC WPL 110\n"
        + "".join(
            f"{i}\t0\t0\t{cmd}\t{p1}\t0\t0\t0\t{_fmt(lat)}\t{_fmt(lon)}\t0\t1\n"
            for i, (cmd, p1, lat, lon) in enumerate([(5000, 0, *rp)] + [(5001, len(verts), *v) for v in verts])
        )
    ),
    "mavproxy": lambda verts, rp: "".join(f"{_fmt(lat)}\t{_fmt(lon)}\n" for lat, lon in [rp, *verts, verts[0]]),
}


@pytest.mark.parametrize("fmt", sorted(WRITERS))
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=star_polygons())
def test_round_trip(tmp_path, fmt, data):
    verts, centre = data
    p = tmp_path / f"rt_{fmt}.txt"
    p.write_text(WRITERS[fmt](verts, centre))
    imp = load_fence_file(p)
    assert imp.source_format == {"plan": "qgc_plan", "wpl": "qgc_wpl_110", "mavproxy": "mavproxy_fence"}[fmt]
    got = np.array(imp.fence.keep_in)
    assert got.shape == (len(verts), 2)
    assert np.abs(got - np.array(verts)).max() <= 1e-7
    assert np.abs(np.array(imp.return_point[:2]) - np.array(centre)).max() <= 1e-7
    assert imp.fence.recovery_point is not None
    assert parse_fence(fence_to_yaml_block(imp)["geofence"]["fence"]) == imp.fence
    assert isinstance(imp.fence, Fence)
