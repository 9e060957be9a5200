"""The CLI on bad input: one line on stderr naming file/field/problem, exit code 2, no traceback."""

import subprocess
import sys
from pathlib import Path

import pytest

GOOD = Path(__file__).parents[1] / "scenarios" / "multicopter_survey_calm.yaml"


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "scenarios.cli", *args], capture_output=True, text=True, cwd=cwd, timeout=120)


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
        (lambda t: write(t, good_text(**{"lat_deg: -35.363262, lon_deg: 149.165237, ground_alt_m": "lat_deg: 123, lon_deg: 149.165237, ground_alt_m"})), "start.lat_deg: must be <= 90"),
        (lambda t: write(t, good_text(**{"duration_s: 240": "duration_s: -5"})), "duration_s: must be > 0"),
    ],
    ids=["missing-file", "bad-yaml", "unknown-aircraft", "latitude-123", "negative-duration"],
)
def test_bad_input_one_line_exit_2(tmp_path, make, expected):
    path = make(tmp_path)
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
    for args in (["--help"], ["run", "--help"], ["validate", "--help"], ["list", "--help"]):
        res = run_cli(*args)
        assert res.returncode == 0 and "usage: geofence-testbed" in res.stdout
    assert "trajectory.csv" in run_cli("run", "--help").stdout
