"""Planar polygon geometry in local ENU metres (the fence's 2-D core).

Pure functions on plain floats/tuples and numpy arrays, modelled on NASA
PolyCARP's care with edge and vertex cases. A point is ``(x, y)`` =
``(east_m, north_m)``; a polygon is a sequence of ``N >= 3`` vertices, open
(a closing vertex equal to the first is dropped by :func:`as_vertices`), in
either orientation. Edge ``i`` runs from vertex ``i`` to vertex ``(i+1) % N``,
so edge numbers always refer to the caller's vertex order.

Conventions
-----------
* Orientation: :func:`signed_area` is positive for counter-clockwise vertices
  (east to north), negative for clockwise.
* Boundary: the polygon is a *closed* set. A point within :data:`BOUNDARY_TOL_M`
  (1e-9 m) of an edge or vertex is *on the boundary* and counts as inside
  (like shapely's ``covers``). :func:`point_location` tells the three cases
  apart: ``1`` inside, ``0`` on the boundary, ``-1`` outside.
* Signed distance: positive inside, negative outside, in m; its magnitude is
  the Euclidean distance to the nearest boundary point. On-boundary points
  give a non-negative value (<= the tolerance).
* Normals: ``inward_normals`` / ``outward_normals`` are unit vectors
  perpendicular to each edge, pointing into / out of the polygon whatever the
  vertex orientation.

Self-intersection (:func:`self_intersections`) uses exact orientation tests
(a floating-point filter with an exact rational fallback, after Shewchuk), so
touching and collinear cases are decided exactly for the given floats.

:class:`PolygonIndex` precomputes the edge arrays once, and its edge table (:func:`edge_rows`). Its scalar
queries are one source, :func:`nearest_rows` over that table (compiled; the compiled kernels of
:mod:`geofence.geometry.scan` inline the same functions); its ``*_array`` methods ask :func:`signed_distances`,
the same formula as in-place array passes for recorded trajectories (what :mod:`analysis.fast_margins` runs).
"""

from __future__ import annotations

import heapq
import math
from fractions import Fraction
from typing import Callable, Iterable, Sequence

import numpy as np

from geofence.jit import compiled, jitable

BOUNDARY_TOL_M: float = 1e-9
"""Points closer than this to the boundary are on the boundary (count as inside)."""

_CCW_ERRBOUND = 3.3306690738754716e-16 * 1.01  # Shewchuk's ccwerrboundA with headroom

Point = tuple[float, float]


# --------------------------------------------------------------------------- basics
def as_vertices(points: Iterable[Sequence[float]]) -> np.ndarray:
    """An (N, 2) float array of vertices; a closing vertex equal to the first is dropped."""
    if isinstance(points, np.ndarray) and points.ndim == 2 and points.shape[1] == 2:
        v = points.astype(float)
    else:
        v = np.asarray([(float(p[0]), float(p[1])) for p in points], dtype=float).reshape(-1, 2)
    if len(v) >= 2 and v[0, 0] == v[-1, 0] and v[0, 1] == v[-1, 1]:
        v = v[:-1]
    return v


def signed_area(vertices) -> float:
    """Shoelace area in m²: positive for counter-clockwise vertices, negative for clockwise."""
    v = as_vertices(vertices)
    if len(v) < 3:
        return 0.0
    x, y = v[:, 0], v[:, 1]
    # centred to keep the shoelace well conditioned far from the origin
    x = x - x.mean()
    y = y - y.mean()
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def is_ccw(vertices) -> bool:
    """True if the vertices run counter-clockwise (positive signed area)."""
    return signed_area(vertices) > 0.0


def oriented_ccw(vertices) -> np.ndarray:
    """The vertices in counter-clockwise order (a copy, reversed if they were clockwise)."""
    v = as_vertices(vertices)
    return v[::-1].copy() if signed_area(v) < 0.0 else v.copy()


def is_convex(vertices, rel_tol: float = 1e-12) -> bool:
    """True if every vertex of the simple polygon turns the polygon's way (collinear ones, within ``rel_tol`` of
    the two edges' lengths product, count as turning it)."""
    v = oriented_ccw(vertices)
    a = v
    b = np.roll(v, -1, axis=0)
    c = np.roll(v, -2, axis=0)
    u, w = b - a, c - b
    cross = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
    scale = np.hypot(u[:, 0], u[:, 1]) * np.hypot(w[:, 0], w[:, 1])
    return bool(np.all(cross >= -rel_tol * scale))


def centroid(vertices) -> Point:
    """Area centroid (x, y) of a simple polygon, in m."""
    v = as_vertices(vertices)
    mx, my = float(v[:, 0].mean()), float(v[:, 1].mean())
    x, y = v[:, 0] - mx, v[:, 1] - my
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = x * y1 - x1 * y
    a = 0.5 * float(cross.sum())
    if a == 0.0:
        return mx, my
    return mx + float(((x + x1) * cross).sum()) / (6.0 * a), my + float(((y + y1) * cross).sum()) / (6.0 * a)


# ------------------------------------------------------------ exact predicates
def orient2d(a: Point, b: Point, c: Point) -> int:
    """Sign of the turn a -> b -> c: +1 left (counter-clockwise), -1 right, 0 collinear. Exact."""
    detleft = (a[0] - c[0]) * (b[1] - c[1])
    detright = (a[1] - c[1]) * (b[0] - c[0])
    det = detleft - detright
    bound = _CCW_ERRBOUND * (abs(detleft) + abs(detright))
    if det > bound:
        return 1
    if det < -bound:
        return -1
    ax, ay, bx, by, cx, cy = (Fraction(t) for t in (a[0], a[1], b[0], b[1], c[0], c[1]))
    d = (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)
    return (d > 0) - (d < 0)


def _on_segment_collinear(a: Point, b: Point, p: Point) -> bool:
    """For p collinear with a-b: is p within the closed segment's bounding box?"""
    return min(a[0], b[0]) <= p[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= p[1] <= max(a[1], b[1])


def segments_intersect(p1: Point, p2: Point, q1: Point, q2: Point) -> bool:
    """True if the closed segments p1-p2 and q1-q2 share at least one point (touching counts). Exact."""
    if (
        max(p1[0], p2[0]) < min(q1[0], q2[0])
        or max(q1[0], q2[0]) < min(p1[0], p2[0])
        or max(p1[1], p2[1]) < min(q1[1], q2[1])
        or max(q1[1], q2[1]) < min(p1[1], p2[1])
    ):
        return False
    o1, o2 = orient2d(p1, p2, q1), orient2d(p1, p2, q2)
    o3, o4 = orient2d(q1, q2, p1), orient2d(q1, q2, p2)
    if o1 != o2 and o3 != o4 and o1 * o2 <= 0 and o3 * o4 <= 0:
        if o1 != 0 or o2 != 0:  # not all collinear
            return True
    if o1 == 0 and _on_segment_collinear(p1, p2, q1):
        return True
    if o2 == 0 and _on_segment_collinear(p1, p2, q2):
        return True
    if o3 == 0 and _on_segment_collinear(q1, q2, p1):
        return True
    if o4 == 0 and _on_segment_collinear(q1, q2, p2):
        return True
    return False


def segments_cross_properly(p1: Point, p2: Point, q1: Point, q2: Point) -> bool:
    """True if the segments cross at a single point interior to both (no touching, no collinear overlap)."""
    o1, o2 = orient2d(p1, p2, q1), orient2d(p1, p2, q2)
    o3, o4 = orient2d(q1, q2, p1), orient2d(q1, q2, p2)
    return o1 * o2 < 0 and o3 * o4 < 0


# ------------------------------------------------------------ simple-polygon check
def self_intersections(vertices) -> list[tuple[int, int]]:
    """Pairs ``(i, j)``, ``i <= j``, of edges that make the polygon non-simple.

    Reported: non-adjacent edges that cross *or touch* (including a vertex
    repeated non-consecutively, which makes its four edges touch); adjacent
    edges that fold back over each other (collinear overlap, a zero-width
    spike); and zero-length edges from a vertex repeated consecutively,
    reported as ``(i, i)``. An empty list means the polygon is simple. A polygon
    with fewer than 3 distinct vertices is not checked here (see callers).
    """
    v = [(float(p[0]), float(p[1])) for p in as_vertices(vertices)]
    n = len(v)
    out: list[tuple[int, int]] = []
    if n < 3:
        return out
    seg = [(v[i], v[(i + 1) % n]) for i in range(n)]
    for i in range(n):
        if seg[i][0] == seg[i][1]:
            out.append((i, i))
    zero = {i for i, _ in out}
    # bounding boxes for a cheap reject, and a sweep over x so only pairs whose x-ranges meet are visited
    bx = [(min(a[0], b[0]), max(a[0], b[0]), min(a[1], b[1]), max(a[1], b[1])) for a, b in seg]
    order = sorted(range(n), key=lambda k: bx[k][0])
    pairs = []
    for oi, i in enumerate(order):
        hi = bx[i][1]
        for oj in range(oi + 1, n):
            j = order[oj]
            if bx[j][0] > hi:
                break
            pairs.append((i, j) if i < j else (j, i))
    pairs.sort()
    for i, j in pairs:
        if i in zero or j in zero:
            continue
        a, b = seg[i]
        adjacent_next = j == i + 1
        adjacent_wrap = i == 0 and j == n - 1
        bi, bj = bx[i], bx[j]
        if bi[1] < bj[0] or bj[1] < bi[0] or bi[3] < bj[2] or bj[3] < bi[2]:
            continue
        c, d = seg[j]
        if adjacent_next or adjacent_wrap:
            # shared vertex: they intersect elsewhere only if collinear and folding back
            if adjacent_next:
                p, q, r = a, b, d  # edge i = p->q, edge j = q->r
            else:
                p, q, r = c, d, b  # edge j = p->q (= v[n-1] -> v[0]), edge i = q->r
            if orient2d(p, q, r) == 0:
                if (q[0] - p[0]) * (r[0] - q[0]) + (q[1] - p[1]) * (r[1] - q[1]) < 0:
                    out.append((i, j))
            continue
        if segments_intersect(a, b, c, d):
            out.append((i, j))
    return out


def is_simple(vertices) -> bool:
    """True if the polygon has >= 3 vertices, no self-intersection and non-zero area."""
    v = as_vertices(vertices)
    return len(v) >= 3 and not self_intersections(v) and signed_area(v) != 0.0


# ------------------------------------------------------------ point queries (one-shot)
def segment_dist2(x: float, y: float, ax: float, ay: float, bx: float, by: float) -> float:
    dx, dy = bx - ax, by - ay
    px, py = x - ax, y - ay
    l2 = dx * dx + dy * dy
    t = 0.0 if l2 == 0.0 else (px * dx + py * dy) / l2
    t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
    qx, qy = px - t * dx, py - t * dy
    return qx * qx + qy * qy


def point_location(x: float, y: float, vertices, tol: float = BOUNDARY_TOL_M) -> int:
    """``1`` inside, ``0`` on the boundary (within ``tol`` m), ``-1`` outside (:func:`nearest_rows` on the polygon's
    edge table)."""
    d2, _, _, _, inside = nearest_at(edge_rows(as_vertices(vertices)), float(x), float(y))
    if d2 <= tol * tol:
        return 0
    return 1 if inside else -1


def point_in_polygon(x: float, y: float, vertices, tol: float = BOUNDARY_TOL_M) -> bool:
    """True if (x, y) is inside or on the boundary (closed-set convention)."""
    return point_location(x, y, vertices, tol) >= 0


def signed_distance(x: float, y: float, vertices) -> float:
    """Signed distance in m from (x, y) to the polygon boundary: + inside, - outside."""
    return PolygonIndex(vertices).signed_distance(x, y)


# ------------------------------------------------------------ polygon relations
def polygon_covers_polygon(outer, inner) -> bool:
    """True if polygon ``inner`` lies inside the closed polygon ``outer`` (shared boundary allowed).

    Checks: every inner vertex and edge midpoint is inside/on ``outer``; no
    inner edge crosses an outer edge properly; no outer vertex lies strictly
    inside ``inner``. Sufficient for simple polygons.
    """
    vo, vi = as_vertices(outer), as_vertices(inner)
    po, pi = PolygonIndex(vo), PolygonIndex(vi)
    for k in range(len(vi)):
        a, b = vi[k], vi[(k + 1) % len(vi)]
        if po.location(float(a[0]), float(a[1])) < 0:
            return False
        if po.location(0.5 * float(a[0] + b[0]), 0.5 * float(a[1] + b[1])) < 0:
            return False
    for k in range(len(vo)):
        if pi.location(float(vo[k, 0]), float(vo[k, 1])) > 0:
            return False
    so = [(tuple(vo[k]), tuple(vo[(k + 1) % len(vo)])) for k in range(len(vo))]
    for k in range(len(vi)):
        a, b = tuple(vi[k]), tuple(vi[(k + 1) % len(vi)])
        for c, d in so:
            if segments_cross_properly(a, b, c, d):
                return False
    return True


def _edges_meeting_box(v: np.ndarray, box: tuple[float, float, float, float]) -> np.ndarray:
    """Indices of the edges of polygon ``v`` whose bounding boxes meet ``box = (xmin, ymin, xmax, ymax)``."""
    w = np.roll(v, -1, axis=0)
    lo, hi = np.minimum(v, w), np.maximum(v, w)
    return np.flatnonzero((lo[:, 0] <= box[2]) & (hi[:, 0] >= box[0]) & (lo[:, 1] <= box[3]) & (hi[:, 1] >= box[1]))


def polygons_intersect(a, b) -> bool:
    """True if the closed polygons share any point (overlap, containment or touching).

    Only the edges of ``a`` whose bounding boxes meet ``b``'s are tested (the
    others cannot touch ``b``), so a small polygon against a large one costs
    little; containment is the parity test, vectorised for the larger polygon.
    """
    va, vb = as_vertices(a), as_vertices(b)
    box_b = (float(vb[:, 0].min()), float(vb[:, 1].min()), float(vb[:, 0].max()), float(vb[:, 1].max()))
    na = len(va)
    sa = [(tuple(va[k]), tuple(va[(k + 1) % na])) for k in _edges_meeting_box(va, box_b).tolist()]
    for k in range(len(vb)):
        p, q = tuple(vb[k]), tuple(vb[(k + 1) % len(vb)])
        for c, d in sa:
            if segments_intersect(p, q, c, d):
                return True
    return point_location(float(va[0, 0]), float(va[0, 1]), vb) >= 0 or point_location(float(vb[0, 0]), float(vb[0, 1]), va) >= 0


# ------------------------------------------------------------ pole of inaccessibility
def pole_of_inaccessibility(
    sdf: Callable[[float, float], float],
    bbox: tuple[float, float, float, float],
    precision_m: float = 0.05,
    max_cells: int = 20000,
) -> tuple[float, float, float]:
    """The point maximising a signed-distance function over a box (Mapbox's *polylabel*).

    ``sdf(x, y)`` must be 1-Lipschitz (a signed distance, or a min of them);
    ``bbox = (xmin, ymin, xmax, ymax)``. Returns ``(x, y, sdf(x, y))``, the
    best value within ``precision_m`` of the true maximum (or the best found
    after ``max_cells`` evaluations). For a polygon this is the centre and
    radius of its largest inscribed circle (the inradius).
    """
    xmin, ymin, xmax, ymax = bbox
    w, h = xmax - xmin, ymax - ymin
    size = min(w, h)
    if size <= 0.0:
        x, y = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
        return x, y, sdf(x, y)
    half = 0.5 * size
    heap: list[tuple[float, float, float, float, float]] = []

    def push(cx: float, cy: float, hh: float) -> None:
        d = sdf(cx, cy)
        heapq.heappush(heap, (-(d + hh * math.sqrt(2.0)), d, cx, cy, hh))

    x = xmin
    while x < xmax:
        y = ymin
        while y < ymax:
            push(x + half, y + half, half)
            y += size
        x += size
    cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
    best = (sdf(cx, cy), cx, cy)
    evaluated = len(heap)
    while heap and evaluated < max_cells:
        negmax, d, cx, cy, hh = heapq.heappop(heap)
        if d > best[0]:
            best = (d, cx, cy)
        if -negmax - best[0] <= precision_m:
            continue
        hh *= 0.5
        for sx in (-hh, hh):
            for sy in (-hh, hh):
                push(cx + sx, cy + sy, hh)
        evaluated += 4
    return best[1], best[2], best[0]


# ------------------------------------------------------------ precomputed index
# ------------------------------------------------------------ point queries on an edge table (one source)
EDGE_COLUMNS = 7
"""An edge table's row: ``(ax, ay, by, dx, dy, 1/len², dx/dy)`` of the edge from ``(ax, ay)`` to
``(ax + dx, by)`` (``1/len²`` 0 for a degenerate edge, ``dx/dy`` 0 for a horizontal one)."""


def edge_rows(vertices: np.ndarray) -> np.ndarray:
    """A polygon's edge table (:data:`EDGE_COLUMNS` floats a row, edge ``i`` from vertex ``i`` to ``i + 1``)."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 2)
    a, b = v, np.roll(v, -1, axis=0)
    d = b - a
    l2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # (an edge 1e-300 m high: inf, as Python's)
        il2 = np.where(l2 > 0.0, 1.0 / np.where(l2 > 0.0, l2, 1.0), 0.0)
        dxdy = np.where(d[:, 1] != 0.0, d[:, 0] / np.where(d[:, 1] != 0.0, d[:, 1], 1.0), 0.0)
    return np.ascontiguousarray(np.column_stack((a[:, 0], a[:, 1], b[:, 1], d[:, 0], d[:, 1], il2, dxdy)))


@jitable
def edge_offset(rows: np.ndarray, k: int, x: float, y: float) -> tuple[float, float, bool]:
    """Edge ``k`` of the table seen from (x, y): ``(qx, qy, crosses)``, the point less its nearest point on the
    edge, and whether the edge crosses the ray from the point toward +x (the crossing-parity test)."""
    ax, ay, by, dx, dy = rows[k, 0], rows[k, 1], rows[k, 2], rows[k, 3], rows[k, 4]
    px = x - ax
    py = y - ay
    t = (px * dx + py * dy) * rows[k, 5]
    if t < 0.0:
        t = 0.0
    elif t > 1.0:
        t = 1.0
    return px - t * dx, py - t * dy, ((ay > y) != (by > y)) and px < py * rows[k, 6]


@jitable
def nearest_rows(rows: np.ndarray, x: float, y: float) -> tuple[float, int, float, float, bool]:
    """``(d², edge, qx, qy, inside)``: the squared distance to the nearest edge (the lowest index on a tie), that
    edge, the point less its nearest boundary point, and the crossing parity."""
    inside = False
    best = math.inf
    bi = 0
    bqx = bqy = 0.0
    for k in range(rows.shape[0]):
        qx, qy, crosses = edge_offset(rows, k, x, y)
        d2 = qx * qx + qy * qy
        if d2 < best:
            best, bi, bqx, bqy = d2, k, qx, qy
        if crosses:
            inside = not inside
    return best, bi, bqx, bqy, inside


@jitable
def signed_distance_rows(rows: np.ndarray, x: float, y: float) -> float:
    """The signed distance to the table's polygon (m; + inside, a point within :data:`BOUNDARY_TOL_M` of the
    boundary counted inside)."""
    d2, _, _, _, inside = nearest_rows(rows, x, y)
    d = math.sqrt(d2)
    return d if (inside or d <= BOUNDARY_TOL_M) else -d


def _edge_distances_rows(rows: np.ndarray, x: float, y: float) -> np.ndarray:
    """The distance from (x, y) to each edge segment (m, edge order)."""
    out = np.empty(rows.shape[0])
    for k in range(rows.shape[0]):
        qx, qy, _ = edge_offset(rows, k, x, y)
        out[k] = math.sqrt(qx * qx + qy * qy)
    return out


nearest_at = compiled(nearest_rows)
"""The compiled :func:`nearest_rows` (Python callers: :class:`PolygonIndex`, :func:`point_location`)."""
signed_distance_at = compiled(signed_distance_rows)
"""The compiled :func:`signed_distance_rows`."""
edge_distances_at = compiled(_edge_distances_rows)
"""The compiled :func:`_edge_distances_rows`."""


def nearest_edges_rows(rows: np.ndarray, x: np.ndarray, y: np.ndarray, out: np.ndarray) -> None:
    """The nearest edge (:func:`nearest_rows`) of every ``(x[i], y[i])`` into ``out[i]``."""
    for i in range(x.shape[0]):
        out[i] = nearest_rows(rows, x[i], y[i])[1]


nearest_edges_at = compiled(nearest_edges_rows)
"""The compiled :func:`nearest_edges_rows`."""


def signed_distances(rows: np.ndarray, x: np.ndarray, y: np.ndarray, out: np.ndarray) -> None:
    """:func:`signed_distance_rows` of every ``(x[i], y[i])`` into ``out`` (m; the same numbers), vectorised for a
    recorded trajectory: one pass of in-place ufuncs over the points per edge, in edge order (a dozen buffers of
    the points' length, no points-by-edges temporaries). Its formula is :func:`edge_offset`'s, written for
    arrays: the crossing test as ``min(ay, by) <= y < max(ay, by)``, the same as ``(ay > y) != (by > y)``.
    Compiled, the per-point loop scores 2-3 times slower (numba does not vectorise its clamp and parity)."""
    m = len(x)
    best = out
    best.fill(np.inf)
    inside = np.zeros(m, dtype=bool)
    px, py, t, tmp = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    s1, s2 = np.empty(m, dtype=bool), np.empty(m, dtype=bool)
    for ax, ay, by, dx, dy, il2, dxdy in rows.tolist():
        np.subtract(x, ax, out=px)
        np.subtract(y, ay, out=py)
        if dy != 0.0:  # the crossing number (the ray toward +x): the edge straddles y, the crossing right of x
            np.less(y, max(ay, by), out=s1)
            np.greater_equal(y, min(ay, by), out=s2)
            np.logical_and(s1, s2, out=s1)
            np.multiply(py, dxdy, out=tmp)
            np.less(px, tmp, out=s2)
            np.logical_and(s1, s2, out=s1)
            np.logical_xor(inside, s1, out=inside)
        np.multiply(px, dx, out=t)  # the squared distance to the segment
        np.multiply(py, dy, out=tmp)
        np.add(t, tmp, out=t)
        np.multiply(t, il2, out=t)
        np.maximum(t, 0.0, out=t)
        np.minimum(t, 1.0, out=t)
        np.multiply(t, dx, out=tmp)
        np.subtract(px, tmp, out=px)
        np.multiply(t, dy, out=tmp)
        np.subtract(py, tmp, out=py)
        np.multiply(px, px, out=px)
        np.multiply(py, py, out=py)
        np.add(px, py, out=px)
        np.minimum(best, px, out=best)
    np.sqrt(best, out=best)
    np.less_equal(best, BOUNDARY_TOL_M, out=s1)  # outside, beyond the boundary tolerance: negative
    np.logical_or(inside, s1, out=inside)
    np.negative(best, out=best, where=~inside)


class PolygonIndex:
    """Precomputed edge arrays of one polygon, with fast scalar and vectorized queries.

    Arrays (numpy, for analysis): ``vertices`` (N, 2), ``starts`` (N, 2),
    ``ends`` (N, 2), ``directions`` (N, 2) unit, ``lengths`` (N,),
    ``inward_normals`` / ``outward_normals`` (N, 2) unit. Edge ``i`` runs from
    vertex ``i`` to ``(i+1) % N`` in the caller's order; ``ccw`` says whether
    that order is counter-clockwise.

    ``rows``: the edge table (:func:`edge_rows`) the scalar methods ask the compiled point queries about
    (:func:`nearest_rows`).
    """

    __slots__ = (
        "vertices",
        "starts",
        "ends",
        "directions",
        "lengths",
        "inward_normals",
        "outward_normals",
        "ccw",
        "area",
        "bbox",
        "rows",
        "n",
    )

    def __init__(self, vertices) -> None:
        v = as_vertices(vertices)
        if len(v) < 3:
            raise ValueError(f"a polygon needs at least 3 vertices, got {len(v)}")
        if not np.all(np.isfinite(v)):
            raise ValueError("polygon vertices must be finite")
        self.vertices = v
        self.n = len(v)
        self.starts = v
        self.ends = np.roll(v, -1, axis=0)
        d = self.ends - self.starts
        self.lengths = np.hypot(d[:, 0], d[:, 1])
        safe = np.where(self.lengths > 0.0, self.lengths, 1.0)
        self.directions = d / safe[:, None]
        a = signed_area(v)
        self.area = abs(a)
        self.ccw = a > 0.0
        sgn = 1.0 if self.ccw else -1.0
        left = np.stack([-self.directions[:, 1], self.directions[:, 0]], axis=1)
        self.inward_normals = sgn * left
        self.outward_normals = -self.inward_normals
        self.bbox = (float(v[:, 0].min()), float(v[:, 1].min()), float(v[:, 0].max()), float(v[:, 1].max()))
        self.rows = edge_rows(v)

    # ---- scalar (per-step) queries
    def signed_distance(self, x: float, y: float) -> float:
        """Signed distance in m to the boundary: + inside, - outside (on-boundary -> >= 0)."""
        return signed_distance_at(self.rows, float(x), float(y))

    def location(self, x: float, y: float) -> int:
        """``1`` inside, ``0`` on the boundary (within :data:`BOUNDARY_TOL_M`), ``-1`` outside."""
        d = self.signed_distance(x, y)
        if abs(d) <= BOUNDARY_TOL_M:
            return 0
        return 1 if d > 0.0 else -1

    def contains(self, x: float, y: float) -> bool:
        """Inside or on the boundary (closed-set convention)."""
        return self.signed_distance(x, y) >= 0.0

    def nearest(self, x: float, y: float) -> tuple[float, int, float, float]:
        """``(signed_distance, edge, ox, oy)`` for the nearest boundary point.

        ``edge`` is the index of the nearest edge (lowest index on ties, e.g. at
        a vertex). ``(ox, oy)`` is the unit direction in which the signed
        distance decreases fastest, i.e. towards/through the boundary and out of
        the polygon: from the point to its nearest boundary point when inside,
        away from it when outside. Along an edge's interior it is that edge's
        outward normal; near a vertex it points at/away from the vertex. On the
        boundary it is the nearest edge's outward normal.
        """
        best, bi, bqx, bqy, inside = nearest_at(self.rows, float(x), float(y))
        d = math.sqrt(best)
        if d <= BOUNDARY_TOL_M:
            o = self.outward_normals[bi]
            return d, bi, float(o[0]), float(o[1])
        # (qx, qy) = point - nearest boundary point
        if inside:
            return d, bi, -bqx / d, -bqy / d
        return -d, bi, bqx / d, bqy / d

    def edge_distances(self, x: float, y: float) -> list[float]:
        """Unsigned distance in m from (x, y) to each edge segment (a list, edge order)."""
        return edge_distances_at(self.rows, float(x), float(y)).tolist()

    # ---- array (analysis) queries
    def signed_distance_array(self, points) -> np.ndarray:
        """:meth:`signed_distance` of each point of an (M, 2) array (:func:`signed_distances`); returns (M,) in m."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        out = np.empty(len(pts))
        signed_distances(self.rows, np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]), out)
        return out

    def contains_array(self, points) -> np.ndarray:
        """Vectorized :meth:`contains` (inside or on the boundary) for an (M, 2) array."""
        return self.signed_distance_array(points) >= 0.0

    def nearest_edge_array(self, points) -> np.ndarray:
        """Index of the nearest edge (lowest on a tie) for each point of an (M, 2) array."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        out = np.empty(len(pts), dtype=np.int64)
        nearest_edges_at(self.rows, np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]), out)
        return out

    # ---- whole-polygon properties
    def inradius(self, precision_m: float = 0.05) -> tuple[float, float, float]:
        """``(x, y, r)``: centre and radius of the largest inscribed circle (pole of inaccessibility)."""
        return pole_of_inaccessibility(self.signed_distance, self.bbox, precision_m)

    def self_intersections(self) -> list[tuple[int, int]]:
        """See :func:`self_intersections`."""
        return self_intersections(self.vertices)
