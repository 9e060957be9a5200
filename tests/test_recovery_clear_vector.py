"""Property: the recovery planner's vectorized segment test gives the scalar loop's verdict, and the same routes.

:meth:`RecoveryPlanner._clear_one` tests the boundary edges in a segment's bounding box with
:func:`geofence.recovery_path._edges_block_np` once there are ``VECTOR_FROM_EDGES`` of them; with
``vector_from`` above every count it loops over them in Python (the reference). Random fences of a few
hundred edges (so the bounding-box prefilter is on), random segments -- ends on and next to keep-in
corners, inside keep-outs, outside the keep-in, zero-length, along an edge -- and clearances: the same
boolean must come out. Also, whole routes: :meth:`RecoveryPlanner.plan` from a planner that never
vectorizes gives the same points, bit for bit.
"""

import math
import random

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import geofence.recovery_path as rp
from geofence.fence import Fence, KeepOutCircle
from geofence.geodesy import LocalFrame
from geofence.jit import use_compiled

FRAME = LocalFrame(47.0, 8.0, 400.0)
NEVER = 10**9


def _fence(seed: int, n_vertices: int, n_squares: int, n_circles: int):
    rng = random.Random(seed)

    def ll(e: float, n: float) -> tuple[float, float]:
        lat, lon, _ = FRAME.to_geodetic(e, n, FRAME.h0_m)
        return lat, lon

    keep_in = []
    for i in range(n_vertices):
        a = 2.0 * math.pi * i / n_vertices
        r = 600.0 * (1.0 + 0.2 * math.sin(5.0 * a) + rng.uniform(-0.04, 0.04))
        keep_in.append(ll(r * math.cos(a), r * math.sin(a)))
    squares, circles = [], []
    for _ in range(n_squares):
        cx, cy, s, t = rng.uniform(-300, 300), rng.uniform(-300, 300), rng.uniform(5, 25), rng.uniform(0, math.pi / 2)
        squares.append(
            tuple(ll(cx + s * math.cos(t + k * math.pi / 2), cy + s * math.sin(t + k * math.pi / 2)) for k in range(4))
        )
    for _ in range(n_circles):
        circles.append(KeepOutCircle(*ll(rng.uniform(-300, 300), rng.uniform(-300, 300)), rng.uniform(5, 30)))
    f = Fence(keep_in=tuple(keep_in), ceiling_m=120.0, keep_out_polygons=tuple(squares), keep_out_circles=tuple(circles))
    return f.to_local(FRAME)


def _point(rng: random.Random, lf) -> tuple[float, float]:
    kind = rng.randrange(5)
    v = lf.keep_in.vertices
    if kind == 0:  # a keep-in corner, or right next to it
        p = v[rng.randrange(len(v))]
        eps = rng.choice([0.0, 1e-9, 1e-3, 0.5])
        return float(p[0]) + eps * rng.uniform(-1, 1), float(p[1]) + eps * rng.uniform(-1, 1)
    if kind == 1 and lf.keep_out_polygons:  # inside (or on a corner of) a keep-out
        k = lf.keep_out_polygons[rng.randrange(len(lf.keep_out_polygons))].vertices
        w = [rng.random() for _ in range(len(k))]
        return float(sum(wi * k[i, 0] for i, wi in enumerate(w)) / sum(w)), float(
            sum(wi * k[i, 1] for i, wi in enumerate(w)) / sum(w)
        )
    if kind == 2:  # on an edge of the keep-in
        i = rng.randrange(len(v))
        a, b, t = v[i - 1], v[i], rng.random()
        return float(a[0] + t * (b[0] - a[0])), float(a[1] + t * (b[1] - a[1]))
    return rng.uniform(-800, 800), rng.uniform(-800, 800)  # anywhere, also outside the keep-in


FENCES = {
    "seed": st.integers(0, 10_000),
    "n_vertices": st.integers(270, 700),
    "n_squares": st.integers(0, 20),
    "n_circles": st.integers(0, 4),
}
"""The random fences of :func:`_fence` the segment tests draw (a few hundred edges: the bounding-box prefilter on)."""


@settings(max_examples=15, deadline=None)
@given(**FENCES)
def test_vectorized_segment_test_equals_the_loop(seed, n_vertices, n_squares, n_circles):
    lf = _fence(seed, n_vertices, n_squares, n_circles)
    planner = rp.RecoveryPlanner(lf, 5.0, lazy=True)
    assert len(planner._edges) > rp.BBOX_PREFILTER_EDGES
    rng = random.Random(seed + 1)
    for _ in range(150):
        p, q = _segment(rng, lf)
        thr = rng.choice([1e-9, 0.01, rng.uniform(0.1, 10.0), rng.uniform(0.1, 60.0)])
        ref = planner._clear_one(p, q, thr, vector_from=NEVER)
        for vf in (0, 1, rp.VECTOR_FROM_EDGES):
            assert planner._clear_one(p, q, thr, vector_from=vf) is ref, (p, q, thr, vf)


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(270, 500), n_squares=st.integers(0, 15))
def test_routes_are_the_same_with_and_without_the_vectorized_test(seed, n_vertices, n_squares):
    lf = _fence(seed, n_vertices, n_squares, 1)
    fast = rp.RecoveryPlanner(lf, 6.0, lazy=True)
    old = rp.VECTOR_FROM_EDGES
    rp.VECTOR_FROM_EDGES = NEVER
    try:
        ref = rp.RecoveryPlanner(lf, 6.0, lazy=True)
        rng = random.Random(seed + 2)
        starts = [_point(rng, lf) for _ in range(6)]
        goal = lf.recovery_en
        ref_routes = [ref.plan(s, goal) for s in starts]
        ref_safe = [(p.east_m, p.north_m, p.clearance_m) for p in ref.safe_points()]
    finally:
        rp.VECTOR_FROM_EDGES = old
    assert [(p.east_m, p.north_m, p.clearance_m) for p in fast.safe_points()] == ref_safe
    for s, r in zip(starts, ref_routes):
        got = fast.plan(s, goal)
        if r is None:
            assert got is None
        else:
            assert got.points == r.points and got.reached_goal == r.reached_goal and got.first_leg_floor_m == r.first_leg_floor_m


def _segment(rng: random.Random, lf) -> tuple[tuple[float, float], tuple[float, float]]:
    p = _point(rng, lf)
    u = rng.random()
    if u < 0.05:
        return p, p
    if u < 0.5:  # short segments: most of them clear
        a, r = rng.uniform(0, 2 * math.pi), rng.uniform(1.0, 80.0)
        return p, (p[0] + r * math.cos(a), p[1] + r * math.sin(a))
    if u < 0.6:  # axis-parallel, along a column or a row of the grid
        r = rng.uniform(-900.0, 900.0)
        return p, ((p[0] + r, p[1]) if rng.random() < 0.5 else (p[0], p[1] + r))
    if u < 0.65:  # far outside the fence (and the grid)
        return (p[0] + 5000.0, p[1] - 3000.0), (p[0] + 5200.0, p[1] + 4000.0)
    return p, _point(rng, lf)


@settings(max_examples=15, deadline=None)
@given(**FENCES, clearance_m=st.floats(1.0, 90.0))
def test_grid_segment_test_equals_the_loop(seed, n_vertices, n_squares, n_circles, clearance_m):
    """The airspace-scale segment test walks the cells of a grid (:func:`geofence.recovery_path.segment_grid`)
    along the segment: for any threshold up to the grid's reach (the clearance) it must give the full loop's
    verdict, segment by segment and as a fan from one origin."""
    lf = _fence(seed, n_vertices, n_squares, n_circles)
    planner = rp.RecoveryPlanner(lf, clearance_m, grid=True)
    grid = planner._segment_grid()
    assert grid is not None
    E, C = planner._edge_rows, planner._circle_rows
    rng = random.Random(seed + 3)
    origin = _point(rng, lf)
    fan, fan_thr = [], rng.uniform(1e-9, clearance_m - 1e-9)
    for _ in range(150):
        p, q = _segment(rng, lf)
        thr = rng.choice([1e-9, 0.01, clearance_m - 1e-9, rng.uniform(0.1, clearance_m)])
        thr = min(thr, clearance_m)
        ref = rp._segment_clear(p[0], p[1], q[0], q[1], thr, E, C)
        assert rp._segment_clear_grid(p[0], p[1], q[0], q[1], thr, E, C, *grid) is ref, (p, q, thr)
        if rp.segment_clear_grid is not None:
            assert rp.segment_clear_grid(p[0], p[1], q[0], q[1], thr, E, C, *grid) is ref, (p, q, thr)
        fan.append(q)
    q = np.array(fan)
    ref = np.array([rp._segment_clear(origin[0], origin[1], x, y, fan_thr, E, C) for x, y in fan])
    assert (rp._fan_clear_grid(origin[0], origin[1], q, fan_thr, E, C, *grid) == ref).all()
    if rp.fan_clear_grid is not None:
        assert (rp.fan_clear_grid(origin[0], origin[1], q, fan_thr, E, C, *grid) == ref).all()


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(270, 500), n_squares=st.integers(0, 15))
def test_routes_are_the_same_with_and_without_the_grid(seed, n_vertices, n_squares):
    """A lazy planner with the grid and one without plan the same routes, bit for bit (same verdicts, same search)."""
    lf = _fence(seed, n_vertices, n_squares, 1)
    with_grid = rp.RecoveryPlanner(lf, 8.0, lazy=True, grid=True)
    without = rp.RecoveryPlanner(lf, 8.0, lazy=True, grid=False)
    rng = random.Random(seed + 4)
    goal = lf.recovery_en
    for s in [_point(rng, lf) for _ in range(6)]:
        a, b = with_grid.plan(s, goal), without.plan(s, goal)
        assert (a is None) == (b is None)
        if a is not None and b is not None:
            assert a.points == b.points and a.reached_goal == b.reached_goal


@settings(max_examples=60, deadline=None)
@given(
    keys=st.lists(st.sampled_from([0.0, 1.0, 2.5, 7.0]) | st.floats(0.0, 1e4), min_size=0, max_size=400),
    first=st.integers(1, 70),
)
def test_first_legs_come_in_stable_key_order(keys, first):
    """The lazy search's untested first legs arrive, chunk after chunk, in a stable sort's order (ties by node)."""
    k = np.array(keys, dtype=float)
    leg = k * 0.5
    got = [i for chunk in rp._by_key_in_chunks(k, leg, first) for i in chunk[2]]
    assert got == np.argsort(k, kind="stable").tolist()


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(270, 500), n_squares=st.integers(10, 40))
def test_compiled_search_plans_the_python_searchs_routes(seed, n_vertices, n_squares):
    """The lazy A* compiled in one call (:func:`geofence.recovery_path._lazy_astar`, a lazy planner with the grid
    while numba is active) plans the Python search's routes, bit for bit: from starts in the free space whose
    straight line to the goal is blocked (a search, the compiled call), and from anywhere."""
    lf = _fence(seed, n_vertices, n_squares, 1)
    compiled = rp.RecoveryPlanner(lf, 7.0, lazy=True, grid=True)
    python = rp.RecoveryPlanner(lf, 7.0, lazy=True, grid=True)
    rng = random.Random(seed + 5)
    goal = lf.recovery_en
    points = [_point(rng, lf) for _ in range(200)]
    thr = compiled.clearance_m - rp.EPS_M

    def searched(p: tuple[float, float]) -> bool:
        return lf.lateral_margin_m(*p) >= thr and not compiled._clear_one(p, goal, thr)

    starts = [p for p in points if searched(p)][:8] + points[:3]
    assert len(starts) > 3
    for s in starts:
        a = compiled.plan(s, goal)
        previous = use_compiled(False)
        try:
            b = python.plan(s, goal)
        finally:
            use_compiled(previous)
        assert (a is None) == (b is None)
        if a is not None and b is not None:
            assert a.points == b.points and a.reached_goal == b.reached_goal, (s, a.points, b.points)


def _tangent_at_with_root(c0, c1, c2, c3, corner, dx, dy) -> bool:
    """:func:`geofence.recovery_path._tangent_at` as it was: the tolerance's square root every time."""
    if not corner:
        return True
    px, py = -dy, dx
    tol = -1e-9 * math.hypot(px, py)
    s1 = c0 * py - c1 * px
    s2 = px * c3 - py * c2
    return (s1 >= tol and s2 >= tol) or (s1 <= -tol and s2 <= -tol)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), scale=st.sampled_from([1e-6, 1.0, 350.0, 1e5]))
def test_the_tangency_test_without_its_square_root_gives_the_same_verdicts(seed, scale):
    """The tangency test decides outside the tolerance's band without the square root: the verdicts of the test
    that takes it every time, for directions anywhere and for directions whose cross products with a cone's
    normals lie at the tolerance (within a few times 1e-9 of the direction's length), zero and the axes."""
    rng = random.Random(seed)
    for _ in range(400):
        a1 = rng.uniform(-math.pi, math.pi)
        a2 = a1 + rng.choice([0.0, rng.uniform(0.0, math.pi / 6), rng.uniform(0.0, math.pi)])
        c = (math.cos(a1), math.sin(a1), math.cos(a2), math.sin(a2))
        kind = rng.randrange(4)
        if kind == 0:
            dx, dy = rng.uniform(-scale, scale), rng.uniform(-scale, scale)
        elif kind == 3:
            dx, dy = rng.choice([(0.0, 0.0), (scale, 0.0), (0.0, -scale), (-scale, scale)])
        else:  # the line's normal p = (-dy, dx) along a cone normal, turned by about the tolerance
            nx, ny = (c[0], c[1]) if kind == 1 else (c[2], c[3])
            k = rng.choice([1.0, -1.0]) * rng.choice([0.0, rng.uniform(0.3, 3.0), 1.0, 0.5, 2.0]) * 1e-9
            length = rng.uniform(0.1, 1.0) * scale
            sign = rng.choice([1.0, -1.0])
            px, py = sign * length * (nx - k * ny), sign * length * (ny + k * nx)
            dx, dy = py, -px
        for corner in (True, False):
            assert rp._tangent_at(*c, corner, dx, dy) == _tangent_at_with_root(*c, corner, dx, dy), (c, dx, dy)


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(270, 500), n_squares=st.integers(5, 30))
def test_the_whole_graph_built_at_once_is_the_graph_found_node_by_node(seed, n_vertices, n_squares):
    """:func:`geofence.recovery_path._tangent_pairs` gives every node's tangent candidates (each pair tested once)
    as :func:`~geofence.recovery_path._tangent_row` finds them node by node, and :meth:`RecoveryPlanner.prepare`
    files every node's graph edges as a lazy search finds them (the same neighbours, lengths and order)."""
    lf = _fence(seed, n_vertices, n_squares, 2)
    whole = rp.RecoveryPlanner(lf, 6.0, lazy=True, grid=True)
    lazy = rp.RecoveryPlanner(lf, 6.0, lazy=True, grid=True)
    whole.prepare()
    lazy._build_graph()
    nodes = whole._nodes
    pairs = rp.tangent_pairs or rp._tangent_pairs
    row = rp.tangent_row or rp._tangent_row
    ptr, cols = pairs(nodes, whole._cones, whole._is_corner)
    rng = random.Random(seed)
    sample = rng.sample(range(len(nodes)), min(60, len(nodes)))
    for i in sample:
        assert cols[ptr[i] : ptr[i + 1]].tolist() == row(i, nodes, whole._cones, whole._is_corner).tolist()
        assert whole._neighbours(i) == lazy._neighbours(i), i
    assert whole._full_graph and not lazy._full_graph


def _length(points) -> float:
    return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(points, points[1:]))


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(270, 500), n_squares=st.integers(10, 40))
def test_routes_by_the_goal_tree_are_the_searchs_shortest_routes(seed, n_vertices, n_squares):
    """A planner prepared for its goal (its whole graph, and the goal's shortest-route tree) answers a search
    from the free space by the tree: a route as short as the lazy A*'s over the same graph (to round-off; the
    same points where no two routes tie), reaching the goal, its first leg clear at the clearance and every
    later segment admissible. Starts whose straight line to the goal is blocked, and starts anywhere."""
    lf = _fence(seed, n_vertices, n_squares, 2)
    tree = rp.RecoveryPlanner(lf, 7.0, lazy=True, grid=True)
    astar = rp.RecoveryPlanner(lf, 7.0, lazy=True, grid=True)
    goal = lf.recovery_en
    tree.prepare(goals=(goal,))
    assert tree._trees
    rng = random.Random(seed + 7)
    thr = tree.clearance_m - rp.EPS_M
    points = [_point(rng, lf) for _ in range(300)]
    searched = [p for p in points if lf.lateral_margin_m(*p) >= thr and not tree._clear_one(p, goal, thr)]
    assert searched
    same = 0
    for s in searched[:12] + points[:4]:
        a, b = tree.plan(s, goal), astar.plan(s, goal)
        assert (a is None) == (b is None)
        if a is None or b is None:
            continue
        assert a.reached_goal == b.reached_goal
        la, lb = _length(a.points), _length(b.points)
        assert abs(la - lb) <= 1e-9 * lb, (s, la, lb)
        same += a.points == b.points
        if s in searched:
            assert tree._clear_one(a.points[0], a.points[1], thr)
            assert all(tree.admissible(p, q) for p, q in zip(a.points[1:], a.points[2:]))
    assert same >= 1
