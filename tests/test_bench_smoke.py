"""Every bench/ script runs end to end on a tiny workload (exit 0, its table printed); nothing here is timed.

The performance targets live in the scripts themselves (ratios measured side by side in one run); this
only keeps them runnable: component_costs.py once broke when the wind sources began refusing time that
goes backwards between repeats, and nothing noticed.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).parents[1] / "bench"


@pytest.mark.parametrize(
    "script, args, expect",
    [
        ("component_costs.py", ["--calls", "20", "--repeats", "2"], "JSBSim frames"),
        ("closed_loop.py", ["--seconds", "1", "--repeats", "1"], "beyond the bare physics"),
        ("loop_floor.py", ["--seconds", "1", "--repeats", "1"], "floor + a compiled call"),
        ("fence_scale.py", ["--quick", "--sizes", "4x0,100x0", "--repeats", "1", "--out", "{tmp}/fs.png"], "figure:"),
        ("scoring.py", ["--repeats", "1", "--sizes", "2000"], "samples"),
        ("whole_batch.py", ["--limit", "2"], "per job / bare"),
    ],
)
def test_bench_script_runs_on_a_tiny_workload(script, args, expect, tmp_path):
    cmd = [sys.executable, str(BENCH / script), *(a.format(tmp=tmp_path) for a in args)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert expect in r.stdout, r.stdout[-2000:]
