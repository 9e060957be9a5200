"""Scenario files: the YAML schema, loaded and validated into frozen dataclasses.

A scenario says what flies (``aircraft``), where it starts (``start``), what the
pilot does (``mission`` for the GPS autopilot, or a ``pilot`` script), the
weather (``wind``), how long (``duration_s``) and, optionally, the
``geofence``. Angles are in degrees and positions WGS-84 lat/lon here at the
edge; everything downstream is SI. See ``README.md`` for a full example, and
``scenarios/*.yaml`` for shipped ones.

Every problem is reported as a :class:`~geofence.validation.ConfigError` whose
message is one line: ``<file>: <field>: <problem>``.

Besides each value's own range, a scenario must make sense as a whole
(:func:`_check_consistency`): the start inside the geofence's allowed area,
mission items inside it, a mean wind the platform can fly against, and nothing
within ~100 km of a pole. The first three may be deliberate (a test of the
fence's recovery, a storm): list them under ``allow:`` (:data:`ALLOWABLE`) and
they become warnings (``Scenario.warnings``) instead of errors. Near a pole the
local frame and the autopilot's geometry break down, so that is always refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum, StrEnum
from functools import partial
from pathlib import Path
from typing import Any

import yaml

from aircraft.jsbsim_model import UnknownAircraftError, model_folder
from aircraft.profile import PlatformProfile, available_profiles, load_profile, parse_profile
from aircraft.sensors import SensorConfig, parse_sensors
from geofence.geometry.fence import AltitudeReference, FenceError
from geofence.geometry.geodesy import LocalFrame
from geofence.geometry.local_fence import LocalFence
from geofence.interface import PlatformKind
from geofence.margins.boundary_shift import check_shift_feasible
from geofence.physics.dynamics import envelope_at_density, isa_density_ratio
from geofence.unit.config import GeofenceConfig, parse_geofence
from geofence.validation import (
    ConfigError,
    enum_value,
    field_default,
    integer,
    latitude,
    longitude,
    number,
    reject_unknown_keys,
    require_mapping,
    string,
)
from scenarios.definition.faults import Fault, parse_faults
from scenarios.definition.fence_file import fence_file_path, fence_from_file
from wind.config import WindConfig, parse_wind

MISSION_ITEM_TYPES = ("takeoff", "waypoint", "loiter", "land")
ALLOWABLE = ("start_outside_fence", "mission_outside_fence", "wind_above_platform_speed", "fence_too_small_at_site")
"""Inconsistencies a scenario may ask for deliberately, with ``allow: [...]``."""
POLE_LIMIT_DEG = 88.0
"""Latitudes beyond +/- this (within ~220 km of a pole) are refused."""
SCRIPT_SPEEDS = ("cruise", "max", "min")
SCRIPT_CLIMBS = ("hold", "max", "descend")


@dataclass(frozen=True)
class StartConfig:
    lat_deg: float
    lon_deg: float
    ground_alt_m: float = 0.0
    """Ground elevation at the site, m above the WGS-84 ellipsoid (flat terrain)."""
    agl_m: float = 0.0
    """Start height above ground, m; 0 = on the ground."""
    heading_deg: float = 0.0
    airspeed_mps: float = 0.0
    """Air-start airspeed (fixed-wing); 0 = the platform's cruise speed."""

    @property
    def frame(self) -> LocalFrame:
        """The flight's local ENU frame: origin at the start point, on the ground."""
        return LocalFrame(self.lat_deg, self.lon_deg, self.ground_alt_m)

    @property
    def altitude_m(self) -> float:
        """The start point's altitude, m (ground elevation plus the start height)."""
        return self.ground_alt_m + max(self.agl_m, 0.0)

    @property
    def density_ratio(self) -> float:
        """The ISA air-density ratio at the start point: the site's density the fence is judged at."""
        return isa_density_ratio(self.altitude_m)


@dataclass(frozen=True)
class MissionItem:
    kind: str
    """One of takeoff, waypoint, loiter, land."""
    lat_deg: float | None = None
    lon_deg: float | None = None
    agl_m: float | None = None
    duration_s: float = 0.0
    """Loiter time, s."""
    radius_m: float = 0.0
    """Loiter circle radius, m (0 = the platform's default)."""


@dataclass(frozen=True)
class MissionConfig:
    items: tuple[MissionItem, ...]
    acceptance_radius_m: float = 5.0
    speed_mps: float | None = None
    """Ground speed (multirotor) or airspeed (fixed-wing) along legs; default cruise."""

    @property
    def n_waypoints(self) -> int:
        return len(self.items)


class SegmentEnd(StrEnum):
    """An event that ends a scripted segment before its ``duration_s`` (the next segment starts at once)."""

    HANDBACK = "handback"
    """The geofence hands control back to the pilot after overriding him during this segment."""
    REACH = "reach"
    """The vehicle comes within ``reach.radius_m`` (horizontal) of ``reach``'s point."""


@dataclass(frozen=True)
class ScriptSegment:
    """One piece of a scripted (adversarial) pilot, held for ``duration_s`` or until its ``end_on`` event.

    Either raw ``sticks`` (roll, pitch, yaw, throttle in [-1, 1]) or a behaviour:
    steer ground ``course_deg`` at ``speed`` (cruise | max | min) while the
    vertical channel does ``climb`` (hold | max | descend).
    """

    duration_s: float
    sticks: tuple[float, float, float, float] | None = None
    course_deg: float | None = None
    speed: str = "max"
    climb: str = "hold"
    end_on: SegmentEnd | None = None
    reach: tuple[float, float, float] | None = None
    """``(lat_deg, lon_deg, radius_m)`` for ``end_on: reach``."""


class VerticalSense(IntEnum):
    """Which way a breach attempt pushes in height: a vertical push (toward the floor or the ceiling), or level."""

    DOWN = -1
    LEVEL = 0
    UP = 1


class BreachDirection(str):
    """One direction of the breach-attempts pilot: a horizontal bearing, ``up`` or ``down``.

    A direction *is* its readable label (a ``str``: ``west``, ``up``, ``down``, ``bearing 20``), so the
    attempt log, its JSON and the seed analysis read it as they read the names; what it means is typed:
    :attr:`bearing_rad` (clockwise from north, in [0, 2 pi); None for a vertical push) and
    :attr:`vertical` (:class:`VerticalSense`). Build one with :meth:`of`: a name of
    :data:`BREACH_DIRECTION_NAMES` or a bearing in degrees (any value, normalised to [0, 360)).
    """

    __slots__ = ("_bearing_rad", "_vertical", "_unit_en")

    _bearing_rad: float | None
    _vertical: VerticalSense
    _unit_en: tuple[float, float]

    def __new__(cls, label: str, bearing_rad: float | None, vertical: VerticalSense) -> BreachDirection:
        self = super().__new__(cls, label)
        if (bearing_rad is None) == (vertical is VerticalSense.LEVEL):
            raise ValueError("a breach direction is a bearing (level) or vertical (no bearing)")
        self._bearing_rad = bearing_rad
        self._vertical = VerticalSense(vertical)
        if bearing_rad is None:
            self._unit_en = (0.0, 0.0)
        else:  # cardinal bearings exactly on the axes (sin/cos rounding noise snapped to 0)
            e, n = math.sin(bearing_rad), math.cos(bearing_rad)
            self._unit_en = (0.0 if abs(e) < 1e-12 else e, 0.0 if abs(n) < 1e-12 else n)
        return self

    def __reduce__(self) -> tuple[Any, ...]:
        return (BreachDirection, (str(self), self._bearing_rad, self._vertical))

    @classmethod
    def of(cls, value: BreachDirection | str | float) -> BreachDirection:
        """A direction from a name (``north``, ``east``, ``south``, ``west``, ``up``, ``down``) or a bearing in degrees.

        Raises ``ValueError`` for anything else (the schema reports that as a :class:`ConfigError`).
        """
        if isinstance(value, BreachDirection):
            return value
        if isinstance(value, str):
            if value not in BREACH_DIRECTION_NAMES:
                raise ValueError(f"{value!r} is not one of {', '.join(BREACH_DIRECTION_NAMES)} or a bearing in degrees")
            return _NAMED_DIRECTIONS[value]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"expected a direction name or a bearing in degrees, got {value!r}")
        bearing_deg = float(value) % 360.0
        if bearing_deg >= 360.0:  # a tiny negative bearing rounds up to 360
            bearing_deg = 0.0
        return cls(f"bearing {bearing_deg:g}", math.radians(bearing_deg), VerticalSense.LEVEL)

    @property
    def bearing_rad(self) -> float | None:
        """The horizontal push's bearing, rad clockwise from north in [0, 2 pi); None for ``up``/``down``."""
        return self._bearing_rad

    @property
    def vertical(self) -> VerticalSense:
        return self._vertical

    @property
    def is_vertical(self) -> bool:
        return self._vertical is not VerticalSense.LEVEL

    @property
    def unit_en(self) -> tuple[float, float]:
        """The horizontal push's unit vector (east, north); (0, 0) for a vertical push."""
        return self._unit_en

    @property
    def unit_enu(self) -> tuple[float, float, float]:
        """The push's unit vector (east, north, up): along the bearing, or straight up or down."""
        return (*self._unit_en, float(self._vertical))


BREACH_DIRECTION_NAMES = ("north", "east", "south", "west", "up", "down")
"""The named breach directions; any other direction is a bearing in degrees (a YAML number)."""
_NAMED_DIRECTIONS = {
    **{
        name: BreachDirection(name, math.radians(deg), VerticalSense.LEVEL)
        for name, deg in (("north", 0.0), ("east", 90.0), ("south", 180.0), ("west", 270.0))
    },
    "up": BreachDirection("up", None, VerticalSense.UP),
    "down": BreachDirection("down", None, VerticalSense.DOWN),
}


class SpeedDraw(StrEnum):
    """How the breach-attempts pilot draws its approach speeds (all up front, from its seed)."""

    PER_ATTEMPT = "per_attempt"
    """A speed per attempt (the seed flights)."""
    PER_ROUND = "per_round"
    """A speed per round of directions: every direction is pushed at the same speed in a round, so the
    axes are compared at matched speeds (the x/y symmetry check of the seed reproduction)."""


@dataclass(frozen=True)
class BreachAttemptsConfig:
    """A pilot who pushes across the fence again and again (the seed flights' indoor pilot; fixed-wings too).

    Each attempt starts from home ``home_agl_m`` above the start point (a hover for a multirotor, an orbit
    for a fixed-wing), flies toward ``directions[k % len]`` (a :class:`BreachDirection`: a compass name or a
    bearing, or ``up``/``down`` toward the ceiling or the floor) at a speed drawn uniformly from
    ``speed_mps`` = [low, high], keeps pushing for ``push_m`` of travel, returns home and rests ``rest_s``.
    The defaults are the indoor quad's; :func:`breach_defaults` gives a fixed-wing's. Directions given as
    names or numbers (in Python) become :class:`BreachDirection` values.
    """

    attempts: int = 10
    directions: tuple[BreachDirection, ...] = (
        _NAMED_DIRECTIONS["west"],
        _NAMED_DIRECTIONS["north"],
        _NAMED_DIRECTIONS["up"],
    )
    speed_mps: tuple[float, float] = (0.3, 1.0)
    push_m: float = 1.5
    rest_s: float = 3.0
    home_agl_m: float = 0.8
    seed: int = 0
    speed_draw: SpeedDraw = SpeedDraw.PER_ATTEMPT

    def __post_init__(self) -> None:
        object.__setattr__(self, "directions", tuple(BreachDirection.of(d) for d in self.directions))

    def direction(self, k: int) -> BreachDirection:
        """The direction of attempt ``k`` (the list repeats)."""
        return self.directions[k % len(self.directions)]


FIXED_WING_PUSH_M = 400.0
"""A fixed-wing breach attempt's default push (m): far enough to reach a fence a few hundred metres away."""
FIXED_WING_REST_S = 10.0
FIXED_WING_HOME_AGL_M = 60.0
"""A fixed-wing's default home height (m AGL) when it starts on the ground (in the air: its start height)."""


def breach_defaults(profile: PlatformProfile, start: StartConfig) -> BreachAttemptsConfig:
    """The breach-attempts settings a scenario leaves out: the indoor quad's, or for a fixed-wing its own.

    Fixed-wing: speeds [cruise, max] of the envelope, a push of :data:`FIXED_WING_PUSH_M`, a rest of
    :data:`FIXED_WING_REST_S`, home at the start height (an air start) or :data:`FIXED_WING_HOME_AGL_M`.
    """
    if profile.envelope.is_multirotor:
        return BreachAttemptsConfig()
    env = profile.envelope
    return BreachAttemptsConfig(
        speed_mps=(env.cruise_speed_mps, env.max_speed_mps),
        push_m=FIXED_WING_PUSH_M,
        rest_s=FIXED_WING_REST_S,
        home_agl_m=start.agl_m if start.agl_m > 0.0 else FIXED_WING_HOME_AGL_M,
    )


class PilotKind(StrEnum):
    """Who flies: the GPS mission autopilot, a stick script, or the breach-attempts pilot."""

    MISSION = "mission"
    """The GPS autopilot flying the scenario's ``mission``."""
    SCRIPTED = "scripted"
    """Timed segments of sticks or blunt behaviours (``segments``)."""
    BREACH_ATTEMPTS = "breach_attempts"
    """Repeated pushes across the fence (``breach``)."""


@dataclass(frozen=True)
class PilotConfig:
    kind: PilotKind
    segments: tuple[ScriptSegment, ...] = ()
    breach: BreachAttemptsConfig | None = None


@dataclass(frozen=True)
class Scenario:
    name: str
    source: Path | None
    aircraft: str
    profile: PlatformProfile
    """Envelope and flight-controller gains (shipped, or inline in the scenario)."""
    start: StartConfig
    duration_s: float
    seed: int
    pilot: PilotConfig
    mission: MissionConfig | None
    wind: WindConfig | None
    control_rate_hz: float = 40.0
    geofence: GeofenceConfig | None = None
    """The geofence unit's configuration (None: fly without a geofence)."""
    description: str = ""
    sensors: SensorConfig = field(default_factory=SensorConfig)
    """The geofence unit's sensors (noise, rates, GPS outages)."""
    allow: frozenset[str] = frozenset()
    """Inconsistencies the scenario asks for deliberately (see :data:`ALLOWABLE`)."""
    warnings: tuple[str, ...] = ()
    """One line each: the allowed inconsistencies this scenario actually has."""
    faults: tuple[Fault, ...] = ()
    """Failures injected into the flight (:mod:`scenarios.definition.faults`)."""

    @property
    def frame(self) -> LocalFrame:
        """The flight's local ENU frame (:attr:`StartConfig.frame`)."""
        return self.start.frame

    @property
    def frames_per_step(self) -> int:
        """JSBSim frames per outer-loop step: the model's frame time (``1 / profile.frame_rate_hz``, the
        platform's ``dt_s``) into the control period, rounded, at least 1."""
        return max(1, round(1.0 / (self.control_rate_hz * (1.0 / self.profile.frame_rate_hz))))

    def local_fence(self) -> LocalFence | None:
        """The geofence's fence in :attr:`frame` (None without a geofence)."""
        return self.geofence.fence.to_local(self.frame) if self.geofence is not None else None


_TOP_KEYS = frozenset(
    {
        "name",
        "description",
        "aircraft",
        "profile",
        "sensors",
        "start",
        "duration_s",
        "seed",
        "pilot",
        "mission",
        "wind",
        "control_rate_hz",
        "geofence",
        "allow",
        "faults",
    }
)


class UniqueKeyLoader(yaml.SafeLoader):
    """PyYAML's safe loader that refuses a mapping repeating a key (YAML forbids it; PyYAML would keep the last
    one silently: a second ``wind:`` pasted below the first would replace it without a word). Merge keys
    (``<<:``) still merge."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        first: dict[Any, yaml.Mark] = {}
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                seen = first.get(key)
            except TypeError:  # an unhashable key: the base class says so
                continue
            if seen is not None:
                raise yaml.constructor.ConstructorError(
                    "while constructing a mapping",
                    node.start_mark,
                    f"duplicate key {key!r} (first at line {seen.line + 1})",
                    key_node.start_mark,
                )
            first[key] = key_node.start_mark
        return super().construct_mapping(node, deep=deep)

    def get_single_data(self) -> Any:
        """The document, refused before it is built when its aliases expand it beyond :data:`MAX_YAML_NODES`."""
        node = self.get_single_node()
        if node is None:
            return None
        _check_expanded_size(node)
        return self.construct_document(node)


MAX_YAML_NODES = 1_000_000
"""A scenario document may hold at most this many YAML nodes once its aliases are expanded (the largest
inline fence, 200,000 vertices of two numbers each, is some 600,000). A few lines of nested aliases
("billion laughs") otherwise stand for 10^9 nodes, and anything that walks the document (a name
stringified, the scenario hash) would grow without end."""


class DocumentTooLarge(yaml.YAMLError):
    """A YAML document whose aliases stand for more than :data:`MAX_YAML_NODES` nodes, or for a loop."""


def _check_expanded_size(root: yaml.Node) -> None:
    """Count ``root``'s nodes as if every alias were copied out (each distinct node visited once, no
    recursion); refuse a recursive alias or more than :data:`MAX_YAML_NODES`."""
    size: dict[int, int] = {}
    on_path: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        children = _yaml_children(node)
        if done:
            on_path.discard(id(node))
            size[id(node)] = total = 1 + sum(size[id(c)] for c in children)
            if total > MAX_YAML_NODES:
                raise DocumentTooLarge(
                    f"YAML aliases: expand the document beyond {MAX_YAML_NODES:,} nodes (an alias bomb?); "
                    f"write the values out or use fewer nested aliases"
                )
            continue
        if id(node) in size:
            continue
        on_path.add(id(node))
        stack.append((node, True))
        for c in children:
            if id(c) in on_path:
                raise DocumentTooLarge(f"YAML aliases: line {c.start_mark.line + 1}: a recursive alias (a node inside itself)")
            if id(c) not in size:
                stack.append((c, False))


def _yaml_children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []


def read_document(path: str | Path, what: str = "scenario file") -> Any:
    """Read a YAML file; any problem (malformed YAML, a key given twice in one mapping) is a one-line
    :class:`ConfigError` naming the file (``what`` it should have been, when it is missing)."""
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise ConfigError(f"{where}: no such {what}")
    try:
        raw = yaml.load(path.read_text(), Loader=UniqueKeyLoader)  # noqa: S506 - a SafeLoader
    except DocumentTooLarge as exc:
        raise ConfigError(f"{where}: {exc}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(f"{where}: malformed YAML{at}: {problem}") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{where}: not a text file") from None
    except RecursionError:
        raise ConfigError(f"{where}: malformed YAML: nested too deeply for the YAML reader") from None
    if raw is None:
        raise ConfigError(f"{where}: the file is empty")
    return raw


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file (one without a ``sweep:`` block)."""
    path = Path(path)
    raw = read_document(path)
    if isinstance(raw, dict) and "sweep" in raw:
        raise ConfigError(f"{path}: sweep: this file is a sweep of many flights; run it with 'geofence-testbed batch'")
    return parse_scenario(raw, where=str(path), default_name=path.stem, source=path)


def scenario_base_dir(where: str, source: Path | str | None = None, base_dir: Path | str | None = None) -> Path | None:
    """The folder files a scenario references (``geofence.fence.file``) are relative to.

    ``base_dir`` if given; else the folder of ``source``; else, when ``where`` (the label of a
    document read from a file, as batches and sweeps pass it) names an existing file, its folder;
    else None (relative paths then resolve against the working directory).
    """
    if base_dir is not None:
        return Path(base_dir)
    if source is not None:
        return Path(source).parent
    try:
        return Path(where).parent if where and Path(where).is_file() else None
    except (OSError, ValueError):
        return None


def referenced_files(document: Any, base_dir: Path | str | None) -> list[Path]:
    """The files a scenario document reads besides itself (a ``profile:`` file, its ``geofence.fence.file``),
    resolved; [] if none.

    For content hashes (:func:`scenarios.app.batch.plan`): editing such a file changes the flight.
    """
    if not isinstance(document, dict):
        return []
    found = []
    if isinstance(document.get("profile"), str) and document["profile"].strip():
        found.append(profile_file_path(document["profile"], base_dir))
    geofence = document.get("geofence")
    fence = geofence.get("fence") if isinstance(geofence, dict) else None
    if isinstance(fence, dict) and isinstance(fence.get("file"), str) and fence["file"].strip():
        found.append(fence_file_path(fence["file"], "geofence.fence", base_dir))
    return found


def profile_file_path(file: str, base_dir: Path | str | None) -> Path:
    """A ``profile:`` file's path: as given if absolute, else relative to ``base_dir`` (the scenario's folder)."""
    path = Path(file).expanduser()
    return path if path.is_absolute() or base_dir is None else Path(base_dir) / path


def parse_scenario(
    raw: Any, where: str, default_name: str = "scenario", source: Path | None = None, base_dir: Path | str | None = None
) -> Scenario:
    """Validate an already-parsed YAML document (see :func:`load_scenario`).

    ``base_dir``: where a relative ``geofence.fence.file`` is looked for (see :func:`scenario_base_dir`:
    by default the folder of ``source``, or of ``where`` when that names the scenario file).
    """
    if raw is None:
        raise ConfigError(f"{where}: the file is empty")
    require_mapping(raw, f"{where}: (top level)")
    reject_unknown_keys(raw, _TOP_KEYS, f"{where}: (top level)")
    for key in ("aircraft", "start", "duration_s"):
        if key not in raw:
            raise ConfigError(f"{where}: {key}: missing (required)")

    aircraft = string(raw["aircraft"], f"{where}: aircraft")
    profile = _parse_aircraft_profile(aircraft, raw.get("profile"), where, scenario_base_dir(where, source, base_dir))

    duration_s = number(raw["duration_s"], f"{where}: duration_s", strictly_positive=True, maximum=24 * 3600)
    seed = integer(raw.get("seed", 0), f"{where}: seed", minimum=0)
    rate = number(
        raw.get("control_rate_hz", field_default(Scenario, "control_rate_hz")),
        f"{where}: control_rate_hz",
        minimum=1.0,
        maximum=120.0,
    )
    name = string(raw.get("name", default_name), f"{where}: name")
    _check_name(name, f"{where}: name")

    allow = _parse_allow(raw.get("allow"), f"{where}: allow")
    start = _parse_start(raw["start"], f"{where}: start")
    _check_latitude(start.lat_deg, f"{where}: start.lat_deg")
    mission = _parse_mission(raw["mission"], f"{where}: mission") if raw.get("mission") is not None else None
    for i, item in enumerate(mission.items if mission is not None else ()):
        if item.lat_deg is not None:
            _check_latitude(item.lat_deg, f"{where}: mission.items[{i}].lat_deg")
    pilot = _parse_pilot(raw.get("pilot"), f"{where}: pilot", mission is not None, profile, start)

    wind = parse_wind(raw["wind"], f"{where}: wind") if raw.get("wind") is not None else None
    sensors = parse_sensors(raw.get("sensors"), f"{where}: sensors")
    faults = parse_faults(raw.get("faults"), f"{where}: faults", profile.kind, duration_s, raw.get("geofence") is not None)

    warnings: list[str] = []
    _check_profile_fits(profile, where, warnings)
    _check_wind(wind, profile, aircraft, where, allow, warnings)
    geofence = None
    if raw.get("geofence") is not None:
        geofence = _parse_geofence_block(
            raw["geofence"], f"{where}: geofence", start, profile, wind, scenario_base_dir(where, source, base_dir)
        )
        _check_fence_at_site(geofence, start, profile, wind, f"{where}: geofence", allow, warnings)
        _check_inside_fence(geofence, start, mission if pilot.kind is PilotKind.MISSION else None, where, allow, warnings)

    return Scenario(
        name=name,
        source=source,
        aircraft=aircraft,
        profile=profile,
        start=start,
        duration_s=duration_s,
        seed=seed,
        pilot=pilot,
        mission=mission,
        wind=wind,
        control_rate_hz=rate,
        geofence=geofence,
        description=str(raw.get("description", field_default(Scenario, "description"))),
        sensors=sensors,
        allow=allow,
        warnings=tuple(warnings),
        faults=faults,
    )


MAX_NAME_BYTES = 200
"""A scenario (flight) name is a folder name: at most 255 bytes on common file systems, less the room the
flight's temporary folder (``.<name>.<random>.tmp``) takes."""


def _check_name(name: str, where: str) -> None:
    """A name usable as one folder name: no slashes, no leading dot, no control character, not too long."""
    if any(c in name for c in "/\\") or name.startswith("."):
        raise ConfigError(f"{where}: {name!r} must be usable as a folder name (no slashes, no leading dot)")
    if any(ord(c) < 32 or ord(c) == 127 for c in name):
        raise ConfigError(f"{where}: {name!r} must be usable as a folder name (no control characters such as NUL)")
    n_bytes = len(name.encode("utf-8", "surrogatepass"))
    if n_bytes > MAX_NAME_BYTES:
        raise ConfigError(f"{where}: must be at most {MAX_NAME_BYTES} bytes (it names a folder), got {n_bytes}")


def _parse_allow(raw: Any, where: str) -> frozenset[str]:
    if raw is None:
        return frozenset()
    if not isinstance(raw, list):
        raise ConfigError(f"{where}: expected a list of {', '.join(ALLOWABLE)}")
    return frozenset(string(x, f"{where}[{i}]", choices=list(ALLOWABLE)) for i, x in enumerate(raw))


def _inconsistent(message: str, key: str, allow: frozenset[str], warnings: list[str]) -> None:
    """An error, unless the scenario allows ``key``: then a warning."""
    if key in allow:
        warnings.append(f"{message} (allowed by allow: {key})")
    else:
        raise ConfigError(f"{message}; fix it, or add 'allow: [{key}]' to fly it on purpose")


def _check_latitude(lat: float, where: str) -> None:
    if abs(lat) > POLE_LIMIT_DEG:
        raise ConfigError(
            f"{where}: {lat:g} deg is within {(90.0 - abs(lat)) * 111.0:.0f} km of the pole; the testbed's local frame and "
            f"mission geometry are only valid up to +/-{POLE_LIMIT_DEG:g} deg latitude"
        )


def _check_wind(
    wind: WindConfig | None, profile: PlatformProfile, aircraft: str, where: str, allow: frozenset[str], warnings: list[str]
) -> None:
    """A mean wind at or above what the platform can fly against (multirotor: max speed; fixed-wing: cruise)."""
    if wind is None:
        return
    env = profile.envelope
    limit, what = (env.max_speed_mps, "max speed") if env.is_multirotor else (env.cruise_speed_mps, "cruise airspeed")
    if wind.speed_mps >= limit:
        _inconsistent(
            f"{where}: wind.speed_mps: a mean wind of {wind.speed_mps:g} m/s is at or above the {what} of the {aircraft} "
            f"({limit:g} m/s): it cannot fly against it and would be blown away",
            "wind_above_platform_speed",
            allow,
            warnings,
        )


def _check_inside_fence(
    cfg: GeofenceConfig, start: StartConfig, mission: MissionConfig | None, where: str, allow: frozenset[str], warnings: list[str]
) -> None:
    """The start and the mission's items inside the geofence's allowed area (laterally, and below an AGL ceiling)."""
    local = cfg.fence.to_local(start.frame)
    agl_ceiling = local.ceiling_m if local.altitude_reference is AltitudeReference.AGL else None

    def outside(lat: float | None, lon: float | None, agl: float | None, radius: float = 0.0) -> str | None:
        if lat is not None and lon is not None:
            e, n = local.horizontal_en(lat, lon)
            margin, feature, index, *_ = local.lateral_nearest(e, n)
            if margin < radius:
                place = "the keep-in" if feature == "keep_in" else f"{feature.replace('_', '-')} {index}"
                if margin >= 0.0:
                    return f"its {radius:g} m loiter circle crosses {place} ({margin:.0f} m from the boundary)"
                return f"{-margin:.0f} m outside the keep-in" if feature == "keep_in" else f"{-margin:.0f} m inside {place}"
        if agl is not None and agl_ceiling is not None and agl > agl_ceiling:
            return f"{agl:g} m AGL is above the ceiling ({agl_ceiling:g} m AGL)"
        return None

    problem = outside(start.lat_deg, start.lon_deg, start.agl_m)
    if problem:
        _inconsistent(
            f"{where}: start: the start ({start.lat_deg:.6f}, {start.lon_deg:.6f}) is {problem} of the geofence",
            "start_outside_fence",
            allow,
            warnings,
        )
    for i, item in enumerate(mission.items if mission is not None else ()):
        problem = outside(item.lat_deg, item.lon_deg, item.agl_m, item.radius_m if item.kind == "loiter" else 0.0)
        if problem:
            _inconsistent(
                f"{where}: mission.items[{i}]: this {item.kind} is {problem} of the geofence: the mission cannot be "
                f"flown to the end",
                "mission_outside_fence",
                allow,
                warnings,
            )


def _check_profile_fits(profile: PlatformProfile, where: str, warnings: list[str]) -> None:
    """A warning (not an error: a user may fly a borrowed profile on purpose) when the profile's figures were
    measured on another model than the one flown, e.g. ``aircraft: pa28`` with ``profile: {base: c172x}``: the
    unit's margins and the flight controller's gains then rest on another aircraft's numbers."""
    if profile.measured_on is not None and profile.measured_on != profile.model:
        warnings.append(
            f"{where}: profile: its envelope and gains were measured on {profile.measured_on}, not on {profile.model}: "
            f"the margins and the controller's gains rest on another aircraft (geofence-testbed characterize "
            f"{profile.model} measures them)"
        )


def _parse_aircraft_profile(aircraft: str, inline: Any, where: str, base_dir: Path | None) -> PlatformProfile:
    """The shipped profile of ``aircraft``, an inline ``profile:`` block, or a ``profile:`` file (the format of
    ``aircraft/profiles/*.yaml``, e.g. written by ``characterize``) for any JSBSim model with standard controls."""
    try:
        model_folder(aircraft)
    except UnknownAircraftError:
        raise ConfigError(
            f"{where}: aircraft: unknown aircraft {aircraft!r} (flyable with a shipped profile: {', '.join(available_profiles())})"
        ) from None
    if isinstance(inline, str):
        if not inline.strip():
            raise ConfigError(f"{where}: profile: an empty file name")
        path = profile_file_path(inline, base_dir)
        if not path.is_file():
            raise ConfigError(f"{where}: profile: {path}: no such profile file (a relative one is in the scenario's folder)")
        raw = read_document(path, "profile file")
        return parse_profile(raw, aircraft, str(path))
    if inline is not None:
        return parse_profile(inline, aircraft, f"{where}: profile")
    if aircraft not in available_profiles():
        raise ConfigError(
            f"{where}: aircraft: {aircraft!r} is a JSBSim model without a shipped profile; add a profile: block "
            f"(kind, envelope, gains; or base: <model>) or use one of {', '.join(available_profiles())}"
        )
    return load_profile(aircraft)


def _parse_geofence_block(
    raw: Any, where: str, start: StartConfig, profile: PlatformProfile, wind: WindConfig | None, base_dir: Path | None = None
) -> GeofenceConfig:
    """Validate the geofence block, and check that its activation boundary exists for this platform and wind."""
    try:
        cfg = parse_geofence(raw, where, fence_file_reader=partial(fence_from_file, base_dir=base_dir))
        f = cfg.fence
        for name, polys in (("keep_in", (f.keep_in,)), ("floor_gaps", f.floor_gaps), ("keep_out_polygons", f.keep_out_polygons)):
            for poly in polys:
                for lat, _ in poly:
                    _check_latitude(lat, f"{where}.fence.{name}")
        for c in f.keep_out_circles:
            _check_latitude(c.center_lat_deg, f"{where}.fence.keep_out_circles")
        frame = start.frame
        wind_speed = wind.speed_mps if wind is not None else 0.0
        check_shift_feasible(cfg.fence.to_local(frame), profile.envelope, wind_speed)
    except FenceError as exc:  # from the checks above, which name no block
        msg = str(exc)
        raise FenceError(msg if msg.startswith(where) else f"{where}.fence: {msg}") from None
    return cfg


def _check_fence_at_site(
    cfg: GeofenceConfig,
    start: StartConfig,
    profile: PlatformProfile,
    wind: WindConfig | None,
    where: str,
    allow: frozenset[str],
    warnings: list[str],
) -> None:
    """Judge the fence with the envelope the platform has at the site's air density, not at sea level.

    Profiles are measured low; at a high site a fixed-wing flies the same indicated speeds at a higher true
    airspeed, so its turn radius grows by ``1/sigma``. A fence that fits the sea-level turn but not the site's
    is refused with the numbers, unless ``allow: [fence_too_small_at_site]`` (then it flies, with a warning).
    """
    sigma = start.density_ratio
    if sigma >= 1.0:
        return
    env = envelope_at_density(profile.envelope, sigma)
    wind_speed = wind.speed_mps if wind is not None else 0.0
    try:
        check_shift_feasible(cfg.fence.to_local(start.frame), env, wind_speed)
    except FenceError as exc:
        msg = f"{where}.fence: at the site's air density (ISA sigma {sigma:.2f} at {start.altitude_m:,.0f} m) the {exc}"
        if "fence_too_small_at_site" not in allow:
            raise FenceError(f"{msg}; list fence_too_small_at_site under allow: to fly it anyway") from None
        warnings.append(f"allowed: {msg}")


def _parse_start(raw: Any, where: str) -> StartConfig:
    require_mapping(raw, where)
    reject_unknown_keys(raw, {"lat_deg", "lon_deg", "ground_alt_m", "agl_m", "heading_deg", "airspeed_mps"}, where)
    for key in ("lat_deg", "lon_deg"):
        if key not in raw:
            raise ConfigError(f"{where}.{key}: missing (required)")

    def num(key: str, lo: float, hi: float) -> float:
        return number(raw.get(key, field_default(StartConfig, key)), f"{where}.{key}", minimum=lo, maximum=hi)

    return StartConfig(
        lat_deg=latitude(raw["lat_deg"], f"{where}.lat_deg"),
        lon_deg=longitude(raw["lon_deg"], f"{where}.lon_deg"),
        ground_alt_m=num("ground_alt_m", -500.0, 9000.0),
        agl_m=num("agl_m", 0.0, 5000.0),
        heading_deg=num("heading_deg", -360.0, 360.0),
        airspeed_mps=num("airspeed_mps", 0.0, 100.0),
    )


def _parse_mission(raw: Any, where: str) -> MissionConfig:
    require_mapping(raw, where)
    reject_unknown_keys(raw, {"items", "acceptance_radius_m", "speed_mps"}, where)
    items_raw = raw.get("items")
    if not isinstance(items_raw, list) or not items_raw:
        raise ConfigError(f"{where}.items: expected a non-empty list of mission items")
    items = tuple(_parse_item(item, f"{where}.items[{i}]") for i, item in enumerate(items_raw))
    for i, item in enumerate(items):
        if item.kind == "land" and i != len(items) - 1:
            raise ConfigError(f"{where}.items[{i}]: land must be the last mission item")
        if item.kind == "takeoff" and i != 0:
            raise ConfigError(f"{where}.items[{i}]: takeoff must be the first mission item")
    speed = raw.get("speed_mps")
    return MissionConfig(
        items=items,
        acceptance_radius_m=number(
            raw.get("acceptance_radius_m", field_default(MissionConfig, "acceptance_radius_m")),
            f"{where}.acceptance_radius_m",
            strictly_positive=True,
        ),
        speed_mps=None if speed is None else number(speed, f"{where}.speed_mps", strictly_positive=True, maximum=100.0),
    )


_ITEM_KEYS = {
    "takeoff": {"agl_m"},
    "waypoint": {"lat_deg", "lon_deg", "agl_m"},
    "loiter": {"lat_deg", "lon_deg", "agl_m", "duration_s", "radius_m"},
    "land": {"lat_deg", "lon_deg"},
}


def _parse_item(raw: Any, where: str) -> MissionItem:
    require_mapping(raw, where)
    kind = string(raw.get("type"), f"{where}.type", choices=list(MISSION_ITEM_TYPES))
    reject_unknown_keys(raw, _ITEM_KEYS[kind] | {"type"}, where)
    needs = {
        "takeoff": ("agl_m",),
        "waypoint": ("lat_deg", "lon_deg", "agl_m"),
        "loiter": ("lat_deg", "lon_deg", "agl_m", "duration_s"),
        "land": (),
    }
    for key in needs[kind]:
        if key not in raw:
            raise ConfigError(f"{where}.{key}: missing (required for a {kind} item)")
    if ("lat_deg" in raw) != ("lon_deg" in raw):
        raise ConfigError(f"{where}: give both lat_deg and lon_deg, or neither")
    return MissionItem(
        kind=kind,
        lat_deg=latitude(raw["lat_deg"], f"{where}.lat_deg") if "lat_deg" in raw else None,
        lon_deg=longitude(raw["lon_deg"], f"{where}.lon_deg") if "lon_deg" in raw else None,
        agl_m=number(raw["agl_m"], f"{where}.agl_m", minimum=0.0, maximum=5000.0) if "agl_m" in raw else None,
        duration_s=number(raw.get("duration_s", field_default(MissionItem, "duration_s")), f"{where}.duration_s", minimum=0.0),
        radius_m=number(raw.get("radius_m", field_default(MissionItem, "radius_m")), f"{where}.radius_m", minimum=0.0),
    )


def _parse_pilot(raw: Any, where: str, has_mission: bool, profile: PlatformProfile, start: StartConfig) -> PilotConfig:
    if raw is None:
        if not has_mission:
            raise ConfigError(f"{where}: missing: give a mission or a pilot script")
        return PilotConfig(kind=PilotKind.MISSION)
    require_mapping(raw, where)
    kind = enum_value(raw.get("type", PilotKind.MISSION), f"{where}.type", PilotKind)
    if kind is PilotKind.BREACH_ATTEMPTS:
        return PilotConfig(
            kind=kind, breach=_parse_breach(raw, where, breach_defaults(profile, start), BREACH_SPEED_LIMIT_MPS[profile.kind])
        )
    reject_unknown_keys(raw, {"type", "segments"}, where)
    if kind is PilotKind.MISSION:
        if not has_mission:
            raise ConfigError(f"{where}.type: 'mission' needs a mission: block")
        return PilotConfig(kind=kind)
    segs = raw.get("segments")
    if not isinstance(segs, list) or not segs:
        raise ConfigError(f"{where}.segments: expected a non-empty list of script segments")
    return PilotConfig(kind=kind, segments=tuple(_parse_segment(s, f"{where}.segments[{i}]") for i, s in enumerate(segs)))


BREACH_SPEED_LIMIT_MPS = {PlatformKind.MULTIROTOR: 30.0, PlatformKind.FIXED_WING: 100.0}
"""The largest ``speed_mps`` a scenario may give (m/s), per platform kind (a fixed-wing pilot clips its
airspeed to the envelope; a vertical push is capped at the climb or descent rate)."""


def _parse_breach(raw: Any, where: str, d: BreachAttemptsConfig, speed_limit_mps: float) -> BreachAttemptsConfig:
    """The ``breach_attempts`` pilot's settings; ``d``: the platform's defaults (:func:`breach_defaults`)."""
    reject_unknown_keys(
        raw, {"type", "attempts", "directions", "speed_mps", "push_m", "rest_s", "home_agl_m", "seed", "speed_draw"}, where
    )
    directions = raw.get("directions", list(d.directions))
    if not isinstance(directions, list) or not directions:
        raise ConfigError(
            f"{where}.directions: expected a non-empty list of {', '.join(BREACH_DIRECTION_NAMES)} or bearings in degrees"
        )
    parsed = []
    for i, x in enumerate(directions):
        at = f"{where}.directions[{i}]"
        if isinstance(x, (int, float)) and not isinstance(x, bool):
            number(x, at)  # a finite number (any bearing; normalised to [0, 360))
        elif not isinstance(x, str):
            raise ConfigError(f"{at}: expected one of {', '.join(BREACH_DIRECTION_NAMES)} or a bearing in degrees, got {x!r}")
        try:
            parsed.append(BreachDirection.of(x))
        except ValueError as exc:
            raise ConfigError(f"{at}: {exc}") from None
    speeds = raw.get("speed_mps", list(d.speed_mps))
    if not isinstance(speeds, list) or len(speeds) != 2:
        raise ConfigError(f"{where}.speed_mps: expected [low, high] in m/s")
    lo = number(speeds[0], f"{where}.speed_mps[0]", strictly_positive=True, maximum=speed_limit_mps)
    hi = number(speeds[1], f"{where}.speed_mps[1]", minimum=lo, maximum=speed_limit_mps)
    return BreachAttemptsConfig(
        attempts=integer(raw.get("attempts", d.attempts), f"{where}.attempts", minimum=1),
        directions=tuple(parsed),
        speed_mps=(lo, hi),
        push_m=number(raw.get("push_m", d.push_m), f"{where}.push_m", strictly_positive=True),
        rest_s=number(raw.get("rest_s", d.rest_s), f"{where}.rest_s", minimum=0.0),
        home_agl_m=number(raw.get("home_agl_m", d.home_agl_m), f"{where}.home_agl_m", strictly_positive=True),
        seed=integer(raw.get("seed", d.seed), f"{where}.seed", minimum=0),
        speed_draw=enum_value(raw.get("speed_draw", d.speed_draw), f"{where}.speed_draw", SpeedDraw),
    )


def _parse_segment(raw: Any, where: str) -> ScriptSegment:
    require_mapping(raw, where)
    reject_unknown_keys(raw, {"duration_s", "sticks", "course_deg", "speed", "climb", "end_on", "reach"}, where)
    if "duration_s" not in raw:
        raise ConfigError(f"{where}.duration_s: missing (required)")
    duration = number(raw["duration_s"], f"{where}.duration_s", strictly_positive=True)
    end_on = None if raw.get("end_on") is None else enum_value(raw["end_on"], f"{where}.end_on", SegmentEnd)
    reach = None
    if end_on is SegmentEnd.REACH:
        if "reach" not in raw:
            raise ConfigError(f"{where}.reach: missing (end_on: reach needs {{lat_deg, lon_deg, radius_m}})")
        r = require_mapping(raw["reach"], f"{where}.reach")
        reject_unknown_keys(r, {"lat_deg", "lon_deg", "radius_m"}, f"{where}.reach")
        for key in ("lat_deg", "lon_deg", "radius_m"):
            if key not in r:
                raise ConfigError(f"{where}.reach.{key}: missing (required)")
        reach = (
            latitude(r["lat_deg"], f"{where}.reach.lat_deg"),
            longitude(r["lon_deg"], f"{where}.reach.lon_deg"),
            number(r["radius_m"], f"{where}.reach.radius_m", strictly_positive=True),
        )
    elif "reach" in raw:
        raise ConfigError(f"{where}.reach: only with end_on: reach")
    if ("sticks" in raw) == ("course_deg" in raw):
        raise ConfigError(f"{where}: give exactly one of sticks or course_deg")
    if "sticks" in raw:
        s = require_mapping(raw["sticks"], f"{where}.sticks")
        reject_unknown_keys(s, {"roll", "pitch", "yaw", "throttle"}, f"{where}.sticks")
        sticks = tuple(
            number(s.get(k, 0.0), f"{where}.sticks.{k}", minimum=-1.0, maximum=1.0) for k in ("roll", "pitch", "yaw", "throttle")
        )
        return ScriptSegment(duration_s=duration, sticks=sticks, end_on=end_on, reach=reach)  # type: ignore[arg-type]
    return ScriptSegment(
        duration_s=duration,
        end_on=end_on,
        reach=reach,
        course_deg=number(raw["course_deg"], f"{where}.course_deg", minimum=-360.0, maximum=360.0),
        speed=string(raw.get("speed", field_default(ScriptSegment, "speed")), f"{where}.speed", choices=SCRIPT_SPEEDS),
        climb=string(raw.get("climb", field_default(ScriptSegment, "climb")), f"{where}.climb", choices=SCRIPT_CLIMBS),
    )
