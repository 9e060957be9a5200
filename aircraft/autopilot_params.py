"""Autopilot parameter files -> a platform profile's envelope (``characterize --from-params``).

Owns reading ArduPilot ``.param``/``.parm`` files (``NAME VALUE`` or ``NAME,VALUE`` lines, ``#`` comments, as
MAVProxy and Mission Planner write them) and PX4 QGroundControl ``.params`` exports (tab-separated
``vehicle-id component-id NAME VALUE type``), and the mapping of the limits they set to envelope figures. Pure:
no JSBSim; the caller supplies the base profile for the figures the parameters cannot give.

Names, units and defaults, checked against the firmware sources:

* ArduCopter: ``ANGLE_MAX`` cd (AC_AttitudeControl; ``ATC_ANGLE_MAX`` deg in newer firmware, default 30 deg);
  ``WPNAV_SPEED`` cm/s (AC_WPNav.cpp ``@Units: cm/s``, default 1000), ``WPNAV_SPEED_UP`` cm/s (250),
  ``WPNAV_SPEED_DN`` cm/s (150); ``LOIT_SPEED`` cm/s (AC_Loiter, 1250); ``PILOT_SPEED_UP``/``PILOT_SPEED_DN`` cm/s
  (``PILOT_SPEED_DN`` 0 = same as up).
* ArduPlane: ``LIM_ROLL_CD``/``LIM_PITCH_MAX`` cd (newer ``ROLL_LIMIT_DEG``/``PTCH_LIM_MAX_DEG`` deg, as in
  Tools/Frame_params/Parrot_Disco.param); ``AIRSPEED_CRUISE`` m/s (older ``TRIM_ARSPD_CM`` cm/s);
  ``AIRSPEED_MIN``/``AIRSPEED_MAX`` m/s (older ``ARSPD_FBW_MIN``/``ARSPD_FBW_MAX``); ``TECS_CLMB_MAX``,
  ``TECS_SINK_MAX`` m/s (Tools/autotest/default_params/plane-jet.parm).
* PX4 multicopter (mc_pos_control params): ``MPC_TILTMAX_AIR`` deg, ``MPC_XY_CRUISE``, ``MPC_XY_VEL_MAX`` m/s,
  ``MPC_Z_VEL_MAX_UP`` m/s (default 3), ``MPC_Z_VEL_MAX_DN`` m/s (default 1), ``MPC_ACC_HOR_MAX`` m/s^2,
  ``MPC_YAWRAUTO_MAX`` deg/s.
* PX4 fixed-wing: ``FW_R_LIM``, ``FW_P_LIM_MAX`` deg; ``FW_AIRSPD_TRIM``/``_MIN``/``_MAX`` m/s;
  ``FW_T_CLMB_MAX`` (``FW_T_CLIMB_MAX`` in newer releases, LongitudinalControlConfiguration), ``FW_T_SINK_MAX`` m/s.

ArduPilot's ``ATC_ACCEL_*_MAX`` (cd/s^2, attitude-rate slew) and ``LOIT_BRK_ACCEL`` (a braking *setting*, not
the airframe's ability) are not mapped: they do not state the envelope's figures honestly. See docs/characterize.md.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

from aircraft.profile import ENVELOPE_BOUNDS, PlatformProfile
from geofence.interface import PlatformKind
from geofence.validation import ConfigError

MAX_FILE_BYTES = 5 * 1024 * 1024
MAX_LINE_CHARS = 4096
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,63}$")


class Firmware(str, Enum):
    ARDUPILOT = "ardupilot"
    PX4 = "px4"


@dataclass(frozen=True)
class ParamFile:
    firmware: Firmware
    values: dict[str, float]


@dataclass(frozen=True)
class Source:
    """One envelope key and the parameters that may give it, first found wins: ``(name, scale to file units)``."""

    key: str
    params: tuple[tuple[str, float], ...]


_MR_ARDU = (
    Source("max_bank_deg", (("ANGLE_MAX", 0.01), ("ATC_ANGLE_MAX", 1.0))),
    Source("max_pitch_deg", (("ANGLE_MAX", 0.01), ("ATC_ANGLE_MAX", 1.0))),
    Source("cruise_speed_mps", (("WPNAV_SPEED", 0.01),)),
    Source("max_speed_mps", (("LOIT_SPEED", 0.01),)),
    Source("max_climb_rate_mps", (("PILOT_SPEED_UP", 0.01), ("WPNAV_SPEED_UP", 0.01))),
    Source("max_descent_rate_mps", (("PILOT_SPEED_DN", 0.01), ("WPNAV_SPEED_DN", 0.01))),
)
_MR_PX4 = (
    Source("max_bank_deg", (("MPC_TILTMAX_AIR", 1.0),)),
    Source("max_pitch_deg", (("MPC_TILTMAX_AIR", 1.0),)),
    Source("cruise_speed_mps", (("MPC_XY_CRUISE", 1.0),)),
    Source("max_speed_mps", (("MPC_XY_VEL_MAX", 1.0),)),
    Source("max_climb_rate_mps", (("MPC_Z_VEL_MAX_UP", 1.0),)),
    Source("max_descent_rate_mps", (("MPC_Z_VEL_MAX_DN", 1.0),)),
    Source("braking_decel_mps2", (("MPC_ACC_HOR_MAX", 1.0),)),
    Source("max_yaw_rate_deg_s", (("MPC_YAWRAUTO_MAX", 1.0),)),
)
_FW_ARDU = (
    Source("max_bank_deg", (("ROLL_LIMIT_DEG", 1.0), ("LIM_ROLL_CD", 0.01))),
    Source("max_pitch_deg", (("PTCH_LIM_MAX_DEG", 1.0), ("LIM_PITCH_MAX", 0.01))),
    Source("cruise_speed_mps", (("AIRSPEED_CRUISE", 1.0), ("TRIM_ARSPD_CM", 0.01))),
    Source("min_speed_mps", (("AIRSPEED_MIN", 1.0), ("ARSPD_FBW_MIN", 1.0))),
    Source("max_speed_mps", (("AIRSPEED_MAX", 1.0), ("ARSPD_FBW_MAX", 1.0))),
    Source("max_climb_rate_mps", (("TECS_CLMB_MAX", 1.0),)),
    Source("max_descent_rate_mps", (("TECS_SINK_MAX", 1.0),)),
)
_FW_PX4 = (
    Source("max_bank_deg", (("FW_R_LIM", 1.0),)),
    Source("max_pitch_deg", (("FW_P_LIM_MAX", 1.0),)),
    Source("cruise_speed_mps", (("FW_AIRSPD_TRIM", 1.0),)),
    Source("min_speed_mps", (("FW_AIRSPD_MIN", 1.0),)),
    Source("max_speed_mps", (("FW_AIRSPD_MAX", 1.0),)),
    Source("max_climb_rate_mps", (("FW_T_CLMB_MAX", 1.0), ("FW_T_CLIMB_MAX", 1.0))),
    Source("max_descent_rate_mps", (("FW_T_SINK_MAX", 1.0),)),
)
SOURCES = {
    (PlatformKind.MULTIROTOR, Firmware.ARDUPILOT): _MR_ARDU,
    (PlatformKind.MULTIROTOR, Firmware.PX4): _MR_PX4,
    (PlatformKind.FIXED_WING, Firmware.ARDUPILOT): _FW_ARDU,
    (PlatformKind.FIXED_WING, Firmware.PX4): _FW_PX4,
}
"""Per (kind, firmware): the envelope keys (profile-file units: deg, m/s, m/s^2) the parameters give."""


def read_param_file(path: Path) -> ParamFile:
    """Read a parameter file (bounded: :data:`MAX_FILE_BYTES`), or one :class:`ConfigError` line."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if len(data) > MAX_FILE_BYTES:
        raise ConfigError(f"{path}: larger than {MAX_FILE_BYTES // (1024 * 1024)} MB; not a parameter file")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not text (not UTF-8); give an ArduPilot .param or PX4 .params file") from None
    return parse_param_text(text, str(path))


def _parse_line(line: str) -> tuple[Firmware, str, str] | None:
    """One data line as ``(firmware, name, value text)``, or None if its shape is neither format's."""
    fields = line.split("\t") if "\t" in line.strip() else None
    if (
        fields is not None
        and len(fields) == 5
        and all(f.strip().lstrip("-").isdigit() for f in (fields[0], fields[1], fields[4]))
    ):
        return Firmware.PX4, fields[2].strip(), fields[3].strip()
    parts = line.split(",") if "," in line else line.split()
    if len(parts) == 2:
        return Firmware.ARDUPILOT, parts[0].strip(), parts[1].strip()
    return None


def parse_param_text(text: str, where: str) -> ParamFile:
    """Parse a parameter file's text; every malformed line is one :class:`ConfigError` naming it."""
    values: dict[str, float] = {}
    firmware = None
    for n, raw in enumerate(text.splitlines(), start=1):
        if len(raw) > MAX_LINE_CHARS:
            raise ConfigError(f"{where}: line {n}: longer than {MAX_LINE_CHARS} characters; not a parameter line")
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parsed = _parse_line(line)
        if parsed is None or not _NAME.match(parsed[1]):
            raise ConfigError(f"{where}: line {n}: not 'NAME VALUE', 'NAME,VALUE' or a PX4 tab-separated line: {line[:60]!r}")
        fw, name, value_text = parsed
        if firmware is not None and fw is not firmware:
            raise ConfigError(f"{where}: line {n}: {name}: a {fw.value} line in a {firmware.value} file")
        firmware = fw
        try:
            value = float(value_text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise ConfigError(f"{where}: {name}: not a finite number: {value_text[:40]!r}")
        if name in values and values[name] != value:
            raise ConfigError(f"{where}: {name}: given twice with different values ({values[name]:g}, {value:g})")
        values[name] = value
    if firmware is None:
        raise ConfigError(f"{where}: no parameters in the file")
    return ParamFile(firmware=firmware, values=values)


@dataclass(frozen=True)
class Derived:
    """An envelope figure (profile-file units) and the parameter it came from."""

    value: float
    param: str


def derive_envelope(params: ParamFile, kind: PlatformKind, where: str) -> dict[str, Derived]:
    """The envelope figures the parameters give (keys as in a profile file), checked against the envelope's
    bounds and ``min <= cruise <= max`` speed; refused with one line naming the parameter."""
    found: dict[str, Derived] = {}
    for src in SOURCES[(kind, params.firmware)]:
        for name, scale in src.params:
            if name in params.values:
                found[src.key] = Derived(params.values[name] * scale, name)
                break
    dn = found.get("max_descent_rate_mps")
    if dn is not None and dn.param == "PILOT_SPEED_DN" and dn.value == 0.0 and "max_climb_rate_mps" in found:
        found["max_descent_rate_mps"] = Derived(found["max_climb_rate_mps"].value, "PILOT_SPEED_DN=0 (same as up)")
    if not found:
        names = sorted({n for s in SOURCES[(kind, params.firmware)] for n, _ in s.params})
        raise ConfigError(f"{where}: none of the {params.firmware.value} {kind.value} limits is in the file ({', '.join(names)})")
    for key, d in found.items():
        low, high, open_low = ENVELOPE_BOUNDS[key]
        if not (low < d.value if open_low else low <= d.value) or d.value > high:
            rel = ">" if open_low else ">="
            raise ConfigError(f"{where}: {d.param}: gives {key} = {d.value:g}, must be {rel} {low:g} and <= {high:g}")
    return found


def check_speed_order(env: dict[str, float], found: dict[str, Derived], where: str) -> None:
    """``min <= cruise <= max`` over the merged envelope; the message names the parameter at fault."""
    for low, high in (("min_speed_mps", "cruise_speed_mps"), ("cruise_speed_mps", "max_speed_mps")):
        if env[low] > env[high]:
            key = low if low in found else high  # the base profile's own speeds are in order: one was derived
            other = high if key == low else low
            bad = found[key]
            rel = "<=" if key == low else ">="
            raise ConfigError(f"{where}: {bad.param}: gives {key} = {env[key]:g} m/s, must be {rel} {other} ({env[other]:g} m/s)")


def base_envelope_values(base: PlatformProfile) -> dict[str, float]:
    """The base profile's envelope in profile-file units (deg, m/s)."""
    e = base.envelope
    deg = 180.0 / math.pi
    out = {}
    for key in ENVELOPE_BOUNDS:
        name = key.replace("_deg_s", "_radps").replace("_deg", "_rad")
        out[key] = getattr(e, name) * (deg if "_deg" in key else 1.0)
    return out
