"""The recovery planner's compiled segment tests, tangency, graph searches and follower, held to oracles.

Segment verdicts against shapely's distances (every edge and circle of random fences of a few hundred edges:
ends on and next to keep-in corners, inside keep-outs, outside the keep-in, zero-length, along an edge); the
tangency test against its closed form; route lengths of every search (the eager graph's Dijkstra, the lazy
graph's A* with and without the segment grid, the compiled A*, a prepared goal's shortest-route tree, the
safe-point searches) against a brute-force Dijkstra (scipy.sparse.csgraph) over the same visibility graph at
1e-9 relative. Then one conformance test per compiled entry point: its source interpreted (``py_func``)
against the compiled call, within :data:`tests.support.CONFORMANCE_REL`.
"""

import math
import random

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from geofence import recovery as rp
from geofence.geometry.fence import Fence, KeepOutCircle
from geofence.geometry.geodesy import LocalFrame
from geofence.jit import COMPILED
from tests.support import close_fields

FRAME = LocalFrame(47.0, 8.0, 400.0)

BAND_M = 1e-7
"""Segments whose shapely clearance lies within this of the threshold are not judged (rounding decides there)."""


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


FENCES = {
    "seed": st.integers(0, 10_000),
    "n_vertices": st.integers(270, 700),
    "n_squares": st.integers(0, 20),
    "n_circles": st.integers(0, 4),
}
"""The random fences of :func:`_fence` the segment tests draw (a few hundred edges)."""


class Shapely:
    """The oracle of a segment's clearance: shapely's distance to the nearest boundary edge, and to the nearest
    keep-out circle (centre distance less the radius)."""

    def __init__(self, edges: np.ndarray, circles: np.ndarray) -> None:
        self.edges = shapely.linestrings(edges[:, :4].reshape(-1, 2, 2))
        self.centres = shapely.points(circles[:, :2]) if len(circles) else None
        self.radii = circles[:, 2]

    def clearance_m(self, p, q) -> float:
        seg = shapely.LineString([p, q]) if p != q else shapely.Point(p)
        d = float(shapely.distance(seg, self.edges).min())
        if self.centres is not None:
            d = min(d, float((shapely.distance(seg, self.centres) - self.radii).min()))
        return d

    def verdict(self, p, q, thr: float) -> bool | None:
        """Clear at ``thr`` (every edge at least ``thr`` away, every circle ``r + thr``); None within :data:`BAND_M`."""
        d = self.clearance_m(p, q)
        return None if abs(d - thr) <= BAND_M * max(1.0, thr) else d > thr


@settings(max_examples=15, deadline=None)
@given(**FENCES, clearance_m=st.floats(1.0, 90.0))
def test_segment_tests_agree_with_shapely(seed, n_vertices, n_squares, n_circles, clearance_m):
    """The loop over every element, the grid's walk of the cells along the segment (any threshold up to its
    reach), the fans from one origin (nearest edges first, and by the grid) and the batch of pairs: each
    verdict is shapely's."""
    lf = _fence(seed, n_vertices, n_squares, n_circles)
    E, C = rp.boundary_tables(lf)
    grid = rp.segment_grid(E, C, clearance_m, max(clearance_m, 25.0))
    oracle = Shapely(E, C)
    rng = random.Random(seed + 3)
    origin = _point(rng, lf)
    fan, fan_thr = [], rng.uniform(1e-9, clearance_m - 1e-9)
    judged = 0
    for _ in range(150):
        p, q = _segment(rng, lf)
        thr = min(rng.choice([1e-9, 0.01, clearance_m - 1e-9, rng.uniform(0.1, clearance_m)]), clearance_m)
        want = oracle.verdict(p, q, thr)
        fan.append(q)
        if want is None:
            continue
        judged += 1
        assert rp.segment_clear(p[0], p[1], q[0], q[1], thr, E, C) is want, (p, q, thr)
        assert rp.segment_clear_grid(p[0], p[1], q[0], q[1], thr, E, C, *grid) is want, (p, q, thr)
    assert judged > 100
    q = np.array(fan)
    want = [oracle.verdict(origin, tuple(x), fan_thr) for x in fan]
    sure = np.array([w is not None for w in want])
    want_arr = np.array([bool(w) for w in want])
    o = np.array([origin] * len(q))
    for got in (
        rp.fan_clear(origin[0], origin[1], q, fan_thr, E, C),
        rp.fan_clear_grid(origin[0], origin[1], q, fan_thr, E, C, *grid),
        rp.pairs_clear(o, q, fan_thr, E, C),
    ):
        assert (got[sure] == want_arr[sure]).all()


def _tangent_closed_form(cone, corner, dx, dy) -> bool:
    """A node's tangency as defined: a normal of the line along (dx, dy) lies in the node's normal cone (within
    1e-9 relative); every direction for a node without a cone."""
    if not corner:
        return True
    c0, c1, c2, c3 = cone
    px, py = -dy, dx
    tol = -1e-9 * math.hypot(px, py)
    s1 = c0 * py - c1 * px
    s2 = px * c3 - py * c2
    return (s1 >= tol and s2 >= tol) or (s1 <= -tol and s2 <= -tol)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), scale=st.sampled_from([1e-6, 1.0, 350.0, 1e5]))
def test_tangent_candidates_are_the_closed_forms(seed, scale):
    """A node's tangent candidates (:data:`geofence.recovery.tangent_row`) are the nodes tangent at both ends by
    the closed form, for directions anywhere and for directions whose cross products with a cone's normals lie
    at the tolerance (within a few times 1e-9 of the direction's length), and every node's at once
    (:data:`~geofence.recovery.tangent_pairs`) are the same rows."""
    rng = random.Random(seed)
    n = 60
    cones = np.empty((n, 4))
    nodes = np.zeros((n, 2))
    for i in range(n):
        a1 = rng.uniform(-math.pi, math.pi)
        a2 = a1 + rng.choice([0.0, rng.uniform(0.0, math.pi / 6), rng.uniform(0.0, math.pi)])
        cones[i] = (math.cos(a1), math.sin(a1), math.cos(a2), math.sin(a2))
        kind = rng.randrange(3) if i else 0
        if kind == 0:
            nodes[i] = rng.uniform(-scale, scale), rng.uniform(-scale, scale)
        else:  # from node 0 along a direction whose normal is a cone normal of node 0, turned by about the tolerance
            nx, ny = (cones[0, 0], cones[0, 1]) if kind == 1 else (cones[0, 2], cones[0, 3])
            k = rng.choice([1.0, -1.0]) * rng.choice([0.0, rng.uniform(0.3, 3.0), 1.0, 0.5, 2.0]) * 1e-9
            length = rng.uniform(0.1, 1.0) * scale * rng.choice([1.0, -1.0])
            px, py = length * (nx - k * ny), length * (ny + k * nx)
            nodes[i] = nodes[0, 0] + py, nodes[0, 1] - px
    is_corner = np.array([rng.random() < 0.9 for _ in range(n)])
    ptr, cols = rp.tangent_pairs(nodes, cones, is_corner)
    for i in range(n):
        want = [
            j
            for j in range(n)
            if j != i
            and _tangent_closed_form(cones[i], is_corner[i], *(nodes[j] - nodes[i]))
            and _tangent_closed_form(cones[j], is_corner[j], *(nodes[i] - nodes[j]))
        ]
        assert rp.tangent_row(i, nodes, cones, is_corner).tolist() == want, i
        assert cols[ptr[i] : ptr[i + 1]].tolist() == want, i


@settings(max_examples=60, deadline=None)
@given(
    keys=st.lists(st.sampled_from([0.0, 1.0, 2.5, 7.0]) | st.floats(0.0, 1e4), min_size=0, max_size=400),
    first=st.integers(1, 70),
)
def test_first_legs_come_in_stable_key_order(keys, first):
    """The lazy search's untested first legs arrive, chunk after chunk, in a stable sort's order (ties by node)."""
    k = np.array(keys, dtype=float)
    got = [i for chunk in rp.by_key_in_chunks(k, k * 0.5, first) for i in chunk[2]]
    assert got == np.argsort(k, kind="stable").tolist()


class Dijkstra:
    """Brute-force shortest route lengths over a planner's visibility graph (scipy.sparse.csgraph): its graph
    edges (:meth:`RecoveryPlanner.graph_edges`), plus a start's and a goal's admissible straight legs to every
    node (and to each other)."""

    def __init__(self, planner) -> None:
        self.planner = planner
        self.nodes = np.array(planner.nodes, dtype=float)
        self.ii, self.jj, self.w = planner.graph_edges()

    def lengths_from(self, s, goal=None) -> np.ndarray:
        """Route lengths from ``s`` (in the free space) to every node, then to ``goal`` (infinite: unreachable)."""
        pl, n = self.planner, len(self.nodes)
        ii, jj, w = [self.ii], [self.jj], [self.w]
        legs = [k for k in range(n) if pl.admissible(s, tuple(self.nodes[k]))]
        ii.append(np.full(len(legs), n))
        jj.append(np.array(legs, dtype=np.int64))
        w.append(np.hypot(*(self.nodes[legs] - s).T))
        if goal is not None:
            ends = [k for k in range(n) if pl.admissible(goal, tuple(self.nodes[k]))]
            ii.append(np.array(ends, dtype=np.int64))
            jj.append(np.full(len(ends), n + 1))
            w.append(np.hypot(*(self.nodes[ends] - goal).T))
            if pl.admissible(s, goal):
                ii.append(np.array([n]))
                jj.append(np.array([n + 1]))
                w.append(np.array([math.hypot(goal[0] - s[0], goal[1] - s[1])]))
        g = csr_matrix((np.concatenate(w), (np.concatenate(ii), np.concatenate(jj))), shape=(n + 2, n + 2))
        d = dijkstra(g, directed=True, indices=n)
        return np.concatenate([d[:n], d[n + 1 :]])


def _route_length(path) -> float:
    return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(path.points, path.points[1:]))


def _assert_route_ok(pl, path, s) -> None:
    """A route from ``s`` in the free space: it starts there and every segment is admissible."""
    assert path.points[0] == s
    assert all(pl.admissible(p, q) for p, q in zip(path.points, path.points[1:]))


PLANNERS = {
    "eager": {"lazy": False},
    "lazy": {"lazy": True, "grid": False},
    "lazy, grid (compiled A*)": {"lazy": True, "grid": True},
    "prepared (goal tree)": {"lazy": True, "grid": True},
}


@pytest.mark.parametrize("kind", list(PLANNERS))
@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(270, 400), n_squares=st.integers(5, 25))
def test_routes_are_the_shortest_over_the_visibility_graph(kind, seed, n_vertices, n_squares):
    """Every search plans, from starts in the free space (most of them with the straight line to the goal
    blocked), a route as long as the brute-force Dijkstra's shortest over the same graph (1e-9 relative),
    reaching the goal exactly when that is finite, every segment admissible; and the nearest safe point's
    route is the shortest to any safe point."""
    lf = _fence(seed, n_vertices, n_squares, 2)
    pl = rp.RecoveryPlanner(lf, 7.0, **PLANNERS[kind])
    goal = lf.recovery_en
    if kind.startswith("prepared"):
        pl.prepare(goals=(goal,))
    rng = random.Random(seed + 7)
    thr = pl.clearance_m - rp.EPS_M
    free = [p for p in (_point(rng, lf) for _ in range(300)) if lf.lateral_margin_m(*p) >= thr]
    blocked = [p for p in free if not pl.admissible(p, goal)]
    assert blocked and lf.lateral_margin_m(*goal) >= thr
    oracle = Dijkstra(pl)
    safe = [next(k for k, p in enumerate(pl.nodes) if p == sp.en) for sp in pl.safe_points()]
    for s in blocked[:6] + free[:2]:
        lengths = oracle.lengths_from(s, goal)
        path = pl.plan(s, goal)
        assert path is not None and path.reached_goal == bool(np.isfinite(lengths[-1]))
        _assert_route_ok(pl, path, s)
        if path.reached_goal:
            assert path.points[-1] == goal
            assert _route_length(path) == pytest.approx(lengths[-1], rel=1e-9, abs=0.0), s
        near = pl.nearest_safe_point(s)
        if near is not None:
            _assert_route_ok(pl, near[1], s)
            assert _route_length(near[1]) == pytest.approx(lengths[safe].min(), rel=1e-9, abs=0.0), s


def _entry_point_calls():
    """One call of each compiled entry point, its arguments built from a random fence's public tables (arrays
    it fills in place are copied per call by :func:`_fresh`)."""
    lf = _fence(5, 300, 12, 2)
    c = 7.0
    E, C = rp.boundary_tables(lf)
    grid = rp.segment_grid(E, C, c, 25.0)
    corner = np.array([p for p in rp.corner_nodes(lf, c) if lf.lateral_margin_m(p[0], p[1]) >= c])
    P, cones = np.ascontiguousarray(corner[:, :2]), np.ascontiguousarray(corner[:, 2:])
    n = len(P)
    is_corner = np.ones(n, dtype=bool)
    thr = c - rp.EPS_M
    s, g = (float(P[3, 0]) * 0.5, float(P[3, 1]) * 0.5), lf.recovery_en
    goal_d = np.array([math.hypot(x - g[0], y - g[1]) if rp.segment_clear(g[0], g[1], x, y, thr, E, C) else math.inf
                       for x, y in P])  # fmt: skip
    store = (np.full(n, -1, np.int64), np.zeros(n, np.int64), np.empty(1 << 16, np.int64), np.empty(1 << 16),
             np.zeros(1, np.int64))  # fmt: skip
    boxes = (np.array([[P[:, 0].min(), P[:, 0].max(), P[:, 1].min(), P[:, 1].max()]]), np.array([0, n]),
             np.arange(n, dtype=np.int64))  # fmt: skip
    ptr, cols = rp.tangent_pairs(P, cones, is_corner)
    filled = tuple(a.copy() for a in store)
    assert rp.file_rows(ptr, cols, P, thr, E, C, *grid, *filled)
    D, _ = rp.goal_tree(goal_d, *filled[:4])
    box_d = np.array([D.min()])
    q = np.ascontiguousarray(P[:40])
    planner = rp.RecoveryPlanner(lf, c)
    route = planner.plan(s, g)
    R = np.array([x for p in route.points for x in p] + route.cum_m)
    Pf, Qf = rp.follower_tables(E, C, None)
    e, nn = route.point_at(0.3 * route.length_m)
    return {
        "segment_clear": (rp.segment_clear, (s[0], s[1], g[0], g[1], thr, E, C)),
        "segment_clear_grid": (rp.segment_clear_grid, (s[0], s[1], g[0], g[1], thr, E, C, *grid)),
        "fan_clear": (rp.fan_clear, (s[0], s[1], q, thr, E, C)),
        "fan_clear_grid": (rp.fan_clear_grid, (s[0], s[1], q, thr, E, C, *grid)),
        "pairs_clear": (rp.pairs_clear, (np.ascontiguousarray(P[:40]), np.ascontiguousarray(P[40:80]), thr, E, C)),
        "tangent_row": (rp.tangent_row, (3, P, cones, is_corner)),
        "tangent_pairs": (rp.tangent_pairs, (P, cones, is_corner)),
        "file_rows": (rp.file_rows, (ptr, cols, P, thr, E, C, *grid, *store)),
        "lazy_astar": (
            rp.lazy_astar,
            (s[0], s[1], g[0], g[1], thr, thr, P, cones, is_corner, goal_d, E, C, *grid, *store, *boxes),
        ),  # fmt: skip
        "goal_tree": (rp.goal_tree, (goal_d, *filled[:4])),
        "tree_first_leg": (rp.tree_first_leg, (s[0], s[1], thr, P, D, E, C, *grid, *boxes, box_d)),
        "path_project": (rp.path_project, (R, Pf, Qf, 0.0, e + 3.0, nn - 2.0, thr)),
        "path_lookahead": (rp.path_lookahead, (R, Pf, Qf, 0.0, e + 3.0, nn - 2.0, 40.0, thr)),
        "path_rollout": (rp.path_rollout, (R, Pf, Qf, 0.0, e + 3.0, nn - 2.0, 40.0, thr, c)),
        "path_follow": (rp.path_follow, (R, Pf, Qf, 0.0, e + 3.0, nn - 2.0, 40.0, thr, c)),
    }


ENTRY_POINTS = [
    "segment_clear", "segment_clear_grid", "fan_clear", "fan_clear_grid", "pairs_clear", "tangent_row",
    "tangent_pairs", "file_rows", "lazy_astar", "goal_tree", "tree_first_leg", "path_project", "path_lookahead",
    "path_rollout", "path_follow",
]  # fmt: skip


def _fresh(args: tuple) -> tuple:
    return tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args)


def _flat(out) -> list:
    """An entry point's answer as a flat list of numbers."""
    items = out if isinstance(out, tuple) else (out,)
    flat: list = []
    for x in items:
        flat.extend(np.asarray(x, dtype=float).ravel().tolist())
    return flat


@pytest.fixture(scope="module")
def entry_point_calls():
    return _entry_point_calls()


@pytest.mark.skipif(not COMPILED, reason="numba compiles nothing here: the entry points are their source")
@pytest.mark.parametrize("name", ENTRY_POINTS)
def test_compiled_entry_point_equals_its_source_interpreted(entry_point_calls, name):
    fn, args = entry_point_calls[name]
    a, b = _fresh(args), _fresh(args)
    got, want = fn(*a), fn.py_func(*b)
    assert close_fields(_flat(got), _flat(want))
    assert close_fields(_flat(a), _flat(b))  # (the arrays it fills in place)
