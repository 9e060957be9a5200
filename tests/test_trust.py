"""Issue 11, trustworthy results: a user never gets a wrong answer with exit code 0.

Stale results (content-hash resume, same-name flights, whole-folder replacement, temporary
JSBSim folders), output paths checked before flying, scenarios that validate but cannot make
sense (start or mission outside the fence, a wind the platform cannot fly against, a pole),
``validate`` of many files and of sweeps, and the smaller CLI fixes. Flights are a few seconds
of simulated time each.
"""

import copy
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from geofence.validation import ConfigError
from scenarios.app.batch import discover, plan
from scenarios.definition.schema import parse_scenario
from scenarios.definition.sweep import expand, scenario_hash

ROOT = Path(__file__).parents[1]
EDGES = ROOT / "scenarios" / "ci" / "multicopter_edges.yaml"
SURVEY = ROOT / "scenarios" / "multicopter_survey_calm.yaml"
FENCED = ROOT / "scenarios" / "geofence_multicopter_adversarial_calm.yaml"


def short_scripted(name: str, duration_s: float = 3.0) -> dict:
    """An F450 flying north at full speed inside a 300 m box, for a few seconds (completes)."""
    return {
        "name": name,
        "aircraft": "F450",
        "seed": 21,
        "duration_s": duration_s,
        "start": {"lat_deg": -35.363262, "lon_deg": 149.165237, "ground_alt_m": 584.0, "agl_m": 20, "heading_deg": 0},
        "pilot": {"type": "scripted", "segments": [{"duration_s": 600, "course_deg": 0, "speed": "max", "climb": "hold"}]},
        "wind": {"speed_mps": 0, "from_deg": 270},
        "geofence": {
            "fence": {
                "keep_in": [
                    [-35.3646139, 149.1635866],
                    [-35.3646139, 149.1668874],
                    [-35.3619101, 149.1668873],
                    [-35.3619101, 149.1635867],
                ],
                "ceiling_m": 60,
            }
        },
    }


def write(path: Path, doc: dict) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def cli(*args, env=None, timeout=120):
    return subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=env,
        timeout=timeout,
    )


def one_line_exit_2(res, *expected):
    assert res.returncode == 2, res.stdout + res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    for text in expected:
        assert text in lines[0], lines[0]
    return lines[0]


def private_tmp(tmp_path) -> tuple[dict, Path]:
    """An environment whose temporary folder is ours alone (other processes' gft-jsbsim-* do not count)."""
    tmp = tmp_path / "tmpdir"
    tmp.mkdir()
    return dict(os.environ, TMPDIR=str(tmp)), tmp


def jsbsim_folders(tmp: Path) -> list[Path]:
    return list(tmp.glob("gft-jsbsim-*"))


# --------------------------------------------------------------------------- stale results
def test_scenario_hash_is_the_resolved_document_and_the_version():
    doc = short_scripted("h")
    h = scenario_hash(doc)
    assert h == scenario_hash(copy.deepcopy(doc)) and len(h) == 64
    assert scenario_hash(dict(doc, duration_s=4)) != h
    from scenarios.definition.sweep import project_version

    assert scenario_hash(doc, version=project_version()) == h
    assert scenario_hash(doc, version="999.0") != h, "a new version must re-fly"
    from scenarios.definition.sweep import code_fingerprint

    assert scenario_hash(doc, code=code_fingerprint()) == h
    assert scenario_hash(doc, code="other code") != h, "a result flown by other code must re-fly"
    # a file without a name and a file naming itself by its stem are the same flight
    nameless = dict(doc)
    nameless.pop("name")
    assert expand(nameless, "h.yaml", "h")[0].scenario_hash == expand(doc, "h.yaml", "h")[0].scenario_hash


def test_batch_resume_reflies_an_edited_scenario_and_says_so(tmp_path):
    env, tmp = private_tmp(tmp_path)
    src = tmp_path / "s"
    write(src / "a.yaml", short_scripted("flight_a"))
    write(src / "b.yaml", short_scripted("flight_b"))
    out = tmp_path / "out"
    args = ("batch", src, "--out", out, "--jobs", "2", "--quiet", "--no-report")
    first = cli(*args, env=env)
    assert first.returncode == 0, first.stdout + first.stderr
    assert not jsbsim_folders(tmp), "a batch left temporary JSBSim folders"
    hashes = {p.parent.name: json.loads(p.read_text())["scenario_hash"] for p in out.glob("*/summary.json")}
    stamp_b = (out / "flight_b" / "summary.json").stat().st_mtime_ns

    write(src / "a.yaml", short_scripted("flight_a", duration_s=2.0))  # edited: same name, other flight
    second = cli(*args[:-3], "1", *args[-2:], env=env)  # --jobs 1: in this process
    assert second.returncode == 0, second.stdout + second.stderr
    assert "re-flying 1 changed flight" in second.stdout and "1 already done" in second.stdout
    a = json.loads((out / "flight_a" / "summary.json").read_text())
    assert a["scenario_hash"] != hashes["flight_a"] and a["sim_time_s"] == pytest.approx(2.0, abs=0.1)
    assert (out / "flight_b" / "summary.json").stat().st_mtime_ns == stamp_b, "an unchanged flight was re-flown"
    assert not list(out.glob(".*.tmp")), "a temporary flight folder was left behind"
    assert not jsbsim_folders(tmp)


def test_same_named_flights_are_refused_up_front_naming_both_files(tmp_path):
    a = write(tmp_path / "one" / "x.yaml", short_scripted("twin"))
    b = write(tmp_path / "two" / "y.yaml", short_scripted("twin"))
    res = cli("run", a, b, "--out", tmp_path / "out")
    one_line_exit_2(res, str(a), str(b), "twin")
    assert not (tmp_path / "out").exists(), "something was flown or written"
    with pytest.raises(ConfigError, match="defined twice"):
        plan(discover([tmp_path]))


def test_a_run_replaces_its_folder_whole_and_says_why_it_did_not_complete(tmp_path):
    """--no-plot leaves no stale flight.png; a stale file of an earlier flight goes; the reason is recorded."""
    from scenarios.definition.schema import load_scenario
    from scenarios.flight.runner import run_scenario

    doc = yaml.safe_load(SURVEY.read_text())
    doc["duration_s"] = 2.0  # the survey cannot finish in 2 s
    path = write(tmp_path / "survey.yaml", doc)
    sc = load_scenario(path)
    out = tmp_path / "out"
    run_scenario(sc, out, plot=True)
    folder = out / sc.name
    assert (folder / "flight.png").is_file()
    (folder / "attempts.json").write_text("[]")  # something an earlier flight left
    result = run_scenario(sc, out, plot=False)
    assert sorted(p.name for p in folder.iterdir()) == ["scenario.yaml", "summary.json", "trajectory.csv"]
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["completed"] is False and summary == json.loads(json.dumps(result.summary))
    assert "mission was not finished" in summary["incomplete_reason"] and "duration_s = 2" in summary["incomplete_reason"]
    assert summary["scenario_hash"] == expand(yaml.safe_load(path.read_text()), str(path), "survey")[0].scenario_hash
    assert not list(out.glob(".*"))


# --------------------------------------------------------------------------- temporary JSBSim folders
def test_temporary_model_folders_go_when_loaded_closed_or_interrupted(tmp_path, monkeypatch):
    import tempfile

    import aircraft.jsbsim_model as jm

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with jm.JSBSimModel("F450") as model:
        assert not jsbsim_folders(tmp_path), "the mirror outlived the load"
        assert model.fdm is not None
    assert model.closed and model.fdm is None
    model.close()  # idempotent

    def ctrl_c(*_args):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        jm.JSBSimModel("F450", on_mirrored=ctrl_c)
    assert not jsbsim_folders(tmp_path) and not jm._LIVE_ROOTS


def test_ctrl_c_and_sigterm_leave_no_temporary_folders(tmp_path):
    """Ctrl-C on a run; SIGTERM to a whole batch (parent and workers, as a job killer sends it): exit 130, nothing left."""
    env, tmp = private_tmp(tmp_path)
    doc = short_scripted("long", duration_s=7200)
    doc["pilot"]["segments"][0]["duration_s"] = 7200  # tens of seconds of wall time: still flying when signalled
    src = write(tmp_path / "long.yaml", doc)
    for sig, args in (
        (signal.SIGINT, ("run", src, "--no-plot")),  # its progress bar says when it is flying
        (signal.SIGTERM, ("batch", src, "--jobs", "2", "--quiet", "--no-report", "--no-flight-plots")),
    ):
        out = tmp_path / f"out_{sig.name}"
        # own process group; a background job inherits an ignored SIGINT, so give the CLI the default, as in a terminal
        proc = subprocess.Popen(
            [sys.executable, "-m", "scenarios.app.cli", *map(str, args), "--out", str(out)],
            cwd=ROOT,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        )
        head = ""
        if sig == signal.SIGINT:  # signalled once flying (not during the imports): the bar counts sim seconds
            while "sim s" not in head and proc.poll() is None:
                head += proc.stderr.read(1)
        deadline = time.monotonic() + 60
        while not (out.is_dir() or sig == signal.SIGINT) and time.monotonic() < deadline:
            time.sleep(0.05)  # the batch has planned and is starting its workers
        time.sleep(1.5)  # flying
        os.killpg(proc.pid, sig)
        _, err = proc.communicate(timeout=120)
        err = head + err
        assert proc.returncode == 130, err[-2000:]
        assert "Traceback" not in err, err
        assert not jsbsim_folders(tmp), f"{sig.name} left temporary JSBSim folders"
        assert not list(out.glob(".*.tmp")) if out.is_dir() else True, "a temporary flight folder was left behind"


def test_a_run_leaves_no_temporary_folder_and_reports_segments(tmp_path):
    env, tmp = private_tmp(tmp_path)
    src = write(tmp_path / "s.yaml", short_scripted("scripted_short", duration_s=2.0))
    res = cli("run", src, "--out", tmp_path / "out", "--quiet", "--no-plot", env=env)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "segments 0/1" in res.stdout and "waypoints" not in res.stdout and "mission" not in res.stdout
    assert not jsbsim_folders(tmp)


# --------------------------------------------------------------------------- output paths, before flying
@pytest.mark.parametrize("kind", ["existing-file", "read-only-folder", "parent-is-a-file"])
def test_unusable_out_is_refused_before_flying(tmp_path, kind):
    src = write(tmp_path / "s.yaml", short_scripted("never_flown", duration_s=600))
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    if kind == "read-only-folder":
        if os.geteuid() == 0:  # root writes anywhere chmod allows; /proc refuses even root
            out = Path("/proc/gft-out")
        else:
            ro = tmp_path / "ro"
            ro.mkdir(mode=0o555)
            out = ro / "out"
    else:
        out = a_file if kind == "existing-file" else a_file / "out"
    t0 = time.monotonic()
    res = cli("run", src, "--out", out)
    one_line_exit_2(res, "--out", str(out))
    assert time.monotonic() - t0 < 30, "the flight was flown before the output was checked"


# --------------------------------------------------------------------------- scenarios that cannot make sense
def fenced(**changes) -> dict:
    doc = yaml.safe_load(FENCED.read_text())
    for key, value in changes.items():
        doc[key] = value
    return doc


def test_a_start_outside_the_keep_in_is_refused_unless_allowed():
    doc = fenced()
    doc["start"]["lat_deg"] -= 0.007  # some 780 m south of the fence's south edge
    with pytest.raises(ConfigError, match=r"^x\.yaml: start: .* m outside the keep-in .*allow: \[start_outside_fence\]") as err:
        parse_scenario(doc, "x.yaml")
    assert "\n" not in str(err.value)
    sc = parse_scenario(dict(doc, allow=["start_outside_fence"]), "x.yaml")
    assert len(sc.warnings) == 1 and "outside the keep-in" in sc.warnings[0]
    inside_keep_out = fenced()
    circle = inside_keep_out["geofence"]["fence"]["keep_out_circles"][0]["center"]
    inside_keep_out["start"].update(lat_deg=circle[0], lon_deg=circle[1])
    with pytest.raises(ConfigError, match="inside keep-out-circle 0"):
        parse_scenario(inside_keep_out, "x.yaml")


def test_mission_items_outside_the_fence_are_refused_unless_allowed():
    doc = yaml.safe_load(SURVEY.read_text())
    doc["geofence"] = {
        "fence": {
            "keep_in": [[-35.3636, 149.1640], [-35.3636, 149.1665], [-35.3617, 149.1665], [-35.3617, 149.1640]],
            "ceiling_m": 50,
        }
    }
    assert parse_scenario(doc, "x.yaml").warnings == ()
    doc["mission"]["items"][3]["lon_deg"] = 149.1700  # ~300 m east of the fence
    with pytest.raises(ConfigError, match=r"x\.yaml: mission\.items\[3\]: this waypoint is \d+ m outside the keep-in"):
        parse_scenario(doc, "x.yaml")
    doc["mission"]["items"][3]["lon_deg"] = 149.1650
    doc["mission"]["items"][3]["agl_m"] = 80
    with pytest.raises(ConfigError, match=r"mission\.items\[3\]: .*above the ceiling"):
        parse_scenario(doc, "x.yaml")
    assert parse_scenario(dict(doc, allow=["mission_outside_fence"]), "x.yaml").warnings


@pytest.mark.parametrize("aircraft, limit", [("F450", "max speed"), ("Tern", "cruise airspeed")])
def test_a_wind_the_platform_cannot_fly_against_is_refused_unless_allowed(aircraft, limit):
    doc = yaml.safe_load(SURVEY.read_text())
    doc["aircraft"] = aircraft
    doc["wind"] = {"speed_mps": 200, "from_deg": 270}
    with pytest.raises(
        ConfigError, match=rf"x\.yaml: wind\.speed_mps: a mean wind of 200 m/s is at or above the {limit} of the {aircraft}"
    ):
        parse_scenario(doc, "x.yaml")
    assert parse_scenario(dict(doc, allow=["wind_above_platform_speed"]), "x.yaml").warnings
    doc["wind"]["speed_mps"] = 5
    parse_scenario(doc, "x.yaml")


@pytest.mark.parametrize("where", ["start", "mission", "fence"])
def test_nothing_within_reach_of_a_pole(where):
    doc = yaml.safe_load(SURVEY.read_text())
    if where == "start":
        doc["start"].update(lat_deg=89.5, lon_deg=0.0)
        field = "start.lat_deg"
    elif where == "mission":
        doc["mission"]["items"][2]["lat_deg"] = -88.5
        field = "mission.items[2].lat_deg"
    else:
        doc["geofence"] = {"fence": {"keep_in": [[-88.2, 0.0], [-88.2, 10.0], [-89.5, 5.0]], "ceiling_m": 50}}
        field = "geofence.fence.keep_in"
    with pytest.raises(ConfigError, match=rf"x\.yaml: {field.replace('.', '[.]').replace('[2]', '.2.')}: .* of the pole"):
        parse_scenario(doc, "x.yaml")
    with pytest.raises(ConfigError):  # not allowable
        parse_scenario(
            dict(doc, allow=list(("start_outside_fence", "mission_outside_fence", "wind_above_platform_speed"))), "x.yaml"
        )


def test_allow_takes_only_known_names():
    with pytest.raises(ConfigError, match=r"allow\[0\]: 'everything' is not one of"):
        parse_scenario(dict(short_scripted("a"), allow=["everything"]), "x.yaml")


# --------------------------------------------------------------------------- validate, sweeps
def test_validate_reports_every_file_and_accepts_sweeps(tmp_path):
    bad = write(tmp_path / "bad.yaml", dict(short_scripted("bad"), duration_s=-1))
    bad_sweep = yaml.safe_load(EDGES.read_text())
    bad_sweep["sweep"]["grid"]["wind.speedd_mps"] = [1, 2]
    bad_sweep = write(tmp_path / "bad_sweep.yaml", bad_sweep)
    res = cli("validate", SURVEY, bad, EDGES, bad_sweep, ROOT / "scenarios" / "ci" / "fixedwing_edges.yaml")
    assert res.returncode == 2
    ok = res.stdout.splitlines()
    n_edges = len(expand(yaml.safe_load(EDGES.read_text()), str(EDGES), EDGES.stem))
    assert len(ok) == 3 and ok[0].startswith(f"ok: {SURVEY}") and f"sweep of {n_edges} flights" in ok[1] and "sweep of" in ok[2]
    errors = res.stderr.splitlines()
    assert len(errors) == 2 and "Traceback" not in res.stderr
    assert str(bad) in errors[0] and "duration_s" in errors[0]
    assert str(bad_sweep) in errors[1] and "sweep.grid.wind.speedd_mps: no such field" in errors[1]


def test_a_sweep_with_a_bad_dotted_path_fails_up_front(tmp_path):
    doc = yaml.safe_load(EDGES.read_text())
    doc["sweep"] = {"monte_carlo": {"count": 3, "draws": {"sed": {"integers": [0, 9]}}}}
    path = write(tmp_path / "s.yaml", doc)
    with pytest.raises(ConfigError, match=r"sweep\.monte_carlo\.draws\.sed: no such field .*sed: unknown key"):
        plan([path])
    res = cli("batch", path, "--out", tmp_path / "out", "--quiet")
    one_line_exit_2(res, str(path), "sed")
    assert not (tmp_path / "out").exists()
    # a key the base scenario lacks but the schema knows is fine (a wind block created by the sweep)
    ok = short_scripted("windy")
    ok.pop("wind")
    ok["sweep"] = {"grid": {"wind.speed_mps": [0, 3]}}
    assert len(expand(ok, "ok.yaml", "ok")) == 2


# --------------------------------------------------------------------------- smaller fixes
def test_version_and_import_fence_output(tmp_path):
    from scenarios.definition.sweep import project_version

    res = cli("--version")
    assert res.returncode == 0 and res.stdout.strip() == f"geofence-testbed {project_version()}"
    plan_file = tmp_path / "f.plan"
    plan_file.write_text(
        json.dumps(
            {
                "fileType": "Plan",
                "version": 1,
                "geoFence": {
                    "version": 2,
                    "circles": [],
                    "polygons": [
                        {
                            "inclusion": True,
                            "version": 1,
                            "polygon": [
                                [-35.3636225, 149.1640268],
                                [-35.3636225, 149.16644720000001],
                                [-35.361729899999996, 149.1664472],
                                [-35.3617299, 149.1640268],
                            ],
                        }
                    ],
                },
                "mission": {"items": [], "plannedHomePosition": [-35.3632, 149.1652, 584]},
                "rallyPoints": {"points": []},
            }
        )
    )
    target = tmp_path / "fence.yaml"
    res = cli("import-fence", plan_file, "--ceiling", "40", "-o", target)
    assert res.returncode == 0, res.stderr
    text = target.read_text()
    assert "149.1664472" in text and "-35.3617299" in text and "0000001" not in text and "99999" not in text
    one_line_exit_2(cli("import-fence", plan_file, "-o", target), str(target), "--force")
    assert cli("import-fence", plan_file, "--ceiling", "30", "-o", target, "--force").returncode == 0
    assert "ceiling_m: 30" in target.read_text()
    one_line_exit_2(cli("import-fence", plan_file, "-o", tmp_path), "is a folder")


def test_seed_reproduction_no_fly_on_an_empty_folder(tmp_path):
    one_line_exit_2(cli("seed-reproduction", tmp_path, "--no-fly"), str(tmp_path), "--no-fly")


def test_an_unreachable_dask_scheduler_is_one_line_at_once(tmp_path):
    import importlib.util
    import socket

    if importlib.util.find_spec("distributed") is None:
        pytest.skip("dask.distributed is not installed")

    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    src = write(tmp_path / "s.yaml", short_scripted("never_flown"))
    t0 = time.monotonic()
    res = cli("batch", src, "--out", tmp_path / "out", "--executor", "dask", "--scheduler", f"tcp://127.0.0.1:{port}")
    one_line_exit_2(res, "--scheduler", "cannot reach the Dask scheduler")
    assert time.monotonic() - t0 < 20
    assert not list((tmp_path / "out").glob("*/summary.json"))


def test_the_code_fingerprint_changes_with_any_code_file_and_only_with_code(tmp_path):
    """Edit a module, add a model file: another fingerprint. A scenario YAML or a figure beside the code: the same."""
    import shutil

    from scenarios.definition.sweep import CODE_PACKAGES, code_fingerprint

    root = Path(__file__).resolve().parents[1]
    for pkg in CODE_PACKAGES:
        shutil.copytree(root / pkg, tmp_path / pkg, ignore=shutil.ignore_patterns("__pycache__", "*.png", "*.svg"))
    base = code_fingerprint(tmp_path)
    assert base == code_fingerprint(tmp_path) and len(base) == 64
    (tmp_path / "scenarios" / "new_case.yaml").write_text("name: x\n")
    assert code_fingerprint(tmp_path) == base, "a scenario file is the input, not the code"
    unit = tmp_path / "geofence" / "unit" / "geofence_unit.py"
    unit.write_text(unit.read_text() + "\n# an edit\n")
    edited = code_fingerprint(tmp_path)
    assert edited != base
    (tmp_path / "aircraft" / "systems" / "extra.xml").write_text("<system/>")
    assert code_fingerprint(tmp_path) not in (base, edited)
