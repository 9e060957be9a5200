"""Benchmark: the closed loop's floor -- what a step costs when only JSBSim's own interface is left in Python.

The closed loop's target (``bench/closed_loop.py``: >= 0.6 of bare JSBSim with
the geofence in the loop) leaves a fixed time per outer-loop step beyond the
physics. This measures how much of it the parts no design can remove take,
and how much is left for the rest, side by side in one run (median of
interleaved repeats), on the Tern's (or ``--model``'s) adversarial geofence
flight:

* ``bare``: bare JSBSim with the flight controller, as ``bench/closed_loop.py``;
* ``replay``: the flight's recorded sticks and winds written before its frames,
  nothing else (the physics of that flight);
* ``floor + C us``: the truth read-out (13 property reads and the ENU
  conversion), one compiled call on its numbers that costs C us, the stick and
  wind writes and the frames: a loop whose pilot, sensing chain, geofence unit
  and recorder would be one compiled call of that cost.

It prints each as a ratio to bare, and the largest compiled call the target
allows (interpolated). The compiled call is a stand-in of calibrated cost (a
numba loop), not the testbed's code: the question is the budget, not the work.

    python bench/loop_floor.py [--model Tern] [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numba
import numpy as np

from aircraft.factory import build_platform
from scenarios.definition.schema import Scenario, load_scenario
from scenarios.flight.runner import fly

sys.path.insert(0, str(Path(__file__).parent))
from closed_loop import GEOFENCE_CASES, TARGET, bare_rate, positive  # noqa: E402  (one definition of bare and the target)

RECORDED = ("cmd_roll", "cmd_pitch", "cmd_yaw", "cmd_throttle", "wind_east_mps", "wind_north_mps", "wind_up_mps")
CALL_ITERATIONS = (0, 1000, 2500, 5000, 10000)
"""Iterations of the stand-in compiled call (calibrated to microseconds in the run)."""


@numba.njit(cache=False)
def _stand_in(state, t, lat, lon, alt, ve, vn, vu, roll, pitch, yaw, airspeed, agl, east, iterations):  # pragma: no cover
    """A compiled call with the truth's numbers in and four numbers out, costing about ``iterations`` steps."""
    x = t + lat + lon + alt + ve + vn + vu + roll + pitch + yaw + airspeed + agl + east
    for q in range(iterations):
        x = x * 0.999 + state[q % state.size] * 1e-12
    state[0] = x
    return x, ve, vn, vu


def recorded_inputs(sc: Scenario) -> list[list[float]]:
    """The flight's sticks and winds, a row per step (flown once here)."""
    rec = fly(sc).recorder
    return np.stack([rec.column(name) for name in RECORDED], axis=1).tolist()


def loop_rate(sc: Scenario, rows: list[list[float]], iterations: int | None, call) -> float:
    """JSBSim frames/s of the replay (``iterations`` None) or of the floor loop with the stand-in call."""
    platform = build_platform(sc.profile)
    st = sc.start
    platform.set_wind_enu(*rows[0][4:])
    platform.reset(sc.frame, st.lat_deg, st.lon_deg, st.agl_m, st.heading_deg, st.airspeed_mps)
    frames = sc.frames_per_step
    truth, command, set_wind, run = platform.truth, platform.command, platform.model.set_wind_enu, platform.model.fdm.run
    state = np.zeros(64)
    t0 = time.perf_counter()
    if iterations is None:
        for row in rows:
            command(row[:4])
            set_wind(*row[4:])
            for _ in range(frames):
                run()
    else:
        for row in rows:
            s = truth()
            call(
                state, s.t_s, s.lat_deg, s.lon_deg, s.alt_m, s.v_east_mps, s.v_north_mps, s.v_up_mps, s.roll_rad,
                s.pitch_rad, s.yaw_rad, s.airspeed_mps, s.agl_m, s.east_m, iterations,
            )  # fmt: skip
            command(row[:4])
            set_wind(*row[4:])
            for _ in range(frames):
                run()
    return frames * len(rows) / (time.perf_counter() - t0)


def call_us(call, iterations: int, calls: int = 20000) -> float:
    state = np.zeros(64)
    args = (state, *([1.0] * 13), iterations)
    t0 = time.perf_counter()
    for _ in range(calls):
        call(*args)
    return 1e6 * (time.perf_counter() - t0) / calls


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", choices=sorted(GEOFENCE_CASES), default="Tern", help="platform (default Tern)")
    ap.add_argument("--seconds", type=positive(float), default=60.0, help="simulated seconds of the flight (default 60)")
    ap.add_argument("--repeats", type=positive(int), default=5, help="interleaved repeats, median reported (default 5)")
    args = ap.parse_args()
    sc = replace(load_scenario(GEOFENCE_CASES[args.model]), duration_s=args.seconds)
    rows = recorded_inputs(sc)
    _stand_in(np.zeros(64), *([1.0] * 13), 1)
    call = next(iter(_stand_in.overloads.values())).entry_point  # as the testbed's kernels are called
    bare, replay = [], []
    floors: dict[int, list[float]] = {n: [] for n in CALL_ITERATIONS}
    for _ in range(args.repeats):
        bare.append(bare_rate(args.model, len(rows) * sc.frames_per_step, with_fc=True))
        replay.append(loop_rate(sc, rows, None, call))
        for n in CALL_ITERATIONS:
            floors[n].append(loop_rate(sc, rows, n, call))
    b = statistics.median(bare)
    print(f"{args.model}: bare {b:.0f} frames/s ({1e6 / b:.2f} us a frame); ratios to bare:")
    print(f"  replay of the flight's sticks and winds      {statistics.median(replay) / b:.3f}")
    points = []
    for n in CALL_ITERATIONS:
        us = call_us(call, n)
        ratio = statistics.median(floors[n]) / b
        points.append((us, ratio))
        print(f"  floor + a compiled call of {us:5.1f} us          {ratio:.3f}")
    below = [(u, r) for u, r in points if r < TARGET]
    above = [(u, r) for u, r in points if r >= TARGET]
    if above and below:
        (u0, r0), (u1, r1) = max(above), min(below)
        allowed = u0 + (TARGET - r0) * (u1 - u0) / (r1 - r0)
        print(f"at {TARGET} of bare, one compiled call per step may take about {allowed:.0f} us")
    elif above:
        print(f"every call measured keeps the loop at {TARGET} of bare or more")
    else:
        print(f"no call measured keeps the loop at {TARGET} of bare")


if __name__ == "__main__":
    main()
