"""The route follower: a vehicle's projection onto its route, the carrot ahead, the roll-out point.

Owns the follower's arithmetic on a route's packed array (:func:`route_arrays`: the points' rows, then their
arc lengths) and its planner's packed tables (:func:`follower_tables`): the point at an arc length
(:func:`_path_point_at`), the projection (:func:`_path_project`), the carrot (:func:`_path_lookahead`), and the
per-step calls the guidance composes (:func:`route_rollout`, :func:`route_follow`), for a vehicle whose chords
are tested exactly (more than :data:`~geofence.recovery.segments.EPS_M` inside). Written once, numba-compilable;
``path_project`` ... ``path_follow`` are the :func:`geofence.jit.compiled` entry points.
"""

from __future__ import annotations

from math import hypot

import numpy as np

from geofence.geometry.scan import lateral_margin_scan, rows_view
from geofence.jit import compiled, jitable
from geofence.recovery.segments import EPS_M, _segment_clear


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
    """The path point at arc length ``s_m`` (clamped to the path), on the path's arrays."""
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


PROJECTION_CANDIDATES: int = 4
"""How many of the path's nearest points a projection tries (nearest first) before it keeps the progress."""


@jitable
def _path_candidates(pts: np.ndarray, cum: np.ndarray, s0: float, e: float, n: float) -> tuple[np.ndarray, int]:
    """``(C, count)``: each segment's point nearest (e, n) at or after arc length ``s0`` (the current segment
    clipped to start there), as the columns ``C[:, :count]`` of rows distance, arc length, east, north and a
    taken flag (0: not yet, :func:`_next_candidate`). One scratch array, not five: compiled, each allocation
    costs about as much as a candidate. A path of at least two points."""
    k = pts.shape[0]
    C = np.empty((5, k - 1))
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
        C[0, c] = hypot(e - px, n - py)
        C[1, c] = cum[i] + t * seg
        C[2, c] = px
        C[3, c] = py
        C[4, c] = 0.0
        c += 1
    return C, c


@jitable
def _next_candidate(C: np.ndarray, c: int) -> int:
    """The nearest candidate not taken yet of :func:`_path_candidates`' ``C[:, :c]``, now taken: in the order
    Python sorts the tuples ``(distance, arc length, east, north)``, the first of equal ones (a stable sort's)."""
    b = -1
    for j in range(c):
        if C[4, j] == 0.0 and (b < 0 or _lex_less(C[0, j], C[1, j], C[2, j], C[3, j], C[0, b], C[1, b], C[2, b], C[3, b])):
            b = j
    C[4, b] = 1.0
    return b


@jitable
def _path_project(
    pts: np.ndarray, cum: np.ndarray, s0: float, e: float, n: float, thr: float, edges: np.ndarray, circles: np.ndarray
) -> float:
    """Arc length of the projection of (e, n) onto the path at or after ``s0``, for a vehicle whose chords are
    tested exactly: its margin exceeds ``thr + EPS_M`` (``thr = min(margin, c) - EPS_M > 0``). The candidates
    (:func:`_path_candidates`) nearest first, at most :data:`PROJECTION_CANDIDATES`; the first whose chord from
    (e, n) is clear at ``thr`` wins (the projection never jumps across a wall to a later leg); none: ``s0``."""
    if pts.shape[0] == 1:
        return 0.0
    C, c = _path_candidates(pts, cum, s0, e, n)
    for _ in range(min(PROJECTION_CANDIDATES, c)):
        b = _next_candidate(C, c)
        if C[0, b] <= EPS_M or _segment_clear(e, n, C[2, b], C[3, b], thr, edges, circles):
            return C[1, b]
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
    """``(projection, carrot east, carrot north)`` for a vehicle whose chords are tested exactly (see
    :func:`_path_project`): the carrot ``lookahead_m`` past the projection; if its chord is not clear (it would
    cut a corner), the next path vertex after the projection; if that chord is not clear either, the projection
    point itself. The caller advances the progress."""
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
    """``thr``, or when it is NaN, the exact chord threshold ``min(margin, c) - EPS_M`` at (e, n)
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
    positive, nothing else is computed (the caller's certified test answers)."""
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


path_project = compiled(_route_project)
"""The compiled :func:`_route_project`."""

path_lookahead = compiled(_route_lookahead)
"""The compiled :func:`_route_lookahead`."""

path_rollout = compiled(route_rollout)
"""The compiled :func:`route_rollout`."""

path_follow = compiled(route_follow)
"""The compiled :func:`route_follow`."""
