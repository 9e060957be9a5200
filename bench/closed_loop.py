"""Benchmark: closed-loop JSBSim frames per second vs bare JSBSim on the same model.

For each platform it measures, interleaved in one run (repeats, median):

* ``bare``: the same JSBSim model (with its flight-controller system) stepped
  by ``fdm.run()`` in a tight Python loop, no guidance, no wind, no recording;
* ``shipped``: the model as it ships, without our flight controller (reference);
* ``closed``: the full closed loop of ``scenarios.flight.runner.fly`` (pilot,
  wind field, recorder, outer loop at the scenario's control rate);
* ``geofence``: the same with the geofence unit in the loop (an adversarial
  pilot against a fence, so the override and its guidance run too).

It prints frames/s for each and the ratios to bare (target >= 0.6 with the
geofence). The closed-loop rates are those of the stepping loop, measured as
bare JSBSim's are (``loop_wall_time_s`` of the flight's summary: no model or
fence loading); the last column gives the whole flight's (loading the model
and the fence, and scoring the flight, included) for the same runs.

    python bench/closed_loop.py [--seconds 60] [--repeats 9]
"""

from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import replace
from pathlib import Path

from aircraft.factory import build_platform
from aircraft.jsbsim_model import JSBSimModel
from geofence.geometry.geodesy import LocalFrame
from scenarios.definition.schema import load_scenario
from scenarios.flight.runner import fly

ROOT = Path(__file__).resolve().parents[1]
CASES = {
    "F450": ROOT / "scenarios" / "multicopter_survey_wind.yaml",
    "Tern": ROOT / "scenarios" / "fixedwing_survey_wind.yaml",
}
GEOFENCE_CASES = {
    "F450": ROOT / "scenarios" / "geofence_multicopter_adversarial_wind.yaml",
    "Tern": ROOT / "scenarios" / "geofence_fixedwing_adversarial_wind.yaml",
}
TARGET = 0.6
"""Closed loop with the geofence, its sensors and estimators, over bare JSBSim with the flight controller."""


def positive(kind: type):
    """An argparse type: a number of ``kind`` above 0 (else argparse's one-line error and exit 2)."""

    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not value > 0:
            raise argparse.ArgumentTypeError(f"{text} must be above 0")
        return value

    return parse


def bare_rate(model: str, frames: int, with_fc: bool) -> float:
    platform = build_platform(model)
    sc = load_scenario(CASES[model])
    st = sc.start
    frame = LocalFrame(st.lat_deg, st.lon_deg, st.ground_alt_m)
    if with_fc:
        platform.reset(frame, st.lat_deg, st.lon_deg, max(st.agl_m, 30.0), st.heading_deg, st.airspeed_mps)
        fdm = platform.model.fdm
    else:
        m = JSBSimModel(model, dt_s=platform.dt_s)
        m.reset(frame, st.lat_deg, st.lon_deg, max(st.agl_m, 30.0), st.heading_deg, platform.envelope.cruise_speed_mps)
        fdm = m.fdm
    run = fdm.run
    t0 = time.perf_counter()
    for _ in range(frames):
        run()
    return frames / (time.perf_counter() - t0)


def closed_rate(path: Path, seconds: float) -> tuple[float, float]:
    """``(frames/s of the stepping loop, frames/s of the whole flight)``: the loop alone is measured as bare
    JSBSim is (no model loading); the whole flight adds loading the model and the fence and scoring it."""
    res = fly(replace(load_scenario(path), duration_s=seconds))
    frames = res.summary["jsbsim_frames"]
    return frames / res.summary["loop_wall_time_s"], frames / res.summary["wall_time_s"]


def budget_line(model: str, bare_fps: float, fenced_fps: float, frames: int, target: float = TARGET) -> str:
    """Where the geofence flight's step goes, from the rates measured: the bare physics of its frames, the
    rest (everything the loop adds, including the caches the physics loses to it), and what ``target`` allows."""
    physics_us = 1e6 * frames / bare_fps
    step_us = 1e6 * frames / fenced_fps
    allowed_us = physics_us / target
    return (
        f"{model}: {frames} frames a step; bare physics {physics_us:.1f} us, the geofence flight's step {step_us:.1f} us"
        f" ({step_us - physics_us:.1f} us beyond the bare physics); at {target} of bare a step may take"
        f" {allowed_us:.1f} us ({allowed_us - physics_us:.1f} us beyond)"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=positive(float), default=60.0, help="simulated seconds per closed-loop run (default 60)")
    ap.add_argument(
        "--repeats",
        type=positive(int),
        default=9,
        help="interleaved repeats, median reported (default 9: a 60 s flight takes well under a second)",
    )
    args = ap.parse_args()
    print(
        f"{'model':6s} {'shipped f/s':>12s} {'bare+FC f/s':>12s} {'closed f/s':>11s} {'+geofence':>10s}"
        f" {'closed/bare':>12s} {'geofence/bare':>14s}"
        f" {'closed/shipped':>15s}"
        f" {'whole flight: closed, +geofence /bare':>38s}"
    )
    budgets = []
    for model in CASES:
        shipped, bare, closed, fenced, closed_all, fenced_all = [], [], [], [], [], []
        for _ in range(args.repeats):
            loop, whole = closed_rate(CASES[model], args.seconds)
            closed.append(loop)
            closed_all.append(whole)
            loop, whole = closed_rate(GEOFENCE_CASES[model], args.seconds)
            fenced.append(loop)
            fenced_all.append(whole)
            frames = int(args.seconds * 120)
            bare.append(bare_rate(model, frames, with_fc=True))
            shipped.append(bare_rate(model, frames, with_fc=False))
        s, b, c, g, ca, ga = (statistics.median(x) for x in (shipped, bare, closed, fenced, closed_all, fenced_all))
        print(
            f"{model:6s} {s:12.0f} {b:12.0f} {c:11.0f} {g:10.0f} {c / b:12.2f} {g / b:14.2f}"
            f" {c / s:15.2f} {ca / b:27.2f}, {ga / b:.2f}"
        )
        budgets.append(budget_line(model, b, g, load_scenario(GEOFENCE_CASES[model]).frames_per_step))
    print("\nper outer-loop step (from the medians above):")
    for line in budgets:
        print("  " + line)


if __name__ == "__main__":
    main()
