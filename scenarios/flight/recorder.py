"""Flight recording: one row of doubles per step in a preallocated buffer, written to CSV once at the end.

One row per outer-loop step. Column names carry their units; angles are in deg
here (the CSV is an edge of the system), everything else SI.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np

from geofence.interface import StickCommand, VehicleState

COLUMNS = (
    "time_s",
    "lat_deg",
    "lon_deg",
    "alt_m",
    "east_m",
    "north_m",
    "up_m",
    "agl_m",
    "v_east_mps",
    "v_north_mps",
    "v_up_mps",
    "ground_speed_mps",
    "airspeed_mps",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
    "wind_east_mps",
    "wind_north_mps",
    "wind_up_mps",
    "pilot_roll",
    "pilot_pitch",
    "pilot_yaw",
    "pilot_throttle",
    "cmd_roll",
    "cmd_pitch",
    "cmd_yaw",
    "cmd_throttle",
    "geofence_mode",
    "mission_item",
    "est_east_m",
    "est_north_m",
    "est_agl_m",
    "est_wind_east_mps",
    "est_wind_north_mps",
    "activation_margin_m",
)
COLUMN_INDEX = {name: i for i, name in enumerate(COLUMNS)}
_DEG = 180.0 / math.pi
_ROW = struct.Struct(f"{len(COLUMNS)}d")
"""One row as native doubles (the layout numpy reads back as float64)."""
_ROW_BYTES = _ROW.size
_pack_row = _ROW.pack_into
PREALLOCATED_ROWS_MAX = 1 << 16
"""At most this many rows are made room for up front (18 MB; 27 min at 40 Hz): a 24-hour scenario would otherwise
zero-fill about 1 GB before its first step, and a flight that ends early would never use it. Beyond, the buffer
doubles as it fills."""


class Recorder:
    """Collects one row per step into a buffer of doubles (a ``bytearray``): a step's values are stored as
    8 bytes each, not kept as Python float objects (a flight's rows would be hundreds of thousands of them,
    and every step would touch new memory).

    A row is written by one ``struct.pack_into`` straight from :meth:`append`'s arguments (``array.extend``
    from a tuple costs three times as much: it converts and appends one item at a time). ``capacity_rows``:
    the rows to make room for up front (the runner knows its step count; at most :data:`PREALLOCATED_ROWS_MAX`); the
    buffer doubles beyond it.

    The buffer is viewed as one float array (rows x :data:`COLUMNS`) when it is read.
    """

    def __init__(self, capacity_rows: int = 1024) -> None:
        self._buf = bytearray(_ROW.size * max(1, min(capacity_rows, PREALLOCATED_ROWS_MAX)))
        self._n = 0
        self._array: np.ndarray | None = None

    @property
    def n(self) -> int:
        return self._n

    @property
    def data(self) -> np.ndarray:
        if self._array is None or len(self._array) != self._n:  # a copy: a view would pin the buffer's size
            rows = np.frombuffer(self._buf, dtype=float, count=self._n * len(COLUMNS))
            self._array = rows.reshape(self._n, len(COLUMNS)).copy()
        return self._array

    def append(
        self,
        s: VehicleState,
        wind_enu: tuple[float, float, float],
        pilot: StickCommand,
        cmd: StickCommand,
        mode: int,
        item: int,
        est: VehicleState | None = None,
        wind_est: tuple[float, float] = (math.nan, math.nan),
        activation_margin_m: float = math.nan,
    ) -> None:
        n = self._n
        offset = n * _ROW_BYTES
        buf = self._buf
        if offset == len(buf):
            buf.extend(bytes(len(buf)))  # (no array views it: :attr:`data` copies)
        self._n = n + 1
        ve, vn = s.v_east_mps, s.v_north_mps
        if est is None:
            est_e = est_n = est_agl = math.nan
        else:
            est_e, est_n, est_agl = est.east_m, est.north_m, est.agl_m
        # the sticks and wind tuples unpacked into the call (a tenth cheaper than indexing them one by one)
        _pack_row(
            buf, offset,
            s.t_s, s.lat_deg, s.lon_deg, s.alt_m, s.east_m, s.north_m, s.up_m, s.agl_m, ve, vn, s.v_up_mps,
            math.hypot(ve, vn), s.airspeed_mps, s.roll_rad * _DEG, s.pitch_rad * _DEG, s.yaw_rad * _DEG,
            *wind_enu, *pilot, *cmd, mode, item, est_e, est_n, est_agl, *wind_est, activation_margin_m,
        )  # fmt: skip

    @property
    def columns(self) -> tuple[str, ...]:
        return COLUMNS

    def rows(self) -> np.ndarray:
        return self.data[: self.n]

    def column(self, name: str) -> np.ndarray:
        return self.data[: self.n, COLUMN_INDEX[name]]

    def write_csv(self, path: Path) -> None:
        fmt = ["%.3f", "%.8f", "%.8f"] + ["%.4f"] * 24 + ["%d", "%d"] + ["%.4f"] * 6
        np.savetxt(path, self.rows(), delimiter=",", header=",".join(COLUMNS), comments="", fmt=fmt)


def read_trajectory_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a trajectory CSV back into named columns."""
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: np.asarray(data[name], dtype=float) for name in data.dtype.names or ()}
