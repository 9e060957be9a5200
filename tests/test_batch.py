"""Batches: parallel, loss-free, resumable; sweeps expand reproducibly; failures are recorded."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from analysis.campaign_report import peak_sustained_wind_mps
from geofence.validation import ConfigError
from scenarios.app.batch import Trajectories, discover, notable, plan, run_batch
from scenarios.definition.sweep import expand

ROOT = Path(__file__).parents[1]
CI_SUITE = ROOT / "scenarios" / "ci"


def summaries(out: Path) -> dict[str, dict]:
    return {p.parent.name: json.loads(p.read_text()) for p in out.glob("*/summary.json")}


def test_grid_and_monte_carlo_expand_reproducibly():
    base = yaml.safe_load((CI_SUITE / "multicopter_edges.yaml").read_text())
    base["sweep"]["monte_carlo"] = {
        "count": 3,
        "seed": 4,
        "draws": {"seed": {"integers": [0, 1000]}, "wind.from_deg": {"uniform": [0, 360]}},
    }
    a = expand(base, "x.yaml", "x")
    b = expand(base, "x.yaml", "x")
    assert len(a) == 4 * 3 * 3
    assert [s.document for s in a] == [s.document for s in b]
    assert len({s.flight_id for s in a}) == len(a)
    assert {s.document["wind"]["speed_mps"] for s in a} == set(base["sweep"]["grid"]["wind.speed_mps"])
    assert len({s.document["seed"] for s in a}) > 1


@pytest.mark.parametrize(
    "sweep, problem",
    [
        ({"grid": {"wind.speed_mps": []}}, "non-empty list"),
        ({"monte_carlo": {"draws": {"seed": {"gaussian": [0, 1]}}}}, "exactly one of"),
        ({"grid": {"pilot.segments.7.course_deg": [0]}}, "no such place"),
        ({"repeat": 3}, "repeat: unknown key"),
    ],
)
def test_bad_sweeps_name_the_field(sweep, problem):
    base = yaml.safe_load((CI_SUITE / "multicopter_edges.yaml").read_text())
    base["sweep"] = sweep
    with pytest.raises(ConfigError, match=problem):
        expand(base, "x.yaml", "x")


def test_failed_scenarios_are_recorded_and_the_batch_goes_on(tmp_path):
    good = yaml.safe_load((CI_SUITE / "multicopter_edges.yaml").read_text())
    good["sweep"] = {"grid": {"wind.speed_mps": [0]}}
    good["duration_s"] = 5
    (tmp_path / "good.yaml").write_text(yaml.safe_dump(good))
    (tmp_path / "broken.yaml").write_text("aircraft: [F450\n")
    bad_value = dict(good, name="latitude_123")
    bad_value.pop("sweep")
    bad_value["start"] = dict(good["start"], lat_deg=123)
    (tmp_path / "bad_value.yaml").write_text(yaml.safe_dump(bad_value))
    specs = plan(discover([tmp_path]))
    out = tmp_path / "out"
    outcome = run_batch(specs, out, jobs=1, progress=False)
    got = summaries(out)
    assert outcome.flown == 3 and len(outcome.failed) == 2
    assert got["broken"]["completed"] is False and "malformed YAML" in got["broken"]["error"]
    assert got["latitude_123"]["completed"] is False and "start.lat_deg" in got["latitude_123"]["error"]
    assert got["ci_multicopter__speed_mps=0"]["completed"] is True


def test_ci_suite_batch_on_two_jobs_writes_every_result_and_no_breach(tmp_path):
    out = tmp_path / "ci"
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "scenarios.app.cli",
            "batch",
            str(CI_SUITE),
            "--out",
            str(out),
            "--jobs",
            "2",
            "--quiet",
            "--no-flight-plots",
        ],  # (a flight's figure is tested in test_outputs.py; 24 of them cost a third of this test)
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stdout + res.stderr
    got = summaries(out)
    assert len(got) == 24
    rows = (out / "results.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + 24
    assert (out / "report.md").is_file()
    assert list(out.glob("*.png")), "batch figures missing"
    assert not list(out.glob("*/flight.png")), "--no-flight-plots drew a flight figure"
    for name, s in got.items():
        assert s["completed"], name
        assert s["max_excursion_m"] <= 0.0, f"{name}: breach of {s['max_excursion_m']:.2f} m"
        assert not s["landed_outside_gap"], name
    platforms = {s["aircraft"] for s in got.values()}
    assert platforms == {"F450RD", "Tern"}
    # the suite tests what it says: every flight really approached its edge, the ceiling and the floor
    from support import assert_ci_suite_approaches

    assert_ci_suite_approaches(out)


def test_interrupted_batch_keeps_finished_flights_and_resumes_without_refling(tmp_path):
    sweep = yaml.safe_load((CI_SUITE / "multicopter_edges.yaml").read_text())
    sweep["duration_s"] = 600  # slow enough (~1 s of wall time each) to interrupt halfway
    sweep["sweep"] = {"grid": {"pilot.segments.0.course_deg": [0, 90, 180, 270], "wind.speed_mps": [0, 4, 8]}}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(sweep))
    out = tmp_path / "out"
    cmd = [
        sys.executable,
        "-m",
        "scenarios.app.cli",
        "batch",
        str(tmp_path / "s.yaml"),
        "--out",
        str(out),
        "--jobs",
        "2",
        "--quiet",
        "--no-flight-plots",
    ]
    # a background job inherits an ignored SIGINT; give the batch the default, as in a terminal
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.monotonic() + 300
    while len(list(out.glob("*/summary.json"))) < 4 and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    stdout, err = proc.communicate(timeout=300)
    first = summaries(out)
    assert 4 <= len(first) < 12, f"{len(first)} flights finished before the interrupt"
    assert proc.returncode == 130, err
    # the console counts the folders written (the flights in the air when Ctrl-C came landed and count)
    assert f"12 flights: 0 already done, {len(first)} flown" in stdout, stdout + err
    from analysis.report import read_results_csv

    assert {(r["batch_partial"], r["batch_flights"]) for r in read_results_csv(out / "results.csv")} == {
        (True, f"{len(first)}/12")
    }
    assert f"**Partial batch: {len(first)} of 12 planned flights have results**" in (out / "report.md").read_text()
    stamps = {name: (out / name / "summary.json").stat().st_mtime_ns for name in first}
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    assert f"{len(first)} already done" in res.stdout
    final = summaries(out)
    assert len(final) == 12 and all(s["completed"] for s in final.values())
    assert all((out / name / "summary.json").stat().st_mtime_ns == t for name, t in stamps.items())
    assert not list(out.rglob(".*.tmp")), "a half-written file was left behind"
    assert "batch_partial" not in read_results_csv(out / "results.csv")[0]  # resumed to its end: complete


def test_dask_executor_runs_the_same_batch_on_a_local_cluster(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    sweep = yaml.safe_load((CI_SUITE / "fixedwing_edges.yaml").read_text())
    sweep["duration_s"] = 10
    sweep["sweep"] = {"grid": {"pilot.segments.0.course_deg": [0, 90], "wind.speed_mps": [0, 8]}}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(sweep))
    specs = plan(discover([tmp_path / "s.yaml"]))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        outcome = run_batch(
            specs, tmp_path / "out", executor="dask", scheduler=cluster.scheduler_address, progress=False,
            dask_in_flight=2,  # (two submitted at a time: the others as they land)
        )  # fmt: skip
    assert outcome.flown == 4 and not outcome.failed
    got = summaries(tmp_path / "out")
    assert sorted(got) == sorted(s.flight_id for s in specs)
    assert all(s["aircraft"] == "Tern" and s["completed"] for s in got.values())


CLEAN = {"geofence": True, "completed": True, "error": None, "max_excursion_m": -4.2, "breached_keep_out": False,
         "landed_outside_gap": False, "terminated_at_s": None, "touchdown_vertical_mps": 0.4,
         "touchdown_horizontal_mps": 0.1}  # fmt: skip


@pytest.mark.parametrize(
    "change",
    [
        {"geofence": False},
        {"completed": False},
        {"error": "diverged"},
        {"max_excursion_m": 0.01},
        {"breached_keep_out": True},
        {"landed_outside_gap": True},
        {"terminated_at_s": 12.5},
        {"touchdown_vertical_mps": 1.2},
        {"touchdown_horizontal_mps": 0.7},
    ],  # fmt: skip
)
def test_a_notable_flight_is_one_a_reviewer_reads_the_trajectory_of(change):
    assert not notable(CLEAN) and notable(dict(CLEAN, **change))
    assert not notable(dict(CLEAN, touchdown_vertical_mps=None, max_excursion_m=0.0))  # (no touchdown; at the edge)


def test_a_batch_keeping_notable_trajectories_writes_them_only_for_those(tmp_path):
    """``--trajectories notable``: a flight inside its fence keeps only its summary (with the wind it met, which
    the campaign report reads), an unprotected one its trajectory too."""
    doc = yaml.safe_load((CI_SUITE / "multicopter_edges.yaml").read_text())
    doc["duration_s"] = 6
    doc["sweep"] = {"grid": {"wind.speed_mps": [5]}}
    (tmp_path / "fenced.yaml").write_text(yaml.safe_dump(doc))
    bare = dict(doc, name="unprotected")
    bare.pop("sweep"), bare.pop("geofence")
    bare["wind"] = dict(doc["wind"], speed_mps=5)
    (tmp_path / "bare.yaml").write_text(yaml.safe_dump(bare))
    specs = plan(discover([tmp_path / "fenced.yaml", tmp_path / "bare.yaml"]))
    out = tmp_path / "out"
    outcome = run_batch(specs, out, jobs=1, progress=False, trajectories=Trajectories.NOTABLE)
    got = summaries(out)
    assert outcome.flown == 2 and not outcome.failed
    fenced = next(name for name in got if name != "unprotected")
    assert got[fenced]["max_excursion_m"] < 0.0 and not (out / fenced / "trajectory.csv").exists()
    assert (out / "unprotected" / "trajectory.csv").is_file()
    # the wind met as the report reads it from a trajectory (a 5 m/s mean at 10 m, stronger at the flight's height)
    assert got["unprotected"]["peak_sustained_wind_mps"] == pytest.approx(
        peak_sustained_wind_mps(out / "unprotected" / "trajectory.csv"), abs=2e-3
    )
    assert all(5.0 < s["peak_sustained_wind_mps"] < 9.0 for s in got.values())


@pytest.mark.parametrize("key", ["wind.\nspeed_mps", "wind speed", 3])
def test_a_sweep_key_that_is_not_a_dotted_path_is_refused_in_one_line(key):
    doc = {"name": "s", "sweep": {"grid": {key: [1, 2]}}}
    with pytest.raises(ConfigError) as exc:
        expand(doc, "s.yaml", "s")
    msg = str(exc.value)
    assert "\n" not in msg and "is not a dotted field path" in msg and msg.startswith("s.yaml: sweep.grid")


# --------------------------------------------------------------------------- refusals, the lock, partial batches
def cli(*args, **kw):
    return subprocess.run([sys.executable, "-m", "scenarios.app.cli", *args], capture_output=True, text=True, timeout=120, **kw)


def broken_specs(tmp_path, n: int = 2):
    """Specs that fail at once (unreadable files): a batch of them writes its folders without flying."""
    for k in range(n):
        (tmp_path / f"broken{k}.yaml").write_text("aircraft: [F450\n")
    return plan(discover([tmp_path / f"broken{k}.yaml" for k in range(n)]))


def test_an_empty_scenario_folder_is_refused_in_one_line(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match="no scenario files"):
        discover([tmp_path / "empty"])
    res = cli("batch", str(tmp_path / "empty"), "--out", str(tmp_path / "out"), "--quiet")
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stdout + res.stderr
    assert "empty: no scenario files (*.yaml) in this folder" in res.stderr
    assert not (tmp_path / "out").exists()


HOLD_LOCK = """
import fcntl, os, sys, time
fh = open(sys.argv[1], "a+")
fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
fh.write(f"pid {os.getpid()} on testhost, started now\\n"); fh.flush()
print("held", flush=True)
time.sleep(60)
"""


def test_a_second_batch_into_the_same_folder_is_refused_naming_the_holder(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    holder = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, str(out / ".batch.lock")], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        specs = broken_specs(tmp_path)
        with pytest.raises(ConfigError, match=rf"another batch is writing into this folder \(pid {holder.pid} on testhost"):
            run_batch(specs, out, jobs=1, progress=False)
        assert not summaries(out), "the refused batch wrote nothing"
        res = cli("batch", str(tmp_path / "broken0.yaml"), "--out", str(out), "--quiet")
        assert res.returncode == 2 and res.stderr.count("\n") == 1 and f"pid {holder.pid}" in res.stderr, res.stderr
    finally:
        holder.kill()
        holder.wait()
    # the holder died without releasing anything: its file is left, and it does not block
    assert "testhost" in (out / ".batch.lock").read_text()
    outcome = run_batch(broken_specs(tmp_path), out, jobs=1, progress=False)
    assert outcome.flown == 2


def lock_is_free(out: Path) -> bool:
    probe = "import fcntl, sys; fcntl.flock(open(sys.argv[1], 'a+'), fcntl.LOCK_EX | fcntl.LOCK_NB)"
    return subprocess.run([sys.executable, "-c", probe, str(out / ".batch.lock")]).returncode == 0


def test_the_lock_is_released_at_the_end_and_on_ctrl_c_and_the_batch_is_marked_partial(tmp_path):
    from analysis.report import batch_progress, collect_results

    out = tmp_path / "out"
    specs = broken_specs(tmp_path, 3)
    run_batch(specs[:1], out, jobs=1, progress=False)
    assert lock_is_free(out)
    assert batch_progress(out, collect_results(out)) is None  # ran to its end

    def ctrl_c(summary):
        raise KeyboardInterrupt

    outcome = run_batch(specs, out, jobs=1, progress=False, on_done=ctrl_c)
    assert outcome.interrupted and lock_is_free(out)
    written = len(summaries(out))
    assert outcome.flown + outcome.skipped == written == 2  # the console's count is the folders written
    assert batch_progress(out, collect_results(out)) == (2, 3)
