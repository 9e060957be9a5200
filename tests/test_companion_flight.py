"""THE two-process flight: the simulator as a lock-stepped MAVLink vehicle (``run SCENARIO --mavlink udpout:...
--lockstep``) and the geofence unit as the companion process (``companion --connect udpin:... --scenario``), on
loopback UDP, flying the adversarial breach scenarios of a multirotor and a fixed-wing.

Shown per platform: the aircraft stays inside (peak excursion <= 0, no time outside); the companion overrode (as
often as the vehicle counted), handed back and released the RC channels; both processes end by themselves within
the time bound (the vehicle at the end of its flight, the companion on the vehicle's POWEROFF heartbeat); and the
peak excursion is near the same scenario flown in-process (:func:`scenarios.flight.runner.fly`): within 0.5 m for
the multirotor; the fixed-wing's bound is 1 m. Lock-step makes the link's latency zero in simulated time: what
differs is what the link carries (the GNSS vertical speed, which GPS_RAW_INT does not carry, and the air data at
10 Hz), measured in docs/companion.md ("Measured"). :func:`test_a_real_time_vehicle_and_its_companion` flies the
same pair unlocked, at wall-clock pace, and measures the link's latency.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from support import free_udp_port

from scenarios.definition.schema import load_scenario
from scenarios.flight.runner import fly

ROOT = Path(__file__).resolve().parents[1]
VEHICLE_BOUND_S = 300.0
"""Wall time the lock-stepped vehicle may take for its flight (about 10 s alone; two cores shared by the suite)."""
COMPANION_AFTER_S = 20.0
"""The companion ends this soon after the vehicle powered off."""
PEAK_TOLERANCE_M = {"multicopter": 0.5, "fixedwing": 1.0}
"""How near the in-process flight's peak excursion the two-process one must be (see the module docstring)."""


def cli(*args: str, out: Path, **kw) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen(
        [sys.executable, "-m", "scenarios.app.cli", *args], cwd=ROOT, env=env, stdout=out.open("w"),
        stderr=subprocess.STDOUT, text=True, **kw,
    )  # fmt: skip


def wait_for_line(path: Path, text: str, proc: subprocess.Popen, timeout_s: float = 120.0) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        if text in path.read_text():
            return
        assert proc.poll() is None, path.read_text()
        time.sleep(0.05)
    raise AssertionError(f"no {text!r} in {path} within {timeout_s} s")


def fly_both(tmp_path: Path, scenario: Path, report_path: Path, lockstep: bool) -> float:
    """The companion, then (once it listens) the vehicle, as two processes on one loopback UDP port; both must end
    by themselves with exit 0 (the vehicle within :data:`VEHICLE_BOUND_S`, the companion :data:`COMPANION_AFTER_S`
    after it). Returns the vehicle's wall time, s; its outputs are in ``tmp_path / "out"``."""
    port = free_udp_port()
    companion = cli(
        "companion", "--connect", f"udpin:127.0.0.1:{port}", "--scenario", str(scenario), "--report", str(report_path),
        "--max-duration-s", str(VEHICLE_BOUND_S + COMPANION_AFTER_S), out=tmp_path / "companion.out",
    )  # fmt: skip
    vehicle = None
    try:
        wait_for_line(tmp_path / "companion.out", "companion: listening", companion)
        t0 = time.monotonic()
        vehicle = cli(
            "run", str(scenario), "--mavlink", f"udpout:127.0.0.1:{port}", *(["--lockstep"] if lockstep else []),
            "--out", str(tmp_path / "out"), "--no-plot", out=tmp_path / "vehicle.out",
        )  # fmt: skip
        assert vehicle.wait(timeout=VEHICLE_BOUND_S) == 0, (tmp_path / "vehicle.out").read_text()[-2000:]
        wall_s = time.monotonic() - t0
        assert companion.wait(timeout=COMPANION_AFTER_S) == 0, (tmp_path / "companion.out").read_text()
    finally:
        for p in (vehicle, companion):
            if p is not None and p.poll() is None:
                p.kill()
    return wall_s


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["multicopter", "fixedwing"])
def test_the_companion_process_keeps_the_vehicle_process_inside(tmp_path, kind):
    scenario = ROOT / "scenarios" / f"geofence_{kind}_adversarial_calm.yaml"
    sc = load_scenario(scenario)
    in_process = fly(sc).summary  # (also compiles the kernels both processes load from the cache)

    report_path = tmp_path / "companion.json"
    vehicle_s = fly_both(tmp_path, scenario, report_path, lockstep=True)

    flown = json.loads((tmp_path / "out" / sc.name / "summary.json").read_text())
    report = json.loads(report_path.read_text())
    assert flown["completed"] and flown["error"] is None
    assert flown["max_excursion_m"] <= 0.0 and flown["time_outside_s"] == 0.0
    assert report["exit_reason"] == "the vehicle powered off"
    assert report["activations"] >= 1 and report["activations"] == flown["activations"]
    handbacks = [t for t in report["transitions"] if (t["from"], t["to"]) == ("OVERRIDE", "RECOVERED")]
    assert handbacks and report["releases_sent"] >= len(handbacks)
    link = flown["link"]
    assert link["overrides_rejected"] == 0 and link["overrides_accepted"] == report["overrides_sent"] + report["releases_sent"]
    if report["mode"] not in ("OVERRIDE", "LAND_IN_GAP", "TERMINATE"):  # released at the end: nothing honoured then
        assert link["override_honoured_spans_s"][-1][1] < flown["sim_time_s"]
    assert report["link"]["dropped_total"] == 0
    difference = flown["max_excursion_m"] - in_process["max_excursion_m"]
    print(
        f"{kind}: peak excursion two-process {flown['max_excursion_m']:.3f} m, in-process "
        f"{in_process['max_excursion_m']:.3f} m (difference {difference:+.3f} m); activations {flown['activations']} vs "
        f"{in_process['activations']}; vehicle {vehicle_s:.1f} s wall; step processing {report['link']['processing']}"
    )
    assert abs(difference) <= PEAK_TOLERANCE_M[kind]


REAL_TIME_FLIGHT_S = 8.0


@pytest.mark.slow
def test_a_real_time_vehicle_and_its_companion(tmp_path):
    """Without --lockstep the vehicle paces itself to wall-clock time and never waits: the companion keeps up
    (every ATTITUDE answered, no sequence gap), sees the vehicle's clock run at 1 s per s, and measures the
    telemetry's receive lag and the TIMESYNC round trip."""
    import yaml

    doc = yaml.safe_load((ROOT / "scenarios" / "geofence_multicopter_adversarial_calm.yaml").read_text())
    doc["duration_s"] = REAL_TIME_FLIGHT_S
    scenario = tmp_path / "short.yaml"
    scenario.write_text(yaml.safe_dump(doc))
    fly(load_scenario(scenario))  # (the kernels compiled before the clock matters)
    report_path = tmp_path / "companion.json"
    wall_s = fly_both(tmp_path, scenario, report_path, lockstep=False)
    link = json.loads(report_path.read_text())["link"]
    assert wall_s >= REAL_TIME_FLIGHT_S  # paced to the clock
    assert link["sim_s_per_wall_s"] == pytest.approx(1.0, abs=0.05)
    assert link["received"]["ATTITUDE"]["rate_hz"] == pytest.approx(40.0, rel=0.1)
    assert link["dropped_total"] == 0
    lag, rtt = link["attitude_receive_lag"], link["timesync_rtt"]
    assert lag is not None and lag["p50_ms"] < 50.0  # (above its least: the jitter of the pacing and the socket)
    assert rtt is not None and rtt["n"] >= 3 and rtt["p50_ms"] < 100.0
    print(f"real time: {wall_s:.1f} s wall for {REAL_TIME_FLIGHT_S:g} s; receive lag {lag}; TIMESYNC RTT {rtt}")
