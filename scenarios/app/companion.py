"""The geofence unit as its own process: a MAVLink 2 companion computer (``geofence-testbed companion``).

It listens to the vehicle's telemetry and runs the same :class:`~geofence.unit.geofence_unit.GeofenceUnit` as the
in-process flight, on its OWN estimate: :class:`~geofence.estimation.estimator.GeofenceEstimator` and
:class:`~geofence.estimation.wind_estimator.WindEstimator`, configured as :mod:`scenarios.flight.sensing`
configures them (the scenario's sensor figures, the profile's envelope, the forecast wind prior), fed with the
decoders of :mod:`scenarios.link.telemetry` (GPS_RAW_INT -> GpsFix, SCALED_PRESSURE + VFR_HUD -> AirData,
ATTITUDE -> AttitudeSample). Per ATTITUDE (the vehicle's frame marker; ``dt`` from ``time_boot_ms``):

1. the estimator steps on what arrived since the last one, the wind estimator after it;
2. the unit steps (the pilot's sticks are not on the link: it is given neutral sticks, and what it returns is
   sent only while it overrides);
3. while it overrides (OVERRIDE, LAND_IN_GAP, TERMINATE): RC_CHANNELS_OVERRIDE (ArduPilot; chan1-4, re-sent every
   step, far inside RC_OVERRIDE_TIME) or MANUAL_CONTROL (PX4, inside COM_RC_LOSS_T); on hand-back the explicit
   release (RC: 0 on chan1-8, sent on three steps; PX4: MANUAL_CONTROL stops, said in a STATUSTEXT);
4. a STATUSTEXT per mode transition, NAMED_VALUE_INT GF_MODE on change and at 1 Hz, and last NAMED_VALUE_FLOAT
   GF_MARGIN for this ATTITUDE (the lock-step reply of the link contract).

No ATTITUDE or GLOBAL_POSITION_INT for :data:`TELEMETRY_LOSS_S` is a loss of the position source: the unit steps
on its own clock at the control rate with ``position_valid=False`` (the estimator extrapolates; the unit's
dead-reckoning and land-in-gap logic fly), and its commands keep going out. The fence is served and replaced over
the mission protocol (:class:`scenarios.link.mission_fence.FenceServer`; a new fence is refused while the unit is
not monitoring). HEARTBEAT 1 Hz as MAV_COMP_ID_ONBOARD_COMPUTER; TIMESYNC 1 Hz (and answered).

Relay mode (``--gcs URL``): a second link to a ground station. Everything is relayed both ways
(:class:`scenarios.link.router.Router`) except fence and rally-point transfers the ground station addresses to the
vehicle, which the same FenceServer answers as the vehicle's ids and does not forward; the companion's HEARTBEAT,
STATUSTEXT and GF_MODE go to both links.

The link is measured (:class:`LinkMeter`): messages and rates per type, sequence gaps per sender (dropped
messages), TIMESYNC round trips, ATTITUDE time vs receive time, and the step's processing time (ATTITUDE received
-> GF_MARGIN sent); printed at exit and written to ``--report``. It exits 0 when its vehicle's HEARTBEAT says
MAV_STATE_POWEROFF, after ``--max-duration-s``, or on Ctrl-C / SIGTERM, releasing any override first.
"""

from __future__ import annotations

import json
import math
import signal
import sys
import time
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from aircraft.profile import PlatformProfile, load_profile, parse_profile
from aircraft.sensors import SensorConfig
from analysis.formats.fence_files import ImportOptions, load_fence_file
from geofence.estimation.estimator import GeofenceEstimator
from geofence.estimation.measurements import AirData, GpsFix
from geofence.estimation.wind_estimator import WindEstimator, WindEstimatorConfig
from geofence.geometry.fence import Fence
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import StickCommand, VehicleState
from geofence.unit.config import GeofenceConfig
from geofence.unit.geofence_unit import GeofenceUnit, Mode
from geofence.validation import ConfigError
from scenarios.definition.schema import load_scenario, read_document
from scenarios.link import telemetry
from scenarios.link.connection import (
    COMPANION_COMPONENT_ID,
    COMPANION_SYSTEM_ID,
    Link,
    LinkError,
    mavlink,
    now_s,
    open_link,
    receive,
    send_heartbeat,
    send_named_int,
    send_statustext,
)
from scenarios.link.mission_fence import FenceServer
from scenarios.link.router import Router, addressed_to, fence_transfer_for, is_fence_transfer
from scenarios.link.sticks import Autopilot, manual_control, rc_override, rc_release

TELEMETRY_LOSS_S = 1.0
"""No ATTITUDE / GLOBAL_POSITION_INT for this long (wall time): the position source is lost."""
OVERRIDING = (Mode.OVERRIDE, Mode.LAND_IN_GAP, Mode.TERMINATE)
RELEASE_REPEATS = 3
"""The RC release goes out on this many consecutive steps (a lost datagram must not leave a channel held)."""
DEFAULT_DT_S = 1.0 / 40.0
ON_GROUND_AGL_M = 0.1
"""A relative altitude at or below this, nearly still vertically: on the ground (the land detector's stand-in)."""
_NEUTRAL = StickCommand()
_MODE_SEVERITY = {
    Mode.MONITOR: mavlink.MAV_SEVERITY_INFO,
    Mode.RECOVERED: mavlink.MAV_SEVERITY_NOTICE,
    Mode.OVERRIDE: mavlink.MAV_SEVERITY_WARNING,
    Mode.LAND_IN_GAP: mavlink.MAV_SEVERITY_CRITICAL,
    Mode.TERMINATE: mavlink.MAV_SEVERITY_EMERGENCY,
}


@dataclass
class CompanionSetup:
    """What the companion flies with: the fence, the unit's configuration, the platform, the sensors' figures."""

    config: GeofenceConfig
    profile: PlatformProfile
    sensors: SensorConfig = field(default_factory=SensorConfig)
    frame: LocalFrame | None = None
    """The local frame (the vehicle's home); None: taken from the first GLOBAL_POSITION_INT."""
    dt_s: float = DEFAULT_DT_S
    autopilot: Autopilot | None = None
    """None: from the vehicle's HEARTBEAT."""
    target_system: int | None = None


def setup_from_scenario(path: str | Path) -> CompanionSetup:
    """The fence, geofence configuration, profile and sensors of a scenario file (as its in-process flight)."""
    sc = load_scenario(path)
    if sc.geofence is None:
        raise ConfigError(f"{path}: geofence: the scenario has no geofence for the companion to fly")
    return CompanionSetup(sc.geofence, sc.profile, sc.sensors, sc.frame, 1.0 / sc.control_rate_hz)


def setup_from_files(fence_path: str, profile: str, ceiling_m: float | None = None) -> CompanionSetup:
    """A fence file (any importer format) and a profile name or file, the unit's defaults otherwise."""
    fence = load_fence_file(fence_path, ImportOptions(ceiling_m=ceiling_m)).fence
    if Path(profile).suffix in (".yaml", ".yml"):
        raw = read_document(profile)
        model = raw.get("model", Path(profile).stem) if isinstance(raw, dict) else Path(profile).stem
        prof = parse_profile(raw, str(model), profile)
    else:
        prof = load_profile(profile)
    return CompanionSetup(GeofenceConfig(fence=fence, fence_file=fence_path), prof)


# --------------------------------------------------------------------------- the link's figures
def _summary(values: list[float], scale: float = 1000.0) -> dict[str, float] | None:
    """mean / p50 / p99 / max of ``values`` (s) in ms."""
    if not values:
        return None
    v = sorted(values)
    pick = lambda q: v[min(len(v) - 1, int(q * (len(v) - 1) + 0.5))]  # noqa: E731
    return {
        "n": len(v), "mean_ms": round(sum(v) / len(v) * scale, 3), "p50_ms": round(pick(0.5) * scale, 3),
        "p99_ms": round(pick(0.99) * scale, 3), "max_ms": round(v[-1] * scale, 3),
    }  # fmt: skip


class LinkMeter:
    """Message counts and rates per type, MAVLink 2 sequence gaps per sender, latencies."""

    def __init__(self) -> None:
        self.t0_s = now_s()
        self.received: Counter[str] = Counter()
        self.sent: Counter[str] = Counter()
        self.first_s: dict[str, float] = {}
        self.last_s: dict[str, float] = {}
        self._seq: dict[tuple[int, int], int] = {}
        self.dropped: Counter[str] = Counter()
        self.rtt_s: list[float] = []
        self.processing_s: list[float] = []
        self.slowest: list[tuple[float, float]] = []
        self._offsets: list[float] = []

    def received_message(self, msg: Any, t_s: float) -> None:
        kind = msg.get_type()
        self.received[kind] += 1
        self.first_s.setdefault(kind, t_s)
        self.last_s[kind] = t_s
        sender = (msg.get_srcSystem(), msg.get_srcComponent())
        seq = msg.get_seq()
        last = self._seq.get(sender)
        if last is not None:
            gap = (seq - last - 1) & 0xFF
            if 0 < gap < 128:  # (a larger "gap" is a repeat or reordering, not a loss)
                self.dropped[f"{sender[0]}/{sender[1]}"] += gap
        self._seq[sender] = seq
        if kind == "ATTITUDE":
            self._offsets.append(t_s - msg.time_boot_ms / 1000.0)

    def step_done(self, t_s: float, processing_s: float) -> None:
        """One ATTITUDE answered (GF_MARGIN sent) ``processing_s`` after it was received; the slowest 5 kept."""
        self.processing_s.append(processing_s)
        self.slowest.append((processing_s, t_s))
        if len(self.slowest) > 20:
            self.slowest = sorted(self.slowest, reverse=True)[:5]

    def _sim_span_s(self) -> float:
        """The vehicle's time covered by the ATTITUDEs received (their receive offsets differ by wall - sim time)."""
        if len(self._offsets) < 2:
            return 0.0
        wall = self.last_s["ATTITUDE"] - self.first_s["ATTITUDE"]
        return wall - (self._offsets[-1] - self._offsets[0])

    def report(self) -> dict[str, Any]:
        """The figures: ``attitude_receive_lag`` (receive time - ATTITUDE time, above its least) only for a vehicle
        that runs in real time (a lock-stepped one runs at the companion's pace: see ``sim_s_per_wall_s``)."""
        span = max(now_s() - self.t0_s, 1e-9)
        low = min(self._offsets) if self._offsets else 0.0
        sim_span = self._sim_span_s()
        wall_span = self.last_s.get("ATTITUDE", 0.0) - self.first_s.get("ATTITUDE", 0.0)
        ratio = sim_span / wall_span if wall_span > 0 and sim_span > 0 else None
        rates = {}
        for kind, n in sorted(self.received.items()):
            dt = self.last_s[kind] - self.first_s[kind]
            hz = (n - 1) / dt if n > 1 and dt > 0 else None
            rates[kind] = {  # per wall second, and per second of the vehicle's clock (they differ when lock-stepped)
                "count": n, "rate_hz": None if hz is None else round(hz, 2),
                "rate_per_vehicle_s_hz": None if hz is None or ratio is None else round(hz / ratio, 2),
            }  # fmt: skip
        real_time = ratio is not None and abs(ratio - 1.0) < 0.05
        return {
            "duration_s": round(span, 3),
            "received": rates,
            "sent": dict(sorted(self.sent.items())),
            "dropped_per_sender": dict(self.dropped),
            "dropped_total": sum(self.dropped.values()),
            "timesync_rtt": _summary(self.rtt_s),
            "sim_s_per_wall_s": None if ratio is None else round(ratio, 3),
            "attitude_receive_lag": _summary([o - low for o in self._offsets]) if real_time else None,
            "processing": _summary(self.processing_s),
            "slowest_steps": [{"t_s": t, "ms": round(p * 1000.0, 3)} for p, t in sorted(self.slowest, reverse=True)[:5]],
        }


# --------------------------------------------------------------------------- the unit's own sensing
class OwnSensing:
    """The estimator and the wind estimator, fed with the telemetry decoded since the last step."""

    def __init__(self, frame: LocalFrame, setup: CompanionSetup) -> None:
        env = setup.profile.envelope
        self.frame = frame
        self.has_pitot = not env.is_multirotor
        self.estimator = GeofenceEstimator(frame, setup.sensors.estimator_config())
        self.wind = WindEstimator(env, WindEstimatorConfig(prior_enu=setup.config.wind_prior_enu))
        self._fix: GpsFix | None = None
        self._air: AirData | None = None
        self._hud: Any = None
        self.position: Any = None
        """The newest GLOBAL_POSITION_INT (its vertical speed completes the GNSS fix; relative_alt: on ground)."""

    def take(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "GPS_RAW_INT":
            v_up = -self.position.vz / 100.0 if self.position is not None else 0.0
            self._fix = telemetry.gps_fix(msg, v_up)
        elif kind == "SCALED_PRESSURE":
            self._air = telemetry.air_data(msg, self._hud, self.has_pitot)
        elif kind == "VFR_HUD":
            self._hud = msg
        elif kind == "GLOBAL_POSITION_INT":
            self.position = msg

    def step(self, dt_s: float, att: Any | None) -> VehicleState:
        """The estimate after ``dt_s``: the fix and air data that came (each used once), the attitude if given."""
        sample = telemetry.attitude_sample(att) if att is not None else None
        est = self.estimator.step(dt_s, self._fix, self._air, sample)
        self._fix = self._air = None
        valid = self.estimator.position_valid
        airspeed = float(self._hud.airspeed) if self.has_pitot and self._hud is not None else None
        self.wind.update(est, airspeed, dt_s, valid)
        p = self.position
        est.on_ground = p is not None and p.relative_alt <= ON_GROUND_AGL_M * 1000.0 and abs(p.vz) < 30
        return est

    def take_fix(self, fix: GpsFix) -> None:
        """A GNSS fix to fuse at the next :meth:`step` (as a GPS_RAW_INT would bring)."""
        self._fix = fix

    def update_unit(self, unit: GeofenceUnit, t_s: float, est: VehicleState, dt_s: float, valid: bool) -> StickCommand:
        """One :meth:`GeofenceUnit.update` on this sensing's estimate, sigmas, wind and fusion horizon."""
        e, w = self.estimator, self.wind
        return unit.update(
            t_s, est, _NEUTRAL, dt_s, wind_en=w.wind_enu, position_valid=valid, sigma_h_m=e.sigma_h_m,
            sigma_v_m=e.sigma_v_m, turbulence_sigma_mps=w.turbulence_sigma_mps, estimate_age_s=e.data_age_s,
            horizon=e.horizon_state(),
        )  # fmt: skip


_WARM_UP_DT_S = 0.25  # (16 steps of 0.25 s: past the minimum override time)


def _warm_up_states(local: Any, frame: LocalFrame, max_speed_mps: float, h_m: float) -> list[VehicleState]:
    """Two steps at the fence's recovery point, then 14 over its first keep-in vertex, flying outward at 0.8 of
    the envelope's speed (:meth:`Companion.warm_up`)."""
    (re, rn), (ve, vn) = local.recovery_en, (float(x) for x in local.keep_in.vertices[0])
    d = max(math.hypot(ve - re, vn - rn), 1e-3)
    speed = 0.8 * max_speed_mps
    states = []
    for k in range(16):
        at = 0.0 if k < 2 else 1.0
        states.append(
            VehicleState(
                t_s=k * _WARM_UP_DT_S, east_m=re + at * (ve - re), north_m=rn + at * (vn - rn), up_m=h_m, agl_m=h_m,
                alt_m=frame.h0_m + h_m, v_east_mps=speed * (ve - re) / d, v_north_mps=speed * (vn - rn) / d,
                airspeed_mps=speed,
            )
        )  # fmt: skip
    return states


# --------------------------------------------------------------------------- the companion
class Companion:
    """The companion's loop over one connection (see the module docstring): :meth:`run` until the end."""

    def __init__(self, conn: Link, setup: CompanionSetup, max_duration_s: float = math.inf, gcs: Link | None = None) -> None:
        self.conn, self.setup, self.max_duration_s = conn, setup, max_duration_s
        self.gcs = gcs
        """The ground-station link in relay mode (:meth:`_from_gcs`), else None."""
        self.router = None if gcs is None else Router(conn, gcs)
        self.env = setup.profile.envelope
        self.meter = LinkMeter()
        self.autopilot = setup.autopilot
        self.target: tuple[int, int] | None = None if setup.target_system is None else (setup.target_system, 1)
        self.server = FenceServer(conn, setup.config.fence, self._replace_fence, on_event=self._say)
        self.unit: GeofenceUnit | None = None
        self.sensing: OwnSensing | None = None
        self.mode = Mode.MONITOR
        self.exit_reason = ""
        self.t_s = 0.0
        """The unit's clock: the vehicle's time_boot_ms, then its own during a telemetry loss."""
        self.handler_errors = 0
        self.armed = False
        """The estimate has been valid once: the unit steps from then on (a loss after it is a loss)."""
        self.overrides_sent = self.releases_sent = self.lost_steps = 0
        self.transitions: list[dict[str, Any]] = []
        self._last_boot_ms: int | None = None
        self._last_telemetry_s = now_s()
        self._release_left = 0
        self._n_transitions = 0
        self._next_heartbeat_s = self._next_mode_s = self._next_lost_s = 0.0
        self._timesync: dict[int, float] = {}
        self._stop = False
        if setup.frame is not None:
            self._build(setup.frame)

    def _build(self, frame: LocalFrame) -> None:
        self.sensing = OwnSensing(frame, self.setup)
        self.unit = GeofenceUnit(self.setup.config, self.setup.config.fence.to_local(frame), self.env)

    def warm_up(self) -> None:
        """Compile the unit's and the estimators' kernels before the first ATTITUDE (a lock-stepped vehicle waits
        for each step's reply, and a first landing must not stall on a compile): throwaway units flown from the
        recovery point out over a vertex, one on given states, one through the sensing chain whose fixes stop
        half-way (the position lost: dead reckoning from the fusion horizon, then the landing)."""
        cfg, fence = self.setup.config, self.setup.config.fence
        frame = self.setup.frame or fence.default_frame()
        local = fence.to_local(frame)
        unit, lander, sensing = (
            GeofenceUnit(cfg, local, self.env),
            GeofenceUnit(cfg, local, self.env),
            OwnSensing(frame, self.setup),
        )
        h_m = 0.5 * (cfg.fence.ceiling_m + (cfg.fence.floor_m or 0.0))
        for s in _warm_up_states(local, frame, self.env.max_speed_mps, h_m):
            unit.update(s.t_s, s, _NEUTRAL, _WARM_UP_DT_S, wind_en=(0.0, 0.0), sigma_h_m=1.0, sigma_v_m=1.0)
        (re, rn), t_s = local.recovery_en, 0.0
        lat, lon, alt = frame.to_geodetic(re, rn, h_m)
        while lander.mode is not Mode.LAND_IN_GAP and t_s < 10.0:  # at the recovery point, the fixes stop at 2 s
            if t_s < 2.0:
                sensing.take_fix(GpsFix(t_s, lat, lon, alt, 0.0, 0.0, 0.0, 1.0, 1.0))
            est = sensing.step(_WARM_UP_DT_S, None)
            sensing.update_unit(lander, t_s, est, _WARM_UP_DT_S, sensing.estimator.position_valid)
            t_s += _WARM_UP_DT_S
        for _ in range(8):  # the landing's first steps
            est = sensing.step(_WARM_UP_DT_S, None)
            sensing.update_unit(lander, t_s, est, _WARM_UP_DT_S, False)
            t_s += _WARM_UP_DT_S

    def _replace_fence(self, fence: Fence) -> str | None:
        """The mission server's accepted upload: a new unit on it while monitoring, else refused."""
        if self.mode is not Mode.MONITOR:
            return f"the unit is in {self.mode.name}: a fence is replaced only while it monitors"
        config = replace(self.setup.config, fence=fence, fence_file=None, fence_warnings=())
        unit = None
        if self.sensing is not None:
            unit = GeofenceUnit(config, fence.to_local(self.sensing.frame), self.env)  # raises on a fence it cannot fly
        self.setup.config = config
        if unit is not None:
            self.unit = unit
        return None

    def stop(self, *_: Any) -> None:
        self._stop = True
        self.exit_reason = self.exit_reason or "interrupted"

    # ---- the loop
    def run(self) -> int:
        t_end = now_s() + self.max_duration_s
        try:
            while not self._stop:
                t = now_s()
                if t >= t_end:
                    self.exit_reason = f"max duration {self.max_duration_s:g} s"
                    break
                self._periodic(t)
                self._receive(0.005)
        except KeyboardInterrupt:
            self.exit_reason = "interrupted"
        self._release(final=True)
        return 0

    def _receive(self, timeout_s: float) -> None:
        """What arrived within ``timeout_s``: the vehicle's messages, then (relay) the ground station's."""
        if self.router is None:
            msg = receive(self.conn, timeout_s)
        else:
            self.router.wait(timeout_s)
            msg = receive(self.conn)
        while msg is not None and not self._stop:
            if not self._dispatch(msg) and self.router is not None:
                self.router.to_gcs(msg)
            msg = receive(self.conn)
        while self.gcs is not None and not self._stop and (msg := receive(self.gcs)) is not None:
            self._from_gcs(msg)

    def _dispatch(self, msg: Any) -> bool:
        """One message from the vehicle link: True when it was for the companion alone (not to be relayed)."""
        t = now_s()
        self.meter.received_message(msg, t)
        try:
            if self._for_server(msg) and self.server.handle(msg, t):
                return True
            self._on_message(msg, t)
        except Exception as exc:  # a message that breaks a handler must not stop the geofence: counted, reported
            self._handler_error(msg, exc)
        return False

    def _for_server(self, msg: Any) -> bool:
        """Whether the fence server sees a vehicle-link message: all of them, but in relay mode only fence transfers
        for the companion's own component (the vehicle's answers to a ground station of our system id, component 0,
        are the ground station's)."""
        if self.router is None:
            return True
        return is_fence_transfer(msg) and getattr(msg, "target_component", -1) == self.conn.mav.srcComponent

    def _from_gcs(self, msg: Any) -> None:
        """Relay mode: a fence/rally transfer addressed to the vehicle (or to the companion) is answered here, as
        the id addressed, and not forwarded; before the vehicle is known such a transfer is dropped; all else goes
        to the vehicle untouched."""
        assert self.router is not None and self.gcs is not None
        kind, me = msg.get_type(), (self.gcs.mav.srcSystem, self.gcs.mav.srcComponent)
        try:
            if self.target is None and fence_transfer_for(msg, None):
                self.router.dropped[kind] += 1
                return
            if self.target is not None and fence_transfer_for(msg, self.target):
                self.server.handle(msg, now_s(), face=self.router.face_as(self.target))
                self.router.taken[kind] += 1
                return
            if addressed_to(msg, me) and self.server.handle(msg, now_s(), face=self.gcs):
                self.router.taken[kind] += 1
                return
        except Exception as exc:  # hostile input from the ground station: counted, reported, not forwarded
            return self._handler_error(msg, exc)
        self.router.to_vehicle(msg)

    def _handler_error(self, msg: Any, exc: Exception) -> None:
        self.handler_errors += 1
        if self.handler_errors <= 5:
            self._say(f"GF: {msg.get_type()} ignored: {type(exc).__name__}", mavlink.MAV_SEVERITY_ERROR)
            print(f"companion: {msg.get_type()}: {type(exc).__name__}: {exc}", file=sys.stderr)

    def _periodic(self, t: float) -> None:
        self.server.poll(t)
        if t >= self._next_heartbeat_s:
            self._next_heartbeat_s = t + 1.0
            for link in self._own_links():
                send_heartbeat(link, mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID)
            stamp = time.monotonic_ns()
            self._timesync = {k: v for k, v in self._timesync.items() if t - v < 5.0}
            self._timesync[stamp] = t
            self.conn.mav.timesync_send(0, stamp)
            self._sent("HEARTBEAT", "TIMESYNC")
        if t >= self._next_mode_s:
            self._next_mode_s = t + 1.0
            for link in self._own_links():
                send_named_int(link, telemetry.GF_MODE_NAME, self._boot_ms(), int(self.mode))
            self._sent("NAMED_VALUE_INT")
        if self.armed and t - self._last_telemetry_s > TELEMETRY_LOSS_S:
            self._lost_step(t)

    def _on_message(self, msg: Any, t: float) -> None:
        kind = msg.get_type()
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind == "TIMESYNC":
            return self._on_timesync(msg, t)
        if kind == "HEARTBEAT":
            return self._on_heartbeat(msg, src)
        if self.target is None or src != self.target:
            return  # telemetry of another system, or before the vehicle's heartbeat
        if kind == "GLOBAL_POSITION_INT" and self.sensing is None:
            home_alt = (msg.alt - msg.relative_alt) / 1000.0
            self._build(LocalFrame(msg.lat * 1e-7, msg.lon * 1e-7, home_alt))
        if self.sensing is None:
            return
        self.sensing.take(msg)
        if kind == "GLOBAL_POSITION_INT":
            self._last_telemetry_s = t
        elif kind == "ATTITUDE":
            self._last_telemetry_s = t
            self._step(msg, t)

    def _on_heartbeat(self, msg: Any, src: tuple[int, int]) -> None:
        vehicle = msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID and msg.type not in (
            mavlink.MAV_TYPE_GCS, mavlink.MAV_TYPE_ONBOARD_CONTROLLER,
        )  # fmt: skip
        if self.target is None and vehicle and src[0] != self.conn.mav.srcSystem:
            if self.setup.target_system is None or src[0] == self.setup.target_system:
                self.target = src
        if self.target is not None and src[0] == self.target[0] and vehicle:
            self.target = src
            if self.autopilot is None:
                self.autopilot = Autopilot.PX4 if msg.autopilot == mavlink.MAV_AUTOPILOT_PX4 else Autopilot.ARDUPILOT
            if msg.system_status == mavlink.MAV_STATE_POWEROFF:
                self.exit_reason = "the vehicle powered off"
                self._stop = True

    def _on_timesync(self, msg: Any, t: float) -> None:
        if msg.tc1 == 0:  # a request: answer it
            self.conn.mav.timesync_send(time.monotonic_ns(), msg.ts1)
            self._sent("TIMESYNC")
        elif msg.ts1 in self._timesync:
            self.meter.rtt_s.append(t - self._timesync.pop(msg.ts1))

    def _boot_ms(self) -> int:
        return self._last_boot_ms if self._last_boot_ms is not None else 0

    def _sent(self, *kinds: str) -> None:
        for k in kinds:
            self.meter.sent[k] += 1

    # ---- one step of the unit
    def _step(self, att: Any, t_recv: float) -> None:
        boot = int(att.time_boot_ms)
        if self._last_boot_ms is not None and boot <= self._last_boot_ms:
            return  # a repeat or a stale frame
        first = self._last_boot_ms is None
        self._last_boot_ms = boot
        dt = self.setup.dt_s if first else max(boot / 1000.0 - self.t_s, 1e-3)
        self.t_s = boot / 1000.0
        assert self.sensing is not None and self.unit is not None
        est = self.sensing.step(dt, att)
        valid = self.sensing.estimator.position_valid
        self.armed = self.armed or valid  # the unit flies from the first valid position on (a companion boots so)
        if self.armed:
            self._unit_step(est, dt, valid)
        margin = self.unit.activation_margin_m if self.armed else math.inf
        self.conn.mav.send(telemetry.gf_margin(boot, margin))
        self._sent("NAMED_VALUE_FLOAT")
        done = now_s()
        self.meter.step_done(self.t_s, done - t_recv)
        self._last_telemetry_s = done  # silence counts from when the companion listens again, not from its stall

    def _lost_step(self, t: float) -> None:
        """A step on the companion's own clock while no telemetry comes: the position source is lost."""
        if t < self._next_lost_s:
            return
        if self.lost_steps == 0 or t - self._last_telemetry_s < TELEMETRY_LOSS_S + self.setup.dt_s:
            self._say("GF: telemetry lost: position source lost", mavlink.MAV_SEVERITY_CRITICAL)
        dt = self.setup.dt_s
        self._next_lost_s = t + dt
        self.t_s += dt
        assert self.sensing is not None
        self._unit_step(self.sensing.step(dt, None), dt, False)
        self.lost_steps += 1

    def _unit_step(self, est: VehicleState, dt: float, valid: bool) -> None:
        assert self.unit is not None and self.sensing is not None
        cmd = self.sensing.update_unit(self.unit, self.t_s, est, dt, valid)
        mode = self.unit.mode
        if mode in OVERRIDING:
            self._command(cmd)
            self._release_left = 0
        elif self.mode in OVERRIDING:
            self._release_left = RELEASE_REPEATS
        if self._release_left > 0:
            self._release()
        self._announce(mode)

    def _command(self, cmd: StickCommand) -> None:
        if self.target is None:
            return
        if self.autopilot is Autopilot.PX4:
            self.conn.mav.send(manual_control(cmd, self.target[0]))
            self._sent("MANUAL_CONTROL")
        else:
            self.conn.mav.send(rc_override(cmd, *self.target))
            self._sent("RC_CHANNELS_OVERRIDE")
        self.overrides_sent += 1

    def _release(self, final: bool = False) -> None:
        """Hand the sticks back: RC 0 on chan1-8 (ArduPilot), or say that MANUAL_CONTROL stopped (PX4)."""
        if final:
            if self.mode not in OVERRIDING and self._release_left == 0:
                return
            self._release_left = RELEASE_REPEATS
        if self.target is None:
            self._release_left = 0
            return
        while self._release_left > 0:
            if self.autopilot is Autopilot.PX4:
                if self._release_left == RELEASE_REPEATS:
                    self._say("GF: hand-back: MANUAL_CONTROL stopped, the pilot has the sticks", mavlink.MAV_SEVERITY_NOTICE)
            else:
                self.conn.mav.send(rc_release(*self.target))
                self._sent("RC_CHANNELS_OVERRIDE")
            self.releases_sent += 1
            self._release_left -= 1
            if not final:
                break

    def _announce(self, mode: Mode) -> None:
        assert self.unit is not None
        new = self.unit.transitions[self._n_transitions :]
        self._n_transitions = len(self.unit.transitions)
        for tr in new:
            self.transitions.append(tr.as_dict())
            text = f"GF {tr.from_mode.name}->{tr.to_mode.name} t={tr.t_s:.2f}: {tr.reason}"
            self._say(text, _MODE_SEVERITY[tr.to_mode])
        if mode is not self.mode:
            self.mode = mode
            for link in self._own_links():
                send_named_int(link, telemetry.GF_MODE_NAME, self._boot_ms(), int(mode))
            self._sent("NAMED_VALUE_INT")

    def _say(self, text: str, severity: int = mavlink.MAV_SEVERITY_INFO) -> None:
        for link in self._own_links():
            send_statustext(link, text, severity)
        self._sent("STATUSTEXT")

    def _own_links(self) -> tuple[Link, ...]:
        """Where the companion's HEARTBEAT, STATUSTEXT and GF_MODE go: the vehicle, and the ground station."""
        return (self.conn,) if self.gcs is None else (self.conn, self.gcs)

    def report(self) -> dict[str, Any]:
        unit = self.unit
        return {
            "exit_reason": self.exit_reason,
            "autopilot": None if self.autopilot is None else self.autopilot.value,
            "target": list(self.target) if self.target is not None else None,
            "mode": self.mode.name,
            "activations": unit.activations if unit is not None else 0,
            "transitions": self.transitions,
            "overrides_sent": self.overrides_sent,
            "releases_sent": self.releases_sent,
            "telemetry_lost_steps": self.lost_steps,
            "handler_errors": self.handler_errors,
            "fence_server": {k: v for k, v in vars(self.server.stats).items()},
            "relay": None if self.router is None else self.router.report(),
            "link": self.meter.report(),
        }


def print_report(report: dict[str, Any], out: Any = sys.stdout) -> None:
    """A few lines of the report for the console."""
    link = report["link"]
    clock = "vehicle" if link["sim_s_per_wall_s"] is not None else "wall"
    key = "rate_per_vehicle_s_hz" if clock == "vehicle" else "rate_hz"
    rates = ", ".join(f"{k} {v[key]}" for k, v in link["received"].items() if v[key] is not None)
    print(f"companion: {report['exit_reason']}; mode {report['mode']}, {report['activations']} activation(s), "
          f"{report['overrides_sent']} override and {report['releases_sent']} release message(s) sent", file=out)  # fmt: skip
    pace = f" ({link['sim_s_per_wall_s']:g} vehicle s per wall s)" if clock == "vehicle" else ""
    print(f"companion: link {link['duration_s']:.1f} s{pace}; received per {clock} s, Hz: {rates}", file=out)
    print(f"companion: dropped {link['dropped_total']} message(s) {link['dropped_per_sender']}; "
          f"TIMESYNC RTT {link['timesync_rtt']}; step processing {link['processing']}", file=out)  # fmt: skip


def _open_gcs(url: str, source_system: int) -> Link:
    """The ground-station link of relay mode (a bad URL named as ``--gcs``)."""
    try:
        return open_link(url, source_system, COMPANION_COMPONENT_ID)
    except LinkError as exc:
        raise LinkError(str(exc).replace("--connect", "--gcs", 1)) from None


def run_companion(args: Any) -> int:
    """The ``companion`` sub-command (arguments: see :func:`scenarios.app.cli.build_parser`)."""
    if args.scenario is not None:
        if args.fence is not None or args.profile is not None:
            raise ConfigError("--scenario: give either --scenario or --fence with --profile, not both")
        setup = setup_from_scenario(args.scenario)
    elif args.fence is not None and args.profile is not None:
        setup = setup_from_files(args.fence, args.profile, args.ceiling_m)
    else:
        raise ConfigError("--scenario FILE, or --fence FILE with --profile NAME|FILE, is required")
    if args.autopilot is not None:
        setup.autopilot = Autopilot(args.autopilot)
    setup.target_system = args.target_system
    if args.max_duration_s is not None and not args.max_duration_s > 0:
        raise ConfigError(f"--max-duration-s: must be > 0, got {args.max_duration_s:g}")
    if args.gcs is not None and args.gcs == args.connect:
        raise ConfigError(f"--gcs {args.gcs!r}: the same link as --connect (relay mode needs two)")
    gcs = None if args.gcs is None else _open_gcs(args.gcs, args.source_system)
    conn = open_link(args.connect, args.source_system, COMPANION_COMPONENT_ID)
    companion = Companion(conn, setup, math.inf if args.max_duration_s is None else args.max_duration_s, gcs)
    companion.warm_up()
    previous = signal.signal(signal.SIGTERM, companion.stop)
    relay = "" if gcs is None else f", relaying to the ground station on {args.gcs}"
    print(f"companion: listening on {args.connect} as {args.source_system}/{COMPANION_COMPONENT_ID}{relay}", flush=True)
    try:
        code = companion.run()
    finally:
        signal.signal(signal.SIGTERM, previous)
        conn.close()
        if gcs is not None:
            gcs.close()
    report = companion.report()
    print_report(report)
    if args.report is not None:
        Path(args.report).write_text(json.dumps(report, indent=1, default=str) + "\n")
    return code


__all__ = ["COMPANION_SYSTEM_ID", "Companion", "CompanionSetup", "LinkMeter", "OwnSensing", "run_companion"]
