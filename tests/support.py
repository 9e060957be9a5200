"""Helpers shared by the test modules (the one place they live: test modules do not import each other).

Twins: :func:`same_bits` (every field equal bit for bit) and :func:`fly_both_ways` (a flight compiled and on
the plain-Python reference, the same trajectory bytes).

Golden flights: a scenario under ``tests/data/golden/`` flown in closed loop, its trajectory sampled at
:data:`GOLDEN_STRIDE` and kept as ``<name>.csv`` beside it, compared with tolerances the way JSBSim's own
regression tests compare tables (:func:`compare_golden`).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
GOLDEN = DATA / "golden"
SHARED_REALWORLD = ROOT.parent / "shared" / "realworld"

GOLDEN_COLUMNS = (
    "time_s", "east_m", "north_m", "up_m", "v_east_mps", "v_north_mps", "v_up_mps", "cmd_roll", "cmd_pitch",
    "cmd_throttle", "geofence_mode", "activation_margin_m",
)  # fmt: skip
GOLDEN_STRIDE = 4
"""Every 4th outer-loop step (10 Hz at the 40 Hz outer loop)."""

GOLDEN_TOLERANCE = {
    "time_s": 1e-9, "east_m": 0.01, "north_m": 0.01, "up_m": 0.01, "v_east_mps": 0.01, "v_north_mps": 0.01,
    "v_up_mps": 0.01, "cmd_roll": 0.01, "cmd_pitch": 0.01, "cmd_throttle": 0.01, "geofence_mode": 0.0,
    "activation_margin_m": 0.01,
}  # fmt: skip
"""Absolute tolerance per column: 1 cm and 1 cm/s, a hundredth of a stick, the mode exactly."""


def golden_table(result) -> np.ndarray:
    """A flight's trajectory as the golden table: :data:`GOLDEN_COLUMNS` at every :data:`GOLDEN_STRIDE`-th row."""
    from scenarios.flight.recorder import COLUMN_INDEX

    data = result.recorder.data[: result.recorder.n]
    return data[::GOLDEN_STRIDE, [COLUMN_INDEX[c] for c in GOLDEN_COLUMNS]]


def write_golden(path: Path, table: np.ndarray) -> None:
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(GOLDEN_COLUMNS)
        w.writerows([repr(float(x)) for x in row] for row in table)


def read_golden(path: Path) -> np.ndarray:
    with path.open(newline="") as f:
        rows = list(csv.reader(f))
    assert tuple(rows[0]) == GOLDEN_COLUMNS, f"{path}: columns {rows[0]}"
    return np.array([[float(x) for x in row] for row in rows[1:]])


def compare_golden(got: np.ndarray, want: np.ndarray) -> list[str]:
    """The differences beyond :data:`GOLDEN_TOLERANCE`, one line per column (its worst row); empty when none."""
    if got.shape != want.shape:
        return [f"shape {got.shape} != golden {want.shape}"]
    problems = []
    for j, name in enumerate(GOLDEN_COLUMNS):
        a, b = got[:, j], want[:, j]
        same = (a == b) | (np.isnan(a) & np.isnan(b))  # equal infinities, or both not a number
        with np.errstate(invalid="ignore"):
            err = np.where(same, 0.0, np.abs(a - b))
        err = np.where(np.isnan(err), math.inf, err)
        k = int(np.argmax(err))
        if err[k] > GOLDEN_TOLERANCE[name]:
            problems.append(f"{name}: {a[k]!r} != golden {b[k]!r} at t = {want[k, 0]:.2f} s")
    return problems


def _bits(x) -> object:
    return x if isinstance(x, str) else float(x).hex()  # a float's exact value (and its sign, inf, nan)


def same_bits(a, b) -> bool:
    """Every field equal bit for bit (numpy or Python floats alike)."""
    return [_bits(x) for x in a] == [_bits(x) for x in b]


def fly_both_ways(sc):
    """The flight compiled and on the plain-Python reference (:func:`geofence.jit.use_compiled`); asserts the same
    trajectory bytes and returns both results."""
    from geofence.jit import use_compiled
    from scenarios.flight.runner import fly

    runs = []
    for on in (True, False):
        previous = use_compiled(on)
        try:
            runs.append(fly(sc))
        finally:
            use_compiled(previous)
    a, b = runs
    assert a.recorder.n == b.recorder.n > 0
    assert a.recorder.data.tobytes() == b.recorder.data.tobytes()
    return a, b
