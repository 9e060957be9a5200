"""Import real-world fence and rally files into a :class:`~geofence.geometry.fence.Fence`.

Supported formats (detected from the content, not the file name):

``qgc_plan``
    QGroundControl ``.plan`` JSON. ``geoFence.polygons[] = {inclusion,
    polygon: [[lat, lon], ...]}``, ``geoFence.circles[] = {inclusion, circle:
    {center: [lat, lon], radius}}``, ``rallyPoints.points[] = [lat, lon,
    alt]``, ``mission.plannedHomePosition = [lat, lon, alt]``. The old
    ``geoFence`` version 1 layout (``polygon`` and ``breachReturn`` directly in
    ``geoFence``) is read too.
``qgc_wpl_110``
    ``QGC WPL 110`` text: one item per line, ``seq current frame command p1 p2
    p3 p4 lat lon alt autocontinue``. Fence items (MAVLink mission_type
    FENCE): 5000 ``NAV_FENCE_RETURN_POINT``, 5001/5002
    ``NAV_FENCE_POLYGON_VERTEX_INCLUSION``/``_EXCLUSION`` (``param1`` = the
    polygon's vertex count; consecutive items of one command form polygons of
    that many vertices), 5003/5004 ``NAV_FENCE_CIRCLE_INCLUSION``/``_EXCLUSION``
    (``param1`` = radius, m). Rally items: 5100 ``NAV_RALLY_POINT``.
``mavproxy_fence``
    Old MAVProxy/ArduPilot ``FENCE_POINT`` text: ``lat lon`` per line. Line 1
    is the return point, the rest the polygon, whose last line repeats the
    first vertex to close it (the duplicate is dropped; a missing one is
    reported in ``warnings``).
``mavproxy_rally``
    MAVProxy rally text: ``RALLY lat lon alt break_alt land_dir flags``.
``geojson``
    RFC 7946 GeoJSON (large airspace fences): a ``FeatureCollection``, a bare
    ``Feature`` or a bare ``Polygon``/``MultiPolygon`` geometry. Positions are
    **[lon, lat]** (RFC 7946 order; a third element, the height above the
    ellipsoid, is ignored), WGS-84 only (a legacy ``crs`` member naming
    anything but CRS84/EPSG:4326 is refused). A feature's role is its
    ``properties.geofence``: ``"keep_in"``, ``"keep_out"`` (Polygon or
    MultiPolygon), ``"return_point"`` or ``"rally"`` (Point). Without it, the
    EUROCAE ED-269 UAS-zone property ``restriction`` is read:
    ``"PROHIBITED"``, ``"REQ_AUTHORISATION"`` and ``"CONDITIONAL"`` are
    keep-outs (the testbed flies without authorisations, so every restricted
    zone is closed to it); a ``"NO_RESTRICTION"`` zone is ignored with a
    warning. ``geofence`` wins when both are given; a feature with neither is
    an error naming it. A keep-out feature's optional numeric properties
    ``floor_m`` and ``ceiling_m`` (in the fence's altitude reference) give its
    own :class:`~geofence.geometry.fence.VerticalExtent` (every part of a MultiPolygon
    the same; holes of the keep-in are full-height); ED-269 zone volumes
    (``upperLimit``/``lowerLimit``, with their own units and references) are
    not read: without ``floor_m``/``ceiling_m`` a keep-out is a full-height
    column. A bare geometry is the keep-in. Rings must be closed (last position = first; the duplicate is
    dropped) with >= 3 distinct vertices; either winding is accepted (RFC 7946
    asks writers, not readers, for the right-hand rule). Holes (interior rings)
    of the keep-in polygon become keep-out polygons; holes of keep-out polygons
    are ignored with a warning (a keep-out's hole would be allowed airspace
    inside forbidden airspace, which :class:`Fence` cannot express). Optional
    numeric properties ``ceiling_m``, ``floor_m`` and the string
    ``altitude_reference`` on the collection (a ``"properties"`` foreign
    member) or on the keep-in feature (which wins) give the vertical limits;
    explicit arguments of :func:`load_fence_file` win over both. A ``Point``'s
    ``alt_m`` property is its altitude above home. Sizes are limited
    (:data:`MAX_FENCE_VERTICES`, :data:`MAX_FENCE_POLYGONS`, checked before the
    coordinates are read). RFC 7946 cuts an area crossing the antimeridian
    into a MultiPolygon; such a keep-in is not re-joined (it is several
    inclusion polygons: pick one, see below).

Parser choice: our own, not :mod:`pymavlink.mavwp`. pymavlink's
``MissionItemProtocol_Fence``/``_Rally`` loaders only work when the
``MAVLINK20`` environment variable was set before pymavlink chose its dialect
(process-global state that would also change how :mod:`analysis.formats.logs` decodes
tlogs); the old-format fence loader truncates coordinates to ``int(deg*1e7)``
and *prints* "Insufficient points" instead of failing; the RALLY loader
multiplies the altitude by 1000 and drops the break altitude; and their
errors name neither the file nor the line. The formats are simple
whitespace-separated text, so a strict parser here gives exact floats,
one-line :class:`~geofence.geometry.fence.FenceError` messages ``"<file>: line <n>:
<problem>"``, and checks pymavlink does not do (vertex-count mismatch, polygon
with < 3 vertices, coordinates out of range or unset). ``tests/test_importers.py``
cross-checks the items against pymavlink's loaders on the real files.

Mapping to :class:`Fence`
-------------------------
* keep-in: the file's one inclusion area. A file with several (polygons and
  circles together) is refused unless the caller picks one by index
  (``inclusion_polygon``: polygons in file order, then circles; the CLI's
  ``--inclusion-polygon N``, a scenario's ``fence: {file: ..., inclusion_polygon: N}``):
  ArduPilot flies several inclusion zones as their intersection (as their
  union with ``FENCE_OPTIONS`` bit 1), ``Fence`` holds one keep-in, and taking
  the first silently scored one real log at +89.4 m or -356 m depending on the
  polygons' order. The others are then listed in ``warnings``. A GeoJSON
  keep-in's holes and properties are the chosen polygon's. An inclusion circle
  becomes the keep-in as an inscribed
  regular polygon (:func:`geofence.geometry.fence.circle_to_polygon`: vertices on the
  geodesic circle, so the approximation lies inside the circle and is
  conservative); its vertex count is the smallest
  (>= 16, <= 720) whose chord sag ``r(1 - cos(pi/N))`` is <= ``circle_tolerance_m``
  (0.1 m default), and both are stated in ``warnings``.
* keep-outs: exclusion polygons and exclusion circles. One that lies entirely
  outside the keep-in constrains nothing (ArduPilot allows it, ``Fence``
  rejects it), so it is dropped with a warning.
* ceiling/floor: at most :data:`MAX_CEILING_M` (10 km), whoever gives them.
  None of the MAVLink/QGC formats carries one (ArduPilot keeps
  ``FENCE_ALT_MAX`` in parameters, PX4 ``GF_MAX_VER_DIST``). The ceiling is
  the caller's ``ceiling_m``, else the file's (GeoJSON only), else
  :data:`DEFAULT_CEILING_M` = 120 m AGL (the EU open-category / FAA Part 107
  400 ft order of magnitude), stated in ``warnings`` when the default was
  used (``ImportedFence.ceiling_source`` says which).
* recovery point: the caller's ``recovery_point`` if given; else the return
  point (``FENCE_RETURN_POINT``, the first line of an old MAVProxy fence, QGC
  v1 ``breachReturn``, a GeoJSON ``return_point``) when it lies inside the
  allowed area; otherwise it is kept in ``return_point`` only, with a warning.
* The :class:`Fence` is built once, at the end: its own validation (simple
  polygons, keep-outs meeting the keep-in, ...) is not repeated here, and its
  messages name the file's item (``exclusion polygon 3``, ``features[12]
  (name 'building 7')``) instead of the fence field.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple, cast

import numpy as np

from geofence.geometry.fence import (
    DEFAULT_CIRCLE_TOLERANCE_M,
    FULL_HEIGHT,
    MAX_CEILING_M,
    AltitudeReference,
    Fence,
    FenceError,
    KeepOutCircle,
    PolygonLL,
    VerticalExtent,
    circle_to_polygon,
)
from geofence.geometry.geodesy import LocalFrame, ecef_to_geodetic, geodetic_to_ecef
from geofence.geometry.polygon import PolygonIndex, polygons_intersect
from geofence.validation import ConfigError, enum_value, field_default, latitude, longitude, number

DEFAULT_CEILING_M = 120.0
"""Ceiling used when the caller gives none (m, AGL)."""

MAV_CMD_NAV_FENCE_RETURN_POINT = 5000
MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION = 5002
MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION = 5003
MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION = 5004
MAV_CMD_NAV_RALLY_POINT = 5100
_FENCE_CMDS = {5000, 5001, 5002, 5003, 5004}
_FRAME_REF = {0: "amsl", 5: "amsl", 3: "relative", 6: "relative", 10: "terrain", 11: "terrain"}

FORMATS = ("qgc_plan", "qgc_wpl_110", "mavproxy_fence", "mavproxy_rally", "geojson")

MAX_FENCE_VERTICES = 200_000
"""Default limit on the polygon vertices of one fence file (all rings, closing duplicates included)."""
MAX_FENCE_POLYGONS = 20_000
"""Default limit on the polygons (rings, holes included) of one fence file."""
"""The highest fence ceiling or floor, m (in either altitude reference): above the service ceiling of
any small UAS and of every shipped model (the Cessna 172's is 4.1 km); a ceiling of 10^9 m is a typo."""

ED269_KEEP_OUT = ("PROHIBITED", "REQ_AUTHORISATION", "CONDITIONAL")
"""ED-269 ``restriction`` values read as keep-outs (``NO_RESTRICTION`` zones are ignored)."""
GEOJSON_TYPES = (
    "FeatureCollection",
    "Feature",
    "Polygon",
    "MultiPolygon",
    "Point",
    "MultiPoint",
    "LineString",
    "MultiLineString",
    "GeometryCollection",
)


@dataclass(frozen=True)
class RallyPoint:
    """A rally (safe return) point. ``alt_m`` is in ``alt_reference``.

    ``alt_reference``: ``"relative"`` (to home), ``"amsl"``, ``"terrain"`` or
    ``"unknown"``. ``break_alt_m``/``land_dir_deg``/``flags`` only come from
    MAVProxy RALLY lines.
    """

    lat_deg: float
    lon_deg: float
    alt_m: float
    alt_reference: str = "relative"
    break_alt_m: float | None = None
    land_dir_deg: float | None = None
    flags: int | None = None


@dataclass(frozen=True)
class InclusionCircle:
    """An inclusion (keep-in) circle as read from the file."""

    center_lat_deg: float
    center_lon_deg: float
    radius_m: float


@dataclass
class ImportedFence:
    """What a fence file yields: the :class:`Fence` plus everything else it said.

    ``keep_in_polygons`` are all inclusion polygons as read (the fence uses the
    first, see the module docstring); ``keep_out_polygons``/``keep_out_circles``
    all exclusions as read (the fence may have dropped some, see
    ``warnings``). ``return_point`` is ``(lat, lon)`` or ``(lat, lon, alt)``;
    ``home`` is QGC's ``plannedHomePosition``.
    """

    fence: Fence
    source_path: str
    source_format: str
    keep_in_polygons: tuple[PolygonLL, ...] = ()
    inclusion_circles: tuple[InclusionCircle, ...] = ()
    keep_out_polygons: tuple[PolygonLL, ...] = ()
    keep_out_circles: tuple[KeepOutCircle, ...] = ()
    return_point: tuple[float, ...] | None = None
    rally_points: tuple[RallyPoint, ...] = ()
    home: tuple[float, float, float] | None = None
    warnings: list[str] = field(default_factory=list)
    ceiling_source: str = "argument"
    """Where ``fence.ceiling_m`` came from: ``"argument"``, ``"file"`` or ``"default"``."""


@dataclass
class _Raw:
    """Format-independent items read from one file (before building the Fence)."""

    fmt: str
    inc_polys: list = field(default_factory=list)
    exc_polys: list = field(default_factory=list)
    inc_circles: list = field(default_factory=list)
    exc_circles: list = field(default_factory=list)
    return_point: tuple | None = None
    rally: list = field(default_factory=list)
    home: tuple | None = None
    warnings: list = field(default_factory=list)
    exc_labels: list = field(default_factory=list)
    """Names of ``exc_polys`` in messages (default ``exclusion polygon <i>``)."""
    exc_extents: list = field(default_factory=list)
    """A :class:`VerticalExtent` per ``exc_polys`` (GeoJSON only; empty: all full-height)."""
    inc_label: str = ""
    """Name of the chosen inclusion polygon in messages (default ``keep_in``)."""
    ceiling_m: float | None = None
    floor_m: float | None = None
    altitude_reference: AltitudeReference | None = None
    n_vertices: int = 0
    n_polygons: int = 0

    def has_fence(self) -> bool:
        return bool(self.inc_polys or self.exc_polys or self.inc_circles or self.exc_circles)


# --------------------------------------------------------------------------- public API
class ImportOptions(NamedTuple):
    """How a fence file (or a mission item list) is read: :func:`load_fence_file`'s options, each explained there."""

    ceiling_m: float | None = None
    floor_m: float | None = None
    altitude_reference: str | None = None
    rally_path: str | Path | None = None
    circle_tolerance_m: float = DEFAULT_CIRCLE_TOLERANCE_M
    return_point_as_recovery: bool = True
    floor_gaps: Sequence[PolygonLL] = ()
    recovery_point: tuple[float, ...] | None = None
    max_vertices: int = MAX_FENCE_VERTICES
    max_polygons: int = MAX_FENCE_POLYGONS
    inclusion_polygon: int | None = None


def load_fence_file(path: str | Path, options: ImportOptions = ImportOptions()) -> ImportedFence:
    """Read a fence file (any format in :data:`FORMATS` except rally-only) into an :class:`ImportedFence`, as
    ``options`` say (:class:`ImportOptions`):

    ``ceiling_m``, ``floor_m``, ``altitude_reference``: explicit values win over the file's (only
    GeoJSON files carry them, see the module docstring); ``None`` means the file's, else the default
    (ceiling :data:`DEFAULT_CEILING_M`, no floor, ``"agl"``). ``floor_gaps`` and ``recovery_point``
    are passed to :class:`Fence` (no format carries floor gaps; an explicit recovery point replaces
    the file's return point as the recovery point, the return point is still reported).
    ``rally_path``: an optional separate rally file (MAVProxy keeps rally points
    apart from the fence) whose points are appended to ``rally_points``.
    ``max_vertices``/``max_polygons``: refuse a file with more polygon vertices / polygons (rings)
    than this, before building anything.
    ``inclusion_polygon``: the index of the inclusion area to use as the keep-in (polygons in file
    order, then circles); required when the file has more than one (see the module docstring).
    Raises :class:`FenceError` with one line naming the file and the problem.
    """
    name, o = str(path), options
    raw = _raw_from_text(
        _read_text(Path(path)), name, max_vertices=o.max_vertices, max_polygons=o.max_polygons,
        keep_in_index=o.inclusion_polygon or 0,
    )  # fmt: skip
    return _build_imported(raw, name, options)


class FenceItem(NamedTuple):
    """One fence or rally item as a WPL 110 line or a MAVLink ``MISSION_ITEM_INT`` carries it (deg, m)."""

    where: str
    """How messages name the item (``line 12``, ``item 3``)."""
    frame: int
    command: int
    params: tuple[float, ...]
    """``param1 .. param4, lat_deg, lon_deg, alt_m``."""


def fence_from_items(items: Sequence[FenceItem], name: str, options: ImportOptions = ImportOptions()) -> ImportedFence:
    """The fence of a mission item list (commands 5000-5004; 5100 rally items are kept as ``rally_points``), checked
    and built exactly as a WPL 110 file of those items; ``options``: :func:`load_fence_file`'s (``rally_path``
    too, a separate rally file). Raises :class:`FenceError` (``"<name>: <item>: <problem>"``)."""
    raw = _Raw("mavlink_mission")
    _read_items(items, name, raw)
    return _build_imported(raw, name, options)


def rally_from_items(items: Sequence[FenceItem], name: str) -> tuple[RallyPoint, ...]:
    """The rally points of a mission item list (command 5100; fence items are checked and ignored)."""
    raw = _Raw("mavlink_mission")
    _read_items(items, name, raw)
    return tuple(raw.rally)


def _build_imported(raw: _Raw, name: str, options: ImportOptions) -> ImportedFence:
    """:func:`load_fence_file` after the file was read: the items of ``raw`` checked as a whole, the fence built."""
    _check_items(raw, name, options)
    warnings = list(raw.warnings)
    heights = _heights(raw, options, warnings)
    _check_heights(name, heights.ceiling_m, heights.floor_m)
    keep_in, keep_in_label = _choose_keep_in(raw, options.inclusion_polygon, name, options.circle_tolerance_m, warnings)
    # Format-level relations in a local frame at the keep-in (vectorised; the Fence validates the
    # geometry itself, once, below): drop keep-outs that constrain nothing, check the return point.
    local = _LocalKeepIn(keep_in)
    kept = _kept_keep_outs(raw, local, warnings)
    recovery_point, from_file = options.recovery_point, False
    if recovery_point is None and raw.return_point is not None and options.return_point_as_recovery:
        recovery_point = _return_point_inside(raw.return_point, local, kept, warnings)
        from_file = recovery_point is not None

    def build(rp: tuple | None) -> Fence:
        # a string: Fence normalises it to the enum and refuses anything else (a FenceError)
        return Fence(
            keep_in=keep_in, ceiling_m=heights.ceiling_m, floor_m=heights.floor_m,
            altitude_reference=cast(AltitudeReference, heights.altitude_reference),
            floor_gaps=tuple(options.floor_gaps), keep_out_polygons=tuple(kept.polygons),
            keep_out_circles=tuple(kept.circles), recovery_point=rp, keep_out_polygon_extents=tuple(kept.extents),
        )  # fmt: skip

    try:
        fence = _built_without_a_bad_return_point(build, recovery_point, from_file, warnings)
    except FenceError as exc:
        raise FenceError(f"{name}: {_relabel(str(exc), keep_in_label, kept.labels)}") from None
    rally = list(raw.rally)
    if options.rally_path is not None:
        rally.extend(load_rally_file(options.rally_path))
    return ImportedFence(
        fence=fence, source_path=name, source_format=raw.fmt, keep_in_polygons=tuple(raw.inc_polys),
        inclusion_circles=tuple(raw.inc_circles), keep_out_polygons=tuple(raw.exc_polys),
        keep_out_circles=tuple(raw.exc_circles), return_point=raw.return_point, rally_points=tuple(rally),
        home=raw.home, warnings=warnings, ceiling_source=heights.ceiling_source,
    )  # fmt: skip


def _check_items(raw: _Raw, name: str, options: ImportOptions) -> None:
    """The file's items as a whole: within the size limits (GeoJSON is checked before its coordinates are read),
    some fence item, and a keep-in among them; else a one-line :class:`FenceError`."""
    if raw.fmt != "geojson":
        polys = [*raw.inc_polys, *raw.exc_polys]
        _check_size(name, sum(len(p) for p in polys), len(polys), options.max_vertices, options.max_polygons)
    if not raw.has_fence():
        what = "only rally points" if raw.rally else "no fence items"
        raise FenceError(f"{name}: {what} (no inclusion/exclusion polygon or circle)")
    if not raw.inc_polys and not raw.inc_circles:
        raise FenceError(f"{name}: no inclusion polygon or circle (only exclusions); a keep-in area is required")


class _Heights(NamedTuple):
    ceiling_m: Any
    ceiling_source: str
    """Where the ceiling came from: ``argument``, ``file`` or ``default``."""
    floor_m: Any
    altitude_reference: Any


def _heights(raw: _Raw, options: ImportOptions, warnings: list[str]) -> _Heights:
    """The fence's vertical limits and reference: the options' where given, else the file's, else the defaults
    (a default ceiling is warned about)."""
    reference = options.altitude_reference
    if reference is None:
        reference = raw.altitude_reference or field_default(Fence, "altitude_reference")
    floor_m = raw.floor_m if options.floor_m is None else options.floor_m
    if options.ceiling_m is not None:
        return _Heights(options.ceiling_m, "argument", floor_m, reference)
    if raw.ceiling_m is not None:
        return _Heights(raw.ceiling_m, "file", floor_m, reference)
    ref = reference.upper() if isinstance(reference, str) else reference
    warnings.append(f"no ceiling in the file; using the default ceiling {DEFAULT_CEILING_M:g} m {ref}")
    return _Heights(DEFAULT_CEILING_M, "default", floor_m, reference)


class _LocalKeepIn:
    """The keep-in in a local frame at it (east, north m), for the format-level relations."""

    def __init__(self, keep_in: PolygonLL) -> None:
        self.frame = _frame_at(keep_in)
        self.index = PolygonIndex(self.en(keep_in))

    def en(self, poly: PolygonLL) -> np.ndarray:
        """A polygon's vertices in the frame (N, 2)."""
        lat = np.array([p[0] for p in poly], dtype=float)
        lon = np.array([p[1] for p in poly], dtype=float)
        return self.frame.to_enu_array(lat, lon, np.zeros(len(poly)))[:, :2]


class _Kept(NamedTuple):
    """The keep-outs that constrain something (in the file's order), with their extents and labels, and in the
    local frame (polygons ``(N, 2)``, circles ``(e, n, r)``)."""

    polygons: list
    extents: list
    labels: list
    polygons_en: list
    circles: list
    circles_en: list


def _kept_keep_outs(raw: _Raw, local: _LocalKeepIn, warnings: list[str]) -> _Kept:
    """The keep-outs that reach into the keep-in; each one entirely outside it is dropped with a warning."""
    n = len(raw.exc_polys)
    labels = raw.exc_labels if len(raw.exc_labels) == n else [f"exclusion polygon {i}" for i in range(n)]
    extents = raw.exc_extents if len(raw.exc_extents) == n else [FULL_HEIGHT] * n
    ki = local.index
    exc_en = [local.en(p) for p in raw.exc_polys]
    first_inside = ki.contains_array(np.array([e[0] for e in exc_en])) if exc_en else np.zeros(0, dtype=bool)
    kept = _Kept([], [], [], [], [], [])
    for i, p in enumerate(raw.exc_polys):
        if first_inside[i] or polygons_intersect(ki.vertices, exc_en[i]):
            kept.polygons.append(p)
            kept.extents.append(extents[i])
            kept.labels.append(labels[i])
            kept.polygons_en.append(exc_en[i])
        else:
            warnings.append(f"{labels[i]} lies entirely outside the keep-in area: dropped (it constrains nothing)")
    for i, c in enumerate(raw.exc_circles):
        c_e, c_n = local.frame.to_enu(c.center_lat_deg, c.center_lon_deg, 0.0)[:2]
        if ki.signed_distance(c_e, c_n) <= -c.radius_m:
            warnings.append(f"exclusion circle {i} lies entirely outside the keep-in area: dropped (it constrains nothing)")
        else:
            kept.circles.append(c)
            kept.circles_en.append((c_e, c_n, c.radius_m))
    return kept


def _return_point_inside(point: tuple, local: _LocalKeepIn, kept: _Kept, warnings: list[str]) -> tuple | None:
    """The file's return point as the recovery point where it is inside the allowed area (the keep-in, outside
    every kept keep-out), else None with a warning."""
    lat, lon = point[0], point[1]
    r_e, r_n = local.frame.to_enu(lat, lon, 0.0)[:2]
    m = local.index.signed_distance(r_e, r_n)
    for k in kept.polygons_en:
        m = min(m, -PolygonIndex(k).signed_distance(r_e, r_n))
    for ce, cn, r in kept.circles_en:
        m = min(m, math.hypot(r_e - ce, r_n - cn) - r)
    if m > 0.0:
        return lat, lon
    warnings.append(
        f"return point ({lat:.7f}, {lon:.7f}) is not inside the allowed area (margin {m:.1f} m): not used as the recovery point"
    )
    return None


def _built_without_a_bad_return_point(
    build: Callable[[tuple | None], Fence], recovery_point: tuple | None, from_file: bool, warnings: list[str]
) -> Fence:  # fmt: skip
    """``build(recovery_point)``; a recovery point taken from the file's return point that the fence refuses is
    dropped with a warning and the fence built without it (any other refusal is raised)."""
    try:
        return build(recovery_point)
    except FenceError as exc:
        if not (from_file and recovery_point is not None and str(exc).startswith("recovery_point:")):
            raise
        warnings.append(f"return point ({recovery_point[0]:.7f}, {recovery_point[1]:.7f}): {exc}: not used as the recovery point")
        return build(None)


def _check_heights(name: str, ceiling_m: Any, floor_m: Any) -> None:
    """A ceiling or floor above :data:`MAX_CEILING_M` (or not a finite number) is refused."""
    for key, value in (("ceiling_m", ceiling_m), ("floor_m", floor_m)):
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise FenceError(f"{name}: {key}: must be a finite number, got {value!r}")
        if value > MAX_CEILING_M:
            raise FenceError(
                f"{name}: {key}: {value:g} m is above {MAX_CEILING_M:g} m, the highest any small UAS flies "
                f"(the limit of a fence here)"
            )


def _choose_keep_in(
    raw: _Raw, index: int | None, name: str, circle_tolerance_m: float, warnings: list[str]
) -> tuple[PolygonLL, str]:
    """``(keep_in, its label)``: the file's one inclusion area, or the one at ``index`` (polygons, then circles).

    Several inclusion areas without an ``index`` are refused: ArduPilot flies their intersection (their union
    with FENCE_OPTIONS bit 1), which one keep-in cannot hold, and any one of them scores a different flight.
    """
    n_poly, n_circ = len(raw.inc_polys), len(raw.inc_circles)
    n = n_poly + n_circ
    if index is None and n > 1:
        raise FenceError(
            f"{name}: inclusion polygons: the file has {n} inclusion areas ({n_poly} polygon(s), {n_circ} circle(s)); "
            f"ArduPilot flies their intersection (their union with FENCE_OPTIONS bit 1) and a fence here holds one "
            f"keep-in: pick one with --inclusion-polygon N (0 to {n - 1}; in a scenario: fence: {{file: ..., "
            f"inclusion_polygon: N}}), or split the file"
        )
    index = index or 0
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < n:
        raise FenceError(f"{name}: inclusion polygon {index!r}: no such inclusion area (the file has {n}: 0 to {n - 1})")
    if n > 1:
        warnings.append(f"inclusion area {index} of {n} used as the keep-in (chosen); the other {n - 1} ignored")
    if index < n_poly:
        return raw.inc_polys[index], raw.inc_label
    c = raw.inc_circles[index - n_poly]
    keep_in, k, sag = circle_to_polygon(c.center_lat_deg, c.center_lon_deg, c.radius_m, circle_tolerance_m)
    warnings.append(
        f"inclusion circle r={c.radius_m:g} m approximated by an inscribed {k}-gon (max gap {sag:.3f} m inside the circle)"
    )
    return keep_in, f"inclusion circle {index - n_poly}"


def _frame_at(poly: PolygonLL) -> LocalFrame:
    """A local frame at the vertices' centre (mean of their ECEF unit vectors, like :meth:`Fence.center`)."""
    xs = ys = zs = 0.0
    for lat, lon in poly:
        x, y, z = geodetic_to_ecef(lat, lon, 0.0)
        xs, ys, zs = xs + x, ys + y, zs + z
    k = len(poly)
    lat, lon, _ = ecef_to_geodetic(xs / k, ys / k, zs / k)
    return LocalFrame(lat, lon, 0.0)


_KEEP_OUT_FIELD = re.compile(r"^keep_out_polygons\[(\d+)\]")


def _relabel(msg: str, keep_in_label: str, keep_out_labels: list[str]) -> str:
    """A :class:`Fence` message with its field (``keep_out_polygons[3]``, ``keep_in``) named as in the file."""
    m = _KEEP_OUT_FIELD.match(msg)
    if m and int(m.group(1)) < len(keep_out_labels):
        return keep_out_labels[int(m.group(1))] + msg[m.end() :]
    if keep_in_label and re.match(r"^keep_in\b", msg):
        return keep_in_label + msg[len("keep_in") :]
    return msg


def _check_size(name: str, n_vertices: int, n_polygons: int, max_vertices: int, max_polygons: int) -> None:
    if n_vertices > max_vertices:
        raise FenceError(
            f"{name}: {n_vertices} polygon vertices exceed the limit of {max_vertices} "
            f"(max_vertices); simplify or split the fence"
        )
    if n_polygons > max_polygons:
        raise FenceError(
            f"{name}: {n_polygons} polygons exceed the limit of {max_polygons} (max_polygons); merge or drop keep-outs"
        )


def load_rally_file(path: str | Path) -> tuple[RallyPoint, ...]:
    """Rally points from any supported file (MAVProxy RALLY, QGC WPL 110 cmd 5100, ``.plan`` rallyPoints).

    A file with no rally points gives an empty tuple; unreadable or malformed
    files raise :class:`FenceError`.
    """
    return tuple(_read_raw(Path(path)).rally)


def detect_format(path: str | Path) -> str:
    """The format name (one of :data:`FORMATS`) of a file, from its content."""
    return _detect(_read_text(Path(path)), str(path))


def fence_to_yaml_block(imported: ImportedFence | Fence) -> dict:
    """A ``{"geofence": {"fence": {...}}}`` mapping for a scenario file (``parse_fence`` reads it back).

    Only the fence geometry is emitted; add the geofence unit's other keys
    (if any) to ``["geofence"]`` yourself.
    """
    f = imported.fence if isinstance(imported, ImportedFence) else imported
    block: dict[str, Any] = {}
    if f.keep_in_circle is not None:
        lat, lon, r = f.keep_in_circle
        block["keep_in_circle"] = {"center": [lat, lon], "radius_m": r}
    else:
        block["keep_in"] = [[lat, lon] for lat, lon in f.keep_in]
    block["ceiling_m"] = f.ceiling_m
    if f.floor_m is not None:
        block["floor_m"] = f.floor_m
    block["altitude_reference"] = f.altitude_reference.value
    if f.floor_gaps:
        block["floor_gaps"] = [[[lat, lon] for lat, lon in g] for g in f.floor_gaps]
    if f.keep_out_polygons:
        block["keep_out_polygons"] = [
            _with_extent({"polygon": vertices}, x) if not x.full_height else vertices
            for vertices, x in zip(([[lat, lon] for lat, lon in p] for p in f.keep_out_polygons), f.keep_out_polygon_extents)
        ]
    if f.keep_out_circles:
        block["keep_out_circles"] = [
            _with_extent({"center": [c.center_lat_deg, c.center_lon_deg], "radius_m": c.radius_m}, c.extent)
            for c in f.keep_out_circles
        ]
    if f.recovery_point is not None:
        block["recovery_point"] = list(f.recovery_point)
    return {"geofence": {"fence": block}}


def _with_extent(item: dict[str, Any], extent: VerticalExtent) -> dict[str, Any]:
    """``item`` with the keep-out's ``floor_m``/``ceiling_m`` keys (those that are set)."""
    if extent.floor_m is not None:
        item["floor_m"] = extent.floor_m
    if extent.ceiling_m is not None:
        item["ceiling_m"] = extent.ceiling_m
    return item


# --------------------------------------------------------------------------- reading
def _read_text(path: Path) -> str:
    name = str(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise FenceError(f"{name}: file not found") from None
    except OSError as exc:
        raise FenceError(f"{name}: cannot read ({exc.strerror or exc})") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise FenceError(f"{name}: not a text fence file (not UTF-8; binary?)") from None


_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_LATLON_LINE = re.compile(rf"^\s*{_NUM}\s+{_NUM}\s*$")


def _detect(text: str, name: str) -> str:
    return _sniff(text, name)[0]


def _sniff(text: str, name: str) -> tuple[str, Any]:
    """``(format, parsed JSON document or None)``: JSON is told apart by its top-level ``type``."""
    for line in text.splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith(("{", "[")):
            try:
                doc = json.loads(text)
            except json.JSONDecodeError:
                return "qgc_plan", None  # _parse_plan reports where the JSON is broken
            except RecursionError:
                raise FenceError(f"{name}: JSON nested too deeply (a fence file needs at most 6 levels)") from None
            if isinstance(doc, dict) and doc.get("type") in GEOJSON_TYPES:
                return "geojson", doc
            return "qgc_plan", doc
        if s.startswith("QGC WPL"):
            if s.split() == ["QGC", "WPL", "110"]:
                return "qgc_wpl_110", None
            raise FenceError(f"{name}: unsupported waypoint file version {s!r} (only 'QGC WPL 110')")
        if s.split()[0].upper() == "RALLY":
            return "mavproxy_rally", None
        if _LATLON_LINE.match(s):
            return "mavproxy_fence", None
        raise FenceError(
            f"{name}: unrecognised fence file format (first line {s[:40]!r}); "
            f"expected .plan JSON, GeoJSON, 'QGC WPL 110', 'lat lon' lines or 'RALLY' lines"
        )
    raise FenceError(f"{name}: empty file")


def _read_raw(path: Path) -> _Raw:
    return _raw_from_text(_read_text(path), str(path))


def _raw_from_text(
    text: str,
    name: str,
    *,
    max_vertices: int = MAX_FENCE_VERTICES,
    max_polygons: int = MAX_FENCE_POLYGONS,
    keep_in_index: int = 0,
) -> _Raw:
    fmt, doc = _sniff(text, name)
    if fmt == "qgc_plan":
        return _parse_plan(text, name, doc)
    if fmt == "geojson":
        return _parse_geojson(doc, name, max_vertices=max_vertices, max_polygons=max_polygons, keep_in_index=keep_in_index)
    return {"qgc_wpl_110": _parse_wpl110, "mavproxy_fence": _parse_mavproxy_fence, "mavproxy_rally": _parse_mavproxy_rally}[fmt](
        text, name
    )


def _kit(read: Any, value: Any, where: str, hint: str = "", **bounds: Any) -> Any:
    """A :mod:`geofence.validation` reader, its message (``<where>: <problem>``, plus ``hint``) as a :class:`FenceError`."""
    try:
        return read(value, where, **bounds)
    except ConfigError as exc:
        raise FenceError(f"{exc}{hint}") from None


def _float(tok: str, name: str, where: str, what: str) -> float:
    """A number token of a text format (WPL, MAVProxy): ``what`` names the column."""
    try:
        v = float(tok)
    except ValueError:
        raise FenceError(f"{name}: {where}: {what} {tok!r} is not a number") from None
    return _kit(number, v, f"{name}: {where} {what}")


def _check_latlon(lat: float, lon: float, name: str, where: str) -> tuple[float, float]:
    lat = _kit(latitude, lat, f"{name}: {where} latitude")
    lon = _kit(longitude, lon, f"{name}: {where} longitude")
    if lat == 0.0 and lon == 0.0:
        raise FenceError(f"{name}: {where}: position (0, 0) is unset")
    return lat, lon


def _close_polygon(pts: list, name: str, where: str) -> PolygonLL:
    if len(pts) >= 2 and pts[0] == pts[-1]:
        pts = pts[:-1]
    if len(pts) < 3:
        raise FenceError(f"{name}: {where}: polygon needs at least 3 vertices, got {len(pts)}")
    return tuple(pts)


# ---- QGroundControl .plan
def _json_number(x: Any, name: str, where: str) -> float:
    return cast(float, _kit(number, x, f"{name}: {where}"))


def _json_point(p: Any, name: str, where: str, n: int | tuple = 2) -> tuple[float, ...]:
    ok = (n,) if isinstance(n, int) else n
    if not isinstance(p, list) or len(p) not in ok:
        raise FenceError(f"{name}: {where}: must be [lat, lon{', alt' if 3 in ok else ''}], got {json.dumps(p)[:60]}")
    vals = tuple(_json_number(v, name, where) for v in p)
    _check_latlon(vals[0], vals[1], name, where)
    return vals


def _parse_plan(text: str, name: str, doc: Any = None) -> _Raw:
    if doc is None:
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise FenceError(f"{name}: not JSON: {exc.msg} at line {exc.lineno} column {exc.colno}") from None
    if not isinstance(doc, dict):
        raise FenceError(f"{name}: not a QGroundControl plan (top level is not a JSON object)")
    raw = _Raw("qgc_plan")
    if doc.get("fileType", "Plan") != "Plan":
        raw.warnings.append(f"fileType is {doc.get('fileType')!r}, not 'Plan'")
    gf = doc.get("geoFence")
    if gf is not None and not isinstance(gf, dict):
        raise FenceError(f"{name}: geoFence: must be a JSON object")
    gf = gf or {}
    polys = gf.get("polygons", [])
    if not isinstance(polys, list):
        raise FenceError(f"{name}: geoFence.polygons: must be a list")
    for i, p in enumerate(polys):
        where = f"geoFence.polygons[{i}]"
        if not isinstance(p, dict) or "polygon" not in p:
            raise FenceError(f"{name}: {where}: must be an object with 'polygon'")
        verts = p["polygon"]
        if not isinstance(verts, list):
            raise FenceError(f"{name}: {where}.polygon: must be a list of [lat, lon]")
        pts = [_json_point(v, name, f"{where}.polygon[{j}]")[:2] for j, v in enumerate(verts)]
        poly = _close_polygon(pts, name, where)
        inclusion = p.get("inclusion", True)
        if not isinstance(inclusion, bool):
            raise FenceError(f"{name}: {where}.inclusion: must be true or false, got {inclusion!r}")
        (raw.inc_polys if inclusion else raw.exc_polys).append(poly)
    circles = gf.get("circles", [])
    if not isinstance(circles, list):
        raise FenceError(f"{name}: geoFence.circles: must be a list")
    for i, c in enumerate(circles):
        where = f"geoFence.circles[{i}]"
        if not isinstance(c, dict) or not isinstance(c.get("circle"), dict):
            raise FenceError(f"{name}: {where}: must be an object with 'circle': {{center, radius}}")
        if "center" not in c["circle"] or "radius" not in c["circle"]:
            raise FenceError(f"{name}: {where}.circle: needs 'center' and 'radius'")
        lat, lon = _json_point(c["circle"]["center"], name, f"{where}.circle.center")
        r = _json_number(c["circle"]["radius"], name, f"{where}.circle.radius")
        if not r > 0.0:
            raise FenceError(f"{name}: {where}.circle.radius: must be > 0, got {r:g}")
        inclusion = c.get("inclusion", True)
        if not isinstance(inclusion, bool):
            raise FenceError(f"{name}: {where}.inclusion: must be true or false, got {inclusion!r}")
        if inclusion:
            raw.inc_circles.append(InclusionCircle(lat, lon, r))
        else:
            raw.exc_circles.append(KeepOutCircle(lat, lon, r))
    # geoFence version 1: a single inclusion polygon and a breach return point
    if isinstance(gf.get("polygon"), list) and gf["polygon"]:
        pts = [_json_point(v, name, f"geoFence.polygon[{j}]")[:2] for j, v in enumerate(gf["polygon"])]
        raw.inc_polys.insert(0, _close_polygon(pts, name, "geoFence.polygon"))
    br = gf.get("breachReturn")
    if isinstance(br, list) and len(br) >= 2 and not (br[0] == 0 and br[1] == 0):
        raw.return_point = _json_point(br, name, "geoFence.breachReturn", (2, 3))
    rp = doc.get("rallyPoints") or {}
    points = rp.get("points", []) if isinstance(rp, dict) else None
    if not isinstance(points, list):
        raise FenceError(f"{name}: rallyPoints.points: must be a list of [lat, lon, alt]")
    for i, p in enumerate(points):
        lat, lon, alt = _json_point(p, name, f"rallyPoints.points[{i}]", 3)
        raw.rally.append(RallyPoint(lat, lon, alt, "relative"))
    mission = doc.get("mission")
    hp = mission.get("plannedHomePosition") if isinstance(mission, dict) else None
    if isinstance(hp, list) and len(hp) >= 2 and not (hp[0] == 0 and hp[1] == 0):  # QGC writes 0, 0 when unset
        h = _json_point(hp, name, "mission.plannedHomePosition", 3)
        raw.home = (h[0], h[1], h[2])
    return raw


# ---- QGC WPL 110
_WPL_NAMES = {
    5000: "FENCE_RETURN_POINT",
    5001: "FENCE_POLYGON_VERTEX_INCLUSION",
    5002: "FENCE_POLYGON_VERTEX_EXCLUSION",
    5003: "FENCE_CIRCLE_INCLUSION",
    5004: "FENCE_CIRCLE_EXCLUSION",
    5100: "RALLY_POINT",
}


def _parse_wpl110(text: str, name: str) -> _Raw:
    raw = _Raw("qgc_wpl_110")
    lines = text.splitlines()
    header_seen = False
    items: list[FenceItem] = []
    seqs: list[int] = []
    for lineno, line in enumerate(lines, 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if not header_seen:
            header_seen = True  # _detect checked it is "QGC WPL 110"
            continue
        a = s.split()
        where = f"line {lineno}"
        if len(a) != 12:
            raise FenceError(
                f"{name}: {where}: expected 12 fields "
                f"(seq current frame command p1 p2 p3 p4 lat lon alt autocontinue), got {len(a)}"
            )
        try:
            seq, frame, cmd = int(a[0]), int(a[2]), int(a[3])
        except ValueError:
            raise FenceError(f"{name}: {where}: seq, frame and command must be integers") from None
        p = [_float(t, name, where, f"field {k + 5}") for k, t in enumerate(a[4:11])]
        seqs.append(seq)
        items.append(FenceItem(where, frame, cmd, tuple(p)))
    if seqs and seqs != list(range(seqs[0], seqs[0] + len(seqs))):
        raw.warnings.append("item sequence numbers are not consecutive; items were read in file order")
    _read_items(items, name, raw)
    return raw


def _read_items(items: Sequence[FenceItem], name: str, raw: _Raw) -> None:
    """Fence and rally items (a WPL 110 file's lines, a MAVLink mission's items) into ``raw``, each checked."""
    group: list | None = None  # [cmd, count, first item's where, vertices]

    def close_group() -> None:
        nonlocal group
        if group is None:
            return
        cmd, count, first, verts = group
        if len(verts) != count:
            raise FenceError(
                f"{name}: {first}: vertex count mismatch: {_WPL_NAMES[cmd]} polygon declares "
                f"{count} vertices (param1) but has {len(verts)}"
            )
        poly = _close_polygon(verts, name, first)
        (raw.inc_polys if cmd == MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION else raw.exc_polys).append(poly)
        group = None

    ignored: dict[int, int] = {}
    for where, frame, cmd, p in items:
        if cmd in (MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION):
            latlon = _check_latlon(p[4], p[5], name, where)
            count = p[0]
            if group is not None and (group[0] != cmd or len(group[3]) == group[1]):
                close_group()
            if group is None:
                if count != int(count) or count < 3:
                    raise FenceError(
                        f"{name}: {where}: {_WPL_NAMES[cmd]} param1 (vertex count) must be an integer >= 3, got {count:g}"
                    )
                group = [cmd, int(count), where, []]
            elif count != group[1]:
                raise FenceError(
                    f"{name}: {where}: vertex count mismatch: param1 {count:g} differs from {group[1]} declared at {group[2]}"
                )
            group[3].append(latlon)
            continue
        close_group()
        if cmd in (MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION):
            lat, lon = _check_latlon(p[4], p[5], name, where)
            r = p[0]
            if not r > 0.0:
                raise FenceError(f"{name}: {where}: {_WPL_NAMES[cmd]} radius (param1) must be > 0, got {r:g}")
            if cmd == MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION:
                raw.inc_circles.append(InclusionCircle(lat, lon, r))
            else:
                raw.exc_circles.append(KeepOutCircle(lat, lon, r))
        elif cmd == MAV_CMD_NAV_FENCE_RETURN_POINT:
            if p[4] == 0.0 and p[5] == 0.0:
                raw.warnings.append(f"{where}: FENCE_RETURN_POINT at (0, 0) means unset: ignored")
                continue
            lat, lon = _check_latlon(p[4], p[5], name, where)
            if raw.return_point is not None:
                raw.warnings.append(f"{where}: second FENCE_RETURN_POINT ignored")
            else:
                raw.return_point = (lat, lon) if p[6] == 0.0 else (lat, lon, p[6])
        elif cmd == MAV_CMD_NAV_RALLY_POINT:
            lat, lon = _check_latlon(p[4], p[5], name, where)
            raw.rally.append(RallyPoint(lat, lon, p[6], _FRAME_REF.get(frame, "unknown")))
        else:
            ignored[cmd] = ignored.get(cmd, 0) + 1
    close_group()
    if ignored:
        raw.warnings.append("ignored non-fence item(s): " + ", ".join(f"{n}x cmd {c}" for c, n in sorted(ignored.items())))


# ---- old MAVProxy fence / rally text
def _parse_mavproxy_fence(text: str, name: str) -> _Raw:
    raw = _Raw("mavproxy_fence")
    pts: list[tuple[float, float] | None] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        a = s.split()
        where = f"line {lineno}"
        if len(a) != 2:
            raise FenceError(f"{name}: {where}: expected 'lat lon', got {len(a)} fields")
        lat, lon = _float(a[0], name, where, "latitude"), _float(a[1], name, where, "longitude")
        if not pts and lat == 0.0 and lon == 0.0:
            pts.append(None)  # return point (0, 0): unset
            continue
        pts.append(_check_latlon(lat, lon, name, where))
    if len(pts) < 4:
        raise FenceError(f"{name}: old-style fence needs a return point and at least 3 vertices, got {len(pts)} point(s)")
    raw.return_point = pts[0]
    if pts[0] is None:
        raw.warnings.append("return point (line 1) at (0, 0) means unset: ignored")
    verts = pts[1:]
    if verts[-1] != verts[0]:
        raw.warnings.append("polygon is not closed (last point does not repeat the first vertex); closed implicitly")
    raw.inc_polys.append(_close_polygon(verts, name, "polygon"))
    return raw


def _parse_mavproxy_rally(text: str, name: str) -> _Raw:
    raw = _Raw("mavproxy_rally")
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        a = s.split()
        where = f"line {lineno}"
        if a[0].upper() != "RALLY":
            raise FenceError(f"{name}: {where}: expected 'RALLY lat lon alt break_alt land_dir flags'")
        if len(a) != 7:
            raise FenceError(
                f"{name}: {where}: RALLY line needs 6 values (lat lon alt break_alt land_dir flags), got {len(a) - 1}"
            )
        v = [_float(t, name, where, f) for t, f in zip(a[1:], ("latitude", "longitude", "alt", "break_alt", "land_dir", "flags"))]
        lat, lon = _check_latlon(v[0], v[1], name, where)
        if v[5] != int(v[5]):
            raise FenceError(f"{name}: {where}: flags {a[6]!r} is not an integer")
        raw.rally.append(RallyPoint(lat, lon, v[2], "relative", break_alt_m=v[3], land_dir_deg=v[4], flags=int(v[5])))
    return raw


# ---- GeoJSON (RFC 7946)
_GEOFENCE_ROLES = ("keep_in", "keep_out", "return_point", "rally")
_ED269_RESTRICTIONS = (*ED269_KEEP_OUT, "NO_RESTRICTION")
_WGS84_CRS = re.compile(r"(?:CRS:?84|EPSG:{1,2}4326)$")


def _parse_geojson(
    doc: Any,
    name: str,
    *,
    max_vertices: int = MAX_FENCE_VERTICES,
    max_polygons: int = MAX_FENCE_POLYGONS,
    keep_in_index: int = 0,
) -> _Raw:
    """The items of a GeoJSON document; the keep-in polygon at ``keep_in_index`` gives its holes (keep-outs),
    label and properties (the others are kept in ``inc_polys`` only)."""
    raw = _Raw("geojson")
    crs = doc.get("crs")
    if crs is not None:
        crs_name = (
            crs.get("properties", {}).get("name") if isinstance(crs, dict) and isinstance(crs.get("properties"), dict) else None
        )
        if not isinstance(crs_name, str) or not _WGS84_CRS.search(crs_name):
            raise FenceError(
                f"{name}: crs: {json.dumps(crs)[:80]} is not WGS-84 longitude/latitude; RFC 7946 GeoJSON "
                f"is always WGS-84 [lon, lat] (reproject the file, e.g. ogr2ogr -t_srs EPSG:4326)"
            )
    kind = doc["type"]
    top: Any = {}
    if kind == "FeatureCollection":
        feats = doc.get("features")
        if not isinstance(feats, list):
            raise FenceError(f"{name}: features: must be a list of Feature objects")
        items = [(f"features[{i}]", f) for i, f in enumerate(feats)]
        top = doc.get("properties") or {}
        if not isinstance(top, dict):
            raise FenceError(f"{name}: properties: must be an object")
    elif kind == "Feature":
        items = [("feature", doc)]
    elif kind in ("Polygon", "MultiPolygon"):
        items = [("geometry", {"type": "Feature", "properties": {"geofence": "keep_in"}, "geometry": doc})]
    else:
        raise FenceError(
            f"{name}: a bare {kind} geometry is not a fence: expected a FeatureCollection, a Feature, "
            f"or a Polygon/MultiPolygon keep-in"
        )

    # size limits first, from the list lengths alone (nothing converted yet)
    n_vertices = n_polygons = 0
    for _, f in items:
        g = f.get("geometry") if isinstance(f, dict) else None
        c = g.get("coordinates") if isinstance(g, dict) else None
        if not isinstance(g, dict) or not isinstance(c, list):
            continue
        polys = [c] if g.get("type") == "Polygon" else (c if g.get("type") == "MultiPolygon" else [])
        for poly in polys:
            for ring in poly if isinstance(poly, list) else ():
                if isinstance(ring, list):
                    n_vertices += len(ring)
                    n_polygons += 1
    _check_size(name, n_vertices, n_polygons, max_vertices, max_polygons)
    raw.n_vertices, raw.n_polygons = n_vertices, n_polygons

    keep_in_props: dict | None = None
    for base, f in items:
        if not isinstance(f, dict) or f.get("type") != "Feature":
            raise FenceError(f"{name}: {base}: must be a Feature object, got {json.dumps(f)[:60]}")
        label = _gj_label(base, f)
        props = f.get("properties")
        if props is None:
            props = {}
        elif not isinstance(props, dict):
            raise FenceError(f"{name}: {label}: properties: must be an object or null")
        role = _gj_role(props, name, label, raw)
        if role is None:
            continue
        geom = f.get("geometry")
        if not isinstance(geom, dict):
            raise FenceError(f"{name}: {label}: geometry: must be a GeoJSON geometry object, got {json.dumps(geom)[:60]}")
        gtype, coords = geom.get("type"), geom.get("coordinates")
        if role in ("keep_in", "keep_out"):
            if gtype == "Polygon":
                parts = [("", coords, "geometry.coordinates")]
            elif gtype == "MultiPolygon":
                if not isinstance(coords, list) or not coords:
                    raise FenceError(f"{name}: {label}: geometry.coordinates: must be a non-empty list of polygons")
                parts = [(f" polygon {p}", c, f"geometry.coordinates[{p}]") for p, c in enumerate(coords)]
            else:
                raise FenceError(
                    f"{name}: {label}: a {role.replace('_', '-')} area must be a Polygon or MultiPolygon, got {gtype!r}"
                )
            for suffix, pc, where in parts:
                rings = _gj_polygon(pc, name, f"{label}: {where}")
                if role == "keep_in":
                    raw.inc_polys.append(rings[0])
                    if len(raw.inc_polys) != keep_in_index + 1:
                        continue  # not the chosen one (load_fence_file refuses or warns), holes and all
                    raw.inc_label = f"{label}{suffix}"
                    keep_in_props = props
                    for h, hole in enumerate(rings[1:], 1):
                        raw.exc_polys.append(hole)
                        raw.exc_labels.append(f"{label}{suffix} hole {h} (a keep-out)")
                        raw.exc_extents.append(FULL_HEIGHT)
                else:
                    raw.exc_polys.append(rings[0])
                    raw.exc_labels.append(f"{label}{suffix}")
                    raw.exc_extents.append(_gj_extent(props, name, label))
                    if len(rings) > 1:
                        raw.warnings.append(
                            f"{label}{suffix}: {len(rings) - 1} hole(s) of a keep-out ignored "
                            f"(the whole exterior ring is kept out)"
                        )
        else:
            if gtype != "Point":
                raise FenceError(f"{name}: {label}: a {role.replace('_', ' ')} must be a Point, got {gtype!r}")
            lat, lon = _gj_position(coords, name, f"{label}: geometry.coordinates")
            alt = props.get("alt_m")
            if alt is not None:
                alt = _json_number(alt, name, f"{label}: properties.alt_m")
            if role == "return_point":
                if raw.return_point is not None:
                    raw.warnings.append(f"{label}: second return point ignored")
                else:
                    raw.return_point = (lat, lon) if alt is None else (lat, lon, alt)
            else:
                raw.rally.append(RallyPoint(lat, lon, 0.0 if alt is None else alt, "unknown" if alt is None else "relative"))

    # vertical limits: the collection's, then the keep-in feature's (which win)
    for where, props in (("properties", top), (f"{raw.inc_label}: properties", keep_in_props or {})):
        for key in ("ceiling_m", "floor_m"):
            if props.get(key) is not None:
                setattr(raw, key, _json_number(props[key], name, f"{where}.{key}"))
        ref = props.get("altitude_reference")
        if ref is not None:
            ref = ref.lower() if isinstance(ref, str) else ref
            raw.altitude_reference = _kit(enum_value, ref, f"{name}: {where}.altitude_reference", enum_type=AltitudeReference)
    return raw


def _gj_extent(props: dict, name: str, label: str) -> VerticalExtent:
    """A keep-out feature's own ``floor_m``/``ceiling_m`` properties (numbers; the :class:`Fence` checks the rest)."""
    lo, hi = (
        None if props.get(key) is None else _json_number(props[key], name, f"{label}: properties.{key}")
        for key in ("floor_m", "ceiling_m")
    )
    return VerticalExtent(lo, hi)


def _gj_label(base: str, f: Any) -> str:
    """``features[3]``, with the feature's ``id`` or ``name`` property when it has one."""
    if isinstance(f, dict):
        if isinstance(f.get("id"), (str, int)) and not isinstance(f.get("id"), bool):
            return f"{base} (id {f['id']!r})"
        props = f.get("properties")
        if isinstance(props, dict) and isinstance(props.get("name"), str):
            return f"{base} (name {props['name']!r})"
    return base


def _gj_role(props: dict, name: str, label: str, raw: _Raw) -> str | None:
    """The feature's role from ``geofence`` (ours) or ``restriction`` (ED-269); None = ignored."""
    role = props.get("geofence")
    if role is not None:
        if role not in _GEOFENCE_ROLES:
            raise FenceError(f"{name}: {label}: properties.geofence: {role!r} is not one of {', '.join(_GEOFENCE_ROLES)}")
        return role
    restriction = props.get("restriction")
    if restriction is not None:
        if restriction in ED269_KEEP_OUT:
            return "keep_out"
        if restriction == "NO_RESTRICTION":
            raw.warnings.append(f"{label}: ED-269 restriction NO_RESTRICTION: ignored (not a keep-out)")
            return None
        raise FenceError(
            f"{name}: {label}: properties.restriction: {restriction!r} is not an ED-269 restriction "
            f"({', '.join(_ED269_RESTRICTIONS)})"
        )
    raise FenceError(
        f"{name}: {label}: no role: give properties.geofence ({', '.join(_GEOFENCE_ROLES)}) or an ED-269 properties.restriction"
    )


def _gj_polygon(coords: Any, name: str, where: str) -> list[PolygonLL]:
    """A GeoJSON Polygon's rings as (lat, lon) vertex tuples: ``[exterior, *holes]``."""
    if not isinstance(coords, list) or not coords:
        raise FenceError(f"{name}: {where}: must be a non-empty list of linear rings")
    return [_gj_ring(ring, name, f"{where}[{k}]") for k, ring in enumerate(coords)]


def _gj_ring(ring: Any, name: str, where: str) -> PolygonLL:
    if not isinstance(ring, list):
        raise FenceError(f"{name}: {where}: must be a list of [lon, lat] positions")
    pts = [_gj_position(p, name, f"{where}[{j}]") for j, p in enumerate(ring)]
    if len(ring) < 2 or ring[0] != ring[-1]:
        raise FenceError(f"{name}: {where}: ring is not closed (RFC 7946: its last position must repeat the first)")
    pts = pts[:-1]
    distinct = len(set(pts))
    if distinct < 3:
        raise FenceError(f"{name}: {where}: ring needs at least 3 distinct vertices, got {distinct}")
    return tuple(pts)


def _gj_position(p: Any, name: str, where: str) -> tuple[float, float]:
    """A GeoJSON position ``[lon, lat]`` or ``[lon, lat, height]`` -> ``(lat, lon)``."""
    if not isinstance(p, list) or not 2 <= len(p) <= 3:
        raise FenceError(f"{name}: {where}: must be a position [lon, lat] or [lon, lat, height], got {json.dumps(p)[:60]}")
    vals = [_json_number(v, name, where) for v in p]
    hint = " (GeoJSON positions are [lon, lat])"
    lon = _kit(longitude, vals[0], f"{name}: {where} longitude", hint)
    return _kit(latitude, vals[1], f"{name}: {where} latitude", hint), lon


def summarize(imported: ImportedFence) -> str:
    """A short multi-line human-readable summary (for a CLI)."""
    f = imported.fence
    lines = [
        f"{imported.source_path}: {imported.source_format}",
        f"  keep-in: {len(f.keep_in)} vertices; ceiling {f.ceiling_m:g} m {f.altitude_reference.upper()}"
        + (f", floor {f.floor_m:g} m" if f.floor_m is not None else ""),
        f"  keep-outs: {len(f.keep_out_polygons)} polygon(s), {len(f.keep_out_circles)} circle(s)",
    ]
    if imported.return_point is not None:
        lines.append(f"  return point: {', '.join(f'{x:.7f}' for x in imported.return_point)}")
    if imported.rally_points:
        lines.append(f"  rally points: {len(imported.rally_points)}")
    lines += [f"  warning: {w}" for w in imported.warnings]
    return "\n".join(lines)


# --------------------------------------------------------------------------- writing
EXPORT_FORMATS = ("qgc_plan", "qgc_wpl_110", "mavproxy_fence", "geojson", "kml")
"""The formats :func:`export_fence` writes (``kml`` is written only: nothing here reads it back)."""
EXPORT_SUFFIX = {"qgc_plan": ".plan", "qgc_wpl_110": ".waypoints", "mavproxy_fence": ".txt", "geojson": ".geojson", "kml": ".kml"}


@dataclass(frozen=True)
class ExportedFence:
    """A fence written in one format: the file's text and what the format could not carry."""

    text: str
    warnings: tuple[str, ...] = ()


def export_fence(fence: Fence, fmt: str, rally_points: Sequence[RallyPoint] = ()) -> ExportedFence:
    """``fence`` (and ``rally_points``) as a file of ``fmt`` (:data:`EXPORT_FORMATS`).

    Coordinates are written with every digit of the float (``repr``), so :func:`load_fence_file` reads back the
    same vertices, circle centres and radii. What a format cannot carry is stated in ``warnings``: none of the
    MAVLink/QGC formats has a ceiling or floor, floor gaps or a keep-out's own vertical extent; GeoJSON and KML
    have no circle (written as the inscribed polygon of :func:`~geofence.geometry.fence.circle_to_polygon`); the
    old MAVProxy format holds the keep-in polygon and the return point only.
    """
    writers = {
        "qgc_plan": _export_plan, "qgc_wpl_110": _export_wpl110, "mavproxy_fence": _export_mavproxy,
        "geojson": _export_geojson, "kml": _export_kml,
    }  # fmt: skip
    if fmt not in writers:
        raise ConfigError(f"--to: unknown fence format {fmt!r}; expected one of {', '.join(EXPORT_FORMATS)}")
    warnings: list[str] = []
    text = writers[fmt](fence, tuple(rally_points), warnings)
    return ExportedFence(text, tuple(warnings))


def _vertical_losses(f: Fence, fmt: str, warnings: list[str]) -> None:
    warnings.append(f"{fmt} carries no ceiling ({f.ceiling_m:g} m {f.altitude_reference.value}): give it again on import")
    if f.floor_m is not None:
        warnings.append(f"{fmt} carries no floor ({f.floor_m:g} m): dropped")
    if f.floor_gaps:
        warnings.append(f"{fmt} carries no floor gaps: {len(f.floor_gaps)} dropped")
    n = sum(1 for x in f.keep_out_polygon_extents if not x.full_height) + sum(
        1 for c in f.keep_out_circles if not c.extent.full_height
    )
    if n:
        warnings.append(f"{fmt} carries no keep-out floor/ceiling: {n} keep-out(s) written as full-height columns")


def _ll(poly: PolygonLL) -> list[list[float]]:
    return [[float(lat), float(lon)] for lat, lon in poly]


def _export_plan(f: Fence, rally: tuple[RallyPoint, ...], warnings: list[str]) -> str:
    _vertical_losses(f, "qgc_plan", warnings)
    polygons: list[dict[str, Any]] = []
    circles: list[dict[str, Any]] = []
    if f.keep_in_circle is not None:
        lat, lon, r = f.keep_in_circle
        circles.append({"circle": {"center": [lat, lon], "radius": r}, "inclusion": True, "version": 1})
    else:
        polygons.append({"inclusion": True, "polygon": _ll(f.keep_in), "version": 1})
    polygons += [{"inclusion": False, "polygon": _ll(p), "version": 1} for p in f.keep_out_polygons]
    circles += [
        {"circle": {"center": [c.center_lat_deg, c.center_lon_deg], "radius": c.radius_m}, "inclusion": False, "version": 1}
        for c in f.keep_out_circles
    ]
    geo: dict[str, Any] = {"circles": circles, "polygons": polygons, "version": 2}
    if f.recovery_point is not None:
        rp = list(f.recovery_point)
        geo["breachReturn"] = rp + [0.0] * (3 - len(rp))
    home = f.recovery_point[:2] if f.recovery_point is not None else f.keep_in[0]
    doc = {
        "fileType": "Plan", "groundStation": "geofence-testbed", "version": 1, "geoFence": geo,
        "mission": {"cruiseSpeed": 15, "firmwareType": 3, "hoverSpeed": 5, "items": [],
                    "plannedHomePosition": [home[0], home[1], 0.0], "vehicleType": 2, "version": 2},
        "rallyPoints": {"points": [[p.lat_deg, p.lon_deg, p.alt_m] for p in rally], "version": 2},
    }  # fmt: skip
    return json.dumps(doc, indent=4) + "\n"


def _wpl_line(seq: int, cmd: int, p1: float, lat: float, lon: float, alt: float = 0.0, frame: int = 0) -> str:
    return "\t".join([str(seq), "0", str(frame), str(cmd), repr(float(p1)), "0.0", "0.0", "0.0", repr(float(lat)), repr(float(lon)), repr(float(alt)), "1"])  # fmt: skip


def fence_items(f: Fence) -> list[FenceItem]:
    """The mission items of a fence, the inverse of :func:`fence_from_items`: the return point (5000), the keep-in
    circle (5003) or polygon vertices (5001, param1 = vertex count), the keep-out vertices (5002) and circles (5004,
    param1 = radius m). What a WPL 110 file and a MAVLink fence upload carry; the ceiling and floor are not among
    them."""
    rows: list[tuple[int, float, float, float, float, int]] = []  # cmd, p1, lat, lon, alt, frame
    if f.recovery_point is not None:
        rp = f.recovery_point
        rows.append((MAV_CMD_NAV_FENCE_RETURN_POINT, 0.0, rp[0], rp[1], rp[2] if len(rp) > 2 else 0.0, 0))
    if f.keep_in_circle is not None:
        lat, lon, r = f.keep_in_circle
        rows.append((MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, r, lat, lon, 0.0, 0))
    else:
        rows += [(MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, len(f.keep_in), lat, lon, 0.0, 0) for lat, lon in f.keep_in]
    for p in f.keep_out_polygons:
        rows += [(MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, len(p), lat, lon, 0.0, 0) for lat, lon in p]
    rows += [
        (MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, c.radius_m, c.center_lat_deg, c.center_lon_deg, 0.0, 0) for c in f.keep_out_circles
    ]
    return [
        FenceItem(f"item {i}", frame, cmd, (float(p1), 0.0, 0.0, 0.0, lat, lon, alt))
        for i, (cmd, p1, lat, lon, alt, frame) in enumerate(rows)
    ]


RALLY_FRAMES = {"relative": 3, "amsl": 0, "terrain": 10}
"""A rally point's altitude reference -> its item's MAV_FRAME (GLOBAL_RELATIVE_ALT, GLOBAL, GLOBAL_TERRAIN_ALT)."""


def rally_items(rally: Sequence[RallyPoint]) -> list[FenceItem]:
    """The mission items of rally points (5100), the inverse of :func:`rally_from_items`."""
    return [
        FenceItem(f"item {i}", RALLY_FRAMES.get(p.alt_reference, 3), MAV_CMD_NAV_RALLY_POINT, (0.0, 0.0, 0.0, 0.0, p.lat_deg, p.lon_deg, p.alt_m))
        for i, p in enumerate(rally)
    ]  # fmt: skip


def _export_wpl110(f: Fence, rally: tuple[RallyPoint, ...], warnings: list[str]) -> str:
    _vertical_losses(f, "qgc_wpl_110", warnings)
    lines = ["QGC WPL 110"]
    for i, it in enumerate(fence_items(f) + rally_items(rally)):
        p1, _, _, _, lat, lon, alt = it.params
        lines.append(_wpl_line(i, it.command, p1, lat, lon, alt, it.frame))
    return "\n".join(lines) + "\n"


def _export_mavproxy(f: Fence, rally: tuple[RallyPoint, ...], warnings: list[str]) -> str:
    _vertical_losses(f, "mavproxy_fence", warnings)
    if f.keep_in_circle is not None:
        warnings.append("mavproxy_fence has no circle: the keep-in circle is written as its inscribed polygon")
    if f.keep_out_polygons or f.keep_out_circles:
        warnings.append(f"mavproxy_fence has no keep-outs: {len(f.keep_out_polygons) + len(f.keep_out_circles)} dropped")
    if rally:
        warnings.append("mavproxy_fence has no rally points: write them with the rally format")
    rp = f.recovery_point[:2] if f.recovery_point is not None else (0.0, 0.0)
    pts = [rp, *f.keep_in, f.keep_in[0]]
    return "".join(f"{float(lat)!r} {float(lon)!r}\n" for lat, lon in pts)


def _keep_out_ring(c: KeepOutCircle) -> PolygonLL:
    """A keep-out circle as a polygon that contains it (conservative: the edges are tangent to the circle, or
    outside it): the inscribed polygon of :func:`circle_to_polygon` on the radius ``r / cos(pi / n)``."""
    _, n, _ = circle_to_polygon(c.center_lat_deg, c.center_lon_deg, c.radius_m)
    verts, _, _ = circle_to_polygon(c.center_lat_deg, c.center_lon_deg, c.radius_m / math.cos(math.pi / n))
    return verts


def _export_geojson(f: Fence, rally: tuple[RallyPoint, ...], warnings: list[str]) -> str:
    feats, top = geojson_fence_features(f, rally, warnings)
    return json.dumps({"type": "FeatureCollection", "properties": top, "features": feats}, indent=1) + "\n"


def geojson_fence_features(
    f: Fence, rally: Sequence[RallyPoint], warnings: list[str]
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The GeoJSON features of a fence (``properties.geofence`` roles, rings closed, [lon, lat], in the fence's
    vertex order) and the collection's ``properties`` (ceiling, floor, altitude reference): what
    :func:`export_fence` writes, for any file that carries the fence among other features."""

    def ring(poly: PolygonLL) -> list[list[float]]:
        pts = [[float(lon), float(lat)] for lat, lon in poly]
        return pts + [pts[0]]

    def feature(role: str, name: str, geometry: dict, **props: Any) -> dict:
        return {"type": "Feature", "properties": {"geofence": role, "name": name, **props}, "geometry": geometry}

    if f.keep_in_circle is not None:
        warnings.append("geojson has no circle: the keep-in circle is written as its inscribed polygon")
    top: dict[str, Any] = {"ceiling_m": f.ceiling_m, "altitude_reference": f.altitude_reference.value}
    if f.floor_m is not None:
        top["floor_m"] = f.floor_m
    if f.floor_gaps:
        warnings.append(f"geojson (as read here) carries no floor gaps: {len(f.floor_gaps)} dropped")
    feats = [feature("keep_in", "keep_in", {"type": "Polygon", "coordinates": [ring(f.keep_in)]})]
    extents = f.keep_out_polygon_extents or (FULL_HEIGHT,) * len(f.keep_out_polygons)
    for i, (p, x) in enumerate(zip(f.keep_out_polygons, extents)):
        feats.append(feature("keep_out", f"keep_out {i}", {"type": "Polygon", "coordinates": [ring(p)]}, **_extent_props(x)))
    if f.keep_out_circles:
        warnings.append(f"geojson has no circle: {len(f.keep_out_circles)} keep-out circle(s) written as polygons around them")
    for i, c in enumerate(f.keep_out_circles):
        poly = _keep_out_ring(c)
        feats.append(
            feature(
                "keep_out", f"keep_out circle {i}", {"type": "Polygon", "coordinates": [ring(poly)]}, **_extent_props(c.extent)
            )
        )
    if f.recovery_point is not None:
        rp = f.recovery_point
        props = {"alt_m": rp[2]} if len(rp) > 2 else {}
        feats.append(feature("return_point", "return point", {"type": "Point", "coordinates": [rp[1], rp[0]]}, **props))
    for i, rally_point in enumerate(rally):
        where = [rally_point.lon_deg, rally_point.lat_deg]
        feats.append(feature("rally", f"rally {i}", {"type": "Point", "coordinates": where}, alt_m=rally_point.alt_m))
    return feats, top


def _extent_props(x: VerticalExtent) -> dict[str, float]:
    out = {}
    if x.floor_m is not None:
        out["floor_m"] = x.floor_m
    if x.ceiling_m is not None:
        out["ceiling_m"] = x.ceiling_m
    return out


KML_NAMESPACE = "http://www.opengis.net/kml/2.2"


def _export_kml(f: Fence, rally: tuple[RallyPoint, ...], warnings: list[str]) -> str:
    """KML 2.2 (Google Earth): the keep-in and keep-outs as extruded polygons up to their ceiling, the return and
    rally points as placemarks (:func:`kml_fence_placemarks`). Written with :mod:`xml.etree.ElementTree`."""
    import xml.etree.ElementTree as ET

    root = ET.Element("kml", xmlns=KML_NAMESPACE)
    doc = ET.SubElement(root, "Document")
    ET.SubElement(doc, "name").text = "geofence"
    kml_fence_styles(doc)
    kml_fence_placemarks(doc, f, rally, warnings)
    return kml_text(root)


def kml_text(root: Any) -> str:
    """A KML element tree as the text of a file (indented, with its XML declaration)."""
    import xml.etree.ElementTree as ET

    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def kml_fence_styles(doc: Any) -> None:
    """The ``keep_in`` and ``keep_out`` polygon styles :func:`kml_fence_placemarks` refers to, added to ``doc``."""
    import xml.etree.ElementTree as ET

    for sid, colour in (("keep_in", "4000ff00"), ("keep_out", "400000ff")):
        style = ET.SubElement(doc, "Style", id=sid)
        ET.SubElement(ET.SubElement(style, "PolyStyle"), "color").text = colour


def kml_fence_placemarks(
    parent: Any, f: Fence, rally: Sequence[RallyPoint], warnings: list[str], ground_alt_m: float | None = None
) -> None:
    """The fence's placemarks, added to the KML element ``parent``: the keep-in and keep-outs as extruded polygons
    up to their ceilings, the return and rally points as points. Heights: an AMSL fence's are absolute; an AGL
    fence's are relative to the ground, or, given ``ground_alt_m`` (the flight's flat ground, m), absolute above
    it, as a flight's track is drawn."""
    import xml.etree.ElementTree as ET

    absolute = ground_alt_m is not None or f.altitude_reference is AltitudeReference.AMSL
    mode = "absolute" if absolute else "relativeToGround"
    lift = float(ground_alt_m) if ground_alt_m is not None and f.altitude_reference is AltitudeReference.AGL else 0.0

    def polygon(name: str, style: str, poly: PolygonLL, top_m: float) -> None:
        pm = ET.SubElement(parent, "Placemark")
        ET.SubElement(pm, "name").text = name
        ET.SubElement(pm, "styleUrl").text = f"#{style}"
        pg = ET.SubElement(pm, "Polygon")
        ET.SubElement(pg, "extrude").text = "1"
        ET.SubElement(pg, "altitudeMode").text = mode
        ring = ET.SubElement(ET.SubElement(pg, "outerBoundaryIs"), "LinearRing")
        pts = [*poly, poly[0]]
        top = top_m + lift
        ET.SubElement(ring, "coordinates").text = " ".join(f"{float(lon)!r},{float(lat)!r},{top!r}" for lat, lon in pts)

    def point(name: str, lat: float, lon: float, alt: float, relative: bool) -> None:
        pm = ET.SubElement(parent, "Placemark")
        ET.SubElement(pm, "name").text = name
        pt = ET.SubElement(pm, "Point")
        ET.SubElement(pt, "altitudeMode").text = "relativeToGround" if relative and ground_alt_m is None else "absolute"
        up = float(alt) + (float(ground_alt_m) if ground_alt_m is not None and relative else 0.0)
        ET.SubElement(pt, "coordinates").text = f"{float(lon)!r},{float(lat)!r},{up!r}"

    if f.keep_in_circle is not None:
        warnings.append("kml has no circle: the keep-in circle is written as its inscribed polygon")
    polygon("keep_in", "keep_in", f.keep_in, float(f.ceiling_m))
    extents = f.keep_out_polygon_extents or (FULL_HEIGHT,) * len(f.keep_out_polygons)
    for i, (p, x) in enumerate(zip(f.keep_out_polygons, extents)):
        polygon(f"keep_out {i}", "keep_out", p, float(x.ceiling_m if x.ceiling_m is not None else f.ceiling_m))
    for i, c in enumerate(f.keep_out_circles):
        top = float(c.extent.ceiling_m if c.extent.ceiling_m is not None else f.ceiling_m)
        polygon(f"keep_out circle {i}", "keep_out", _keep_out_ring(c), top)
    if f.keep_out_circles:
        warnings.append(f"kml has no circle: {len(f.keep_out_circles)} keep-out circle(s) written as polygons around them")
    if f.recovery_point is not None:
        rp = f.recovery_point
        point("return point", rp[0], rp[1], rp[2] if len(rp) > 2 else 0.0, f.altitude_reference is AltitudeReference.AGL)
    for i, rally_point in enumerate(rally):
        point(f"rally {i}", rally_point.lat_deg, rally_point.lon_deg, rally_point.alt_m, rally_point.alt_reference != "amsl")
