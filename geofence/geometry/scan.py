"""The lateral margin of a point by the full scan of every element, compiled.

One question (and its twin for the floor gaps, :func:`deepest_polygon`):
:meth:`geofence.geometry.local_fence.LocalFence.lateral_margin_scan_m`
(the keep-in's signed distance, less each keep-out polygon's, each circle's
``hypot - radius``, the smallest), for a small fence's every step and for the
breached points of a large one, as one compiled call over float tables built
once per fence: the arithmetic of :meth:`geofence.geometry.polygon.PolygonIndex.signed_distance`
``tests/test_lateral_kernel.py`` holds it to the vectorised margins
(:meth:`~geofence.geometry.local_fence.LocalFence.lateral_margin_array`).
"""

from __future__ import annotations

import math
from math import hypot
from typing import Sequence

import numpy as np
from numpy.lib.stride_tricks import as_strided

from geofence.geometry.polygon import BOUNDARY_TOL_M
from geofence.jit import compiled, jitable

__all__ = ["deepest_polygon", "lateral_margin_scan", "polygon_rows", "rows_view", "signed_distance_rows", "stacked"]


def polygon_rows(edges: Sequence[tuple]) -> np.ndarray:
    """A polygon's ``PolygonIndex`` edge tuples ``(ax, ay, by, dx, dy, 1/len², dx/dy)`` as a float table."""
    return np.array(edges, dtype=np.float64).reshape(-1, 7)


def stacked(tables: Sequence[np.ndarray], columns: int) -> tuple[np.ndarray, np.ndarray]:
    """``(rows, offsets)``: tables of ``columns`` columns end to end, table ``k`` at rows ``offsets[k]:offsets[k + 1]``
    (the form the compiled scans take a list of polygons in)."""
    rows = np.concatenate(tables) if len(tables) else np.zeros((0, columns))
    return rows, np.cumsum([0] + [len(t) for t in tables]).astype(np.int64)


@jitable
def rows_view(F: np.ndarray, start: int, rows: int, cols: int) -> np.ndarray:
    """``F[start : start + rows * cols].reshape(rows, cols)``, a table packed in a flat float array, as a view made
    by its strides: compiled, a reshape costs about 20 ns (a shape check in C) and a step unpacks its tables a
    dozen times."""
    return as_strided(F[start : start + rows * cols], shape=(rows, cols), strides=(cols * F.itemsize, F.itemsize))


@jitable
def signed_distance_rows(rows: np.ndarray, x: float, y: float) -> float:
    """:meth:`PolygonIndex.signed_distance` over its edge table (the same arithmetic: the smallest squared
    point-segment distance and the crossing parity, + inside, within the boundary tolerance counted inside)."""
    inside = False
    best = math.inf
    for k in range(rows.shape[0]):
        ax = rows[k, 0]
        ay = rows[k, 1]
        by = rows[k, 2]
        dx = rows[k, 3]
        dy = rows[k, 4]
        px = x - ax
        py = y - ay
        t = (px * dx + py * dy) * rows[k, 5]
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
        qx = px - t * dx
        qy = py - t * dy
        d2 = qx * qx + qy * qy
        if d2 < best:
            best = d2
        if (ay > y) != (by > y) and px < py * rows[k, 6]:
            inside = not inside
    d = math.sqrt(best)
    return d if (inside or d <= BOUNDARY_TOL_M) else -d


def _lateral_margin_scan(
    e: float, n: float, keep_in: np.ndarray, keep_outs: np.ndarray, offsets: np.ndarray, circles: np.ndarray
) -> float:
    """:meth:`LocalFence.lateral_margin_scan_m`: the keep-in's signed distance, less every keep-out polygon's
    (rows ``offsets[k]:offsets[k + 1]`` of ``keep_outs``) and every circle's ``hypot - r`` (rows ``(e, n, r)``),
    the smallest."""
    m = signed_distance_rows(keep_in, e, n)
    for k in range(offsets.shape[0] - 1):
        d = -signed_distance_rows(keep_outs[offsets[k] : offsets[k + 1]], e, n)
        if d < m:
            m = d
    for k in range(circles.shape[0]):
        d = hypot(e - circles[k, 0], n - circles[k, 1]) - circles[k, 2]
        if d < m:
            m = d
    return m


lateral_margin_scan = compiled(_lateral_margin_scan)
"""The compiled :func:`_lateral_margin_scan`."""


def _deepest_polygon(e: float, n: float, rows: np.ndarray, offsets: np.ndarray) -> tuple[int, float]:
    """``(index, signed distance)`` of the polygon (rows ``offsets[k]:offsets[k + 1]``) that (e, n) is deepest
    inside, the first on a tie; ``(-1, -inf)`` with none: :meth:`LocalFence.best_gap` over its floor gaps."""
    best, best_d = -1, -math.inf
    for k in range(offsets.shape[0] - 1):
        d = signed_distance_rows(rows[offsets[k] : offsets[k + 1]], e, n)
        if d > best_d:
            best, best_d = k, d
    return best, best_d


deepest_polygon = compiled(_deepest_polygon)
"""The compiled :func:`_deepest_polygon`."""
