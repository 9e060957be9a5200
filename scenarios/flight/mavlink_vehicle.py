"""The simulated flight as a MAVLink vehicle: telemetry out, a companion's sticks in.

:func:`fly_mavlink` flies a scenario as :func:`scenarios.flight.runner.fly` does (the same platform, wind, pilot
and, from the same seed, the same simulated sensors of the geofence unit) but with NO in-process geofence unit:
the companion on the other end of the link is the geofence. Per control step (a telemetry tick):

1. truth, wind, the pilot's sticks, the unit's sensors sampled (:class:`aircraft.sensors.SensorSuite`);
2. the telemetry due (:class:`scenarios.link.telemetry.TelemetryRates`, decimated to the control rate): the
   delivered GNSS fix as GPS_RAW_INT, GLOBAL_POSITION_INT (truth: the autopilot's estimate), SCALED_PRESSURE of
   the barometer, VFR_HUD of the pitot, WIND (the wind at the vehicle), HEARTBEAT, and last the AHRS attitude as
   ATTITUDE, the tick's frame marker;
3. with ``lockstep``: wait (wall-time bound ``lockstep_timeout_s``) for the companion's GF_MARGIN of this tick
   (and, before the first tick, up to ``lockstep_start_timeout_s`` for its HEARTBEAT: the vehicle may be started
   first);
   without: paced to wall-clock time, never waiting;
4. every override received so far taken in (:class:`scenarios.link.sticks.OverrideInput`): the sticks flown are
   the honoured override channels in place of the pilot's; the pilot is told whether it has control;
5. the row recorded (the companion's reported GF_MODE and GF_MARGIN in the mode and margin columns), the sticks
   latched, the platform stepped.

It answers TIMESYNC requests at once (the companion's round-trip latency). At the end it sends three HEARTBEATs with system_status POWEROFF, 50 ms apart. The summary is fly()'s, scored
against the scenario's fence, with a ``link`` block: messages sent per type and their rates (per simulated
second), overrides accepted and refused, how long and when an override was honoured, the lock-step wait.
With ``tlog`` every message sent and received is logged, stamped with the flight's start time plus the
simulated time.
"""

from __future__ import annotations

import collections
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from aircraft.sensors import SensorSuite
from analysis.scoring import SCORED_COLUMNS, score_flight
from geofence.interface import VehicleState
from geofence.unit.geofence_unit import Mode
from scenarios.definition.preflight import findings_summary, preflight_findings
from scenarios.definition.schema import PilotKind, Scenario
from scenarios.flight.runner import TAIL_AFTER_FINISH_S, FlightResult, FlightSetup, flight_summary, set_up_flight
from scenarios.link import telemetry
from scenarios.link.sticks import RC_OVERRIDE_TIME_S, Autopilot, OverrideInput
from scenarios.link.telemetry import GF_MARGIN_NAME, GF_MODE_NAME, TelemetryRates, named_value_name
from scenarios.link.tlog import TlogWriter

POWEROFF_HEARTBEATS = 3
MAV_TYPE_ONBOARD_CONTROLLER = 18  # (common.xml MAV_TYPE)
POWEROFF_SPACING_S = 0.05


@dataclass(frozen=True)
class LinkOptions:
    """How the vehicle speaks MAVLink (``run --mavlink URL ...``)."""

    url: str
    autopilot: Autopilot = Autopilot.ARDUPILOT
    lockstep: bool = False
    lockstep_timeout_s: float = 10.0
    lockstep_start_timeout_s: float = 120.0
    """How long a lock-stepped vehicle waits for the companion's first HEARTBEAT (a companion on a cold numba cache
    compiles its kernels for about a minute before it listens)."""
    rc_override_time_s: float = RC_OVERRIDE_TIME_S
    rates: TelemetryRates = TelemetryRates()
    system: int = 1
    component: int = 1
    tlog: Path | None = None


class LockstepTimeout(RuntimeError):
    """The companion's GF_MARGIN for a tick did not come within the lock-step bound."""


@dataclass
class LinkStats:
    """The link's figures for the summary."""

    sent: collections.Counter = field(default_factory=collections.Counter)
    received: collections.Counter = field(default_factory=collections.Counter)
    lockstep_wait_s: float = 0.0
    lockstep_wait_max_s: float = 0.0
    honoured_s: float = 0.0
    honoured_spans_s: list[list[float]] = field(default_factory=list)

    def honour(self, honoured: bool, t_s: float, dt_s: float) -> None:
        """Account one step flown with (or without) an honoured override."""
        if not honoured:
            return
        self.honoured_s += dt_s
        spans = self.honoured_spans_s
        if spans and abs(spans[-1][1] - t_s) < 0.5 * dt_s:
            spans[-1][1] = t_s + dt_s
        else:
            spans.append([t_s, t_s + dt_s])

    def as_dict(self, sim_time_s: float, overrides: OverrideInput, opts: LinkOptions) -> dict[str, Any]:
        per_s = 1.0 / sim_time_s if sim_time_s > 0 else 0.0
        return {
            "url": opts.url, "autopilot": opts.autopilot.value, "lockstep": opts.lockstep,
            "sent": dict(sorted(self.sent.items())),
            "sent_rate_hz": {k: round(v * per_s, 2) for k, v in sorted(self.sent.items())},
            "received": dict(sorted(self.received.items())),
            "overrides_accepted": overrides.accepted, "overrides_rejected": overrides.rejected,
            "override_honoured_s": round(self.honoured_s, 3),
            "override_honoured_spans_s": [[round(a, 3), round(b, 3)] for a, b in self.honoured_spans_s],
            "lockstep_wait_s": round(self.lockstep_wait_s, 4), "lockstep_wait_max_s": round(self.lockstep_wait_max_s, 4),
        }  # fmt: skip


class VehicleLink:
    """The vehicle's end: a pymavlink connection, its counters and the optional tlog of both directions."""

    def __init__(self, opts: LinkOptions, epoch_s: float) -> None:
        from pymavlink import mavutil

        self.conn = mavutil.mavlink_connection(
            opts.url, source_system=opts.system, source_component=opts.component, dialect="ardupilotmega"
        )
        self.stats = LinkStats()
        self.epoch_s = epoch_s
        self.t_s = 0.0
        self.tlog = TlogWriter(opts.tlog) if opts.tlog is not None else None

    def send(self, msg: Any) -> None:
        self.conn.mav.send(msg)
        self.stats.sent[msg.get_type()] += 1
        if self.tlog is not None:
            self.tlog.write(msg.get_msgbuf(), self.epoch_s + self.t_s)

    def poll(self, timeout_s: float | None = None) -> Any | None:
        """The next message received (waiting up to ``timeout_s`` wall s; None: only what has arrived)."""
        msg = self.conn.recv_match(blocking=timeout_s is not None, timeout=timeout_s)
        if msg is None or msg.get_type() == "BAD_DATA":
            return None
        self.stats.received[msg.get_type()] += 1
        if self.tlog is not None:
            self.tlog.write(msg.get_msgbuf(), self.epoch_s + self.t_s)
        if msg.get_type() == "TIMESYNC" and msg.tc1 == 0:  # a request: answered at once, as autopilots do
            self.send(self.conn.mav.timesync_encode(time.monotonic_ns(), msg.ts1))
        return msg

    def wait_for_companion(self, kind: Any, autopilot: Autopilot, timeout_s: float) -> None:
        """Lock-step start: HEARTBEATs every 0.5 s until an onboard computer's HEARTBEAT comes back (a companion
        listening on udpin learns the vehicle's address from the first one that reaches it)."""
        deadline = time.perf_counter() + timeout_s
        while time.perf_counter() < deadline:
            self.send(telemetry.heartbeat(kind, autopilot))
            wait_until = min(deadline, time.perf_counter() + 0.5)
            while (left := wait_until - time.perf_counter()) > 0.0:
                msg = self.poll(left)
                if msg is not None and msg.get_type() == "HEARTBEAT" and msg.type == MAV_TYPE_ONBOARD_CONTROLLER:
                    return
        raise LockstepTimeout(f"lock-step: no companion HEARTBEAT within {timeout_s:g} s")

    def close(self) -> None:
        self.conn.close()
        if self.tlog is not None:
            self.tlog.close()


class _Companion:
    """What the companion has told the vehicle: overrides, its mode and margin (for the recorder)."""

    def __init__(self, overrides: OverrideInput) -> None:
        self.overrides = overrides
        self.mode = int(Mode.MONITOR)
        self.margin_m = math.nan
        self.modes: list[tuple[float, int]] = []

    def take(self, msg: Any, t_s: float) -> bool:
        """Take in one received message; True when it is the lock-step marker GF_MARGIN of ``t_s``'s tick."""
        kind = msg.get_type()
        if kind in ("RC_CHANNELS_OVERRIDE", "MANUAL_CONTROL"):
            self.overrides.receive(msg, t_s)
        elif kind == "NAMED_VALUE_INT" and named_value_name(msg) == GF_MODE_NAME:
            if not self.modes or self.modes[-1][1] != msg.value:
                self.modes.append((t_s, int(msg.value)))
            self.mode = int(msg.value)
        elif kind == "NAMED_VALUE_FLOAT" and named_value_name(msg) == GF_MARGIN_NAME:
            self.margin_m = float(msg.value)
            return bool(msg.time_boot_ms == telemetry.time_boot_ms(t_s))
        return False


class _Schedule:
    """Which telemetry is due on a step: every ``round(control rate / rate)`` steps (at least every step)."""

    def __init__(self, rates: TelemetryRates, dt_s: float) -> None:
        self.every = {name: max(1, int(round(1.0 / (hz * dt_s)))) for name, hz in rates._asdict().items() if hz > 0}

    def due(self, name: str, step: int) -> bool:
        n = self.every.get(name)
        return n is not None and step % n == 0


def _publish(link: VehicleLink, sched: _Schedule, step: int, truth: VehicleState, sensed: tuple, wind: tuple, kind, opts) -> None:  # fmt: skip
    """The telemetry due on ``step``, ending with ATTITUDE."""
    fix, air, att = sensed
    if sched.due("heartbeat_hz", step):
        link.send(telemetry.heartbeat(kind, opts.autopilot))
    if fix is not None and fix.t_s >= 0.0:  # (the receiver's pre-filled first fix is from before boot: not sent)
        link.send(telemetry.gps_raw_int(fix))
    if sched.due("global_position_int_hz", step):
        link.send(telemetry.global_position_int(truth, truth.alt_m - truth.agl_m))
    if sched.due("scaled_pressure_hz", step):
        link.send(telemetry.scaled_pressure(air))
    if sched.due("vfr_hud_hz", step):
        link.send(telemetry.vfr_hud(air, truth))
    if sched.due("wind_hz", step):
        link.send(telemetry.wind(wind))
    link.send(telemetry.attitude(att))


def _wait_marker(link: VehicleLink, companion: _Companion, t_s: float, timeout_s: float) -> None:
    """Lock-step: take in messages until the GF_MARGIN of ``t_s``'s tick (stale ones skipped)."""
    wall0 = time.perf_counter()
    deadline = wall0 + timeout_s
    while True:
        remaining = deadline - time.perf_counter()
        if remaining <= 0.0:
            raise LockstepTimeout(
                f"lock-step: no {GF_MARGIN_NAME} for time_boot_ms {telemetry.time_boot_ms(t_s)} within {timeout_s:g} s"
            )
        msg = link.poll(min(remaining, 0.5))
        if msg is not None and companion.take(msg, t_s):
            break
    waited = time.perf_counter() - wall0
    link.stats.lockstep_wait_s += waited
    link.stats.lockstep_wait_max_s = max(link.stats.lockstep_wait_max_s, waited)


def _drain(link: VehicleLink, companion: _Companion, t_s: float) -> None:
    while (msg := link.poll()) is not None:
        companion.take(msg, t_s)


def fly_mavlink(scenario: Scenario, opts: LinkOptions, on_step: Callable[[float], None] | None = None) -> FlightResult:
    """Fly ``scenario`` as a MAVLink vehicle on ``opts.url`` (see the module docstring); nothing is written but the
    tlog. A lock-step timeout ends the flight with the error in the summary."""
    wall0 = time.perf_counter()
    setup = set_up_flight(scenario)
    env = setup.env
    suite = SensorSuite(scenario.sensors, has_pitot=not env.is_multirotor, seed=scenario.seed)
    companion = _Companion(OverrideInput(opts.autopilot, own_system=opts.system, rc_override_time_s=opts.rc_override_time_s))
    link = VehicleLink(opts, epoch_s=time.time())
    error: str | None = None
    step = 0
    loop0 = time.perf_counter()
    try:
        if opts.lockstep:
            link.wait_for_companion(env.kind, opts.autopilot, opts.lockstep_start_timeout_s)
        step = _loop(scenario, setup, suite, link, companion, opts, on_step)
    except (LockstepTimeout, FloatingPointError) as exc:
        error = str(exc)
    finally:
        for _ in range(POWEROFF_HEARTBEATS):
            link.send(telemetry.heartbeat(env.kind, opts.autopilot, powering_off=True))
            time.sleep(POWEROFF_SPACING_S)
        link.close()
    loop_wall, wall = time.perf_counter() - loop0, time.perf_counter() - wall0
    pilot, recorder = setup.pilot, setup.recorder
    mission = scenario.pilot.kind is PilotKind.MISSION
    completed = error is None and (pilot.finished if mission else True)
    summary = flight_summary(
        scenario, env, pilot, recorder, completed, False, error, wall, loop_wall, step * setup.frames_per_step, setup.dt_s
    )
    summary["geofence"] = "companion"
    fence = None
    if scenario.geofence is not None:
        fence = scenario.geofence.fence.to_local(setup.frame)
        summary["preflight"] = findings_summary(preflight_findings(scenario))
        summary.update(score_flight({name: recorder.column(name) for name in SCORED_COLUMNS}, fence))
    summary["companion_modes"] = [[round(t, 3), Mode(m).name if m in Mode._value2member_map_ else m] for t, m in companion.modes]
    summary["link"] = link.stats.as_dict(summary["sim_time_s"], companion.overrides, opts)
    return FlightResult(scenario=scenario, summary=summary, recorder=recorder, frame=setup.frame, pilot=pilot, fence=fence)


def _loop(
    scenario: Scenario, setup: FlightSetup, suite: SensorSuite, link: VehicleLink, companion: _Companion,
    opts: LinkOptions, on_step: Callable[[float], None] | None,
) -> int:  # fmt: skip
    """The steps of :func:`fly_mavlink`; returns the last step's index."""
    platform, pilot, dt_s, t0 = setup.platform, setup.pilot, setup.dt_s, setup.t0
    sched = _Schedule(opts.rates, dt_s)
    diverged_above_mps = 5.0 * setup.env.max_speed_mps + 50.0
    finished_at = None
    pace0 = time.perf_counter()
    step = 0
    for step in range(setup.n_steps + 1):
        truth = platform.truth()
        t = truth.t_s = truth.t_s - t0
        link.t_s = t
        if abs(truth.v_east_mps) + abs(truth.v_north_mps) + abs(truth.v_up_mps) > diverged_above_mps:
            raise FloatingPointError(f"JSBSim state of {scenario.aircraft} diverged at t={t:.2f} s")
        w = setup.sample_wind(t, truth.east_m, truth.north_m, truth.agl_m, truth.airspeed_mps)
        platform.set_wind_enu(*w)
        cmd_in = pilot.command(truth)
        sensed = suite.sample(truth)
        if not opts.lockstep:
            ahead = pace0 + t - time.perf_counter()
            if ahead > 0.0:
                time.sleep(ahead)
        _publish(link, sched, step, truth, sensed, w, setup.env.kind, opts)
        if opts.lockstep:
            _wait_marker(link, companion, t, opts.lockstep_timeout_s)
        _drain(link, companion, t)
        cmd, honoured = companion.overrides.sticks(cmd_in, t)
        link.stats.honour(honoured, t, dt_s)
        pilot.notice_control(not honoured)
        setup.recorder.append(truth, w, cmd_in, cmd, companion.mode, pilot.items_reached, activation_margin_m=companion.margin_m)
        platform.command(cmd)
        ended_by_geofence = companion.mode >= Mode.LAND_IN_GAP and truth.on_ground
        if finished_at is None and (pilot.finished or ended_by_geofence):
            finished_at = t
        if finished_at is not None and t - finished_at >= (0.0 if ended_by_geofence else TAIL_AFTER_FINISH_S):
            break
        if step == setup.n_steps:
            break
        platform.step(setup.frames_per_step)
        if on_step is not None:
            on_step(dt_s)
    return step
