"""A fence's elements as float tables, the form the compiled margins and the fence index read.

Owns: the element table (:func:`element_table`: one row per keep-in or keep-out edge, then per keep-out
circle), the packed margin tables of a fence (:class:`MarginTables`: every table a margin reads, in one float
and one int array, and the accessors :func:`packed_table`, :func:`packed_column`, :func:`packed_vector`,
:func:`fence_scalar`), how an element is scored from a point (:func:`edge_scored`) and the walk over a fence
index's candidates in order of their lower bounds (:func:`walk_candidates`, :data:`nearest_distance`).
Geometry only: no room, no envelope; the margins (:mod:`geofence.margins.kernel`) build on these.
"""

from __future__ import annotations

import math
from math import hypot
from typing import NamedTuple, Sequence

import numpy as np

from geofence.geometry.scan import rows_view
from geofence.jit import compiled, jitable

__all__ = [
    "MarginTables", "edge_scored", "element_table", "fence_scalar", "nearest_distance", "packed_column", "packed_table",
    "packed_vector", "walk_candidates",
]  # fmt: skip


# fence scalars
CEILING, FLOOR, HAS_FLOOR, RECOVERY_E, RECOVERY_N, LINE_EDGES = range(6)


# the tables packed in one float and one int array (two arguments: a compiled call pays per array)
ELEMENTS, KEEP_IN, KEEP_OUTS, CIRCLES, GAP_POLYGONS, GAP_EDGES, ZEROS, SCALARS = range(8)  # float tables


_FLOAT_COLUMNS = (7, 7, 7, 3, 7, 7, 1, 1)


IDS, KEEP_OUT_OFFSETS, GAP_OFFSETS, GAP_EDGE_OFFSETS = range(8, 12)  # int vectors


_HEADER = 2 * 12  # (start, rows) of each


class MarginTables(NamedTuple):
    """A fence's tables for :func:`margins`, packed (see :meth:`geofence.geometry.local_fence.LocalFence.margin_tables`).

    Float tables: the lateral elements (:func:`geofence.geometry.elements.element_table` rows, ``danger_edges``
    then circles), the lateral margin's scan tables (the keep-in's and keep-outs' polygon rows, the circles),
    the floor gaps' polygon rows end to end and their edge elements end to end (normals out of the gap), a
    zero per element, and ``(ceiling, floor (nan without), has floor, recovery east, recovery north, line-scored elements)``.
    Int vectors: the element ids in order, the keep-outs', gaps' and gap edges' offsets. ``layout``'s first
    :data:`_HEADER` entries are each part's ``(start, rows)``.
    """

    floats: np.ndarray
    layout: np.ndarray

    @classmethod
    def pack(
        cls,
        elements: np.ndarray,
        ids: np.ndarray,
        scan_tables: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
        gap_polygons: tuple[np.ndarray, np.ndarray],
        gap_edges: tuple[np.ndarray, np.ndarray],
        ceiling_m: float,
        floor_m: float | None,
        recovery_en: tuple[float, float],
        line_edges: int = 0,
    ) -> MarginTables:
        """Pack a fence's tables (:meth:`geofence.geometry.local_fence.LocalFence.margin_tables` gives them): its element
        table and ids, its scan tables ``(keep-in rows, keep-out rows, their offsets, circles)``, the floor
        gaps' polygon rows and their edge elements (each ``(rows, offsets)``, :func:`geofence.geometry.scan.stacked`),
        its ceiling and floor (None: none), recovery point, and how many elements are scored at their line distance
        (:meth:`~geofence.geometry.local_fence.LocalFence.line_scored_edges`)."""
        ki, ko, ko_off, circles = scan_tables
        re, rn = recovery_en
        floats = [
            elements, ki, ko, circles,
            gap_polygons[0],
            gap_edges[0],
            np.zeros((len(ids), 1)),
            np.array(
                [ceiling_m, math.nan if floor_m is None else floor_m, float(floor_m is not None), re, rn, float(line_edges)]
            ).reshape(-1, 1),
        ]  # fmt: skip
        ints = [
            ids,
            ko_off,
            gap_polygons[1],
            gap_edges[1],
        ]
        header = np.zeros(_HEADER, np.int64)
        start = 0
        for k, (t, cols) in enumerate(zip(floats, _FLOAT_COLUMNS)):
            assert t.shape[1] == cols
            header[2 * k], header[2 * k + 1] = start, t.shape[0]
            start += t.size
        start = _HEADER
        for k, v in enumerate(ints, start=len(floats)):
            header[2 * k], header[2 * k + 1] = start, v.shape[0]
            start += v.shape[0]
        return cls(
            np.concatenate([t.ravel() for t in floats]).astype(np.float64),
            np.concatenate([header, *ints]).astype(np.int64),
        )


@jitable
def packed_table(F: np.ndarray, L: np.ndarray, k: int, cols: int) -> np.ndarray:
    """Float table ``k`` (``cols`` columns) of a packed :class:`MarginTables`."""
    return rows_view(F, L[2 * k], L[2 * k + 1], cols)


@jitable
def packed_column(F: np.ndarray, L: np.ndarray, k: int) -> np.ndarray:
    """Float table ``k`` of a packed :class:`MarginTables`, of one column, as a vector."""
    start = L[2 * k]
    return F[start : start + L[2 * k + 1]]


@jitable
def fence_scalar(F: np.ndarray, L: np.ndarray, i: int) -> float:
    """Fence scalar ``i`` (:data:`CEILING`, ...) of a packed :class:`MarginTables` (read in place: a view costs a
    reference count)."""
    return F[L[2 * SCALARS] + i]


@jitable
def packed_vector(L: np.ndarray, k: int) -> np.ndarray:
    """Int vector ``k`` of a packed :class:`MarginTables`."""
    start = L[2 * k]
    return L[start : start + L[2 * k + 1]]


def element_table(edges: Sequence[tuple], circles: Sequence[tuple[float, float, float]]) -> np.ndarray:
    """The kernel's float table of ``edges`` (``danger_edges`` items) then ``circles`` (``(east, north, r)``)."""
    rows = [(ax, ay, dx, dy, il2, nx, ny) for ax, ay, dx, dy, il2, nx, ny, *_ in edges]
    rows += [(ce, cn, r, 0.0, -1.0, 0.0, 0.0) for ce, cn, r in circles]
    return np.array(rows, dtype=np.float64).reshape(-1, 7)


@jitable
def walk_candidates(
    E: np.ndarray,
    ids: np.ndarray,
    lbs: np.ndarray,
    walk: bool,
    e: float,
    n: float,
    reach: float,
    delta_c: float,
    n_line: int,
    free: bool,
    f_id: np.ndarray,
    f_b: np.ndarray,
    f_nx: np.ndarray,
    f_ny: np.ndarray,
) -> tuple[int, float]:
    """``(count, nearest d)``: the first ``count`` entries of ``f_id, f_b, f_nx, f_ny`` (the caller's, at least
    ``ids``' length) are set to the candidates walked, the distances they are scored at and the unit
    directions they are scored along (an edge's :func:`edge_scored`, the first ``n_line`` being a convex
    keep-in's; a circle's ``hypot - radius`` and the direction to its centre), in ``ids`` order; with ``walk``,
    until the bound ``lbs[k] - delta_c - reach`` exceeds the nearest point-segment or circle distance found
    (every element within ``reach`` of the nearest is walked: each ``d`` is 1-Lipschitz)."""
    m = ids.shape[0]
    cnt = 0
    best = math.inf
    for k in range(m):
        if walk and lbs[k] - delta_c - reach > best:
            break
        i = ids[k]
        a = E[i, 0]
        b = E[i, 1]
        c = E[i, 2]
        dd = E[i, 3]
        il2 = E[i, 4]
        if il2 >= 0.0:
            d, db, nx, ny = edge_scored(e - a, n - b, c, dd, il2, E[i, 5], E[i, 6], i < n_line, free)
            f_b[cnt] = db
        else:
            dist = hypot(a - e, b - n)
            if dist > 0.0:
                nx = (a - e) / dist
                ny = (b - n) / dist
            else:
                nx = 1.0
                ny = 0.0
            d = dist - c
            f_b[cnt] = d
        f_id[cnt] = i
        f_nx[cnt] = nx
        f_ny[cnt] = ny
        cnt += 1
        if d < best:
            best = d
    return cnt, best


@jitable
def edge_scored(
    px: float, py: float, dx: float, dy: float, il2: float, nx: float, ny: float, line: bool, free: bool
) -> tuple[float, float, float, float]:
    """``(d, scored d, ux, uy)`` of an edge from a point: its point-segment distance ``d``, the distance the
    margins score it at and the unit direction they score the manoeuvre's excursion along.

    ``(px, py) = p - a`` (``a`` the edge's start), ``(dx, dy) = b - a``, ``il2 = 1/|b - a|²``, ``(nx, ny)`` the
    breach-pointing unit normal. ``line``: the edge is a convex keep-in's. ``free``: the point is in the free
    space (lateral margin >= 0).

    A margin scores an element as a distance less the manoeuvre's excursion along one direction; it is sound
    when the whole element lies at least that distance away along that direction, for then the manoeuvre must
    reach that far to touch it. Where the perpendicular foot lies on the segment that is the normal and ``d``.
    Where it lies off the segment, the normal with ``d`` is not sound: a turn drifting in wind leaves through
    the segment far along it, or heads straight at its end, with less excursion along the normal than ``d``
    (a divided circle, a U-shaped keep-in's inner corner and a keep-out's corner alike, the last two found by
    ``tests/test_edge_scoring.py``) (case history: docs/campaigns.md#breach-classes-found-and-fixed). Two
    sound choices remain:

    * the direction to the segment's nearest point (its end) and ``d``: the nearest point of a convex set, so
      every point of the segment lies at least ``d`` along that direction; it treats the end as a point;
    * the normal and the line distance ``-(p - a)·n``, when positive: the whole segment lies on its line.
      Inside a convex keep-in, crossing any edge's line is leaving the fence, so this is the exact rule there
      (``line``), and no more pessimistic.

    Where the foot lies on the segment but the point is on the segment's breach side (the edge faces away: the
    far side of a building, seen past its near side), the normal points away from the edge and does not hold
    it either. From the free space such an edge is scored like an end: along the direction to its nearest
    point (the foot), which is sound by the same argument. Before, its normal made a phantom wall behind the
    point, which flipped a fixed-wing's scored turn within a step, so that it turned the long way round into
    the building (case history: docs/campaigns.md#breach-classes-found-and-fixed). From a breached point (inside a keep-out or
    outside the keep-in) the normal stays.
    """
    t = (px * dx + py * dy) * il2
    off = t < 0.0 or t > 1.0
    t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
    qx = px - t * dx
    qy = py - t * dy
    d = math.sqrt(qx * qx + qy * qy)
    if off:
        if line:
            dl = -(px * nx + py * ny)
            if dl > 0.0:
                return d, dl, nx, ny
        if d > 0.0:
            return d, d, -qx / d, -qy / d
    elif free and d > 0.0 and px * nx + py * ny > 0.0:  # faces away from a point in the free space
        return d, d, -qx / d, -qy / d
    return d, d, nx, ny


def nearest_distance_of(E: np.ndarray, ids: np.ndarray, lbs: np.ndarray, delta_c: float, e: float, n: float) -> float:
    """The nearest candidate's ``d`` by :func:`walk_candidates` (reach 0): :meth:`FenceGrid.nearest_distance`."""
    m = ids.shape[0]
    W = np.empty((3, m))
    return walk_candidates(E, ids, lbs, True, e, n, 0.0, delta_c, 0, False, np.empty(m, np.int64), W[0], W[1], W[2])[1]


nearest_distance = compiled(nearest_distance_of)
"""The compiled :func:`nearest_distance_of`."""
