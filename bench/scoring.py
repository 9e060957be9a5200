"""Benchmark: breach-scoring throughput (samples per second) on synthetic flights.

Scores 1e6 to 1e7 recorded samples (flights of 36 000 samples = 15 min at
40 Hz, wandering in and out of the fence, with override episodes) against
fences of 6, 12 and 20 keep-in vertices (the 20-vertex one also with a
keep-out circle, a keep-out polygon, a floor and a floor gap), three ways:

* ``score_many``: all flights in one vectorized call (the batch path);
* ``per flight``: ``score_flight`` flight by flight;
* ``baseline``: the 3-D margin alone from ``LocalFence.margin_array`` (the
  polygon's own vectorized signed distance), for comparison.

Prints samples/s (best of ``--repeats``). Target: score_many >= 5e6 samples/s.

    python bench/scoring.py [--repeats 3] [--threads N] [--sizes 1e6 3e6 1e7]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from analysis.fast_margins import default_threads
from analysis.scoring import score_flight, score_many
from geofence.geometry.fence import Fence, KeepOutCircle

LAT0, LON0 = -35.3626, 149.1652
FLIGHT_SAMPLES = 36_000


def _ll(e: float, n: float) -> tuple[float, float]:
    return LAT0 + n / 111_320.0, LON0 + e / (111_320.0 * math.cos(math.radians(LAT0)))


def _star(k: int, r: float, ce: float = 0.0, cn: float = 0.0) -> list[tuple[float, float]]:
    """A non-convex k-vertex outline of mean radius r (m) around (ce, cn)."""
    ang = np.linspace(0.0, 2.0 * np.pi, k, endpoint=False)
    rad = r * (1.0 + 0.2 * np.cos(3.0 * ang))
    return [_ll(ce + q * math.cos(a), cn + q * math.sin(a)) for a, q in zip(ang, rad)]


def fences():
    yield "6 vertices", Fence(keep_in=_star(6, 300.0), ceiling_m=60.0).to_local()
    yield "12 vertices", Fence(keep_in=_star(12, 300.0), ceiling_m=60.0).to_local()
    yield (
        "20 vertices + keep-outs + floor gap",
        Fence(
            keep_in=_star(20, 300.0),
            ceiling_m=60.0,
            floor_m=5.0,
            floor_gaps=[_star(6, 30.0, -80.0, -60.0)],
            keep_out_polygons=[_star(5, 25.0, 90.0, 40.0)],
            keep_out_circles=[KeepOutCircle(*_ll(-60.0, 120.0), 20.0)],
        ).to_local(),
    )


def flights(total: int, seed: int = 1) -> list[dict[str, np.ndarray]]:
    rng = np.random.default_rng(seed)
    out = []
    for i in range(max(1, total // FLIGHT_SAMPLES)):
        t = np.arange(FLIGHT_SAMPLES) * 0.025
        a, b = rng.uniform(30.0, 70.0, 2)
        e = 330.0 * np.sin(t / a + i)
        n = 330.0 * np.cos(t / b + 2 * i)
        ve, vn = np.gradient(e, t), np.gradient(n, t)
        mode = np.where(np.sin(t / 5.0 + i) > 0.8, 1.0, 0.0)
        mode[(mode == 0) & (np.roll(mode, 40) == 1)] = 2.0
        out.append(
            {
                "time_s": t,
                "east_m": e,
                "north_m": n,
                "agl_m": 30.0 + 28.0 * np.sin(t / 9.0),
                "alt_m": 600.0 + 30.0 * np.sin(t / 9.0),
                "v_east_mps": ve,
                "v_north_mps": vn,
                "ground_speed_mps": np.hypot(ve, vn),
                "geofence_mode": mode,
            }
        )
    return out


def best_rate(fn, samples: int, repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return samples / best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3, help="timed repeats, best reported (default 3)")
    ap.add_argument("--threads", type=int, default=None, help=f"margin threads (default {default_threads()})")
    ap.add_argument("--sizes", type=float, nargs="+", default=[1e6, 3e6, 1e7], help="sample counts")
    args = ap.parse_args()
    print(f"threads: {args.threads or default_threads()}, flights of {FLIGHT_SAMPLES} samples")
    print(f"{'fence':38s} {'samples':>10s} {'score_many':>13s} {'per flight':>13s} {'baseline':>13s}   (samples/s)")
    for name, fence in fences():
        for size in args.sizes:
            fl = flights(int(size))
            n = sum(len(f["time_s"]) for f in fl)
            many = best_rate(lambda: score_many(fl, fence, threads=args.threads), n, args.repeats)
            one = best_rate(lambda: [score_flight(f, fence) for f in fl], n, args.repeats)
            if size <= 1e6:
                base = best_rate(
                    lambda: [fence.margin_array(np.column_stack([f["east_m"], f["north_m"]]), f["agl_m"]) for f in fl], n, 1
                )
                base_s = f"{base:13.3g}"
            else:
                base_s = f"{'-':>13s}"
            print(f"{name:38s} {n:10.3g} {many:13.3g} {one:13.3g} {base_s}", flush=True)


if __name__ == "__main__":
    main()
