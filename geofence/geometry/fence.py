"""The fence model: a WGS-84 fence (:class:`Fence`), its validation and its YAML parser.

A :class:`Fence` is what a scenario or a ground station declares: an ordered
keep-in polygon of WGS-84 lat/lon vertices (either orientation) or a keep-in
circle (``keep_in_circle``, made into its inscribed polygon by
:func:`circle_to_polygon`, the one home of that formula), optional keep-out
polygons and circles, each with an optional :class:`VerticalExtent` (its own
floor and ceiling), a ceiling, an optional floor with floor gaps (where
descent below the floor, landing or flight termination is allowed; with no
floor, landing is allowed anywhere inside), the altitude reference
(``"agl"``: height above the home/ground; ``"amsl"``: altitude above mean sea
level) and an optional recovery point. Construction validates everything and
raises :class:`FenceError` with one line naming the field and the problem.

Keep-out vertical extents
-------------------------
A keep-out may be bounded below and/or above (a building: ``ceiling_m``; an
airspace shelf: ``floor_m``), in the fence's altitude reference. **The
geofence unit treats every keep-out as full-height** (conservative: it never
flies over or under one; lifting that is future work), so its margins and
behaviour do not depend on the extents. The **scoring**
(:mod:`analysis.scoring`) counts a keep-out entry only inside the keep-out's
volume, with :meth:`VerticalExtent.volume_margin_array`.

:meth:`Fence.to_local` projects it into a :class:`~geofence.geometry.geodesy.LocalFrame`
(by default one at the keep-in vertices' centre) and returns a
:class:`~geofence.geometry.local_fence.LocalFence` (its own module) with precomputed :class:`~geofence.geometry.polygon.PolygonIndex`
objects and fast scalar margins (plain Python floats, for the 40 Hz loop) plus
vectorized ``*_array`` versions for analysis. For a fence of more than a few
dozen elements the per-step lateral queries are answered from a
:class:`~geofence.geometry.fence_grid.FenceGrid` (only the elements within reach; the
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
from typing import Any, Mapping, Sequence

import numpy as np

from geofence.geometry.geodesy import LocalFrame, ecef_to_geodetic, geodesic_destination, geodesic_distance_m, geodetic_to_ecef
from geofence.geometry.heights import ALTITUDE_REFERENCES, FULL_HEIGHT, AltitudeReference, VerticalExtent  # noqa: F401 (re-exported)
from geofence.geometry.local_fence import LocalFence
from geofence.geometry.polygon import (
    polygon_covers_polygon,
    polygons_intersect,
    self_intersections,
    signed_area,
)
from geofence.validation import ConfigError, enum_value, field_default, latitude, longitude, number, reject_unknown_keys


class FenceError(ConfigError):
    """An invalid fence: one line, naming the field and the problem."""


LatLon = tuple[float, float]
PolygonLL = tuple[LatLon, ...]


DEFAULT_CIRCLE_TOLERANCE_M = 0.1
"""Largest allowed gap between a keep-in circle and its inscribed polygon (m)."""
MIN_KEEP_IN_CIRCLE_RADIUS_M = 5.0
"""The smallest keep-in circle radius (m): below it, there is no room for a fence."""
MAX_KEEP_IN_CIRCLE_RADIUS_M = 10_000.0
"""The largest inline keep-in circle radius (m): up to it, :func:`circle_to_polygon`'s 720 vertices meet
:data:`DEFAULT_CIRCLE_TOLERANCE_M` (sag ``r(1 - cos(pi/720))`` = 0.095 m at 10 km)."""


MAX_CEILING_M = 10_000.0
"""The highest ceiling or floor a fence may have, m (above any small UAS: a larger value is a typo), whoever
gives it: a scenario, a fence file or the command line."""
LOCAL_FRAMES_KEPT = 8
"""Projections of one fence kept by :meth:`Fence.to_local` (a flight uses one or two frames; a bound, not a guess)."""


@dataclass(frozen=True)
class KeepOutCircle:
    """A circular keep-out zone: centre (WGS-84 deg), radius in m, and its :class:`VerticalExtent`."""

    center_lat_deg: float
    center_lon_deg: float
    radius_m: float
    extent: VerticalExtent = FULL_HEIGHT


def circle_to_polygon(
    lat_deg: float, lon_deg: float, radius_m: float, tolerance_m: float = DEFAULT_CIRCLE_TOLERANCE_M
) -> tuple[PolygonLL, int, float]:
    """An inscribed regular polygon of a geodesic circle: ``(vertices, n, max_gap_m)``.

    The vertices lie on the geodesic circle (azimuths ``360 k / n`` from the centre, at ``radius_m``), so
    the polygon lies inside the circle: a conservative keep-in. ``n`` is the smallest count in [16, 720]
    with chord sag ``r(1 - cos(pi/n)) <= tolerance_m``; ``max_gap_m`` is that sag (how far inside the
    circle an edge's midpoint lies). The one home of this formula (the keep-in circle of a scenario and
    the inclusion circle of a fence file).
    """
    if not radius_m > 0.0:
        raise FenceError(f"circle radius must be > 0, got {radius_m:g}")
    ratio = 1.0 - min(tolerance_m / radius_m, 1.0)
    n = 16 if ratio <= math.cos(math.pi / 16) else math.ceil(math.pi / math.acos(ratio))
    n = max(16, min(720, n))
    verts = tuple(geodesic_destination(lat_deg, lon_deg, 360.0 * k / n, radius_m) for k in range(n))
    return verts, n, radius_m * (1.0 - math.cos(math.pi / n))


@dataclass(frozen=True)
class Fence:
    """A validated WGS-84 fence (see the module docstring).

    ``keep_in``, ``keep_out_polygons`` and ``floor_gaps`` hold ``(lat_deg,
    lon_deg)`` vertices in order (either orientation; a closing vertex equal to
    the first is dropped). ``recovery_point`` is ``(lat, lon)`` or ``(lat, lon,
    alt_m)`` with the altitude in ``altitude_reference``; when omitted
    :meth:`resolved_recovery_point` supplies the default (the pole of
    inaccessibility of the allowed area, at mid-height).

    ``keep_in_circle``: ``(lat_deg, lon_deg, radius_m)`` of a circular keep-in,
    kept so that messages and reports can name it; ``keep_in`` is then its
    inscribed polygon (:func:`circle_to_polygon` at
    :data:`DEFAULT_CIRCLE_TOLERANCE_M`): pass ``keep_in=()`` and it is filled in
    (a ``keep_in`` given with it must be that polygon). The radius is
    :data:`MIN_KEEP_IN_CIRCLE_RADIUS_M` to :data:`MAX_KEEP_IN_CIRCLE_RADIUS_M`.

    ``keep_out_polygon_extents``: one :class:`VerticalExtent` per keep-out
    polygon, in order (``()``: all full-height); a circle carries its own
    (:attr:`KeepOutCircle.extent`). Each bound is finite, the floor below the
    ceiling, the floor below the fence's ceiling and (AGL) the ceiling above
    the ground. The unit treats every keep-out as full-height; only the
    scoring uses the extents (see the module docstring).
    """

    keep_in: PolygonLL
    ceiling_m: float
    floor_m: float | None = None
    altitude_reference: AltitudeReference = AltitudeReference.AGL
    floor_gaps: tuple[PolygonLL, ...] = ()
    keep_out_polygons: tuple[PolygonLL, ...] = ()
    keep_out_circles: tuple[KeepOutCircle, ...] = ()
    recovery_point: tuple[float, ...] | None = None
    keep_in_circle: tuple[float, float, float] | None = None
    keep_out_polygon_extents: tuple[VerticalExtent, ...] = ()
    _default_local: list = field(default_factory=list, init=False, repr=False, compare=False)
    _local_by_frame: dict = field(default_factory=dict, init=False, repr=False, compare=False)

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
        elif self.altitude_reference is AltitudeReference.AGL and not ceiling > 0.0:
            raise FenceError(f"ceiling_m: {ceiling:g} m AGL must be above the ground (> 0)")

        if self.keep_in_circle is not None:
            circle = _keep_in_circle(self.keep_in_circle)
            set_(self, "keep_in_circle", circle)
            polygon = circle_to_polygon(*circle)[0]
            if self.keep_in is None or len(self.keep_in) == 0:
                set_(self, "keep_in", polygon)
            elif _polygon(self.keep_in, "keep_in") != _polygon(polygon, "keep_in_circle"):
                raise FenceError("keep_in_circle: keep_in is not this circle's polygon; give one of keep_in, keep_in_circle")
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
            circles.append(KeepOutCircle(lat, lon, r, self._extent(c.extent, name)))
        set_(self, "keep_out_circles", tuple(circles))
        extents = _seq(self.keep_out_polygon_extents, "keep_out_polygon_extents")
        n_polys = len(self.keep_out_polygons)
        if not extents:
            extents = (FULL_HEIGHT,) * n_polys
        elif len(extents) != n_polys:
            raise FenceError(f"keep_out_polygon_extents: {len(extents)} extents for {n_polys} keep_out_polygons (one each)")
        set_(
            self,
            "keep_out_polygon_extents",
            tuple(self._extent(x, f"keep_out_polygons[{i}]") for i, x in enumerate(extents)),
        )
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
                agl = self.altitude_reference is AltitudeReference.AGL
                lo = self.floor_m if self.floor_m is not None else (0.0 if agl else -math.inf)
                if self.floor_m is not None and local.in_floor_gap(e, n):
                    lo = 0.0 if agl else -math.inf
                if not lo < alt < ceiling:
                    raise FenceError(f"recovery_point: altitude {alt:g} m is not between the floor and ceiling_m {ceiling:g} m")

    def _extent(self, x: Any, name: str) -> VerticalExtent:
        """``x`` (a :class:`VerticalExtent` or a ``(floor_m, ceiling_m)`` pair) validated against this fence."""
        if isinstance(x, (str, bytes, Mapping)) or not isinstance(x, Sequence) or len(x) != 2:
            raise FenceError(f"{name}: vertical extent must be (floor_m, ceiling_m), got {x!r}")
        lo = None if x[0] is None else _number(x[0], f"{name}.floor_m")
        hi = None if x[1] is None else _number(x[1], f"{name}.ceiling_m")
        if lo is not None and hi is not None and not hi > lo:
            raise FenceError(f"{name}.ceiling_m: {hi:g} m must be above its floor_m {lo:g} m")
        if lo is not None and not lo < self.ceiling_m:
            raise FenceError(
                f"{name}.floor_m: {lo:g} m is at or above the fence's ceiling_m {self.ceiling_m:g} m (the keep-out constrains nothing)"
            )
        if hi is not None and self.altitude_reference is AltitudeReference.AGL and not hi > 0.0:
            raise FenceError(f"{name}.ceiling_m: {hi:g} m AGL must be above the ground (> 0)")
        return VerticalExtent(lo, hi)

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

    def to_local(self, frame: LocalFrame | None = None, *, index: bool | None = None) -> LocalFence:
        """This fence projected into ``frame`` (default: :meth:`default_frame`); ``index``: see :class:`LocalFence`.
        Cached by frame origin and ``index``: a scenario's checks, its pre-flight check and its flight project the
        fence into the same frame, and a projection costs its inscribed circles (tens of ms)."""
        if frame is None and index is None:
            if not self._default_local:
                self._default_local.append(LocalFence(self, self.default_frame()))
            return self._default_local[0]
        frame = frame if frame is not None else self.default_frame()
        key = (frame.lat0_deg, frame.lon0_deg, frame.h0_m, index)
        local = self._local_by_frame.get(key)
        if local is None:
            if len(self._local_by_frame) >= LOCAL_FRAMES_KEPT:
                self._local_by_frame.clear()
            local = self._local_by_frame[key] = LocalFence(self, frame, index=index)
        return local

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
def _as_fence_error(read: Any, x: Any, name: str) -> float:
    """``read`` (a kit reader) applied to ``x`` (numpy scalars too), its error as a :class:`FenceError`."""
    try:
        return read(x.item() if isinstance(x, np.generic) else x, name)
    except ConfigError as exc:
        raise FenceError(str(exc)) from None


def _number(x: Any, name: str) -> float:
    """A finite number (numpy scalars too), as a :class:`FenceError`."""
    return _as_fence_error(number, x, name)


def _seq(x: Any, name: str) -> Sequence:
    if x is None:
        return ()
    if isinstance(x, (str, bytes, Mapping)) or not isinstance(x, Sequence):
        raise FenceError(f"{name}: must be a list, got {type(x).__name__}")
    return x


def _latlon(p: Any, name: str) -> LatLon:
    if isinstance(p, (str, bytes, Mapping)) or not isinstance(p, Sequence) or len(p) != 2:
        raise FenceError(f"{name}: must be [lat_deg, lon_deg], got {p!r}")
    return _as_fence_error(latitude, p[0], f"{name} latitude"), _as_fence_error(longitude, p[1], f"{name} longitude")


def _keep_in_circle(c: Any, name: str = "keep_in_circle") -> tuple[float, float, float]:
    """``(lat, lon, radius_m)`` of a keep-in circle, validated (radius within the limits, no pole inside)."""
    if isinstance(c, (str, bytes, Mapping)) or not isinstance(c, Sequence) or len(c) != 3:
        raise FenceError(f"{name}: must be (lat_deg, lon_deg, radius_m), got {c!r}")
    lat, lon = _latlon(c[:2], f"{name}.center")
    r = _as_fence_error(number, c[2], f"{name}.radius_m")
    if not MIN_KEEP_IN_CIRCLE_RADIUS_M <= r <= MAX_KEEP_IN_CIRCLE_RADIUS_M:
        raise FenceError(
            f"{name}.radius_m: must be {MIN_KEEP_IN_CIRCLE_RADIUS_M:g} to {MAX_KEEP_IN_CIRCLE_RADIUS_M:g} m, got {r:g} "
            f"(a larger area: a keep_in polygon or a fence file)"
        )
    pole = geodesic_distance_m(lat, lon, math.copysign(90.0, lat), 0.0)
    if r >= pole:
        raise FenceError(f"{name}: a circle of {r:g} m at latitude {lat:g} contains the pole ({pole:.0f} m away)")
    return lat, lon, r


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
    "keep_in_circle",
    "ceiling_m",
    "floor_m",
    "altitude_reference",
    "floor_gaps",
    "keep_out_polygons",
    "keep_out_circles",
    "recovery_point",
)
_CIRCLE_KEYS = ("center", "radius_m")
_EXTENT_KEYS = ("floor_m", "ceiling_m")
_KEEP_OUT_POLYGON_KEYS = ("polygon", *_EXTENT_KEYS)


def _circle_mapping(c: Any, name: str, optional: tuple[str, ...] = ()) -> tuple[float, float, Any]:
    """``(lat, lon, radius)`` of a ``{center: [lat, lon], radius_m: r}`` mapping (the radius unchecked)."""
    if not isinstance(c, Mapping):
        raise FenceError(f"{name}: must be a mapping {{center: [lat, lon], radius_m: r}}, got {c!r}")
    reject_unknown_keys(c, (*_CIRCLE_KEYS, *optional), name)
    for req in _CIRCLE_KEYS:
        if req not in c:
            raise FenceError(f"{name}.{req}: required")
    lat, lon = _latlon(c["center"], f"{name}.center")
    return lat, lon, c["radius_m"]


def parse_fence(mapping: Any, where: str = "") -> Fence:
    """Validate a YAML mapping (a scenario's ``geofence.fence`` block) into a :class:`Fence`.

    Keys: ``keep_in`` (``[[lat, lon], ...]``) or ``keep_in_circle``
    (``{center: [lat, lon], radius_m: r}``, made into its inscribed polygon by
    :func:`circle_to_polygon`): exactly one of the two; ``ceiling_m``
    (required), ``floor_m``, ``altitude_reference`` (``agl`` default or
    ``amsl``), ``floor_gaps`` (list of polygons), ``keep_out_polygons`` (list
    of polygons, each a bare vertex list (full height) or ``{polygon: [...],
    floor_m: f, ceiling_m: c}`` with optional bounds), ``keep_out_circles``
    (list of ``{center: [lat, lon], radius_m, floor_m, ceiling_m}``, the bounds
    optional), ``recovery_point`` (``[lat, lon]`` or ``[lat, lon, alt_m]``).
    A keep-out's ``floor_m``/``ceiling_m`` are in the fence's altitude
    reference; the unit treats every keep-out as full-height, the scoring
    counts an entry only inside its volume (see the module docstring). Unknown
    keys are rejected. Errors are :class:`FenceError` with one line
    ``"<where>: <field>: <problem>"``.
    """
    pre = f"{where}: " if where else ""
    try:
        if not isinstance(mapping, Mapping):
            raise FenceError(f"fence: must be a mapping, got {type(mapping).__name__}")
        reject_unknown_keys(mapping, _FENCE_KEYS, "fence")
        has_polygon, has_circle = mapping.get("keep_in") is not None, mapping.get("keep_in_circle") is not None
        if has_polygon and has_circle:
            raise FenceError("keep_in_circle: give keep_in (a polygon) or keep_in_circle, not both")
        if not has_polygon and not has_circle:
            raise FenceError(
                "keep_in: required (a polygon [[lat, lon], ...], or keep_in_circle: {center: [lat, lon], radius_m: r})"
            )
        if mapping.get("ceiling_m") is None:
            raise FenceError("ceiling_m: required")
        keep_in_circle = None
        if has_circle:
            keep_in_circle = _circle_mapping(mapping["keep_in_circle"], "keep_in_circle")
        circles = []
        for i, c in enumerate(_seq(mapping.get("keep_out_circles"), "keep_out_circles")):
            name = f"keep_out_circles[{i}]"
            lat, lon, r = _circle_mapping(c, name, _EXTENT_KEYS)
            extent = VerticalExtent(c.get("floor_m"), c.get("ceiling_m"))
            circles.append(KeepOutCircle(lat, lon, _number(r, f"{name}.radius_m"), extent))
        polygons, extents = [], []
        for i, k in enumerate(_seq(mapping.get("keep_out_polygons"), "keep_out_polygons")):
            if isinstance(k, Mapping):
                name = f"keep_out_polygons[{i}]"
                reject_unknown_keys(k, _KEEP_OUT_POLYGON_KEYS, name)
                if k.get("polygon") is None:
                    raise FenceError(f"{name}.polygon: required (or give the vertex list itself for a full-height keep-out)")
                polygons.append(_polygon(k["polygon"], f"{name}.polygon"))
                extents.append(VerticalExtent(k.get("floor_m"), k.get("ceiling_m")))
            else:
                polygons.append(k)
                extents.append(FULL_HEIGHT)
        floor = mapping.get("floor_m")
        return Fence(
            keep_in=mapping["keep_in"] if has_polygon else (),
            ceiling_m=mapping["ceiling_m"],
            floor_m=floor,
            altitude_reference=mapping.get("altitude_reference", field_default(Fence, "altitude_reference")),
            floor_gaps=tuple(_seq(mapping.get("floor_gaps"), "floor_gaps")),
            keep_out_polygons=tuple(polygons),
            keep_out_circles=tuple(circles),
            recovery_point=mapping.get("recovery_point"),
            keep_in_circle=keep_in_circle,
            keep_out_polygon_extents=tuple(extents),
        )
    except ConfigError as exc:  # FenceError, or a kit reader's
        raise FenceError(f"{pre}{exc}") from None


# --------------------------------------------------------------------------- local fence
