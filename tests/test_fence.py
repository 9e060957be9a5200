"""Fence model: parser errors, local projection (with its error bound) and margins."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from geographiclib.geodesic import Geodesic

from geofence.geometry.fence import FenceError, KeepOutCircle, parse_fence
from geofence.geometry.geodesy import LocalFrame, geodesic_destination, geodesic_distance_m
from geofence.geometry.local_fence import LocalFence
from geofence.geometry.polygon import segment_dist2

BOX = [[47.3975, 8.5450], [47.3990, 8.5450], [47.3990, 8.5475], [47.3975, 8.5475]]
GOOD = {
    "keep_in": BOX,
    "ceiling_m": 60,
    "floor_m": 5,
    "altitude_reference": "agl",
    "floor_gaps": [[[47.3978, 8.5455], [47.3980, 8.5455], [47.3980, 8.5458]]],
    "keep_out_polygons": [[[47.3985, 8.5452], [47.3987, 8.5452], [47.3987, 8.5455]]],
    "keep_out_circles": [{"center": [47.3985, 8.5470], "radius_m": 20}],
    "recovery_point": [47.3982, 8.5462, 30],
}


def _with(**kw):
    m = copy.deepcopy(GOOD)
    for k, v in kw.items():
        if v is _DEL:
            m.pop(k)
        else:
            m[k] = v
    return m


_DEL = object()


def test_parse_good_fence():
    f = parse_fence(GOOD, "s.yaml")
    assert f.ceiling_m == 60.0 and f.floor_m == 5.0 and f.altitude_reference == "agl"
    assert len(f.keep_in) == 4 and f.keep_in[0] == (47.3975, 8.5450)
    assert f.keep_out_circles == (KeepOutCircle(47.3985, 8.5470, 20.0),)
    assert f.recovery_point == (47.3982, 8.5462, 30.0)
    # hashable and frozen
    hash(f)
    with pytest.raises(AttributeError):
        f.ceiling_m = 1.0  # type: ignore[misc]
    # minimal fence: defaults
    g = parse_fence({"keep_in": BOX, "ceiling_m": 60}, "s.yaml")
    assert g.floor_m is None and g.floor_gaps == () and g.altitude_reference == "agl"
    lat, lon, alt = g.resolved_recovery_point()
    assert alt == 30.0
    assert g.to_local().lateral_margin_m(*g.to_local().horizontal_en(lat, lon)) > 80.0


BAD = [
    (_with(keep_in=BOX[:2]), "keep_in: needs at least 3 vertices, got 2"),
    (_with(keep_in=BOX[:2] + [BOX[0]]), "keep_in: needs at least 3 vertices"),
    (
        _with(keep_in=[BOX[0], BOX[2], BOX[1], BOX[3]]),
        "keep_in: self-intersecting: edge 0 (vertex 0->1) meets edge 2 (vertex 2->3)",
    ),
    (_with(keep_in=[BOX[0], BOX[1], BOX[1], BOX[2]]), "keep_in: vertices 1 and 2 are the same point"),
    (_with(keep_in=[[95.0, 8.5], BOX[1], BOX[2]]), "keep_in[0] latitude: must be <= 90, got 95.0"),
    (_with(keep_in=[BOX[0], [47.39, 181.0], BOX[2]]), "keep_in[1] longitude: must be <= 180, got 181.0"),
    (_with(keep_in=[BOX[0], [float("nan"), 8.5], BOX[2]]), "keep_in[1] latitude: must be a finite number, got nan"),
    (_with(keep_in=[BOX[0], [47.39], BOX[2]]), "keep_in[1]: must be [lat_deg, lon_deg]"),
    (_with(keep_in="47,8"), "keep_in: must be a list"),
    (_with(keep_in=_DEL), "keep_in: required"),
    (_with(ceiling_m=_DEL), "ceiling_m: required"),
    (_with(ceiling_m=5), "ceiling_m: 5 m must be above floor_m 5 m"),
    (_with(ceiling_m=3), "ceiling_m: 3 m must be above floor_m 5 m"),
    (_with(ceiling_m=float("nan")), "ceiling_m: must be a finite number, got nan"),
    (_with(ceiling_m="high"), "ceiling_m: expected a number, got a string 'high'"),
    (_with(ceiling_m=True), "ceiling_m: expected a number, got a boolean True"),
    (
        _with(floor_m=_DEL, floor_gaps=_DEL, ceiling_m=-5, recovery_point=[47.3982, 8.5462]),
        "ceiling_m: -5 m AGL must be above the ground",
    ),
    (_with(altitude_reference="msl"), "altitude_reference: 'msl' is not one of agl, amsl"),
    (_with(colour="red"), "fence.colour: unknown key"),
    (
        _with(floor_gaps=[[[47.3970, 8.5455], [47.3980, 8.5455], [47.3980, 8.5458]]]),
        "floor_gaps[0]: gap is not inside the keep_in area",
    ),
    (_with(floor_gaps=[[[47.3978, 8.5455], [47.3980, 8.5455]]]), "floor_gaps[0]: needs at least 3 vertices, got 2"),
    (
        _with(keep_out_polygons=[[[47.3, 8.5], [47.31, 8.5], [47.31, 8.51]]]),
        "keep_out_polygons[0]: lies entirely outside the keep_in area",
    ),
    (
        _with(keep_out_circles=[{"center": [47.3, 8.5470], "radius_m": 20}]),
        "keep_out_circles[0]: lies entirely outside the keep_in area",
    ),
    (_with(keep_out_circles=[{"center": [47.3985, 8.5470], "radius_m": 0}]), "keep_out_circles[0].radius_m: must be > 0, got 0"),
    (_with(keep_out_circles=[{"center": [47.3985, 8.5470]}]), "keep_out_circles[0].radius_m: required"),
    (
        _with(keep_out_circles=[{"center": [47.3985, 8.5470], "radius_m": 5, "r": 1}]),
        "keep_out_circles[0].r: unknown key (allowed: ceiling_m, center, floor_m, radius_m)",
    ),
    (_with(keep_out_circles=[{"center": [47.3982, 8.5462], "radius_m": 500}]), "keep-outs cover the whole keep_in area"),
    (_with(recovery_point=[47.0, 8.5]), "recovery_point: not inside the allowed area"),
    (_with(recovery_point=[47.3985, 8.5470]), "recovery_point: not inside the allowed area"),
    (_with(recovery_point=[47.3982, 8.5462, 70]), "recovery_point: altitude 70 m is not between the floor and ceiling_m 60 m"),
    (_with(recovery_point=[47.3982]), "recovery_point: must be [lat, lon] or [lat, lon, alt_m]"),
]


@pytest.mark.parametrize("mapping, expected", BAD, ids=[e for _, e in BAD])
def test_parse_errors_are_one_clear_line(mapping, expected):
    with pytest.raises(FenceError) as exc:
        parse_fence(mapping, "scn.yaml")
    msg = str(exc.value)
    assert msg.startswith("scn.yaml: ")
    assert expected in msg
    assert "\n" not in msg
    assert isinstance(exc.value, ValueError)


def test_parse_rejects_non_mapping():
    with pytest.raises(FenceError, match=r"^x: fence: must be a mapping, got list$"):
        parse_fence([1, 2], "x")


def test_orientation_and_closing_vertex_do_not_matter():
    a = parse_fence(_with(recovery_point=_DEL), "s").to_local()
    b = parse_fence(_with(recovery_point=_DEL, keep_in=BOX[::-1] + [BOX[-1]]), "s").to_local(a.frame)
    pts = np.random.default_rng(1).uniform(-150, 150, (500, 2))
    assert np.allclose(a.lateral_margin_array(pts), b.lateral_margin_array(pts), atol=1e-9)


def test_local_margins_known_values():
    f = parse_fence(GOOD, "s")
    lf = f.to_local()
    # half widths of the box from geodesics (the frame is at the box centre)
    half_ns = 0.5 * geodesic_distance_m(47.3975, 8.5450, 47.3990, 8.5450)
    half_ew = 0.5 * geodesic_distance_m(47.39825, 8.5450, 47.39825, 8.5475)
    assert lf.keep_in.signed_distance(0.0, 0.0) == pytest.approx(min(half_ns, half_ew), abs=0.05)
    assert lf.keep_in.signed_distance(0.0, 0.0) == pytest.approx(half_ns, abs=0.05)
    # vertical margins
    assert lf.vertical_margins_m(20.0) == (40.0, 15.0)
    # circle keep-out: margin at its centre is -radius
    ce, cn, r = lf.keep_out_circles[0]
    assert lf.lateral_margin_m(ce, cn) == pytest.approx(-20.0)
    assert lf.lateral_nearest(ce + 25.0, cn)[:4] == (pytest.approx(5.0), "keep_out_circle", 0, -1)
    assert lf.lateral_nearest(ce + 25.0, cn)[4:] == pytest.approx((-1.0, 0.0))
    # keep-out polygon: inside it the margin is negative
    ko = lf.keep_out_polygons[0]
    kx, ky = ko.vertices.mean(axis=0)
    assert lf.lateral_margin_m(kx, ky) < 0 and lf.lateral_nearest(kx, ky)[1] == "keep_out_polygon"
    # 3-D margin
    e, n = lf.recovery_en
    lat_m = lf.lateral_margin_m(e, n)
    assert lf.margin_m(e, n, 30.0) == pytest.approx(min(lat_m, 30.0, 25.0))
    assert lf.margin_m(e, n, 59.0) == pytest.approx(min(lat_m, 1.0))
    assert lf.margin_m(e, n, 61.0) == pytest.approx(-1.0)


def test_floor_gap_margins():
    lf = parse_fence(GOOD, "s").to_local()
    g = lf.floor_gaps[0]
    gx, gy, gr = g.inradius(precision_m=1e-3)
    assert lf.in_floor_gap(gx, gy) and not lf.in_floor_gap(*lf.recovery_en)
    assert lf.landing_allowed(gx, gy) and not lf.landing_allowed(*lf.recovery_en)
    # above the floor, outside the gaps: height above the floor
    e, n = lf.recovery_en
    assert lf.floor_margin_m(e, n, 12.0) == pytest.approx(7.0)
    # below the floor outside the gaps: breached
    assert lf.floor_margin_m(e, n, 2.0) < 0
    # below the floor inside a gap: the lateral room left in the gap
    assert lf.floor_margin_m(gx, gy, 1.0) == pytest.approx(gr)
    assert lf.margin_m(gx, gy, 1.0) == pytest.approx(min(gr, lf.lateral_margin_m(gx, gy)))
    # no floor: +inf and landing allowed anywhere inside
    nf = parse_fence(_with(floor_m=_DEL, recovery_point=[47.3982, 8.5462]), "s").to_local()
    assert nf.floor_margin_m(e, n, -3.0) == math.inf and nf.landing_allowed(*nf.recovery_en)


def test_array_versions_match_scalar():
    lf = parse_fence(GOOD, "s").to_local()
    rng = np.random.default_rng(2)
    pts = rng.uniform(-150, 150, (400, 2))
    h = rng.uniform(-10, 80, 400)
    assert np.allclose(lf.lateral_margin_array(pts), [lf.lateral_margin_m(*p) for p in pts])
    assert np.allclose(lf.margin_array(pts, h), [lf.margin_m(p[0], p[1], z) for p, z in zip(pts, h)])
    assert np.array_equal(lf.in_floor_gap_array(pts), [lf.in_floor_gap(*p) for p in pts])
    c, f = lf.vertical_margins_array(h)
    assert np.allclose(c, 60 - h) and np.allclose(f, h - 5)


def test_default_recovery_point_is_pole_of_inaccessibility():
    f = parse_fence(_with(recovery_point=_DEL), "s")
    lf = f.to_local()
    e, n, r = lf.inradius()
    assert lf.recovery_en == (e, n)
    assert lf.lateral_margin_m(e, n) == pytest.approx(r)
    # no random point inside has a larger margin
    pts = np.random.default_rng(3).uniform(-120, 120, (3000, 2))
    assert lf.lateral_margin_array(pts).max() <= r + 0.05
    lat, lon, alt = f.resolved_recovery_point()
    assert alt == pytest.approx(32.5)
    assert lf.horizontal_en(lat, lon) == pytest.approx((e, n), abs=1e-6)


def test_to_local_with_given_frame():
    f = parse_fence(GOOD, "s")
    frame = LocalFrame(47.3975, 8.5450, 400.0)  # the SW corner, at 400 m
    lf = f.to_local(frame)
    assert isinstance(lf, LocalFence)
    assert lf.keep_in.vertices[0] == pytest.approx((0.0, 0.0), abs=1e-6)
    # the same fence in two frames gives the same margin at the same place
    lf0 = f.to_local()
    lat, lon = 47.3980, 8.5460
    # (to within the scale (R + 400 m)/R = 1 + 6.3e-5 of projecting at 400 m: 3.5 mm on 55 m)
    m400 = lf.lateral_margin_m(*lf.horizontal_en(lat, lon))
    m0 = lf0.lateral_margin_m(*lf0.horizontal_en(lat, lon))
    assert m400 == pytest.approx(m0 * (1.0 + 400.0 / 6.371e6), abs=1e-3)


# ------------------------------------------------------------------ projection error bound
@pytest.mark.parametrize("lat0", [0.0, 47.4, 75.0])
def test_projection_error_bound_10km(lat0):
    """Documented bound: planar vs geodesic distances < 3 mm; geodesic edge vs segment < 2 mm.

    Points fill a 10 km x 10 km square centred on the frame origin (corners at 7.07 km).
    """
    rng = np.random.default_rng(int(lat0))
    corners = [geodesic_destination(lat0, 8.5, az, 5000.0 * math.sqrt(2.0)) for az in (45, 135, 225, 315)]
    frame = LocalFrame(lat0, 8.5, 0.0)
    pts = list(corners)
    for _ in range(120):
        az, r = rng.uniform(0, 360), rng.uniform(0, 5000.0)
        pts.append(geodesic_destination(lat0, 8.5, az, r))
    enu = [frame.to_enu(la, lo, 0.0)[:2] for la, lo in pts]
    worst = 0.0
    for i in range(len(pts)):
        for j in range(i + 1, len(pts)):
            g = geodesic_distance_m(*pts[i], *pts[j])
            worst = max(worst, abs(g - math.dist(enu[i], enu[j])))
    assert worst < 3.0e-3
    assert worst > 1.0e-3  # the effect is real (s³/6R² per end), not a broken test
    # geodesic edges vs straight ENU segments
    dev = 0.0
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        line = Geodesic.WGS84.InverseLine(*a, *b)
        ea, eb = frame.to_enu(*a, 0.0)[:2], frame.to_enu(*b, 0.0)[:2]
        for t in np.linspace(0.0, 1.0, 41):
            p = line.Position(line.s13 * t)
            e = frame.to_enu(p["lat2"], p["lon2"], 0.0)[:2]
            dev = max(dev, math.sqrt(segment_dist2(*e, *ea, *eb)))
    assert dev < 2.0e-3


def test_height_tilt_is_why_horizontal_en_exists():
    frame = LocalFrame(47.4, 8.5, 0.0)
    lat, lon = geodesic_destination(47.4, 8.5, 45.0, 7071.0)
    e0 = frame.to_enu(lat, lon, 0.0)
    e120 = frame.to_enu(lat, lon, 120.0)
    # the vertical at 7 km tilts by s/R: 120 m of height moves ENU east/north by ~0.13 m
    assert 0.1 < math.dist(e0[:2], e120[:2]) < 0.16
    # and ENU up is not height: the plane is ~3.9 m above the ellipsoid there
    assert e0[2] == pytest.approx(-3.9, abs=0.1)
