"""Fence-aware recovery routes: a visibility-graph planner over the clearance-offset free space.

The geofence unit used to fly straight at the recovery point, which in concave
fences (L, U, star shapes, corridors) and past keep-outs cuts across forbidden
ground. :class:`RecoveryPlanner` replaces that straight line by the shortest
route (up to the conservatism below) that keeps a lateral clearance ``c`` from
every boundary. Pure planar math in local ENU metres on a
:class:`~geofence.local_fence.LocalFence`; floor gaps and heights are not involved.

Free space and admissibility
----------------------------
``F = {p : lateral_margin_m(p) >= c}``: the keep-in shrunk by ``c`` minus every
keep-out polygon and circle grown by ``c``. A segment is **admissible** when
every point of it is in ``F``. This is decided *exactly* (no sampling): a
segment ``p-q`` with ``margin(p) >= t > 0`` has ``margin >= t`` everywhere iff
its distance to every keep-in/keep-out edge is ``>= t`` and its distance to
every keep-out circle centre is ``>= r + t`` (a segment that stays ``t > 0``
away from every boundary cannot change region, and inside the allowed region
the margin *is* the distance to the nearest boundary). Segment-segment
distances use floating point; a misjudged crossing can only happen within
~1e-12 relative of an endpoint, where the endpoint distance already fails the
test. Thresholds carry :data:`EPS_M` (1e-9 m) of slack for rounding, so an
admissible segment has ``margin >= c - 1e-9`` m everywhere.

The graph
---------
Nodes are the vertices of *circumscribed* polygons around the rounded corners
of the grown obstacles: at each reflex keep-in vertex and each convex
keep-out-polygon vertex, the arc of radius ``c' = c + 1e-6 m`` swept between the
two edge normals is replaced by ``k = ceil(turn / 30 deg)`` tangent pieces (nodes
at ``c' / cos(turn / 2k)`` from the vertex); each circle gets a 16-gon around the
radius ``r + c'``. The circumscribed pieces contain the true Minkowski sum, so
the routes are conservative (at most ~3.5 % longer round a corner, ~2 % round a
circle), and they are tangent to the clearance circles, so consecutive nodes see
each other. Nodes not in ``F`` (covered by another grown obstacle) are dropped.
The safe points (below) are nodes too. Edges join the pairs of nodes whose
segment is admissible (exact test above, vectorized over the pairs with
early rejection) and *tangent* at both corner nodes (the line supports the
node's circumscribed obstacle; a shortest path can only bend at a corner by
wrapping round it, so other edges are never needed: the classic reduced
visibility graph). Per query, the start and goal are joined to every node
they see (no pruning at the ends). Shortest paths: Dijkstra over this graph plus, per query,
the edges from the start and to the goal.

Guarantee of :meth:`RecoveryPlanner.plan`
-----------------------------------------
* Every segment of the returned path **after the first** is admissible
  (``margin >= c - 1e-9`` m everywhere on it); every vertex after the first is
  in ``F``.
* The **first leg** (start -> second point) keeps ``margin >= min(m_s, c) - tol``
  everywhere, where ``m_s`` is the start's margin: it never takes the vehicle
  closer to any boundary than it already is (and for a start in ``F`` it is an
  ordinary admissible segment). ``tol`` is 1e-9 m when ``m_s > 0`` (exact test,
  and the whole leg is inside the allowed area) and :data:`BREACHED_TOL_M`
  (1 mm) when ``m_s <= 0`` (the start is already outside the allowed area: the
  leg is certified by Lipschitz bisection of the 1-Lipschitz margin, i.e. it
  never goes deeper into the breach). The first leg goes to a graph node, to
  the goal, or to an *escape point* found by pushing the start along the
  steepest margin ascent until it is in ``F``.
* If the goal is not in ``F`` it is replaced by the point reached by the same
  margin-ascent push (the exact nearest point of ``F`` when one boundary feature
  binds), or failing that the nearest graph node.
* If the (replaced) goal is not reachable in the start's component of ``F``,
  the path ends at the reachable node nearest to it and
  ``RecoveryPath.reached_goal`` is ``False``. ``plan`` returns ``None`` only when
  no admissible first leg exists (the start's component of ``F`` is not
  reachable from the start under the first-leg rule: e.g. a start in a
  corridor narrower than ``2c``).
* When the start is in ``F`` and the straight segment to the goal is
  admissible, the path is exactly ``[start, goal]``.

Complexity
----------
Build: ``O(V^2 E)`` for ``V`` nodes and ``E`` edges + circles, vectorized and
with failed pairs dropped after each edge chunk (pairs blocked early cost
little); the safe points cost a 64 x 64 grid of margins. Query:
``O(V E)`` vectorized tests to connect the start and goal, then Dijkstra
``O(G log V)`` over ``G`` graph edges.

From :data:`LAZY_MIN_NODES` nodes on (airspace-scale fences: a 10,000-vertex
park has some 12,000), the ``V^2`` pairs are neither stored nor tested at
build: a node's graph edges are found when a search first expands it (the
same tangency filter and exact test, one row of pairs), and the searches stop
early: :meth:`RecoveryPlanner.plan` is A* toward the goal (Euclidean
heuristic, admissible and consistent: the route is still the shortest over
the same graph) and the safe-point searches stop at the first safe point
settled. Same graph, same routes; only the work done differs. The compiled A* takes its first legs from
boxes of nodes released in order of a lower bound of their keys (:func:`_lazy_astar`: not a heap of every
node per search). :meth:`RecoveryPlanner.prepare` (a unit's ``prepare_routes``, before flight) instead files
every node's edges at once (each tangent pair tested once, :func:`_tangent_pairs`) and, for each goal it is
given, the shortest-route tree to it over the whole graph (:func:`_goal_tree`). A search towards a prepared goal
is then no search: the route leaves for the first node, in order of the straight leg plus its route length,
whose leg is clear (:func:`_tree_first_leg`; the elements that blocked the last legs, and those filed in the
node's own cell, are tried first), then follows the tree. The same shortest length over the same graph (to
round-off; ``tests/test_recovery_clear_vector.py``); a 10,000-vertex park with 500 buildings answers in some
30 µs instead of 0.3-1 ms. Per step, :meth:`RecoveryPath.lookahead_point`
is a projection over the path's segments and one or two exact chord tests
(bounding-box filtered loops over the edges): one compiled call
(:data:`path_lookahead`) while the vehicle is inside by more than 1e-9 m, the
Python methods (the reference, and the certified test of a breached start)
otherwise. A segment whose
bounding box holds many edges (a fixed-wing's roll-out route: a straight leg
across the fence to the recovery point, asked once per 10 m cell it enters)
is tested in numpy, with the scalar test's arithmetic (the same verdict).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Iterator, Sequence

import numpy as np

from . import jit as _jit
from .cpython_math import hypot
from .jit import COMPILED, jitable, numba
from .polygon import pole_of_inaccessibility
from .scan_kernel import lateral_margin_scan, rows_view

if TYPE_CHECKING:  # pragma: no cover
    from .local_fence import LocalFence

EPS_M: float = 1e-9
"""Rounding slack (m) in the exact admissibility thresholds."""

NODE_INFLATION_M: float = 1e-6
"""Nodes sit on clearance circles of radius ``c + NODE_INFLATION_M``."""

BREACHED_TOL_M: float = 1e-3
"""Tolerance (m) of the certified first-leg test from a start outside the allowed area."""

ORBIT_CUT_STEP_M: float = 1e-3
"""The smallest step (m) of :meth:`RecoveryPlanner.safe_point_with_radius`'s sphere tracing along a route: its cut
point is the route's first point with the room, to within this (two routes a rounding apart can be cut a step
apart)."""

CORNER_STEP_RAD: float = math.pi / 6.0
"""Largest turn covered by one circumscribed piece at a corner (30 deg)."""

CIRCLE_SIDES: int = 16
"""Sides of the polygon circumscribed round each grown keep-out circle."""

GRID_CELLS: int = 64
"""Safe-point search grid: cells along the keep-in's longer bounding-box side."""

MAX_SAFE_POINTS: int = 12

BBOX_PREFILTER_EDGES: int = 256
"""From this many boundary edges on, the scalar segment test filters edges by bounding box in numpy first."""

VECTOR_FROM_EDGES: int = 24
"""From this many edges in a segment's bounding box on, :meth:`RecoveryPlanner._clear_one` tests them in numpy
(a roll-out route's straight leg across an airspace-scale fence meets thousands); the same answer as the loop."""

NODES_PER_BOX: int = 16
"""About how many graph nodes share a box of the compiled search's first legs (:meth:`RecoveryPlanner._node_boxes`)."""

FULL_GRAPH_MAX_NODES: int = 20_000
"""Up to this many nodes :meth:`RecoveryPlanner.prepare` files a lazy graph's every edge (every pair of nodes is
tested for tangency, about 2 s for the 11,300 nodes of the 10,000 + 500 park); a larger graph stays lazy and its
goals get no shortest-route tree."""

LAZY_MIN_NODES: int = 1500
"""From this many graph nodes on, the graph is built lazily (see the module docstring's Complexity)."""

Point = tuple[float, float]


# ----------------------------------------------------------------------------- scalar helpers
@jitable
def _pt_seg_d2(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    """Squared distance from point p to the closed segment a-b (m²)."""
    dx, dy = bx - ax, by - ay
    qx, qy = px - ax, py - ay
    l2 = dx * dx + dy * dy
    if l2 > 0.0:
        t = (qx * dx + qy * dy) / l2
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
        qx -= t * dx
        qy -= t * dy
    return qx * qx + qy * qy


def segment_segment_distance(p1: Point, p2: Point, q1: Point, q2: Point) -> float:
    """Euclidean distance (m) between the closed segments p1-p2 and q1-q2 (0 if they meet)."""
    if _cross_properly(p1[0], p1[1], p2[0], p2[1], q1[0], q1[1], q2[0], q2[1]):
        return 0.0
    return math.sqrt(
        min(
            _pt_seg_d2(p1[0], p1[1], q1[0], q1[1], q2[0], q2[1]),
            _pt_seg_d2(p2[0], p2[1], q1[0], q1[1], q2[0], q2[1]),
            _pt_seg_d2(q1[0], q1[1], p1[0], p1[1], p2[0], p2[1]),
            _pt_seg_d2(q2[0], q2[1], p1[0], p1[1], p2[0], p2[1]),
        )
    )


@jitable
def _cross_properly(ax, ay, bx, by, cx, cy, dx, dy) -> bool:
    ux, uy = bx - ax, by - ay
    o1 = ux * (cy - ay) - uy * (cx - ax)
    o2 = ux * (dy - ay) - uy * (dx - ax)
    if (o1 > 0.0 and o2 > 0.0) or (o1 < 0.0 and o2 < 0.0):
        return False
    vx, vy = dx - cx, dy - cy
    o3 = vx * (ay - cy) - vy * (ax - cx)
    o4 = vx * (by - cy) - vy * (bx - cx)
    return o1 * o2 < 0.0 and o3 * o4 < 0.0


@jitable
def _edge_blocks(ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float, t2: float) -> bool:
    """Does edge c-d cross the segment a-b properly or come within ``sqrt(t2)`` of it (an end point of either
    within that distance of the other)? The exact per-edge test of :meth:`RecoveryPlanner._clear_one`."""
    if _cross_properly(ax, ay, bx, by, cx, cy, dx, dy):
        return True
    return (
        _pt_seg_d2(ax, ay, cx, cy, dx, dy) < t2
        or _pt_seg_d2(bx, by, cx, cy, dx, dy) < t2
        or _pt_seg_d2(cx, cy, ax, ay, bx, by) < t2
        or _pt_seg_d2(dx, dy, ax, ay, bx, by) < t2
    )


@jitable
def _segment_clear(ax: float, ay: float, bx: float, by: float, thr: float, edges: np.ndarray, circles: np.ndarray) -> bool:
    """:meth:`RecoveryPlanner._clear_one`'s verdict in one loop: no edge row ``(cx, cy, dx, dy, xmin, xmax, ymin,
    ymax)`` crosses a-b or comes within ``thr`` of it, and no circle row ``(x, y, r)`` comes within ``thr``.

    The same tests in the same arithmetic as the scalar loop (:func:`_edge_blocks`), so the same verdict; compiled (:data:`segment_clear`) it is the per-step form of a long leg across a large
    fence, which stops at the first edge in the way.
    """
    t2 = thr * thr
    xmin = (ax if ax <= bx else bx) - thr
    xmax = (ax if ax >= bx else bx) + thr
    ymin = (ay if ay <= by else by) - thr
    ymax = (ay if ay >= by else by) + thr
    for k in range(edges.shape[0]):
        if edges[k, 5] < xmin or edges[k, 4] > xmax or edges[k, 7] < ymin or edges[k, 6] > ymax:
            continue
        cx = edges[k, 0]
        cy = edges[k, 1]
        dx = edges[k, 2]
        dy = edges[k, 3]
        if _edge_blocks(ax, ay, bx, by, cx, cy, dx, dy, t2):
            return False
    for k in range(circles.shape[0]):
        if _circle_blocks(ax, ay, bx, by, thr, xmin, xmax, ymin, ymax, circles, k):
            return False
    return True


@jitable
def _circle_blocks(
    ax: float, ay: float, bx: float, by: float, thr: float, xmin: float, xmax: float, ymin: float, ymax: float,
    circles: np.ndarray, k: int,
) -> bool:  # fmt: skip
    """Does circle row ``k`` come within ``thr`` of a-b (``xmin..ymax``: a-b's bounding box grown by ``thr``)?"""
    cx = circles[k, 0]
    cy = circles[k, 1]
    rr = circles[k, 2] + thr
    if cx + rr < xmin + thr or cx - rr > xmax - thr or cy + rr < ymin + thr or cy - rr > ymax - thr:
        return False
    return _pt_seg_d2(cx, cy, ax, ay, bx, by) < rr * rr


@jitable
def _tangent_at(c0: float, c1: float, c2: float, c3: float, corner: bool, dx: float, dy: float) -> bool:
    """:meth:`RecoveryPlanner._tangent` for one node (its cone ``c0..c3``) and one direction, in its arithmetic."""
    if not corner:
        return True
    px = -dy
    py = dx
    s1 = c0 * py - c1 * px
    s2 = px * c3 - py * c2
    # the tolerance's size lies within [lo, hi]; a cross product outside that band on both sides of zero gets its
    # verdict without the square root (the same verdict: the square root decides only within the band)
    ax = abs(px)
    ay = abs(py)
    lo = 0.5e-9 * (ax if ax > ay else ay)
    hi = 2e-9 * (ax + ay)
    a1 = abs(s1)
    a2 = abs(s2)
    if (a1 < lo or a1 > hi) and (a2 < lo or a2 > hi):
        small1 = a1 < lo
        small2 = a2 < lo
        return ((small1 or s1 > 0.0) and (small2 or s2 > 0.0)) or ((small1 or s1 < 0.0) and (small2 or s2 < 0.0))
    tol = -1e-9 * math.hypot(px, py)
    return (s1 >= tol and s2 >= tol) or (s1 <= -tol and s2 <= -tol)


@jitable
def _tangent_row(i: int, nodes: np.ndarray, cones: np.ndarray, is_corner: np.ndarray) -> np.ndarray:
    """The nodes ``j != i`` whose straight edge to node ``i`` is tangent at both ends (:meth:`RecoveryPlanner._tangent`
    leaving ``i`` along ``nodes[j] - nodes[i]`` and leaving ``j`` along its negation): the candidates of ``i``'s
    graph edges, ascending."""
    n = nodes.shape[0]
    out = np.empty(n, np.int64)
    m = 0
    xi = nodes[i, 0]
    yi = nodes[i, 1]
    for j in range(n):
        if j == i:
            continue
        dx = nodes[j, 0] - xi
        dy = nodes[j, 1] - yi
        if _tangent_at(cones[i, 0], cones[i, 1], cones[i, 2], cones[i, 3], is_corner[i], dx, dy) and _tangent_at(
            cones[j, 0], cones[j, 1], cones[j, 2], cones[j, 3], is_corner[j], -dx, -dy
        ):
            out[m] = j
            m += 1
    return out[:m]


@jitable
def _tangent_pairs(nodes: np.ndarray, cones: np.ndarray, is_corner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every node's :func:`_tangent_row` at once, ``(ptr, cols)``: node ``i``'s candidates are
    ``cols[ptr[i]:ptr[i + 1]]``, ascending, the same as its row. Each pair is tested once: the test is symmetric
    (row ``j`` tests the same two cones along the negated difference, and ``a - b`` is exactly ``-(b - a)``)."""
    n = nodes.shape[0]
    cap = 4 * n + 16
    pa = np.empty(cap, np.int64)
    pb = np.empty(cap, np.int64)
    m = 0
    for a in range(n):
        xa = nodes[a, 0]
        ya = nodes[a, 1]
        c0 = cones[a, 0]
        c1 = cones[a, 1]
        c2 = cones[a, 2]
        c3 = cones[a, 3]
        corner = is_corner[a]
        for b in range(a + 1, n):
            dx = nodes[b, 0] - xa
            dy = nodes[b, 1] - ya
            if _tangent_at(c0, c1, c2, c3, corner, dx, dy) and _tangent_at(
                cones[b, 0], cones[b, 1], cones[b, 2], cones[b, 3], is_corner[b], -dx, -dy
            ):
                if m == cap:
                    cap *= 2
                    qa = np.empty(cap, np.int64)
                    qb = np.empty(cap, np.int64)
                    qa[:m] = pa[:m]
                    qb[:m] = pb[:m]
                    pa = qa
                    pb = qb
                pa[m] = a
                pb[m] = b
                m += 1
    ptr = np.zeros(n + 1, np.int64)
    for k in range(m):
        ptr[pa[k] + 1] += 1
        ptr[pb[k] + 1] += 1
    for i in range(n):
        ptr[i + 1] += ptr[i]
    fill = ptr[:n].copy()
    cols = np.empty(2 * m, np.int64)
    for k in range(m):  # in the order found: a row gets its lower partners first, each side ascending
        a = pa[k]
        b = pb[k]
        cols[fill[a]] = b
        fill[a] += 1
        cols[fill[b]] = a
        fill[b] += 1
    return ptr, cols


@jitable
def _file_row(
    i: int, jj: np.ndarray, P: np.ndarray, node_thr: float, edges: np.ndarray, circles: np.ndarray, x0: float,
    y0: float, cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray, row_start: np.ndarray,
    row_len: np.ndarray, store_j: np.ndarray, store_w: np.ndarray, used: np.ndarray,
) -> bool:  # fmt: skip
    """File node ``i``'s graph edges among its tangent candidates ``jj`` (those whose segment is clear at
    ``node_thr``, :meth:`RecoveryPlanner._neighbours`' test) in the edge store; ``False``: the store is full."""
    ok = _fan_clear_grid(P[i, 0], P[i, 1], P[jj], node_thr, edges, circles, x0, y0, cell, nx, ny, start, items)
    jj = jj[ok]
    m = jj.shape[0]
    if used[0] + m > store_j.shape[0]:
        return False
    at = used[0]
    for k in range(m):
        store_j[at + k] = jj[k]
        store_w[at + k] = np.hypot(P[jj[k], 0] - P[i, 0], P[jj[k], 1] - P[i, 1])
    row_start[i] = at
    row_len[i] = m
    used[0] = at + m
    return True


@jitable
def _file_rows(
    ptr: np.ndarray, cols: np.ndarray, P: np.ndarray, node_thr: float, edges: np.ndarray, circles: np.ndarray,
    x0: float, y0: float, cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray,
    row_start: np.ndarray, row_len: np.ndarray, store_j: np.ndarray, store_w: np.ndarray, used: np.ndarray,
) -> bool:  # fmt: skip
    """:func:`_file_row` for every node not filed yet, its candidates from :func:`_tangent_pairs`; ``False``: the
    store is full (the rows filed so far stay)."""
    for i in range(P.shape[0]):
        if row_start[i] >= 0:
            continue
        if not _file_row(i, cols[ptr[i] : ptr[i + 1]], P, node_thr, edges, circles, x0, y0, cell, nx, ny, start,
                         items, row_start, row_len, store_j, store_w, used):  # fmt: skip
            return False
    return True


SEGMENT_GRID_MIN_EDGES: int = 2000
"""From this many boundary edges on, a planner files its edges and circles in a uniform grid
(:func:`segment_grid`) and its compiled segment test walks the cells along the segment
(:func:`_segment_clear_grid`) instead of looping over every edge: an airspace-scale route search tests hundreds
of first legs per plan."""

SEGMENT_GRID_SLACK_M: float = 0.5
"""Slack (m) of the grid's filing and walking, far beyond any rounding: an element is filed in every cell within
the grid's reach plus this of its bounding box, and the walk visits every cell within this of the segment."""


def segment_grid(
    edges: np.ndarray, circles: np.ndarray, reach_m: float, cell_m: float
) -> tuple[float, float, float, int, int, np.ndarray, np.ndarray]:
    """The uniform grid of :func:`_segment_clear_grid`: ``(x0, y0, cell_m, nx, ny, start, items)``.

    Cell ``(i, j)`` (column ``i`` east from ``x0``, row ``j`` north from ``y0``) lists, in
    ``items[start[j * nx + i]:start[j * nx + i + 1]]``, every edge row (its index) and circle (``len(edges)`` plus
    its index) whose bounding box, grown by ``reach_m`` (the largest test distance the grid answers for) and
    :data:`SEGMENT_GRID_SLACK_M`, overlaps the cell.
    """
    grow = reach_m + SEGMENT_GRID_SLACK_M
    boxes = [edges[:, 4:8]]
    if len(circles):
        x, y, r = circles[:, 0], circles[:, 1], circles[:, 2]
        boxes.append(np.column_stack([x - r, x + r, y - r, y + r]))
    box = np.concatenate(boxes)  # xmin, xmax, ymin, ymax
    x0, y0 = float(box[:, 0].min() - grow), float(box[:, 2].min() - grow)
    nx = int((box[:, 1].max() + grow - x0) // cell_m) + 1
    ny = int((box[:, 3].max() + grow - y0) // cell_m) + 1
    i0 = ((box[:, 0] - grow - x0) // cell_m).astype(np.int64)
    i1 = ((box[:, 1] + grow - x0) // cell_m).astype(np.int64)
    j0 = ((box[:, 2] - grow - y0) // cell_m).astype(np.int64)
    j1 = ((box[:, 3] + grow - y0) // cell_m).astype(np.int64)
    ni, nj = i1 - i0 + 1, j1 - j0 + 1
    count = ni * nj
    owner = np.repeat(np.arange(len(box)), count)
    k = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)  # index within the owner's block
    cells = (np.repeat(j0, count) + k // np.repeat(ni, count)) * nx + np.repeat(i0, count) + k % np.repeat(ni, count)
    order = np.argsort(cells, kind="stable")
    start = np.zeros(nx * ny + 1, np.int64)
    np.cumsum(np.bincount(cells, minlength=nx * ny), out=start[1:])
    return x0, y0, float(cell_m), nx, ny, start, owner[order].astype(np.int64)


@jitable
def _segment_clear_grid(
    ax: float, ay: float, bx: float, by: float, thr: float, edges: np.ndarray, circles: np.ndarray, x0: float,
    y0: float, cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray,
) -> bool:  # fmt: skip
    """:func:`_segment_clear`'s verdict from the elements filed in the cells along a-b (``thr`` at most the
    grid's reach, :func:`segment_grid`), walked from a's end: the same tests, in the same arithmetic, of every
    element that can block (within ``thr`` of a point of the segment, it is filed in that point's cell), some
    others, and a few twice."""
    return _segment_blocker_grid(ax, ay, bx, by, thr, edges, circles, x0, y0, cell, nx, ny, start, items) < 0


@jitable
def _segment_box(ax: float, ay: float, bx: float, by: float, thr: float) -> tuple[float, float, float, float]:
    """``(xmin, xmax, ymin, ymax)``: a-b's bounding box grown by ``thr``."""
    return (
        (ax if ax <= bx else bx) - thr, (ax if ax >= bx else bx) + thr,
        (ay if ay <= by else by) - thr, (ay if ay >= by else by) + thr,
    )  # fmt: skip


@jitable
def _element_blocks(
    ax: float, ay: float, bx: float, by: float, thr: float, box: tuple[float, float, float, float], edges: np.ndarray,
    circles: np.ndarray, k: int,
) -> bool:  # fmt: skip
    """Does element ``k`` (an edge row, or ``len(edges)`` plus a circle row) come within ``thr`` of a-b (``box``:
    :func:`_segment_box`)? :func:`_segment_blocker_grid`'s test of each element it meets, so an element found
    blocking anywhere is found blocking by the walk too (every element within ``thr`` is filed along the segment)."""
    xmin, xmax, ymin, ymax = box
    n_edges = edges.shape[0]
    if k < n_edges:
        if edges[k, 5] < xmin or edges[k, 4] > xmax or edges[k, 7] < ymin or edges[k, 6] > ymax:
            return False
        return _edge_blocks(ax, ay, bx, by, edges[k, 0], edges[k, 1], edges[k, 2], edges[k, 3], thr * thr)
    return _circle_blocks(ax, ay, bx, by, thr, xmin, xmax, ymin, ymax, circles, k - n_edges)


@jitable
def _segment_blocker_grid(
    ax: float, ay: float, bx: float, by: float, thr: float, edges: np.ndarray, circles: np.ndarray, x0: float,
    y0: float, cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray,
) -> int:  # fmt: skip
    """The first element :func:`_segment_clear_grid`'s walk finds within ``thr`` of a-b (an edge row, or
    ``len(edges)`` plus a circle row); -1: the segment is clear."""
    box = _segment_box(ax, ay, bx, by, thr)
    sl = SEGMENT_GRID_SLACK_M
    lo_x = ax if ax <= bx else bx
    hi_x = ax if ax >= bx else bx
    ia = min(max(int((ax - x0) // cell), 0), nx - 1)
    ib = min(max(int((bx - x0) // cell), 0), nx - 1)
    di = 1 if ib >= ia else -1
    for i in range(ia, ib + di, di):
        # the segment's part in column i (its y-range, with the slack)
        c0 = x0 + i * cell
        u0 = c0 if c0 > lo_x else lo_x
        u1 = c0 + cell if c0 + cell < hi_x else hi_x
        if bx != ax:
            ya = ay + (u0 - ax) * (by - ay) / (bx - ax)
            yb = ay + (u1 - ax) * (by - ay) / (bx - ax)
        else:
            ya, yb = ay, by
        ylo = (ya if ya <= yb else yb) - sl
        yhi = (ya if ya >= yb else yb) + sl
        ja = min(max(int((ylo - y0) // cell), 0), ny - 1)
        jb = min(max(int((yhi - y0) // cell), 0), ny - 1)
        if by < ay:
            ja, jb = jb, ja
        dj = 1 if jb >= ja else -1
        for j in range(ja, jb + dj, dj):
            c = j * nx + i
            for p in range(start[c], start[c + 1]):
                if _element_blocks(ax, ay, bx, by, thr, box, edges, circles, items[p]):
                    return int(items[p])
    return -1


@jitable
def _fan_clear_grid(
    ox: float, oy: float, q: np.ndarray, thr: float, edges: np.ndarray, circles: np.ndarray, x0: float, y0: float,
    cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """:func:`_fan_clear_rows`' verdicts by :func:`_segment_clear_grid`, segment by segment (the same verdicts)."""
    out = np.zeros(q.shape[0], np.bool_)
    for i in range(q.shape[0]):
        out[i] = _segment_clear_grid(ox, oy, q[i, 0], q[i, 1], thr, edges, circles, x0, y0, cell, nx, ny, start, items)
    return out


@jitable
def _key_less(keys: np.ndarray, a: int, b: int) -> bool:
    """Is ``(keys[a], a)`` before ``(keys[b], b)``: ascending key, ties by index (a stable sort's order)."""
    return keys[a] < keys[b] or (keys[a] == keys[b] and a < b)


@jitable
def _key_sift_down(heap: np.ndarray, keys: np.ndarray, pos: int, size: int) -> None:
    """Restore the binary min-heap ``heap[:size]`` of indices (ordered by :func:`_key_less`) below ``pos``."""
    while True:
        child = 2 * pos + 1
        if child >= size:
            return
        if child + 1 < size and _key_less(keys, heap[child + 1], heap[child]):
            child += 1
        if not _key_less(keys, heap[child], heap[pos]):
            return
        heap[child], heap[pos] = heap[pos], heap[child]
        pos = child


@jitable
def _key_sift_up(heap: np.ndarray, keys: np.ndarray, pos: int) -> None:
    """Restore the binary min-heap of :func:`_key_sift_down` above ``pos`` (a new entry there)."""
    while pos > 0:
        parent = (pos - 1) // 2
        if not _key_less(keys, heap[pos], heap[parent]):
            return
        heap[parent], heap[pos] = heap[pos], heap[parent]
        pos = parent


@jitable
def _key_pop(heap: np.ndarray, keys: np.ndarray, size: int) -> int:
    """Take the top of the binary min-heap ``heap[:size]`` (of :func:`_key_sift_down`); the heap is then
    ``heap[:size - 1]``."""
    top = heap[0]
    heap[0] = heap[size - 1]
    _key_sift_down(heap, keys, 0, size - 1)
    return top


@jitable
def _key_push(heap: np.ndarray, keys: np.ndarray, size: int, i: int) -> None:
    """Put ``i`` in the binary min-heap ``heap[:size]``; the heap is then ``heap[:size + 1]``."""
    heap[size] = i
    _key_sift_up(heap, keys, size)


@jitable
def _box_distance(x: float, y: float, box: np.ndarray, c: int) -> float:
    """Distance from (x, y) to box ``c`` (``xmin, xmax, ymin, ymax``): at most any of its nodes' (to round-off)."""
    dx = box[c, 0] - x if box[c, 0] > x else (x - box[c, 1] if x > box[c, 1] else 0.0)
    dy = box[c, 2] - y if box[c, 2] > y else (y - box[c, 3] if y > box[c, 3] else 0.0)
    return math.sqrt(dx * dx + dy * dy)


@jitable
def _box_key_bound(sx: float, sy: float, gx: float, gy: float, box: np.ndarray, c: int) -> float:
    """A lower bound of a first leg's key (straight length from the start plus straight length to the goal) over
    the nodes in box ``c`` (``xmin, xmax, ymin, ymax``), below the computed key by more than its round-off."""
    return (_box_distance(sx, sy, box, c) + _box_distance(gx, gy, box, c)) * (1.0 - 1e-12) - 1e-9


@jitable
def _lazy_astar(
    sx: float, sy: float, gx: float, gy: float, thr: float, node_thr: float, P: np.ndarray, cones: np.ndarray,
    is_corner: np.ndarray, goal_d: np.ndarray, edges: np.ndarray, circles: np.ndarray, x0: float, y0: float,
    cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray, row_start: np.ndarray, row_len: np.ndarray,
    store_j: np.ndarray, store_w: np.ndarray, used: np.ndarray, box: np.ndarray, box_start: np.ndarray,
    box_items: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, int, int]:  # fmt: skip
    """:meth:`RecoveryPlanner._search` of a lazy graph with a segment grid, from a start (sx, sy) in the free space
    towards the goal (gx, gy), in one compiled call: ``(dist, pred, first legs found, best node)`` (``first
    legs found`` -1: the edge store is full, grow it and call again; ``best node``: the node of the smallest
    ``dist + goal_d``, the first on a tie, -1 when none is finite).

    The same search step for step: first legs taken in key order (a heap of node indices by
    :func:`_key_less`, the stable sort's order) and tested as their key comes up, the open nodes in a heap of
    ``(key, distance, node)``, the same stops. ``goal_d``: each node's straight length to the goal, infinite
    where it does not see it. A node's graph edges (:meth:`RecoveryPlanner._neighbours`' candidates and tests,
    at ``node_thr``) are found on its first expansion and kept in ``row_start``/``row_len`` (-1: not yet)
    over ``store_j``/``store_w`` (``used[0]`` entries filled), across calls.

    The first legs' heap does not start with every node: the nodes come in boxes (``box``, rows
    ``xmin, xmax, ymin, ymax``; box ``c`` holds ``box_items[box_start[c]:box_start[c + 1]]``), and a box's nodes
    join the heap once the box's lower bound of their keys (:func:`_box_key_bound`) is at most the smallest key
    waiting (first leg or open node). Every node left out has a key above that, so the next first leg and the
    choice between it and the next open node are those of the heap of every node, ties included.
    """
    n = P.shape[0]
    dist = np.full(n, np.inf)
    pred = np.full(n, -1, np.int64)
    leg = np.empty(n)
    keys = np.empty(n)
    touched = np.empty(n, np.int64)  # the nodes given a finite distance, for the best node
    n_touched = 0
    nb = box.shape[0]
    blb = np.empty(nb)
    for c in range(nb):
        blb[c] = _box_key_bound(sx, sy, gx, gy, box, c)
    boxes = np.arange(nb)
    n_boxes = nb
    for pos in range(nb // 2 - 1, -1, -1):
        _key_sift_down(boxes, blb, pos, n_boxes)
    cand = np.empty(n, np.int64)
    size = 0
    open_ = [(0.0, 0.0, 0)]
    open_.pop()
    best_goal = np.inf
    n_first = 0
    while True:
        while n_boxes > 0:  # release the boxes whose nodes can come next
            bound = keys[cand[0]] if size > 0 else np.inf
            if len(open_) > 0 and open_[0][0] < bound:
                bound = open_[0][0]
            if blb[boxes[0]] > bound:
                break
            c = _key_pop(boxes, blb, n_boxes)
            n_boxes -= 1
            for p in range(box_start[c], box_start[c + 1]):
                i = box_items[p]
                ex = P[i, 0] - sx  # (square roots, as the Python search's numpy: the same bits)
                ey = P[i, 1] - sy
                fx = P[i, 0] - gx
                fy = P[i, 1] - gy
                leg[i] = math.sqrt(ex * ex + ey * ey)
                keys[i] = leg[i] + math.sqrt(fx * fx + fy * fy)
                _key_push(cand, keys, size, i)
                size += 1
        if size > 0 and (len(open_) == 0 or keys[cand[0]] < open_[0][0]):  # the next untested first leg first
            i = _key_pop(cand, keys, size)
            size -= 1
            key = keys[i]
            d = leg[i]
            if key >= best_goal:
                break
            if d >= dist[i]:
                continue
            if not _segment_clear_grid(sx, sy, P[i, 0], P[i, 1], thr, edges, circles, x0, y0, cell, nx, ny, start, items):
                continue
            if dist[i] == np.inf:
                touched[n_touched] = i
                n_touched += 1
            dist[i] = d
            pred[i] = -1
            n_first += 1
        elif len(open_) > 0:
            key, d, i = heapq.heappop(open_)
            if d > dist[i]:
                continue
        else:
            break
        if key >= best_goal:
            break  # no open node can shorten the best route found to the goal
        if goal_d[i] < np.inf:
            best_goal = min(best_goal, d + goal_d[i])
        if row_start[i] < 0:  # node i's graph edges, found on its first expansion
            if not _file_row(i, _tangent_row(i, P, cones, is_corner), P, node_thr, edges, circles, x0, y0, cell, nx,
                             ny, start, items, row_start, row_len, store_j, store_w, used):  # fmt: skip
                return dist, pred, -1, -1
        at = row_start[i]
        for k in range(at, at + row_len[i]):
            j = store_j[k]
            nd = d + store_w[k]
            if nd < dist[j]:
                if dist[j] == np.inf:
                    touched[n_touched] = j
                    n_touched += 1
                dist[j] = nd
                pred[j] = i
                heapq.heappush(open_, (nd + hypot(P[j, 0] - gx, P[j, 1] - gy), nd, j))
    best = -1
    best_total = np.inf
    for k in range(n_touched):  # the smallest dist + goal_d, the lowest index on a tie (np.argmin's)
        i = touched[k]
        total = dist[i] + goal_d[i]
        if total < best_total or (total == best_total and i < best):
            best_total = total
            best = i
    return dist, pred, n_first, best


@jitable
def _goal_tree(
    goal_d: np.ndarray, row_start: np.ndarray, row_len: np.ndarray, store_j: np.ndarray, store_w: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(D, nxt)``: every node's shortest route length to the goal over the graph (every row filed) and the next
    node on it (-1: straight to the goal; ``D`` infinite: no route). Dijkstra from the goal over the reversed
    edges: node ``v`` reaches the goal through ``u`` when ``u`` is in ``v``'s row (the forward search's edges,
    each with the length filed in ``v``'s row), starting from ``goal_d`` (the straight lengths of the nodes that
    see the goal)."""
    n = goal_d.shape[0]
    # the reversed rows: who has u in its row, and at what length
    rptr = np.zeros(n + 1, np.int64)
    for v in range(n):
        for k in range(row_start[v], row_start[v] + row_len[v]):
            rptr[store_j[k] + 1] += 1
    for u in range(n):
        rptr[u + 1] += rptr[u]
    fill = rptr[:n].copy()
    rsrc = np.empty(rptr[n], np.int64)
    rw = np.empty(rptr[n])
    for v in range(n):
        for k in range(row_start[v], row_start[v] + row_len[v]):
            u = store_j[k]
            rsrc[fill[u]] = v
            rw[fill[u]] = store_w[k]
            fill[u] += 1
    D = goal_d.copy()
    nxt = np.full(n, -1, np.int64)
    open_ = [(0.0, 0)]
    open_.pop()
    for i in range(n):
        if D[i] < np.inf:
            heapq.heappush(open_, (D[i], i))
    while len(open_) > 0:
        d, u = heapq.heappop(open_)
        if d > D[u]:
            continue
        for k in range(rptr[u], rptr[u + 1]):
            v = rsrc[k]
            nd = d + rw[k]
            if nd < D[v]:
                D[v] = nd
                nxt[v] = u
                heapq.heappush(open_, (nd, v))
    return D, nxt


@jitable
def _tree_first_leg(
    sx: float, sy: float, thr: float, P: np.ndarray, D: np.ndarray, edges: np.ndarray, circles: np.ndarray,
    x0: float, y0: float, cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray, box: np.ndarray,
    box_start: np.ndarray, box_items: np.ndarray, box_d: np.ndarray,
) -> int:  # fmt: skip
    """The node a shortest route from (sx, sy) (in the free space) leaves for: the first node, by ``(leg + D,
    index)``, whose straight leg from the start is clear at ``thr``; -1: none (no route to the goal from here).

    ``D``: :func:`_goal_tree`'s lengths. The nodes come in :func:`_lazy_astar`'s boxes, each released into
    the heap once its lower bound (the start's distance to the box, less its round-off, plus ``box_d``: the
    smallest ``D`` in it) is at most the smallest key waiting: the same order as a heap of every node. A route
    through any later node is no shorter, so with exact ``D`` no other node's first leg is tested."""
    n = P.shape[0]
    nb = box.shape[0]
    blb = np.empty(nb)
    for c in range(nb):
        blb[c] = (_box_distance(sx, sy, box, c) + box_d[c]) * (1.0 - 1e-12) - 1e-9
    boxes = np.arange(nb)
    n_boxes = nb
    for pos in range(nb // 2 - 1, -1, -1):
        _key_sift_down(boxes, blb, pos, n_boxes)
    keys = np.empty(n)
    cand = np.empty(n, np.int64)
    size = 0
    recent = np.empty(8, np.int64)
    n_recent = 0
    next_recent = 0
    while True:
        while n_boxes > 0:
            if blb[boxes[0]] == np.inf or (size > 0 and blb[boxes[0]] > keys[cand[0]]):
                break
            c = _key_pop(boxes, blb, n_boxes)
            n_boxes -= 1
            for p in range(box_start[c], box_start[c + 1]):
                i = box_items[p]
                if D[i] == np.inf:
                    continue
                ex = P[i, 0] - sx
                ey = P[i, 1] - sy
                keys[i] = math.sqrt(ex * ex + ey * ey) + D[i]
                _key_push(cand, keys, size, i)
                size += 1
        if size == 0:
            return -1
        i = _key_pop(cand, keys, size)
        size -= 1
        blocked = False
        box_i = _segment_box(sx, sy, P[i, 0], P[i, 1], thr)
        for r in range(n_recent):  # the elements that blocked the last legs first: nearby legs share them
            if _element_blocks(sx, sy, P[i, 0], P[i, 1], thr, box_i, edges, circles, recent[r]):
                blocked = True
                break
        if not blocked:  # then the elements filed in the node's own cell: a leg to a node is often blocked there
            ci = min(max(int((P[i, 0] - x0) // cell), 0), nx - 1)
            cj = min(max(int((P[i, 1] - y0) // cell), 0), ny - 1)
            c = cj * nx + ci
            for p in range(start[c], start[c + 1]):
                if _element_blocks(sx, sy, P[i, 0], P[i, 1], thr, box_i, edges, circles, items[p]):
                    blocked = True
                    recent[next_recent] = items[p]
                    next_recent = (next_recent + 1) % recent.shape[0]
                    n_recent = n_recent + 1 if n_recent < recent.shape[0] else n_recent
                    break
        if blocked:
            continue
        k = _segment_blocker_grid(sx, sy, P[i, 0], P[i, 1], thr, edges, circles, x0, y0, cell, nx, ny, start, items)
        if k < 0:
            return i
        recent[next_recent] = k
        next_recent = (next_recent + 1) % recent.shape[0]
        n_recent = n_recent + 1 if n_recent < recent.shape[0] else n_recent


FAN_SLACK_M: float = 1e-6
"""Slack (m) of the fans' early exit: an edge is skipped only when it is this much (plus 1e-9 relative) farther
from the fan's origin than the segment's length plus the threshold, far beyond any rounding of the tests."""


def _fan_clear_rows(
    ox: float, oy: float, q: np.ndarray, thr: float, edges: np.ndarray, edge_d: np.ndarray, circles: np.ndarray
) -> np.ndarray:
    """:meth:`RecoveryPlanner._clear_batch`'s verdicts for the segments from (ox, oy) to each row of ``q``: each
    circle row ``(x, y, r)`` first, then the edge rows ``(cx, cy, dx, dy, ...)`` in the given order (by their
    distance ``edge_d`` from the origin, nearest first), with the same per-edge test (:func:`_edge_blocks`, the
    vectorised test's arithmetic); a segment leaves at the first element in its way, or at the first edge
    farther from the origin than its length plus ``thr``: every point of the segment is within its length of
    the origin, so neither that edge nor any after it can cross it or come within ``thr``. An edge whose
    bounding box is more than ``thr`` from the segment's is skipped. Both shortcuts carry
    :data:`FAN_SLACK_M` (beyond any rounding of the per-edge test, so the verdicts are the vectorised test's),
    and spare the far side of a large fence for a short segment."""
    t2 = thr * thr
    out = np.zeros(q.shape[0], np.bool_)
    for i in range(q.shape[0]):
        bx = q[i, 0]
        by = q[i, 1]
        clear = True
        for k in range(circles.shape[0]):
            rr = circles[k, 2] + thr
            if _pt_seg_d2(circles[k, 0], circles[k, 1], ox, oy, bx, by) < rr * rr:
                clear = False
                break
        if clear:
            reach = math.sqrt((bx - ox) * (bx - ox) + (by - oy) * (by - oy)) + thr
            slack = FAN_SLACK_M + 1e-9 * reach
            reach += slack
            grow = thr + slack
            xmin = (ox if ox <= bx else bx) - grow
            xmax = (ox if ox >= bx else bx) + grow
            ymin = (oy if oy <= by else by) - grow
            ymax = (oy if oy >= by else by) + grow
            for k in range(edges.shape[0]):
                if edge_d[k] > reach:
                    break
                if edges[k, 5] < xmin or edges[k, 4] > xmax or edges[k, 7] < ymin or edges[k, 6] > ymax:
                    continue  # the edge's box is more than thr (and the slack) away from the segment's
                if _edge_blocks(ox, oy, bx, by, edges[k, 0], edges[k, 1], edges[k, 2], edges[k, 3], t2):
                    clear = False
                    break
        out[i] = clear
    return out


@jitable
def _lex_less(a0: float, a1: float, a2: float, a3: float, b0: float, b1: float, b2: float, b3: float) -> bool:
    """``(a0, a1, a2, a3) < (b0, b1, b2, b3)`` as Python orders tuples of floats (no NaN)."""
    if a0 != b0:
        return a0 < b0
    if a1 != b1:
        return a1 < b1
    if a2 != b2:
        return a2 < b2
    return a3 < b3


@jitable
def _path_point_at(pts: np.ndarray, cum: np.ndarray, s_m: float) -> tuple[float, float]:
    """:meth:`RecoveryPath.point_at` on the path's arrays (the same arithmetic)."""
    k = pts.shape[0]
    if s_m <= 0.0 or k == 1:
        return pts[0, 0], pts[0, 1]
    if s_m >= cum[k - 1]:
        return pts[k - 1, 0], pts[k - 1, 1]
    i = 0
    while cum[i + 1] < s_m:
        i += 1
    seg = cum[i + 1] - cum[i]
    t = (s_m - cum[i]) / seg if seg > 0.0 else 0.0
    ax = pts[i, 0]
    ay = pts[i, 1]
    return ax + t * (pts[i + 1, 0] - ax), ay + t * (pts[i + 1, 1] - ay)


@jitable
def _path_project(
    pts: np.ndarray, cum: np.ndarray, s0: float, e: float, n: float, thr: float, edges: np.ndarray, circles: np.ndarray
) -> float:
    """:meth:`RecoveryPath.project` on the path's arrays, for a vehicle whose chords are tested exactly: its
    margin exceeds ``thr + EPS_M`` (``thr = min(margin, c) - EPS_M > 0``, :meth:`RecoveryPlanner.chord_ok`'s
    first branch). The same candidates in the same arithmetic, taken nearest first in the order Python sorts
    their tuples (the first of equal ones, as the stable sort), the first four at most. The candidates' arrays
    are rows of one scratch array (one allocation, not five: compiled, each costs about as much as a candidate)."""
    k = pts.shape[0]
    if k == 1:
        return 0.0
    C = np.empty((5, k - 1))
    cd = C[0]  # distance
    cs = C[1]  # arc length
    cx = C[2]
    cy = C[3]
    used = C[4]  # taken (non-zero)
    c = 0
    for i in range(k - 1):
        if cum[i + 1] < s0:
            continue
        ax = pts[i, 0]
        ay = pts[i, 1]
        seg = cum[i + 1] - cum[i]
        lo = (s0 - cum[i]) / seg if (seg > 0.0 and s0 > cum[i]) else 0.0
        dx = pts[i + 1, 0] - ax
        dy = pts[i + 1, 1] - ay
        l2 = dx * dx + dy * dy
        t = ((e - ax) * dx + (n - ay) * dy) / l2 if l2 > 0.0 else 0.0
        t = lo if t < lo else (1.0 if t > 1.0 else t)
        px = ax + t * dx
        py = ay + t * dy
        cd[c] = hypot(e - px, n - py)
        cs[c] = cum[i] + t * seg
        cx[c] = px
        cy[c] = py
        c += 1
    used[:c] = 0.0
    for _ in range(min(4, c)):
        b = -1
        for j in range(c):
            if used[j] == 0.0 and (b < 0 or _lex_less(cd[j], cs[j], cx[j], cy[j], cd[b], cs[b], cx[b], cy[b])):
                b = j
        used[b] = 1.0
        if cd[b] <= EPS_M or _segment_clear(e, n, cx[b], cy[b], thr, edges, circles):
            return cs[b]
    return s0


@jitable
def _path_lookahead(
    pts: np.ndarray,
    cum: np.ndarray,
    s0: float,
    e: float,
    n: float,
    lookahead_m: float,
    thr: float,
    edges: np.ndarray,
    circles: np.ndarray,
) -> tuple[float, float, float]:
    """``(projection, carrot east, carrot north)``: :meth:`RecoveryPath.lookahead_point` on the path's arrays
    for a vehicle whose chords are tested exactly (see :func:`_path_project`); the caller advances the progress."""
    s = _path_project(pts, cum, s0, e, n, thr, edges, circles)
    ce, cn = _path_point_at(pts, cum, s + lookahead_m)
    if _segment_clear(e, n, ce, cn, thr, edges, circles):
        return s, ce, cn
    for i in range(cum.shape[0]):
        if cum[i] > s + EPS_M:
            if _segment_clear(e, n, pts[i, 0], pts[i, 1], thr, edges, circles):
                return s, pts[i, 0], pts[i, 1]
            break
    ce, cn = _path_point_at(pts, cum, s)
    return s, ce, cn


def follower_tables(edges: np.ndarray, circles: np.ndarray, scan: tuple | None) -> tuple[np.ndarray, np.ndarray]:
    """A planner's tables for the compiled route follower, packed in one float and one int array (a compiled call
    pays for every array it takes): its edge rows ``(cx, cy, dx, dy, xmin, xmax, ymin, ymax)`` and circle rows
    ``(x, y, r)`` (:func:`_segment_clear`'s), and for a fence without an index its scan tables ``scan`` (the
    keep-in's rows, the keep-outs' rows and offsets, the circles: ``LocalFence.scan_tables``), with which the
    follower finds the chord threshold itself; ``None``: none (the caller gives the threshold). Int array:
    ``(edges, circles, keep-in rows, keep-out rows, scan circles, has scan, keep-out offsets...)``."""
    ki, ko, offsets, scan_circles = (
        scan if scan is not None else (np.zeros((0, 7)), np.zeros((0, 7)), np.zeros(1), np.zeros((0, 3)))
    )
    floats = np.concatenate([t.ravel() for t in (edges, circles, ki, ko, scan_circles)]).astype(np.float64)
    layout = [len(edges), len(circles), len(ki), len(ko), len(scan_circles), int(scan is not None), *offsets]
    return floats, np.array(layout, dtype=np.int64)


@jitable
def _follower_tables(
    P: np.ndarray, Q: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(edges, circles, keep_in, keep_outs, offsets, scan_circles)`` of :func:`follower_tables`' packed arrays."""
    o = 0
    edges = rows_view(P, o, Q[0], 8)
    o += 8 * Q[0]
    circles = rows_view(P, o, Q[1], 3)
    o += 3 * Q[1]
    keep_in = rows_view(P, o, Q[2], 7)
    o += 7 * Q[2]
    keep_outs = rows_view(P, o, Q[3], 7)
    o += 7 * Q[3]
    scan_circles = rows_view(P, o, Q[4], 3)
    return edges, circles, keep_in, keep_outs, Q[6:], scan_circles


@jitable
def route_arrays(R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(points, arc lengths)`` of a route's packed array (:meth:`RecoveryPath._arrays`: the points' rows, then
    their arc lengths)."""
    k = R.shape[0] // 3
    return rows_view(R, 0, k, 2), R[2 * k :]


def _route_project(R: np.ndarray, P: np.ndarray, Q: np.ndarray, s0: float, e: float, n: float, thr: float) -> float:
    """:func:`_path_project` on a route's and its planner's packed arrays."""
    pts, cum = route_arrays(R)
    edges, circles, _ki, _ko, _off, _sc = _follower_tables(P, Q)
    return _path_project(pts, cum, s0, e, n, thr, edges, circles)


def _route_lookahead(
    R: np.ndarray, P: np.ndarray, Q: np.ndarray, s0: float, e: float, n: float, lookahead_m: float, thr: float
) -> tuple[float, float, float]:
    """:func:`_path_lookahead` on a route's and its planner's packed arrays."""
    pts, cum = route_arrays(R)
    edges, circles, _ki, _ko, _off, _sc = _follower_tables(P, Q)
    return _path_lookahead(pts, cum, s0, e, n, lookahead_m, thr, edges, circles)


@jitable
def _chord_threshold(
    thr: float,
    e: float,
    n: float,
    clearance_m: float,
    keep_in: np.ndarray,
    keep_outs: np.ndarray,
    offsets: np.ndarray,
    scan_circles: np.ndarray,
) -> float:
    """``thr``, or when it is NaN, :meth:`RecoveryPath._exact_chord_threshold`'s ``min(margin, c) - EPS_M`` at (e, n)
    with the margin by the fence's compiled scan (its tables, :func:`_follower_tables`' last four: the number
    ``LocalFence.lateral_margin_m`` gives a fence without an index)."""
    if thr == thr:
        return thr
    m = lateral_margin_scan(e, n, keep_in, keep_outs, offsets, scan_circles)
    return (clearance_m if clearance_m < m else m) - EPS_M


@jitable
def _follower_start(
    P: np.ndarray, Q: np.ndarray, thr: float, e: float, n: float, clearance_m: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """``(thr, edges, circles)``: a compiled follower step's start, the planner's packed tables unpacked and the
    chord threshold found where it is NaN (:func:`_chord_threshold`)."""
    edges, circles, keep_in, keep_outs, offsets, scan_circles = _follower_tables(P, Q)
    return _chord_threshold(thr, e, n, clearance_m, keep_in, keep_outs, offsets, scan_circles), edges, circles


@jitable
def route_rollout(
    R: np.ndarray,
    P: np.ndarray,
    Q: np.ndarray,
    s0: float,
    e: float,
    n: float,
    lookahead_m: float,
    thr: float,
    clearance_m: float,
) -> tuple[float, float, float]:
    """``(thr, east, north)``: :meth:`RecoveryPath.rollout_point` on a route's and its planner's packed arrays for a
    vehicle whose chords are tested exactly (see :func:`_path_project`), the point ``lookahead_m`` past its
    projection; ``thr`` NaN: found from the fence's scan (:func:`_chord_threshold`), and returned; when it is not
    positive, nothing else is computed (the Python methods answer)."""
    thr, edges, circles = _follower_start(P, Q, thr, e, n, clearance_m)
    if not thr > 0.0:
        return thr, 0.0, 0.0
    pts, cum = route_arrays(R)
    ce, cn = _path_point_at(pts, cum, _path_project(pts, cum, s0, e, n, thr, edges, circles) + lookahead_m)
    return thr, ce, cn


@jitable
def route_follow(
    R: np.ndarray,
    P: np.ndarray,
    Q: np.ndarray,
    s0: float,
    e: float,
    n: float,
    lookahead_m: float,
    thr: float,
    clearance_m: float,
) -> tuple[float, float, float, float, float]:
    """``(thr, progress after, carrot east, carrot north, projection after)``: :meth:`RecoveryPath.follow` on a
    route's and its planner's packed arrays for a vehicle whose chords are tested exactly (see
    :func:`_path_project`): :func:`_path_lookahead`, the progress advanced to its projection, then the projection
    from there (:meth:`RecoveryPath.remaining_m`'s); ``thr`` as :func:`route_rollout` takes and returns it."""
    thr, edges, circles = _follower_start(P, Q, thr, e, n, clearance_m)
    if not thr > 0.0:
        return thr, s0, 0.0, 0.0, 0.0
    pts, cum = route_arrays(R)
    s, ce, cn = _path_lookahead(pts, cum, s0, e, n, lookahead_m, thr, edges, circles)
    progress = s if s > s0 else s0
    return thr, progress, ce, cn, _path_project(pts, cum, progress, e, n, thr, edges, circles)


segment_clear = numba.njit(cache=True)(_segment_clear) if COMPILED else None
"""The compiled :func:`_segment_clear` (``None`` without numba: :meth:`RecoveryPlanner._clear_one` loops)."""

segment_clear_grid = numba.njit(cache=True)(_segment_clear_grid) if COMPILED else None
"""The compiled :func:`_segment_clear_grid` (``None`` without numba)."""

fan_clear_grid = numba.njit(cache=True)(_fan_clear_grid) if COMPILED else None
"""The compiled :func:`_fan_clear_grid` (``None`` without numba)."""

lazy_astar = numba.njit(cache=True)(_lazy_astar) if COMPILED else None
"""The compiled :func:`_lazy_astar` (``None`` without numba: :meth:`RecoveryPlanner._search` in Python)."""

tangent_row = numba.njit(cache=True)(_tangent_row) if COMPILED else None
"""The compiled :func:`_tangent_row` (``None`` without numba: :meth:`RecoveryPlanner._neighbours` vectorises)."""

tangent_pairs = numba.njit(cache=True)(_tangent_pairs) if COMPILED else None
"""The compiled :func:`_tangent_pairs` (``None`` without numba: a lazy graph's rows are found as searches expand)."""

file_rows = numba.njit(cache=True)(_file_rows) if COMPILED else None
"""The compiled :func:`_file_rows` (``None`` without numba)."""

goal_tree = numba.njit(cache=True)(_goal_tree) if COMPILED else None
"""The compiled :func:`_goal_tree` (``None`` without numba)."""

tree_first_leg = numba.njit(cache=True)(_tree_first_leg) if COMPILED else None
"""The compiled :func:`_tree_first_leg` (``None`` without numba)."""

fan_clear = numba.njit(cache=True)(_fan_clear_rows) if COMPILED else None
"""The compiled :func:`_fan_clear_rows` (``None`` without numba: :meth:`RecoveryPlanner._fan_clear` vectorises)."""

path_project = numba.njit(cache=True)(_route_project) if COMPILED else None
"""The compiled :func:`_route_project` (``None`` without numba: :meth:`RecoveryPath.project` loops)."""

path_lookahead = numba.njit(cache=True)(_route_lookahead) if COMPILED else None
"""The compiled :func:`_route_lookahead` (``None`` without numba: :meth:`RecoveryPath.lookahead_point` loops)."""

path_rollout = numba.njit(cache=True)(route_rollout) if COMPILED else None
"""The compiled :func:`route_rollout` (``None`` without numba: :meth:`RecoveryPath.rollout_point` loops)."""

path_follow = numba.njit(cache=True)(route_follow) if COMPILED else None
"""The compiled :func:`route_follow` (``None`` without numba: :meth:`RecoveryPath.follow` loops)."""


def _margin_function(fence: "LocalFence") -> Callable[[float, float], float]:
    """``fence.lateral_margin_m`` as a function of ``(e, n)`` for a search that asks it at many points (a safe
    point's polylabel): for a fence without an index, while :data:`geofence.jit.ACTIVE`, the compiled scan with
    its tables bound (:meth:`~geofence.local_fence.LocalFence.lateral_margin_scan_m`'s number, without the
    per-call lookups)."""
    if fence.grid() is not None or not _jit.ACTIVE:
        return fence.lateral_margin_m
    ki, ko, offsets, circles = fence.scan_tables()
    return lambda e, n: lateral_margin_scan(e, n, ki, ko, offsets, circles)


# ----------------------------------------------------------------------------- results
@dataclass(frozen=True)
class SafePoint:
    """A point deep inside the free space: ``(east_m, north_m)`` and its lateral margin ``clearance_m``."""

    east_m: float
    north_m: float
    clearance_m: float

    @property
    def en(self) -> Point:
        return (self.east_m, self.north_m)


class RecoveryPath:
    """A planned polyline, with carrot-chasing helpers (see the module docstring for its guarantee).

    Attributes: ``points`` (list of ``(east_m, north_m)``, start first),
    ``length_m``, ``goal_en`` (the goal asked for), ``reached_goal`` (``False``
    when the path ends at the reachable point nearest an unreachable goal),
    ``first_leg_floor_m`` (the margin guaranteed along the first leg, ``c`` for a
    start in the free space) and ``progress_m`` (arc length of the furthest
    projection so far; :meth:`lookahead_point` advances it, never backwards).
    """

    def __init__(
        self, planner: "RecoveryPlanner", points: Sequence[Point], goal_en: Point, reached_goal: bool, first_leg_floor_m: float
    ) -> None:
        self.planner = planner
        self.points = [(float(p[0]), float(p[1])) for p in points]
        cum = [0.0]
        for (ax, ay), (bx, by) in zip(self.points, self.points[1:]):
            cum.append(cum[-1] + math.hypot(bx - ax, by - ay))
        self.cum_m = cum
        self.length_m = cum[-1]
        self._rows: np.ndarray | None = None  # the compiled follower's array, when it first asks
        self.goal_en = (float(goal_en[0]), float(goal_en[1]))
        self.reached_goal = reached_goal
        self.first_leg_floor_m = first_leg_floor_m
        self.progress_m = 0.0

    def __repr__(self) -> str:
        return f"RecoveryPath({len(self.points)} points, {self.length_m:.1f} m, reached_goal={self.reached_goal})"

    def _arrays(self) -> np.ndarray:
        """The points and their arc lengths packed as the compiled follower's array (the points' rows, then the arc
        lengths: :func:`route_arrays`), built on first use."""
        if self._rows is None:
            self._rows = np.array([c for p in self.points for c in p] + self.cum_m, dtype=np.float64)
        return self._rows

    def point_at(self, s_m: float) -> Point:
        """The path point at arc length ``s_m`` (clamped to the path)."""
        pts, cum = self.points, self.cum_m
        if s_m <= 0.0 or len(pts) == 1:
            return pts[0]
        if s_m >= self.length_m:
            return pts[-1]
        i = 0
        while cum[i + 1] < s_m:
            i += 1
        seg = cum[i + 1] - cum[i]
        t = (s_m - cum[i]) / seg if seg > 0.0 else 0.0
        (ax, ay), (bx, by) = pts[i], pts[i + 1]
        return (ax + t * (bx - ax), ay + t * (by - ay))

    def project(self, e: float, n: float) -> float:
        """Arc length of the projection of (e, n) onto the path, at or after ``progress_m``.

        Candidates are each segment's nearest point (the current segment
        clipped to start at ``progress_m``), nearest first; the first whose
        chord from (e, n) is safe (margin kept ``>= min(margin(e, n), c)``, see
        :meth:`RecoveryPlanner.chord_ok`) wins, so the projection never jumps
        across a wall to a later leg of the path. If none is, ``progress_m``.
        Does not change ``progress_m``. Compiled (:data:`path_project`) while :data:`geofence.jit.ACTIVE` and the
        chords are tested exactly (the vehicle is more than 1e-9 m inside).
        """
        pts, cum = self.points, self.cum_m
        s0 = self.progress_m
        if len(pts) == 1:
            return 0.0
        thr = self._exact_chord_threshold(e, n)
        if thr is not None and path_project is not None:
            planner = self.planner
            return path_project(self._arrays(), *planner._follower, s0, e, n, thr)
        cands = []
        for i in range(len(pts) - 1):
            if cum[i + 1] < s0:
                continue
            (ax, ay), (bx, by) = pts[i], pts[i + 1]
            seg = cum[i + 1] - cum[i]
            lo = (s0 - cum[i]) / seg if (seg > 0.0 and s0 > cum[i]) else 0.0
            dx, dy = bx - ax, by - ay
            l2 = dx * dx + dy * dy
            t = ((e - ax) * dx + (n - ay) * dy) / l2 if l2 > 0.0 else 0.0
            t = lo if t < lo else (1.0 if t > 1.0 else t)
            px, py = ax + t * dx, ay + t * dy
            cands.append((math.hypot(e - px, n - py), cum[i] + t * seg, px, py))
        cands.sort()
        m_v = self.planner.fence.lateral_margin_m(e, n)
        for d, s, px, py in cands[:4]:
            if d <= EPS_M or self.planner.chord_ok((e, n), (px, py), m_v):
                return s
        return s0

    def _exact_chord_threshold(self, e: float, n: float) -> float | None:
        """:meth:`RecoveryPlanner.chord_ok`'s exact threshold ``min(margin, c) - EPS_M`` for chords from (e, n)
        while the compiled follower is active and it is positive; else None (the Python methods)."""
        if not _jit.ACTIVE:
            return None
        planner = self.planner
        t = min(planner.fence.lateral_margin_m(e, n), planner.clearance_m) - EPS_M
        return t if t > 0.0 else None

    def remaining_m(self, e: float, n: float) -> float:
        """Path length (m) left from the projection of (e, n) (see :meth:`project`) to the end."""
        return max(0.0, self.length_m - self.project(e, n))

    def rollout_point(self, e: float, n: float, lookahead_m: float) -> Point:
        """Where a fixed-wing's recovery turn from (e, n) rolls out towards: ``lookahead_m`` along the path past
        the projection of (e, n) (:meth:`project`), with no chord test. Does not change ``progress_m``.

        The turn ends heading for the path a turn's length ahead, not for a point near the vehicle: a vertex
        a few metres away, or behind it, would have the turn swing round with every step (the margin scores
        this turn, :func:`geofence.boundary_shift.activation_margins`, and the guidance flies it,
        :class:`geofence.guidance.FixedWingRecovery`). After the roll-out the guidance follows
        :meth:`lookahead_point`'s carrot, which does test its chord.
        """
        if len(self.points) > 1 and path_rollout is not None:
            args = self._kernel_arguments(e, n)
            if args is not None:
                P, Q, thr, c = args
                thr, ce, cn = path_rollout(self._arrays(), P, Q, self.progress_m, e, n, lookahead_m, thr, c)
                if thr > 0.0:
                    return (ce, cn)
        return self.point_at(self.project(e, n) + lookahead_m)

    def follow(self, e: float, n: float, lookahead_m: float) -> tuple[Point, float]:
        """``(carrot, remaining)``: :meth:`lookahead_point` (which advances ``progress_m``), then :meth:`remaining_m`
        from the advanced progress; a route follower's step in one compiled call (:data:`path_follow`) as
        :meth:`project` is compiled."""
        if path_follow is not None:
            args = self._kernel_arguments(e, n)
            if args is not None:
                P, Q, thr, c = args
                thr, progress, ce, cn, s = path_follow(self._arrays(), P, Q, self.progress_m, e, n, lookahead_m, thr, c)
                if thr > 0.0:
                    self.progress_m = progress
                    return (ce, cn), max(0.0, self.length_m - s)
        carrot = self.lookahead_point(e, n, lookahead_m)
        return carrot, self.remaining_m(e, n)

    def constant_kernel_arguments(self) -> tuple | None:
        """:meth:`_kernel_arguments` where they do not depend on the position (a fence without an index, while
        :data:`geofence.jit.ACTIVE`), else None."""
        planner = self.planner
        return planner._follower_scan_arguments if planner._follower_scans and _jit.ACTIVE else None

    def _kernel_arguments(self, e: float, n: float) -> tuple | None:
        """``(P, Q, thr, clearance)``: the planner's packed tables (:func:`follower_tables`) and the chord
        threshold of :data:`path_rollout` and :data:`path_follow` for a vehicle at (e, n). For a fence without an
        index ``thr`` is NaN: the compiled call finds :meth:`_exact_chord_threshold` itself (one call less per step;
        the planner keeps these arguments made). None: the Python methods (not :data:`geofence.jit.ACTIVE`, or no
        positive threshold)."""
        planner = self.planner
        if planner._follower_scans:
            return planner._follower_scan_arguments if _jit.ACTIVE else None
        thr = self._exact_chord_threshold(e, n)
        return None if thr is None else (*planner._follower, thr, planner.clearance_m)

    def lookahead_point(self, e: float, n: float, lookahead_m: float) -> Point:
        """The carrot for a vehicle at (e, n): ``lookahead_m`` along the path past its projection.

        Advances ``progress_m`` to the projection. If the chord from (e, n) to
        the carrot is not safe (:meth:`RecoveryPlanner.chord_ok`: it would cut a
        corner), the next path vertex after the projection is returned instead,
        and if that chord is not safe either, the projection point itself. The
        returned point always lies on the path (so in the free space, except on
        the first leg). Compiled (:data:`path_lookahead`) as :meth:`project` is.
        """
        thr = self._exact_chord_threshold(e, n)
        if thr is not None and path_lookahead is not None:
            planner = self.planner
            s, ce, cn = path_lookahead(self._arrays(), *planner._follower, self.progress_m, e, n, lookahead_m, thr)
            if s > self.progress_m:
                self.progress_m = s
            return (ce, cn)
        s = self.project(e, n)
        if s > self.progress_m:
            self.progress_m = s
        carrot = self.point_at(s + lookahead_m)
        m_v = self.planner.fence.lateral_margin_m(e, n)
        if self.planner.chord_ok((e, n), carrot, m_v):
            return carrot
        for i, c in enumerate(self.cum_m):
            if c > s + EPS_M:
                v = self.points[i]
                if self.planner.chord_ok((e, n), v, m_v):
                    return v
                break
        return self.point_at(s)


# ----------------------------------------------------------------------------- planner
class RecoveryPlanner:
    """Shortest admissible routes inside a :class:`LocalFence` with lateral clearance ``clearance_m`` (> 0).

    Built once per fence and clearance; :meth:`plan`, :meth:`nearest_safe_point` and
    :meth:`safe_point_with_radius` answer at activation time. See the module
    docstring for the guarantee. The graph's nodes (corner nodes and safe points) and, unless ``lazy``, its
    edges are built on the first question that needs them (:meth:`_build_graph`): a route whose straight
    segment is clear needs none (most of a convex fence's). ``lazy``: find each node's edges on its first
    use (``None``: from :data:`LAZY_MIN_NODES` nodes on); the routes are the same either way. ``grid``: file the
    edges in a grid for the compiled segment tests (:func:`segment_grid`; ``None``: from
    :data:`SEGMENT_GRID_MIN_EDGES` edges on); the same verdicts either way.
    """

    def __init__(self, fence: "LocalFence", clearance_m: float, *, lazy: bool | None = None, grid: bool | None = None) -> None:
        c = float(clearance_m)
        if not (c > 0.0 and math.isfinite(c)):
            raise ValueError(f"clearance_m must be finite and > 0, got {clearance_m!r}")
        self.fence = fence
        self.clearance_m = c
        self._thr = c - EPS_M
        # ---- boundary edges (keep-in + keep-out polygons) and circles
        polys = [fence.keep_in, *fence.keep_out_polygons]
        a = np.concatenate([p.starts for p in polys])
        b = np.concatenate([p.ends for p in polys])
        self._ea, self._eb = a, b
        self._edges = tuple(
            (float(ax), float(ay), float(bx), float(by), min(ax, bx), max(ax, bx), min(ay, by), max(ay, by))
            for (ax, ay), (bx, by) in zip(a.tolist(), b.tolist())
        )
        self._edge_rows = np.array(self._edges, dtype=float).reshape(-1, 8)  # the compiled tests' rows
        self._ebox = self._edge_rows[:, 4:]  # xmin, xmax, ymin, ymax
        self._circles = tuple((float(x), float(y), float(r)) for x, y, r in fence.keep_out_circles)
        self._circle_rows = np.array(self._circles, dtype=float).reshape(-1, 3)
        # the compiled follower's tables; with the fence's scan tables (no index) it finds the chord threshold itself
        self._follower_scans = fence.grid() is None
        self._follower = follower_tables(
            self._edge_rows, self._circle_rows, fence.scan_tables() if self._follower_scans else None
        )
        self._follower_scan_arguments = (*self._follower, math.nan, c)  # RecoveryPath._kernel_arguments' (no index)
        self._cc, self._cr = self._circle_rows[:, :2], self._circle_rows[:, 2]
        # a fixed shuffled edge order spreads each chunk over the whole fence (earlier rejection)
        self._perm = np.random.default_rng(12345).permutation(len(a))
        self._lazy_choice = lazy
        self._graph_built = False
        self._grid: tuple | None = None  # the segment test's grid (:meth:`_segment_grid`; (): none)
        self._grid_choice = grid
        self._goal_margin: tuple[Point, float] | None = None  # the last goal :meth:`plan` was asked and its margin

    def prepare(self, goals: Sequence[Point] = ()) -> None:
        """Build the graph (its nodes and edges, a lazy graph's too where it is compiled with a segment grid and has
        at most :data:`FULL_GRAPH_MAX_NODES` nodes), the segment grid and, over a whole graph, the goals' visible
        nodes and shortest-route trees now, not at the first question that needs them. The same graph and
        routes as short: only when the work is done differs."""
        self._build_graph()
        grid = self._segment_grid()
        whole = len(self._node_list) <= FULL_GRAPH_MAX_NODES and self._lazy and grid is not None and _jit.ACTIVE
        if whole and tangent_pairs is not None and file_rows is not None and grid is not None:
            ptr, cols = tangent_pairs(self._nodes, self._cones, self._is_corner)
            row_start, row_len, store_j, store_w, used = self._edge_store()
            if int(used[0]) + len(cols) > len(store_j):
                self._grow_edge_store(len(cols))
            row_start, row_len, store_j, store_w, used = self._edge_store()
            done = file_rows(ptr, cols, self._nodes, self._thr, self._edge_rows, self._circle_rows, *grid, row_start,
                             row_len, store_j, store_w, used)  # fmt: skip
            assert done  # (room for every candidate)
            self._full_graph = True
        if not (self._full_graph and goal_tree is not None):
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
        """``(D, nxt, box_d)``: :func:`_goal_tree` of ``goal`` over the whole graph, and each of
        :meth:`_node_boxes`' smallest ``D``."""
        goal_d = self._goal_lengths(goal, self._goal_nodes_of(goal))
        row_start, row_len, store_j, store_w, _ = self._edge_store()
        assert goal_tree is not None
        D, nxt = goal_tree(goal_d, row_start, row_len, store_j, store_w)
        _, box_start, box_items = self._node_boxes()
        box_d = np.minimum.reduceat(D[box_items], box_start[:-1])
        return D, nxt, box_d

    def _tree_route(self, s: Point, g: Point, goal: Point) -> RecoveryPath | None:
        """The shortest route from ``s`` (in the free space) to ``g`` by its goal tree (:meth:`prepare`'s): the
        first leg :func:`_tree_first_leg` finds, then the tree's next nodes. ``None``: no tree for ``g``, or no
        route to it from ``s`` (the search finds the partial route)."""
        tree = self._trees.get(g)
        grid = self._segment_grid()
        if tree is None or grid is None or tree_first_leg is None or not _jit.ACTIVE:
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
        corner = [p for p in self._corner_nodes() if fence.lateral_margin_m(p[0], p[1]) >= self._thr]
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
        # a lazy graph's edges as found, as arrays (:meth:`_edge_store`): the compiled search's, and the Python's
        self._store: tuple[np.ndarray, ...] | None = None
        self._boxes: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._full_graph = False  # a lazy graph's every row filed (:meth:`prepare`)
        self._trees: dict[Point, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}  # goal -> :meth:`_goal_tree`
        self._lazy: bool = nn >= LAZY_MIN_NODES if lazy is None else bool(lazy)
        self._adj: list[list[tuple[int, float]] | None] = [None if self._lazy else [] for _ in nodes]
        if nn >= 2 and not self._lazy:
            ii, jj = np.triu_indices(nn, k=1)
            d = self._nodes[jj] - self._nodes[ii]
            keep = self._tangent(ii, d) & self._tangent(jj, -d)
            ii, jj = ii[keep], jj[keep]
            ok = self._clear_batch(self._nodes[ii], self._nodes[jj], self._thr)
            adj: list[list[tuple[int, float]]] = [[] for _ in nodes]
            for i, j in zip(ii[ok].tolist(), jj[ok].tolist()):
                w = math.hypot(nodes[i][0] - nodes[j][0], nodes[i][1] - nodes[j][1])
                adj[i].append((j, w))
                adj[j].append((i, w))
            self._adj = list(adj)

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

    def _neighbours(self, i: int) -> list[tuple[int, float]]:
        """Node ``i``'s graph edges ``(j, length)``: precomputed, or for a lazy graph found on first use (by this
        method or by the compiled search, :func:`_lazy_astar`: one edge store for both, :meth:`_edge_store`)."""
        row = self._adj[i]
        if row is None:
            row_start, row_len, store_j, store_w, _ = self._edge_store()
            at = int(row_start[i])
            if at >= 0:  # found by the compiled search
                row = list(zip(store_j[at : at + row_len[i]].tolist(), store_w[at : at + row_len[i]].tolist()))
            else:
                d = self._nodes - self._nodes[i]
                if _jit.ACTIVE and tangent_row is not None:
                    jj = tangent_row(i, self._nodes, self._cones, self._is_corner)
                else:
                    idx = np.arange(len(self.nodes))
                    jj = idx[(idx != i) & self._tangent(np.full(len(idx), i), d) & self._tangent(idx, -d)]
                ok = self._fan_clear(self._nodes[i], self._nodes[jj], self._thr)
                jj = jj[ok]
                w = np.hypot(d[jj, 0], d[jj, 1])
                self._store_row(i, jj, w)
                row = list(zip(jj.tolist(), w.tolist()))
            self._adj[i] = row
        return row

    def _edge_store(self) -> tuple[np.ndarray, ...]:
        """The lazy graph's edges as arrays, ``(row_start, row_len, store_j, store_w, used)``: node ``i``'s edges are
        ``store_j[row_start[i]:][:row_len[i]]`` (other nodes) and ``store_w`` (lengths), ``row_start[i]`` -1 until
        found; ``used[0]`` entries filled. :func:`_lazy_astar` fills it in place."""
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
    def _corner_nodes(self) -> list[tuple[float, float, float, float, float, float]]:
        """Corner nodes ``(east, north, n1e, n1n, n2e, n2n)``: the point and its normal cone (n1 -> n2)."""
        cp = self.clearance_m + NODE_INFLATION_M
        out: list[tuple[float, float, float, float, float, float]] = []

        def arc(vx: float, vy: float, a0: float, delta: float, radius: float, k: int = 0) -> None:
            # node j: corner of the tangent lines at angles a0 + j·delta/k and a0 + (j+1)·delta/k
            k = k or max(1, math.ceil(abs(delta) / CORNER_STEP_RAD - 1e-12))
            dist = radius / math.cos(abs(delta) / (2 * k))
            sg = 1.0 if delta >= 0.0 else -1.0
            for j in range(k):
                ang = a0 + (j + 0.5) * delta / k
                a1, a2 = a0 + j * delta / k, a0 + (j + 1) * delta / k
                # the two normals, ordered counter-clockwise (cone from n1 to n2)
                if sg < 0.0:
                    a1, a2 = a2, a1
                out.append(
                    (vx + dist * math.cos(ang), vy + dist * math.sin(ang), math.cos(a1), math.sin(a1), math.cos(a2), math.sin(a2))
                )

        def polygon(p, free_side: float) -> None:
            # free_side=+1: free space is the polygon's interior (keep-in); -1: its exterior (keep-out)
            v = p.vertices
            sgn = 1.0 if p.ccw else -1.0
            nv = len(v)
            for i in range(nv):
                px, py = float(v[i - 1, 0]), float(v[i - 1, 1])
                vx, vy = float(v[i, 0]), float(v[i, 1])
                qx, qy = float(v[(i + 1) % nv, 0]), float(v[(i + 1) % nv, 1])
                d1x, d1y, d2x, d2y = vx - px, vy - py, qx - vx, qy - vy
                l1, l2 = math.hypot(d1x, d1y), math.hypot(d2x, d2y)
                if l1 == 0.0 or l2 == 0.0:
                    continue
                turn = sgn * (d1x * d2y - d1y * d2x)  # > 0: convex corner of the polygon
                if free_side > 0.0 and turn >= 0.0:
                    continue  # convex keep-in corner: no obstacle corner to wrap round
                if free_side < 0.0 and turn <= 0.0:
                    continue  # reflex keep-out corner
                # normals pointing into the free space (inward for keep-in, outward for keep-out)
                k = free_side * sgn
                n1x, n1y = -k * d1y / l1, k * d1x / l1
                n2x, n2y = -k * d2y / l2, k * d2x / l2
                delta = math.atan2(n1x * n2y - n1y * n2x, n1x * n2x + n1y * n2y)
                arc(vx, vy, math.atan2(n1y, n1x), delta, cp)

        polygon(self.fence.keep_in, 1.0)
        for p in self.fence.keep_out_polygons:
            polygon(p, -1.0)
        for x, y, r in self._circles:
            arc(x, y, -math.pi / CIRCLE_SIDES, 2.0 * math.pi, r + cp, CIRCLE_SIDES)
        return out

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

    def _tangent(self, idx: np.ndarray, d: np.ndarray) -> np.ndarray:
        """For nodes ``idx`` and directions ``d`` (leaving them): can a shortest path use that direction there?

        A shortest path only bends at a corner node by wrapping round it: the
        line through the node along ``d`` must support the node's local
        (circumscribed) obstacle, i.e. a normal of the line lies in the node's
        normal cone. Non-corner nodes (safe points) accept every direction.
        Collinear cases (within 1e-9 relative) count as tangent.
        """
        c = self._cones[idx]
        px, py = -d[:, 1], d[:, 0]  # a normal of the line
        tol = -1e-9 * np.hypot(px, py)
        s1 = c[:, 0] * py - c[:, 1] * px  # cross(n1, m)
        s2 = px * c[:, 3] - py * c[:, 2]  # cross(m, n2)
        in_cone = ((s1 >= tol) & (s2 >= tol)) | ((s1 <= -tol) & (s2 <= -tol))
        return in_cone | ~self._is_corner[idx]

    # ------------------------------------------------------------------ exact segment tests
    def _segment_grid(self) -> tuple | None:
        """The grid of the compiled segment test (:func:`segment_grid`, reach: the clearance; cells of the
        clearance, at least 25 m), made on first use; ``None`` without one (the planner's ``grid`` argument; by
        default from :data:`SEGMENT_GRID_MIN_EDGES` edges on)."""
        if self._grid is None:
            choice = self._grid_choice
            if not len(self._edge_rows) or not (len(self._edge_rows) >= SEGMENT_GRID_MIN_EDGES if choice is None else choice):
                self._grid = ()
            else:
                c = self.clearance_m
                self._grid = segment_grid(self._edge_rows, self._circle_rows, c, max(c, 25.0))
        return self._grid or None

    def _clear_one(self, p: Point, q: Point, thr: float, *, vector_from: int | None = None) -> bool:
        """Exact: with ``margin(p) >= thr > 0`` (caller's duty), is ``margin >= thr`` all along p-q?

        ``vector_from``: from this many boundary edges in the segment's bounding box on, they are tested
        by :func:`_edges_block_np` (the same arithmetic, vectorized; ``None``: :data:`VECTOR_FROM_EDGES`); a
        huge value loops over them in Python (the reference). ``None`` while :data:`geofence.jit.ACTIVE`:
        the compiled loop (:data:`segment_clear`, the same verdict; with the planner's grid, from its cells
        along the segment, :data:`segment_clear_grid`).
        """
        ax, ay = p
        bx, by = q
        if vector_from is None and _jit.ACTIVE and segment_clear is not None:
            grid = self._segment_grid()
            if grid is not None and thr <= self.clearance_m and segment_clear_grid is not None:
                return segment_clear_grid(ax, ay, bx, by, thr, self._edge_rows, self._circle_rows, *grid)
            return segment_clear(ax, ay, bx, by, thr, self._edge_rows, self._circle_rows)
        t2 = thr * thr
        xmin, xmax = min(ax, bx) - thr, max(ax, bx) + thr
        ymin, ymax = min(ay, by) - thr, max(ay, by) + thr
        edges = self._edges
        if len(edges) > BBOX_PREFILTER_EDGES:  # large fences: the bounding-box test vectorized first
            b = self._ebox
            hit = np.flatnonzero((b[:, 1] >= xmin) & (b[:, 0] <= xmax) & (b[:, 3] >= ymin) & (b[:, 2] <= ymax))
            if len(hit) >= (VECTOR_FROM_EDGES if vector_from is None else vector_from):
                if _edges_block_np(ax, ay, bx, by, self._ea[hit], self._eb[hit], t2):
                    return False
                edges = ()
            else:
                edges = tuple(edges[k] for k in hit.tolist())
        for cx, cy, dx, dy, exmin, exmax, eymin, eymax in edges:
            if exmax < xmin or exmin > xmax or eymax < ymin or eymin > ymax:
                continue
            if _edge_blocks(ax, ay, bx, by, cx, cy, dx, dy, t2):
                return False
        for cx, cy, r in self._circles:
            rr = r + thr
            if cx + rr < xmin + thr or cx - rr > xmax - thr or cy + rr < ymin + thr or cy - rr > ymax - thr:
                continue
            if _pt_seg_d2(cx, cy, ax, ay, bx, by) < rr * rr:
                return False
        return True

    def _clear_batch(
        self, p: np.ndarray, q: np.ndarray, thr: float, block: int = 8192, chunk: int = 48, edge_order: np.ndarray | None = None
    ) -> np.ndarray:
        """Vectorized :meth:`_clear_one` for (M, 2) arrays of endpoints; returns (M,) bool.

        ``edge_order``: the boundary edges to test, in that order (default: all,
        in a fixed shuffled order); the caller guarantees that the others can
        neither cross nor come within ``thr`` of any of the segments.
        """
        m = len(p)
        out = np.zeros(m, dtype=bool)
        t2 = thr * thr
        order = self._perm if edge_order is None else edge_order
        ea, eb = self._ea[order], self._eb[order]
        for s in range(0, m, block):
            idx = np.arange(s, min(m, s + block))
            # circles first (cheap, few)
            if len(self._cr):
                pa, pb = p[idx], q[idx]
                d2 = _pt_seg_d2_np(self._cc[None, :, :], pa[:, None, :], pb[:, None, :])
                idx = idx[np.all(d2 >= (self._cr[None, :] + thr) ** 2, axis=1)]
            for k in range(0, len(ea), chunk):
                if len(idx) == 0:
                    break
                pa, pb = p[idx][:, None, :], q[idx][:, None, :]
                ca, cb = ea[None, k : k + chunk, :], eb[None, k : k + chunk, :]
                bad = _cross_np(pa, pb, ca, cb)
                bad |= _pt_seg_d2_np(pa, ca, cb) < t2
                bad |= _pt_seg_d2_np(pb, ca, cb) < t2
                bad |= _pt_seg_d2_np(ca, pa, pb) < t2
                bad |= _pt_seg_d2_np(cb, pa, pb) < t2
                idx = idx[~bad.any(axis=1)]
            out[idx] = True
        return out

    def _fan_clear(self, origin: np.ndarray, q: np.ndarray, thr: float) -> np.ndarray:
        """:meth:`_clear_batch` for the segments from one ``origin`` to each row of ``q`` (exact).

        Every point of a segment lies within its length ``L`` of the origin, so
        an edge farther than ``max L + thr`` from the origin can neither cross
        one nor come within ``thr``: those edges are dropped, and the rest are
        tested nearest first (near edges block most directions of a fan, so
        blocked segments leave after the first chunk). While :data:`geofence.jit.ACTIVE`, the compiled
        :data:`fan_clear` gives the same verdicts segment by segment.
        """
        if len(q) == 0:
            return np.zeros(0, dtype=bool)
        if _jit.ACTIVE and fan_clear_grid is not None and thr <= self.clearance_m:
            grid = self._segment_grid()
            if grid is not None:  # compiled: each segment walks the grid's cells from the origin
                o = np.asarray(origin, dtype=float)
                return fan_clear_grid(
                    float(o[0]), float(o[1]), np.ascontiguousarray(q, dtype=float), thr, self._edge_rows,
                    self._circle_rows, *grid,
                )  # fmt: skip
        reach = float(np.sqrt(((q - origin) ** 2).sum(axis=1).max())) + thr
        d2 = _pt_seg_d2_np(origin, self._ea, self._eb)
        near = np.flatnonzero(d2 <= reach * reach)
        order = near[np.argsort(d2[near], kind="stable")]
        if _jit.ACTIVE and fan_clear is not None:  # compiled: each segment stops at its first blocking element
            o = np.asarray(origin, dtype=float)
            return fan_clear(
                float(o[0]), float(o[1]), np.ascontiguousarray(q, dtype=float), thr, self._edge_rows[order],
                np.sqrt(d2[order]), self._circle_rows,
            )  # fmt: skip
        return self._clear_batch(np.broadcast_to(origin, q.shape), q, thr, edge_order=order)

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

    # ------------------------------------------------------------------ queries
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
    ):
        """Dijkstra from s with the first-leg rule. Returns a context dict (``None``: no first leg).

        For a lazy graph the search stops early: with ``goal`` and ``goal_nodes``
        (node -> straight length to the goal, the nodes that see it) it is A*
        and stops once no open node can improve the best route to the goal; with
        ``targets`` it stops when the first target is settled. An eager graph is
        searched in full (every reachable node gets its distance).
        """
        f = self.fence
        m_s = f.lateral_margin_m(s[0], s[1])
        nodes = self.nodes
        nn = len(nodes)
        in_free = m_s >= self._thr
        floor = self.clearance_m if in_free else m_s
        extra: list[Point] = []  # per-query nodes: the escape point
        if not in_free:
            x = self._push_into_free(s[0], s[1])
            if x is not None:
                extra.append(x)
        allpts = nodes + extra
        if (
            in_free
            and self._lazy
            and goal is not None
            and goal_nodes is not None
            and targets is None
            and _jit.ACTIVE
            and lazy_astar is not None
            and self._segment_grid() is not None
        ):
            return self._search_compiled(s, goal, goal_nodes, m_s, allpts)
        if goal is not None and goal_nodes is not None and extra and self._clear_one(extra[0], goal, self._thr):
            goal_nodes = {**goal_nodes, nn: math.hypot(extra[0][0] - goal[0], extra[0][1] - goal[1])}
        # first legs
        lazy = self._lazy
        untested: Iterator[tuple[list, list, list]] | None = None  # lazy first legs: (keys, lengths, nodes) chunks
        thr = self._thr
        if in_free or m_s - EPS_M > 0.0:
            thr = self._thr if in_free else m_s - EPS_M
            if lazy and nn:
                # a first leg to a node is tested only when its key comes up: the same search (the straight leg is
                # the shortest way to its node, so its key is the node's best), without a fan to every node
                first = [nn] if extra and self._clear_one(s, extra[0], thr) else []
                P = self._nodes
                ex, ey = P[:, 0] - s[0], P[:, 1] - s[1]
                leg = np.sqrt(ex * ex + ey * ey)
                if goal is not None:
                    fx, fy = P[:, 0] - goal[0], P[:, 1] - goal[1]
                    keys = leg + np.sqrt(fx * fx + fy * fy)
                else:
                    keys = leg
                untested = _by_key_in_chunks(keys, leg)
            else:
                cand = self._visible_from(s, thr)
                if extra and self._clear_one(s, extra[0], thr):
                    cand.append(nn)
                first = cand
        else:
            order_ = sorted(range(len(allpts)), key=lambda i: math.hypot(allpts[i][0] - s[0], allpts[i][1] - s[1]))
            if extra:
                order_.remove(nn)
                order_.insert(0, nn)
            first = [i for i in order_[:32] if self._certified(s, allpts[i], m_s)]
        dist = [math.inf] * len(allpts)
        pred = [-1] * len(allpts)
        heap = []
        for i in first:
            d = math.hypot(allpts[i][0] - s[0], allpts[i][1] - s[1])
            dist[i] = d
            heap.append((d, i))
        if lazy and goal is not None:  # A*: keys are distance + straight line to the goal (consistent)
            gx, gy = goal

            def h(k: int) -> float:
                return math.hypot(allpts[k][0] - gx, allpts[k][1] - gy)
        else:

            def h(k: int) -> float:
                return 0.0

        open_ = [(d + h(i), d, i) for d, i in heap]
        heapq.heapify(open_)
        extra_adj = None
        best_goal = math.inf
        u_key: list[float] = []
        u_leg: list[float] = []
        u_node: list[int] = []
        u = nu = 0
        while True:
            if u == nu and untested is not None:  # the next chunk of untested first legs, by key
                chunk = next(untested, None)
                if chunk is None:
                    untested = None
                else:
                    u_key, u_leg, u_node = chunk
                    u, nu = 0, len(u_key)
            if u < nu and (not open_ or u_key[u] < open_[0][0]):  # the next untested first leg comes first
                key, d, i = u_key[u], u_leg[u], u_node[u]
                u += 1
                if goal_nodes is not None and key >= best_goal:
                    break  # (as below)
                if d >= dist[i]:
                    continue  # reached as short already
                if not self._clear_one(s, allpts[i], thr):
                    continue
                dist[i] = d
                pred[i] = -1
                first.append(i)
            elif open_:
                key, d, i = heapq.heappop(open_)
                if d > dist[i]:
                    continue
            else:
                break
            if lazy:
                if goal_nodes is not None and key >= best_goal:
                    break  # no open node can shorten the best route found to the goal
                if targets is not None and i in targets:
                    break  # the nearest target (by route) is settled
                if goal_nodes is not None and i in goal_nodes:
                    best_goal = min(best_goal, d + goal_nodes[i])
            if i < nn:
                nbrs = self._neighbours(i)
            else:
                if extra_adj is None:
                    extra_adj = [
                        (j, math.hypot(nodes[j][0] - extra[0][0], nodes[j][1] - extra[0][1]))
                        for j in self._visible_from(extra[0], self._thr)
                    ]
                nbrs = extra_adj
            for j, w in nbrs:
                nd = d + w
                if nd < dist[j]:
                    dist[j] = nd
                    pred[j] = i
                    heapq.heappush(open_, (nd + h(j), nd, j))
        return {
            "s": (float(s[0]), float(s[1])),
            "m_s": m_s,
            "in_free": in_free,
            "floor": floor,
            "pts": allpts,
            "dist": dist,
            "pred": pred,
            "first": set(first),
        }

    def _search_compiled(self, s: Point, goal: Point, goal_nodes: dict[int, float], m_s: float, allpts: list[Point]):
        """:meth:`_search`'s A* from a start in the free space, in one compiled call (:func:`_lazy_astar`, the same
        search); its context carries ``dist`` and ``pred`` as arrays, ``first`` as the count of first legs."""
        goal_d = self._goal_lengths(goal, goal_nodes)
        grid = self._segment_grid()
        assert grid is not None and lazy_astar is not None  # (the caller's conditions)
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
        return {"s": s, "m_s": m_s, "in_free": True, "floor": self.clearance_m, "pts": allpts, "dist": dist,
                "pred": pred, "first": n_first, "best": best}  # fmt: skip

    def _node_boxes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The graph's nodes in boxes for :func:`_lazy_astar`'s first legs, ``(box, box_start, box_items)``: the
        non-empty cells of a square grid of about :data:`NODES_PER_BOX` nodes a cell, each as its nodes' bounding
        box; made on first use."""
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

    def _path_to(self, ctx, i: int, end: Point | None) -> list[Point]:
        chain = []
        while i != -1:
            chain.append(ctx["pts"][i])
            i = ctx["pred"][i]
        pts = [ctx["s"], *reversed(chain)]
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

    def plan(self, start_en: Point, goal_en: Point) -> RecoveryPath | None:
        """Shortest admissible route from ``start_en`` to ``goal_en`` (see the module docstring's guarantee).

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
        # the straight segment first (the shortest possible route)
        if g is not None:
            if in_free:
                direct = self._clear_one(s, g, self._thr)
            elif m_s - EPS_M > 0.0:
                direct = self._clear_one(s, g, m_s - EPS_M)
            else:
                direct = self._certified(s, g, m_s)
            if direct:
                return RecoveryPath(self, [s, g], goal, True, floor)
        self._build_graph()
        if self._lazy and g is not None:
            if in_free:  # a prepared goal's tree answers without a search
                route = self._tree_route(s, g, goal)
                if route is not None:
                    return route
            ctx = self._search(s, goal=g, goal_nodes=self._goal_nodes_of(g))
        else:
            ctx = self._search(s)
        if not ctx["first"]:
            if in_free:
                return RecoveryPath(self, [s], goal, False, floor)
            return None
        dist, pts = ctx["dist"], ctx["pts"]
        best_i, best_d = -1, math.inf
        if isinstance(dist, np.ndarray) and g is not None:  # the compiled search's: the same choice, made there
            best_i = int(ctx["best"])  # (the first smallest, as the loop below keeps it)
        elif g is not None:
            vis = [i for i in self._visible_from(g, self._thr) if dist[i] < math.inf]
            if len(pts) > len(self.nodes) and dist[-1] < math.inf and self._clear_one(pts[-1], g, self._thr):
                vis.append(len(pts) - 1)
            for i in vis:
                d = dist[i] + math.hypot(pts[i][0] - g[0], pts[i][1] - g[1])
                if d < best_d:
                    best_i, best_d = i, d
        if best_i >= 0:
            return RecoveryPath(self, self._path_to(ctx, best_i, g), goal, True, floor)
        # unreachable goal: end at the reachable point nearest to it
        target = g if g is not None else goal
        cand = [i for i in range(len(pts)) if dist[i] < math.inf]
        i = min(cand, key=lambda k: (math.hypot(pts[k][0] - target[0], pts[k][1] - target[1]), dist[k]))
        return RecoveryPath(self, self._path_to(ctx, i, None), goal, False, floor)

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
        ctx = self._search(s, targets={k for k, _ in want} if self._lazy else None)
        dist = ctx["dist"]
        # a direct first leg to a safe point counts too (the graph search already includes it)
        best = min(want, key=lambda kv: dist[kv[0]])
        if dist[best[0]] == math.inf:
            return None
        k, sp = best
        return sp, RecoveryPath(self, self._path_to(ctx, k, None), sp.en, True, ctx["floor"])


def _by_key_in_chunks(keys: np.ndarray, leg: np.ndarray, first: int = 64) -> Iterator[tuple[list, list, list]]:
    """``(keys, legs, nodes)`` lists in ascending key order (ties by node index, as a stable sort), a chunk at a
    time (the first ``first`` smallest, then twice as many each time): a search that stops early sorts a few."""
    n = len(keys)
    rest = np.arange(n)
    k = first
    while len(rest):
        if len(rest) > k:
            kth = np.partition(keys[rest], k)[k]
            take = keys[rest] < kth
            if not take.any():  # (k + 1 or more tied at the smallest key)
                take = keys[rest] <= kth
            chunk, rest = rest[take], rest[~take]
        else:
            chunk, rest = rest, rest[:0]
        chunk = chunk[np.argsort(keys[chunk], kind="stable")]
        yield keys[chunk].tolist(), leg[chunk].tolist(), chunk.tolist()
        k *= 2


# ----------------------------------------------------------------------------- numpy kernels
def _pt_seg_d2_np(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Squared distance from points p to segments a-b (broadcast over leading axes; last axis 2)."""
    d = b - a
    w = p - a
    l2 = d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(l2 > 0.0, (w[..., 0] * d[..., 0] + w[..., 1] * d[..., 1]) / np.where(l2 > 0.0, l2, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    qx = w[..., 0] - t * d[..., 0]
    qy = w[..., 1] - t * d[..., 1]
    return qx * qx + qy * qy


def _edges_block_np(ax: float, ay: float, bx: float, by: float, ca: np.ndarray, cb: np.ndarray, t2: float) -> bool:
    """Does any edge ``ca[k]-cb[k]`` cross the segment a-b or come within ``sqrt(t2)`` of it?

    :meth:`RecoveryPlanner._clear_one`'s per-edge test (:func:`_cross_properly` and the four
    :func:`_pt_seg_d2` endpoint distances) over 1-D arrays, with the scalar code's operations in the
    same order, so each edge gets the same floats and the same verdict.
    """
    cx, cy, dx, dy = ca[:, 0], ca[:, 1], cb[:, 0], cb[:, 1]
    # _cross_properly(a, b, c, d)
    ux, uy = bx - ax, by - ay
    o1 = ux * (cy - ay) - uy * (cx - ax)
    o2 = ux * (dy - ay) - uy * (dx - ax)
    vx, vy = dx - cx, dy - cy
    o3 = vx * (ay - cy) - vy * (ax - cx)
    o4 = vx * (by - cy) - vy * (bx - cx)
    bad = (o1 * o2 < 0.0) & (o3 * o4 < 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        # _pt_seg_d2(a, c-d) and _pt_seg_d2(b, c-d): a point to each edge
        l2 = vx * vx + vy * vy
        pos = l2 > 0.0
        for px, py in ((ax, ay), (bx, by)):
            qx, qy = px - cx, py - cy
            t = np.clip((qx * vx + qy * vy) / l2, 0.0, 1.0)
            qx = np.where(pos, qx - t * vx, qx)
            qy = np.where(pos, qy - t * vy, qy)
            bad |= qx * qx + qy * qy < t2
    # _pt_seg_d2(c, a-b) and _pt_seg_d2(d, a-b): each edge's endpoints to the segment
    sl2 = ux * ux + uy * uy
    for ex, ey in ((cx, cy), (dx, dy)):
        rx, ry = ex - ax, ey - ay
        if sl2 > 0.0:
            s = np.clip((rx * ux + ry * uy) / sl2, 0.0, 1.0)
            rx = rx - s * ux
            ry = ry - s * uy
        bad |= rx * rx + ry * ry < t2
    return bool(bad.any())


def _cross_np(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Proper crossing of segments a-b and c-d (broadcast)."""
    u = b - a
    o1 = u[..., 0] * (c[..., 1] - a[..., 1]) - u[..., 1] * (c[..., 0] - a[..., 0])
    o2 = u[..., 0] * (d[..., 1] - a[..., 1]) - u[..., 1] * (d[..., 0] - a[..., 0])
    v = d - c
    o3 = v[..., 0] * (a[..., 1] - c[..., 1]) - v[..., 1] * (a[..., 0] - c[..., 0])
    o4 = v[..., 0] * (b[..., 1] - c[..., 1]) - v[..., 1] * (b[..., 0] - c[..., 0])
    return (o1 * o2 < 0.0) & (o3 * o4 < 0.0)
