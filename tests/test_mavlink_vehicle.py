"""The simulated flight as a MAVLink vehicle (scenarios.flight.mavlink_vehicle), lock-stepped to a test-side
pymavlink companion on loopback UDP: the vehicle flies the override sticks while they are honoured and the
pilot's after the release or the timeout; its telemetry arrives at the contract's rates and in order."""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from geofence.interface import StickCommand
from scenarios.definition.schema import load_scenario
from scenarios.flight.mavlink_vehicle import LinkOptions, fly_mavlink
from scenarios.link import sticks, telemetry
from scenarios.link.sticks import Autopilot
from tests.support import ROOT

pytestmark = pytest.mark.closed_loop

from pymavlink import mavutil  # noqa: E402  (after scenarios.link: MAVLink 2)
from support import free_udp_port  # noqa: E402

SCENARIO = ROOT / "scenarios" / "geofence_multicopter_keep_in_circle.yaml"
OVERRIDE = StickCommand(roll=-0.6, pitch=0.4, yaw=0.2, throttle=0.5)


class Companion(threading.Thread):
    """Answers every ATTITUDE with GF_MARGIN; overrides the sticks while ``start_s <= t < stop_s``, then
    releases them (``release``) or just stops sending."""

    def __init__(self, port: int, autopilot: Autopilot, start_s: float, stop_s: float, release: bool) -> None:
        super().__init__(daemon=True)
        self.conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255, source_component=191)
        self.autopilot, self.start_s, self.stop_s, self.release = autopilot, start_s, stop_s, release
        self.types: list[str] = []
        self.attitude_ms: list[int] = []
        self.gps_usec: list[int] = []
        self.poweroff = 0
        self.stopping = False

    def run(self) -> None:
        released = False
        while not self.stopping and self.poweroff < 3:
            msg = self.conn.recv_match(blocking=True, timeout=0.5)
            if msg is None:
                continue
            kind = msg.get_type()
            self.types.append(kind)
            if kind == "HEARTBEAT" and msg.system_status == mavutil.mavlink.MAV_STATE_POWEROFF:
                self.poweroff += 1
            elif kind == "HEARTBEAT":  # (a lock-stepped vehicle starts when a companion's heartbeat comes back)
                self.conn.mav.heartbeat_send(
                    mavutil.mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0
                )
            elif kind == "GPS_RAW_INT":
                self.gps_usec.append(msg.time_usec)
            elif kind == "ATTITUDE":
                self.attitude_ms.append(msg.time_boot_ms)
                t = msg.time_boot_ms / 1000.0
                if self.start_s <= t < self.stop_s:
                    if self.autopilot is Autopilot.ARDUPILOT:
                        self.conn.mav.send(sticks.rc_override(OVERRIDE, 1))
                    else:
                        self.conn.mav.send(sticks.manual_control(OVERRIDE, 1))
                elif t >= self.stop_s and self.release and not released:
                    self.conn.mav.send(sticks.rc_release(1))
                    released = True
                self.conn.mav.send(telemetry.gf_margin(msg.time_boot_ms, 7.5))
        self.conn.close()


def fly_with_companion(tmp_path: Path, autopilot: Autopilot, release: bool, rc_override_time_s: float = 3.0):
    port = free_udp_port()
    companion = Companion(port, autopilot, 1.0, 2.0, release)
    companion.start()
    sc = dataclasses.replace(load_scenario(SCENARIO), duration_s=4.0)
    opts = LinkOptions(
        url=f"udpout:127.0.0.1:{port}", autopilot=autopilot, lockstep=True, lockstep_timeout_s=10.0,
        rc_override_time_s=rc_override_time_s, tlog=tmp_path / "flight.tlog",
    )  # fmt: skip
    try:
        result = fly_mavlink(sc, opts)
    finally:
        companion.stopping = True
        companion.join(timeout=5.0)
    return result, companion


def flown(result, name: str) -> np.ndarray:
    return result.recorder.column(name)


def assert_override_between(result, start_s: float, end_s: float) -> None:
    """The sticks flown are OVERRIDE (to the PWM's 1 us) on [start_s, end_s) and the pilot's elsewhere."""
    t = flown(result, "time_s")
    inside = (t >= start_s - 1e-9) & (t < end_s - 1e-9)
    assert inside.any() and (~inside).any()
    for name in ("roll", "pitch", "yaw", "throttle"):
        cmd, pilot = flown(result, f"cmd_{name}"), flown(result, f"pilot_{name}")
        assert np.all(np.abs(cmd[inside] - getattr(OVERRIDE, name)) <= 1e-3 + 1e-12), name
        assert np.array_equal(cmd[~inside], pilot[~inside]), name


def test_lockstep_override_then_release(tmp_path):
    result, companion = fly_with_companion(tmp_path, Autopilot.ARDUPILOT, release=True)
    s = result.summary
    assert s["error"] is None and s["completed"], s.get("error")
    assert_override_between(result, 1.0, 2.0)  # released at the first tick from 2.0 s on
    link = s["link"]
    assert link["overrides_accepted"] == 41 and link["overrides_rejected"] == 0  # 40 ticks + the release
    assert link["override_honoured_s"] == pytest.approx(1.0, abs=1e-6)
    assert link["override_honoured_spans_s"] == [[1.0, 2.0]]
    assert link["lockstep_wait_s"] > 0.0
    # telemetry at the contract's rates, decimated to the 40 Hz control step; every tick ends with ATTITUDE
    rate = link["sent_rate_hz"]
    sim = s["sim_time_s"]
    assert link["sent"]["ATTITUDE"] == len(flown(result, "time_s"))
    assert rate["GLOBAL_POSITION_INT"] == pytest.approx(40.0, rel=0.05)
    assert rate["SCALED_PRESSURE"] == pytest.approx(10.0, rel=0.1) and rate["VFR_HUD"] == pytest.approx(10.0, rel=0.1)
    assert rate["WIND"] == pytest.approx(2.0, rel=0.3) and rate["GPS_RAW_INT"] == pytest.approx(5.0, rel=0.2)
    # 1 Hz from t = 0, three POWEROFF at the end, and the start's (every 0.5 s until the companion answers: one or two)
    assert math.floor(sim) + 1 + 3 + 1 <= link["sent"]["HEARTBEAT"] <= math.floor(sim) + 1 + 3 + 2
    assert companion.types[-1] == "HEARTBEAT" and companion.poweroff == 3
    assert companion.attitude_ms == sorted(companion.attitude_ms)
    assert np.all(np.diff(companion.gps_usec) == 200_000)  # each fix once, stamped with its time of validity
    assert np.all(flown(result, "activation_margin_m")[1:] == pytest.approx(7.5))
    assert mavutil.mavlink_connection(str(tmp_path / "flight.tlog")).recv_match(type="GLOBAL_POSITION_INT") is not None


def test_rc_override_times_out_without_a_release(tmp_path):
    result, _ = fly_with_companion(tmp_path, Autopilot.ARDUPILOT, release=False, rc_override_time_s=1.0)
    # the last override at the 1.975 s tick is honoured for 1 s: through the tick before 2.975 s
    assert_override_between(result, 1.0, 2.975)


def test_px4_manual_control_times_out(tmp_path):
    result, _ = fly_with_companion(tmp_path, Autopilot.PX4, release=False)
    assert_override_between(result, 1.0, 2.475)  # COM_RC_LOSS_T 0.5 s after the last MANUAL_CONTROL


def test_run_cli_lockstep_timeout_is_an_error_line(tmp_path):
    port = free_udp_port()  # nobody answers: the start's wait times out
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "run", str(SCENARIO), "--out", str(tmp_path), "--quiet", "--no-plot",
         "--mavlink", f"udpout:127.0.0.1:{port}", "--lockstep", "--lockstep-start-timeout-s", "0.5"],
        capture_output=True, text=True, timeout=300, env=env, cwd=ROOT,
    )  # fmt: skip
    assert proc.returncode == 1, proc.stderr
    assert "lock-step: no companion HEARTBEAT within 0.5 s" in proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
