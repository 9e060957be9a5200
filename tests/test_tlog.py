"""``run --tlog``: a simulated flight written as a MAVLink 2 telemetry log that pymavlink, mavlogdump and
``score-log`` read, scoring the same peak excursion as the in-process flight within the telemetry quantisation;
and ``score-log`` on a PX4 ULog."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys

import pytest

from tests.support import ROOT, SHARED_REALWORLD

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


# --------------------------------------------------------------------------- PX4 ULog in score-log

ULOG = SHARED_REALWORLD / "pyulog_sample_px4_events.ulg"


def square_fence_geojson(path, lat0: float, lon0: float, half_side_m: float) -> None:
    """A keep-in square of ``half_side_m`` about (lat0, lon0), as GeoJSON."""
    dlat = half_side_m / 111_132.0
    dlon = half_side_m / (111_320.0 * math.cos(math.radians(lat0)))
    ring = [[lon0 - dlon, lat0 - dlat], [lon0 + dlon, lat0 - dlat], [lon0 + dlon, lat0 + dlat], [lon0 - dlon, lat0 + dlat]]
    geometry = {"type": "Polygon", "coordinates": [ring + [ring[0]]]}
    path.write_text(json.dumps({"type": "Feature", "properties": {"geofence": "keep_in"}, "geometry": geometry}))


@pytest.mark.skipif(not ULOG.is_file(), reason="shared/realworld is not beside the repo")
def test_score_log_reads_a_px4_ulog(tmp_path):
    from analysis.formats.logs import load_log

    traj, info = load_log(ULOG)
    assert info.log_format == "ulog" and info.position_source == "vehicle_global_position"
    assert info.n_positions == 109 and info.simulated and "AUTO_TAKEOFF" in info.modes
    lat0, lon0 = float(traj["lat_deg"][0]), float(traj["lon_deg"][0])
    fence = tmp_path / "square.geojson"
    square_fence_geojson(fence, lat0, lon0, 100.0)
    proc = cli("score-log", str(ULOG), "--fence", str(fence), "--json")
    assert proc.returncode == 0, proc.stderr
    scores = json.loads(proc.stdout)
    # the vehicle stays within centimetres of home (PROVENANCE.md): inside, 100 m from every edge
    assert scores["max_lateral_excursion_m"] == pytest.approx(-100.0, abs=0.5)
    assert scores["time_outside_s"] == 0.0


def test_a_broken_ulog_is_one_error_line(tmp_path):
    bad = tmp_path / "bad.ulg"
    bad.write_bytes(b"ULog\x01\x12\x35" + b"\x00" * 40)
    fence = tmp_path / "square.geojson"
    square_fence_geojson(fence, 47.0, 8.0, 100.0)
    proc = cli("score-log", str(bad), "--fence", str(fence))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and str(bad) in proc.stderr
