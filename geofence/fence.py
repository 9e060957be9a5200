"""The fence model: a WGS-84 fence (:class:`Fence`), its validation and its YAML parser.

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
:class:`~geofence.local_fence.LocalFence` (its own module) with precomputed :class:`~geofence.polygon.PolygonIndex`
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
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from .geodesy import LocalFrame, ecef_to_geodetic, geodetic_to_ecef
from .polygon import (
    polygon_covers_polygon,
    polygons_intersect,
    self_intersections,
    signed_area,
)
from .validation import ConfigError, enum_value, field_default, latitude, longitude, number, reject_unknown_keys

if TYPE_CHECKING:
    from .local_fence import LocalFence


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
        elif self.altitude_reference is AltitudeReference.AGL and not ceiling > 0.0:
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
                agl = self.altitude_reference is AltitudeReference.AGL
                lo = self.floor_m if self.floor_m is not None else (0.0 if agl else -math.inf)
                if self.floor_m is not None and local.in_floor_gap(e, n):
                    lo = 0.0 if agl else -math.inf
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

    def to_local(self, frame: LocalFrame | None = None, *, index: bool | None = None) -> LocalFence:
        """This fence projected into ``frame`` (default: :meth:`default_frame`, cached); ``index``: see
        :class:`LocalFence`."""
        from .local_fence import LocalFence  # the local form imports this module for its types only

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
            altitude_reference=mapping.get("altitude_reference", field_default(Fence, "altitude_reference")),
            floor_gaps=tuple(_seq(mapping.get("floor_gaps"), "floor_gaps")),
            keep_out_polygons=tuple(_seq(mapping.get("keep_out_polygons"), "keep_out_polygons")),
            keep_out_circles=tuple(circles),
            recovery_point=mapping.get("recovery_point"),
        )
    except ConfigError as exc:  # FenceError, or a kit reader's
        raise FenceError(f"{pre}{exc}") from None


# --------------------------------------------------------------------------- local fence
