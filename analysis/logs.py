"""Read a real flight log (MAVLink telemetry ``.tlog`` or ArduPilot DataFlash ``.bin``) into trajectory columns.

The columns match :mod:`scenarios.recorder` where the log has the data, so
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
    ``POS.RelHomeAlt`` (interpolated to the GPS samples). With neither
    (GPS_RAW_INT fallback, a .bin without POS) it is ``alt_m`` minus the first
    sample's ``alt_m`` and ``LogInfo.agl_source`` says so.
``east_m``, ``north_m``, ``up_m``
    ENU about ``frame`` (default: the first valid fix at its altitude).
    ``east_m``/``north_m`` are the lat/lon projected at the frame's height (as
    :meth:`geofence.fence.LocalFence.horizontal_en` recommends for fence
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
coordinates are skipped, and so are samples whose time does not increase (a
duplicated packet). A tlog carrying several vehicles keeps the system id
that sent the most position messages.

pymavlink is used for decoding (``mavutil.mavlink_connection(path,
dialect="ardupilotmega")``); messages are read once, row by row, into
lists, and every derived column is computed vectorized with numpy.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from geofence.geodesy import LocalFrame

TRAJECTORY_COLUMNS = (
    "time_s", "unix_time_s", "lat_deg", "lon_deg", "alt_m", "agl_m", "east_m", "north_m", "up_m",
    "v_east_mps", "v_north_mps", "v_up_mps", "ground_speed_mps", "mode",
)


class LogError(ValueError):
    """A log that cannot be read or holds no usable position: one line naming the file."""


@dataclass
class LogInfo:
    """What a log is: for a report next to its scores."""

    path: str
    log_format: str                 # "tlog" or "dataflash"
    vehicle_type: str               # e.g. "FIXED_WING", "QUADROTOR" ("UNKNOWN" if not stated)
    autopilot: str                  # e.g. "ARDUPILOTMEGA", or the firmware string of a .bin
    position_source: str            # message type the trajectory came from
    agl_source: str                 # where agl_m came from
    n_positions: int                # samples kept
    n_skipped: int                  # position messages skipped (no fix, zero coordinates, repeated time)
    start_unix_s: float             # first message
    end_unix_s: float               # last message
    duration_s: float               # end - start
    position_span_s: tuple[float, float]  # (first, last) kept sample, in time_s
    message_counts: dict[str, int] = field(default_factory=dict)
    modes: tuple[str, ...] = ()     # the mode sequence over the kept samples (consecutive repeats merged)
    simulated: bool = False         # a SITL log (SIMSTATE/SIM messages present)
    frame: LocalFrame | None = None  # the ENU frame of east/north/up


def read_log(path: str | Path, frame: LocalFrame | None = None) -> dict[str, np.ndarray]:
    """Trajectory columns of a ``.tlog`` or DataFlash ``.bin`` (see the module docstring)."""
    return load_log(path, frame)[0]


def load_log(path: str | Path, frame: LocalFrame | None = None) -> tuple[dict[str, np.ndarray], LogInfo]:
    """``(trajectory columns, LogInfo)`` of one log, read in one pass."""
    p = Path(path)
    name = str(path)
    if not p.is_file():
        raise LogError(f"{name}: file not found")
    with open(p, "rb") as fh:
        head = fh.read(3)
    if head == b"\xa3\x95\x80":  # DataFlash binary: HEAD1, HEAD2, FMT id 128
        return _read_dataflash(p, name, frame)
    return _read_tlog(p, name, frame)


# --------------------------------------------------------------------------- tlog
def _connection(p: Path, name: str):
    from pymavlink import mavutil

    try:
        return mavutil, mavutil.mavlink_connection(str(p), dialect="ardupilotmega")
    except Exception as exc:  # pymavlink raises many types on garbage
        raise LogError(f"{name}: pymavlink cannot open it ({type(exc).__name__}: {exc})") from None


def _enum_name(mavutil, enum: str, value: int, prefix: str) -> str:
    e = mavutil.mavlink.enums.get(enum, {}).get(value)
    return e.name[len(prefix):] if e is not None and e.name.startswith(prefix) else f"{value}"


def _messages(m, name: str, counts: collections.Counter):
    """Every message of a pymavlink connection, counted by type; decoding errors become a LogError."""
    while True:
        try:
            msg = m.recv_match()
        except Exception as exc:
            raise LogError(f"{name}: decoding failed after {sum(counts.values())} messages "
                           f"({type(exc).__name__}: {exc})") from None
        if msg is None:
            return
        counts[msg.get_type()] += 1
        yield msg


def _read_tlog(p: Path, name: str, frame: LocalFrame | None):
    mavutil, m = _connection(p, name)
    counts: collections.Counter = collections.Counter()
    gpi: dict[int, list] = collections.defaultdict(list)
    gps: dict[int, list] = collections.defaultdict(list)
    vehicle = None
    first_t = last_t = None
    simulated = False
    gcs = mavutil.mavlink.MAV_TYPE_GCS
    for msg in _messages(m, name, counts):
        t = msg.get_type()
        if t == "BAD_DATA":
            continue
        ts = msg._timestamp
        if first_t is None:
            first_t = ts
        last_t = ts
        if t == "GLOBAL_POSITION_INT":
            gpi[msg.get_srcSystem()].append((ts, msg.lat, msg.lon, msg.alt, msg.relative_alt, msg.vx, msg.vy, msg.vz,
                                             m.flightmode))
        elif t == "GPS_RAW_INT":
            gps[msg.get_srcSystem()].append((ts, msg.lat, msg.lon, msg.alt, msg.fix_type, msg.vel, msg.cog,
                                             m.flightmode))
        elif t == "HEARTBEAT" and msg.type != gcs and vehicle is None and msg.autopilot != mavutil.mavlink.MAV_AUTOPILOT_INVALID:
            vehicle = (msg.type, msg.autopilot)
        elif t in ("SIMSTATE", "SIM_STATE"):
            simulated = True
    if first_t is None:
        raise LogError(f"{name}: no MAVLink messages (not a tlog?)")
    if gpi:
        sysid = max(gpi, key=lambda k: len(gpi[k]))
        rows = gpi[sysid]
        a = np.array([r[:8] for r in rows], dtype=float)
        modes = np.array([r[8] for r in rows], dtype=str)
        lat, lon, alt = a[:, 1] * 1e-7, a[:, 2] * 1e-7, a[:, 3] * 1e-3
        ok = _valid(lat, lon)
        cols = {"unix_time_s": a[:, 0], "lat_deg": lat, "lon_deg": lon, "alt_m": alt, "agl_m": a[:, 4] * 1e-3,
                "v_east_mps": a[:, 6] * 0.01, "v_north_mps": a[:, 5] * 0.01, "v_up_mps": -a[:, 7] * 0.01}
        source, agl_source = "GLOBAL_POSITION_INT", "GLOBAL_POSITION_INT.relative_alt"
    elif gps:
        sysid = max(gps, key=lambda k: len(gps[k]))
        rows = gps[sysid]
        a = np.array([r[:7] for r in rows], dtype=float)
        modes = np.array([r[7] for r in rows], dtype=str)
        lat, lon, alt = a[:, 1] * 1e-7, a[:, 2] * 1e-7, a[:, 3] * 1e-3
        ok = _valid(lat, lon) & (a[:, 4] >= 3)
        vel = np.where(a[:, 5] == 65535, np.nan, a[:, 5] * 0.01)
        cog = np.radians(np.where(a[:, 6] == 65535, np.nan, a[:, 6] * 0.01))
        cols = {"unix_time_s": a[:, 0], "lat_deg": lat, "lon_deg": lon, "alt_m": alt, "agl_m": None,
                "v_east_mps": vel * np.sin(cog), "v_north_mps": vel * np.cos(cog), "v_up_mps": None}
        source, agl_source = "GPS_RAW_INT", "alt_m minus the first sample's alt_m (no relative altitude in GPS_RAW_INT)"
    else:
        raise LogError(f"{name}: no GLOBAL_POSITION_INT or GPS_RAW_INT messages")
    if vehicle is not None:
        vtype = _enum_name(mavutil, "MAV_TYPE", vehicle[0], "MAV_TYPE_")
        autopilot = _enum_name(mavutil, "MAV_AUTOPILOT", vehicle[1], "MAV_AUTOPILOT_")
    else:
        vtype, autopilot = "UNKNOWN", "UNKNOWN"
    return _finish(name, "tlog", cols, modes, ok, frame, first_t, last_t, counts, vtype, autopilot, source,
                   agl_source, simulated)


# --------------------------------------------------------------------------- DataFlash
def _read_dataflash(p: Path, name: str, frame: LocalFrame | None):
    mavutil, m = _connection(p, name)
    counts: collections.Counter = collections.Counter()
    gps_rows, pos_rows = [], []
    first_t = last_t = None
    firmware = None
    simulated = False
    for msg in _messages(m, name, counts):
        t = msg.get_type()
        if t in ("FMT", "FMTU", "UNIT", "MULT"):
            continue
        ts = msg._timestamp
        if first_t is None:
            first_t = ts
        last_t = ts
        if t == "GPS":
            if getattr(msg, "I", 0) != 0:  # keep the first GPS instance only
                continue
            gps_rows.append((ts, msg.TimeUS, msg.Status, msg.Lat, msg.Lng, msg.Alt, msg.Spd, msg.GCrs,
                             getattr(msg, "VZ", math.nan), m.flightmode))
        elif t == "POS":
            pos_rows.append((ts, msg.TimeUS, msg.Lat, msg.Lng, msg.Alt, getattr(msg, "RelHomeAlt", math.nan),
                             m.flightmode))
        elif t == "VER" and firmware is None:
            firmware = getattr(msg, "FWS", None)
        elif t == "MSG" and firmware is None and str(msg.Message).startswith(("ArduPlane", "ArduCopter", "ArduRover",
                                                                              "ArduSub", "APM:", "Blimp", "AntennaTracker")):
            firmware = str(msg.Message)
        elif t in ("SIM", "SIM2", "SITL"):
            simulated = True
    if first_t is None:
        raise LogError(f"{name}: no DataFlash messages")
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
        cols = {"unix_time_s": a[:, 0], "lat_deg": lat, "lon_deg": lon, "alt_m": alt, "agl_m": agl,
                "v_east_mps": a[:, 6] * np.sin(crs), "v_north_mps": a[:, 6] * np.cos(crs), "v_up_mps": -a[:, 8]}
        source = "GPS"
    elif len(pos):
        modes = np.array([r[6] for r in pos_rows], dtype=str)
        lat, lon = pos[:, 2], pos[:, 3]
        ok = _valid(lat, lon)
        cols = {"unix_time_s": pos[:, 0], "lat_deg": lat, "lon_deg": lon, "alt_m": pos[:, 4], "agl_m": pos[:, 5],
                "v_east_mps": None, "v_north_mps": None, "v_up_mps": None}
        source, agl_source = "POS", "POS.RelHomeAlt"
    else:
        raise LogError(f"{name}: no GPS or POS messages")
    vtype = {1: "FIXED_WING", 2: "QUADROTOR", 10: "GROUND_ROVER", 12: "SUBMARINE"}.get(getattr(m, "mav_type", None), "UNKNOWN")
    if firmware:
        for prefix, vt in (("ArduPlane", "FIXED_WING"), ("ArduCopter", "QUADROTOR"), ("ArduRover", "GROUND_ROVER"),
                           ("ArduSub", "SUBMARINE")):
            if firmware.startswith(prefix) and vtype == "UNKNOWN":
                vtype = vt
    return _finish(name, "dataflash", cols, modes, ok, frame, first_t, last_t, counts, vtype,
                   firmware or "ARDUPILOTMEGA", source, agl_source, simulated)


# --------------------------------------------------------------------------- common
def _valid(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    return (np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90.0) & (np.abs(lon) <= 180.0)
            & ~((lat == 0.0) & (lon == 0.0)))


def _finish(name, fmt, cols, modes, ok, frame, first_t, last_t, counts, vtype, autopilot, source, agl_source,
            simulated):
    n_in = len(ok)
    # drop invalid fixes, then samples whose time does not increase
    idx = np.flatnonzero(ok)
    t = cols["unix_time_s"][idx]
    if len(idx):
        keep = np.concatenate([[True], t[1:] > np.maximum.accumulate(t)[:-1]])
        idx = idx[keep]
    if len(idx) == 0:
        raise LogError(f"{name}: no valid position fix in {n_in} {source} message(s)")
    out: dict[str, np.ndarray] = {}
    unix = cols["unix_time_s"][idx]
    out["time_s"] = unix - first_t
    out["unix_time_s"] = unix
    lat, lon, alt = cols["lat_deg"][idx], cols["lon_deg"][idx], cols["alt_m"][idx]
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
        path=name, log_format=fmt, vehicle_type=vtype, autopilot=autopilot, position_source=source,
        agl_source=agl_source, n_positions=len(idx), n_skipped=n_in - len(idx),
        start_unix_s=float(first_t), end_unix_s=float(last_t), duration_s=float(last_t - first_t),
        position_span_s=(float(tt[0]), float(tt[-1])), message_counts=dict(counts), modes=sequence,
        simulated=simulated, frame=frame,
    )
    return out, info


def _gradient(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    if len(x) < 2:
        return np.zeros_like(x)
    return np.gradient(x, t)


def describe(info: LogInfo) -> str:
    """A short multi-line summary of a :class:`LogInfo` (for a CLI report)."""
    top = ", ".join(f"{k} {v}" for k, v in sorted(info.message_counts.items(), key=lambda kv: -kv[1])[:6])
    return "\n".join([
        f"{info.path}: {info.log_format}, {info.vehicle_type} ({info.autopilot}){', SITL' if info.simulated else ''}",
        f"  duration {info.duration_s:.1f} s; {sum(info.message_counts.values())} messages ({top}, ...)",
        f"  {info.n_positions} positions from {info.position_source} ({info.n_skipped} skipped), "
        f"t = {info.position_span_s[0]:.1f}..{info.position_span_s[1]:.1f} s; agl from {info.agl_source}",
        f"  modes: {' -> '.join(info.modes) if info.modes else 'none'}",
    ])
