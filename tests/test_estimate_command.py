"""The ``estimate`` command: its refusals, and a tiny subset simulation and Monte Carlo flown closed-loop."""

import json
import math

import pytest

from scenarios.app.cli import main


@pytest.mark.parametrize(
    "args, expected",
    [
        (["--samples", "0"], "--samples: must be 1..100000 flights, got 0"),
        (["--samples", "101"], "--samples/--p0/--max-levels: subset simulation: p0 0.1 x N 101 must be a whole number"),
        (["--p0", "0.9"], "--p0: must be in (0, 0.5], got 0.9"),
        (["--max-levels", "0"], "max_levels must be 1..30, got 0"),
        (["--below-m", "nan"], "--below-m: must be a finite margin"),
        (["--platform", "Wright_Flyer"], "no platform profile for aircraft 'Wright_Flyer'"),
        (["--executor", "dask"], "--executor dask: give the cluster with --scheduler ADDRESS"),
    ],
)
def test_bad_arguments_are_refused_in_one_line(tmp_path, capsys, args, expected):
    base = {"--platform": "F450", "--variant": "reactive", "--out": str(tmp_path / "out")}
    base.update(dict(zip(args[::2], args[1::2])))
    code = main(["estimate", *[t for kv in base.items() for t in kv]])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and expected in err, err
    assert not (tmp_path / "out").exists()


@pytest.mark.closed_loop
def test_a_tiny_subset_simulation_multiplies_its_levels_and_resumes_without_refling(tmp_path, capsys):
    out = tmp_path / "est"
    argv = ["estimate", "--platform", "F450", "--variant", "reactive", "--below-m", "-60", "--samples", "10", "--p0", "0.2"]
    argv += ["--max-levels", "2", "--out", str(out), "--jobs", "1", "--max-duration-s", "30"]
    assert main(argv) == 0
    console = capsys.readouterr().out
    record = json.loads((out / "estimate.json").read_text())
    levels = record["levels"]
    assert record["flights"] == 10 + 8 * (len(levels) - 1) == len(record["evaluations"])
    assert record["probability"] == pytest.approx(math.prod(lv["probability"] for lv in levels))
    thresholds = [lv["threshold"] for lv in levels]
    assert thresholds == sorted(thresholds, reverse=True)
    margins = [e["margin_m"] for e in record["evaluations"]]
    assert all(e["completed"] for e in record["evaluations"]) and min(margins) < 0.0  # the reactive fence breaches
    assert f"P[min margin <= -60 m] = {record['probability']:.3g}" in console
    assert "uniform and independent" in record["input_distribution"]
    assert (out / "estimate.png").stat().st_size > 10_000
    stamps = {p: p.stat().st_mtime_ns for p in (out / "flights").glob("*/summary.json")}
    assert len(stamps) == record["flights"]
    assert main(argv) == 0  # deterministic: the same command asks for the same flights, all already flown
    assert {p: p.stat().st_mtime_ns for p in (out / "flights").glob("*/summary.json")} == stamps
    assert json.loads((out / "estimate.json").read_text())["probability"] == record["probability"]


@pytest.mark.closed_loop
def test_monte_carlo_counts_the_flights_in_the_event_with_an_exact_interval(tmp_path, capsys):
    out = tmp_path / "mc"
    argv = ["estimate", "--platform", "F450", "--variant", "reactive", "--method", "monte-carlo", "--samples", "8"]
    assert main([*argv, "--below-m", "0", "--out", str(out), "--jobs", "1", "--max-duration-s", "30"]) == 0
    record = json.loads((out / "estimate.json").read_text())
    k = sum(e["margin_m"] <= 0.0 for e in record["evaluations"])
    assert record["probability"] == k / 8 and record["flights"] == 8
    low, high = record["interval_95"]
    assert low <= k / 8 <= high


@pytest.mark.closed_loop
def test_the_estimate_flies_on_a_dask_cluster_as_on_processes(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    argv = ["estimate", "--platform", "F450", "--variant", "reactive", "--method", "monte-carlo", "--samples", "4"]
    argv += ["--below-m", "0", "--max-duration-s", "20"]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        assert main([*argv, "--out", str(tmp_path / "dask"), "--executor", "dask", "--scheduler", cluster.scheduler_address]) == 0
    assert main([*argv, "--out", str(tmp_path / "local"), "--jobs", "1"]) == 0
    on_dask, local = (json.loads((tmp_path / d / "estimate.json").read_text()) for d in ("dask", "local"))
    assert [e["margin_m"] for e in on_dask["evaluations"]] == [e["margin_m"] for e in local["evaluations"]]
    assert on_dask["probability"] == local["probability"] and on_dask["flights"] == 4
