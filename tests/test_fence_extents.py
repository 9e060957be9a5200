"""Fence-format extensions: the inline circular keep-in and keep-outs with a floor and ceiling of their own.

Parsing (good and bad, hypothesis on the extent validation), the keep-in circle's polygon (inside the
circle and within the tolerance of it, at any latitude), the scoring (an entry only inside a keep-out's
volume) and the unit (its margins do not depend on the extents).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import analysis.formats.fence_files
from aircraft.profile import load_profile
from analysis.fast_margins import fence_margins
from analysis.formats.fence_files import fence_to_yaml_block, load_fence_file
from analysis.scoring import keep_out_margin, score_flight
from geofence.geometry.fence import (
    DEFAULT_CIRCLE_TOLERANCE_M,
    FULL_HEIGHT,
    Fence,
    FenceError,
    KeepOutCircle,
    VerticalExtent,
    circle_to_polygon,
    parse_fence,
)
from geofence.geometry.geodesy import LocalFrame, geodesic_distance_m
from geofence.geometry.local_fence import LocalFence
from geofence.margins.boundary_shift import activation_margins
from scenarios.definition.schema import load_scenario

ROOT = Path(__file__).parents[1]
LAT0, LON0 = 47.4, 8.5
FRAME = LocalFrame(LAT0, LON0, 0.0)


def ll(e: float, n: float) -> list[float]:
    """[lat, lon] of a point (east, north) m from the test origin."""
    lat, lon, _ = FRAME.to_geodetic(e, n, 0.0)
    return [lat, lon]


def box(e0: float, n0: float, e1: float, n1: float) -> list[list[float]]:
    return [ll(e0, n0), ll(e1, n0), ll(e1, n1), ll(e0, n1)]


KEEP_IN = box(-100.0, -100.0, 100.0, 100.0)
BUILDING = box(20.0, -10.0, 40.0, 10.0)
"""20 m x 20 m, centred 30 m east of the origin."""


def fence_block(**kw) -> dict:
    m: dict = {"keep_in": KEEP_IN, "ceiling_m": 120}
    m.update(kw)
    return m


def local(block: dict) -> LocalFence:
    return parse_fence(block, "t.yaml").to_local(FRAME)


def error(block: dict) -> str:
    with pytest.raises(FenceError) as exc:
        parse_fence(block, "t.yaml")
    msg = str(exc.value)
    assert msg.startswith("t.yaml: ") and "\n" not in msg
    return msg


# ------------------------------------------------------------------ parsing: good
def test_keep_in_circle_becomes_its_inscribed_polygon_and_is_kept():
    f = parse_fence({"keep_in_circle": {"center": [LAT0, LON0], "radius_m": 80}, "ceiling_m": 50}, "t.yaml")
    assert f.keep_in_circle == (LAT0, LON0, 80.0)
    verts, n, sag = circle_to_polygon(LAT0, LON0, 80.0)
    assert f.keep_in == verts and len(f.keep_in) == n and sag <= DEFAULT_CIRCLE_TOLERANCE_M
    # the largest circle inside is the polygon's incircle, centred on the circle
    e, nn, r = f.to_local(FRAME).inradius()
    assert math.hypot(e, nn) < 0.05 and r == pytest.approx(80.0 * math.cos(math.pi / n), abs=0.02)
    # a Fence given the circle alone fills the polygon in; given both, they must agree
    g = Fence(keep_in=(), ceiling_m=50, keep_in_circle=(LAT0, LON0, 80))
    assert g == f
    assert Fence(keep_in=verts, ceiling_m=50, keep_in_circle=(LAT0, LON0, 80)) == f
    with pytest.raises(FenceError, match=r"^keep_in_circle: keep_in is not this circle's polygon"):
        Fence(keep_in=tuple(tuple(p) for p in KEEP_IN), ceiling_m=50, keep_in_circle=(LAT0, LON0, 80))


def test_keep_out_extents_parse_in_both_polygon_forms_and_on_circles():
    block = fence_block(
        keep_out_polygons=[BUILDING, {"polygon": box(-40, -40, -20, -20), "ceiling_m": 30}, {"polygon": box(-40, 20, -20, 40)}],
        keep_out_circles=[
            {"center": ll(50, 60), "radius_m": 10, "floor_m": 60},
            {"center": ll(-60, -60), "radius_m": 10, "floor_m": 5, "ceiling_m": 40.5},
            {"center": ll(60, -60), "radius_m": 10},
        ],
    )
    f = parse_fence(block, "t.yaml")
    assert f.keep_out_polygon_extents == (FULL_HEIGHT, VerticalExtent(None, 30.0), FULL_HEIGHT)
    assert [c.extent for c in f.keep_out_circles] == [VerticalExtent(60.0, None), VerticalExtent(5.0, 40.5), FULL_HEIGHT]
    assert f.keep_out_polygons[1] == tuple(tuple(p) for p in box(-40, -40, -20, -20))
    lf = f.to_local(FRAME)
    assert lf.keep_out_polygon_extents == f.keep_out_polygon_extents
    assert lf.keep_out_circle_extents == tuple(c.extent for c in f.keep_out_circles)
    assert lf.has_keep_out_extents
    assert not local(fence_block(keep_out_polygons=[BUILDING])).has_keep_out_extents
    # an old-style circle still equals a full-height KeepOutCircle
    assert KeepOutCircle(1.0, 2.0, 3.0) == KeepOutCircle(1.0, 2.0, 3.0, FULL_HEIGHT)
    hash(f)


def test_yaml_block_round_trips_the_circle_and_the_extents():
    f = parse_fence(
        {
            "keep_in_circle": {"center": [LAT0, LON0], "radius_m": 150},
            "ceiling_m": 60,
            "keep_out_polygons": [{"polygon": BUILDING, "floor_m": 2, "ceiling_m": 30}, box(-40, -40, -20, -20)],
            "keep_out_circles": [{"center": ll(0, 60), "radius_m": 10, "floor_m": 45}],
        },
        "t.yaml",
    )
    block = fence_to_yaml_block(f)["geofence"]["fence"]
    assert block["keep_in_circle"] == {"center": [LAT0, LON0], "radius_m": 150.0} and "keep_in" not in block
    assert block["keep_out_polygons"][0]["ceiling_m"] == 30.0 and isinstance(block["keep_out_polygons"][1], list)
    assert parse_fence(json.loads(json.dumps(block)), "again") == f


def test_circle_to_polygon_has_one_home():
    assert analysis.formats.fence_files.circle_to_polygon is circle_to_polygon


def test_shipped_scenario_loads_with_the_circle_and_the_building():
    scn = load_scenario(ROOT / "scenarios" / "geofence_multicopter_keep_in_circle.yaml")
    f = scn.geofence.fence
    assert f.keep_in_circle is not None and f.keep_in_circle[2] == 80.0
    assert f.keep_out_polygon_extents == (VerticalExtent(None, 25.0),)


# ------------------------------------------------------------------ parsing: bad
CIRCLE = {"center": [LAT0, LON0], "radius_m": 80}
BAD = [
    (
        {"keep_in": KEEP_IN, "keep_in_circle": CIRCLE, "ceiling_m": 50},
        "keep_in_circle: give keep_in (a polygon) or keep_in_circle",
    ),
    ({"ceiling_m": 50}, "keep_in: required"),
    ({"keep_in_circle": None, "ceiling_m": 50}, "keep_in: required"),
    ({"keep_in_circle": CIRCLE}, "ceiling_m: required"),
    ({"keep_in_circle": {"center": [LAT0, LON0]}, "ceiling_m": 50}, "keep_in_circle.radius_m: required"),
    ({"keep_in_circle": {"radius_m": 80}, "ceiling_m": 50}, "keep_in_circle.center: required"),
    ({"keep_in_circle": {**CIRCLE, "r": 1}, "ceiling_m": 50}, "keep_in_circle.r: unknown key"),
    ({"keep_in_circle": [LAT0, LON0, 80], "ceiling_m": 50}, "keep_in_circle: must be a mapping"),
    (
        {"keep_in_circle": {"center": [95, LON0], "radius_m": 80}, "ceiling_m": 50},
        "keep_in_circle.center latitude: must be <= 90",
    ),
    (
        {"keep_in_circle": {"center": [LAT0, LON0], "radius_m": 0}, "ceiling_m": 50},
        "keep_in_circle.radius_m: must be 5 to 10000 m, got 0",
    ),
    (
        {"keep_in_circle": {"center": [LAT0, LON0], "radius_m": 4.9}, "ceiling_m": 50},
        "keep_in_circle.radius_m: must be 5 to 10000 m",
    ),
    ({"keep_in_circle": {"center": [LAT0, LON0], "radius_m": -80}, "ceiling_m": 50}, "keep_in_circle.radius_m: must be 5 to"),
    ({"keep_in_circle": {"center": [LAT0, LON0], "radius_m": 2e4}, "ceiling_m": 50}, "keep_in_circle.radius_m: must be 5 to"),
    (
        {"keep_in_circle": {"center": [LAT0, LON0], "radius_m": math.nan}, "ceiling_m": 50},
        "keep_in_circle.radius_m: must be a finite",
    ),
    (
        {"keep_in_circle": {"center": [LAT0, LON0], "radius_m": math.inf}, "ceiling_m": 50},
        "keep_in_circle.radius_m: must be a finite",
    ),
    (
        {"keep_in_circle": {"center": [LAT0, LON0], "radius_m": "80"}, "ceiling_m": 50},
        "keep_in_circle.radius_m: expected a number",
    ),
    ({"keep_in_circle": {"center": [89.95, 0.0], "radius_m": 6000}, "ceiling_m": 50}, "keep_in_circle: a circle of 6000 m"),
    (
        fence_block(keep_out_polygons=[{"polygon": BUILDING, "ceiling_m": 30}, {"ceiling_m": 30}]),
        "keep_out_polygons[1].polygon: required",
    ),
    (fence_block(keep_out_polygons=[{"polygon": BUILDING, "top_m": 30}]), "keep_out_polygons[0].top_m: unknown key"),
    (fence_block(keep_out_polygons=[{"polygon": BUILDING[:2]}]), "keep_out_polygons[0].polygon: needs at least 3 vertices"),
    (
        fence_block(keep_out_polygons=[BUILDING, {"polygon": BUILDING, "floor_m": 30, "ceiling_m": 30}]),
        "keep_out_polygons[1].ceiling_m: 30 m must be above its floor_m 30 m",
    ),
    (
        fence_block(keep_out_polygons=[{"polygon": BUILDING, "floor_m": 40, "ceiling_m": 30}]),
        "keep_out_polygons[0].ceiling_m: 30 m must be above its floor_m 40 m",
    ),
    (
        fence_block(keep_out_polygons=[{"polygon": BUILDING, "ceiling_m": math.nan}]),
        "keep_out_polygons[0].ceiling_m: must be a finite number",
    ),
    (
        fence_block(keep_out_polygons=[{"polygon": BUILDING, "floor_m": math.inf}]),
        "keep_out_polygons[0].floor_m: must be a finite number",
    ),
    (fence_block(keep_out_polygons=[{"polygon": BUILDING, "floor_m": "low"}]), "keep_out_polygons[0].floor_m: expected a number"),
    (fence_block(keep_out_polygons=[{"polygon": BUILDING, "floor_m": True}]), "keep_out_polygons[0].floor_m: expected a number"),
    (
        fence_block(keep_out_polygons=[{"polygon": BUILDING, "floor_m": 120}]),
        "keep_out_polygons[0].floor_m: 120 m is at or above the fence's ceiling_m 120 m",
    ),
    (
        fence_block(keep_out_polygons=[{"polygon": BUILDING, "ceiling_m": 0}]),
        "keep_out_polygons[0].ceiling_m: 0 m AGL must be above the ground",
    ),
    (
        fence_block(keep_out_circles=[{"center": ll(0, 50), "radius_m": 5, "floor_m": 10, "ceiling_m": 5}]),
        "keep_out_circles[0].ceiling_m: 5 m must be above its floor_m 10 m",
    ),
    (
        fence_block(keep_out_circles=[{"center": ll(0, 50), "radius_m": 5, "ceiling_m": math.nan}]),
        "keep_out_circles[0].ceiling_m: must be a finite number",
    ),
    (
        fence_block(keep_out_circles=[{"center": ll(0, 50), "radius_m": 5, "floor_m": 200}]),
        "keep_out_circles[0].floor_m: 200 m is at or above",
    ),
    (fence_block(keep_out_circles=[{"center": ll(0, 50), "radius_m": 5, "top_m": 1}]), "keep_out_circles[0].top_m: unknown key"),
]


@pytest.mark.parametrize("block, expected", BAD, ids=[e for _, e in BAD])
def test_bad_fences_are_refused_in_one_line_naming_the_field(block, expected):
    assert expected in error(block)


def test_extents_on_a_fence_built_in_code_are_checked_too():
    with pytest.raises(FenceError, match=r"^keep_out_polygon_extents: 2 extents for 1 keep_out_polygons"):
        Fence(keep_in=KEEP_IN, ceiling_m=60, keep_out_polygons=(BUILDING,), keep_out_polygon_extents=(FULL_HEIGHT, FULL_HEIGHT))
    with pytest.raises(FenceError, match=r"^keep_out_polygons\[0\]: vertical extent must be \(floor_m, ceiling_m\)"):
        Fence(keep_in=KEEP_IN, ceiling_m=60, keep_out_polygons=(BUILDING,), keep_out_polygon_extents=(30.0,))  # type: ignore[arg-type]
    f = Fence(keep_in=KEEP_IN, ceiling_m=60, keep_out_polygons=(BUILDING,), keep_out_polygon_extents=((np.float64(1.0), 30),))  # type: ignore[arg-type]
    assert f.keep_out_polygon_extents == (VerticalExtent(1.0, 30.0),)
    assert type(f.keep_out_polygon_extents[0]) is VerticalExtent


bound = st.none() | st.floats(min_value=-50.0, max_value=250.0, allow_nan=False) | st.integers(-50, 250)


@settings(max_examples=150, deadline=None)
@given(floor=bound, ceiling=bound, circle=st.booleans())
def test_extent_validation_refuses_exactly_the_bad_pairs(floor, ceiling, circle):
    item: dict = {"floor_m": floor, "ceiling_m": ceiling}
    if circle:
        block = fence_block(keep_out_circles=[{"center": ll(30, 0), "radius_m": 10, **item}])
        name = "keep_out_circles[0]"
    else:
        block = fence_block(keep_out_polygons=[{"polygon": BUILDING, **item}])
        name = "keep_out_polygons[0]"
    if floor is not None and ceiling is not None and floor >= ceiling:
        assert f"{name}.ceiling_m: {float(ceiling):g} m must be above its floor_m {float(floor):g} m" in error(block)
        return
    if (floor is not None and floor >= 120) or (ceiling is not None and ceiling <= 0):
        assert f"{name}." in error(block)
        return
    f = parse_fence(block, "t.yaml")
    extent = f.keep_out_circles[0].extent if circle else f.keep_out_polygon_extents[0]
    assert extent == VerticalExtent(floor, ceiling)
    assert parse_fence(fence_to_yaml_block(f)["geofence"]["fence"], "again") == f


@settings(max_examples=50, deadline=None)
@given(bad=st.sampled_from([math.nan, math.inf, -math.inf]), key=st.sampled_from(["floor_m", "ceiling_m"]))
def test_non_finite_bounds_are_refused(bad, key):
    assert f"keep_out_polygons[0].{key}: must be a finite number" in error(
        fence_block(keep_out_polygons=[{"polygon": BUILDING, key: bad}])
    )


# ------------------------------------------------------------------ the keep-in circle's polygon
@settings(max_examples=60, deadline=None)
@given(
    lat=st.floats(min_value=-85.0, max_value=85.0),
    lon=st.floats(min_value=-180.0, max_value=180.0),
    radius=st.floats(min_value=5.0, max_value=10_000.0),
)
def test_circle_polygon_lies_inside_the_circle_within_the_tolerance(lat, lon, radius):
    f = Fence(keep_in=(), ceiling_m=100, keep_in_circle=(lat, lon, radius))
    lf = f.to_local()
    n = len(f.keep_in)
    sag = radius * (1.0 - math.cos(math.pi / n))
    assert sag <= DEFAULT_CIRCLE_TOLERANCE_M + 1e-12
    # every vertex on the geodesic circle
    d = [geodesic_distance_m(lat, lon, a, b) for a, b in f.keep_in]
    assert max(abs(x - radius) for x in d) < 1e-6 * radius + 1e-6
    # every vertex and edge midpoint of the planar fence, back on the ellipsoid (the tangent plane lies
    # (e^2 + n^2) / 2R below it there): inside the circle, at most the sag inside
    v = lf.keep_in.vertices
    pts = np.concatenate([v, 0.5 * (v + np.roll(v, -1, axis=0))])
    up = lf.frame.h0_m - (pts[:, 0] ** 2 + pts[:, 1] ** 2) / (2.0 * 6_371_000.0)
    dist = np.array([geodesic_distance_m(lat, lon, *lf.frame.to_geodetic(e, nn, u)[:2]) for (e, nn), u in zip(pts, up)])
    assert dist.max() <= radius + 0.001
    assert dist.min() >= radius - sag - 0.001
    # the centre is the incircle's radius from every edge in the plane (the tangent plane shortens
    # distances by about s^3 / 6R^2: 4 mm at 10 km)
    ce, cn = lf.horizontal_en(lat, lon)
    assert lf.lateral_margin_m(ce, cn) == pytest.approx(radius - sag, abs=0.005)


# ------------------------------------------------------------------ scoring
def flight(h_m: float, n_m: float = 0.0) -> dict[str, np.ndarray]:
    """Straight east along north = n_m at 10 m/s, from -80 m to +80 m, at a constant height."""
    t = np.arange(0.0, 16.0 + 1e-9, 0.05)
    e = -80.0 + 10.0 * t
    return {"time_s": t, "east_m": e, "north_m": np.full_like(t, n_m), "agl_m": np.full_like(t, h_m)}


BUILDING_30 = fence_block(keep_out_polygons=[{"polygon": BUILDING, "ceiling_m": 30}])


def test_passing_over_a_building_is_not_an_entry_and_through_it_is():
    lf = local(BUILDING_30)
    over = score_flight(flight(40.0), lf)
    assert over["breached_keep_out"] is False
    assert over["max_lateral_excursion_m"] < 0.0 and over["max_excursion_m"] < 0.0
    # 5 m below the roof through the middle: inside its volume, 5 m deep (the roof is the nearest way out)
    through = score_flight(flight(25.0), lf)
    assert through["breached_keep_out"] is True
    assert through["max_excursion_m"] == pytest.approx(5.0, abs=1e-6)
    assert through["max_lateral_excursion_m"] == pytest.approx(5.0, abs=1e-6)
    # a roof-top skim (exactly at the ceiling) touches the volume but is not inside it
    assert score_flight(flight(30.0), lf)["breached_keep_out"] is False
    # beside the building, below its roof: no entry either
    assert score_flight(flight(20.0, n_m=30.0), lf)["breached_keep_out"] is False


def test_a_full_height_keep_out_is_entered_at_any_height():
    lf = local(fence_block(keep_out_polygons=[BUILDING]))
    for h in (5.0, 40.0, 110.0):
        sc = score_flight(flight(h), lf)
        assert sc["breached_keep_out"] is True and sc["max_lateral_excursion_m"] == pytest.approx(10.0, abs=1e-6)


def test_an_airspace_shelf_is_entered_only_above_its_floor():
    shelf = local(fence_block(keep_out_circles=[{"center": ll(30, 0), "radius_m": 15, "floor_m": 60}]))
    assert score_flight(flight(40.0), shelf)["breached_keep_out"] is False
    sc = score_flight(flight(70.0), shelf)
    assert sc["breached_keep_out"] is True and sc["max_excursion_m"] == pytest.approx(10.0, abs=1e-6)
    # keep_out_margin reads the height too
    m = keep_out_margin(flight(70.0), shelf)
    assert m.min() == pytest.approx(-10.0, abs=1e-6)
    assert keep_out_margin(flight(40.0), shelf).min() == pytest.approx(20.0, abs=1e-6)


def test_volume_margins_match_a_brute_force_reference():
    lf = local(
        fence_block(
            keep_out_polygons=[{"polygon": BUILDING, "floor_m": 10, "ceiling_m": 30}, box(-40, -40, -20, -20)],
            keep_out_circles=[{"center": ll(-50, 50), "radius_m": 12, "floor_m": 60}, {"center": ll(50, 50), "radius_m": 8}],
        )
    )
    rng = np.random.default_rng(3)
    x, y, h = rng.uniform(-110, 110, 4000), rng.uniform(-110, 110, 4000), rng.uniform(0, 130, 4000)
    pts = np.column_stack([x, y])
    k0 = np.maximum(np.maximum(-lf.keep_out_polygons[0].signed_distance_array(pts), h - 30.0), 10.0 - h)
    k1 = -lf.keep_out_polygons[1].signed_distance_array(pts)
    c0 = np.maximum(np.hypot(x - lf.keep_out_circles[0][0], y - lf.keep_out_circles[0][1]) - 12.0, 60.0 - h)
    c1 = np.hypot(x - lf.keep_out_circles[1][0], y - lf.keep_out_circles[1][1]) - 8.0
    ref = np.minimum.reduce([k0, k1, c0, c1])
    m = fence_margins(lf, x, y, h, threads=1)
    np.testing.assert_allclose(m["keep_out"], ref, atol=1e-9)
    np.testing.assert_allclose(m["lateral"], np.minimum(lf.keep_in.signed_distance_array(pts), ref), atol=1e-9)
    # with full-height keep-outs only the scoring's margins are the unit's (LocalFence) margins, bit for bit
    full = local(
        fence_block(
            keep_out_polygons=[BUILDING, box(-40, -40, -20, -20)], keep_out_circles=[{"center": ll(-50, 50), "radius_m": 12}]
        )
    )
    mf = fence_margins(full, x, y, h, threads=1)
    assert np.array_equal(mf["lateral"], full.lateral_margin_array(pts))
    assert np.array_equal(mf["total"], full.margin_array(pts, h))


# ------------------------------------------------------------------ the unit: full-height, unchanged
MC = load_profile("F450RD").envelope


def test_the_units_margins_do_not_depend_on_the_extents():
    with_extent = local(
        fence_block(
            keep_out_polygons=[{"polygon": BUILDING, "ceiling_m": 30}],
            keep_out_circles=[{"center": ll(-50, 50), "radius_m": 12, "floor_m": 60}],
        )
    )
    without = local(fence_block(keep_out_polygons=[BUILDING], keep_out_circles=[{"center": ll(-50, 50), "radius_m": 12}]))
    assert with_extent.has_keep_out_extents and not without.has_keep_out_extents
    rng = np.random.default_rng(5)
    states = [(10.0, 0.0, 40.0, 10.0, 0.0, 0.0), (0.0, 0.0, 45.0, 8.0, 0.0, -1.0), (-50.0, 30.0, 20.0, 0.0, 8.0, 2.0)]
    states += [tuple(rng.uniform([-90, -90, 1, -12, -12, -3], [90, 90, 110, 12, 12, 3])) for _ in range(200)]
    for e, n, h, ve, vn, vu in states:
        a = activation_margins(with_extent, e, n, h, ve, vn, vu, MC, 3.0, -1.0, h_uncertainty_m=1.0)
        b = activation_margins(without, e, n, h, ve, vn, vu, MC, 3.0, -1.0, h_uncertainty_m=1.0)
        assert a == b
        assert with_extent.margin_m(e, n, h) == without.margin_m(e, n, h)
    # the first state flies at 40 m (over the 30 m roof) straight at the building: the unit still acts on it
    first = activation_margins(with_extent, *states[0], MC, 3.0, -1.0)
    assert first.feature == "keep_out_polygon" and first.lateral_activation_m < 0.0


# ------------------------------------------------------------------ GeoJSON keep-outs with floor_m / ceiling_m
def _feature(role: str, ring: list[list[float]], **props) -> dict:
    coords = [[lon, lat] for lat, lon in ring]
    return {
        "type": "Feature",
        "properties": {"geofence": role, **props},
        "geometry": {"type": "Polygon", "coordinates": [coords + [coords[0]]]},
    }


def test_geojson_keep_outs_carry_their_floor_and_ceiling(tmp_path):
    doc = {
        "type": "FeatureCollection",
        "features": [
            _feature("keep_in", KEEP_IN, ceiling_m=90),
            _feature("keep_out", box(300, 300, 320, 320), floor_m=10),  # outside the keep-in: dropped
            _feature("keep_out", BUILDING, ceiling_m=30),
            _feature("keep_out", box(-40, -40, -20, -20)),
            _feature("keep_out", box(-40, 20, -20, 40), floor_m=50, ceiling_m=None),
        ],
    }
    p = tmp_path / "f.geojson"
    p.write_text(json.dumps(doc))
    imp = load_fence_file(p)
    assert imp.fence.ceiling_m == 90.0
    assert imp.fence.keep_out_polygon_extents == (VerticalExtent(None, 30.0), FULL_HEIGHT, VerticalExtent(50.0, None))
    assert sum("dropped" in w for w in imp.warnings) == 1


@pytest.mark.parametrize(
    "props, expected",
    [
        ({"floor_m": 40, "ceiling_m": 30}, "features[1] (name 'tower').ceiling_m: 30 m must be above its floor_m 40 m"),
        ({"ceiling_m": "tall"}, "features[1] (name 'tower'): properties.ceiling_m: expected a number"),
        ({"floor_m": 95}, "features[1] (name 'tower').floor_m: 95 m is at or above the fence's ceiling_m 90 m"),
    ],
)
def test_geojson_bad_extents_name_the_feature(tmp_path, props, expected):
    doc = {
        "type": "FeatureCollection",
        "features": [_feature("keep_in", KEEP_IN, ceiling_m=90), _feature("keep_out", BUILDING, name="tower", **props)],
    }
    p = tmp_path / "f.geojson"
    p.write_text(json.dumps(doc))
    with pytest.raises(FenceError) as exc:
        load_fence_file(p)
    assert str(exc.value).startswith(f"{p}: ") and expected in str(exc.value)
    assert "\n" not in str(exc.value)
