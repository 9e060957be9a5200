"""Read a real flight log (MAVLink ``.tlog``, ArduPilot DataFlash ``.bin``, PX4 ULog ``.ulg``) into trajectory columns.

The columns match :mod:`scenarios.flight.recorder` where the log has the data, so
:func:`analysis.scoring.score_flight` works on them unchanged:

``time_s``
    seconds since the log's first message (the log's own time axis: the
    ground station's receive time for a tlog, the autopilot clock mapped to
    GPS time by pymavlink for a DataFlash log); ``unix_time_s`` is the
    absolute time.
``lat_deg``, ``lon_deg``, ``alt_m``
    WGS-84 position, altitude above mean sea level as the autopilot reports it.
``agl_m``
    height above home: GLOBAL_POSITION_INT ``relative_alt``; DataFlash
    ``POS.RelHomeAlt`` (interpolated to the GPS samples); ULog ``alt`` minus
    ``home_position.alt``. With neither
    (GPS_RAW_INT fallback, a .bin without POS) it is ``alt_m`` minus the first
    sample's ``alt_m`` and ``LogInfo.agl_source`` says so.
``east_m``, ``north_m``, ``up_m``
    ENU about ``frame`` (default: the first valid fix at its altitude).
    ``east_m``/``north_m`` are the lat/lon projected at the frame's height (as
    :meth:`geofence.geometry.local_fence.LocalFence.horizontal_en` recommends for fence
    margins); ``up_m`` is the full ENU up.
``v_east_mps``, ``v_north_mps``, ``v_up_mps``, ``ground_speed_mps``
    GLOBAL_POSITION_INT ``vy``/``vx``/``-vz``; GPS_RAW_INT and DataFlash GPS
    ``vel``/``Spd`` along ``cog``/``GCrs`` (``v_up`` from ``-VZ`` in a .bin,
    from differentiating ``alt_m`` for GPS_RAW_INT); DataFlash POS from
    differentiating the ENU position.
``mode``
    flight-mode name at each sample (numpy ``str`` array; ``"UNKNOWN"`` before
    the first vehicle HEARTBEAT / MODE message).

Samples with no fix (GPS status < 3D), a (0, 0) position or out-of-range
coordinates are skipped, and so are samples whose time repeats the previous
one (a duplicated packet).

Sanity checks (:class:`LogInfo` ``warnings`` says what was dropped, in
samples and seconds; :class:`LogIntegrityError` refuses a log beyond the
limits of :class:`SanityLimits`):

* **CRC**: tlog messages that fail their MAVLink CRC (pymavlink ``BAD_DATA``)
  and DataFlash bytes the parser had to skip are counted.
* **time**: message times outside a plausible range (2000-01-01 .. now + 2
  days for a wall-clock/GPS time axis, 0 .. 10^7 s for a time-since-boot
  axis) are faults, and so are backward jumps and isolated forward spikes:
  the log keeps the longest non-decreasing run of message times and every
  other message is a time fault (a single 6e10 s timestamp no longer hides
  the rest of the flight).
* **position**: a fix that would need a horizontal or vertical speed above
  ``max_speed_mps`` (150 m/s: no small aircraft flies that) from the last
  accepted fix is a glitch; the filter runs outwards from the sample nearest
  the median position, so a glitch at the start cannot poison the rest.
* **truncation**: bytes after the last complete message are reported.
* pymavlink's own prints on garbage are captured, never shown.

:func:`check_near_fence` refuses a log whose median position is far from a
fence (a wrong fence file). A tlog carrying several vehicles keeps the system id
that sent the most position messages.

A ULog is read with pyulog: ``vehicle_global_position`` (the estimator's
lat/lon/alt AMSL; velocities by differentiation), else ``vehicle_gps_position``
(the receiver's fixes with ``fix_type`` >= 3 and its NED velocity); the time
axis is the log's microseconds since boot; ``mode`` is ``vehicle_status.nav_state``.

pymavlink is used for decoding (``mavutil.mavlink_connection(path,
dialect="ardupilotmega")``); messages are read once, row by row, into
lists, and every derived column is computed vectorized with numpy.
"""

from __future__ import annotations

import bisect
import collections
import contextlib
import io
import math
import os
import re
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from geofence.geometry.geodesy import LocalFrame
from geofence.validation import ConfigError

TRAJECTORY_COLUMNS = (
    "time_s",
    "unix_time_s",
    "lat_deg",
    "lon_deg",
    "alt_m",
    "agl_m",
    "east_m",
    "north_m",
    "up_m",
    "v_east_mps",
    "v_north_mps",
    "v_up_mps",
    "ground_speed_mps",
    "mode",
)


class LogError(ConfigError):
    """A log that cannot be read or holds no usable position: one line naming the file."""


class LogIntegrityError(LogError):
    """A log refused because too much of it is corrupt (CRC failures, time faults, position glitches)."""


class LogFenceDistanceError(LogError):
    """A log whose positions are far from the fence it is scored against (a wrong fence file?)."""


@dataclass(frozen=True)
class SanityLimits:
    """Bounds of the sanity checks; a log beyond a ``max_*_fraction`` is refused."""

    max_speed_mps: float = 150.0  # faster than any small aircraft: a position glitch
    max_bad_fraction: float = 0.05  # CRC failures / skipped chunks per decoded message
    max_time_fault_fraction: float = 0.05  # messages with an implausible or out-of-order time
    max_dropped_fraction: float = 0.2  # position samples dropped for time faults or glitches
    future_slack_s: float = 2 * 86400.0  # a wall-clock time this far past "now" is absurd
    max_boot_time_s: float = 1.0e7  # a time-since-boot axis beyond this (115 days) is absurd
    time_tolerance_s: float = 0.5  # a step back this small is jitter, not a fault


EPOCH_2000_S = 946684800.0


@dataclass
class LogInfo:
    """What a log is: for a report next to its scores."""

    path: str
    log_format: str  # "tlog", "dataflash" or "ulog"
    vehicle_type: str  # e.g. "FIXED_WING", "QUADROTOR" ("UNKNOWN" if not stated)
    autopilot: str  # e.g. "ARDUPILOTMEGA", or the firmware string of a .bin
    position_source: str  # message type the trajectory came from
    agl_source: str  # where agl_m came from
    n_positions: int  # samples kept
    n_skipped: int  # position messages skipped (no fix, zero coordinates, repeated time)
    start_unix_s: float  # first message
    end_unix_s: float  # last message
    duration_s: float  # end - start
    position_span_s: tuple[float, float]  # (first, last) kept sample, in time_s
    message_counts: dict[str, int] = field(default_factory=dict)
    modes: tuple[str, ...] = ()  # the mode sequence over the kept samples (consecutive repeats merged)
    simulated: bool = False  # a SITL log (SIMSTATE/SIM messages present)
    frame: LocalFrame | None = None  # the ENU frame of east/north/up
    n_bad_crc: int = 0  # tlog messages failing their CRC; DataFlash corrupt chunks skipped
    bad_bytes: int = 0  # bytes in those
    n_time_faults: int = 0  # messages with an implausible or out-of-order time
    n_position_time_faults: int = 0  # position samples among them (dropped)
    n_glitches: int = 0  # position samples dropped as implausible jumps
    dropped_s: float = 0.0  # seconds of the position time line the dropped samples fell in
    truncated_bytes: int = 0  # bytes after the last complete message
    warnings: tuple[str, ...] = ()  # one line each; what was dropped or looks wrong


def read_log(path: str | Path, frame: LocalFrame | None = None, limits: SanityLimits | None = None) -> dict[str, np.ndarray]:
    """Trajectory columns of a ``.tlog`` or DataFlash ``.bin`` (see the module docstring)."""
    return load_log(path, frame, limits)[0]


def load_log(
    path: str | Path, frame: LocalFrame | None = None, limits: SanityLimits | None = None
) -> tuple[dict[str, np.ndarray], LogInfo]:
    """``(trajectory columns, LogInfo)`` of one log, read in one pass.

    Raises :class:`LogError` (one line naming the file) for a log that cannot
    be read, :class:`LogIntegrityError` for one beyond ``limits``.
    """
    p = Path(path)
    name = str(path)
    limits = limits or SanityLimits()
    if not p.is_file():
        raise LogError(f"{name}: file not found")
    with open(p, "rb") as fh:
        head = fh.read(3)
    is_dataflash = head == b"\xa3\x95\x80"  # DataFlash binary: HEAD1, HEAD2, FMT id 128
    if head == b"ULo" or p.suffix.lower() == ".ulg":
        return _read_ulog(p, name, frame, limits)
    if not is_dataflash and p.suffix.lower() == ".bin":
        raise LogError(f"{name}: not a DataFlash log (it does not start with the DataFlash header A3 95 80)")
    # pymavlink prints to stdout/stderr on garbage (thousands of lines): keep it, count it, never show it
    with _silenced() as noise:
        if is_dataflash:
            return _read_dataflash(p, name, frame, limits, noise)
        return _read_tlog(p, name, frame, limits, noise)


@contextlib.contextmanager
def _silenced():
    """Capture everything printed meanwhile: Python-level prints and, at the file-descriptor level, the
    output of pymavlink's compiled DataFlash indexer. Yields the Python-level text (a StringIO)."""
    buf = io.StringIO()
    saved: list[tuple[int, int]] = []
    with tempfile.TemporaryFile() as tmp:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:  # pragma: no cover - a closed or odd stream
                pass
        try:
            for fd in (1, 2):
                try:
                    saved.append((fd, os.dup(fd)))
                    os.dup2(tmp.fileno(), fd)
                except OSError:  # pragma: no cover - no such descriptor
                    pass
            with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
                yield buf
        finally:
            try:  # C stdio buffers must reach the temporary file, not the restored terminal
                import ctypes

                ctypes.CDLL(None).fflush(None)
            except Exception:  # pragma: no cover - no libc
                pass
            for fd, old in saved:
                os.dup2(old, fd)
                os.close(old)


# --------------------------------------------------------------------------- tlog
def _connection(p: Path, name: str):
    from pymavlink import mavutil

    try:
        return mavutil, mavutil.mavlink_connection(str(p), dialect="ardupilotmega")
    except Exception as exc:  # pymavlink raises many types on garbage
        raise LogError(f"{name}: pymavlink cannot open it ({type(exc).__name__}: {exc})") from None


def _enum_name(mavutil, enum: str, value: int, prefix: str) -> str:
    e = mavutil.mavlink.enums.get(enum, {}).get(value)
    return e.name[len(prefix) :] if e is not None and e.name.startswith(prefix) else f"{value}"


def _messages(m, name: str, counts: collections.Counter):
    """Every message of a pymavlink connection, counted by type; decoding errors become a LogError."""
    while True:
        try:
            msg = m.recv_match()
        except Exception as exc:
            raise LogError(
                f"{name}: decoding failed after {sum(counts.values())} messages ({type(exc).__name__}: {exc})"
            ) from None
        if msg is None:
            return
        counts[msg.get_type()] += 1
        yield msg


def _read_tlog(p: Path, name: str, frame: LocalFrame | None, limits: SanityLimits, noise: io.StringIO):
    mavutil, m = _connection(p, name)
    counts: collections.Counter = collections.Counter()
    gpi: dict[int, list] = collections.defaultdict(list)
    gps: dict[int, list] = collections.defaultdict(list)
    vehicle = None
    times: list[float] = []
    bad, bad_bytes, end_ofs = 0, 0, 0
    simulated = False
    gcs = mavutil.mavlink.MAV_TYPE_GCS
    for msg in _messages(m, name, counts):
        t = msg.get_type()
        if t == "BAD_DATA":
            if "CRC" in str(getattr(msg, "reason", "")) or len(getattr(msg, "data", b"")) > 1:
                bad += 1
            bad_bytes += len(getattr(msg, "data", b""))
            continue
        end_ofs = m.f.tell()
        ts = msg._timestamp
        k = len(times)
        times.append(ts)
        if t == "GLOBAL_POSITION_INT":
            gpi[msg.get_srcSystem()].append(
                (k, msg.lat, msg.lon, msg.alt, msg.relative_alt, msg.vx, msg.vy, msg.vz, msg.time_boot_ms * 1e-3, m.flightmode)
            )
        elif t == "GPS_RAW_INT":
            gps[msg.get_srcSystem()].append(
                (k, msg.lat, msg.lon, msg.alt, msg.fix_type, msg.vel, msg.cog, msg.time_usec * 1e-6, m.flightmode)
            )
        elif t == "HEARTBEAT" and msg.type != gcs and vehicle is None and msg.autopilot != mavutil.mavlink.MAV_AUTOPILOT_INVALID:
            vehicle = (msg.type, msg.autopilot)
        elif t in ("SIMSTATE", "SIM_STATE"):
            simulated = True
    if not times:
        extra = f"; {bad_bytes} bytes of unreadable data" if bad_bytes else ""
        raise LogError(f"{name}: no MAVLink messages (not a tlog?{extra})")
    integrity = _Integrity(
        times=np.asarray(times, dtype=float),
        n_bad=bad,
        bad_bytes=bad_bytes,
        bad_what="message(s) failed their MAVLink CRC",
        truncated_bytes=max(0, p.stat().st_size - end_ofs),
    )
    if gpi:
        sysid = max(gpi, key=lambda k: len(gpi[k]))
        rows = gpi[sysid]
        a = np.array([r[:9] for r in rows], dtype=float)
        modes = np.array([r[9] for r in rows], dtype=str)
        lat, lon, alt = a[:, 1] * 1e-7, a[:, 2] * 1e-7, a[:, 3] * 1e-3
        ok = _valid(lat, lon)
        cols: dict[str, np.ndarray | None] = {
            "msg_index": a[:, 0].astype(int),
            "lat_deg": lat,
            "lon_deg": lon,
            "alt_m": alt,
            "agl_m": a[:, 4] * 1e-3,
            "v_east_mps": a[:, 6] * 0.01,
            "v_north_mps": a[:, 5] * 0.01,
            "v_up_mps": -a[:, 7] * 0.01,
            "vehicle_time_s": a[:, 8],
        }
        source, agl_source = "GLOBAL_POSITION_INT", "GLOBAL_POSITION_INT.relative_alt"
    elif gps:
        sysid = max(gps, key=lambda k: len(gps[k]))
        rows = gps[sysid]
        a = np.array([r[:8] for r in rows], dtype=float)
        modes = np.array([r[8] for r in rows], dtype=str)
        lat, lon, alt = a[:, 1] * 1e-7, a[:, 2] * 1e-7, a[:, 3] * 1e-3
        ok = _valid(lat, lon) & (a[:, 4] >= 3)
        vel = np.where(a[:, 5] == 65535, np.nan, a[:, 5] * 0.01)
        cog = np.radians(np.where(a[:, 6] == 65535, np.nan, a[:, 6] * 0.01))
        cols = {
            "msg_index": a[:, 0].astype(int),
            "lat_deg": lat,
            "lon_deg": lon,
            "alt_m": alt,
            "agl_m": None,
            "v_east_mps": vel * np.sin(cog),
            "v_north_mps": vel * np.cos(cog),
            "v_up_mps": None,
            "vehicle_time_s": a[:, 7],
        }
        source, agl_source = "GPS_RAW_INT", "alt_m minus the first sample's alt_m (no relative altitude in GPS_RAW_INT)"
    else:
        raise LogError(f"{name}: no GLOBAL_POSITION_INT or GPS_RAW_INT messages")
    if vehicle is not None:
        vtype = _enum_name(mavutil, "MAV_TYPE", vehicle[0], "MAV_TYPE_")
        autopilot = _enum_name(mavutil, "MAV_AUTOPILOT", vehicle[1], "MAV_AUTOPILOT_")
    else:
        vtype, autopilot = "UNKNOWN", "UNKNOWN"
    return _finish(
        name, "tlog", cols, modes, ok, frame, integrity, counts, vtype, autopilot, source, agl_source, simulated, limits
    )


# --------------------------------------------------------------------------- DataFlash
def _read_dataflash(p: Path, name: str, frame: LocalFrame | None, limits: SanityLimits, noise: io.StringIO):
    mavutil, m = _connection(p, name)
    counts: collections.Counter = collections.Counter()
    gps_rows, pos_rows = [], []
    times: list[float] = []
    firmware = None
    simulated = False
    for msg in _messages(m, name, counts):
        t = msg.get_type()
        if t in ("FMT", "FMTU", "UNIT", "MULT"):
            continue
        ts = msg._timestamp
        k = len(times)
        times.append(ts)
        if t == "GPS":
            if getattr(msg, "I", 0) != 0:  # keep the first GPS instance only
                continue
            gps_rows.append(
                (
                    k,
                    msg.TimeUS,
                    msg.Status,
                    msg.Lat,
                    msg.Lng,
                    msg.Alt,
                    msg.Spd,
                    msg.GCrs,
                    getattr(msg, "VZ", math.nan),
                    m.flightmode,
                )
            )
        elif t == "POS":
            pos_rows.append((k, msg.TimeUS, msg.Lat, msg.Lng, msg.Alt, getattr(msg, "RelHomeAlt", math.nan), m.flightmode))
        elif t == "VER" and firmware is None:
            firmware = getattr(msg, "FWS", None)
        elif (
            t == "MSG"
            and firmware is None
            and str(msg.Message).startswith(
                ("ArduPlane", "ArduCopter", "ArduRover", "ArduSub", "APM:", "Blimp", "AntennaTracker")
            )
        ):
            firmware = str(msg.Message)
        elif t in ("SIM", "SIM2", "SITL"):
            simulated = True
    if not times:
        raise LogError(f"{name}: no DataFlash messages")
    # DataFlash has no CRC: corruption shows as byte runs the parser skips ("Skipped N bad bytes ...")
    skipped = [int(x) for x in re.findall(r"Skipped (\d+) bad bytes", noise.getvalue())]
    failed = len(re.findall(r"Failed to parse", noise.getvalue()))
    tail = max(0, int(getattr(m, "data_len", 0)) - int(getattr(m, "offset", 0)))
    # block-based logs pad their last page (< 256 bytes) with anything but a message header
    data_map = getattr(m, "data_map", None)
    tail_is_msg = tail >= 2 and data_map is not None and bytes(data_map[m.offset : m.offset + 2]) == b"\xa3\x95"
    integrity = _Integrity(
        times=np.asarray(times, dtype=float),
        n_bad=len(skipped) + failed,
        bad_bytes=sum(skipped),
        bad_what="corrupt chunk(s) skipped by the DataFlash parser",
        truncated_bytes=tail if (tail_is_msg or tail >= 528) else 0,
    )
    pos = np.array([r[:6] for r in pos_rows], dtype=float).reshape(-1, 6)
    if gps_rows:
        a = np.array([r[:9] for r in gps_rows], dtype=float)
        modes = np.array([r[9] for r in gps_rows], dtype=str)
        lat, lon, alt = a[:, 3], a[:, 4], a[:, 5]
        ok = _valid(lat, lon) & (a[:, 2] >= 3)
        crs = np.radians(a[:, 7])
        agl = None
        agl_source = "alt_m minus the first sample's alt_m (no POS messages)"
        pv = pos[np.isfinite(pos[:, 5])]
        if len(pv) >= 2:
            agl = np.interp(a[:, 1], pv[:, 1], pv[:, 5])
            agl_source = "POS.RelHomeAlt interpolated to the GPS samples"
        cols = {
            "msg_index": a[:, 0].astype(int),
            "lat_deg": lat,
            "lon_deg": lon,
            "alt_m": alt,
            "agl_m": agl,
            "v_east_mps": a[:, 6] * np.sin(crs),
            "v_north_mps": a[:, 6] * np.cos(crs),
            "v_up_mps": -a[:, 8],
            "vehicle_time_s": a[:, 1] * 1e-6,
        }
        source = "GPS"
    elif len(pos):
        modes = np.array([r[6] for r in pos_rows], dtype=str)
        lat, lon = pos[:, 2], pos[:, 3]
        ok = _valid(lat, lon)
        cols = {
            "msg_index": pos[:, 0].astype(int),
            "lat_deg": lat,
            "lon_deg": lon,
            "alt_m": pos[:, 4],
            "agl_m": pos[:, 5],
            "v_east_mps": None,
            "v_north_mps": None,
            "v_up_mps": None,
            "vehicle_time_s": pos[:, 1] * 1e-6,
        }
        source, agl_source = "POS", "POS.RelHomeAlt"
    else:
        raise LogError(f"{name}: no GPS or POS messages")
    vtype = {1: "FIXED_WING", 2: "QUADROTOR", 10: "GROUND_ROVER", 12: "SUBMARINE"}.get(
        int(getattr(m, "mav_type", -1) or -1), "UNKNOWN"
    )
    if firmware:
        for prefix, vt in (
            ("ArduPlane", "FIXED_WING"),
            ("ArduCopter", "QUADROTOR"),
            ("ArduRover", "GROUND_ROVER"),
            ("ArduSub", "SUBMARINE"),
        ):
            if firmware.startswith(prefix) and vtype == "UNKNOWN":
                vtype = vt
    return _finish(
        name,
        "dataflash",
        cols,
        modes,
        ok,
        frame,
        integrity,
        counts,
        vtype,
        firmware or "ARDUPILOTMEGA",
        source,
        agl_source,
        simulated,
        limits,
    )


# --------------------------------------------------------------------------- PX4 ULog
PX4_NAV_STATES = {
    0: "MANUAL", 1: "ALTCTL", 2: "POSCTL", 3: "AUTO_MISSION", 4: "AUTO_LOITER", 5: "AUTO_RTL", 10: "ACRO",
    12: "DESCEND", 13: "TERMINATION", 14: "OFFBOARD", 15: "STAB", 17: "AUTO_TAKEOFF", 18: "AUTO_LAND",
    19: "AUTO_FOLLOW_TARGET", 20: "AUTO_PRECLAND", 21: "ORBIT", 22: "AUTO_VTOL_TAKEOFF",
}  # fmt: skip
"""PX4 ``vehicle_status.nav_state`` numbers and names (msg/VehicleStatus.msg)."""
_ULOG_TOPICS = ["vehicle_global_position", "vehicle_gps_position", "vehicle_status", "home_position"]


def _read_ulog(p: Path, name: str, frame: LocalFrame | None, limits: SanityLimits):
    try:
        from pyulog import ULog
    except ImportError:  # pragma: no cover - a dependency of the package
        raise LogError(f"{name}: reading a PX4 ULog needs pyulog (pip install pyulog)") from None
    try:
        with _silenced():
            ulog = ULog(str(p), _ULOG_TOPICS)
    except Exception as exc:  # pyulog raises many types on garbage
        raise LogError(f"{name}: pyulog cannot read it ({type(exc).__name__}: {exc})") from None
    topics = {d.name: d.data for d in ulog.data_list if d.multi_id == 0}
    counts = collections.Counter({d.name: len(d.data["timestamp"]) for d in ulog.data_list})
    vel: tuple[np.ndarray | None, ...] = (None, None, None)
    if "vehicle_global_position" in topics:
        d = topics["vehicle_global_position"]
        lat, lon, alt = (np.asarray(d[k], dtype=float) for k in ("lat", "lon", "alt"))
        ok, source = _valid(lat, lon), "vehicle_global_position"
    elif "vehicle_gps_position" in topics:
        d = topics["vehicle_gps_position"]
        new = "latitude_deg" in d  # (PX4 >= 1.14: degrees and metres; before: 1e-7 deg and mm)
        lat = np.asarray(d["latitude_deg"] if new else d["lat"] * 1e-7, dtype=float)
        lon = np.asarray(d["longitude_deg"] if new else d["lon"] * 1e-7, dtype=float)
        alt = np.asarray(d["altitude_msl_m"] if new else d["alt"] * 1e-3, dtype=float)
        vel = (np.asarray(d["vel_e_m_s"], float), np.asarray(d["vel_n_m_s"], float), -np.asarray(d["vel_d_m_s"], float))
        ok, source = _valid(lat, lon) & (np.asarray(d["fix_type"]) >= 3), "vehicle_gps_position"
    else:
        raise LogError(f"{name}: no vehicle_global_position or vehicle_gps_position topic")
    t = np.asarray(d["timestamp"], dtype=float) * 1e-6
    home = topics.get("home_position")
    if home is not None and len(home["alt"]):
        agl, agl_source = alt - float(home["alt"][-1]), "alt minus home_position.alt"
    else:
        agl = alt - alt[ok][0] if ok.any() else alt
        agl_source = "alt_m minus the first sample's alt_m (no home_position)"
    cols = {
        "msg_index": np.arange(len(t)), "lat_deg": lat, "lon_deg": lon, "alt_m": alt, "agl_m": agl,
        "v_east_mps": vel[0], "v_north_mps": vel[1], "v_up_mps": vel[2], "vehicle_time_s": t,
    }  # fmt: skip
    integrity = _Integrity(t, 0, 0, "corrupt ULog chunks", 0)
    info = ulog.msg_info_dict
    status = topics.get("vehicle_status")
    return _finish(
        name, "ulog", cols, _ulog_modes(status, t), ok, frame, integrity, counts, _ulog_vehicle_type(status),
        str(info.get("sys_name", "PX4")).upper(), source, agl_source, "SITL" in str(info.get("ver_hw", "")), limits,
    )  # fmt: skip


def _ulog_modes(status: dict | None, t: np.ndarray) -> np.ndarray:
    """The nav_state name in force at each time of ``t`` ("UNKNOWN" before the first vehicle_status)."""
    if status is None or not len(status["timestamp"]):
        return np.full(len(t), "UNKNOWN")
    ts = np.asarray(status["timestamp"], dtype=float) * 1e-6
    names = np.array(["UNKNOWN"] + [PX4_NAV_STATES.get(int(v), f"NAV_STATE_{int(v)}") for v in status["nav_state"]])
    return names[np.searchsorted(ts, t, side="right")]


def _ulog_vehicle_type(status: dict | None) -> str:
    if status is None or "vehicle_type" not in status or not len(status["vehicle_type"]):
        return "UNKNOWN"  # vehicle_type: 1 rotary wing, 2 fixed wing (VehicleStatus.msg)
    return {1: "QUADROTOR", 2: "FIXED_WING", 3: "GROUND_ROVER"}.get(int(status["vehicle_type"][-1]), "UNKNOWN")


# --------------------------------------------------------------------------- common
@dataclass
class _Integrity:
    """What a reader learned about the byte stream, for the sanity checks in :func:`_finish`."""

    times: np.ndarray  # the time of every decoded message, in file order
    n_bad: int  # CRC failures (tlog) / corrupt chunks skipped (DataFlash)
    bad_bytes: int
    bad_what: str
    truncated_bytes: int


def _valid(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    return np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90.0) & (np.abs(lon) <= 180.0) & ~((lat == 0.0) & (lon == 0.0))


def _longest_nondecreasing(t: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """Mask of a longest subsequence of ``t`` in which no time is more than ``tol`` before the largest one kept
    before it (patience sorting, O(n log n)): about the fewest drops that put the times in order. DataFlash
    logs write some messages a fraction of a millisecond out of order; ``tol`` lets that through."""
    n = len(t)
    keep = np.zeros(n, dtype=bool)
    if n == 0:
        return keep
    tails: list[float] = []  # tails[j]: the smallest running maximum of a kept run of length j + 1
    tail_idx: list[int] = []
    parent = [-1] * n
    for i, x in enumerate(t.tolist()):
        j = bisect.bisect_right(tails, x + tol)
        parent[i] = tail_idx[j - 1] if j else -1
        top = max(tails[j - 1], x) if j else x
        if j == len(tails):
            tails.append(top)
            tail_idx.append(i)
        elif top <= tails[j]:
            tails[j] = top
            tail_idx[j] = i
    k = tail_idx[-1]
    while k >= 0:
        keep[k] = True
        k = parent[k]
    return keep


def _time_ok(times: np.ndarray, limits: SanityLimits) -> tuple[np.ndarray, str]:
    """Per message: time plausible and in order. The axis is wall-clock/GPS time or time since boot, by the median."""
    finite = np.isfinite(times)
    if not finite.any():
        return finite, "none"
    med = float(np.median(times[finite]))
    if med >= EPOCH_2000_S * 0.5:
        lo, hi, axis = EPOCH_2000_S, time.time() + limits.future_slack_s, "wall-clock"
    else:
        lo, hi, axis = 0.0, limits.max_boot_time_s, "time since boot"
    plausible = finite & (times >= lo) & (times <= hi)
    ok = np.zeros(len(times), dtype=bool)
    idx = np.flatnonzero(plausible)
    ok[idx[_longest_nondecreasing(times[idx], limits.time_tolerance_s)]] = True
    return ok, axis


def _glitch_mask(
    lat: np.ndarray,
    lon: np.ndarray,
    alt: np.ndarray,
    t: np.ndarray,
    max_speed_mps: float,
    t_vehicle: np.ndarray | None = None,
    slack_m: float = 10.0,
) -> np.ndarray:
    """Mask of fixes reachable from the last accepted one at ``max_speed_mps`` (horizontal and vertical).

    The time between two fixes is the larger of the log's time step and the vehicle clock's (a tlog's
    receive times bunch up when the radio link delivers a burst; the vehicle clock may reset on a reboot):
    a fix is a glitch only if both clocks say it moved too fast.

    The walk starts at the fix nearest the median position and runs forwards and backwards from it, so a
    glitch at the start of the log cannot make every later fix look like a jump.
    """
    n = len(lat)
    keep = np.ones(n, dtype=bool)
    if n < 2:
        return keep
    lat0, lon0 = float(np.median(lat)), float(np.median(lon))
    y = (lat - lat0) * 111_195.0
    dlon = (lon - lon0 + 180.0) % 360.0 - 180.0
    x = dlon * 111_195.0 * math.cos(math.radians(lat0))
    start = int(np.argmin(np.hypot(x, y)))
    xs, ys, zs, ts = x.tolist(), y.tolist(), np.nan_to_num(alt).tolist(), t.tolist()
    vs = np.nan_to_num(t_vehicle).tolist() if t_vehicle is not None else ts
    for order in (range(start + 1, n), range(start - 1, -1, -1)):
        j = start
        for i in order:
            reach = max_speed_mps * max(abs(ts[i] - ts[j]), abs(vs[i] - vs[j])) + slack_m
            if math.hypot(xs[i] - xs[j], ys[i] - ys[j]) > reach or abs(zs[i] - zs[j]) > reach:
                keep[i] = False
            else:
                j = i
    return keep


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" + ("" if n == 1 else "s")


def _finish(
    name,
    fmt,
    cols,
    modes,
    ok,
    frame,
    integrity: _Integrity,
    counts,
    vtype,
    autopilot,
    source,
    agl_source,
    simulated,
    limits: SanityLimits,
):
    times = integrity.times
    n_msgs = len(times)
    warnings: list[str] = []
    if integrity.truncated_bytes:
        warnings.append(
            f"the log ends in a truncated message ({integrity.truncated_bytes} bytes after the last "
            f"complete message; the file was cut short?)"
        )
    # CRC failures
    n_bad = integrity.n_bad
    if n_bad:
        frac = n_bad / max(1, n_msgs + n_bad)
        if frac > limits.max_bad_fraction:
            raise LogIntegrityError(
                f"{name}: refused: {n_bad} {integrity.bad_what} ({integrity.bad_bytes} bytes) against {n_msgs} good "
                f"messages ({100 * frac:.1f}% > {100 * limits.max_bad_fraction:g}%): the file is corrupt"
            )
        warnings.append(f"{n_bad} {integrity.bad_what} ({integrity.bad_bytes} bytes), not used")
    # time: plausible and in order
    time_ok, axis = _time_ok(times, limits)
    n_time_faults = int(n_msgs - time_ok.sum())
    if not time_ok.any():
        finite = times[np.isfinite(times)]
        span = f" ({finite.min():.6g}..{finite.max():.6g} s)" if len(finite) else ""
        raise LogIntegrityError(f"{name}: refused: no message has a plausible time{span}")
    if n_time_faults / n_msgs > limits.max_time_fault_fraction:
        raise LogIntegrityError(
            f"{name}: refused: {n_time_faults} of {n_msgs} messages have an implausible or out-of-order "
            f"{axis} time ({100 * n_time_faults / n_msgs:.1f}% > {100 * limits.max_time_fault_fraction:g}%)"
        )
    good_t = times[time_ok]
    first_t, last_t = float(good_t.min()), float(good_t.max())

    n_in = len(ok)
    unix_all = times[cols["msg_index"]]
    tok = time_ok[cols["msg_index"]]
    time_faulty = ok & ~tok
    idx = np.flatnonzero(ok & tok)
    if len(idx):  # drop samples not after the previous ones (duplicated packets, sub-tolerance jitter)
        t = unix_all[idx]
        idx = idx[np.concatenate([[True], t[1:] > np.maximum.accumulate(t)[:-1]])]
    lat_all, lon_all, alt_all = cols["lat_deg"], cols["lon_deg"], cols["alt_m"]
    g = _glitch_mask(lat_all[idx], lon_all[idx], alt_all[idx], unix_all[idx], limits.max_speed_mps, cols["vehicle_time_s"][idx])
    glitched = idx[~g]
    idx = idx[g]
    n_pos_time_faults, n_glitches = int(time_faulty.sum()), len(glitched)
    n_valid = int(ok.sum())
    n_dropped = n_pos_time_faults + n_glitches
    if len(idx) == 0:
        if n_dropped:
            raise LogIntegrityError(f"{name}: refused: all {n_valid} {source} fixes are time faults or glitches")
        raise LogError(f"{name}: no valid position fix in {n_in} {source} message(s)")
    dropped_s = 0.0
    if n_dropped:
        faulty = time_faulty.copy()
        faulty[glitched] = True
        if n_dropped / n_valid > limits.max_dropped_fraction:
            raise LogIntegrityError(
                f"{name}: refused: {n_dropped} of {n_valid} {source} fixes are time faults ({n_pos_time_faults}) "
                f"or position glitches ({n_glitches}) ({100 * n_dropped / n_valid:.0f}% > "
                f"{100 * limits.max_dropped_fraction:g}%)"
            )
        # seconds of the kept time line with dropped samples in them (+ a median interval per sample at either end)
        tk = unix_all[idx]
        cf = np.concatenate([[0], np.cumsum(faulty)])
        between = cf[idx[1:]] - cf[idx[:-1] + 1]
        dropped_s = float(np.diff(tk)[between > 0].sum())
        ends = int(cf[idx[0]] + (cf[-1] - cf[idx[-1] + 1]))
        if ends:
            dropped_s += ends * (float(np.median(np.diff(tk))) if len(tk) > 1 else 0.0)
        parts = []
        if n_pos_time_faults:
            parts.append(f"{_plural(n_pos_time_faults, 'time fault')}")
        if n_glitches:
            parts.append(
                f"{_plural(n_glitches, 'position glitch')} (faster than {limits.max_speed_mps:g} m/s)".replace(
                    "glitchs", "glitches"
                )
            )
        warnings.append(
            f"scored over the clean part only: dropped {n_dropped} of {n_valid} {source} fixes "
            f"({', '.join(parts)}), {dropped_s:.1f} s of the {tk[-1] - tk[0]:.1f} s track"
        )
    if n_time_faults > n_pos_time_faults:
        warnings.append(f"{n_time_faults} message(s) with an implausible or out-of-order {axis} time ignored")

    out: dict[str, np.ndarray] = {}
    unix = unix_all[idx]
    out["time_s"] = unix - first_t
    out["unix_time_s"] = unix
    lat, lon, alt = lat_all[idx], lon_all[idx], alt_all[idx]
    out["lat_deg"], out["lon_deg"], out["alt_m"] = lat, lon, alt
    out["agl_m"] = cols["agl_m"][idx] if cols["agl_m"] is not None else alt - alt[0]
    if frame is None:
        frame = LocalFrame(float(lat[0]), float(lon[0]), float(alt[0]))
    en = frame.to_enu_array(lat, lon, np.full_like(lat, frame.h0_m))
    up = frame.to_enu_array(lat, lon, alt)[:, 2]
    out["east_m"], out["north_m"], out["up_m"] = en[:, 0], en[:, 1], up
    tt = out["time_s"]
    for key, fallback in (("v_east_mps", out["east_m"]), ("v_north_mps", out["north_m"]), ("v_up_mps", alt)):
        v = cols[key]
        out[key] = v[idx] if v is not None else _gradient(fallback, tt)
    out["ground_speed_mps"] = np.hypot(out["v_east_mps"], out["v_north_mps"])
    out["mode"] = modes[idx]
    mode = out["mode"]
    changes = np.flatnonzero(mode[1:] != mode[:-1]) + 1
    sequence = tuple(str(x) for x in mode[np.concatenate([[0], changes])])
    info = LogInfo(
        path=name,
        log_format=fmt,
        vehicle_type=vtype,
        autopilot=autopilot,
        position_source=source,
        agl_source=agl_source,
        n_positions=len(idx),
        n_skipped=n_in - len(idx) - n_dropped,
        start_unix_s=first_t,
        end_unix_s=last_t,
        duration_s=last_t - first_t,
        position_span_s=(float(tt[0]), float(tt[-1])),
        message_counts=dict(counts),
        modes=sequence,
        simulated=simulated,
        frame=frame,
        n_bad_crc=n_bad,
        bad_bytes=integrity.bad_bytes,
        n_time_faults=n_time_faults,
        n_position_time_faults=n_pos_time_faults,
        n_glitches=n_glitches,
        dropped_s=dropped_s,
        truncated_bytes=integrity.truncated_bytes,
        warnings=tuple(warnings),
    )
    return out, info


def _haversine_m(lat1, lon1, lat2, lon2):
    p1, p2 = np.radians(lat1), np.radians(lat2)
    dp, dl = p2 - p1, np.radians(np.asarray(lon2) - lon1)
    a = np.sin(dp / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(dl / 2) ** 2
    return 2 * 6_371_008.8 * np.arcsin(np.sqrt(np.clip(a, 0.0, 1.0)))


def log_fence_distance_m(traj: dict[str, np.ndarray], fence) -> float:
    """Great-circle distance (m) from the log's median position to the fence: 0 inside the keep-in polygon,
    else to its nearest vertex (keep-in and keep-out vertices, keep-out circle centres)."""
    lat, lon = float(np.median(traj["lat_deg"])), float(np.median(traj["lon_deg"]))
    poly = [(float(a), float(b)) for a, b in fence.keep_in]
    if len(poly) >= 3:  # ray casting in lat/lon (fences are small; on the boundary either answer is fine)
        inside = False
        for (y1, x1), (y2, x2) in zip(poly, poly[1:] + poly[:1]):
            if (y1 > lat) != (y2 > lat) and lon < x1 + (lat - y1) * (x2 - x1) / (y2 - y1):
                inside = not inside
        if inside:
            return 0.0
    pts = poly + [(float(a), float(b)) for p in fence.keep_out_polygons for a, b in p]
    pts += [(c.center_lat_deg, c.center_lon_deg) for c in fence.keep_out_circles]
    if not pts:
        return 0.0
    a = np.array(pts, dtype=float)
    return float(_haversine_m(lat, lon, a[:, 0], a[:, 1]).min())


MAX_FENCE_DISTANCE_M = 100_000.0
"""The largest log-to-fence distance a log may be scored at (``--max-fence-distance-km`` at most 100). The
score is taken in one flat local ENU (tangent-plane) frame: at a distance d it shortens lengths by about
d^3 / (6 R^2) (4 m at 100 km, 4 km at 1,000 km) and its up axis rises d^2 / (2 R) above the ground
(0.8 km at 100 km). A log that far from its fence is the wrong fence anyway."""


def check_distance_bound(max_distance_m: float, where: str = "--max-fence-distance-km") -> float:
    """``max_distance_m`` if finite, > 0 and at most :data:`MAX_FENCE_DISTANCE_M`; else a one-line refusal."""
    bound_km = MAX_FENCE_DISTANCE_M / 1000.0
    if not (math.isfinite(max_distance_m) and 0.0 < max_distance_m <= MAX_FENCE_DISTANCE_M):
        raise LogFenceDistanceError(
            f"{where}: must be > 0 and <= {bound_km:g} km, got {max_distance_m / 1000.0:g} km (the scores are taken in "
            f"one flat ENU frame: at 100 km it shortens lengths by 4 m and its up axis is 0.8 km above the ground)"
        )
    return max_distance_m


def check_near_fence(traj: dict[str, np.ndarray], fence, max_distance_m: float = 50_000.0, name: str = "log") -> float:
    """:func:`log_fence_distance_m`, refused with :class:`LogFenceDistanceError` beyond ``max_distance_m``
    (itself refused unless finite and within :data:`MAX_FENCE_DISTANCE_M`: ``nan`` or ``inf`` switched the
    guard off)."""
    check_distance_bound(max_distance_m, f"{name}: max_distance_m")
    d = log_fence_distance_m(traj, fence)
    if d > max_distance_m:
        far = f"{d / 1000:,.0f} km" if d >= 10_000 else f"{d / 1000:,.1f} km"
        raise LogFenceDistanceError(
            f"{name}: log and fence are {far} apart (median log position to the nearest fence vertex; "
            f"bound {max_distance_m / 1000:g} km): wrong fence?"
        )
    return d


def _gradient(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    if len(x) < 2:
        return np.zeros_like(x)
    return np.gradient(x, t)


def describe(info: LogInfo) -> str:
    """A short multi-line summary of a :class:`LogInfo` (for a CLI report)."""
    top = ", ".join(f"{k} {v}" for k, v in sorted(info.message_counts.items(), key=lambda kv: -kv[1])[:6])
    return "\n".join(
        [
            f"{info.path}: {info.log_format}, {info.vehicle_type} ({info.autopilot}){', SITL' if info.simulated else ''}",
            f"  duration {info.duration_s:.1f} s; {sum(info.message_counts.values())} messages ({top}, ...)",
            f"  {info.n_positions} positions from {info.position_source} ({info.n_skipped} skipped), "
            f"t = {info.position_span_s[0]:.1f}..{info.position_span_s[1]:.1f} s; agl from {info.agl_source}",
            f"  modes: {' -> '.join(info.modes) if info.modes else 'none'}",
        ]
    )
