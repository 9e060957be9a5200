"""``run --tlog``: a simulated flight written as a MAVLink 2 telemetry log that pymavlink, mavlogdump and
``score-log`` read, scoring the same peak excursion as the in-process flight within the telemetry quantisation."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import pytest

from tests.support import ROOT

pytestmark = pytest.mark.closed_loop

from pymavlink import mavutil  # noqa: E402

SCENARIO = ROOT / "scenarios" / "geofence_multicopter_keep_in_circle.yaml"
QUANTISATION_M = 0.01
"""GLOBAL_POSITION_INT lat/lon round to 1e-7 deg (at most 5.6 mm north, 4.6 mm east at 35 deg S) and
relative_alt to 1 mm: a margin moves by under 1 cm."""


def cli(*args: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "scenarios.app.cli", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT)


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("tlog")
    scenario = tmp / "keep_in_circle.yaml"
    scenario.write_text(SCENARIO.read_text().replace("duration_s: 90", "duration_s: 25"))
    proc = cli("run", str(scenario), "--out", str(tmp / "out"), "--quiet", "--no-plot", "--tlog", str(tmp / "flight.tlog"))
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp / "out" / "geofence_multicopter_keep_in_circle" / "summary.json").read_text())
    return tmp, summary


def test_tlog_opens_with_pymavlink(flight):
    tmp, summary = flight
    m = mavutil.mavlink_connection(str(tmp / "flight.tlog"))
    counts: dict[str, int] = {}
    while (msg := m.recv_match()) is not None:
        counts[msg.get_type()] = counts.get(msg.get_type(), 0) + 1
    assert "BAD_DATA" not in counts
    rows = round(summary["sim_time_s"] * summary["control_rate_hz"]) + 1
    assert counts["GLOBAL_POSITION_INT"] == counts["ATTITUDE"] == rows
    assert counts["VFR_HUD"] == pytest.approx(rows / 4, abs=1) and counts["HEARTBEAT"] == pytest.approx(
        summary["sim_time_s"] + 2, abs=1
    )


@pytest.mark.skipif(shutil.which("mavlogdump.py") is None, reason="mavlogdump.py is not installed")
def test_tlog_reads_with_mavlogdump(flight):
    tmp, _ = flight
    proc = subprocess.run(
        ["mavlogdump.py", "--types", "GLOBAL_POSITION_INT", str(tmp / "flight.tlog")], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0 and proc.stdout.count("GLOBAL_POSITION_INT") > 100


def test_score_log_of_the_tlog_matches_the_flight(flight):
    tmp, summary = flight
    fence = tmp / "fence.geojson"
    assert cli("export-fence", str(SCENARIO), "--to", "geojson", "--out", str(fence)).returncode == 0
    proc = cli("score-log", str(tmp / "flight.tlog"), "--fence", str(fence), "--json")
    assert proc.returncode == 0, proc.stderr
    scores = json.loads(proc.stdout)
    for key in ("max_excursion_m", "max_lateral_excursion_m", "max_vertical_excursion_m", "min_margin_m"):
        assert scores[key] == pytest.approx(summary[key], abs=QUANTISATION_M), key
    assert scores["time_outside_s"] == summary["time_outside_s"]
