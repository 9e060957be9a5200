"""The recovery planner: shortest admissible routes in a fence's clearance-offset free space.

Owns :class:`RecoveryPlanner`: the graph's nodes (corner nodes and safe points), its edges (all at once, or
found as searches expand them), the segment tests over the planner's tables, the searches (the planner's own
Dijkstra / A* with the first-leg rule, :class:`Search`; the compiled lazy A* and goal trees of
:mod:`geofence.recovery.search` where they apply) and the queries (:meth:`RecoveryPlanner.plan`, the safe
points). See :mod:`geofence.recovery` for the guarantee.
"""

from __future__ import annotations

import heapq
import math
from typing import TYPE_CHECKING, Callable, Iterator, NamedTuple, Sequence

import numpy as np

from geofence.geometry.polygon import pole_of_inaccessibility
from geofence.geometry.scan import lateral_margin_scan
from geofence.recovery.follower import follower_tables
from geofence.recovery.graph import NODE_INFLATION_M, corner_nodes, file_rows, tangent_pairs, tangent_row
from geofence.recovery.path import RecoveryPath, SafePoint
from geofence.recovery.search import by_key_in_chunks, goal_tree, lazy_astar, tree_first_leg
from geofence.recovery.segments import (
    EPS_M,
    SEGMENT_GRID_MIN_EDGES,
    Grid,
    Point,
    boundary_tables,
    fan_clear,
    fan_clear_grid,
    pairs_clear,
    segment_clear,
    segment_clear_grid,
    segment_grid,
)

if TYPE_CHECKING:  # pragma: no cover
    from geofence.geometry.local_fence import LocalFence

BREACHED_TOL_M: float = 1e-3
"""Tolerance (m) of the certified first-leg test from a start outside the allowed area."""

ORBIT_CUT_STEP_M: float = 1e-3
"""The smallest step (m) of :meth:`RecoveryPlanner.safe_point_with_radius`'s sphere tracing along a route: its cut
point is the route's first point with the room, to within this (two routes a rounding apart can be cut a step
apart)."""

GRID_CELLS: int = 64
"""Safe-point search grid: cells along the keep-in's longer bounding-box side."""

MAX_SAFE_POINTS: int = 12

NODES_PER_BOX: int = 16
"""About how many graph nodes share a box of the compiled search's first legs (:meth:`RecoveryPlanner._node_boxes`)."""

FULL_GRAPH_MAX_NODES: int = 20_000
"""Up to this many nodes :meth:`RecoveryPlanner.prepare` files a lazy graph's every edge (every pair of nodes is
tested for tangency, about 2 s for the 11,300 nodes of the 10,000 + 500 park); a larger graph stays lazy and its
goals get no shortest-route tree."""

LAZY_MIN_NODES: int = 1500
"""From this many graph nodes on, the graph is built lazily (see :mod:`geofence.recovery`'s Complexity)."""


class Search(NamedTuple):
    """A search's answer from a start: route lengths and predecessors over the graph's points."""

    start: Point
    floor_m: float
    """The margin the first leg keeps: the clearance from the free space, else the start's margin."""
    points: list[Point]
    """The graph's nodes, then the search's escape point (a breached start's), if any."""
    dist: Sequence[float] | np.ndarray
    """Route length from the start to each point (infinite: not reached)."""
    pred: Sequence[int] | np.ndarray
    """The point before each on its route (-1: the start)."""
    n_first: int
    """How many first legs leave the start (0: none)."""
    best: int | None
    """The point a route to the goal leaves the graph from, where the search chose it (the compiled A*; -1:
    none); ``None``: the caller chooses."""


class _FirstLegs:
    """A lazy search's untested first legs, ``(key, leg, node)`` in ascending key order, a chunk at a time
    (:func:`~geofence.recovery.search.by_key_in_chunks`); none for an eager search."""

    def __init__(self, chunks: Iterator[tuple[list, list, list]] | None) -> None:
        self._chunks = chunks
        self._key: list[float] = []
        self._leg: list[float] = []
        self._node: list[int] = []
        self._at = 0

    def next_key(self) -> float:
        """The next untested first leg's key (infinite: none left)."""
        if self._at == len(self._key) and self._chunks is not None:
            chunk = next(self._chunks, None)
            if chunk is None:
                self._chunks = None
            else:
                self._key, self._leg, self._node = chunk
                self._at = 0
        return self._key[self._at] if self._at < len(self._key) else math.inf

    def pop(self) -> tuple[float, float, int]:
        """Take the next untested first leg (after :meth:`next_key`)."""
        k = self._at
        self._at += 1
        return self._key[k], self._leg[k], self._node[k]


def _margin_function(fence: "LocalFence") -> Callable[[float, float], float]:
    """``fence.lateral_margin_m`` as a function of ``(e, n)`` for a search that asks it at many points (a safe
    point's polylabel): for a fence without an index, the compiled scan with its tables bound
    (:meth:`~geofence.geometry.local_fence.LocalFence.lateral_margin_scan_m`'s number, without the per-call lookups)."""
    if fence.grid() is not None:
        return fence.lateral_margin_m
    ki, ko, offsets, circles = fence.scan_tables()
    return lambda e, n: lateral_margin_scan(e, n, ki, ko, offsets, circles)


class RecoveryPlanner:
    """Shortest admissible routes inside a :class:`LocalFence` with lateral clearance ``clearance_m`` (> 0).

    Built once per fence and clearance; :meth:`plan`, :meth:`nearest_safe_point` and
    :meth:`safe_point_with_radius` answer at activation time. See :mod:`geofence.recovery` for the guarantee.
    The graph's nodes (corner nodes and safe points) and, unless ``lazy``, its
    edges are built on the first question that needs them (:meth:`_build_graph`): a route whose straight
    segment is clear needs none (most of a convex fence's). ``lazy``: find each node's edges on its first
    use (``None``: from :data:`LAZY_MIN_NODES` nodes on); the routes are the same either way. ``grid``: file the
    edges in a grid for the segment tests (:func:`~geofence.recovery.segments.segment_grid`; ``None``: from
    :data:`~geofence.recovery.segments.SEGMENT_GRID_MIN_EDGES` edges on); the same verdicts either way.
    """

    def __init__(self, fence: "LocalFence", clearance_m: float, *, lazy: bool | None = None, grid: bool | None = None) -> None:
        c = float(clearance_m)
        if not (c > 0.0 and math.isfinite(c)):
            raise ValueError(f"clearance_m must be finite and > 0, got {clearance_m!r}")
        self.fence = fence
        self.clearance_m = c
        self._thr = c - EPS_M
        self._edge_rows, self._circle_rows = boundary_tables(fence)  # the segment tests' tables
        # the compiled follower's tables; with the fence's scan tables (no index) it finds the chord threshold itself
        self._follower_scans = fence.grid() is None
        self._follower = follower_tables(
            self._edge_rows, self._circle_rows, fence.scan_tables() if self._follower_scans else None
        )
        self._follower_scan_arguments = (*self._follower, math.nan, c)  # RecoveryPath._kernel_arguments' (no index)
        self._lazy_choice = lazy
        self._graph_built = False
        self._grid: Grid | tuple[()] | None = None  # the segment test's grid (:meth:`_segment_grid`; (): none)
        self._grid_choice = grid
        self._goal_margin: tuple[Point, float] | None = None  # the last goal :meth:`plan` was asked and its margin

    def prepare(self, goals: Sequence[Point] = ()) -> None:
        """Build the graph (its nodes and edges, a lazy graph's too where it has a segment grid and at most
        :data:`FULL_GRAPH_MAX_NODES` nodes), the segment grid and, over a whole graph, the goals' visible
        nodes and shortest-route trees now, not at the first question that needs them. The same graph and
        routes as short: only when the work is done differs."""
        self._build_graph()
        grid = self._segment_grid()
        if len(self._node_list) <= FULL_GRAPH_MAX_NODES and self._lazy and grid is not None:
            ptr, cols = tangent_pairs(self._nodes, self._cones, self._is_corner)
            row_start, row_len, store_j, store_w, used = self._edge_store()
            if int(used[0]) + len(cols) > len(store_j):
                self._grow_edge_store(len(cols))
            row_start, row_len, store_j, store_w, used = self._edge_store()
            done = file_rows(ptr, cols, self._nodes, self._thr, self._edge_rows, self._circle_rows, *grid, row_start,
                             row_len, store_j, store_w, used)  # fmt: skip
            assert done  # (room for every candidate)
            self._full_graph = True
        if not self._full_graph:
            return  # (a lazy graph's goals find their visible nodes at their first search)
        for goal in goals:
            g = self._free_goal((float(goal[0]), float(goal[1])))
            if g is not None:
                self._trees[g] = self._goal_tree(g)
                self._tree_route(g, g, g)  # (loads the compiled query now, not at the first route search)

    def _goal_lengths(self, goal: Point, goal_nodes: dict[int, float]) -> np.ndarray:
        """``goal_nodes`` (the nodes that see ``goal``, :meth:`_goal_nodes_of`) as an array over every node,
        infinite where the goal is not seen (the last goal's kept)."""
        goal_d = self._goal_d.get(goal)
        if goal_d is None:
            goal_d = np.full(len(self._node_list), math.inf)
            for i, d in goal_nodes.items():
                goal_d[i] = d
            self._goal_d.clear()
            self._goal_d[goal] = goal_d
        return goal_d

    def _goal_tree(self, goal: Point) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(D, nxt, box_d)``: :func:`~geofence.recovery.search.goal_tree` of ``goal`` over the whole graph, and each of
        :meth:`_node_boxes`' smallest ``D``."""
        goal_d = self._goal_lengths(goal, self._goal_nodes_of(goal))
        row_start, row_len, store_j, store_w, _ = self._edge_store()
        D, nxt = goal_tree(goal_d, row_start, row_len, store_j, store_w)
        _, box_start, box_items = self._node_boxes()
        box_d = np.minimum.reduceat(D[box_items], box_start[:-1])
        return D, nxt, box_d

    def _tree_route(self, s: Point, g: Point, goal: Point) -> RecoveryPath | None:
        """The shortest route from ``s`` (in the free space) to ``g`` by its goal tree (:meth:`prepare`'s): the first
        leg :func:`~geofence.recovery.search.tree_first_leg` finds, then the tree's next nodes. ``None``: no
        tree for ``g``, or no route to it from ``s`` (the search finds the partial route)."""
        tree = self._trees.get(g)
        grid = self._segment_grid()
        if tree is None or grid is None:
            return None
        D, nxt, box_d = tree
        i = int(tree_first_leg(s[0], s[1], self._thr, self._nodes, D, self._edge_rows, self._circle_rows, *grid,
                               *self._node_boxes(), box_d))  # fmt: skip
        if i < 0:
            return None
        pts = [s]
        while i >= 0:
            pts.append(self._node_list[i])
            i = int(nxt[i])
        pts.append(g)
        return RecoveryPath(self, pts, goal, True, self.clearance_m)

    def _build_graph(self) -> None:
        """The graph's nodes (corner nodes and safe points), their normal cones and, unless lazy, its edges: once,
        on the first question that needs them (:attr:`nodes` asks)."""
        if self._graph_built:
            return
        self._graph_built = True
        fence = self.fence
        lazy = self._lazy_choice
        corner = [p for p in corner_nodes(fence, self.clearance_m) if fence.lateral_margin_m(p[0], p[1]) >= self._thr]
        self._safe = self._find_safe_points()
        self._safe_index = list(range(len(corner), len(corner) + len(self._safe)))
        nodes = [(p[0], p[1]) for p in corner] + [sp.en for sp in self._safe]
        self._node_list = nodes
        self._nodes = np.array(nodes, dtype=float).reshape(-1, 2)
        # normal cones (n1 -> n2 counter-clockwise) of the corner nodes; safe points: no cone
        cones = np.array([p[2:] for p in corner] + [(0.0, 0.0, 0.0, 0.0)] * len(self._safe), dtype=float)
        self._cones = cones.reshape(-1, 4)
        self._is_corner = np.arange(len(nodes)) < len(corner)
        nn = len(nodes)
        self._visible_cache: dict[tuple[float, float, float], tuple[int, ...]] = {}
        self._goal_nodes: dict[Point, dict[int, float]] = {}  # plan's goal -> the nodes that see it and how far
        self._goal_d: dict[Point, np.ndarray] = {}  # the same as an array (infinite: not seen), the last goal's
        # a lazy graph's edges as found, as arrays (:meth:`_edge_store`): the compiled search's, and the planner's
        self._store: tuple[np.ndarray, ...] | None = None
        self._boxes: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._full_graph = False  # a lazy graph's every row filed (:meth:`prepare`)
        self._trees: dict[Point, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}  # goal -> :meth:`_goal_tree`
        self._lazy: bool = nn >= LAZY_MIN_NODES if lazy is None else bool(lazy)
        self._adj: list[list[tuple[int, float]] | None] = [None if self._lazy else [] for _ in nodes]
        if nn >= 2 and not self._lazy:
            self._adj = list(self._eager_rows())

    def _eager_rows(self) -> list[list[tuple[int, float]]]:
        """Every node's graph edges ``(j, length)``, ascending ``j``: the pairs tangent at both ends
        (:func:`~geofence.recovery.graph.tangent_pairs`, each pair once) whose segment is clear."""
        nodes = self._node_list
        ptr, cols = tangent_pairs(self._nodes, self._cones, self._is_corner)
        ii = np.repeat(np.arange(len(nodes)), np.diff(ptr))
        up = cols > ii  # each pair once, in ascending (i, j) order
        ii, jj = ii[up], cols[up]
        ok = pairs_clear(self._nodes[ii], self._nodes[jj], self._thr, self._edge_rows, self._circle_rows)
        adj: list[list[tuple[int, float]]] = [[] for _ in nodes]
        for i, j in zip(ii[ok].tolist(), jj[ok].tolist()):
            w = math.hypot(nodes[i][0] - nodes[j][0], nodes[i][1] - nodes[j][1])
            adj[i].append((j, w))
            adj[j].append((i, w))
        return adj

    @property
    def nodes(self) -> list[Point]:
        """The graph's nodes: the corner nodes, then the safe points (built on first use)."""
        self._build_graph()
        return self._node_list

    @property
    def graph_edge_count(self) -> int:
        """Graph edges found so far: all of them, or for a lazy graph those of the nodes expanded."""
        self._build_graph()
        found = sum(len(x) for x in self._adj if x is not None)
        return found // 2 if not self._lazy else found

    def graph_edges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(i, j, length_m)``: every graph edge from node ``i`` to node ``j`` (both directions), a lazy graph's
        every node's edges found now."""
        rows = [self._neighbours(i) for i in range(len(self.nodes))]
        ii = np.array([i for i, row in enumerate(rows) for _ in row], dtype=np.int64)
        jj = np.array([j for row in rows for j, _ in row], dtype=np.int64)
        w = np.array([w for row in rows for _, w in row], dtype=float)
        return ii, jj, w

    def _neighbours(self, i: int) -> list[tuple[int, float]]:
        """Node ``i``'s graph edges ``(j, length)``: precomputed, or for a lazy graph found on first use (by this
        method or by the compiled search, :func:`~geofence.recovery.search.lazy_astar`: one edge store for both,
        :meth:`_edge_store`)."""
        row = self._adj[i]
        if row is None:
            row_start, row_len, store_j, store_w, _ = self._edge_store()
            at = int(row_start[i])
            if at >= 0:  # found by the compiled search
                row = list(zip(store_j[at : at + row_len[i]].tolist(), store_w[at : at + row_len[i]].tolist()))
            else:
                d = self._nodes - self._nodes[i]
                jj = tangent_row(i, self._nodes, self._cones, self._is_corner)
                jj = jj[self._fan_clear(self._nodes[i], self._nodes[jj], self._thr)]
                w = np.hypot(d[jj, 0], d[jj, 1])
                self._store_row(i, jj, w)
                row = list(zip(jj.tolist(), w.tolist()))
            self._adj[i] = row
        return row

    def _edge_store(self) -> tuple[np.ndarray, ...]:
        """The lazy graph's edges as arrays, ``(row_start, row_len, store_j, store_w, used)``: node ``i``'s edges are
        ``store_j[row_start[i]:][:row_len[i]]`` (other nodes) and ``store_w`` (lengths), ``row_start[i]`` -1 until
        found; ``used[0]`` entries filled. :func:`~geofence.recovery.search.lazy_astar` fills it in place."""
        if self._store is None:
            n = len(self.nodes)
            room = 1 << 16
            self._store = (
                np.full(n, -1, np.int64), np.zeros(n, np.int64), np.empty(room, np.int64), np.empty(room),
                np.zeros(1, np.int64),
            )  # fmt: skip
        return self._store

    def _grow_edge_store(self, need: int) -> None:
        """Room for ``need`` more edges in :meth:`_edge_store` (at least twice the room it had)."""
        row_start, row_len, store_j, store_w, used = self._edge_store()
        filled = int(used[0])
        room = max(2 * len(store_j), filled + need)
        j, w = np.empty(room, np.int64), np.empty(room)
        j[:filled], w[:filled] = store_j[:filled], store_w[:filled]
        self._store = (row_start, row_len, j, w, used)

    def _store_row(self, i: int, jj: np.ndarray, w: np.ndarray) -> None:
        """File node ``i``'s edges (found in Python) in :meth:`_edge_store`."""
        row_start, row_len, store_j, store_w, used = self._edge_store()
        if int(used[0]) + len(jj) > len(store_j):
            self._grow_edge_store(len(jj))
            row_start, row_len, store_j, store_w, used = self._edge_store()
        at = int(used[0])
        store_j[at : at + len(jj)] = jj
        store_w[at : at + len(jj)] = w
        row_start[i], row_len[i] = at, len(jj)
        used[0] = at + len(jj)

    # ------------------------------------------------------------------ construction
    def _find_safe_points(self) -> list[SafePoint]:
        f = self.fence
        c = self.clearance_m
        x0, y0, x1, y1 = f.keep_in.bbox
        h = max(x1 - x0, y1 - y0) / GRID_CELLS
        xs = np.arange(x0 + 0.5 * h, x1, h)
        ys = np.arange(y0 + 0.5 * h, y1, h)
        gx, gy = np.meshgrid(xs, ys)
        m = f.lateral_margin_array(np.column_stack([gx.ravel(), gy.ravel()])).reshape(gx.shape)
        pad = np.pad(m, 1, constant_values=-np.inf)
        is_max = np.ones(m.shape, dtype=bool)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                if di or dj:
                    is_max &= m >= pad[1 + di : 1 + di + m.shape[0], 1 + dj : 1 + dj + m.shape[1]]
        is_max &= m >= c
        cand = [(float(m[i, j]), float(gx[i, j]), float(gy[i, j])) for i, j in zip(*np.nonzero(is_max))]
        ex, ey, er = f.inradius()
        cand.append((float(er), float(ex), float(ey)))
        cand.sort(reverse=True)
        kept: list[SafePoint] = []
        for r, x, y in cand:
            if r < c or len(kept) >= MAX_SAFE_POINTS:
                break
            # same lobe as a kept point: the straight line between them keeps 70 % of the smaller clearance
            if any(self._clear_one((k.east_m, k.north_m), (x, y), 0.7 * r) for k in kept):
                continue
            px, py, pr = pole_of_inaccessibility(
                _margin_function(f), (x - h, y - h, x + h, y + h), precision_m=max(0.01, 1e-3 * h), max_cells=400
            )
            if pr < r:
                px, py, pr = x, y, r
            kept.append(SafePoint(px, py, f.lateral_margin_m(px, py)))
        return kept

    # ------------------------------------------------------------------ exact segment tests
    def _segment_grid(self) -> Grid | None:
        """The grid of the compiled segment test (:func:`~geofence.recovery.segments.segment_grid`, reach: the
        clearance; cells of the clearance, at least 25 m), made on first use; ``None`` without one (the
        planner's ``grid`` argument; by default from :data:`SEGMENT_GRID_MIN_EDGES` edges on)."""
        if self._grid is None:
            choice = self._grid_choice
            if not len(self._edge_rows) or not (len(self._edge_rows) >= SEGMENT_GRID_MIN_EDGES if choice is None else choice):
                self._grid = ()
            else:
                c = self.clearance_m
                self._grid = segment_grid(self._edge_rows, self._circle_rows, c, max(c, 25.0))
        return self._grid or None

    def _clear_one(self, p: Point, q: Point, thr: float) -> bool:
        """Exact: with ``margin(p) >= thr > 0`` (caller's duty), is ``margin >= thr`` all along p-q?

        One compiled call: :data:`~geofence.recovery.segments.segment_clear`, or with the planner's grid (and
        ``thr`` within its reach, the clearance) from its cells along the segment,
        :data:`~geofence.recovery.segments.segment_clear_grid` (the same verdict)."""
        grid = self._segment_grid()
        if grid is not None and thr <= self.clearance_m:
            return bool(segment_clear_grid(p[0], p[1], q[0], q[1], thr, self._edge_rows, self._circle_rows, *grid))
        return bool(segment_clear(p[0], p[1], q[0], q[1], thr, self._edge_rows, self._circle_rows))

    def _fan_clear(self, origin: np.ndarray, q: np.ndarray, thr: float) -> np.ndarray:
        """:meth:`_clear_one` for the segments from one ``origin`` to each row of ``q`` (exact): one compiled call,
        each segment walking the grid's cells from the origin (:data:`~geofence.recovery.segments.fan_clear_grid`)
        or testing the edges near the origin, nearest first (:data:`~geofence.recovery.segments.fan_clear`)."""
        if len(q) == 0:
            return np.zeros(0, dtype=bool)
        o = np.asarray(origin, dtype=float)
        q = np.ascontiguousarray(q, dtype=float)
        grid = self._segment_grid()
        if grid is not None and thr <= self.clearance_m:
            return fan_clear_grid(float(o[0]), float(o[1]), q, thr, self._edge_rows, self._circle_rows, *grid)
        return fan_clear(float(o[0]), float(o[1]), q, thr, self._edge_rows, self._circle_rows)

    def _visible_from(self, p: Point, thr: float, dist: list[float] | None = None) -> list[int]:
        """Graph nodes joined to p by a segment keeping ``margin >= thr`` (exact; ``margin(p) >= thr > 0``).

        Every node is tested (no tangency pruning here: the start or goal may
        lie between a clearance arc and its circumscribed polygon, outside the
        polygonal domain the pruning argument holds in), except, with ``dist``,
        nodes whose ``dist`` is infinite.
        """
        if not self.nodes:
            return []
        key = (float(p[0]), float(p[1]), float(thr))
        if dist is None and key in self._visible_cache:  # the goal (recovery point) is the same at every override
            return list(self._visible_cache[key])
        pa = np.asarray(p, dtype=float)
        keep = np.ones(len(self.nodes), dtype=bool)
        if dist is not None:
            keep &= np.isfinite(np.asarray(dist[: len(self.nodes)]))
        idx = np.nonzero(keep)[0]
        ok = self._fan_clear(pa, self._nodes[idx], thr)
        out = idx[ok].tolist()
        if dist is None:
            if len(self._visible_cache) >= 16:
                self._visible_cache.pop(next(iter(self._visible_cache)))
            self._visible_cache[key] = tuple(out)
        return out

    def _certified(self, p: Point, q: Point, t: float, tol: float = BREACHED_TOL_M, max_evals: int = 4000) -> bool:
        """Certified: ``margin >= t - tol`` all along p-q, by bisection with the 1-Lipschitz bound.

        ``True`` is a proof (each piece of length L has ``margin(mid) - L/2 >=
        t - tol``, or ``L <= tol`` and ``margin(mid) >= t - tol/2``); ``False``
        means a violation was found or the budget ran out.
        """
        f = self.fence.lateral_margin_m
        (ax, ay), (bx, by) = p, q
        length = math.hypot(bx - ax, by - ay)
        stack = [(0.0, 1.0)]
        evals = 0
        while stack:
            u0, u1 = stack.pop()
            um = 0.5 * (u0 + u1)
            half = 0.5 * (u1 - u0) * length
            v = f(ax + um * (bx - ax), ay + um * (by - ay))
            evals += 1
            if v - half >= t - tol:
                continue
            if v < t - tol or evals > max_evals:
                return False
            if half <= 0.5 * tol:
                if v >= t - 0.5 * tol:
                    continue
                return False
            stack.append((u0, um))
            stack.append((um, u1))
        return True

    def chord_ok(self, p: Point, q: Point, margin_p: float | None = None) -> bool:
        """Is the straight move p -> q safe for a vehicle at p?

        Safe means the margin stays ``>= min(margin(p), c)`` (within 1e-9 m,
        exact) all along; for a breached p (``margin(p) <= 0``) it must not go
        deeper than ``margin(p)`` (within 1 mm, certified). For p in the free
        space this is plain admissibility.
        """
        m = self.fence.lateral_margin_m(p[0], p[1]) if margin_p is None else margin_p
        t = min(m, self.clearance_m) - EPS_M
        if t > 0.0:
            return self._clear_one(p, q, t)
        return self._certified(p, q, min(m, 0.0))

    def admissible(self, p: Point, q: Point) -> bool:
        """Exact: is every point of segment p-q in the free space (``margin >= c - 1e-9``)?"""
        if self.fence.lateral_margin_m(p[0], p[1]) < self._thr:
            return False
        return self._clear_one((float(p[0]), float(p[1])), (float(q[0]), float(q[1])), self._thr)

    # ------------------------------------------------------------------ searches
    def _push_into_free(self, x: float, y: float, iters: int = 8) -> Point | None:
        """Push (x, y) along steepest margin ascent until it is in the free space; ``None`` if that fails."""
        f = self.fence
        target = self.clearance_m + NODE_INFLATION_M
        for _ in range(iters):
            m, _, _, _, dx, dy = f.lateral_nearest(x, y)
            if m >= self._thr:
                return (x, y)
            step = target - m
            x, y = x - dx * step, y - dy * step
        return (x, y) if f.lateral_margin_m(x, y) >= self._thr else None

    def _search(
        self, s: Point, goal: Point | None = None, goal_nodes: dict[int, float] | None = None, targets: set[int] | None = None
    ) -> Search:
        """Dijkstra from s with the first-leg rule (:meth:`_first_legs`).

        For a lazy graph the search stops early: with ``goal`` and ``goal_nodes``
        (node -> straight length to the goal, the nodes that see it) it is A*
        and stops once no open node can improve the best route to the goal (one compiled call,
        :meth:`_search_compiled`, from the free space with a segment grid); with
        ``targets`` it stops when the first target is settled. An eager graph is
        searched in full (every reachable node gets its distance).
        """
        m_s = self.fence.lateral_margin_m(s[0], s[1])
        nn = len(self.nodes)
        in_free = m_s >= self._thr
        floor = self.clearance_m if in_free else m_s
        escape = None if in_free else self._push_into_free(s[0], s[1])
        pts = self.nodes + ([] if escape is None else [escape])
        astar = goal is not None and goal_nodes is not None and targets is None
        if in_free and self._lazy and astar and self._segment_grid() is not None:
            assert goal is not None and goal_nodes is not None
            return self._search_compiled(s, goal, goal_nodes, pts)
        if goal is not None and goal_nodes is not None and escape is not None and self._clear_one(escape, goal, self._thr):
            goal_nodes = {**goal_nodes, nn: math.hypot(escape[0] - goal[0], escape[1] - goal[1])}
        first, legs, thr = self._first_legs(s, m_s, pts, escape is not None, goal)
        heuristic = goal if self._lazy else None
        dist, pred, n_first = self._dijkstra(s, pts, first, legs, thr, heuristic, goal_nodes, targets)
        return Search((float(s[0]), float(s[1])), floor, pts, dist, pred, n_first, None)

    def _first_legs(
        self, s: Point, m_s: float, pts: list[Point], escape: bool, goal: Point | None
    ) -> tuple[list[int], _FirstLegs, float]:
        """``(first, untested, thr)``: the first legs from s tested now (points), those a lazy graph tests as
        their key comes up, and the threshold they are tested at.

        From the free space, or a start with a positive margin, a first leg keeps ``min(margin, c)`` (exact
        test); a lazy graph tests a first leg to a node only when its key comes up (the straight leg is the
        shortest way to its node, so its key is the node's best), without a fan to every node. From a breached
        start the 32 nearest points (the escape point first) are certified (:meth:`_certified`)."""
        nn = len(self.nodes)
        in_free = m_s >= self._thr
        if not (in_free or m_s - EPS_M > 0.0):
            order = sorted(range(len(pts)), key=lambda i: math.hypot(pts[i][0] - s[0], pts[i][1] - s[1]))
            if escape:
                order.remove(nn)
                order.insert(0, nn)
            return [i for i in order[:32] if self._certified(s, pts[i], m_s)], _FirstLegs(None), self._thr
        thr = self._thr if in_free else m_s - EPS_M
        to_escape = [nn] if escape and self._clear_one(s, pts[nn], thr) else []
        if not (self._lazy and nn):
            return self._visible_from(s, thr) + to_escape, _FirstLegs(None), thr
        P = self._nodes
        ex, ey = P[:, 0] - s[0], P[:, 1] - s[1]
        leg = np.sqrt(ex * ex + ey * ey)
        if goal is not None:
            fx, fy = P[:, 0] - goal[0], P[:, 1] - goal[1]
            keys = leg + np.sqrt(fx * fx + fy * fy)
        else:
            keys = leg
        return to_escape, _FirstLegs(by_key_in_chunks(keys, leg)), thr

    def _dijkstra(
        self, s: Point, pts: list[Point], first: list[int], legs: _FirstLegs, thr: float, goal: Point | None,
        goal_nodes: dict[int, float] | None, targets: set[int] | None,
    ) -> tuple[list[float], list[int], int]:  # fmt: skip
        """``(dist, pred, first legs found)`` of the search from s over ``pts`` (:meth:`_search`): the first legs
        ``first`` and, as their keys come up, ``legs`` (tested at ``thr``); A* keys towards ``goal`` (``None``:
        Dijkstra); a lazy graph stops as :meth:`_search` says."""
        dist = [math.inf] * len(pts)
        pred = [-1] * len(pts)
        n_first = len(first)
        open_ = []
        for i in first:
            d = math.hypot(pts[i][0] - s[0], pts[i][1] - s[1])
            dist[i] = d
            open_.append((d + self._heuristic(pts[i], goal), d, i))
        heapq.heapify(open_)
        best_goal = math.inf
        while True:
            if legs.next_key() < (open_[0][0] if open_ else math.inf):  # the next untested first leg comes first
                key, d, i = legs.pop()
                if goal_nodes is not None and key >= best_goal:
                    break  # (as below)
                if d >= dist[i] or not self._clear_one(s, pts[i], thr):
                    continue  # reached as short already, or not seen
                dist[i], pred[i] = d, -1
                n_first += 1
            elif open_:
                key, d, i = heapq.heappop(open_)
                if d > dist[i]:
                    continue
            else:
                break
            if self._lazy:
                if goal_nodes is not None and key >= best_goal:
                    break  # no open node can shorten the best route found to the goal
                if targets is not None and i in targets:
                    break  # the nearest target (by route) is settled
                if goal_nodes is not None and i in goal_nodes:
                    best_goal = min(best_goal, d + goal_nodes[i])
            for j, w in self._adjacent(i, pts):
                nd = d + w
                if nd < dist[j]:
                    dist[j] = nd
                    pred[j] = i
                    heapq.heappush(open_, (nd + self._heuristic(pts[j], goal), nd, j))
        return dist, pred, n_first

    @staticmethod
    def _heuristic(p: Point, goal: Point | None) -> float:
        """A*'s key term: the straight length from p to the goal (0 without one)."""
        return 0.0 if goal is None else math.hypot(p[0] - goal[0], p[1] - goal[1])

    def _adjacent(self, i: int, pts: list[Point]) -> list[tuple[int, float]]:
        """Point ``i``'s edges ``(j, length)``: a node's graph edges, or the escape point's to every node it sees."""
        if i < len(self._node_list):
            return self._neighbours(i)
        x = pts[i]
        return [(j, math.hypot(pts[j][0] - x[0], pts[j][1] - x[1])) for j in self._visible_from(x, self._thr)]

    def _search_compiled(self, s: Point, goal: Point, goal_nodes: dict[int, float], pts: list[Point]) -> Search:
        """:meth:`_search`'s A* from a start in the free space with a segment grid, in one compiled call
        (:func:`~geofence.recovery.search.lazy_astar`); it chooses the route's last node itself."""
        goal_d = self._goal_lengths(goal, goal_nodes)
        grid = self._segment_grid()
        assert grid is not None  # (the caller's condition)
        while True:
            row_start, row_len, store_j, store_w, used = self._edge_store()
            dist, pred, n_first, best = lazy_astar(
                s[0], s[1], goal[0], goal[1], self._thr, self._thr, self._nodes, self._cones, self._is_corner, goal_d,
                self._edge_rows, self._circle_rows, *grid, row_start, row_len, store_j, store_w, used,
                *self._node_boxes(),
            )  # fmt: skip
            if n_first >= 0:
                break
            self._grow_edge_store(len(self._node_list))  # the edge store is full: more room, and search again
        return Search(s, self.clearance_m, pts, dist, pred, int(n_first), int(best))

    def _node_boxes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The graph's nodes in boxes for :func:`~geofence.recovery.search.lazy_astar`'s first legs, ``(box, box_start,
        box_items)``: the non-empty cells of a square grid of about :data:`NODES_PER_BOX` nodes a cell, each as
        its nodes' bounding box; made on first use."""
        if self._boxes is None:
            P = self._nodes
            lo, hi = P.min(axis=0), P.max(axis=0)
            side = max(float(math.sqrt(max((hi[0] - lo[0]) * (hi[1] - lo[1]), 1.0) * NODES_PER_BOX / len(P))), 1.0)
            ij = ((P - lo) // side).astype(np.int64)
            cell = ij[:, 1] * (int(ij[:, 0].max()) + 1) + ij[:, 0]
            order = np.argsort(cell, kind="stable")
            ids, first = np.unique(cell[order], return_index=True)
            box_start = np.append(first, len(P)).astype(np.int64)
            x, y = P[order, 0], P[order, 1]
            box = np.column_stack([np.minimum.reduceat(x, first), np.maximum.reduceat(x, first),
                                   np.minimum.reduceat(y, first), np.maximum.reduceat(y, first)])  # fmt: skip
            self._boxes = (np.ascontiguousarray(box), box_start, order.astype(np.int64))
        return self._boxes

    def _path_to(self, search: Search, i: int, end: Point | None) -> list[Point]:
        """The route the search found to point ``i``, from its start, then ``end`` (if any)."""
        chain = []
        while i != -1:
            chain.append(search.points[i])
            i = int(search.pred[i])
        pts = [search.start, *reversed(chain)]
        if end is not None:
            pts.append(end)
        return pts

    def _free_goal(self, goal: Point) -> Point | None:
        """The goal a route to ``goal`` ends at: itself in the free space, else the margin-ascent push's point,
        else the nearest graph node (``None``: no node)."""
        if self._goal_margin is None or self._goal_margin[0] != goal:  # a unit asks for the same goal every time
            self._goal_margin = (goal, self.fence.lateral_margin_m(goal[0], goal[1]))
        if self._goal_margin[1] >= self._thr:
            return goal
        g = self._push_into_free(goal[0], goal[1])
        if g is None and self.nodes:
            d = np.hypot(self._nodes[:, 0] - goal[0], self._nodes[:, 1] - goal[1])
            g = self.nodes[int(np.argmin(d))]
        return g

    def _goal_nodes_of(self, g: Point) -> dict[int, float]:
        """The graph nodes that see goal ``g`` and their straight lengths to it (the last 16 goals' kept)."""
        goal_nodes = self._goal_nodes.get(g)  # a unit asks for the same goal every time
        if goal_nodes is None:
            gx, gy = g
            nodes = self.nodes
            goal_nodes = {i: math.hypot(nodes[i][0] - gx, nodes[i][1] - gy) for i in self._visible_from(g, self._thr)}
            if len(self._goal_nodes) >= 16:
                self._goal_nodes.pop(next(iter(self._goal_nodes)))
            self._goal_nodes[g] = goal_nodes
        return goal_nodes

    # ------------------------------------------------------------------ queries
    def plan(self, start_en: Point, goal_en: Point) -> RecoveryPath | None:
        """Shortest admissible route from ``start_en`` to ``goal_en`` (see :mod:`geofence.recovery`'s guarantee).

        Returns ``None`` only if no admissible first leg leaves the start (its
        component of the free space is unreachable under the first-leg rule).
        A start in the free space with nothing reachable gives the one-point
        path ``[start]`` with ``reached_goal=False``.
        """
        s = (float(start_en[0]), float(start_en[1]))
        goal = (float(goal_en[0]), float(goal_en[1]))
        g = self._free_goal(goal)
        m_s = self.fence.lateral_margin_m(s[0], s[1])
        in_free = m_s >= self._thr
        floor = self.clearance_m if in_free else m_s
        if g is not None and self._direct(s, g, m_s):  # the straight segment first (the shortest possible route)
            return RecoveryPath(self, [s, g], goal, True, floor)
        self._build_graph()
        if self._lazy and g is not None:
            if in_free:  # a prepared goal's tree answers without a search
                route = self._tree_route(s, g, goal)
                if route is not None:
                    return route
            found = self._search(s, goal=g, goal_nodes=self._goal_nodes_of(g))
        else:
            found = self._search(s)
        if not found.n_first:
            return RecoveryPath(self, [s], goal, False, floor) if in_free else None
        best_i = self._last_node(found, g)
        if best_i >= 0:
            return RecoveryPath(self, self._path_to(found, best_i, g), goal, True, floor)
        # unreachable goal: end at the reachable point nearest to it
        target = g if g is not None else goal
        dist, pts = found.dist, found.points
        cand = [i for i in range(len(pts)) if dist[i] < math.inf]
        i = min(cand, key=lambda k: (math.hypot(pts[k][0] - target[0], pts[k][1] - target[1]), dist[k]))
        return RecoveryPath(self, self._path_to(found, i, None), goal, False, floor)

    def _direct(self, s: Point, g: Point, m_s: float) -> bool:
        """Is the straight move s -> g a route (the first-leg rule for a start of margin ``m_s``)?"""
        if m_s >= self._thr:
            return self._clear_one(s, g, self._thr)
        if m_s - EPS_M > 0.0:
            return self._clear_one(s, g, m_s - EPS_M)
        return self._certified(s, g, m_s)

    def _last_node(self, found: Search, g: Point | None) -> int:
        """The reached point a shortest route to ``g`` leaves from for ``g`` (the first smallest route length;
        -1: none, or no ``g``): the search's choice where it made it."""
        if g is None:
            return -1
        if found.best is not None:
            return found.best
        dist, pts = found.dist, found.points
        vis = [i for i in self._visible_from(g, self._thr) if dist[i] < math.inf]
        if len(pts) > len(self.nodes) and dist[-1] < math.inf and self._clear_one(pts[-1], g, self._thr):
            vis.append(len(pts) - 1)
        best_i, best_d = -1, math.inf
        for i in vis:
            d = dist[i] + math.hypot(pts[i][0] - g[0], pts[i][1] - g[1])
            if d < best_d:
                best_i, best_d = i, d
        return best_i

    def safe_points(self) -> list[SafePoint]:
        """Points deep inside the free space, largest clearance first.

        The pole of inaccessibility of the whole allowed area, plus one local
        maximum of the margin per lobe (maxima of a 64 x 64 grid of margins,
        refined by polylabel; a maximum is dropped when the straight line to a
        larger kept one keeps 70 % of its clearance: same lobe). Only points in
        the free space (clearance >= c); at most 12. Lobes narrower than a grid
        cell can be missed.
        """
        self._build_graph()
        return list(self._safe)

    def nearest_safe_point(self, start_en: Point) -> tuple[SafePoint, RecoveryPath] | None:
        """The safe point with the shortest admissible route from ``start_en``, and that route.

        ``None`` if no safe point is reachable (see :meth:`plan`'s first-leg rule).
        """
        return self._best_safe(start_en, self.clearance_m)

    def safe_point_with_radius(self, start_en: Point, radius_m: float) -> tuple[SafePoint, RecoveryPath] | None:
        """The nearest (by route length) point where a circle of ``radius_m`` keeps the clearance.

        Returns ``(point, route)`` with ``point.clearance_m >= radius_m + c``, so
        an orbit of radius ``radius_m`` round it keeps margin ``>= c``. Among the
        reachable safe points with enough clearance, the one with the shortest
        route is taken; the route is then cut at its first point whose margin
        reaches ``radius_m + c`` (found by sphere tracing along the route: steps
        of ``max(deficit, ORBIT_CUT_STEP_M)``, which skip no such point by more than that
        since the margin is 1-Lipschitz; the cut point's margin is checked). ``None`` if no
        reachable safe point has that clearance.
        """
        need = float(radius_m) + self.clearance_m
        best = self._best_safe(start_en, need)
        if best is None:
            return None
        sp, path = best
        f = self.fence
        pts = path.points
        for k in range(1, len(pts)):
            (ax, ay), (bx, by) = pts[k - 1], pts[k]
            seg = math.hypot(bx - ax, by - ay)
            u = 0.0
            for _ in range(2000):
                x, y = ax + u * (bx - ax), ay + u * (by - ay)
                m = f.lateral_margin_m(x, y)
                if m >= need:
                    cut = [*pts[:k], (x, y)] if u > 0.0 else pts[:k]
                    return SafePoint(x, y, m), RecoveryPath(self, cut, path.goal_en, True, path.first_leg_floor_m)
                if seg == 0.0:
                    break
                u += max(need - m, ORBIT_CUT_STEP_M) / seg  # sphere tracing: no point with margin >= need is skipped
                if u > 1.0:
                    break
        return sp, path

    def _best_safe(self, start_en: Point, need: float) -> tuple[SafePoint, RecoveryPath] | None:
        self._build_graph()
        want = [(k, sp) for k, sp in zip(self._safe_index, self._safe) if sp.clearance_m >= need]
        if not want:
            return None
        s = (float(start_en[0]), float(start_en[1]))
        found = self._search(s, targets={k for k, _ in want} if self._lazy else None)
        dist = found.dist
        # a direct first leg to a safe point counts too (the graph search already includes it)
        best = min(want, key=lambda kv: dist[kv[0]])
        if dist[best[0]] == math.inf:
            return None
        k, sp = best
        return sp, RecoveryPath(self, self._path_to(found, k, None), sp.en, True, found.floor_m)
