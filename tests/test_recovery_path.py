"""Recovery routes (geofence/recovery/): hand cases and property tests against shapely."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import unary_union

from geofence.geometry.fence import Fence, FenceError, KeepOutCircle
from geofence.geometry.geodesy import LocalFrame
from geofence.recovery import ORBIT_CUT_STEP_M, RecoveryPlanner, segment_segment_distance

FRAME = LocalFrame(0.0, 0.0, 0.0)
SLACK_M = 1e-6


def _ll(p):
    lat, lon, _ = FRAME.to_geodetic(float(p[0]), float(p[1]), 0.0)
    return (lat, lon)


def make_fence(keep_in, keep_out_polygons=(), keep_out_circles=()):
    """A LocalFence whose ENU vertices are the given metres (frame at lat/lon 0, 0)."""
    f = Fence(
        keep_in=tuple(_ll(p) for p in keep_in),
        ceiling_m=100.0,
        keep_out_polygons=tuple(tuple(_ll(p) for p in k) for k in keep_out_polygons),
        keep_out_circles=tuple(KeepOutCircle(*_ll((x, y)), r) for x, y, r in keep_out_circles),
    )
    return f.to_local(FRAME)


def shapely_allowed(lf):
    allowed = Polygon(lf.keep_in.vertices)
    holes = [Polygon(k.vertices) for k in lf.keep_out_polygons]
    holes += [Point(x, y).buffer(r, quad_segs=64) for x, y, r in lf.keep_out_circles]
    if holes:
        allowed = allowed.difference(unary_union(holes))
    return allowed


def shapely_eroded(lf, c):
    """Shapely's free space: the keep-in eroded by c minus every keep-out dilated by c.

    The same set as ``shapely_allowed(lf).buffer(-c)``, but GEOS's negative
    buffer simplifies its input (tolerance ~c/100) and drops the finely
    segmented arc of a keep-out circle that cuts the keep-in boundary (measured:
    3.4 m too small), so the erosion and the dilations are done separately.
    Shapely's circles and arcs are inscribed polygons, so this set is slightly
    larger than the true free space near arcs and exact along straight edges.
    """
    eroded = Polygon(lf.keep_in.vertices).buffer(-c, quad_segs=64)
    grown = [Polygon(k.vertices).buffer(c, quad_segs=64) for k in lf.keep_out_polygons]
    grown += [Point(x, y).buffer(r + c, quad_segs=64) for x, y, r in lf.keep_out_circles]
    if grown:
        eroded = eroded.difference(unary_union(grown))
    return eroded


def sample_segment(a, b, step_m=0.5):
    n = max(2, int(math.hypot(b[0] - a[0], b[1] - a[1]) / step_m) + 2)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a, float)[None, :] * (1.0 - t) + np.asarray(b, float)[None, :] * t


def check_path(pl, path, start, eroded=None):
    """The module's guarantee, checked by dense sampling and (optionally) by shapely."""
    lf, c = pl.fence, pl.clearance_m
    pts = path.points
    assert pts[0] == pytest.approx(start, abs=0.0)
    m_s = lf.lateral_margin_m(*start)
    first_floor = min(m_s, c)
    for k in range(len(pts) - 1):
        m = lf.lateral_margin_array(sample_segment(pts[k], pts[k + 1])).min()
        if k == 0:
            tol = SLACK_M if m_s > 0.0 else 1e-3 + SLACK_M
            assert m >= first_floor - tol, (k, m, first_floor)
        else:
            assert m >= c - SLACK_M, (k, m, c)
    for p in pts[1:]:
        assert lf.lateral_margin_m(*p) >= c - SLACK_M
    if eroded is not None:
        # shapely's reference approximates arcs by chords, and GEOS's overlay of coincident circles and
        # keep-out polygons was seen 0.095 m off (the exact sampled margins above held): a reference tolerance
        tol = SLACK_M + max(1e-3 * c, 0.2)
        tail = pts[1:] if m_s < c else pts
        if len(tail) >= 2:
            assert eroded.buffer(tol).covers(LineString(tail))
        elif len(tail) == 1:
            assert eroded.buffer(tol).covers(Point(tail[0]))
    assert path.length_m >= math.hypot(pts[-1][0] - start[0], pts[-1][1] - start[1]) - 1e-9


# ----------------------------------------------------------------------------- hand cases
U = [(0, 0), (300, 0), (300, 300), (200, 300), (200, 100), (100, 100), (100, 300), (0, 300)]
NOTCH = Polygon([(100, 100), (200, 100), (200, 400), (100, 400)])


def test_u_shape_goes_round_the_notch():
    lf = make_fence(U)
    pl = RecoveryPlanner(lf, 20.0)
    s, g = (50.0, 250.0), (250.0, 250.0)
    assert not pl.admissible(s, g)
    p = pl.plan(s, g)
    assert p is not None and p.reached_goal
    assert p.points[0] == s and p.points[-1] == pytest.approx(g)
    check_path(pl, p, s, shapely_eroded(lf, 20.0))
    check_path(pl, p, s, shapely_allowed(lf).buffer(-20.0, quad_segs=64))  # no circles: GEOS is reliable here
    line = LineString(p.points)
    assert line.distance(NOTCH) >= 20.0 - 1e-6  # never across, never closer than the clearance
    # optimal: down the arm, round both notch corners on radius-20 arcs, up the other arm
    s_arm = math.hypot(80 - 50, 250 - 100)  # to the tangent region of the corner; a loose lower bound
    assert p.length_m > 2 * s_arm + 100
    assert p.length_m < 1.05 * (2 * math.hypot(30.0, 150.0 + 20.0) + 100.0 + math.pi * 20.0)
    assert p.remaining_m(*s) == pytest.approx(p.length_m)
    assert p.remaining_m(*g) == pytest.approx(0.0, abs=1e-6)


def test_u_shape_lookahead_never_cuts_the_notch():
    lf = make_fence(U)
    pl = RecoveryPlanner(lf, 20.0)
    p = pl.plan((50.0, 250.0), (250.0, 250.0))
    for s in np.linspace(0.0, p.length_m, 80):
        e, n = p.point_at(float(s))
        for look in (10.0, 60.0, 400.0):
            q = p.lookahead_point(e, n, look)
            assert lf.lateral_margin_m(*q) >= 20.0 - SLACK_M
            seg = sample_segment((e, n), q)
            assert lf.lateral_margin_array(seg).min() >= 20.0 - SLACK_M
            assert not LineString([(e, n), q]).intersects(NOTCH)
    assert p.progress_m == pytest.approx(p.length_m, abs=1e-6)


def test_straight_when_visible():
    lf = make_fence(U)
    pl = RecoveryPlanner(lf, 20.0)
    s, g = (40.0, 250.0), (60.0, 40.0)
    p = pl.plan(s, g)
    assert p.points == [s, g] and p.reached_goal
    assert p.length_m == pytest.approx(math.hypot(20.0, 210.0))


def test_goal_behind_keep_out_circle():
    r, c = 80.0, 15.0
    lf = make_fence([(-500, -200), (500, -200), (500, 200), (-500, 200)], keep_out_circles=[(0.0, 0.0, r)])
    pl = RecoveryPlanner(lf, c)
    s, g = (-400.0, 0.0), (400.0, 0.0)
    p = pl.plan(s, g)
    assert p.reached_goal
    check_path(pl, p, s, shapely_eroded(lf, c))
    # analytic shortest path: tangent + arc + tangent round the radius r + c circle
    R, d = r + c, 400.0
    t = math.sqrt(d * d - R * R)
    arc = R * (math.pi - 2 * math.acos(R / d))
    best = 2 * t + arc
    assert best - 1e-6 <= p.length_m <= best * 1.02
    # the path stays clear of the circle's grown disk
    assert LineString(p.points).distance(Point(0, 0)) >= R - 1e-6


def test_corridor_between_two_areas():
    # two 200 m squares joined by a 60 m wide, 200 m long corridor
    dumbbell = [
        (0, 0),
        (200, 0),
        (200, 70),
        (400, 70),
        (400, 0),
        (600, 0),
        (600, 200),
        (400, 200),
        (400, 130),
        (200, 130),
        (200, 200),
        (0, 200),
    ]
    lf = make_fence(dumbbell)
    s, g = (50.0, 180.0), (550.0, 20.0)
    pl = RecoveryPlanner(lf, 20.0)  # 60 m > 2 x 20 m: passable
    p = pl.plan(s, g)
    assert p.reached_goal
    check_path(pl, p, s, shapely_eroded(lf, 20.0))
    assert all(70 + 20 - 1e-6 <= y <= 130 - 20 + 1e-6 for x, y in p.points if 200 < x < 400)
    pl = RecoveryPlanner(lf, 35.0)  # 60 m < 2 x 35 m: blocked
    p = pl.plan(s, g)
    assert p is not None and not p.reached_goal
    check_path(pl, p, s)
    assert all(x < 200 for x, _ in p.points)  # stays in the start's lobe
    assert p.points[-1][0] > 150  # as near the goal as that lobe allows


def test_l_shape():
    L = [(0, 0), (400, 0), (400, 100), (100, 100), (100, 400), (0, 400)]
    lf = make_fence(L)
    pl = RecoveryPlanner(lf, 10.0)
    s, g = (350.0, 50.0), (50.0, 350.0)
    p = pl.plan(s, g)
    assert p.reached_goal and len(p.points) >= 3
    check_path(pl, p, s, shapely_eroded(lf, 10.0))
    corner = (100.0, 100.0)
    assert min(math.hypot(x - corner[0], y - corner[1]) for x, y in p.points[1:-1]) < 12.0  # wraps the corner
    ideal = 2 * math.hypot(250.0, 40.0)  # via (100, 100) + clearance, roughly
    assert p.length_m < 1.05 * ideal


def test_start_inside_the_grown_margin_of_a_keep_out():
    r, c = 50.0, 20.0
    lf = make_fence([(-300, -300), (300, -300), (300, 300), (-300, 300)], keep_out_circles=[(0.0, 0.0, r)])
    pl = RecoveryPlanner(lf, c)
    s = (-(r + 5.0), 0.0)  # margin 5 < clearance 20
    p = pl.plan(s, (200.0, 0.0))
    assert p is not None and p.reached_goal
    assert p.first_leg_floor_m == pytest.approx(5.0, abs=1e-6)
    check_path(pl, p, s)
    # start inside the keep-out itself (breached): the first leg never goes deeper
    s = (-(r - 10.0), 5.0)
    p = pl.plan(s, (200.0, 0.0))
    assert p is not None and p.reached_goal
    assert p.first_leg_floor_m == pytest.approx(math.hypot(*s) - r, abs=1e-6) and p.first_leg_floor_m < 0.0
    check_path(pl, p, s)
    # start outside the keep-in
    s = (-310.0, 0.0)
    p = pl.plan(s, (200.0, 0.0))
    assert p is not None and p.reached_goal
    check_path(pl, p, s)


def test_goal_outside_free_space_is_replaced_by_a_near_admissible_point():
    lf = make_fence(U)
    pl = RecoveryPlanner(lf, 20.0)
    g = (250.0, 310.0)  # outside the keep-in, beyond the right arm's end
    p = pl.plan((50.0, 250.0), g)
    assert p.reached_goal
    end = p.points[-1]
    assert lf.lateral_margin_m(*end) >= 20.0 - SLACK_M
    assert math.hypot(end[0] - g[0], end[1] - g[1]) == pytest.approx(30.0, abs=1e-3)  # (250, 280)
    check_path(pl, p, (50.0, 250.0))


def test_safe_points():
    lf = make_fence(U)
    pl = RecoveryPlanner(lf, 10.0)
    sps = pl.safe_points()
    assert sps and sps[0].clearance_m == pytest.approx(lf.inradius()[2], abs=0.5)
    for sp in sps:
        assert lf.lateral_margin_m(*sp.en) == pytest.approx(sp.clearance_m) and sp.clearance_m >= 10.0
    sp, path = pl.nearest_safe_point((250.0, 280.0))
    check_path(pl, path, (250.0, 280.0))
    assert path.points[-1] == sp.en
    got = pl.safe_point_with_radius((250.0, 280.0), 30.0)
    assert got is not None
    sp, path = got
    assert sp.clearance_m >= 40.0 - 1e-9 and path.points[-1] == pytest.approx(sp.en)
    assert lf.lateral_margin_m(*sp.en) >= 40.0 - 1e-9
    check_path(pl, path, (250.0, 280.0))
    assert path.length_m < 60.0  # the right arm (100 m wide) fits a 40 m circle close by
    assert pl.safe_point_with_radius((250.0, 280.0), 200.0) is None


def test_bad_clearance_and_segment_distance():
    lf = make_fence(U)
    with pytest.raises(ValueError):
        RecoveryPlanner(lf, 0.0)
    assert segment_segment_distance((0, 0), (10, 0), (5, -1), (5, 1)) == 0.0
    assert segment_segment_distance((0, 0), (10, 0), (12, 3), (12, 5)) == pytest.approx(math.hypot(2, 3))
    assert segment_segment_distance((0, 0), (10, 0), (3, 2), (7, 2)) == pytest.approx(2.0)


# ----------------------------------------------------------------------------- property tests
COORD = st.floats(-500.0, 500.0).map(lambda x: round(x, 6))
"""A coordinate (m) on a micrometre lattice (GEOS mismeasures segments of subnormal length)."""


@settings(max_examples=300, deadline=None)
@given(st.tuples(COORD, COORD), st.tuples(COORD, COORD), st.tuples(COORD, COORD), st.tuples(COORD, COORD))
def test_segment_distance_is_shapelys(p1, p2, q1, q2):
    """The distance between two closed segments (0 where they meet) is shapely's."""
    a = LineString([p1, p2]) if p1 != p2 else Point(p1)
    b = LineString([q1, q2]) if q1 != q2 else Point(q1)
    assert segment_segment_distance(p1, p2, q1, q2) == pytest.approx(a.distance(b), rel=1e-9, abs=1e-9)


@st.composite
def star_keep_in(draw):
    n = draw(st.integers(5, 24))
    jit = draw(st.lists(st.floats(-0.45, 0.45), min_size=n, max_size=n))
    radii = draw(st.lists(st.floats(120.0, 800.0), min_size=n, max_size=n))
    return [
        (r * math.cos(2 * math.pi * (k + j) / n), r * math.sin(2 * math.pi * (k + j) / n))
        for k, (j, r) in enumerate(zip(jit, radii))
    ]


@st.composite
def skyline_keep_in(draw):
    """Concave orthogonal 'skyline' polygons: U, comb and corridor shapes."""
    k = draw(st.integers(2, 6))
    w = draw(st.floats(60.0, 250.0))
    heights = draw(st.lists(st.floats(40.0, 600.0), min_size=k, max_size=k))
    base = draw(st.floats(40.0, 150.0))
    pts = [(0.0, -base)]
    pts.append((k * w, -base))
    for i in range(k - 1, -1, -1):
        pts.append(((i + 1) * w, heights[i]))
        pts.append((i * w, heights[i]))
    # merge consecutive equal heights (collinear vertices are fine but keep it clean)
    return pts


@st.composite
def fences(draw):
    keep_in = draw(st.one_of(star_keep_in(), skyline_keep_in()))
    poly = Polygon(keep_in)
    x0, y0, x1, y1 = poly.bounds
    kops, kocs = [], []
    for _ in range(draw(st.integers(0, 3))):
        cx, cy = draw(st.floats(x0, x1)), draw(st.floats(y0, y1))
        m = draw(st.integers(3, 7))
        rad = draw(st.lists(st.floats(8.0, 60.0), min_size=m, max_size=m))
        kops.append([(cx + r * math.cos(2 * math.pi * i / m), cy + r * math.sin(2 * math.pi * i / m)) for i, r in enumerate(rad)])
    for _ in range(draw(st.integers(0, 3))):
        kocs.append((draw(st.floats(x0, x1)), draw(st.floats(y0, y1)), draw(st.floats(5.0, 60.0))))
    try:
        lf = make_fence(keep_in, kops, kocs)
    except FenceError:
        assume(False)
    return lf


_CACHE: dict = {}


def _planner(lf, c):
    key = (id(lf), c)
    if key not in _CACHE:
        _CACHE.clear()
        _CACHE[key] = (RecoveryPlanner(lf, c), shapely_eroded(lf, c), lf)
    return _CACHE[key][:2]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(fences(), st.floats(3.0, 30.0), st.data())
def test_random_fences_paths_are_admissible(lf, c, data):
    pl, eroded = _planner(lf, c)
    x0, y0, x1, y1 = lf.keep_in.bbox
    for _ in range(3):
        s = (data.draw(st.floats(x0, x1)), data.draw(st.floats(y0, y1)))
        g = (data.draw(st.floats(x0, x1)), data.draw(st.floats(y0, y1)))
        m_s = lf.lateral_margin_m(*s)
        p = pl.plan(s, g)
        if m_s >= c:
            assert p is not None  # a start in the free space always gets a path
        if p is None:
            continue
        check_path(pl, p, s, eroded)
        if m_s >= c and lf.lateral_margin_m(*g) >= c and pl.admissible(s, g):
            assert p.points == [s, g]
        if p.reached_goal and lf.lateral_margin_m(*g) >= c:
            assert p.points[-1] == g
        # carrot chasing along the path: carrots lie on the path, chords keep the margin
        for frac in (0.1, 0.4, 0.7, 1.0):
            e, n = p.point_at(frac * p.length_m)
            q = p.lookahead_point(e, n, data.draw(st.floats(5.0, 300.0)))
            m_v = lf.lateral_margin_m(e, n)
            floor = min(m_v, c) - (SLACK_M if m_v > 0 else 1e-3 + SLACK_M)
            assert lf.lateral_margin_array(sample_segment((e, n), q)).min() >= floor
            if m_v >= c - 1e-9:
                assert lf.lateral_margin_m(*q) >= c - SLACK_M
            # a fixed-wing's roll-out point: the path a lookahead past the projection, in the free space past the
            # first leg, however near a vertex the vehicle is (no chord test: no fallback to a vertex behind it)
            look = data.draw(st.floats(5.0, 300.0))
            s_proj = p.project(e, n)
            r = p.rollout_point(e, n, look)
            assert r == p.point_at(s_proj + look)
            if len(p.points) > 2 and s_proj + look >= p.cum_m[1] and lf.lateral_margin_m(*p.points[-1]) >= c - SLACK_M:
                assert lf.lateral_margin_m(*r) >= c - SLACK_M


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(fences(), st.floats(3.0, 20.0), st.data())
def test_random_fences_graph_edges_and_safe_points(lf, c, data):
    pl, eroded = _planner(lf, c)
    nodes = pl.nodes
    # every graph edge is admissible (sampled) and inside shapely's eroded area
    ii, jj, w = pl.graph_edges()
    assert len(ii) == 2 * pl.graph_edge_count  # (an eager graph: every edge both ways)
    for i, j, length in zip(ii.tolist(), jj.tolist(), w.tolist()):
        assert length == pytest.approx(math.dist(nodes[i], nodes[j]), rel=1e-12)
        if j > i:
            seg = sample_segment(nodes[i], nodes[j], 1.0)
            assert lf.lateral_margin_array(seg).min() >= c - SLACK_M
            assert eroded.buffer(SLACK_M).covers(LineString([nodes[i], nodes[j]]))
    for sp in pl.safe_points():
        assert lf.lateral_margin_m(*sp.en) >= c
    x0, y0, x1, y1 = lf.keep_in.bbox
    s = (data.draw(st.floats(x0, x1)), data.draw(st.floats(y0, y1)))
    got = pl.nearest_safe_point(s)
    if got is not None:
        sp, path = got
        check_path(pl, path, s, eroded)
    R = data.draw(st.floats(1.0, 100.0))
    got = pl.safe_point_with_radius(s, R)
    if got is not None:
        sp, path = got
        assert lf.lateral_margin_m(*sp.en) >= R + c - 1e-9
        check_path(pl, path, s, eroded)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(fences(), st.floats(3.0, 30.0), st.data())
def test_lazy_graph_gives_the_eager_graphs_routes(lf, c, data):
    """The airspace-scale lazy graph (A* with first legs tested as their keys come up / first-target stops; with
    or without the segment grid) finds routes as short as the full graph's."""
    eager, _ = _planner(lf, c)
    lazy = RecoveryPlanner(lf, c, lazy=True, grid=data.draw(st.booleans()))
    assert lazy.nodes == eager.nodes and lazy.graph_edge_count <= eager.graph_edge_count
    x0, y0, x1, y1 = lf.keep_in.bbox
    for _ in range(3):
        s = (data.draw(st.floats(x0, x1)), data.draw(st.floats(y0, y1)))
        g = (data.draw(st.floats(x0, x1)), data.draw(st.floats(y0, y1)))
        a, b = eager.plan(s, g), lazy.plan(s, g)
        assert (a is None) == (b is None)
        if a is not None and b is not None:
            assert a.reached_goal == b.reached_goal
            if a.reached_goal:
                assert b.length_m == pytest.approx(a.length_m, rel=1e-9, abs=1e-6)
                assert b.points[-1] == a.points[-1]
        for radius in (None, data.draw(st.floats(1.0, 100.0))):
            sa = eager.nearest_safe_point(s) if radius is None else eager.safe_point_with_radius(s, radius)
            sb = lazy.nearest_safe_point(s) if radius is None else lazy.safe_point_with_radius(s, radius)
            assert (sa is None) == (sb is None)
            if sa is not None and sb is not None:
                # a route with an orbit's room is cut by sphere tracing: equal routes a rounding apart may be cut
                # a step apart (a clean-clone run found one 1.000 mm longer)
                cut = 0.0 if radius is None else ORBIT_CUT_STEP_M
                assert sb[1].length_m == pytest.approx(sa[1].length_m, rel=1e-9, abs=1e-6 + cut)
