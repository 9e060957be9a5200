"""Import real-world fence and rally files into a :class:`~geofence.fence.Fence`.

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

Parser choice: our own, not :mod:`pymavlink.mavwp`. pymavlink's
``MissionItemProtocol_Fence``/``_Rally`` loaders only work when the
``MAVLINK20`` environment variable was set before pymavlink chose its dialect
(process-global state that would also change how :mod:`analysis.logs` decodes
tlogs); the old-format fence loader truncates coordinates to ``int(deg*1e7)``
and *prints* "Insufficient points" instead of failing; the RALLY loader
multiplies the altitude by 1000 and drops the break altitude; and their
errors name neither the file nor the line. The formats are simple
whitespace-separated text, so a strict parser here gives exact floats,
one-line :class:`~geofence.fence.FenceError` messages ``"<file>: line <n>:
<problem>"``, and checks pymavlink does not do (vertex-count mismatch, polygon
with < 3 vertices, coordinates out of range or unset). ``tests/test_importers.py``
cross-checks the items against pymavlink's loaders on the real files.

Mapping to :class:`Fence`
-------------------------
* keep-in: the first inclusion polygon. Further inclusion polygons and any
  inclusion circles are *not* intersected in (``Fence`` holds one keep-in);
  they are listed in ``warnings``. If the file has no inclusion polygon but an
  inclusion circle, the first circle becomes the keep-in as an inscribed
  regular polygon (vertices on the geodesic circle, so the approximation lies
  inside the circle and is conservative); its vertex count is the smallest
  (>= 16, <= 720) whose chord sag ``r(1 - cos(pi/N))`` is <= ``circle_tolerance_m``
  (0.1 m default), and both are stated in ``warnings``.
* keep-outs: exclusion polygons and exclusion circles. One that lies entirely
  outside the keep-in constrains nothing (ArduPilot allows it, ``Fence``
  rejects it), so it is dropped with a warning.
* ceiling/floor: none of these formats carries one (ArduPilot keeps
  ``FENCE_ALT_MAX`` in parameters, PX4 ``GF_MAX_VER_DIST``). The ceiling is
  the caller's ``ceiling_m``, default :data:`DEFAULT_CEILING_M` = 120 m AGL
  (the EU open-category / FAA Part 107 400 ft order of magnitude), stated in
  ``warnings`` when the default was used.
* recovery point: the return point (``FENCE_RETURN_POINT``, the first line of
  an old MAVProxy fence, QGC v1 ``breachReturn``) when it lies inside the
  allowed area; otherwise it is kept in ``return_point`` only, with a warning.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .fence import Fence, FenceError, KeepOutCircle, PolygonLL
from .geodesy import geodesic_destination
from .polygon import polygons_intersect

DEFAULT_CEILING_M = 120.0
"""Ceiling used when the caller gives none (m, AGL)."""

DEFAULT_CIRCLE_TOLERANCE_M = 0.1
"""Largest allowed gap between an inclusion circle and its inscribed polygon (m)."""

MAV_CMD_NAV_FENCE_RETURN_POINT = 5000
MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION = 5002
MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION = 5003
MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION = 5004
MAV_CMD_NAV_RALLY_POINT = 5100
_FENCE_CMDS = {5000, 5001, 5002, 5003, 5004}
_FRAME_REF = {0: "amsl", 5: "amsl", 3: "relative", 6: "relative", 10: "terrain", 11: "terrain"}

FORMATS = ("qgc_plan", "qgc_wpl_110", "mavproxy_fence", "mavproxy_rally")


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

    def has_fence(self) -> bool:
        return bool(self.inc_polys or self.exc_polys or self.inc_circles or self.exc_circles)


# --------------------------------------------------------------------------- public API
def load_fence_file(
    path: str | Path,
    *,
    ceiling_m: float | None = None,
    floor_m: float | None = None,
    altitude_reference: str = "agl",
    rally_path: str | Path | None = None,
    circle_tolerance_m: float = DEFAULT_CIRCLE_TOLERANCE_M,
    return_point_as_recovery: bool = True,
) -> ImportedFence:
    """Read a fence file (any format in :data:`FORMATS` except rally-only) into an :class:`ImportedFence`.

    ``rally_path``: an optional separate rally file (MAVProxy keeps rally points
    apart from the fence) whose points are appended to ``rally_points``.
    Raises :class:`FenceError` with one line naming the file and the problem.
    """
    name = str(path)
    raw = _read_raw(Path(path))
    if not raw.has_fence():
        what = "only rally points" if raw.rally else "no fence items"
        raise FenceError(f"{name}: {what} (no inclusion/exclusion polygon or circle)")
    if not raw.inc_polys and not raw.inc_circles:
        raise FenceError(f"{name}: no inclusion polygon or circle (only exclusions); a keep-in area is required")
    warnings = list(raw.warnings)
    if ceiling_m is None:
        ceiling_m = DEFAULT_CEILING_M
        warnings.append(f"no ceiling in the file format; using the default ceiling {DEFAULT_CEILING_M:g} m {altitude_reference.upper()}")

    # keep-in
    if raw.inc_polys:
        keep_in = raw.inc_polys[0]
        if len(raw.inc_polys) > 1:
            warnings.append(f"{len(raw.inc_polys) - 1} further inclusion polygon(s) ignored: the fence uses the first only")
        if raw.inc_circles:
            warnings.append(f"{len(raw.inc_circles)} inclusion circle(s) ignored: the fence uses the first inclusion polygon only")
    else:
        c = raw.inc_circles[0]
        keep_in, n, sag = circle_to_polygon(c.center_lat_deg, c.center_lon_deg, c.radius_m, circle_tolerance_m)
        warnings.append(f"inclusion circle r={c.radius_m:g} m approximated by an inscribed {n}-gon (max gap {sag:.3f} m inside the circle)")
        if len(raw.inc_circles) > 1:
            warnings.append(f"{len(raw.inc_circles) - 1} further inclusion circle(s) ignored: the fence uses the first only")

    def build(**kw: Any) -> Fence:
        try:
            return Fence(keep_in=keep_in, ceiling_m=ceiling_m, floor_m=floor_m,
                         altitude_reference=altitude_reference, **kw)
        except FenceError as exc:
            raise FenceError(f"{name}: {exc}") from None

    base = build()
    local = base.to_local()
    keep_out_polys = []
    for i, p in enumerate(raw.exc_polys):
        try:
            Fence(keep_in=p, ceiling_m=ceiling_m, floor_m=floor_m, altitude_reference=altitude_reference)
        except FenceError as exc:
            raise FenceError(f"{name}: exclusion polygon {i}: {exc}") from None
        en = [local.horizontal_en(lat, lon) for lat, lon in p]
        if polygons_intersect(local.keep_in.vertices, en):
            keep_out_polys.append(p)
        else:
            warnings.append(f"exclusion polygon {i} lies entirely outside the keep-in area: dropped (it constrains nothing)")
    keep_out_circles = []
    for i, c in enumerate(raw.exc_circles):
        e, n = local.horizontal_en(c.center_lat_deg, c.center_lon_deg)
        if local.keep_in.signed_distance(e, n) <= -c.radius_m:
            warnings.append(f"exclusion circle {i} lies entirely outside the keep-in area: dropped (it constrains nothing)")
        else:
            keep_out_circles.append(c)
    fence = build(keep_out_polygons=tuple(keep_out_polys), keep_out_circles=tuple(keep_out_circles))

    if raw.return_point is not None and return_point_as_recovery:
        lat, lon = raw.return_point[0], raw.return_point[1]
        lf = fence.to_local()
        m = lf.lateral_margin_m(*lf.horizontal_en(lat, lon))
        if m > 0.0:
            fence = build(keep_out_polygons=fence.keep_out_polygons, keep_out_circles=fence.keep_out_circles,
                          recovery_point=(lat, lon))
        else:
            warnings.append(f"return point ({lat:.7f}, {lon:.7f}) is not inside the allowed area "
                            f"(margin {m:.1f} m): not used as the recovery point")

    rally = list(raw.rally)
    if rally_path is not None:
        rally.extend(load_rally_file(rally_path))
    return ImportedFence(
        fence=fence,
        source_path=name,
        source_format=raw.fmt,
        keep_in_polygons=tuple(raw.inc_polys),
        inclusion_circles=tuple(raw.inc_circles),
        keep_out_polygons=tuple(raw.exc_polys),
        keep_out_circles=tuple(raw.exc_circles),
        return_point=raw.return_point,
        rally_points=tuple(rally),
        home=raw.home,
        warnings=warnings,
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


def circle_to_polygon(lat_deg: float, lon_deg: float, radius_m: float,
                      tolerance_m: float = DEFAULT_CIRCLE_TOLERANCE_M) -> tuple[PolygonLL, int, float]:
    """An inscribed regular polygon of a geodesic circle: ``(vertices, n, max_gap_m)``.

    ``n`` is the smallest count in [16, 720] with chord sag ``r(1 - cos(pi/n)) <=
    tolerance_m``; ``max_gap_m`` is that sag (how far inside the circle an edge's
    midpoint lies).
    """
    if not radius_m > 0.0:
        raise FenceError(f"circle radius must be > 0, got {radius_m:g}")
    ratio = 1.0 - min(tolerance_m / radius_m, 1.0)
    n = 16 if ratio <= math.cos(math.pi / 16) else math.ceil(math.pi / math.acos(ratio))
    n = max(16, min(720, n))
    verts = tuple(geodesic_destination(lat_deg, lon_deg, 360.0 * k / n, radius_m) for k in range(n))
    return verts, n, radius_m * (1.0 - math.cos(math.pi / n))


def fence_to_yaml_block(imported: ImportedFence | Fence) -> dict:
    """A ``{"geofence": {"fence": {...}}}`` mapping for a scenario file (``parse_fence`` reads it back).

    Only the fence geometry is emitted; add the geofence unit's other keys
    (if any) to ``["geofence"]`` yourself.
    """
    f = imported.fence if isinstance(imported, ImportedFence) else imported
    block: dict[str, Any] = {"keep_in": [[lat, lon] for lat, lon in f.keep_in], "ceiling_m": f.ceiling_m}
    if f.floor_m is not None:
        block["floor_m"] = f.floor_m
    block["altitude_reference"] = f.altitude_reference
    if f.floor_gaps:
        block["floor_gaps"] = [[[lat, lon] for lat, lon in g] for g in f.floor_gaps]
    if f.keep_out_polygons:
        block["keep_out_polygons"] = [[[lat, lon] for lat, lon in p] for p in f.keep_out_polygons]
    if f.keep_out_circles:
        block["keep_out_circles"] = [{"center": [c.center_lat_deg, c.center_lon_deg], "radius_m": c.radius_m}
                                     for c in f.keep_out_circles]
    if f.recovery_point is not None:
        block["recovery_point"] = list(f.recovery_point)
    return {"geofence": {"fence": block}}


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
    for line in text.splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith(("{", "[")):
            return "qgc_plan"
        if s.startswith("QGC WPL"):
            if s.split() == ["QGC", "WPL", "110"]:
                return "qgc_wpl_110"
            raise FenceError(f"{name}: unsupported waypoint file version {s!r} (only 'QGC WPL 110')")
        if s.split()[0].upper() == "RALLY":
            return "mavproxy_rally"
        if _LATLON_LINE.match(s):
            return "mavproxy_fence"
        raise FenceError(f"{name}: unrecognised fence file format (first line {s[:40]!r}); "
                         f"expected .plan JSON, 'QGC WPL 110', 'lat lon' lines or 'RALLY' lines")
    raise FenceError(f"{name}: empty file")


def _read_raw(path: Path) -> _Raw:
    text = _read_text(path)
    name = str(path)
    fmt = _detect(text, name)
    return {"qgc_plan": _parse_plan, "qgc_wpl_110": _parse_wpl110,
            "mavproxy_fence": _parse_mavproxy_fence, "mavproxy_rally": _parse_mavproxy_rally}[fmt](text, name)


def _float(tok: str, name: str, where: str, what: str) -> float:
    try:
        v = float(tok)
    except ValueError:
        raise FenceError(f"{name}: {where}: {what} {tok!r} is not a number") from None
    if not math.isfinite(v):
        raise FenceError(f"{name}: {where}: {what} {tok!r} is not finite")
    return v


def _check_latlon(lat: float, lon: float, name: str, where: str) -> tuple[float, float]:
    if not -90.0 <= lat <= 90.0:
        raise FenceError(f"{name}: {where}: latitude {lat:g} deg is outside [-90, 90]")
    if not -180.0 <= lon <= 180.0:
        raise FenceError(f"{name}: {where}: longitude {lon:g} deg is outside [-180, 180]")
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
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(float(x)):
        raise FenceError(f"{name}: {where}: must be a number, got {x!r}")
    return float(x)


def _json_point(p: Any, name: str, where: str, n: int | tuple = 2) -> tuple[float, ...]:
    ok = (n,) if isinstance(n, int) else n
    if not isinstance(p, list) or len(p) not in ok:
        raise FenceError(f"{name}: {where}: must be [lat, lon{', alt' if 3 in ok else ''}], got {json.dumps(p)[:60]}")
    vals = tuple(_json_number(v, name, where) for v in p)
    _check_latlon(vals[0], vals[1], name, where)
    return vals


def _parse_plan(text: str, name: str) -> _Raw:
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
        h = _json_point(mission["plannedHomePosition"], name, "mission.plannedHomePosition", 3)
        raw.home = (h[0], h[1], h[2])
    return raw


# ---- QGC WPL 110
_WPL_NAMES = {5000: "FENCE_RETURN_POINT", 5001: "FENCE_POLYGON_VERTEX_INCLUSION",
              5002: "FENCE_POLYGON_VERTEX_EXCLUSION", 5003: "FENCE_CIRCLE_INCLUSION",
              5004: "FENCE_CIRCLE_EXCLUSION", 5100: "RALLY_POINT"}


def _parse_wpl110(text: str, name: str) -> _Raw:
    raw = _Raw("qgc_wpl_110")
    lines = text.splitlines()
    header_seen = False
    items = []
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
            raise FenceError(f"{name}: {where}: expected 12 fields "
                             f"(seq current frame command p1 p2 p3 p4 lat lon alt autocontinue), got {len(a)}")
        try:
            seq, frame, cmd = int(a[0]), int(a[2]), int(a[3])
        except ValueError:
            raise FenceError(f"{name}: {where}: seq, frame and command must be integers") from None
        p = [_float(t, name, where, f"field {k + 5}") for k, t in enumerate(a[4:11])]
        items.append((lineno, seq, frame, cmd, p))
    if items and [it[1] for it in items] != list(range(items[0][1], items[0][1] + len(items))):
        raw.warnings.append("item sequence numbers are not consecutive; items were read in file order")

    group: list | None = None  # [cmd, count, first_lineno, vertices]

    def close_group() -> None:
        nonlocal group
        if group is None:
            return
        cmd, count, ln, verts = group
        if len(verts) != count:
            raise FenceError(f"{name}: line {ln}: vertex count mismatch: {_WPL_NAMES[cmd]} polygon declares "
                             f"{count} vertices (param1) but has {len(verts)}")
        poly = _close_polygon(verts, name, f"line {ln}")
        (raw.inc_polys if cmd == MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION else raw.exc_polys).append(poly)
        group = None

    ignored: dict[int, int] = {}
    for ln, _seq, frame, cmd, p in items:
        where = f"line {ln}"
        if cmd in (MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION):
            latlon = _check_latlon(p[4], p[5], name, where)
            count = p[0]
            if group is not None and (group[0] != cmd or len(group[3]) == group[1]):
                close_group()
            if group is None:
                if count != int(count) or count < 3:
                    raise FenceError(f"{name}: {where}: {_WPL_NAMES[cmd]} param1 (vertex count) must be an "
                                     f"integer >= 3, got {count:g}")
                group = [cmd, int(count), ln, []]
            elif count != group[1]:
                raise FenceError(f"{name}: {where}: vertex count mismatch: param1 {count:g} differs from "
                                 f"{group[1]} declared at line {group[2]}")
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
    return raw


# ---- old MAVProxy fence / rally text
def _parse_mavproxy_fence(text: str, name: str) -> _Raw:
    raw = _Raw("mavproxy_fence")
    pts: list[tuple[float, float]] = []
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
            raise FenceError(f"{name}: {where}: RALLY line needs 6 values (lat lon alt break_alt land_dir flags), got {len(a) - 1}")
        v = [_float(t, name, where, f) for t, f in zip(a[1:], ("latitude", "longitude", "alt", "break_alt", "land_dir", "flags"))]
        lat, lon = _check_latlon(v[0], v[1], name, where)
        if v[5] != int(v[5]):
            raise FenceError(f"{name}: {where}: flags {a[6]!r} is not an integer")
        raw.rally.append(RallyPoint(lat, lon, v[2], "relative", break_alt_m=v[3], land_dir_deg=v[4], flags=int(v[5])))
    return raw


def summarize(imported: ImportedFence) -> str:
    """A short multi-line human-readable summary (for a CLI)."""
    f = imported.fence
    lines = [f"{imported.source_path}: {imported.source_format}",
             f"  keep-in: {len(f.keep_in)} vertices; ceiling {f.ceiling_m:g} m {f.altitude_reference.upper()}"
             + (f", floor {f.floor_m:g} m" if f.floor_m is not None else ""),
             f"  keep-outs: {len(f.keep_out_polygons)} polygon(s), {len(f.keep_out_circles)} circle(s)"]
    if imported.return_point is not None:
        lines.append(f"  return point: {', '.join(f'{x:.7f}' for x in imported.return_point)}")
    if imported.rally_points:
        lines.append(f"  rally points: {len(imported.rally_points)}")
    lines += [f"  warning: {w}" for w in imported.warnings]
    return "\n".join(lines)

