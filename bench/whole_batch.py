"""Benchmark: a whole batch of campaign flights against bare JSBSim stepping the same models' frames.

Flies the predictive flights of a campaign folder (default: the committed CI slice, ``scenarios/campaign_ci``) with
``batch`` (model and fence loading, the geofence, recording, scoring, writing each flight's folder: everything a
campaign pays), then steps bare JSBSim (each model with its flight controller, loaded once, ``fdm.run()`` in a
tight loop, no guidance) for the same number of frames per model, in the same run. It prints:

* the whole batch's JSBSim frames per wall second over bare JSBSim's (issue 39's target: >= 0.6, both kinds), with
  every trajectory written and with ``--trajectories notable`` (the campaign-scale setting), after the same batch
  flown once to warm up (a worker loads its compiled kernels once: its time printed apart);
* per platform kind, the same ratio from each flight's own wall time (``wall_time_s`` of its summary);
* the campaign throughput: simulated flight hours per wall hour, and per hour on every core at this rate.

    python bench/whole_batch.py [--folder scenarios/campaign_ci] [--jobs 1] [--limit N]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from aircraft.factory import build_platform
from aircraft.profile import load_profile
from geofence.geometry.geodesy import LocalFrame
from scenarios.app.batch import Trajectories, discover, plan, run_batch
from scenarios.definition.schema import parse_scenario

ROOT = Path(__file__).resolve().parents[1]
TARGET = 0.6


def bare_seconds(aircraft: str, frames: int, start) -> float:
    """Wall seconds bare JSBSim takes to step ``frames`` frames of ``aircraft`` (its flight controller on)."""
    platform = build_platform(aircraft)
    frame = LocalFrame(start.lat_deg, start.lon_deg, start.ground_alt_m)
    platform.reset(frame, start.lat_deg, start.lon_deg, max(start.agl_m, 30.0), start.heading_deg, start.airspeed_mps)
    run = platform.model.fdm.run
    t0 = time.perf_counter()
    for _ in range(frames):
        run()
    return time.perf_counter() - t0


def fly_batch(specs, jobs: int, trajectories: Trajectories) -> tuple[float, list[dict]]:
    """A batch of ``specs`` into a temporary folder: ``(its wall seconds, the flights' summaries)``."""
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        outcome = run_batch(specs, Path(out), jobs=jobs, progress=False, trajectories=trajectories)
        wall_s = time.perf_counter() - t0
        summaries = [json.loads(p.read_text()) for p in Path(out).glob("*/summary.json")]
    assert not outcome.failed, outcome.failed
    return wall_s, summaries


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--folder", type=Path, default=ROOT / "scenarios" / "campaign_ci", help="a campaign folder")
    ap.add_argument("--variant", default="predictive", help="which variant's files to fly (default predictive)")
    ap.add_argument("--jobs", type=int, default=1, help="batch worker processes (default 1: one core)")
    ap.add_argument("--limit", type=int, default=0, help="fly only the first N files (default: all)")
    args = ap.parse_args()
    files = sorted(args.folder.glob(f"*__{args.variant}.yaml"))[: args.limit or None]
    if not files:
        ap.error(f"{args.folder}: no *__{args.variant}.yaml files")
    specs = plan(discover(files))
    warm_s, _ = fly_batch(specs, 1, Trajectories.ALL)  # (this process's kernels loaded from the cache)
    wall_s, summaries = fly_batch(specs, args.jobs, Trajectories.ALL)
    notable_s, _ = fly_batch(specs, args.jobs, Trajectories.NOTABLE)
    frames: dict[str, int] = defaultdict(int)
    kinds: dict[str, str] = {}
    starts, own_wall, sim_s = {}, defaultdict(float), 0.0
    by_name = {s["scenario"]: s for s in summaries}
    for spec in specs:
        s = by_name[spec.flight_id]
        sc = parse_scenario(spec.document, spec.flight_id)
        frames[sc.aircraft] += int(s["jsbsim_frames"])
        kinds[sc.aircraft] = load_profile(sc.aircraft).kind.value
        starts.setdefault(sc.aircraft, sc.start)
        own_wall[sc.aircraft] += float(s["wall_time_s"])
        sim_s += float(s["sim_time_s"])
    bare = {a: bare_seconds(a, n, starts[a]) for a, n in frames.items()}
    total, bare_s = sum(frames.values()), sum(bare.values())
    print(f"{len(specs)} flights, {total} JSBSim frames, {sim_s / 3600:.2f} simulated flight hours, --jobs {args.jobs}")
    print(f"warm-up: the same batch first, {warm_s:.2f} s (each kernel's machine code loaded from the cache: once a worker)")
    print(f"bare JSBSim: {total / bare_s:,.0f} frames/s ({bare_s:.1f} s)")
    for label, w in (("every trajectory written", wall_s), ("--trajectories notable", notable_s)):
        per_job = bare_s / (w * args.jobs)  # (bare JSBSim steps on one core)
        print(f"whole batch, {label}: {total / w:,.0f} frames/s in {w:.2f} s; per job / bare = {per_job:.2f} "
              f"(target >= {TARGET})")  # fmt: skip
    for kind in sorted(set(kinds.values())):
        names = [a for a in frames if kinds[a] == kind]
        n = sum(frames[a] for a in names)
        r = sum(bare[a] for a in names) / sum(own_wall[a] for a in names)
        print(f"  {kind}: {n} frames, flights' own wall time / bare = {r:.2f} ({', '.join(sorted(names))})")
    cores = os.cpu_count() or 1
    for label, w in (("every trajectory", wall_s), ("notable", notable_s)):
        per_core = (sim_s / w) / max(args.jobs, 1)
        print(f"throughput, {label}: {sim_s / w:.0f} flight h per wall h; at this rate {per_core * cores:.0f} "
              f"flight h per h on {cores} cores (target >= 600 on 2)")  # fmt: skip


if __name__ == "__main__":
    main()
