"""Model validation: fly each platform through standard manoeuvres and compare with published figures.

This module owns the *measurement* of a platform's performance in the sim and
its comparison with (a) published reference bands and (b) the envelope its
profile declares. It flies platforms only through the Platform protocol
(``reset`` / ``command`` / ``step`` / ``truth``) with stick commands at a 40 Hz
outer loop, like the simulation loop, and imports nothing from ``scenarios/``
or ``analysis/``.

Manoeuvres (calm air unless stated, air start at :data:`START_AGL_M`):

* multirotor: steady forward speed at several pitch sticks (cruise = 1/2 stick,
  top speed = full stick; the steady speed/tilt pairs identify the drag law
  ``g·tan(tilt) = k1·v + k2·v²``), stop from top speed and from cruise (full
  reverse stick until the along-track velocity is 0: distance, time, reaction
  time to 1 m/s² of deceleration), zero-tilt pick-up of a 5 m/s wind step (time
  to 63 %), full climb and descent (steady rate, arrest on release), roll step
  (steady tilt, time to 90 %, overshoot), full yaw stick (heading rate).
* fixed-wing: cruise (zero sticks), full and idle throttle stick (steady
  airspeeds, deceleration), max-bank turn (rate and radius, compared with
  ``V²/(g·tan φ)``), roll step (time to 90 % of max bank), full climb and
  descent, arrest on release, power-off glide (engine off, a sweep of descent
  commands; the best ratio of horizontal speed to sink rate).

Public API: :func:`run_validation` (the whole command: fly, write markdown,
check profiles, exit code), :func:`validate_models` (rows for a list of model
names), :func:`measure_platform`, :func:`render_markdown`,
:func:`check_profile`, :func:`land_and_sit_in_wind`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

from aircraft.factory import build_platform
from aircraft.platform import Platform
from aircraft.profile import PlatformProfile, load_profile
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import PlatformKind, StickCommand, VehicleState
from geofence.physics.dynamics import G_MPS2, drag_accel_mps2, drag_coefficients, isa_density_ratio
from geofence.physics.rooms import turn_radius_m

OUTER_HZ = 40.0
LAT0_DEG, LON0_DEG, GROUND_ALT_M = 47.0, 8.0, 400.0
SEA_LEVEL_EQUIVALENT = " (sea-level equivalent)"
"""Suffix of a speed row converted to equivalent airspeed: the published figures it is compared with are at sea level."""
FRAME = LocalFrame(LAT0_DEG, LON0_DEG, GROUND_ALT_M)
START_AGL_M = {PlatformKind.MULTIROTOR: 30.0, PlatformKind.FIXED_WING: 300.0}
WIND_STEP_MPS = 5.0
WIND_PICKUP_MAX_S = 80.0
GEAR_WIND_MPS = {"Micro250": 10.7}
"""Wind for the landing-gear check: the platform's published wind limit (default 10 m/s)."""


@dataclass(frozen=True)
class Reference:
    """A published band ``[low, high]`` for a quantity, with where it comes from."""

    low: float
    high: float
    source: str


@dataclass(frozen=True)
class ValidationRow:
    """One measured quantity of one platform, with its reference band (if any)."""

    platform: str
    quantity: str
    value: float
    unit: str
    reference: Reference | None = None
    note: str = ""

    @property
    def in_band(self) -> bool | None:
        if self.reference is None:
            return None
        if math.isnan(self.value):
            return False  # the manoeuvre did not reach its end point
        return self.reference.low <= self.value <= self.reference.high

    @property
    def ratio(self) -> float | None:
        """Measured value over the middle of the reference band."""
        if self.reference is None:
            return None
        mid = 0.5 * (self.reference.low + self.reference.high)
        return self.value / mid if mid != 0.0 and math.isfinite(mid) else None


@dataclass
class Measurement:
    """What :func:`measure_platform` found: named values (with units) and the envelope they imply."""

    platform: str
    kind: PlatformKind
    values: dict[str, tuple[float, str, str]] = field(default_factory=dict)
    """quantity -> (value, unit, note)"""
    envelope: dict[str, float] = field(default_factory=dict)
    """profile envelope key (profile units: m/s, deg, s, 1/s, 1/m) -> measured value"""
    references: dict[str, Reference] = field(default_factory=dict)
    """bands derived from the measurement itself (e.g. the turn radius from V and bank)"""
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0

    def add(self, quantity: str, value: float, unit: str, note: str = "") -> None:
        self.values[quantity] = (float(value), unit, note)


# -- published reference bands ------------------------------------------------------------
_FAESSLER = "Faessler et al., RA-L 2018 (rotor drag 0.3-0.6 1/s per unit mass); issue 10"
_F450_CLASS = "F450-class quad, 30 deg tilt, with rotor drag (issue 10; shared/README.md)"
_DJI_MINI = "DJI Mini 2 spec (249 g): 16 m/s S mode, 5 m/s ascent, 3.5 m/s descent, Level-5 wind 10.7 m/s"
_J3 = "Piper J-3C-65 Cub: cruise 75 mph, max 87 mph, stall 38 mph, climb 450 ft/min"
_C172 = "Cessna 172R: cruise 122 kt at 8000 ft, max 124 kt SL, stall 51 kt clean, climb 720 ft/min, glide ~9:1 at 65-68 KIAS"
_TERN = "Tern.xml design calculation (stall 9.3 m/s, cruise 16 m/s); own model, not a product"
FTLB_TO_NM = 1.3558179483314004
"""foot-pound-force to newton metre (exact: 0.3048 m x 4.4482216152605 N)."""
_SERVO = "hobby servo rated 0.08-0.12 s per 60 deg (e.g. Hitec HS-65MG 0.11 s at 4.8 V): 500-750 deg/s, slower under load"
_MOTOR = "3536-class 1000 kV outrunner, 45 A continuous: torque <= Kt I = 9.55e-3 N m/A x 45 A = 0.43 N m"
_TURN = "level coordinated turn R = V^2/(g tan phi) at the measured V and bank, +-10 %"

REFERENCES: dict[str, dict[str, Reference]] = {
    "F450RD": {
        "top speed at max tilt": Reference(10.0, 14.0, _F450_CLASS),
        "stop distance from top speed": Reference(0.0, 15.0, _F450_CLASS),
        "wind pick-up time to 63 % (5 m/s step)": Reference(1.5, 3.5, _FAESSLER),
        "drag per unit mass at hover, linear": Reference(0.3, 0.6, _FAESSLER),
        "climb rate, full stick": Reference(2.5, 5.0, "ArduPilot PILOT_SPEED_UP 2.5 m/s default; F450 T/W 4.4 allows 5"),
        "descent rate, full stick": Reference(1.5, 3.0, "ArduPilot PILOT_SPEED_DN (default = PILOT_SPEED_UP 2.5 m/s) range"),
    },
    "Micro250": {
        "top speed at max tilt": Reference(14.5, 17.5, _DJI_MINI),
        "stop distance from top speed": Reference(0.0, 25.0, "DJI Mini 2 S mode braking distance class (own bound: < 25 m)"),
        "wind pick-up time to 63 % (5 m/s step)": Reference(1.5, 4.0, _FAESSLER),
        "drag per unit mass at hover, linear": Reference(0.2, 0.6, _FAESSLER),
        "climb rate, full stick": Reference(4.5, 5.5, _DJI_MINI),
        "descent rate, full stick": Reference(3.0, 4.0, _DJI_MINI),
        "headway against a 10.7 m/s wind at max tilt": Reference(0.5, math.inf, _DJI_MINI + " (must make headway)"),
    },
    "F450": {
        "top speed at max tilt": Reference(10.0, 14.0, _F450_CLASS),
        "stop distance from top speed": Reference(0.0, 15.0, _F450_CLASS),
        "wind pick-up time to 63 % (5 m/s step)": Reference(1.5, 3.5, _FAESSLER),
        "drag per unit mass at hover, linear": Reference(0.3, 0.6, _FAESSLER),
    },
    "J3Cub": {
        "cruise airspeed (sea-level equivalent)": Reference(29.0, 34.0, _J3 + " (65-75 mph)"),
        "max airspeed, full throttle stick (sea-level equivalent)": Reference(33.5, 38.9, _J3),
        "min airspeed, idle throttle stick (sea-level equivalent)": Reference(17.0, 27.0, _J3 + " (>= stall, < 1.6 Vs)"),
        "climb rate, full stick": Reference(1.5, 2.3, _J3),
    },
    "c172x": {
        "cruise airspeed (sea-level equivalent)": Reference(46.0, 63.0, _C172 + " (90-122 kt)"),
        "max airspeed, full throttle stick (sea-level equivalent)": Reference(52.0, 64.0, _C172),
        "min airspeed, idle throttle stick (sea-level equivalent)": Reference(26.0, 42.0, _C172 + " (>= stall, < 1.6 Vs)"),
        "climb rate, full stick": Reference(2.5, 3.7, _C172),
        "best glide ratio, power off": Reference(8.5, 10.0, _C172),
    },
    "Tern": {
        "cruise airspeed (sea-level equivalent)": Reference(14.0, 18.0, _TERN),
        "min airspeed, idle throttle stick (sea-level equivalent)": Reference(9.3, 15.0, _TERN + " (>= stall, < 1.6 Vs)"),
        "best glide ratio, power off": Reference(
            8.0,
            11.2,
            "foam trainer with fixed gear: polar CD = 0.047 + 0.042 CL^2 "
            "(Aerosonde C_Dp 0.043, Beard & McLain App. E, plus gear) gives (L/D)max "
            "11.2 as an upper bound",
        ),
        "aileron rate, full roll reversals (max)": Reference(400.0, 750.0, _SERVO),
        "propeller torque, full throttle from idle (max)": Reference(0.30, 0.44, _MOTOR),
    },
}


PLATFORM_NOTES: dict[str, str] = {
    "F450RD": "Our F450-class quad (aircraft/models/F450RD): JSBSim's F450 plus rotor drag, ESC lag and four-leg gear.",
    "Micro250": "Our 249 g micro quad (aircraft/models/Micro250), sized from the DJI Mini 2 specification; "
    "40 deg tilt limit assumed.",
    "F450": "JSBSim's wheel F450 as shipped (no rotor drag), flown against the same F450-class bands for contrast.",
    "Tern": "Our 2.5 kg electric trainer (aircraft/models/Tern): bands from its design figures, hobby-servo and motor "
    "ratings, and a glide bound from the Aerosonde's parasitic drag plus fixed gear.",
    "J3Cub": "JSBSim's wheel J3Cub; speeds are the FC's commanded limits (profile), compared with the J-3C-65's.",
    "c172x": "JSBSim's wheel Cessna 172 plus the drag of its idling or windmilling propeller (aircraft/models/C172W; "
    "without it the c172x glides at 14.4:1); speeds are the FC's commanded limits (profile), compared with the 172R's.",
}


# -- flying --------------------------------------------------------------------------------
class _Flyer:
    """Holds sticks on a platform at the 40 Hz outer-loop rate and records what it sees."""

    def __init__(self, platform: Platform):
        self.p = platform
        self.frames = max(1, round(1.0 / (OUTER_HZ * platform.dt_s)))
        self.dt_s = self.frames * platform.dt_s
        self.sim_time_s = 0.0

    def start(self, agl_m: float, heading_deg: float = 0.0, wind_e_mps: float = 0.0) -> VehicleState:
        self.p.set_wind_enu(wind_e_mps, 0.0, 0.0)
        self.p.reset(FRAME, LAT0_DEG, LON0_DEG, agl_m, heading_deg, 0.0)
        return self.p.truth()

    def fly(self, cmd: StickCommand, seconds: float, until: Callable[[VehicleState], bool] | None = None) -> list[VehicleState]:
        states = []
        for _ in range(max(1, int(round(seconds / self.dt_s)))):
            self.p.command(cmd)
            self.p.step(self.frames)
            s = self.p.truth()
            states.append(s)
            if until is not None and until(s):
                break
        self.sim_time_s += len(states) * self.dt_s
        return states

    def fly_steady(
        self, cmd: StickCommand, signal: Callable[[VehicleState], float], max_s: float, tol_per_s: float, min_s: float = 4.0
    ) -> list[VehicleState]:
        """Hold ``cmd`` until ``signal`` changes by less than ``tol_per_s`` over the last 2 s (or ``max_s``)."""
        states: list[VehicleState] = []
        window = int(round(2.0 / self.dt_s))
        while len(states) * self.dt_s < max_s:
            states += self.fly(cmd, 1.0)
            if len(states) * self.dt_s >= min_s and len(states) > window:
                if abs(signal(states[-1]) - signal(states[-1 - window])) < 2.0 * tol_per_s:
                    break
        return states


def _mean(xs: Iterable[float]) -> float:
    xs = list(xs)
    return sum(xs) / len(xs) if xs else math.nan


def _tail(states: Sequence[VehicleState], seconds: float, dt_s: float) -> Sequence[VehicleState]:
    return states[-max(1, int(round(seconds / dt_s))) :]


def _time_to(states: Sequence[VehicleState], t0_s: float, pred: Callable[[VehicleState], bool]) -> float:
    return next((s.t_s - t0_s for s in states if pred(s)), math.nan)


def fit_drag_law(points: Sequence[tuple[float, float]]) -> tuple[float, float]:
    """Least-squares ``(k1, k2)`` with ``a = k1·v + k2·v²`` through ``(v, a)`` points (k2 >= 0)."""
    s11 = sum(v * v for v, _ in points)
    s12 = sum(v**3 for v, _ in points)
    s22 = sum(v**4 for v, _ in points)
    b1 = sum(v * a for v, a in points)
    b2 = sum(v * v * a for v, a in points)
    det = s11 * s22 - s12 * s12
    if det > 1e-12 * max(s11 * s22, 1e-300):
        k1 = (b1 * s22 - b2 * s12) / det
        k2 = (s11 * b2 - s12 * b1) / det
        if k2 >= 0.0 and k1 >= 0.0:
            return k1, k2
        if k1 < 0.0:
            return 0.0, b2 / s22
    return (b1 / s11 if s11 > 0 else 0.0), 0.0


# -- multirotor ------------------------------------------------------------------------------
@dataclass(frozen=True)
class LandingResult:
    """What :func:`land_and_sit_in_wind` saw around and after the first touchdown."""

    wind_mps: float
    touchdown_descent_mps: float
    """descent rate at the last sample before the legs touched"""
    touchdown_tilt_deg: float
    """tilt (largest of |roll|, |pitch|) at touchdown: the bank into the wind"""
    max_tilt_after_deg: float
    """largest tilt from :data:`SETTLE_AFTER_TOUCHDOWN_S` after touchdown to the end (tip-over if large)"""
    final_tilt_deg: float
    drift_m: float
    """horizontal distance moved while sitting (from the settle time to the end)"""
    diverged: bool
    """JSBSim's state went to NaN"""

    @property
    def survived(self) -> bool:
        return not self.diverged and self.max_tilt_after_deg < 30.0 and self.final_tilt_deg < 5.0


SETTLE_AFTER_TOUCHDOWN_S = 1.0
FINAL_APPROACH_AGL_M = 2.0
LAND_SPEED_MPS = 0.5
"""Final descent rate of a landing: ArduPilot's LAND_SPEED default, 50 cm/s (below LAND_ALT_LOW)."""


def _tilt_deg(s: VehicleState) -> float:
    return math.degrees(max(abs(s.roll_rad), abs(s.pitch_rad)))


def land_and_sit_in_wind(platform: Platform, wind_mps: float, sit_s: float = 30.0, start_agl_m: float = 5.0) -> LandingResult:
    """Hold station in a steady wind (toward east), land, then sit ``sit_s`` with the motors idle.

    The descent is at full stick down to :data:`FINAL_APPROACH_AGL_M`, then at
    :data:`LAND_SPEED_MPS` to touchdown (as an autopilot's land mode does).

    The station-keeping pilot banks into the wind by the tilt the profile's drag
    law needs (feed-forward), plus a velocity and position correction. On the
    ground the flight controller idles the motors (landed logic) and levels.
    """
    f = _Flyer(platform)
    env = platform.envelope
    k1, k2 = drag_coefficients(env)
    bank_ff = -math.atan(drag_accel_mps2(k1, k2, wind_mps) / G_MPS2) / env.max_bank_rad
    s = f.start(start_agl_m, wind_e_mps=wind_mps)
    before = s
    touchdown: VehicleState | None = None
    settled: VehicleState | None = None
    max_tilt = 0.0
    n_max = int(round((start_agl_m / max(env.max_descent_rate_mps, 0.1) + 10.0 + sit_s) * OUTER_HZ))
    try:
        for _ in range(n_max):
            roll = max(-1.0, min(1.0, bank_ff - 0.15 * s.v_east_mps - 0.05 * s.east_m))
            before = s
            if touchdown is not None:
                throttle = 0.0
            elif s.agl_m > FINAL_APPROACH_AGL_M:
                throttle = -1.0
            else:
                throttle = -min(1.0, LAND_SPEED_MPS / max(env.max_descent_rate_mps, 1e-3))
            s = f.fly(StickCommand(roll=roll, throttle=throttle), 1.0 / OUTER_HZ)[-1]
            if touchdown is None and s.on_ground:
                touchdown = s
                td_descent, td_tilt = -before.v_up_mps, _tilt_deg(before)
            if touchdown is not None and s.t_s >= touchdown.t_s + SETTLE_AFTER_TOUCHDOWN_S:
                settled = settled or s
                max_tilt = max(max_tilt, _tilt_deg(s))
                if s.t_s >= settled.t_s + sit_s:
                    break
    except FloatingPointError:
        return LandingResult(wind_mps, math.nan, math.nan, math.nan, math.nan, math.nan, True)
    if touchdown is None or settled is None:
        return LandingResult(wind_mps, math.nan, math.nan, math.nan, math.nan, math.nan, False)
    return LandingResult(
        wind_mps,
        td_descent,
        td_tilt,
        max_tilt,
        _tilt_deg(s),
        math.hypot(s.east_m - settled.east_m, s.north_m - settled.north_m),
        False,
    )


def _measure_multirotor(p: Platform, m: Measurement) -> None:
    f = _Flyer(p)
    env = p.envelope
    h0 = START_AGL_M[PlatformKind.MULTIROTOR]
    tilt_limit_deg = math.degrees(min(env.max_bank_rad, env.max_pitch_rad))
    m.add("tilt limit (FC setting)", tilt_limit_deg, "deg")

    # roll step: steady tilt, time to 90 %, overshoot
    f.start(h0)
    roll = f.fly(StickCommand(roll=1.0), 3.0)
    steady_roll = math.degrees(_mean(s.roll_rad for s in _tail(roll, 1.0, f.dt_s)))
    t90 = _time_to(roll, roll[0].t_s - f.dt_s, lambda s: math.degrees(s.roll_rad) >= 0.9 * steady_roll)
    peak = max(math.degrees(s.roll_rad) for s in roll)
    m.add("tilt, full roll stick (steady)", steady_roll, "deg")
    m.add("tilt step, time to 90 %", t90, "s")
    m.add("tilt step overshoot", 100.0 * (peak / steady_roll - 1.0), "%")

    # yaw rate at full stick
    f.start(h0)
    f.fly(StickCommand(yaw=1.0), 1.0)
    a = p.truth()
    f.fly(StickCommand(yaw=1.0), 2.0)
    b = p.truth()
    dpsi = (b.yaw_rad - a.yaw_rad) % (2.0 * math.pi)
    yaw_rate = math.degrees(dpsi / (b.t_s - a.t_s))
    m.add("yaw rate, full stick", yaw_rate, "deg/s")

    # forward-speed sweep: steady (speed, tilt) pairs -> drag law; cruise = 1/2 stick
    points = []
    cruise_mps = math.nan
    for stick in (-0.25, -0.5, -0.75):
        f.start(h0)
        run = f.fly_steady(StickCommand(pitch=stick), lambda s: s.v_north_mps, 25.0, 0.02)
        tail = _tail(run, 1.0, f.dt_s)
        v = _mean(s.v_north_mps for s in tail)
        points.append((v, G_MPS2 * math.tan(abs(_mean(s.pitch_rad for s in tail)))))
        if stick == -0.5:
            cruise_mps = v
            # stop from cruise: full reverse stick until the along-track velocity is 0
            brake = f.fly(StickCommand(pitch=1.0), 15.0, until=lambda s: s.v_north_mps <= 0.0)
            t_stop = brake[-1].t_s - tail[-1].t_s
            d_stop = brake[-1].north_m - tail[-1].north_m
            vs = [tail[-1].v_north_mps] + [s.v_north_mps for s in brake]
            t_react = next(((i + 1) * f.dt_s for i in range(len(vs) - 1) if (vs[i] - vs[i + 1]) / f.dt_s >= 1.0), math.nan)
            m.add("cruise speed (1/2 pitch stick)", cruise_mps, "m/s")
            m.add("stop distance from cruise", d_stop, "m")
            m.add("stop time from cruise", t_stop, "s")
            m.add("reaction time (reversal to 1 m/s^2 decel)", t_react, "s")
            brake_accel = cruise_mps**2 / (2.0 * max(d_stop - cruise_mps * t_react, 1e-3))
            m.add("braking decel from cruise (after reaction)", brake_accel, "m/s^2")

    # top speed at full tilt, then stop from it
    f.start(h0)
    run = f.fly_steady(StickCommand(pitch=-1.0), lambda s: s.v_north_mps, 40.0, 0.02)
    tail = _tail(run, 1.0, f.dt_s)
    v_top = _mean(s.v_north_mps for s in tail)
    tilt_top = abs(_mean(s.pitch_rad for s in tail))
    points.append((v_top, G_MPS2 * math.tan(tilt_top)))
    t90 = _time_to(run, run[0].t_s - f.dt_s, lambda s: s.v_north_mps >= 0.9 * v_top)
    m.add("top speed at max tilt", v_top, "m/s", f"steady after {run[-1].t_s - run[0].t_s:.0f} s")
    m.add("time to 90 % of top speed", t90, "s")
    m.add("tilt at top speed (steady)", math.degrees(tilt_top), "deg")
    m.add("altitude change while accelerating", min(s.up_m for s in run) - h0, "m")
    brake = f.fly(StickCommand(pitch=1.0), 20.0, until=lambda s: s.v_north_mps <= 0.0)
    m.add("stop distance from top speed", brake[-1].north_m - tail[-1].north_m, "m")
    m.add("stop time from top speed", brake[-1].t_s - tail[-1].t_s, "s")

    k1, k2 = fit_drag_law(points)
    m.add("drag per unit mass at hover, linear", k1, "1/s", "fit g tan(tilt) = k1 v + k2 v^2 over 4 steady speeds")
    m.add("drag per unit mass, quadratic", k2, "1/m")
    resid = max(abs(k1 * v + k2 * v * v - a) for v, a in points)
    m.add("drag-law fit residual (max)", resid, "m/s^2")

    # zero-tilt wind pick-up
    f.start(h0)
    p.set_wind_enu(WIND_STEP_MPS, 0.0, 0.0)
    s0 = p.truth()
    run = f.fly(StickCommand(), WIND_PICKUP_MAX_S, until=lambda s: s.v_east_mps >= 0.63 * WIND_STEP_MPS)
    pickup = run[-1].t_s - s0.t_s if run[-1].v_east_mps >= 0.63 * WIND_STEP_MPS else math.nan
    m.add(
        "wind pick-up time to 63 % (5 m/s step)",
        pickup,
        "s",
        "" if math.isfinite(pickup) else f"not reached in {WIND_PICKUP_MAX_S:.0f} s",
    )

    # climb / descent and their arrest on release
    vert = {}
    for name, stick in (("climb", 1.0), ("descent", -1.0)):
        f.start(h0)
        run = f.fly(StickCommand(throttle=stick), 4.0)
        rate = abs(_mean(s.v_up_mps for s in run if s.t_s >= 2.0))
        v0 = run[-1].v_up_mps
        rel = f.fly(StickCommand(), 5.0, until=lambda s: s.v_up_mps * v0 <= 0.0)
        t_arrest = rel[-1].t_s - run[-1].t_s
        vert[name] = abs(v0) / t_arrest
        m.add(f"{name} rate, full stick", rate, "m/s")
        m.add(f"{name} arrest on release, mean decel", vert[name], "m/s^2")

    # the micro quad's published wind rating: headway at max tilt against 10.7 m/s
    if "headway against a 10.7 m/s wind at max tilt" in REFERENCES.get(p.name, {}):
        f.start(h0, wind_e_mps=-10.7)
        run = f.fly(StickCommand(roll=1.0), 12.0)
        m.add("headway against a 10.7 m/s wind at max tilt", _mean(s.v_east_mps for s in _tail(run, 2.0, f.dt_s)), "m/s")

    # landing gear: station-keeping landing and sitting in a calm and a limit wind
    for wind in (0.0, GEAR_WIND_MPS.get(p.name, 10.0)):
        r = land_and_sit_in_wind(p, wind, sit_s=30.0)
        tag = f"in {wind:g} m/s wind"
        note = "diverged (NaN)" if r.diverged else ""
        m.add(f"gear: touchdown descent rate {tag}", r.touchdown_descent_mps, "m/s", note)
        m.add(f"gear: tilt at touchdown {tag}", r.touchdown_tilt_deg, "deg", "banked into the wind" if wind else "")
        m.add(f"gear: max tilt from 1 s after touchdown {tag}", r.max_tilt_after_deg, "deg", note)
        m.add(f"gear: drift sitting 30 s {tag}", r.drift_m, "m")
        m.references[f"gear: max tilt from 1 s after touchdown {tag}"] = Reference(0.0, 30.0, "no tip-over (issue 10)")
        m.references[f"gear: drift sitting 30 s {tag}"] = Reference(0.0, 0.1, "stays put on its legs (issue 10)")

    m.envelope = {
        "cruise_speed_mps": cruise_mps,
        "max_speed_mps": v_top,
        "max_bank_deg": steady_roll,
        "max_pitch_deg": math.degrees(tilt_top),
        "max_yaw_rate_deg_s": yaw_rate,
        "max_climb_rate_mps": m.values["climb rate, full stick"][0],
        "max_descent_rate_mps": m.values["descent rate, full stick"][0],
        "braking_decel_mps2": m.values["braking decel from cruise (after reaction)"][0],
        "vertical_accel_mps2": min(vert.values()),
        "reaction_time_s": m.values["reaction time (reversal to 1 m/s^2 decel)"][0],
        "drag_linear_per_s": k1,
        "drag_quadratic_per_m": k2,
    }
    m.sim_time_s = f.sim_time_s


# -- fixed-wing ------------------------------------------------------------------------------
def _unwrapped_rate_deg_s(states: Sequence[VehicleState]) -> float:
    total = 0.0
    for a, b in zip(states, states[1:]):
        total += (b.yaw_rad - a.yaw_rad + math.pi) % (2.0 * math.pi) - math.pi
    return math.degrees(total / (states[-1].t_s - states[0].t_s))


def _measure_fixed_wing(p: Platform, m: Measurement) -> None:
    f = _Flyer(p)
    h0 = START_AGL_M[PlatformKind.FIXED_WING]

    def as_(s: VehicleState) -> float:
        return s.airspeed_mps

    f.start(h0)
    run = f.fly(StickCommand(), 10.0)
    v_cruise = _mean(s.airspeed_mps for s in _tail(run, 3.0, f.dt_s))
    m.add("cruise airspeed", v_cruise, "m/s", "zero sticks")
    m.add("altitude hold error at cruise (max)", max(abs(s.up_m - h0) for s in run), "m")

    run = f.fly_steady(StickCommand(throttle=1.0), as_, 60.0, 0.03, min_s=25.0)
    v_max = _mean(s.airspeed_mps for s in _tail(run, 2.0, f.dt_s))
    m.add("max airspeed, full throttle stick", v_max, "m/s")

    f.start(h0)
    s0 = p.truth()
    run = f.fly_steady(StickCommand(throttle=-1.0), as_, 60.0, 0.03, min_s=25.0)
    v_min = _mean(s.airspeed_mps for s in _tail(run, 2.0, f.dt_s))
    m.add("min airspeed, idle throttle stick", v_min, "m/s")
    # published speeds are sea-level figures (an equivalent airspeed): the bands compare EAS = TAS sqrt(sigma)
    alt_m = GROUND_ALT_M + h0
    root_sigma = math.sqrt(isa_density_ratio(alt_m))
    for name, v in (
        ("cruise airspeed", v_cruise),
        ("max airspeed, full throttle stick", v_max),
        ("min airspeed, idle throttle stick", v_min),
    ):
        m.add(f"{name}{SEA_LEVEL_EQUIVALENT}", v * root_sigma, "m/s", f"TAS x sqrt(sigma), ISA at {alt_m:.0f} m AMSL")
    target = s0.airspeed_mps - 0.9 * (s0.airspeed_mps - v_min)
    t90 = _time_to(run, s0.t_s, lambda s: s.airspeed_mps <= target)
    decel = 0.9 * (s0.airspeed_mps - v_min) / t90 if t90 > 0 else math.nan
    m.add("speed reduction from cruise, mean decel to 90 %", decel, "m/s^2")
    # from idle, full throttle: the largest propeller torque (a current-limited motor caps it)
    model = p.model  # type: ignore[attr-defined]
    torque_nm = 0.0
    for _ in range(int(round(3.0 / f.dt_s))):
        f.fly(StickCommand(throttle=1.0), f.dt_s)
        torque_nm = max(torque_nm, abs(model.get("propulsion/engine/propeller-torque-ftlb")) * FTLB_TO_NM)
    m.add("propeller torque, full throttle from idle (max)", torque_nm, "N m")

    f.start(h0)
    run = f.fly(StickCommand(roll=1.0), 20.0)
    bank_deg = math.degrees(_mean(s.roll_rad for s in _tail(run, 5.0, f.dt_s)))
    t90 = _time_to(run, run[0].t_s - f.dt_s, lambda s: math.degrees(s.roll_rad) >= 0.9 * bank_deg)
    tail = list(_tail(run, 8.0, f.dt_s))
    rate_deg_s = _unwrapped_rate_deg_s(tail)
    v_turn = _mean(s.ground_speed_mps for s in tail)
    radius = v_turn / math.radians(abs(rate_deg_s))
    r_theory = turn_radius_m(v_turn, math.radians(bank_deg))
    m.add("bank, full roll stick (steady)", bank_deg, "deg")
    m.add("roll step, time to 90 % of max bank", t90, "s")
    m.add("turn rate at max bank", rate_deg_s, "deg/s")
    m.add("turn radius at max bank", radius, "m", f"at {v_turn:.1f} m/s")
    # the turn-radius band is physics at the measured speed and bank, not a product figure
    m.references["turn radius at max bank"] = Reference(0.9 * r_theory, 1.1 * r_theory, _TURN)

    # bank reversals every 0.5 s, frame by frame: the fastest aileron motion (servo rate limit)
    f.start(h0)
    prev, rate_max = model.get("fcs/left-aileron-pos-rad"), 0.0
    for k in range(int(round(3.0 / p.dt_s))):
        p.command(StickCommand(roll=1.0 if (k * p.dt_s) % 1.0 < 0.5 else -1.0))
        p.step(1)
        a = model.get("fcs/left-aileron-pos-rad")
        rate_max, prev = max(rate_max, abs(a - prev) / p.dt_s), a
    f.sim_time_s += 3.0
    m.add("aileron rate, full roll reversals (max)", math.degrees(rate_max), "deg/s")

    vert = {}
    for name, stick in (("climb", 1.0), ("descent", -1.0)):
        f.start(h0)
        run = f.fly(StickCommand(pitch=stick), 15.0)
        rate = abs(_mean(s.v_up_mps for s in _tail(run, 5.0, f.dt_s)))
        v0 = run[-1].v_up_mps
        rel = f.fly(StickCommand(), 8.0, until=lambda s: s.v_up_mps * v0 <= 0.0)
        vert[name] = abs(v0) / (rel[-1].t_s - run[-1].t_s)
        m.add(f"{name} rate, full stick", rate, "m/s")
        m.add(f"{name} arrest on release, mean decel", vert[name], "m/s^2")

    # power-off glide: the FC's throttle forced to 0 (speed loop off, trim far below 0 so the
    # frozen speed integrator cannot lift it), a sweep of descent commands. A piston engine idles
    # (the FC keeps its mixture leaned for altitude): the handbooks' glide is at idle power.
    best = (math.nan, math.nan, math.nan)
    throttle_max = rpm_max = 0.0
    for stick in (-0.2, -0.35, -0.5, -0.7, -1.0):
        f.start(h0)
        for prop, value in (
            ("fc/speed-kp", 0.0),
            ("fc/speed-ki", 0.0),
            ("fc/climb-throttle-ff", 0.0),
            ("fc/throttle-trim", -10.0),
        ):
            model.set(prop, value)
        run = f.fly(StickCommand(pitch=stick), 45.0)
        throttle_max = max(throttle_max, model.get("fcs/throttle-cmd-norm"))
        rpm_max = max(rpm_max, model.get("propulsion/engine/engine-rpm"))
        # over the last 15 s: horizontal distance per metre of *energy* height lost
        # (h + V^2/2g), so a glide still trading speed for height is not flattered
        a, b = _tail(run, 15.0, f.dt_s)[0], run[-1]
        dist = sum(s.ground_speed_mps for s in _tail(run, 15.0, f.dt_s)[1:]) * f.dt_s
        energy_drop = (a.up_m - b.up_m) + (a.airspeed_mps**2 - b.airspeed_mps**2) / (2.0 * G_MPS2)
        if energy_drop > 0.1 and not (dist / energy_drop <= best[0]):
            best = (dist / energy_drop, b.airspeed_mps, -b.v_up_mps)
    m.add(
        "best glide ratio, power off",
        best[0],
        "-",
        f"at {best[1]:.1f} m/s, sink {best[2]:.2f} m/s; throttle {throttle_max:.2f}, engine {rpm_max:.0f} rpm",
    )
    p.reset(FRAME, LAT0_DEG, LON0_DEG, h0, 0.0, 0.0)  # restores the profile's throttle gains

    m.envelope = {
        "cruise_speed_mps": v_cruise,
        "max_speed_mps": v_max,
        "min_speed_mps": v_min,
        "max_bank_deg": bank_deg,
        "max_yaw_rate_deg_s": rate_deg_s,
        "max_climb_rate_mps": m.values["climb rate, full stick"][0],
        "max_descent_rate_mps": m.values["descent rate, full stick"][0],
        "braking_decel_mps2": decel,
        "vertical_accel_mps2": min(vert.values()),
        "reaction_time_s": m.values["roll step, time to 90 % of max bank"][0],
    }
    m.sim_time_s = f.sim_time_s


# -- public API --------------------------------------------------------------------------------
def measure_platform(profile: PlatformProfile | str) -> Measurement:
    """Build the platform for ``profile`` (or a profile's name) and fly its standard manoeuvres.

    The measurement carries the profile's name when given one (the name scenarios fly), else the
    profile's JSBSim model.
    """
    prof = load_profile(profile) if isinstance(profile, str) else profile
    t0 = time.perf_counter()
    p = build_platform(prof)
    m = Measurement(platform=profile if isinstance(profile, str) else prof.model, kind=prof.kind)
    if prof.kind is PlatformKind.MULTIROTOR:
        _measure_multirotor(p, m)
    else:
        _measure_fixed_wing(p, m)
    m.wall_time_s = time.perf_counter() - t0
    return m


def rows_for(m: Measurement) -> list[ValidationRow]:
    """The measurement as table rows, each with its published band where one exists."""
    refs = REFERENCES.get(m.platform, {})
    rows = []
    for q, (value, unit, note) in m.values.items():
        ref = m.references.get(q, refs.get(q))
        rows.append(ValidationRow(m.platform, q, value, unit, ref, note))
    return rows


def validate_models(
    models: Sequence[str], progress: Callable[[str], None] | None = None
) -> tuple[list[ValidationRow], dict[str, Measurement]]:
    """Fly every model in ``models`` (profile names) and return ``(rows, measurements by model)``.

    ``progress`` (e.g. ``print``) gets one line per model as it finishes.
    """
    rows: list[ValidationRow] = []
    measured: dict[str, Measurement] = {}
    for name in models:
        if progress:
            progress(f"flying {name} ...")
        m = measure_platform(name)
        measured[name] = m
        rows += rows_for(m)
        if progress:
            bad = sum(1 for r in rows_for(m) if r.in_band is False)
            progress(
                f"  {name}: {len(m.values)} quantities, {m.sim_time_s:.0f} s simulated in "
                f"{m.wall_time_s:.1f} s wall, {bad} outside their published band"
            )
    return rows, measured


# -- profile check ---------------------------------------------------------------------------------
TOLERANCES: dict[str, tuple[float, float]] = {
    # envelope key -> (relative, absolute floor) tolerance
    "cruise_speed_mps": (0.10, 0.5),
    "max_speed_mps": (0.10, 0.5),
    "min_speed_mps": (0.10, 0.5),
    "max_bank_deg": (0.10, 1.5),
    "max_pitch_deg": (0.10, 1.5),
    "max_yaw_rate_deg_s": (0.10, 2.0),
    "max_climb_rate_mps": (0.10, 0.2),
    "max_descent_rate_mps": (0.10, 0.2),
    "braking_decel_mps2": (0.20, 0.3),
    "vertical_accel_mps2": (0.20, 0.3),
    "reaction_time_s": (0.25, 0.05),
    "drag_linear_per_s": (0.15, 0.03),
    "drag_quadratic_per_m": (0.30, 0.003),
}


CONSERVATIVE_SIDE: dict[str, int] = {
    # +1: declaring more than measured makes the geofence's margins larger (safe side);
    # -1: declaring less does; keys not listed have no safe side.
    "max_speed_mps": +1,
    "max_bank_deg": +1,
    "max_pitch_deg": +1,
    "max_climb_rate_mps": +1,
    "max_descent_rate_mps": +1,
    "reaction_time_s": +1,
    "braking_decel_mps2": -1,
    "vertical_accel_mps2": -1,
}


@dataclass(frozen=True)
class ProfileMismatch:
    platform: str
    key: str
    declared: float
    measured: float
    tolerance: float

    @property
    def conservative(self) -> bool:
        """The declared figure errs on the geofence's safe side (see :data:`CONSERVATIVE_SIDE`)."""
        side = CONSERVATIVE_SIDE.get(self.key, 0)
        return side != 0 and math.isfinite(self.measured) and side * (self.declared - self.measured) > 0

    def __str__(self) -> str:
        return (
            f"{self.platform}: envelope.{self.key} declares {self.declared:g}, measured "
            f"{self.measured:.3g} (tolerance {self.tolerance:.3g})" + (" - on the conservative side" if self.conservative else "")
        )


def declared_envelope(profile: PlatformProfile) -> dict[str, float]:
    """The profile's envelope in profile units (deg for angles), keyed like the YAML."""
    env = profile.envelope
    out = {}
    for key in TOLERANCES:
        field_name = key.replace("_deg_s", "_radps").replace("_deg", "_rad")
        value = getattr(env, field_name)
        out[key] = math.degrees(value) if key.endswith(("_deg", "_deg_s")) else value
    return out


def check_profile(m: Measurement, profile: PlatformProfile | None = None, tolerance_scale: float = 1.0) -> list[ProfileMismatch]:
    """Envelope figures of ``profile`` (default: the shipped one) that differ from the measured ones.

    The tolerance per figure is ``max(rel·|measured|, floor)`` from :data:`TOLERANCES`, times ``tolerance_scale``.
    """
    prof = profile or load_profile(m.platform)
    declared = declared_envelope(prof)
    # a profile without a drag law gets the geofence's default one: compare that
    declared["drag_linear_per_s"], declared["drag_quadratic_per_m"] = drag_coefficients(prof.envelope)
    out = []
    for key, measured in m.envelope.items():
        rel, floor = TOLERANCES[key]
        tol = max(rel * abs(measured), floor) * tolerance_scale
        if not math.isfinite(measured) or abs(declared[key] - measured) > tol:
            out.append(ProfileMismatch(m.platform, key, declared[key], measured, tol))
    return out


# -- rendering ---------------------------------------------------------------------------------
def _fmt(x: float) -> str:
    if x is None or not math.isfinite(x):
        return "–" if x is None or math.isnan(x) else ("∞" if x > 0 else "−∞")
    return f"{x:.3g}" if abs(x) < 100 else f"{x:.0f}"


def render_markdown(rows: Sequence[ValidationRow], measured: dict[str, Measurement] | None = None) -> str:
    """The rows as a markdown document: one table per platform, then the envelope each implies."""
    lines = [
        "# Model validation",
        "",
        "Generated by `python3 bench/validate_models.py` (`aircraft.validation`): every platform flown through",
        "its standard manoeuvres in the sim (calm air, 40 Hz stick commands, air start at 30 m AGL for",
        "multirotors and 300 m AGL for fixed-wings, over ground at 400 m AMSL), compared with published bands.",
        "Published airspeeds are sea-level figures: a fixed-wing's speeds are banded as equivalent airspeed",
        "(`(sea-level equivalent)` rows, TAS x sqrt(sigma)); the true airspeeds beside them give the envelope.",
        "In band: ✓ inside, ✗ outside, blank where no published figure applies.",
        "",
    ]
    by_platform: dict[str, list[ValidationRow]] = {}
    for r in rows:
        by_platform.setdefault(r.platform, []).append(r)
    for name, prow in by_platform.items():
        lines += [f"## {name}", ""]
        if name in PLATFORM_NOTES:
            lines += [PLATFORM_NOTES[name], ""]
        lines += [
            "| quantity | measured | unit | reference band | ratio | in band | source / note |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in prow:
            band = f"{_fmt(r.reference.low)} – {_fmt(r.reference.high)}" if r.reference else ""
            flag = {True: "✓", False: "✗", None: ""}[r.in_band]
            ratio = _fmt(r.ratio) if r.ratio is not None else ""
            src = "; ".join(x for x in (r.reference.source if r.reference else "", r.note) if x)
            lines.append(f"| {r.quantity} | {_fmt(r.value)} | {r.unit} | {band} | {ratio} | {flag} | {src} |")
        lines.append("")
        m = (measured or {}).get(name)
        if m is not None:
            env = ", ".join(f"`{k}: {_fmt(v)}`" for k, v in m.envelope.items())
            lines += [
                f"Envelope implied by the measurement: {env}.",
                "",
                f"{m.sim_time_s:.0f} s simulated in {m.wall_time_s:.1f} s wall.",
                "",
            ]
    return "\n".join(lines)


# -- the command -------------------------------------------------------------------------------
DEFAULT_MODELS = ("F450RD", "Micro250", "F450", "J3Cub", "Tern", "c172x")
"""What validate-models flies without ``--models``: the hand-built profiles (the profiles ``characterize MODEL``
wrote, e.g. pa28, are flown when named, so that the default run and the tests stay as fast as before)."""


def default_models() -> list[str]:
    """The shipped hand-built profiles (:data:`DEFAULT_MODELS`), our own multirotors first."""
    from aircraft.profile import available_profiles

    names = available_profiles()
    return [n for n in DEFAULT_MODELS if n in names]


def envelope_yaml(m: Measurement) -> str:
    """The measured envelope as a YAML ``envelope:`` block (to paste into a profile)."""
    lines = ["envelope:"]
    for key, value in m.envelope.items():
        lines.append(f"  {key}: {value:.3g}")
    return "\n".join(lines)


def run_validation(
    models: Sequence[str] | None = None,
    out: str | None = "docs/validation.md",
    check_profiles: bool = False,
    tolerance_scale: float = 1.0,
    allow_conservative: bool = False,
    progress: Callable[[str], None] | None = print,
) -> int:
    """Fly ``models`` (default: every profile), write the markdown table to ``out``, optionally check profiles.

    Returns a process exit code: 0, or 1 when ``check_profiles`` finds an
    envelope figure that differs from its measurement by more than the
    tolerance (:data:`TOLERANCES` times ``tolerance_scale``); with
    ``allow_conservative`` a figure off on the geofence's safe side is reported
    but does not fail. Each mismatch is reported through ``progress`` with the
    measured envelope to paste.
    """
    from pathlib import Path

    names = list(models) if models else default_models()
    rows, measured = validate_models(names, progress=progress)
    if out:
        path = Path(out)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(render_markdown(rows, measured) + "\n")
        if progress:
            progress(f"wrote {path}")
    if not check_profiles:
        return 0
    failed = False
    for name, m in measured.items():
        mismatches = check_profile(m, tolerance_scale=tolerance_scale)
        if progress:
            progress(f"{name}: profile envelope {'OK' if not mismatches else f'{len(mismatches)} figure(s) off'}")
            for mm in mismatches:
                progress(f"  {mm}")
            if mismatches:
                progress("  measured " + envelope_yaml(m).replace("\n", "\n  "))
        failed |= any(not (allow_conservative and mm.conservative) for mm in mismatches)
    return 1 if failed else 0
