"""MAVLink telemetry logs (``.tlog``) of simulated flights, as MAVProxy and QGroundControl write them.

A tlog is a sequence of records, each an 8-byte big-endian count of microseconds since the Unix epoch (the time
the message was received or sent) followed by one packed MAVLink message. :class:`TlogWriter` writes records;
:func:`write_trajectory_tlog` writes a recorded flight's trajectory as the vehicle's telemetry at the link's
rates (:class:`scenarios.link.telemetry.TelemetryRates`): HEARTBEAT, GLOBAL_POSITION_INT, ATTITUDE and VFR_HUD
from the recorded truth, each record stamped ``start_unix_s + time_s``. The MAVLink vehicle
(:mod:`scenarios.flight.mavlink_vehicle`) instead logs every message it sends and receives as it flies.
"""

from __future__ import annotations

import math
import struct
import time
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from geofence.estimation.measurements import AirData, AttitudeSample
from geofence.interface import PlatformKind, VehicleState
from scenarios.link import telemetry
from scenarios.link.sticks import Autopilot
from scenarios.link.telemetry import TelemetryRates, mav

_STAMP = struct.Struct(">Q")


class TlogWriter:
    """Writes ``.tlog`` records to ``path`` (replaced); messages packed by its own MAVLink 2 encoder as
    ``system``/``component`` (:meth:`send`), or already packed (:meth:`write`). Use as a context manager."""

    def __init__(self, path: str | Path, system: int = 1, component: int = 1) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file: BinaryIO = open(self.path, "wb")
        self._stamp_us = 0
        self.link = mav.MAVLink(self, srcSystem=system, srcComponent=component)
        self.records = 0

    def write(self, packed: bytes | bytearray, unix_time_s: float | None = None) -> None:
        """One record: ``packed`` (a whole MAVLink message) at ``unix_time_s`` (default: the time of the last
        :meth:`send`). Also the file-like ``write`` pymavlink's encoder calls."""
        if unix_time_s is not None:
            self._stamp_us = int(round(unix_time_s * 1e6))
        self._file.write(_STAMP.pack(self._stamp_us) + bytes(packed))
        self.records += 1

    def send(self, msg: Any, unix_time_s: float) -> None:
        """Pack ``msg`` (sequence numbers in order) and write it at ``unix_time_s``."""
        self._stamp_us = int(round(unix_time_s * 1e6))
        self.link.send(msg)

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> "TlogWriter":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _every(rate_hz: float, row_dt_s: float) -> int:
    """Rows between messages of ``rate_hz`` on rows ``row_dt_s`` apart (at least every row)."""
    return max(1, int(round(1.0 / (rate_hz * row_dt_s)))) if rate_hz > 0.0 else 0


def write_trajectory_tlog(
    traj: dict[str, np.ndarray], path: str | Path, kind: PlatformKind, *, autopilot: Autopilot = Autopilot.ARDUPILOT,
    rates: TelemetryRates = TelemetryRates(), start_unix_s: float | None = None,
) -> int:  # fmt: skip
    """Write a recorded trajectory (the recorder's columns) as the vehicle's telemetry; returns the records written.

    GLOBAL_POSITION_INT carries the recorded lat/lon/alt, ``agl_m`` as ``relative_alt`` and the velocities, so
    ``score-log`` on the file reproduces the flight's scores within the fields' quantisation.
    """
    t = np.asarray(traj["time_s"], dtype=float)
    row_dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    start = time.time() if start_unix_s is None else start_unix_s
    every = {
        "HEARTBEAT": _every(rates.heartbeat_hz, row_dt), "GLOBAL_POSITION_INT": _every(rates.global_position_int_hz, row_dt),
        "VFR_HUD": _every(rates.vfr_hud_hz, row_dt), "ATTITUDE": _every(rates.attitude_hz, row_dt),
    }  # fmt: skip
    col = {name: np.asarray(traj[name], dtype=float) for name in traj if name != "mode"}
    has_pitot = kind is not PlatformKind.MULTIROTOR
    with TlogWriter(path) as out:
        for i in range(len(t)):
            state = _state_of_row(col, i)
            stamp = start + float(t[i])
            if every["HEARTBEAT"] and i % every["HEARTBEAT"] == 0:
                out.send(telemetry.heartbeat(kind, autopilot), stamp)
            if every["GLOBAL_POSITION_INT"] and i % every["GLOBAL_POSITION_INT"] == 0:
                out.send(telemetry.global_position_int(state, state.alt_m - state.agl_m), stamp)
            if every["VFR_HUD"] and i % every["VFR_HUD"] == 0:
                air = AirData(state.t_s, state.airspeed_mps if has_pitot else None, state.alt_m)
                out.send(telemetry.vfr_hud(air, state), stamp)
            if every["ATTITUDE"] and i % every["ATTITUDE"] == 0:
                att = AttitudeSample(state.t_s, state.roll_rad, state.pitch_rad, state.yaw_rad)
                out.send(telemetry.attitude(att), stamp)
        out.send(telemetry.heartbeat(kind, autopilot, powering_off=True), start + float(t[-1]) if len(t) else start)
        return out.records


def _state_of_row(col: dict[str, np.ndarray], i: int) -> VehicleState:
    def v(name: str) -> float:
        return float(col[name][i]) if name in col else 0.0

    airspeed = v("airspeed_mps")
    return VehicleState(
        t_s=v("time_s"), lat_deg=v("lat_deg"), lon_deg=v("lon_deg"), alt_m=v("alt_m"), agl_m=v("agl_m"),
        v_east_mps=v("v_east_mps"), v_north_mps=v("v_north_mps"), v_up_mps=v("v_up_mps"),
        roll_rad=math.radians(v("roll_deg")), pitch_rad=math.radians(v("pitch_deg")), yaw_rad=math.radians(v("yaw_deg")),
        airspeed_mps=airspeed if math.isfinite(airspeed) else 0.0,
    )  # fmt: skip
