"""Benchmark: batch throughput with --jobs 2 vs --jobs 1 (flights per second, measured in one run).

Flies the CI comparison suite (scenarios/ci: 24 flights, both platforms) into
fresh temporary folders, alternating job counts, and prints flights/s and the
speed-up (target >= 1.8x on 2 cores).

    python bench/batch.py [--repeats 2]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from scenarios.app.batch import discover, plan, run_batch

SUITE = Path(__file__).resolve().parents[1] / "scenarios" / "ci"


def throughput(jobs: int) -> float:
    specs = plan(discover([SUITE]))
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        outcome = run_batch(specs, Path(out), jobs=jobs, progress=False)
        wall = time.perf_counter() - t0
    assert not outcome.failed, outcome.failed
    return len(specs) / wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=2, help="alternating repeats, median reported (default 2)")
    args = ap.parse_args()
    one, two = [], []
    for _ in range(args.repeats):
        one.append(throughput(1))
        two.append(throughput(2))
    a, b = statistics.median(one), statistics.median(two)
    print(f"flights: {len(plan(discover([SUITE])))}")
    print(f"--jobs 1: {a:6.2f} flights/s")
    print(f"--jobs 2: {b:6.2f} flights/s")
    print(f"speed-up: {b / a:6.2f}x (target >= 1.8)")


if __name__ == "__main__":
    main()
