"""The fence in a local ENU frame: :class:`LocalFence`, with the fast margins the 40 Hz loop asks.

:meth:`geofence.geometry.fence.Fence.to_local` builds one: the WGS-84 fence projected into a
:class:`~geofence.geometry.geodesy.LocalFrame` with precomputed
:class:`~geofence.geometry.polygon.PolygonIndex` objects, fast scalar margins (plain
Python floats) and vectorized ``*_array`` versions for analysis. For a fence of
more than a few dozen elements the per-step lateral queries are answered from a
:class:`~geofence.geometry.fence_grid.FenceGrid` (only the elements within reach; the
same answers as the full scan, which stays as ``lateral_margin_scan_m``). The
margins, heights and the projection error bound are documented in
:mod:`geofence.geometry.fence`; the per-edge view the margins iterate is :class:`DangerEdge`.

Every margin here is the geofence unit's, and treats each keep-out as
full-height. The keep-outs' own floors and ceilings
(:class:`~geofence.geometry.fence.VerticalExtent`) are carried along as
``keep_out_polygon_extents`` and ``keep_out_circle_extents`` for analysis: the
scoring counts a keep-out entry only inside the keep-out's volume.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from geofence import jit as _jit
from geofence.geometry.elements import MarginTables, element_table
from geofence.geometry.fence_grid import SMALL_FENCE_ELEMENTS, FenceGrid
from geofence.geometry.geodesy import LocalFrame
from geofence.geometry.heights import AltitudeReference, VerticalExtent
from geofence.geometry.polygon import EDGE_COLUMNS, PolygonIndex, is_convex, pole_of_inaccessibility
from geofence.geometry.scan import deepest_polygon, lateral_margin_scan, stacked

if TYPE_CHECKING:
    from geofence.geometry.fence import Fence, PolygonLL


FEATURE_KEEP_IN = "keep_in"
FEATURE_KEEP_OUT_POLYGON = "keep_out_polygon"
FEATURE_KEEP_OUT_CIRCLE = "keep_out_circle"
FEATURE_FLOOR_GAP = "floor_gap"
LIPSCHITZ_SLACK_M = 1e-6
"""Round-off allowance when the lateral margin at one point is bounded by the margin at another plus their
distance (a signed distance moves no faster than the point; computed in float, it may by far less than this)."""


class DangerEdge(NamedTuple):
    """One lateral boundary edge as the margins see it (ENU m), with the unit normal pointing *towards the breach*."""

    ax: float
    ay: float
    """Start point."""
    dx: float
    dy: float
    """Edge vector (end - start)."""
    inv_len2: float
    """1 / |d|^2 (0 for a zero-length edge)."""
    nx: float
    ny: float
    """Unit normal towards the breach."""
    feature: str
    """FEATURE_KEEP_IN, FEATURE_KEEP_OUT_POLYGON or FEATURE_FLOOR_GAP."""
    feature_index: int
    """Which keep-out polygon or floor gap (0 for the keep-in)."""
    edge: int
    """The edge's index in its polygon."""


def _edge_items(p: PolygonIndex, feature: str, index: int, sign: float) -> tuple[DangerEdge, ...]:
    """A :class:`DangerEdge` per edge of ``p``; normal = sign · outward."""
    out = []
    for j in range(p.n):
        ax, ay = float(p.starts[j, 0]), float(p.starts[j, 1])
        dx, dy = float(p.ends[j, 0]) - ax, float(p.ends[j, 1]) - ay
        l2 = dx * dx + dy * dy
        nx, ny = sign * float(p.outward_normals[j, 0]), sign * float(p.outward_normals[j, 1])
        out.append(DangerEdge(ax, ay, dx, dy, 1.0 / l2 if l2 > 0.0 else 0.0, nx, ny, feature, index, j))
    return tuple(out)


INRADIUS_MEMORY = 64
"""How many (fence, frame) inradii :meth:`LocalFence.inradius` remembers (a polylabel search costs up to ~25 ms)."""
_INRADII: dict[tuple[Fence, LocalFrame], tuple[float, float, float]] = {}


class LocalFence:
    """A :class:`Fence` projected into a :class:`LocalFrame` (ENU metres), with fast margins.

    Attributes: ``fence``, ``frame``, ``keep_in`` (:class:`PolygonIndex`),
    ``keep_out_polygons`` and ``floor_gaps`` (tuples of PolygonIndex),
    ``keep_out_circles`` (tuple of ``(east_m, north_m, radius_m)``),
    ``keep_out_polygon_extents`` and ``keep_out_circle_extents`` (one
    :class:`~geofence.geometry.fence.VerticalExtent` per keep-out, in the same order;
    not used by any margin here: the unit treats every keep-out as
    full-height), ``has_keep_out_extents`` (any of them bounded), ``ceiling_m``, ``floor_m`` (``None`` = no floor), ``altitude_reference``,
    ``recovery_en`` (east, north of the recovery point) and
    ``recovery_height_m`` (``None`` if unknown, see
    :meth:`Fence.resolved_recovery_point`). Heights ``h`` are in the fence's
    altitude reference, not ENU up (see the module docstring).
    """

    __slots__ = (
        "fence",
        "frame",
        "keep_in",
        "keep_out_polygons",
        "keep_out_circles",
        "keep_out_polygon_extents",
        "keep_out_circle_extents",
        "has_keep_out_extents",
        "floor_gaps",
        "ceiling_m",
        "floor_m",
        "altitude_reference",
        "_recovery_en",
        "recovery_height_m",
        "_inradius",
        "_danger_edges",
        "_gap_edges",
        "_grid",
        "_use_index",
        "_memo_en",
        "_memo_margin_m",
        "_margin_tables",
        "_gap_table",
        "_element_table",
        "_scan_table",
        "_line_edges",
    )

    def __init__(self, fence: Fence, frame: LocalFrame, *, index: bool | None = None) -> None:
        """``index``: answer the per-step lateral queries from a :class:`~geofence.geometry.fence_grid.FenceGrid`
        (``None``: when the fence has at least :data:`~geofence.geometry.fence_grid.SMALL_FENCE_ELEMENTS` elements;
        ``False``: always the full scan, the reference the index is tested against)."""
        self.fence = fence
        self.frame = frame
        self._grid: FenceGrid | None = None
        self._memo_en: tuple[float, float] | None = None
        self._memo_margin_m = math.nan
        h0 = frame.h0_m

        def proj(poly: PolygonLL) -> PolygonIndex:
            return PolygonIndex([frame.to_enu(lat, lon, h0)[:2] for lat, lon in poly])

        self.keep_in = proj(fence.keep_in)
        self.keep_out_polygons = tuple(proj(p) for p in fence.keep_out_polygons)
        self.floor_gaps = tuple(proj(p) for p in fence.floor_gaps)
        self.keep_out_circles = tuple(
            (*frame.to_enu(c.center_lat_deg, c.center_lon_deg, h0)[:2], c.radius_m) for c in fence.keep_out_circles
        )
        self.keep_out_polygon_extents: tuple[VerticalExtent, ...] = fence.keep_out_polygon_extents
        self.keep_out_circle_extents: tuple[VerticalExtent, ...] = tuple(c.extent for c in fence.keep_out_circles)
        self.has_keep_out_extents = not all(
            x.full_height for x in (*self.keep_out_polygon_extents, *self.keep_out_circle_extents)
        )
        self.ceiling_m = fence.ceiling_m
        self.floor_m = fence.floor_m
        self.altitude_reference = fence.altitude_reference
        n_elements = self.keep_in.n + sum(k.n for k in self.keep_out_polygons) + len(self.keep_out_circles)
        self._use_index = index if index is not None else n_elements >= SMALL_FENCE_ELEMENTS
        self._inradius: tuple[float, float, float] | None = None
        self._danger_edges: tuple[DangerEdge, ...] | None = None
        self._gap_edges: tuple[tuple[DangerEdge, ...], ...] | None = None
        self._element_table: tuple | None = None
        self._scan_table: tuple | None = None
        self._margin_tables: MarginTables | None = None
        self._gap_table: tuple[np.ndarray, np.ndarray] | None = None
        self._line_edges: int | None = None
        self.recovery_height_m: float | None
        rp = fence.recovery_point
        self._recovery_en: tuple[float, float] | None = frame.to_enu(rp[0], rp[1], h0)[:2] if rp is not None else None
        if rp is not None and len(rp) == 3:
            self.recovery_height_m = rp[2]
        elif fence.floor_m is not None:
            self.recovery_height_m = 0.5 * (fence.floor_m + fence.ceiling_m)
        elif fence.altitude_reference is AltitudeReference.AGL:
            self.recovery_height_m = 0.5 * fence.ceiling_m
        else:
            self.recovery_height_m = None

    # ---- projection helper
    def horizontal_en(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """East, north (m) of a lat/lon, projected at the frame's height (see the module docstring)."""
        e, n, _ = self.frame.to_enu(lat_deg, lon_deg, self.frame.h0_m)
        return e, n

    def grid(self) -> FenceGrid | None:
        """The candidate-set index of the lateral elements (built on first use), or None for a small fence."""
        if self._grid is None and self._use_index:
            self._grid = FenceGrid(
                self.danger_edges(),
                self.keep_out_circles,
                self.keep_in,
                self.keep_out_polygons,
                line_edges=self.line_scored_edges(),
            )
        return self._grid

    def line_scored_edges(self) -> int:
        """How many lateral elements, from the first, a margin scores at their line distance where the foot lies
        off the edge (:func:`geofence.geometry.elements.edge_scored`): the keep-in's edges when it is
        convex (they come first in :meth:`danger_edges`), else none (cached)."""
        if self._line_edges is None:
            self._line_edges = self.keep_in.n if is_convex(self.keep_in.vertices) else 0
        return self._line_edges

    # ---- scalar margins (per-step)
    def lateral_margin_m(self, e: float, n: float) -> float:
        """Lateral margin in m: + inside the allowed area, - breached (keep-in or a keep-out).

        A step asks it several times at the same estimate (the unit's skip shortcut, its margins, the
        recovery route's projection and carrot): the last answer is remembered (a pure function of (e, n)).
        """
        if self._memo_en == (e, n):
            return self._memo_margin_m
        grid = self._grid if self._grid is not None else self.grid()
        m = grid.margin_from_index(e, n) if grid is not None else None
        if m is None:
            m = self.lateral_margin_scan_m(e, n)
        self._memo_en = (e, n)
        self._memo_margin_m = m
        return m

    def lateral_margin_exceeds(self, e: float, n: float, m: float) -> bool:
        """``lateral_margin_m(e, n) > m``, answered from the index's lower bound when it suffices (far from
        every boundary), or from the last margin computed (near a boundary: the margin is 1-Lipschitz, so it is
        at most that margin plus the distance from its point, with ``LIPSCHITZ_SLACK_M`` for round-off), else
        exactly."""
        if self._memo_en is not None:
            e0, n0 = self._memo_en
            if self._memo_margin_m + math.hypot(e - e0, n - n0) + LIPSCHITZ_SLACK_M <= m:
                return False
        grid = self._grid if self._grid is not None else self.grid()
        if grid is not None:
            lb = grid.margin_lower_bound(e, n)
            if lb is not None and lb > m:
                return True
        return self.lateral_margin_m(e, n) > m

    def lateral_margin_scan_m(self, e: float, n: float) -> float:
        """:meth:`lateral_margin_m` by the full scan of every element (also the index's breached case):
        :func:`geofence.geometry.scan.lateral_margin_scan`."""
        return lateral_margin_scan(e, n, *self.scan_tables())

    def scan_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The compiled scan's tables (cached): the keep-in's edge rows, the keep-outs' rows end to end with
        their offsets, and the circles ``(east, north, r)``."""
        if self._scan_table is None:
            self._scan_table = self._build_scan_table()
        return self._scan_table

    def margin_tables(self) -> MarginTables:
        """The compiled margins' tables of this fence (cached; :class:`geofence.geometry.elements.MarginTables`)."""
        if self._margin_tables is None:
            E, _meta, ids, _zeros = self.element_table()
            gap_edges = stacked([element_table(self.gap_edges(i), ()) for i in range(len(self.floor_gaps))], 7)
            self._margin_tables = MarginTables.pack(
                E, ids, self.scan_tables(), self.gap_table(), gap_edges, self.ceiling_m, self.floor_m, self.recovery_en,
                self.line_scored_edges(),
            )  # fmt: skip
        return self._margin_tables

    def gap_table(self) -> tuple[np.ndarray, np.ndarray]:
        """The floor gaps' polygon rows end to end and their offsets (cached; :func:`geofence.geometry.scan.stacked`)."""
        if self._gap_table is None:
            self._gap_table = stacked([g.rows for g in self.floor_gaps], EDGE_COLUMNS)
        return self._gap_table

    def remember_margin(self, e: float, n: float, margin_m: float) -> None:
        """Keep ``margin_m`` as :meth:`lateral_margin_m`'s answer at (e, n) (computed elsewhere, the same number)."""
        self._memo_en = (e, n)
        self._memo_margin_m = margin_m

    def _build_scan_table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The compiled scan's tables: the keep-in's edge rows, the keep-outs' rows end to end with their
        offsets, and the circles ``(east, north, r)``."""
        ko, offsets = stacked([k.rows for k in self.keep_out_polygons], EDGE_COLUMNS)
        circles = np.array(self.keep_out_circles, dtype=np.float64).reshape(-1, 3)
        return self.keep_in.rows, ko, offsets, circles

    def lateral_nearest(self, e: float, n: float) -> tuple[float, str, int, int, float, float]:
        """``(margin, feature, feature_index, edge, dx, dy)`` of the binding lateral constraint.

        ``feature`` is ``"keep_in"``, ``"keep_out_polygon"`` or
        ``"keep_out_circle"``; ``edge`` the polygon edge (``-1`` for a circle);
        ``(dx, dy)`` the unit direction in which the margin decreases fastest
        (towards the breach: outward across the keep-in edge, into a keep-out).
        """
        m, edge, dx, dy = self.keep_in.nearest(e, n)
        best = (m, FEATURE_KEEP_IN, 0, edge, dx, dy)
        for i, k in enumerate(self.keep_out_polygons):
            sd, edge, ox, oy = k.nearest(e, n)
            if -sd < best[0]:
                best = (-sd, FEATURE_KEEP_OUT_POLYGON, i, edge, -ox, -oy)
        for i, (ce, cn, r) in enumerate(self.keep_out_circles):
            dist = math.hypot(ce - e, cn - n)
            if dist - r < best[0]:
                ux, uy = ((ce - e) / dist, (cn - n) / dist) if dist > 0.0 else (1.0, 0.0)
                best = (dist - r, FEATURE_KEEP_OUT_CIRCLE, i, -1, ux, uy)
        return best

    def vertical_margins_m(self, h: float) -> tuple[float, float]:
        """``(ceiling_m - h, h - floor_m)``; the floor margin is ``+inf`` with no floor (gaps ignored)."""
        return self.ceiling_m - h, (h - self.floor_m) if self.floor_m is not None else math.inf

    def gap_distance_m(self, e: float, n: float) -> float:
        """Largest floor-gap signed distance (+ inside a gap); ``-inf`` with no gaps."""
        return self.best_gap(e, n)[1]

    def in_floor_gap(self, e: float, n: float) -> bool:
        """True if (e, n) is inside or on the boundary of a floor gap."""
        return self.gap_distance_m(e, n) >= 0.0

    def landing_allowed(self, e: float, n: float) -> bool:
        """Inside the allowed area and (no floor, or inside a floor gap)."""
        if self.lateral_margin_m(e, n) < 0.0:
            return False
        return self.floor_m is None or self.in_floor_gap(e, n)

    def floor_margin_m(self, e: float, n: float, h: float) -> float:
        """Gap-aware floor margin: ``max(h - floor, gap_distance)``; ``+inf`` with no floor."""
        if self.floor_m is None:
            return math.inf
        m = h - self.floor_m
        if self.floor_gaps:
            g = self.gap_distance_m(e, n)
            if g > m:
                m = g
        return m

    def margin_m(self, e: float, n: float, h: float) -> float:
        """The 3-D margin: ``min(lateral, ceiling, gap-aware floor)`` in m (+ safe)."""
        m = self.lateral_margin_m(e, n)
        c = self.ceiling_m - h
        if c < m:
            m = c
        if self.floor_m is not None:
            f = self.floor_margin_m(e, n, h)
            if f < m:
                m = f
        return m

    # ---- vectorized (analysis)
    def lateral_margin_array(self, points) -> np.ndarray:
        """Vectorized :meth:`lateral_margin_m` for an (M, 2) array of (east, north)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        m = self.keep_in.signed_distance_array(pts)
        for k in self.keep_out_polygons:
            m = np.minimum(m, -k.signed_distance_array(pts))
        for ce, cn, r in self.keep_out_circles:
            m = np.minimum(m, np.hypot(pts[:, 0] - ce, pts[:, 1] - cn) - r)
        return m

    def gap_distance_array(self, points) -> np.ndarray:
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        m = np.full(len(pts), -np.inf)
        for g in self.floor_gaps:
            m = np.maximum(m, g.signed_distance_array(pts))
        return m

    def in_floor_gap_array(self, points) -> np.ndarray:
        """Vectorized :meth:`in_floor_gap`."""
        return self.gap_distance_array(points) >= 0.0

    def vertical_margins_array(self, h) -> tuple[np.ndarray, np.ndarray]:
        """Vectorized :meth:`vertical_margins_m`."""
        h = np.asarray(h, dtype=float)
        floor = h - self.floor_m if self.floor_m is not None else np.full(h.shape, np.inf)
        return self.ceiling_m - h, floor

    def floor_margin_array(self, points, h) -> np.ndarray:
        """Vectorized :meth:`floor_margin_m`."""
        h = np.asarray(h, dtype=float)
        if self.floor_m is None:
            return np.full(h.shape, np.inf)
        m = h - self.floor_m
        if self.floor_gaps:
            m = np.maximum(m, self.gap_distance_array(points))
        return m

    def margin_array(self, points, h) -> np.ndarray:
        """Vectorized :meth:`margin_m`: ``points`` (M, 2) east/north, ``h`` (M,) heights."""
        h = np.asarray(h, dtype=float)
        m = np.minimum(self.lateral_margin_array(points), self.ceiling_m - h)
        return np.minimum(m, self.floor_margin_array(points, h))

    def danger_edges(self) -> tuple[DangerEdge, ...]:
        """Every lateral boundary edge as a :class:`DangerEdge`, for per-edge analyses (cached).

        The keep-in's edges first, then each keep-out polygon's; the normal
        points *towards the breach* (outward for keep-in edges, into the
        keep-out for keep-out edges). Circles are in ``keep_out_circles``.
        """
        if self._danger_edges is None:
            out = list(_edge_items(self.keep_in, FEATURE_KEEP_IN, 0, 1.0))
            for i, k in enumerate(self.keep_out_polygons):
                out += _edge_items(k, FEATURE_KEEP_OUT_POLYGON, i, -1.0)
            self._danger_edges = tuple(out)
        return self._danger_edges

    def element_table(self) -> tuple[np.ndarray, tuple[tuple[str, int, int], ...], np.ndarray, np.ndarray]:
        """``(E, meta, ids, zeros)`` for the compiled lateral search (cached): the float table of
        :meth:`danger_edges` then ``keep_out_circles`` (:func:`geofence.geometry.elements.element_table`), each
        element's ``(feature, feature_index, edge)``, and every element's id in order with a zero bound per
        element (the full scan's candidate list)."""
        if self._element_table is None:
            edges = self.danger_edges()
            circles = self.keep_out_circles
            meta = tuple((x.feature, x.feature_index, x.edge) for x in edges)
            meta += tuple((FEATURE_KEEP_OUT_CIRCLE, k, -1) for k in range(len(circles)))
            n = len(meta)
            grid = self.grid()  # an indexed fence's index holds the same table
            table = grid.table if grid is not None else element_table(edges, circles)
            self._element_table = (table, meta, np.arange(n, dtype=np.int64), np.zeros(n))
        return self._element_table

    def gap_edges(self, gap: int) -> tuple[DangerEdge, ...]:
        """The edges of floor gap ``gap`` in the :meth:`danger_edges` item format (cached).

        The normal points *out of the gap*: below the floor, leaving the gap
        sideways is the breach, so for a vehicle below the floor the gap's
        edges are lateral boundaries like the keep-in's.
        """
        if self._gap_edges is None:
            self._gap_edges = tuple(_edge_items(g, FEATURE_FLOOR_GAP, i, 1.0) for i, g in enumerate(self.floor_gaps))
        return self._gap_edges[gap]

    def best_gap(self, e: float, n: float) -> tuple[int, float]:
        """``(index, signed distance)`` of the floor gap that (e, n) is deepest inside; ``(-1, -inf)`` with no gaps
        (:func:`geofence.geometry.scan.deepest_polygon`)."""
        if not self.floor_gaps:
            return -1, -math.inf
        return deepest_polygon(e, n, *self.gap_table())

    # ---- whole-fence properties
    @property
    def recovery_en(self) -> tuple[float, float]:
        """(east, north) of the recovery point, m: the declared one, else the pole of inaccessibility of the allowed
        area (:meth:`inradius`), found at the first use: a projection made only to validate a fence never needs it."""
        if self._recovery_en is None:
            e, n, _ = self.inradius()
            self._recovery_en = (e, n)
        return self._recovery_en

    def _distance_function(self):
        """:meth:`lateral_margin_m` for a search that asks it thousands of times: without an index, the compiled
        scan's entry point with this fence's tables bound (the same machine code, so the same values, without the
        memo's and the dispatcher's cost per call); with one, the method itself."""
        if self.grid() is not None:
            return self.lateral_margin_m
        tables = self.scan_tables()
        lateral_margin_scan(0.0, 0.0, *tables)  # its one specialization exists before its entry point is taken
        scan = _jit.entry_point(lateral_margin_scan)
        return lambda e, n: scan(e, n, *tables)

    def inradius(self) -> tuple[float, float, float]:
        """``(east, north, r)``: centre and radius of the largest circle inside the allowed area. A pure function of
        the fence and the frame, remembered for the last :data:`INRADIUS_MEMORY` of them (a scenario's variants,
        its validation and its flight each project the same fence again)."""
        if self._inradius is None:
            key = (self.fence, self.frame)
            found = _INRADII.pop(key, None)
            if found is None:
                size = max(self.keep_in.bbox[2] - self.keep_in.bbox[0], self.keep_in.bbox[3] - self.keep_in.bbox[1])
                found = pole_of_inaccessibility(self._distance_function(), self.keep_in.bbox, precision_m=max(0.01, 1e-4 * size))
            _INRADII[key] = found  # (the newest last)
            while len(_INRADII) > INRADIUS_MEMORY:
                del _INRADII[next(iter(_INRADII))]
            self._inradius = found
        return self._inradius
