"""The lateral margin of a point by the full scan of every element, compiled.

One question (and its twin for the floor gaps, :func:`deepest_polygon`):
:meth:`geofence.geometry.local_fence.LocalFence.lateral_margin_scan_m`
(the keep-in's signed distance, less each keep-out polygon's, each circle's
``hypot - radius``, the smallest), for a small fence's every step and for the
breached points of a large one, as one compiled call over float tables built
once per fence, each polygon by :func:`geofence.geometry.polygon.signed_distance_rows` (the source of
:meth:`~geofence.geometry.polygon.PolygonIndex.signed_distance` too) on its edge table.
``tests/test_lateral_kernel.py`` holds it to the vectorised margins
(:meth:`~geofence.geometry.local_fence.LocalFence.lateral_margin_array`).
"""

from __future__ import annotations

import math
from math import hypot
from typing import Sequence

import numpy as np
from numpy.lib.stride_tricks import as_strided

from geofence.geometry.polygon import signed_distance_rows
from geofence.jit import compiled, jitable

__all__ = ["deepest_polygon", "lateral_margin_scan", "rows_view", "stacked"]


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
