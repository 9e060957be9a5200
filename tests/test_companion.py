"""The companion process (``geofence-testbed companion``) against a test-side pymavlink vehicle on loopback UDP.

The vehicle here is a point-mass multirotor in angle mode (tilt = stick x the envelope's tilt limit, the drag law
the unit's own wind estimator inverts, yaw north): its pilot flies east at ~15 m/s toward the fence's east edge
and gives up (hovers) once the sticks come back. It sends the contract's telemetry each 40 Hz tick, ending with
ATTITUDE, and waits for the companion's GF_MARGIN of that tick (lock-step), honouring the companion's overrides
through :class:`scenarios.link.sticks.OverrideInput`. The test shows: the companion overrides before the edge, keeps
sending overrides, hands back, releases every channel, says so in STATUSTEXT, reports the link, and exits by
itself when the vehicle powers off; for PX4 the same with MANUAL_CONTROL; a telemetry loss makes it land.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from support import SQUARE_FENCE_WPL, free_udp_port

from aircraft.profile import load_profile
from geofence.estimation.measurements import AirData, AttitudeSample, GpsFix
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import PlatformKind, StickCommand, VehicleState
from geofence.physics.dynamics import G_MPS2, drag_coefficients
from scenarios.link import telemetry
from scenarios.link.connection import now_s, open_link, receive
from scenarios.link.sticks import COM_RC_LOSS_T_S, Autopilot, OverrideInput, rc_override_channels

ROOT = Path(__file__).resolve().parents[1]
LAT0, LON0, GROUND_M = 47.397, 8.545, 500.0
FENCE_WPL = SQUARE_FENCE_WPL
DT_S = 0.025
GPS_EVERY, GPS_LATENCY_S = 8, 0.2  # a fix every 0.2 s, 0.2 s old


@dataclass
class PointMassQuad:
    """A multirotor point mass in angle mode: thrust tilted by the sticks, the unit's drag law, climb = throttle x rate."""

    e: float = 0.0
    n: float = 0.0
    up: float = 20.0
    ve: float = 15.0
    vn: float = 0.0
    vu: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0
    history: list = field(default_factory=list)

    def step(self, cmd: StickCommand, dt: float, env) -> None:
        k1, k2 = drag_coefficients(env)
        self.roll, self.pitch = cmd.roll * env.max_bank_rad, cmd.pitch * env.max_bank_rad
        cr, sr, cp, sp = math.cos(self.roll), math.sin(self.roll), math.cos(self.pitch), math.sin(self.pitch)
        t_up = cp * cr
        ae, an = G_MPS2 * sr / t_up, G_MPS2 * -(sp * cr) / t_up  # yaw 0: thrust east = roll, north = -pitch
        v = math.hypot(self.ve, self.vn)
        drag = (k1 + k2 * v) if v > 0 else 0.0
        self.ve += (ae - drag * self.ve) * dt
        self.vn += (an - drag * self.vn) * dt
        climb = cmd.throttle * (env.max_climb_rate_mps if cmd.throttle > 0 else env.max_descent_rate_mps)
        self.vu += (climb - self.vu) * min(1.0, dt / 0.3)
        self.e, self.n, self.up = self.e + self.ve * dt, self.n + self.vn * dt, max(0.0, self.up + self.vu * dt)


class LineVehicle:
    """The test-side vehicle (see the module docstring): telemetry out, overrides in, lock-step on GF_MARGIN."""

    def __init__(self, port: int, autopilot: Autopilot, cruise_roll: float = 0.3) -> None:
        self.conn = open_link(f"udpout:127.0.0.1:{port}", 1, 1)
        self.autopilot = autopilot
        self.env = load_profile("F450").envelope
        self.frame = LocalFrame(LAT0, LON0, GROUND_M)
        self.quad = PointMassQuad()
        self.overrides = OverrideInput(autopilot)
        self.cruise = StickCommand(roll=cruise_roll)
        self.pilot_gave_up = False
        self.modes: list[int] = []
        self.texts: list[str] = []
        self.releases = 0
        self.honoured_steps = 0
        self.max_east_m = -math.inf
        self.max_wait_s = 0.0

    def state(self, t: float) -> VehicleState:
        q = self.quad
        lat, lon, alt = self.frame.to_geodetic(q.e, q.n, q.up)
        return VehicleState(
            t_s=t, lat_deg=lat, lon_deg=lon, alt_m=alt, east_m=q.e, north_m=q.n, up_m=q.up, agl_m=q.up,
            v_east_mps=q.ve, v_north_mps=q.vn, v_up_mps=q.vu, roll_rad=q.roll, pitch_rad=q.pitch, yaw_rad=0.0,
        )  # fmt: skip

    def tick(self, step: int, send_attitude: bool = True) -> None:
        t = step * DT_S
        s = self.state(t)
        send = self.conn.mav.send
        if step % 40 == 0:
            send(telemetry.heartbeat(PlatformKind.MULTIROTOR, self.autopilot))
        if step % GPS_EVERY == 0 and t >= GPS_LATENCY_S:
            old = self.history_state(t - GPS_LATENCY_S)
            send(telemetry.gps_raw_int(GpsFix(t - GPS_LATENCY_S, old.lat_deg, old.lon_deg, old.alt_m, old.v_east_mps, old.v_north_mps, old.v_up_mps, 0.7, 1.2)))  # fmt: skip
        send(telemetry.global_position_int(s, GROUND_M))
        if step % 4 == 0:
            air = AirData(t, None, s.alt_m)
            send(telemetry.scaled_pressure(air))
            send(telemetry.vfr_hud(air, s))
        self.quad.history.append(s)
        if send_attitude:
            send(telemetry.attitude(AttitudeSample(t, s.roll_rad, s.pitch_rad, 0.0)))

    def history_state(self, t: float) -> VehicleState:
        k = max(0, min(len(self.quad.history) - 1, int(round(t / DT_S))))
        return self.quad.history[k] if self.quad.history else self.state(t)

    def wait_margin(self, t: float, timeout_s: float = 60.0) -> None:
        want = telemetry.time_boot_ms(t)
        t0 = now_s()
        while now_s() - t0 < timeout_s:
            msg = receive(self.conn, 0.05)
            if msg is None:
                continue
            if self.take(msg, t) and msg.time_boot_ms == want:
                self.max_wait_s = max(self.max_wait_s, now_s() - t0)
                return
        raise AssertionError(f"no GF_MARGIN for t={t:.3f} within {timeout_s} s")

    def take(self, msg, t: float) -> bool:
        kind = msg.get_type()
        if kind in ("RC_CHANNELS_OVERRIDE", "MANUAL_CONTROL"):
            self.overrides.receive(msg, t)
            if kind == "RC_CHANNELS_OVERRIDE" and all(v is None for v in rc_override_channels(msg)):
                self.releases += 1
        elif kind == "STATUSTEXT":
            self.texts.append(msg.text)
        elif kind == "NAMED_VALUE_INT" and telemetry.named_value_name(msg) == telemetry.GF_MODE_NAME:
            if not self.modes or self.modes[-1] != msg.value:
                self.modes.append(int(msg.value))
        return kind == "NAMED_VALUE_FLOAT" and telemetry.named_value_name(msg) == telemetry.GF_MARGIN_NAME

    def fly(self, seconds: float, lose_telemetry_at_s: float | None = None) -> None:
        for step in range(int(round(seconds / DT_S)) + 1):
            t = step * DT_S
            if lose_telemetry_at_s is not None and t >= lose_telemetry_at_s:
                return
            self.tick(step)
            self.wait_margin(t)
            sticks, honoured = self.overrides.sticks(self.pilot_sticks(), t)
            if honoured:
                self.honoured_steps += 1
                self.pilot_gave_up = True  # the pilot hovers once the companion took over
            self.quad.step(sticks, DT_S, self.env)
            self.max_east_m = max(self.max_east_m, self.quad.e)

    def pilot_sticks(self) -> StickCommand:
        return StickCommand() if self.pilot_gave_up else self.cruise

    def power_off(self) -> None:
        for _ in range(3):
            self.conn.mav.send(telemetry.heartbeat(PlatformKind.MULTIROTOR, self.autopilot, powering_off=True))
        self.conn.close()


def start_companion(tmp_path: Path, port: int, *extra: str) -> subprocess.Popen:
    fence = tmp_path / "fence.txt"
    fence.write_text(FENCE_WPL)
    cmd = [
        sys.executable, "-m", "scenarios.app.cli", "companion", "--connect", f"udpin:127.0.0.1:{port}",
        "--fence", str(fence), "--profile", "F450", "--ceiling-m", "60", "--report", str(tmp_path / "report.json"),
        "--max-duration-s", "240", *extra,
    ]  # fmt: skip
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    ready = proc.stdout.readline()  # the companion's socket is bound: the vehicle's first tick reaches it
    assert ready.startswith("companion: listening"), (ready, proc.stderr.read() if proc.poll() is not None else "")
    return proc


def east_edge_m() -> float:
    frame = LocalFrame(LAT0, LON0, GROUND_M)
    return frame.to_enu(LAT0, 8.547, GROUND_M)[0]


def finish(proc: subprocess.Popen, tmp_path: Path, timeout_s: float = 30.0) -> dict:
    out, err = proc.communicate(timeout=timeout_s)
    assert proc.returncode == 0, err
    report = json.loads((tmp_path / "report.json").read_text())
    report["stdout"] = out
    return report


@pytest.mark.slow
@pytest.mark.parametrize("autopilot", [Autopilot.ARDUPILOT, Autopilot.PX4])
def test_companion_overrides_before_the_edge_hands_back_and_releases(tmp_path, autopilot):
    port = free_udp_port()
    proc = start_companion(tmp_path, port)
    try:
        v = LineVehicle(port, autopilot)
        v.fly(30.0)
        v.power_off()
        report = finish(proc, tmp_path)
    finally:
        proc.kill()
    edge = east_edge_m()
    assert report["exit_reason"] == "the vehicle powered off"
    assert report["autopilot"] == autopilot.value  # from the vehicle's HEARTBEAT
    names = [(t["from"], t["to"]) for t in report["transitions"]]
    assert names[:3] == [("MONITOR", "OVERRIDE"), ("OVERRIDE", "RECOVERED"), ("RECOVERED", "MONITOR")], names
    assert v.max_east_m < edge, (v.max_east_m, edge)  # overridden before the edge: the vehicle stayed inside
    assert v.honoured_steps > 2.0 / DT_S
    # PX4 has no release: the last MANUAL_CONTROL is flown until COM_RC_LOSS_T passes without one
    hold = 0 if autopilot is Autopilot.ARDUPILOT else round(COM_RC_LOSS_T_S / DT_S)
    assert v.honoured_steps <= report["overrides_sent"] + hold
    assert v.modes[v.modes.index(1) :][:3] == [1, 2, 0]  # (a GF_MODE before the vehicle was heard went nowhere)
    assert any("MONITOR->OVERRIDE" in t for t in v.texts) and any("OVERRIDE->RECOVERED" in t for t in v.texts)
    if autopilot is Autopilot.ARDUPILOT:
        assert v.releases >= 1  # chan1-8 = 0 on hand-back
        assert all(x is None for x in v.overrides.values)
    else:
        assert any("MANUAL_CONTROL stopped" in t for t in v.texts)
    link = report["link"]
    assert link["received"]["ATTITUDE"]["count"] == int(30.0 / DT_S) + 1
    assert link["dropped_total"] == 0 and link["processing"]["p99_ms"] < 100.0
    assert "companion: the vehicle powered off" in report["stdout"]


@pytest.mark.slow
def test_telemetry_loss_is_position_loss_and_the_companion_lands(tmp_path):
    port = free_udp_port()
    proc = start_companion(tmp_path, port)
    try:
        v = LineVehicle(port, Autopilot.ARDUPILOT, cruise_roll=0.0)
        v.fly(10.0, lose_telemetry_at_s=5.0)  # hovering inside, then the telemetry stops
        t0 = now_s()
        landing = []
        while now_s() - t0 < 3.0:
            msg = receive(v.conn, 0.05)
            if msg is not None:
                v.take(msg, 5.0)
                if msg.get_type() == "RC_CHANNELS_OVERRIDE":
                    landing.append(rc_override_channels(msg))
        v.power_off()
        report = finish(proc, tmp_path)
    finally:
        proc.kill()
    assert ("MONITOR", "LAND_IN_GAP") in [(t["from"], t["to"]) for t in report["transitions"]]
    assert "position source lost" in report["transitions"][0]["reason"]
    assert report["telemetry_lost_steps"] > 0 and len(landing) > 20  # its own clock: overrides keep going out
    assert any("telemetry lost" in t for t in v.texts)
