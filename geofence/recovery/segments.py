"""Exact segment clearance: does a segment keep a distance from every boundary edge and keep-out circle?

Owns the scalar point/segment distances and the per-element tests (:func:`_edge_blocks`,
:func:`_circle_blocks`), the one-segment test over a planner's tables (:func:`_segment_clear`), the uniform
grid of those tables for airspace-scale fences (:func:`segment_grid`, walked by :func:`_segment_clear_grid`),
and the fans of segments from one origin (:func:`_fan_clear_rows`, :func:`_fan_clear_grid`). The tables are
:func:`boundary_tables`': edge rows ``(cx, cy, dx, dy, xmin, xmax, ymin, ymax)`` and circle rows ``(x, y, r)``.
Every test is written once, numba-compilable; the entry points (``segment_clear``, ``fan_clear``, ...) are
:func:`geofence.jit.compiled` (the same source interpreted without numba).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from geofence.jit import compiled, jitable

if TYPE_CHECKING:  # pragma: no cover
    from geofence.geometry.local_fence import LocalFence

EPS_M: float = 1e-9
"""Rounding slack (m) in the exact admissibility thresholds."""

Point = tuple[float, float]

Grid = tuple[float, float, float, int, int, np.ndarray, np.ndarray]
"""A segment grid's tables, ``(x0, y0, cell_m, nx, ny, start, items)`` (:func:`segment_grid`)."""


def boundary_tables(fence: "LocalFence") -> tuple[np.ndarray, np.ndarray]:
    """``(edges, circles)``: the fence's keep-in and keep-out polygon edges as rows ``(cx, cy, dx, dy, xmin, xmax,
    ymin, ymax)`` and its keep-out circles as rows ``(x, y, r)``, the tables every test here takes."""
    polys = [fence.keep_in, *fence.keep_out_polygons]
    a = np.concatenate([p.starts for p in polys])
    b = np.concatenate([p.ends for p in polys])
    edges = np.array(
        [
            (float(ax), float(ay), float(bx), float(by), min(ax, bx), max(ax, bx), min(ay, by), max(ay, by))
            for (ax, ay), (bx, by) in zip(a.tolist(), b.tolist())
        ],
        dtype=float,
    ).reshape(-1, 8)
    circles = np.array([(float(x), float(y), float(r)) for x, y, r in fence.keep_out_circles], dtype=float)
    return edges, circles.reshape(-1, 3)


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
    within that distance of the other)? The exact per-edge test of every segment test here."""
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
    """Is a-b clear at ``thr``, in one loop: no edge row ``(cx, cy, dx, dy, xmin, xmax, ymin,
    ymax)`` crosses a-b or comes within ``thr`` of it, and no circle row ``(x, y, r)`` comes within ``thr``.

    Elements whose bounding box is more than ``thr`` from a-b's are skipped; the loop stops at the first element
    in the way.
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


SEGMENT_GRID_MIN_EDGES: int = 2000
"""From this many boundary edges on, a planner files its edges and circles in a uniform grid
(:func:`segment_grid`) and its compiled segment test walks the cells along the segment
(:func:`_segment_clear_grid`) instead of looping over every edge: an airspace-scale route search tests hundreds
of first legs per plan."""

SEGMENT_GRID_SLACK_M: float = 0.5
"""Slack (m) of the grid's filing and walking, far beyond any rounding: an element is filed in every cell within
the grid's reach plus this of its bounding box, and the walk visits every cell within this of the segment."""


def segment_grid(edges: np.ndarray, circles: np.ndarray, reach_m: float, cell_m: float) -> Grid:
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


FAN_SLACK_M: float = 1e-6
"""Slack (m) of the fans' early exit: an edge is skipped only when it is this much (plus 1e-9 relative) farther
from the fan's origin than the segment's length plus the threshold, far beyond any rounding of the tests."""


@jitable
def _fan_clear_rows(
    ox: float, oy: float, q: np.ndarray, thr: float, edges: np.ndarray, edge_d: np.ndarray, circles: np.ndarray
) -> np.ndarray:
    """The verdicts of :func:`_segment_clear` for the segments from (ox, oy) to each row of ``q``: each circle row
    ``(x, y, r)`` first, then the edge rows ``(cx, cy, dx, dy, ...)`` in the given order (by their distance
    ``edge_d`` from the origin, nearest first), with the same per-edge test (:func:`_edge_blocks`); a segment
    leaves at the first element in its way, or at the first edge farther from the origin than its length plus
    ``thr``: every point of the segment is within its length of the origin, so neither that edge nor any after
    it can cross it or come within ``thr``. An edge whose bounding box is more than ``thr`` from the segment's
    is skipped. Both shortcuts carry :data:`FAN_SLACK_M` (beyond any rounding of the per-edge test, so the
    verdicts are :func:`_segment_clear`'s), and spare the far side of a large fence for a short segment."""
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


def _fan_clear_near(ox: float, oy: float, q: np.ndarray, thr: float, edges: np.ndarray, circles: np.ndarray) -> np.ndarray:
    """:func:`_fan_clear_rows` over the edges near the origin: an edge farther than the longest segment plus
    ``thr`` from the origin can neither cross one nor come within ``thr``, so only the others are tested,
    nearest first (near edges block most directions of a fan)."""
    reach2 = 0.0
    for i in range(q.shape[0]):
        dx = q[i, 0] - ox
        dy = q[i, 1] - oy
        d2 = dx * dx + dy * dy
        if d2 > reach2:
            reach2 = d2
    reach = math.sqrt(reach2) + thr
    d2e = np.empty(edges.shape[0])
    for k in range(edges.shape[0]):
        d2e[k] = _pt_seg_d2(ox, oy, edges[k, 0], edges[k, 1], edges[k, 2], edges[k, 3])
    near = np.flatnonzero(d2e <= reach * reach)
    order = near[np.argsort(d2e[near], kind="mergesort")]
    return _fan_clear_rows(ox, oy, q, thr, np.ascontiguousarray(edges[order]), np.sqrt(d2e[order]), circles)


def _pairs_clear(p: np.ndarray, q: np.ndarray, thr: float, edges: np.ndarray, circles: np.ndarray) -> np.ndarray:
    """:func:`_segment_clear` of each segment ``p[k]-q[k]``."""
    out = np.zeros(p.shape[0], np.bool_)
    for k in range(p.shape[0]):
        out[k] = _segment_clear(p[k, 0], p[k, 1], q[k, 0], q[k, 1], thr, edges, circles)
    return out


segment_clear = compiled(_segment_clear)
"""The compiled :func:`_segment_clear`."""

segment_clear_grid = compiled(_segment_clear_grid)
"""The compiled :func:`_segment_clear_grid`."""

fan_clear_grid = compiled(_fan_clear_grid)
"""The compiled :func:`_fan_clear_grid`."""

fan_clear = compiled(_fan_clear_near)
"""The compiled :func:`_fan_clear_near`."""

pairs_clear = compiled(_pairs_clear)
"""The compiled :func:`_pairs_clear`."""
