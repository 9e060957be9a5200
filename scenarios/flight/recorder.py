"""Flight recording: one row of doubles per step in a preallocated table, written to CSV once at the end.

One row per outer-loop step. Column names carry their units; angles are in deg
here (the CSV is an edge of the system), everything else SI. A row is written by
:meth:`Recorder.append` or, from a compiled step, by :func:`write_row` (the same
numbers in the same columns).
"""

from __future__ import annotations

import math
import os
import struct
from math import hypot
from pathlib import Path

import numpy as np

from geofence.interface import StickCommand, VehicleState
from geofence.jit import jitable

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
"""One row as native doubles (the table's float64 row)."""
_ROW_BYTES = _ROW.size
_pack_row = _ROW.pack_into
PREALLOCATED_ROWS_MAX = 1 << 16
"""At most this many rows are made room for up front (18 MB; 27 min at 40 Hz): a 24-hour scenario would otherwise
zero-fill about 1 GB before its first step, and a flight that ends early would never use it. Beyond, the table
doubles as it fills."""


class Recorder:
    """Collects one row per step into a table of doubles (rows x :data:`COLUMNS`, float64): a step's values are
    stored as 8 bytes each, not kept as Python float objects (a flight's rows would be hundreds of thousands of
    them, and every step would touch new memory).

    A row is written by one ``struct.pack_into`` straight from :meth:`append`'s arguments (``array.extend``
    from a tuple costs three times as much: it converts and appends one item at a time), or by a compiled step
    (:meth:`next_row`, :func:`write_row`, :meth:`commit_row`). ``capacity_rows``: the rows to make room for up
    front (the runner knows its step count; at most :data:`PREALLOCATED_ROWS_MAX`); the table doubles beyond it.
    """

    def __init__(self, capacity_rows: int = 1024) -> None:
        self._table = np.zeros((max(1, min(capacity_rows, PREALLOCATED_ROWS_MAX)), len(COLUMNS)))
        self._n = 0
        self._array: np.ndarray | None = None

    @property
    def n(self) -> int:
        return self._n

    @property
    def capacity_rows(self) -> int:
        """Rows the table has room for now (it doubles when full)."""
        return len(self._table)

    @property
    def data(self) -> np.ndarray:
        if self._array is None or len(self._array) != self._n:  # a copy: the table grows by being replaced
            self._array = self._table[: self._n].copy()
        return self._array

    def _grow(self) -> None:
        """Double the table (a new one, the rows so far copied)."""
        table = np.zeros((2 * len(self._table), len(COLUMNS)))
        table[: self._n] = self._table[: self._n]
        self._table = table

    def next_row(self) -> tuple[np.ndarray, int]:
        """The table and the index of the next row, with room for it (for :func:`write_row`; then :meth:`commit_row`).
        The table is replaced when it grows: ask again for every row."""
        if self._n == len(self._table):
            self._grow()
        return self._table, self._n

    def commit_row(self) -> None:
        """Count the row :func:`write_row` wrote at :meth:`next_row`'s index."""
        self._n += 1

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
        if n == len(self._table):
            self._grow()
        self._n = n + 1
        ve, vn = s.v_east_mps, s.v_north_mps
        if est is None:
            est_e = est_n = est_agl = math.nan
        else:
            est_e, est_n, est_agl = est.east_m, est.north_m, est.agl_m
        # the sticks and wind tuples unpacked into the call (a tenth cheaper than indexing them one by one)
        _pack_row(
            self._table, n * _ROW_BYTES,  # type: ignore[arg-type]  # (an ndarray is a writable buffer)
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
        """The table as CSV: a header of :data:`COLUMNS`, a row per step in :data:`CSV_ROW_FORMAT` (what
        ``numpy.savetxt`` writes with it, formatted from Python floats: about twice as quick)."""
        body = "\n".join([CSV_ROW_FORMAT % row for row in map(tuple, self.rows().tolist())])
        with open(path, "w", encoding="ascii", newline="\n") as f:
            f.write(",".join(COLUMNS) + "\n")
            f.write(body + "\n" if body else "")


CSV_ROW_FORMAT = ",".join(["%.3f", "%.8f", "%.8f"] + ["%.4f"] * 24 + ["%d", "%d"] + ["%.4f"] * 6)
"""A trajectory row's CSV format: time to the millisecond, latitude and longitude to 1e-8 degrees (about a
millimetre), the mode and the mission item as integers, the rest to 1e-4 of its unit."""


@jitable
def write_row(
    T: np.ndarray, i: int, t_s: float, lat_deg: float, lon_deg: float, alt_m: float, east_m: float, north_m: float,
    up_m: float, agl_m: float, ve: float, vn: float, vu: float, airspeed_mps: float, roll_rad: float, pitch_rad: float,
    yaw_rad: float, wind_e: float, wind_n: float, wind_u: float, pilot_roll: float, pilot_pitch: float,
    pilot_yaw: float, pilot_throttle: float, cmd_roll: float, cmd_pitch: float, cmd_yaw: float, cmd_throttle: float,
    mode: float, item: float, est_e: float, est_n: float, est_agl: float, wind_est_e: float, wind_est_n: float,
    activation_margin_m: float,
) -> None:  # fmt: skip
    """Row ``i`` of table ``T``, as :meth:`Recorder.append` writes it from the same values (the truth's fields, the
    wind, the pilot's and the sent sticks, the mode, the mission item, the unit's estimate and margin)."""
    row = T[i]
    row[0], row[1], row[2], row[3], row[4], row[5], row[6], row[7] = (
        t_s, lat_deg, lon_deg, alt_m, east_m, north_m, up_m, agl_m
    )  # fmt: skip
    row[8], row[9], row[10], row[11], row[12] = ve, vn, vu, hypot(ve, vn), airspeed_mps
    row[13], row[14], row[15] = roll_rad * _DEG, pitch_rad * _DEG, yaw_rad * _DEG
    row[16], row[17], row[18] = wind_e, wind_n, wind_u
    row[19], row[20], row[21], row[22] = pilot_roll, pilot_pitch, pilot_yaw, pilot_throttle
    row[23], row[24], row[25], row[26] = cmd_roll, cmd_pitch, cmd_yaw, cmd_throttle
    row[27], row[28] = mode, item
    row[29], row[30], row[31], row[32], row[33], row[34] = est_e, est_n, est_agl, wind_est_e, wind_est_n, activation_margin_m


def read_trajectory_csv(path: Path, required: tuple[str, ...] = ("time_s",)) -> dict[str, np.ndarray]:
    """A trajectory CSV read back into named columns, or a one-line :class:`ConfigError`: cut short (every
    row ends with a newline), not text, rows of different lengths, fewer than two rows, or without one of
    the ``required`` columns."""
    from geofence.validation import ConfigError

    try:
        with open(path, "rb") as f:
            head = f.read(4096)
            size = f.seek(0, os.SEEK_END)
            f.seek(max(0, size - 1))
            last = f.read(1)
        head.decode("ascii")
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a trajectory CSV (not text; binary?): re-fly the flight") from None
    if size == 0 or last != b"\n":
        raise ConfigError(f"{path}: cut short ({'empty' if size == 0 else 'its last row is incomplete'}): re-fly the flight")
    try:
        data = np.genfromtxt(path, delimiter=",", names=True)
        traj = {name: np.asarray(data[name], dtype=float) for name in data.dtype.names or ()}
    except (ValueError, UnicodeDecodeError, IndexError) as exc:
        why = " ".join(str(exc).split())[:120]
        raise ConfigError(f"{path}: not a complete trajectory CSV ({why}): re-fly the flight") from None
    missing = [c for c in required if c not in traj]
    if missing:
        raise ConfigError(f"{path}: not a trajectory CSV: no column {missing[0]!r} (header cut or another file?)")
    if traj["time_s"].ndim != 1 or len(traj["time_s"]) < 2:
        raise ConfigError(f"{path}: fewer than two rows: nothing to plot (re-fly the flight)")
    return traj
