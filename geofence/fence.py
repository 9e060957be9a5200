"""The fence model: a WGS-84 fence (:class:`Fence`), its YAML parser and its local ENU form.

A :class:`Fence` is what a scenario or a ground station declares: an ordered
keep-in polygon of WGS-84 lat/lon vertices (either orientation), optional
keep-out polygons and circles, a ceiling, an optional floor with floor gaps
(where descent below the floor, landing or flight termination is allowed;
with no floor, landing is allowed anywhere inside), the altitude reference
(``"agl"``: height above the home/ground; ``"amsl"``: altitude above mean sea
level) and an optional recovery point. Construction validates everything and
raises :class:`FenceError` with one line naming the field and the problem.

:meth:`Fence.to_local` projects it into a :class:`~geofence.geodesy.LocalFrame`
(by default one at the keep-in vertices' centre) and returns a
:class:`LocalFence` with precomputed :class:`~geofence.polygon.PolygonIndex`
objects and fast scalar margins (plain Python floats, for the 40 Hz loop) plus
vectorized ``*_array`` versions for analysis. For a fence of more than a few
dozen elements the per-step lateral queries are answered from a
:class:`~geofence.fence_grid.FenceGrid` (only the elements within reach; the
same answers as the full scan, which stays as ``lateral_margin_scan_m``).

Margins (all in m, positive = inside/safe, negative = breached)
-------------------------------------------------------------------
* lateral: ``min(keep-in signed distance, distance outside each keep-out
  polygon, distance outside each keep-out circle)``;
* ceiling: ``ceiling_m - h``;
* floor: ``max(h - floor_m, gap_distance(e, n))`` where ``gap_distance`` is
  the largest floor-gap signed distance (+ inside a gap). It is the distance
  to the forbidden "below the floor and outside every gap" region: above the
  floor it is at least the height above it; below the floor inside a gap it is
  the lateral room left before leaving the gap; ``+inf`` with no floor;
* 3-D margin: the minimum of the three.

``h`` is the height in the fence's altitude reference (``VehicleState.agl_m``
for ``"agl"``, ``VehicleState.alt_m`` for ``"amsl"``), **not** the ENU ``up``
coordinate: the tangent plane drops below the ellipsoid by s²/(2R), about
3.9 m at 7 km from the origin.

Projection error bound (measured, see ``tests/test_fence.py``)
----------------------------------------------------------------
Vertices are projected exactly (geodetic -> ECEF -> ENU) at the frame's
origin height, and fence edges are straight segments in the tangent plane.
For every fence inside a 10 km x 10 km square centred on the frame origin
(points up to 7.07 km from it), at latitudes 0-85 deg:

* planar ENU distance between any two fence points differs from the WGS-84
  geodesic distance by at most **2.9 mm** (the tangent plane shortens a
  distance s from the origin by about s³/(6R²));
* a geodesic edge between two vertices deviates from the straight ENU
  segment by at most **1.6 mm**.

So the planar fence is exact to < 3 mm, far below any GNSS error. One effect
is larger and lies with the *caller*: the ENU east/north of a point at height
h above ground at distance s from the origin are displaced outward by about
h·s/R (0.13 m for h = 120 m at 7 km) because the local vertical tilts away
from the frame's. Compute the horizontal position used against the fence with
:meth:`LocalFence.horizontal_en` (projects lat/lon at the frame's height) to
stay within the 3 mm bound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np

from .fence_grid import SMALL_FENCE_ELEMENTS, FenceGrid
from .geodesy import LocalFrame, ecef_to_geodetic, geodetic_to_ecef
from .polygon import (
    PolygonIndex,
    pole_of_inaccessibility,
    polygon_covers_polygon,
    polygons_intersect,
    self_intersections,
    signed_area,
)
from .validation import ConfigError, enum_value, number, reject_unknown_keys


class FenceError(ConfigError):
    """An invalid fence: one line, naming the field and the problem."""


class AltitudeReference(StrEnum):
    """What the fence's heights (ceiling, floor, recovery altitude) are measured from."""

    AGL = "agl"
    """Above the ground under the vehicle (the scenario's flat ground at the start's ground altitude)."""
    AMSL = "amsl"
    """Above mean sea level (the WGS-84 height the platforms report)."""


ALTITUDE_REFERENCES = tuple(r.value for r in AltitudeReference)

LatLon = tuple[float, float]
PolygonLL = tuple[LatLon, ...]


@dataclass(frozen=True)
class KeepOutCircle:
    """A circular keep-out zone: centre (WGS-84 deg) and radius in m."""

    center_lat_deg: float
    center_lon_deg: float
    radius_m: float


@dataclass(frozen=True)
class Fence:
    """A validated WGS-84 fence (see the module docstring).

    ``keep_in``, ``keep_out_polygons`` and ``floor_gaps`` hold ``(lat_deg,
    lon_deg)`` vertices in order (either orientation; a closing vertex equal to
    the first is dropped). ``recovery_point`` is ``(lat, lon)`` or ``(lat, lon,
    alt_m)`` with the altitude in ``altitude_reference``; when omitted
    :meth:`resolved_recovery_point` supplies the default (the pole of
    inaccessibility of the allowed area, at mid-height).
    """

    keep_in: PolygonLL
    ceiling_m: float
    floor_m: float | None = None
    altitude_reference: AltitudeReference = AltitudeReference.AGL
    floor_gaps: tuple[PolygonLL, ...] = ()
    keep_out_polygons: tuple[PolygonLL, ...] = ()
    keep_out_circles: tuple[KeepOutCircle, ...] = ()
    recovery_point: tuple[float, ...] | None = None
    _default_local: list = field(default_factory=list, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        ref = self.altitude_reference
        try:
            set_(
                self,
                "altitude_reference",
                enum_value(ref.lower() if isinstance(ref, str) else ref, "altitude_reference", AltitudeReference),
            )
        except ConfigError as exc:
            raise FenceError(str(exc)) from None
        ceiling = _number(self.ceiling_m, "ceiling_m")
        set_(self, "ceiling_m", ceiling)
        if self.floor_m is not None:
            floor = _number(self.floor_m, "floor_m")
            set_(self, "floor_m", floor)
            if not ceiling > floor:
                raise FenceError(f"ceiling_m: {ceiling:g} m must be above floor_m {floor:g} m")
        elif self.altitude_reference == "agl" and not ceiling > 0.0:
            raise FenceError(f"ceiling_m: {ceiling:g} m AGL must be above the ground (> 0)")

        keep_in = _polygon(self.keep_in, "keep_in")
        set_(self, "keep_in", keep_in)
        set_(
            self, "floor_gaps", tuple(_polygon(g, f"floor_gaps[{i}]") for i, g in enumerate(_seq(self.floor_gaps, "floor_gaps")))
        )
        set_(
            self,
            "keep_out_polygons",
            tuple(
                _polygon(p, f"keep_out_polygons[{i}]") for i, p in enumerate(_seq(self.keep_out_polygons, "keep_out_polygons"))
            ),
        )
        circles = []
        for i, c in enumerate(_seq(self.keep_out_circles, "keep_out_circles")):
            name = f"keep_out_circles[{i}]"
            if not isinstance(c, KeepOutCircle):
                raise FenceError(f"{name}: must be a KeepOutCircle, got {type(c).__name__}")
            lat, lon = _latlon((c.center_lat_deg, c.center_lon_deg), f"{name}.center")
            r = _number(c.radius_m, f"{name}.radius_m")
            if not r > 0.0:
                raise FenceError(f"{name}.radius_m: must be > 0, got {r:g}")
            circles.append(KeepOutCircle(lat, lon, r))
        set_(self, "keep_out_circles", tuple(circles))
        if self.recovery_point is not None:
            rp = self.recovery_point
            if isinstance(rp, (str, bytes)) or not isinstance(rp, Sequence) or len(rp) not in (2, 3):
                raise FenceError(f"recovery_point: must be [lat, lon] or [lat, lon, alt_m], got {rp!r}")
            lat, lon = _latlon(rp[:2], "recovery_point")
            if len(rp) == 3:
                set_(self, "recovery_point", (lat, lon, _number(rp[2], "recovery_point altitude")))
            else:
                set_(self, "recovery_point", (lat, lon))

        # ---- planar checks in a frame at the keep-in's centre
        local = self.to_local()
        ki = local.keep_in
        for i, g in enumerate(local.floor_gaps):
            if not polygon_covers_polygon(ki.vertices, g.vertices):
                raise FenceError(f"floor_gaps[{i}]: gap is not inside the keep_in area")
        for i, k in enumerate(local.keep_out_polygons):
            if not polygons_intersect(ki.vertices, k.vertices):
                raise FenceError(f"keep_out_polygons[{i}]: lies entirely outside the keep_in area")
        for i, (ce, cn, r) in enumerate(local.keep_out_circles):
            if ki.signed_distance(ce, cn) <= -r:
                raise FenceError(f"keep_out_circles[{i}]: lies entirely outside the keep_in area")
        if local.keep_out_polygons or local.keep_out_circles:
            if local.inradius()[2] <= 0.0:
                raise FenceError("keep_out_polygons/keep_out_circles: keep-outs cover the whole keep_in area")
        if self.recovery_point is not None:
            e, n = local.recovery_en
            m = local.lateral_margin_m(e, n)
            if m <= 0.0:
                raise FenceError(f"recovery_point: not inside the allowed area (lateral margin {m:.1f} m)")
            if len(self.recovery_point) == 3:
                alt = self.recovery_point[2]
                lo = self.floor_m if self.floor_m is not None else (0.0 if self.altitude_reference == "agl" else -math.inf)
                if self.floor_m is not None and local.in_floor_gap(e, n):
                    lo = -math.inf if self.altitude_reference == "amsl" else 0.0
                if not lo < alt < ceiling:
                    raise FenceError(f"recovery_point: altitude {alt:g} m is not between the floor and ceiling_m {ceiling:g} m")

    # ---- geometry
    def center(self) -> LatLon:
        """The keep-in vertices' centre (mean of their ECEF unit vectors; antimeridian-safe), deg."""
        xs = ys = zs = 0.0
        for lat, lon in self.keep_in:
            x, y, z = geodetic_to_ecef(lat, lon, 0.0)
            xs, ys, zs = xs + x, ys + y, zs + z
        k = len(self.keep_in)
        lat, lon, _ = ecef_to_geodetic(xs / k, ys / k, zs / k)
        return lat, lon

    def default_frame(self) -> LocalFrame:
        """A LocalFrame at :meth:`center`, height 0."""
        lat, lon = self.center()
        return LocalFrame(lat, lon, 0.0)

    def to_local(self, frame: LocalFrame | None = None, *, index: bool | None = None) -> "LocalFence":
        """This fence projected into ``frame`` (default: :meth:`default_frame`, cached); ``index``: see
        :class:`LocalFence`."""
        if frame is None and index is None:
            if not self._default_local:
                self._default_local.append(LocalFence(self, self.default_frame()))
            return self._default_local[0]
        return LocalFence(self, frame if frame is not None else self.default_frame(), index=index)

    def resolved_recovery_point(self) -> tuple[float, float, float | None]:
        """``(lat, lon, alt_m)``: the declared recovery point, with defaults filled in.

        Default position: the pole of inaccessibility of the allowed area (the
        centre of its largest inscribed circle). Default altitude: midway
        between the floor (or the ground, for AGL) and the ceiling; ``None``
        for an AMSL fence with no floor (the altitude is then the caller's).
        """
        local = self.to_local()
        lat, lon, _ = local.frame.to_geodetic(*local.recovery_en, local.frame.h0_m)
        if self.recovery_point is not None:
            lat, lon = self.recovery_point[0], self.recovery_point[1]
        return lat, lon, local.recovery_height_m


# --------------------------------------------------------------------------- validation helpers
def _number(x: Any, name: str) -> float:
    """A finite number (numpy scalars too), as a :class:`FenceError`."""
    try:
        return number(x.item() if isinstance(x, np.generic) else x, name)
    except ConfigError as exc:
        raise FenceError(str(exc)) from None


def _seq(x: Any, name: str) -> Sequence:
    if x is None:
        return ()
    if isinstance(x, (str, bytes, Mapping)) or not isinstance(x, Sequence):
        raise FenceError(f"{name}: must be a list, got {type(x).__name__}")
    return x


def _latlon(p: Any, name: str) -> LatLon:
    if isinstance(p, (str, bytes, Mapping)) or not isinstance(p, Sequence) or len(p) != 2:
        raise FenceError(f"{name}: must be [lat_deg, lon_deg], got {p!r}")
    lat = _number(p[0], f"{name} latitude")
    lon = _number(p[1], f"{name} longitude")
    if not -90.0 <= lat <= 90.0:
        raise FenceError(f"{name}: latitude {lat:g} deg is outside [-90, 90]")
    if not -180.0 <= lon <= 180.0:
        raise FenceError(f"{name}: longitude {lon:g} deg is outside [-180, 180]")
    return lat, lon


def _polygon(poly: Any, name: str) -> PolygonLL:
    pts = _seq(poly, name)
    out = [_latlon(p, f"{name}[{i}]") for i, p in enumerate(pts)]
    if len(out) >= 2 and out[0] == out[-1]:
        out = out[:-1]
    if len(out) < 3:
        raise FenceError(f"{name}: needs at least 3 vertices, got {len(out)}")
    # planar checks in a frame at this polygon's first vertex
    fr = LocalFrame(out[0][0], out[0][1], 0.0)
    en = [fr.to_enu(lat, lon, 0.0)[:2] for lat, lon in out]
    bad = self_intersections(en)
    if bad:
        i, j = bad[0]
        k = len(out)
        if i == j:
            raise FenceError(f"{name}: vertices {i} and {(i + 1) % k} are the same point (zero-length edge {i})")
        more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
        raise FenceError(
            f"{name}: self-intersecting: edge {i} (vertex {i}->{(i + 1) % k}) meets edge {j} (vertex {j}->{(j + 1) % k}){more}"
        )
    if signed_area(en) == 0.0:
        raise FenceError(f"{name}: has zero area")
    return tuple(out)


# --------------------------------------------------------------------------- YAML parser
_FENCE_KEYS = (
    "keep_in",
    "ceiling_m",
    "floor_m",
    "altitude_reference",
    "floor_gaps",
    "keep_out_polygons",
    "keep_out_circles",
    "recovery_point",
)
_CIRCLE_KEYS = ("center", "radius_m")


def parse_fence(mapping: Any, where: str = "") -> Fence:
    """Validate a YAML mapping (a scenario's ``geofence.fence`` block) into a :class:`Fence`.

    Keys: ``keep_in`` (required, ``[[lat, lon], ...]``), ``ceiling_m``
    (required), ``floor_m``, ``altitude_reference`` (``agl`` default or
    ``amsl``), ``floor_gaps`` (list of polygons), ``keep_out_polygons`` (list of
    polygons), ``keep_out_circles`` (list of ``{center: [lat, lon], radius_m}``),
    ``recovery_point`` (``[lat, lon]`` or ``[lat, lon, alt_m]``). Unknown keys
    are rejected. Errors are :class:`FenceError` with one line
    ``"<where>: <field>: <problem>"``.
    """
    pre = f"{where}: " if where else ""
    try:
        if not isinstance(mapping, Mapping):
            raise FenceError(f"fence: must be a mapping, got {type(mapping).__name__}")
        reject_unknown_keys(mapping, _FENCE_KEYS, "fence")
        for req in ("keep_in", "ceiling_m"):
            if req not in mapping or mapping[req] is None:
                raise FenceError(f"{req}: required")
        circles = []
        for i, c in enumerate(_seq(mapping.get("keep_out_circles"), "keep_out_circles")):
            name = f"keep_out_circles[{i}]"
            if not isinstance(c, Mapping):
                raise FenceError(f"{name}: must be a mapping {{center: [lat, lon], radius_m: r}}, got {c!r}")
            reject_unknown_keys(c, _CIRCLE_KEYS, name)
            for req in _CIRCLE_KEYS:
                if req not in c:
                    raise FenceError(f"{name}.{req}: required")
            lat, lon = _latlon(c["center"], f"{name}.center")
            circles.append(KeepOutCircle(lat, lon, _number(c["radius_m"], f"{name}.radius_m")))
        floor = mapping.get("floor_m")
        return Fence(
            keep_in=mapping["keep_in"],
            ceiling_m=mapping["ceiling_m"],
            floor_m=floor,
            altitude_reference=mapping.get("altitude_reference", "agl"),
            floor_gaps=tuple(_seq(mapping.get("floor_gaps"), "floor_gaps")),
            keep_out_polygons=tuple(_seq(mapping.get("keep_out_polygons"), "keep_out_polygons")),
            keep_out_circles=tuple(circles),
            recovery_point=mapping.get("recovery_point"),
        )
    except ConfigError as exc:  # FenceError, or a kit reader's
        raise FenceError(f"{pre}{exc}") from None


# --------------------------------------------------------------------------- local fence
FEATURE_KEEP_IN = "keep_in"
FEATURE_KEEP_OUT_POLYGON = "keep_out_polygon"
FEATURE_KEEP_OUT_CIRCLE = "keep_out_circle"
FEATURE_FLOOR_GAP = "floor_gap"


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


class LocalFence:
    """A :class:`Fence` projected into a :class:`LocalFrame` (ENU metres), with fast margins.

    Attributes: ``fence``, ``frame``, ``keep_in`` (:class:`PolygonIndex`),
    ``keep_out_polygons`` and ``floor_gaps`` (tuples of PolygonIndex),
    ``keep_out_circles`` (tuple of ``(east_m, north_m, radius_m)``),
    ``ceiling_m``, ``floor_m`` (``None`` = no floor), ``altitude_reference``,
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
        "floor_gaps",
        "ceiling_m",
        "floor_m",
        "altitude_reference",
        "recovery_en",
        "recovery_height_m",
        "_inradius",
        "_no_keepouts",
        "_danger_edges",
        "_gap_edges",
        "_grid",
        "_use_index",
    )

    def __init__(self, fence: Fence, frame: LocalFrame, *, index: bool | None = None) -> None:
        """``index``: answer the per-step lateral queries from a :class:`~geofence.fence_grid.FenceGrid`
        (``None``: when the fence has at least :data:`~geofence.fence_grid.SMALL_FENCE_ELEMENTS` elements;
        ``False``: always the full scan, the reference the index is tested against)."""
        self.fence = fence
        self.frame = frame
        self._grid: FenceGrid | None = None
        h0 = frame.h0_m

        def proj(poly: PolygonLL) -> PolygonIndex:
            return PolygonIndex([frame.to_enu(lat, lon, h0)[:2] for lat, lon in poly])

        self.keep_in = proj(fence.keep_in)
        self.keep_out_polygons = tuple(proj(p) for p in fence.keep_out_polygons)
        self.floor_gaps = tuple(proj(p) for p in fence.floor_gaps)
        self.keep_out_circles = tuple(
            (*frame.to_enu(c.center_lat_deg, c.center_lon_deg, h0)[:2], c.radius_m) for c in fence.keep_out_circles
        )
        self.ceiling_m = fence.ceiling_m
        self.floor_m = fence.floor_m
        self.altitude_reference = fence.altitude_reference
        self._no_keepouts = not self.keep_out_polygons and not self.keep_out_circles
        n_elements = self.keep_in.n + sum(k.n for k in self.keep_out_polygons) + len(self.keep_out_circles)
        self._use_index = index if index is not None else n_elements >= SMALL_FENCE_ELEMENTS
        self._inradius: tuple[float, float, float] | None = None
        self._danger_edges: tuple[DangerEdge, ...] | None = None
        self._gap_edges: tuple[tuple[DangerEdge, ...], ...] | None = None
        self.recovery_height_m: float | None
        rp = fence.recovery_point
        if rp is not None:
            self.recovery_en = frame.to_enu(rp[0], rp[1], h0)[:2]
        else:
            e, n, _ = self.inradius()
            self.recovery_en = (e, n)
        if rp is not None and len(rp) == 3:
            self.recovery_height_m = rp[2]
        elif fence.floor_m is not None:
            self.recovery_height_m = 0.5 * (fence.floor_m + fence.ceiling_m)
        elif fence.altitude_reference == "agl":
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
                self.danger_edges(), self.keep_out_circles, FEATURE_KEEP_OUT_CIRCLE, self.keep_in, self.keep_out_polygons
            )
        return self._grid

    # ---- scalar margins (per-step)
    def lateral_margin_m(self, e: float, n: float) -> float:
        """Lateral margin in m: + inside the allowed area, - breached (keep-in or a keep-out)."""
        grid = self._grid if self._grid is not None else self.grid()
        if grid is not None:
            m = grid.clearly_allowed(e, n)
            if m is not None:
                return m
        return self.lateral_margin_scan_m(e, n)

    def lateral_margin_exceeds(self, e: float, n: float, m: float) -> bool:
        """``lateral_margin_m(e, n) > m``, answered from the index's lower bound when it suffices (far from
        every boundary), else exactly."""
        grid = self._grid if self._grid is not None else self.grid()
        if grid is not None:
            lb = grid.margin_lower_bound(e, n)
            if lb is not None and lb > m:
                return True
        return self.lateral_margin_m(e, n) > m

    def lateral_margin_scan_m(self, e: float, n: float) -> float:
        """:meth:`lateral_margin_m` by the full scan of every element (the reference; also the breached case)."""
        m = self.keep_in.signed_distance(e, n)
        if self._no_keepouts:
            return m
        for k in self.keep_out_polygons:
            d = -k.signed_distance(e, n)
            if d < m:
                m = d
        for ce, cn, r in self.keep_out_circles:
            d = math.hypot(e - ce, n - cn) - r
            if d < m:
                m = d
        return m

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
        best = -math.inf
        for g in self.floor_gaps:
            d = g.signed_distance(e, n)
            if d > best:
                best = d
        return best

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
        """``(index, signed distance)`` of the floor gap that (e, n) is deepest inside; ``(-1, -inf)`` with no gaps."""
        best, best_d = -1, -math.inf
        for i, g in enumerate(self.floor_gaps):
            d = g.signed_distance(e, n)
            if d > best_d:
                best, best_d = i, d
        return best, best_d

    # ---- whole-fence properties
    def inradius(self) -> tuple[float, float, float]:
        """``(east, north, r)``: centre and radius of the largest circle inside the allowed area."""
        if self._inradius is None:
            size = max(self.keep_in.bbox[2] - self.keep_in.bbox[0], self.keep_in.bbox[3] - self.keep_in.bbox[1])
            self._inradius = pole_of_inaccessibility(self.lateral_margin_m, self.keep_in.bbox, precision_m=max(0.01, 1e-4 * size))
        return self._inradius
