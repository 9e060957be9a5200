"""The CLI on bad input: one line on stderr naming file/field/problem, exit code 2, no traceback."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

GOOD = Path(__file__).parents[1] / "scenarios" / "multicopter_survey_calm.yaml"


def run_cli(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", *args], capture_output=True, text=True, cwd=cwd, timeout=120
    )


def write(tmp_path, text, name="s.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def good_text(**replace):
    text = GOOD.read_text()
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    return text


@pytest.mark.parametrize(
    "make, expected",
    [
        (lambda t: t / "missing.yaml", "no such scenario file"),
        (lambda t: write(t, "aircraft: [F450\n"), "malformed YAML at line"),
        (lambda t: write(t, good_text(**{"aircraft: F450": "aircraft: Wright_Flyer_3000"})), "aircraft: unknown aircraft"),
        (
            lambda t: write(
                t,
                good_text(
                    **{
                        "lat_deg: -35.363262, lon_deg: 149.165237, ground_alt_m": "lat_deg: 123, lon_deg: 149.165237, ground_alt_m"
                    }
                ),
            ),
            "start.lat_deg: must be <= 90",
        ),
        (lambda t: write(t, good_text(**{"duration_s: 240": "duration_s: -5"})), "duration_s: must be > 0"),
        (
            lambda t: write(t, good_text(**{"duration_s: 240": "duration_s: 240\nduration_s: 30"})),
            "line 7, column 1: duplicate key 'duration_s' (first at line 6)",
        ),
        (
            lambda t: write(t, good_text(**{"agl_m: 0": "agl_m: 0, agl_m: 20"})),
            "duplicate key 'agl_m'",
        ),
    ],
    ids=["missing-file", "bad-yaml", "unknown-aircraft", "latitude-123", "negative-duration", "key-twice", "nested-key-twice"],
)
def test_bad_input_one_line_exit_2(tmp_path, make, expected):
    _assert_one_line_exit_2(tmp_path, make(tmp_path), expected)


GEOFENCE = Path(__file__).parents[1] / "scenarios" / "geofence_multicopter_adversarial_calm.yaml"


def bad_fence(tmp_path, **changes):
    doc = yaml.safe_load(GEOFENCE.read_text())
    doc["geofence"]["fence"].update(changes)
    p = tmp_path / "fence.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


@pytest.mark.parametrize(
    "changes, expected",
    [
        ({"keep_in": [[-35.3636, 149.1640], [-35.3617, 149.1665], [-35.3636, 149.1665], [-35.3617, 149.1640]]}, "intersect"),
        ({"ceiling_m": 5, "floor_m": 8}, "ceiling"),
        ({"keep_in": [[-35.3636, 149.1640], [-35.3617, 149.1665]]}, "3"),
    ],
    ids=["self-intersecting", "ceiling-below-floor", "two-vertices"],
)
def test_bad_fence_one_line_exit_2(tmp_path, changes, expected):
    _assert_one_line_exit_2(tmp_path, bad_fence(tmp_path, **changes), expected)


def _assert_one_line_exit_2(tmp_path, path, expected):
    res = run_cli("run", str(path), "--out", str(tmp_path / "out"))
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, res.stderr
    assert str(path) in lines[0] and expected in lines[0]
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "out").exists()


def test_validate_accepts_shipped_example():
    res = run_cli("validate", str(GOOD))
    assert res.returncode == 0 and "ok:" in res.stdout


def test_help_explains_every_subcommand():
    commands = ["run", "batch", "plot", "compare", "seed-reproduction", "score-log", "import-fence", "validate", "list"]
    for args in (["--help"], *([c, "--help"] for c in commands)):
        res = run_cli(*args)
        assert res.returncode == 0 and "usage: geofence-testbed" in res.stdout
    assert "trajectory.csv" in run_cli("run", "--help").stdout
    assert "resume" in run_cli("batch", "--help").stdout
    listing = run_cli("list").stdout
    assert "F450" in listing and "Tern" in listing and "scenarios/paper/indoor_quad.yaml" in listing


REALWORLD = Path(__file__).parents[2] / "shared" / "realworld"


def test_score_log_scores_a_real_flight_against_a_real_fence_file():
    log, fence = REALWORLD / "uavlogviewer_vtol.tlog", REALWORLD / "mavproxy_cmac-foamy-fence.txt"
    if not (log.is_file() and fence.is_file()):
        pytest.skip("shared/realworld is not beside the repo")
    res = run_cli("score-log", str(log), "--fence", str(fence), "--ceiling", "100")
    assert res.returncode == 0, res.stderr
    scores = json.loads(res.stdout[res.stdout.index("{") :])
    # the SITL quadplane stays below 100 m (its highest relative altitude is 63.4 m per PROVENANCE.md) ...
    assert scores["max_vertical_excursion_m"] == pytest.approx(63.4 - 100.0, abs=0.2)
    # ... but its CIRCLE segment takes it some 49 m outside the club's "foamy" fence
    assert 40.0 < scores["max_lateral_excursion_m"] < 60.0 and scores["time_outside_s"] > 10.0


def test_import_fence_prints_a_block_the_schema_accepts(tmp_path):
    fence = REALWORLD / "qgc_ce_geofence_home_base.plan"
    if not fence.is_file():
        pytest.skip("shared/realworld is not beside the repo")
    res = run_cli("import-fence", str(fence), "--ceiling", "40")
    assert res.returncode == 0, res.stderr
    block = yaml.safe_load(res.stdout)
    assert len(block["geofence"]["fence"]["keep_in"]) == 4 and block["geofence"]["fence"]["ceiling_m"] == 40


def test_bad_fence_file_is_one_line_exit_2(tmp_path):
    bad = tmp_path / "f.plan"
    bad.write_text("{not json")
    res = run_cli("import-fence", str(bad))
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1 and "Traceback" not in res.stderr


@pytest.mark.parametrize("name", ["analysis", "wind"])
def test_a_package_shadowing_ours_is_refused_in_one_line(tmp_path, name):
    """Another installed package named like one of ours (README: namespacing) is caught before any work."""
    (tmp_path / "shadow" / name).mkdir(parents=True)
    (tmp_path / "shadow" / name / "__init__.py").write_text("")
    import os

    env = dict(os.environ, PYTHONPATH=str(tmp_path / "shadow"))
    r = subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "list"], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120
    )
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and f"the package {name!r}" in lines[0] and "shadows it" in lines[0], r.stderr
    assert "Traceback" not in r.stderr and r.stdout == ""


def test_validate_prints_the_fence_files_warnings(tmp_path):
    """An importer's warning (here an ED-269 zone without restriction, skipped) reaches the user, exit 0."""

    def square(lat, lon, d):
        return [[lon - d, lat - d], [lon + d, lat - d], [lon + d, lat + d], [lon - d, lat + d], [lon - d, lat - d]]

    lat, lon = -35.363262, 149.165237
    features = [
        {
            "type": "Feature",
            "properties": {"geofence": "keep_in"},
            "geometry": {"type": "Polygon", "coordinates": [square(lat, lon, 0.003)]},
        },
        {
            "type": "Feature",
            "id": "open-1",
            "properties": {"restriction": "NO_RESTRICTION"},
            "geometry": {"type": "Polygon", "coordinates": [square(lat + 0.001, lon, 0.0003)]},
        },
    ]
    write(tmp_path, json.dumps({"type": "FeatureCollection", "features": features}), "f.geojson")
    p = write(tmp_path, good_text() + "geofence: {fence: {file: f.geojson, ceiling_m: 60}}\n")
    r = run_cli("validate", str(p))
    assert r.returncode == 0, r.stderr
    assert "fence file:" in r.stderr and "NO_RESTRICTION" in r.stderr and "open-1" in r.stderr
