"""Benchmark: a whole batch of campaign flights against bare JSBSim stepping the same models' frames.

Flies the predictive flights of a campaign folder (default: the committed CI slice, ``scenarios/campaign_ci``) with
``batch`` (model and fence loading, the geofence, recording, scoring, writing each flight's folder: everything a
campaign pays), then steps bare JSBSim (each model with its flight controller, loaded once, ``fdm.run()`` in a
tight loop, no guidance) for the same number of frames per model, in the same run. It prints:

* the whole batch's JSBSim frames per wall second over bare JSBSim's (issue 39's target: >= 0.6, both kinds);
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
from scenarios.app.batch import discover, plan, run_batch
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
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        outcome = run_batch(specs, Path(out), jobs=args.jobs, progress=False)
        wall_s = time.perf_counter() - t0
        summaries = [json.loads(p.read_text()) for p in Path(out).glob("*/summary.json")]
    assert not outcome.failed, outcome.failed
    frames: dict[str, int] = defaultdict(int)
    kinds: dict[str, str] = {}
    starts, own_wall, sim_s = {}, defaultdict(float), 0.0
    for spec, s in zip(specs, sorted(summaries, key=lambda s: [sp.flight_id for sp in specs].index(s["scenario"]))):
        sc = parse_scenario(spec.document, spec.flight_id)
        frames[sc.aircraft] += int(s["jsbsim_frames"])
        kinds[sc.aircraft] = load_profile(sc.aircraft).kind.value
        starts.setdefault(sc.aircraft, sc.start)
        own_wall[sc.aircraft] += float(s["wall_time_s"])
        sim_s += float(s["sim_time_s"])
    bare = {a: bare_seconds(a, n, starts[a]) for a, n in frames.items()}
    total = sum(frames.values())
    ratio = (total / wall_s) / (total / sum(bare.values()))
    print(f"{len(specs)} flights, {total} JSBSim frames, {sim_s / 3600:.2f} simulated flight hours, --jobs {args.jobs}")
    print(f"whole batch: {total / wall_s:,.0f} frames/s in {wall_s:.1f} s wall; bare JSBSim: "
          f"{total / sum(bare.values()):,.0f} frames/s ({sum(bare.values()):.1f} s)")  # fmt: skip
    print(f"whole batch / bare = {ratio:.2f} (target >= {TARGET})")
    for kind in sorted(set(kinds.values())):
        names = [a for a in frames if kinds[a] == kind]
        n = sum(frames[a] for a in names)
        r = (n / sum(own_wall[a] for a in names)) / (n / sum(bare[a] for a in names))
        print(f"  {kind}: {n} frames, flights' own wall time / bare = {r:.2f} ({', '.join(sorted(names))})")
    per_core = (sim_s / 3600) / (wall_s / 3600) / max(args.jobs, 1)
    print(f"throughput: {sim_s / wall_s:.0f} flight h per wall h; at this rate {per_core * (os.cpu_count() or 1):.0f} "
          f"flight h per h on {os.cpu_count()} cores (target >= 600 on 2)")  # fmt: skip


if __name__ == "__main__":
    main()
