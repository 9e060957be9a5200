"""Which lateral fence elements can matter near a point: the per-step candidate sets of a large fence.

One question: for a position ``p`` and a *reach* ``r`` (the largest room the
platform can need against any edge in the current wind, see
:func:`geofence.margins.kernel.room_bound`), which boundary elements can have
``d_s(p) < d_min(p) + r``, where ``d_s`` is the distance an element is scored
at (:func:`geofence.geometry.elements.edge_scored`: its distance ``d``, or for a
convex keep-in's edge its line distance where that is nearer) and ``d_min``
the nearest element's distance? Only those can bind the activation margin (an
element's activation is ``d_s - room >= d_s - r``), so the per-step cost
depends on the elements *within reach*, not on the size of the fence.

Elements and their distance ``d`` (the same float arithmetic as the full scan):
keep-in and keep-out polygon edges (unsigned point-segment distance) and
keep-out circles (``hypot - radius``, negative inside), in the order of
:meth:`LocalFence.danger_edges` followed by ``keep_out_circles``.

The index is a table of square cells (``cell_m`` on a side) filled lazily:
the first time the vehicle is in a cell, one vectorised pass over all elements
(numpy, ``O(N)``) computes their bounds ``g(c)`` from the cell centre ``c``
(``d(c)``, or for a line-scored edge ``min(d, line distance)``: at most
``d_s`` and ``d``, and 1-Lipschitz, :meth:`FenceGrid._bounds_from`) and keeps,
sorted by ``g(c)``, those with ``g(c) <= U + r_cell + h`` where ``h`` is the
half diagonal and ``U = min d(c) + h`` bounds ``d_min`` anywhere in the cell.
While the vehicle stays in the cell every step reuses that list: it walks it
in order of ``g(c)`` and stops as soon as the lower bound ``g(c) - |p - c|``
exceeds the best distance found plus the reach. A step therefore costs
``O(elements within reach)``; a new cell costs one ``O(N)`` numpy pass. A
larger reach than the cell was built for rebuilds it (with 1.5x the reach).
From :data:`BLOCK_MIN_ELEMENTS` elements on, the ``O(N)`` pass is made once per
block of 8 x 8 cells, keeping the elements any of its cells can keep (by the
same Lipschitz argument, :meth:`FenceGrid._block_ids`); a new cell then looks
at its block's elements only and keeps the same list.

Containment for the lateral margin (inside the keep-in? inside a keep-out?)
is exact too: each cell records whether it lies wholly inside or outside the
keep-in (no keep-in edge within its half diagonal) and which keep-out
polygons' bounding boxes meet it; in a cell the keep-in boundary crosses, the
crossing parity is counted over the edges of one horizontal row strip (the
only edges that can straddle the point's latitude line), with the same test
as :meth:`geofence.geometry.polygon.PolygonIndex.signed_distance`.

The per-step walk is compiled (:func:`geofence.margins.lateral.lateral_binding`
over :meth:`FenceGrid.candidates`, in :func:`geofence.margins.kernel.indexed_margins`;
:func:`geofence.geometry.elements.nearest_distance`). ``tests/test_fence_grid.py``
compares every answer with the full scan on random fences and states (next to
corners, inside keep-outs, outside).
"""

from __future__ import annotations

import math
from typing import NamedTuple, Sequence

import numpy as np

from geofence.geometry.elements import element_table, nearest_distance
from geofence.geometry.polygon import BOUNDARY_TOL_M, PolygonIndex

SMALL_FENCE_ELEMENTS: int = 256
"""Fences with fewer lateral elements than this are scanned in full: the scan's whole-margins compiled call
(:mod:`geofence.margins.kernel`) is cheaper than the index's bookkeeping up to about 400 elements near an edge
(``bench/fence_scale.py``, 2026-11-26: 200 edges 7.4 against 8.8 µs per update for the F450RD, 8.3 against 11.8
for the Tern; 700 edges 9.1 against 8.7 and 10.8 against 12.6)."""

DEFAULT_CELL_M: float = 16.0
"""Side of a cache cell (m): a vehicle at 20 m/s enters a new cell about every 0.8 s."""

MIN_REACH_M: float = 50.0
"""A cell is built for at least this reach (m), so small changes of speed do not rebuild it."""

MAX_CELLS: int = 50_000
"""Cells kept before the table is cleared (memory bound for long flights over big fences)."""

BLOCK_CELLS: int = 8
"""Cells along a side of a block: from :data:`BLOCK_MIN_ELEMENTS` elements on, a new cell looks only at its block's
elements (:meth:`FenceGrid._block_ids`), and the pass over every element is made once per block."""

BLOCK_MIN_ELEMENTS: int = 2000
"""From this many elements on, cells are built from their block's elements (:data:`BLOCK_CELLS`)."""

BLOCK_SLACK_M: float = 1e-6
"""Slack (m) of a block's selection, far beyond the round-off of its distances."""

MAX_CACHED_CANDIDATES: int = 4_000_000
"""Candidates (all cells together) kept before the table is cleared: a cell far inside a 100,000-vertex fence
can hold most of its elements, and scattered queries (an inradius search) visit thousands of cells."""


class Cell(NamedTuple):
    """One cache cell: what every query at a point inside it starts from (:meth:`FenceGrid.cell_at`)."""

    built_for: float
    """The reach (m) its candidate list covers."""
    cx: float
    cy: float
    """Its centre (m, ENU)."""
    ids: np.ndarray
    """Every candidate element's id, sorted by ``lbs``."""
    lbs: np.ndarray
    """Each candidate's bound ``g`` from the centre (:meth:`FenceGrid._bounds_from`: a lower bound of the distance
    it is scored at, and of its distance, from any point ``p``, plus ``|p - c|``)."""
    u: float
    """The nearest element's distance from the centre plus the half diagonal: bounds ``d_min`` in the cell."""
    ki_state: int
    """The keep-in wholly around the cell (+1), wholly away (-1) or crossing it (0)."""
    ko: tuple[int, ...]
    """The keep-out polygons whose bounding box meets the cell."""


class FenceGrid:
    """The candidate-set index of one :class:`~geofence.geometry.local_fence.LocalFence` (see the module docstring).

    ``edges``: the :meth:`LocalFence.danger_edges` items ``(ax, ay, dx, dy,
    inv_len2, nx, ny, ...)``; ``circles``: ``(east, north, radius)``;
    ``keep_in`` / ``keep_outs``: the polygons, for containment.
    """

    def __init__(
        self,
        edges: Sequence[tuple],
        circles: Sequence[tuple[float, float, float]],
        keep_in: PolygonIndex,
        keep_outs: Sequence[PolygonIndex],
        cell_m: float = DEFAULT_CELL_M,
        line_edges: int = 0,
        block_min_elements: int = BLOCK_MIN_ELEMENTS,
    ) -> None:
        self.block_min_elements = int(block_min_elements)
        """From this many elements on, cells are built from their block's elements (the same cells)."""
        self.line_edges = int(line_edges)
        """The first ``line_edges`` elements are a convex keep-in's edges (:func:`~geofence.geometry.elements.edge_scored`)."""
        self.cell_m = float(cell_m)
        self.half_diag_m = self.cell_m * math.sqrt(0.5)
        s = len(edges)
        self.n_elements = s + len(circles)
        self.table = element_table(edges, circles)
        """Every element as the compiled walk's float rows (:func:`geofence.geometry.elements.element_table`)."""
        e = self.table[:s]
        self._ax, self._ay, self._dx, self._dy, self._il2, self._nx, self._ny = (e[:, k].copy() for k in range(7))
        c = np.array(list(circles), dtype=float).reshape(-1, 3)
        self._ce, self._cn, self._cr = (c[:, k].copy() for k in range(3))
        self._keep_in = keep_in
        self._keep_outs = tuple(keep_outs)
        kb = np.array([k.bbox for k in keep_outs], dtype=float).reshape(-1, 4)
        self._ko_bbox = kb
        self._cells: dict[tuple[int, int], Cell] = {}
        self._blocks: dict[tuple[int, int], tuple[float, np.ndarray]] = {}  # block -> (reach, ids): _block_ids
        self._cached = 0
        self._rows = _RowStrips(keep_in)

    # ---- cells
    def _segment_distances(self, x: float, y: float, which) -> np.ndarray:
        """Distance from (x, y) to the edges selected by ``which`` (a slice or index array), vectorised."""
        dx, dy = self._dx[which], self._dy[which]
        px, py = x - self._ax[which], y - self._ay[which]
        t = np.clip((px * dx + py * dy) * self._il2[which], 0.0, 1.0)
        qx, qy = px - t * dx, py - t * dy
        return np.sqrt(qx * qx + qy * qy)

    def _distances_from(self, x: float, y: float, ids: np.ndarray | None = None) -> np.ndarray:
        """``d`` of every element from (x, y), or of the elements ``ids`` (ascending), vectorised, in element order
        (element by element the same floats either way)."""
        if ids is None:
            d_seg = self._segment_distances(x, y, slice(None))
            d_circ = np.hypot(self._ce - x, self._cn - y) - self._cr
        else:
            s = len(self._ax)
            k = int(np.searchsorted(ids, s))
            d_seg = self._segment_distances(x, y, ids[:k])
            c = ids[k:] - s
            d_circ = np.hypot(self._ce[c] - x, self._cn[c] - y) - self._cr[c]
        return np.concatenate([d_seg, d_circ])

    def _bounds_from(self, x: float, y: float, d: np.ndarray, ids: np.ndarray | None = None) -> np.ndarray:
        """``g``: a 1-Lipschitz lower bound of the distance each element (every one, or ``ids``, ascending) is
        scored at, from (x, y), given their distances ``d`` from it: ``d`` itself, but for the first
        :attr:`line_edges` (a convex keep-in's edges, scored at their line distance ``dl`` where the foot lies off
        the edge: :func:`~geofence.geometry.elements.edge_scored`) ``min(d, max(dl, 0))``, which can be far below
        ``d`` (an edge far along a slightly curved side)."""
        k = self.line_edges if ids is None else int(np.searchsorted(ids, self.line_edges))
        if k == 0:
            return d
        which = slice(0, k) if ids is None else ids[:k]
        dl = -((x - self._ax[which]) * self._nx[which] + (y - self._ay[which]) * self._ny[which])
        g = d.copy()
        g[:k] = np.minimum(d[:k], np.maximum(dl, 0.0))
        return g

    def _block_ids(self, key: tuple[int, int], built_for: float) -> np.ndarray:
        """The elements (ascending ids) every cell of ``key``'s block (:data:`BLOCK_CELLS` cells a side) can keep
        when built for a reach up to ``built_for``: one pass over every element per block, then each of its cells
        looks at these only.

        With ``C`` the block's centre, ``H`` its half diagonal, ``c`` a cell's centre (``|c - C| <= H``), ``h``
        the cell's half diagonal and ``r`` its reach, a cell keeps ``g(c) <= min d(c) + 2h + r``
        (:meth:`_bounds_from`); every ``g`` and ``d`` is 1-Lipschitz, so those have
        ``g(C) <= min d(C) + 2H + 2h + r``, and the keep-in edges a cell's
        containment looks at (``d(c) <= h + 1e-6``) have ``d(C) <= h + 1e-6 + H``. Kept: both, and
        :data:`BLOCK_SLACK_M` more, far beyond any rounding. The nearest element from a cell's centre is
        among them, so the cell's list and bounds are those of the pass over every element."""
        b = BLOCK_CELLS
        bkey = (key[0] // b, key[1] // b)
        blk = self._blocks.get(bkey)
        if blk is not None and blk[0] >= built_for:
            return blk[1]
        reach = max(built_for, 1.5 * blk[0] if blk is not None else 0.0)
        side = b * self.cell_m
        big_h = side * math.sqrt(0.5)
        h = self.half_diag_m
        bx, by = (bkey[0] + 0.5) * side, (bkey[1] + 0.5) * side
        d = self._distances_from(bx, by)
        g = self._bounds_from(bx, by, d)
        bound = float(d.min()) + 2.0 * big_h + 2.0 * h + reach + BLOCK_SLACK_M
        ids = np.flatnonzero((g <= bound) | (d <= h + 1e-6 + big_h + BLOCK_SLACK_M))
        self._blocks[bkey] = (reach, ids)
        self._cached += len(ids)
        return ids

    def _cell(self, e: float, n: float, reach: float) -> Cell:
        c = self.cell_m
        key = (math.floor(e / c), math.floor(n / c))
        cell = self._cells.get(key)
        if cell is not None and cell.built_for >= reach:
            return cell
        built_for = max(reach, MIN_REACH_M, 1.5 * cell.built_for if cell is not None else 0.0)
        cx, cy = (key[0] + 0.5) * c, (key[1] + 0.5) * c
        h = self.half_diag_m
        pool = self._block_ids(key, built_for) if self.n_elements >= self.block_min_elements else None
        d = self._distances_from(cx, cy, pool)
        g = self._bounds_from(cx, cy, d, pool)
        u = float(d.min()) + h
        at = np.flatnonzero(g <= u + built_for + h)
        at = at[np.argsort(g[at], kind="stable")]
        sel = at if pool is None else pool[at]
        # keep-in: wholly inside (+1), wholly outside (-1) or crossed by its boundary (0)
        n_ki = self._keep_in.n if pool is None else int(np.searchsorted(pool, self._keep_in.n))
        d_ki = float(d[:n_ki].min()) if n_ki else math.inf  # the keep-in's edges come first
        ki_state = 0 if d_ki <= h + 1e-6 else (1 if self._rows.inside(cx, cy) else -1)
        kb = self._ko_bbox
        lo_x, lo_y, hi_x, hi_y = key[0] * c, key[1] * c, (key[0] + 1) * c, (key[1] + 1) * c
        ko = tuple(np.flatnonzero((kb[:, 0] <= hi_x) & (kb[:, 2] >= lo_x) & (kb[:, 1] <= hi_y) & (kb[:, 3] >= lo_y)).tolist())
        cell = Cell(built_for, cx, cy, sel, g[at], u, ki_state, ko)
        if len(self._cells) >= MAX_CELLS or self._cached + len(sel) > MAX_CACHED_CANDIDATES:
            self._cells.clear()
            self._blocks.clear()
            self._cached = 0
        self._cells[key] = cell
        self._cached += len(sel)
        return cell

    def cell_at(self, e: float, n: float, reach: float) -> Cell:
        """The cell a query at (e, n) for ``reach`` starts from, built (or rebuilt for a larger reach) as the
        query would: its candidates and their bounds, the keep-in containment and the keep-out boxes that meet
        it. Every query below starts here; it is public so that a cell can be inspected."""
        return self._cell(e, n, reach)

    @property
    def blocks_built(self) -> int:
        """The blocks whose pass over every element has been made (0 while cells look at every element: a
        fence of fewer than ``block_min_elements`` elements)."""
        return len(self._blocks)

    def candidates(self, e: float, n: float, reach: float) -> tuple[np.ndarray, np.ndarray, float]:
        """``(ids, bounds, delta)``: the candidates within ``reach`` of (e, n) for the compiled walk
        (:func:`geofence.margins.lateral.lateral_binding`): the cell's candidate ids sorted by their distance
        ``bounds`` from the cell centre, and ``delta = |p - c|``; walked in order until
        ``bound - delta - reach`` exceeds the nearest distance found, every element with ``d - reach < d_min``
        is walked."""
        cell = self._cell(e, n, reach)
        return cell.ids, cell.lbs, math.hypot(e - cell.cx, n - cell.cy)

    def nearest_distance(self, e: float, n: float) -> float:
        """The nearest element's ``d`` (circles signed: negative inside): the walk with no reach
        (:func:`geofence.geometry.elements.nearest_distance`)."""
        ids, lbs, delta = self.candidates(e, n, 0.0)
        return nearest_distance(self.table, ids, lbs, delta, e, n)

    def margin_lower_bound(self, e: float, n: float) -> float | None:
        """A lower bound of the lateral margin at (e, n) in O(1) (no walk), or None where the cell is not wholly
        inside the keep-in or a keep-out's bounding box holds the point.

        The nearest element's distance from the cell centre, less the distance to it (1-Lipschitz).
        """
        cell = self._cell(e, n, 0.0)
        if cell.ki_state != 1 or not len(cell.ids):
            return None
        kb = self._ko_bbox
        for k in cell.ko:
            if kb[k, 0] <= e <= kb[k, 2] and kb[k, 1] <= n <= kb[k, 3]:
                return None
        return float(cell.lbs[0]) - math.hypot(e - cell.cx, n - cell.cy)

    def margin_from_index(self, e: float, n: float) -> float | None:
        """The lateral margin at (e, n) where the index gives it exactly, else ``None`` (the caller then scans
        every element). Inside the keep-in (its cell wholly inside, or the row strip's crossing parity):

        * inside no keep-out and more than the boundary tolerance from every element, the margin *is* the
          nearest element's distance;
        * inside keep-outs by more than the tolerance, the margin is the smallest of their negated depths:
          the polygons whose box holds the point and whose signed distance is >= 0 (the only ones whose term
          can be negative), and the circles, whose smallest ``d`` is then the nearest element's. The full
          scan's minimum over the same floats (the keep-in's term is positive, every other keep-out's is
          above minus the tolerance), without visiting thousands of keep-outs for one point inside a
          building, as the recovery planner asks for every corner of a dense city.
        """
        cell = self._cell(e, n, 0.0)
        if cell.ki_state < 0 or (cell.ki_state == 0 and not self._rows.inside(e, n)):
            return None
        best = self.nearest_distance(e, n)
        m = best if best < 0.0 else math.inf  # inside a circle: the deepest one's d
        kb = self._ko_bbox
        for k in cell.ko:
            if kb[k, 0] <= e <= kb[k, 2] and kb[k, 1] <= n <= kb[k, 3]:
                sd = self._keep_outs[k].signed_distance(e, n)
                if sd >= 0.0 and -sd < m:
                    m = -sd
        if m < math.inf:
            return m if m < -BOUNDARY_TOL_M else None
        return best if best > BOUNDARY_TOL_M else None


class _RowStrips:
    """Crossing parity of a polygon from one horizontal row strip of its edges (exact point-in-polygon)."""

    def __init__(self, poly: PolygonIndex) -> None:
        v = poly.starts
        w = poly.ends
        y0, y1 = float(poly.bbox[1]), float(poly.bbox[3])
        rows = max(1, min(8192, poly.n // 2))
        self.y0 = y0
        self.h = max((y1 - y0) / rows, 1e-9)
        self.rows: list[list[tuple[float, float, float, float]]] = [[] for _ in range(rows)]
        self.n_rows = rows
        for i in range(poly.n):
            ax, ay = float(v[i, 0]), float(v[i, 1])
            by = float(w[i, 1])
            dx, dy = float(w[i, 0]) - ax, by - ay
            rec = (ax, ay, by, dx / dy if dy != 0.0 else 0.0)
            r0 = self._row(min(ay, by))
            r1 = self._row(max(ay, by))
            for r in range(r0, r1 + 1):
                self.rows[r].append(rec)

    def _row(self, y: float) -> int:
        r = int((y - self.y0) / self.h)
        return 0 if r < 0 else (self.n_rows - 1 if r >= self.n_rows else r)

    def inside(self, x: float, y: float) -> bool:
        """The parity test of :meth:`PolygonIndex.signed_distance` (boundary tolerance not applied)."""
        inside = False
        for ax, ay, by, dxdy in self.rows[self._row(y)]:
            if (ay > y) != (by > y) and x - ax < (y - ay) * dxdy:
                inside = not inside
        return inside
