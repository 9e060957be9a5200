"""Characterising a fixed-wing JSBSim model: fly it to find the profile our controller needs to fly it.

This module owns the measurement-to-profile logic of ``characterize MODEL``: it refuses a model our
fixed-wing controller (``aircraft/systems/fixedwing_fc.xml``) cannot fly, then, flying the model with that
controller (calm air, air start at :data:`~aircraft.validation.START_AGL_M` over the validation site):

1. picks the propeller lever (``fcs/advance-cmd-norm``, written with the gains) of most thrust;
2. probes the *maximum level speed* (full throttle, altitude held) and the *minimum level speed* (speed
   command ramped down until the altitude can no longer be held: the stall or the back of the power curve),
   and picks the FC's speeds with stated margins (:data:`MIN_SPEED_MARGIN`, :data:`MAX_SPEED_MARGIN`,
   :data:`CRUISE_FRACTION`);
3. trims: the throttle and pitch attitude of level flight at cruise (``fc/throttle-trim``, ``fc/theta-trim-rad``);
4. picks the climb and descent rates the FC may command (the largest candidate flown within 10 % while the
   speed stays in the envelope) and the bank limit (the largest candidate whose level turn holds its speed);
5. tunes the gains: a coordinate search over four groups of the seed profile's gains (roll, pitch, vertical,
   speed), each scaled by :data:`GAIN_SCALES`, scored by short steps (roll, climb/descent, throttle);
6. checks the tuned set in a max-bank turn, then measures the envelope with
   :func:`aircraft.validation.measure_platform` and turns it into a profile (conservative where a figure
   is a bound), checked as ``validate-models --check-profiles`` would check it.

Everything is bounded by a budget of simulated seconds (:data:`SIM_BUDGET_S`). Speeds are equivalent
airspeeds (what the FC holds). JSBSim is reached only through :mod:`aircraft.jsbsim_model` and the platform.
"""

from __future__ import annotations

import datetime
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from aircraft.fixedwing import FixedWingPlatform
from aircraft.jsbsim_model import DERIVE_SUFFIX, FT_TO_M, JSBSimModel, add_model_dir, derive_model_xml, model_folder
from aircraft.profile import PlatformProfile, load_profile, parse_profile
from aircraft.validation import (
    FRAME,
    LAT0_DEG,
    LON0_DEG,
    OUTER_HZ,
    START_AGL_M,
    Measurement,
    check_profile,
    measure_platform,
)
from geofence.interface import PlatformKind, StickCommand
from geofence.physics.dynamics import G_MPS2
from geofence.validation import ConfigError

SEED_PROFILE = "c172x"
"""The shipped profile whose gains start the search (and whose FC settings are the defaults below)."""
MAX_BANK_DEG = 35.0
BANK_CANDIDATES_DEG = (35.0, 30.0, 25.0, 20.0)
"""The FC's bank limit: the largest whose level turn at cruise holds (with the seed gains) without the speed
falling below the envelope's minimum (the pa28 cannot hold 35 deg: its speed falls from 43 to 37.5 m/s)."""
MAX_PITCH_DEG = 15.0
MIN_SPEED_MARGIN = 1.3
"""min_speed = 1.3 x the minimum level speed (the usual 1.3 Vs approach margin)."""
MAX_SPEED_MARGIN = 0.95
"""max_speed = 0.95 x the maximum level speed at full throttle (the FC reaches it in a bounded time)."""
CRUISE_FRACTION = 0.6
"""cruise = min + 0.6 (max - min), lowered while the trim throttle is above :data:`MAX_CRUISE_THROTTLE`."""
MAX_CRUISE_THROTTLE = 0.85
CLIMB_CANDIDATES_MPS = (6.0, 5.0, 4.0, 3.5, 3.0, 2.5, 2.0, 1.5, 1.0)
DESCENT_CANDIDATES_MPS = (6.0, 5.0, 4.0, 3.5, 3.0, 2.5, 2.0)
GAIN_GROUPS = {
    "roll": ("fc/roll-kp", "fc/roll-ki", "fc/roll-rate-kd"),
    "pitch": ("fc/pitch-kp", "fc/pitch-ki", "fc/pitch-rate-kd"),
    "vertical": ("fc/alt-kp", "fc/vs-kp", "fc/vs-ki"),
    "speed": ("fc/speed-kp", "fc/speed-ki"),
}
GAIN_SCALES = (0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 2.8)
SEARCH_PASSES = 2
PROBE_SETTLE_S = 10.0
"""Level flight after the platform's own 5 s settle, before a probe: a turbine spools up slowly (the pc7 ends
the 5 s 6 m/s below cruise, its PT6 still accelerating)."""
SIM_BUDGET_S = 15000.0
"""Simulated seconds the probes and the gain search may fly (the envelope measurement adds about 500 s)."""
MIN_THRUST_TO_WEIGHT = 0.05
ADVANCE = "fcs/advance-cmd-norm"
ADVANCE_CANDIDATES = (1.0, 0.8, 0.6, 0.4, 0.2, 0.0)
"""Propeller levers tried (written with the gains; the one of most thrust at full throttle kept, the highest of
equals). A constant-speed propeller's governor holds ``minrpm + lever (maxrpm - minrpm)``; JSBSim's default 0
leaves the pa28 at 1,650 rpm and 110 of its 180 hp, unable to hold altitude below 40 m/s, and at a lever of 0.7 or
more its engine stops. No effect on a fixed-pitch propeller."""
H0_M = START_AGL_M[PlatformKind.FIXED_WING]
RHO0_KGM3 = 1.225
LBF_TO_N = 4.4482216152605
SQFT_TO_M2 = 0.09290304


class CharacterizationError(ConfigError):
    """The model cannot be flown by our controllers, or could not be trimmed or stabilised."""


class Sample(NamedTuple):
    """One 40 Hz sample of a probe flight (SI; EAS as the FC sees it)."""

    t_s: float
    phi_rad: float
    theta_rad: float
    hdot_mps: float
    up_m: float
    eas_mps: float
    throttle: float
    phi_cmd_rad: float
    theta_cmd_rad: float
    vs_cmd_mps: float
    v_cmd_mps: float
    h_ref_m: float


@dataclass
class Characterized:
    """The result of :func:`characterize`: the profile mapping and what each figure came from."""

    model: str
    doc: dict
    notes: dict[str, str] = field(default_factory=dict)
    measurement: Measurement | None = None
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    mismatches: list[str] = field(default_factory=list)
    """What :func:`aircraft.validation.check_profile` finds between the written profile and its measurement."""


# -- refusals ------------------------------------------------------------------------------------
STANDARD_CONTROLS = ("fcs/aileron-cmd-norm", "fcs/elevator-cmd-norm", "fcs/rudder-cmd-norm")


def check_flyable(model: str) -> tuple[float, float]:
    """Refuse (one line) a model our fixed-wing controller cannot fly; else its ``(weight N, wing area m^2)``."""
    folder = model_folder(model)  # an unknown name: UnknownAircraftError, one line
    with JSBSimModel(model) as m:
        engines = m.fdm.get_propulsion().get_num_engines()
        lift = [i for i in range(engines) if abs(m.get(f"propulsion/engine[{i}]/pitch-angle-rad")) > math.radians(45.0)]
        weight_n = m.get("inertia/weight-lbs") * LBF_TO_N
        area_m2 = m.get("metrics/Sw-sqft") * SQFT_TO_M2
    if lift:
        raise CharacterizationError(f"characterize {model}: a multirotor (lift thrusters): fixed-wing only in this version")
    if engines == 0:
        raise CharacterizationError(
            f"characterize {model}: no engine (a glider or a ballistic body): the controller needs thrust"
        )
    if engines > 1:
        raise CharacterizationError(
            f"characterize {model}: {engines} engines: the fixed-wing controller drives one throttle; single-engine only"
        )
    folders = [folder]
    derive = folder / f"{model}{DERIVE_SUFFIX}"
    if derive.is_file():  # a derived model of ours: the controls are in its base's files
        folders.append(model_folder(derive_model_xml(derive)[0]))
    text = "".join(p.read_text(errors="replace") for f in folders for p in sorted(f.rglob("*.xml")))
    missing = [c for c in STANDARD_CONTROLS if c not in text]
    if missing or area_m2 < 0.05:
        what = ", ".join(missing) if missing else "a wing"
        raise CharacterizationError(f"characterize {model}: not a fixed-wing with standard controls (no {what})")
    return weight_n, area_m2


# -- flying probes ---------------------------------------------------------------------------------
class Flights:
    """Builds platforms for trial profiles, flies stick scripts on them, and keeps the simulated-time budget."""

    def __init__(self, model: str, budget_s: float = SIM_BUDGET_S):
        self.model = model
        self.budget_s = budget_s
        self.sim_time_s = 0.0
        self._frames = 0

    def start(self, profile: PlatformProfile) -> FixedWingPlatform:
        """The platform air-started level at cruise, then flown level :data:`PROBE_SETTLE_S` more."""
        p = FixedWingPlatform(profile)
        p.reset(FRAME, LAT0_DEG, LON0_DEG, H0_M, 0.0, 0.0)
        self._frames = max(1, round(1.0 / (OUTER_HZ * p.dt_s)))
        self._spend(5.0)  # the platform's settle
        self.fly(p, [(StickCommand(), PROBE_SETTLE_S)])
        return p

    def _spend(self, seconds: float) -> None:
        self.sim_time_s += seconds
        if self.sim_time_s > self.budget_s:
            raise CharacterizationError(
                f"characterize {self.model}: simulated-time budget of {self.budget_s:.0f} s used up before the profile was found"
            )

    def fly(
        self,
        p: FixedWingPlatform,
        script: Sequence[tuple[StickCommand, float]],
        each: Callable[[FixedWingPlatform, Sample], bool] | None = None,
    ) -> tuple[list[Sample], bool]:
        """Fly ``(sticks, seconds)`` segments; returns the samples and whether the flight diverged.

        ``each(p, sample)`` (optional) may change properties between samples; returning True ends the flight.
        """
        out: list[Sample] = []
        dt_s = self._frames * p.dt_s
        for cmd, seconds in script:
            n = max(1, int(round(seconds / dt_s)))
            self._spend(n * dt_s)
            for _ in range(n):
                p.command(cmd)
                p.step(self._frames)
                try:
                    s = p.truth()
                except FloatingPointError:
                    return out, True
                fc = p.fc
                x = Sample(s.t_s, s.roll_rad, s.pitch_rad, s.v_up_mps, s.up_m, fc("fc/airspeed-mps"),
                           fc("fcs/throttle-cmd-norm"), fc("fc/phi-cmd-rad"), fc("fc/theta-cmd-rad"),
                           fc("fc/vs-cmd-mps"), fc("fc/speed-cmd-mps"),
                           fc("fc/h-ref-ft") * FT_TO_M - FRAME.h0_m)  # fmt: skip
                out.append(x)
                if abs(x.phi_rad) > math.radians(80.0) or abs(x.up_m - H0_M) > 250.0 or not math.isfinite(x.eas_mps):
                    return out, True
                if each is not None and each(p, x):
                    return out, False
        return out, False


def _mean(xs) -> float:
    xs = list(xs)
    return sum(xs) / len(xs) if xs else math.nan


def _tail(samples: Sequence[Sample], seconds: float) -> Sequence[Sample]:
    return samples[-max(1, int(round(seconds * OUTER_HZ))) :]


def trial_profile(model: str, env: dict[str, float], gains: dict[str, float]) -> PlatformProfile:
    """A profile for ``model`` with the given envelope (profile units) and gains, through the profile loader."""
    return parse_profile({"model": model, "kind": "fixed_wing", "envelope": env, "gains": gains}, model, f"characterize {model}")


# -- speeds, trim, rates ---------------------------------------------------------------------------
def _steady_speed(fl: Flights, p: FixedWingPlatform, cmd: StickCommand, max_s: float) -> tuple[list[Sample], bool]:
    """Hold ``cmd`` until the airspeed changes by less than 0.06 m/s over 2 s (or ``max_s``)."""
    run: list[Sample] = []
    while len(run) < max_s * OUTER_HZ:
        more, diverged = fl.fly(p, [(cmd, 2.0)])
        run += more
        if diverged:
            return run, True
        if len(run) > 20 * OUTER_HZ and abs(run[-1].eas_mps - run[-int(2 * OUTER_HZ)].eas_mps) < 0.06:
            break
    return run, False


def probe_propeller(fl: Flights, env: dict[str, float], gains: dict[str, float], weight_n: float) -> tuple[float, float]:
    """The propeller lever (``fcs/advance-cmd-norm``) of most thrust at full throttle, 8 s from the first guess of
    cruise: ``(lever, thrust N)``. Refuses an engine that does not start or gives no thrust at any lever."""
    best = (math.nan, -math.inf)
    for lever in ADVANCE_CANDIDATES:
        p = fl.start(trial_profile(fl.model, dict(env, max_speed_mps=149.0), dict(gains, **{ADVANCE: lever})))
        _, diverged = fl.fly(p, [(StickCommand(throttle=1.0), 8.0)])
        thrust_n = p.fc("propulsion/engine/thrust-lbs") * LBF_TO_N
        running = p.fc("propulsion/engine/set-running") > 0.5
        if not diverged and running and thrust_n > best[1] * 1.01:
            best = (lever, thrust_n)
    if not best[1] >= MIN_THRUST_TO_WEIGHT * weight_n:
        raise CharacterizationError(
            f"characterize {fl.model}: the engine does not start or gives no thrust ({max(best[1], 0.0):.0f} N at full "
            f"throttle, weight {weight_n:.0f} N; needs {MIN_THRUST_TO_WEIGHT:g} W)"
        )
    return best


def probe_max_level_speed(fl: Flights, env: dict[str, float], gains: dict[str, float]) -> float:
    """Steady EAS at full throttle, altitude held (the speed command far above reach)."""
    p = fl.start(trial_profile(fl.model, dict(env, max_speed_mps=149.0), gains))
    run, diverged = _steady_speed(fl, p, StickCommand(throttle=1.0), 150.0)
    tail = _tail(run, 2.0)
    if diverged or max(abs(s.up_m - H0_M) for s in tail) > 15.0:
        raise CharacterizationError(f"characterize {fl.model}: could not hold level flight at full throttle (seed gains)")
    return _mean(s.eas_mps for s in tail)


def probe_min_level_speed(fl: Flights, env: dict[str, float], gains: dict[str, float], v0: float) -> float:
    """The lowest EAS flown level while the speed command ramps down at 0.3 m/s per s (stall guard off).

    Level flight is lost when the altitude falls 5 m below the start, the bank exceeds 15 deg, or the
    pitch command reaches its (probe) limit of 25 deg.
    """
    p = fl.start(trial_profile(fl.model, dict(env, cruise_speed_mps=v0, min_speed_mps=1.0), gains))
    p.model.set("fc/max-pitch-rad", math.radians(25.0))
    lowest = [v0]

    def ramp(p: FixedWingPlatform, x: Sample) -> bool:
        lost = x.up_m < H0_M - 5.0 or abs(x.phi_rad) > math.radians(15.0) or x.theta_cmd_rad >= math.radians(24.9)
        if not lost:
            lowest[0] = min(lowest[0], x.eas_mps)
            p.model.set("fc/cruise-speed-mps", x.v_cmd_mps - 0.3 / OUTER_HZ)
        return lost or x.v_cmd_mps < 0.2 * v0

    fl.fly(p, [(StickCommand(), 1.2 * v0 / 0.3)], each=ramp)
    return lowest[0]


def choose_speeds(v_min_level: float, v_max_level: float) -> tuple[float, float, float]:
    """``(min, cruise, max)`` EAS with the stated margins, rounded to 0.5 m/s inward."""
    lo = math.ceil(2.0 * MIN_SPEED_MARGIN * v_min_level) / 2.0
    hi = math.floor(2.0 * MAX_SPEED_MARGIN * v_max_level) / 2.0
    return lo, round(2.0 * (lo + CRUISE_FRACTION * (hi - lo))) / 2.0, hi


def level_trim(fl: Flights, env: dict[str, float], gains: dict[str, float]) -> tuple[float, float]:
    """``(throttle, pitch attitude rad)`` of level flight at ``env``'s cruise, flown 25 s; refuses a failed trim."""
    p = fl.start(trial_profile(fl.model, env, gains))
    run, diverged = fl.fly(p, [(StickCommand(), 25.0)])
    tail = _tail(run, 5.0)
    v = env["cruise_speed_mps"]
    thr, theta = _mean(s.throttle for s in tail), _mean(s.theta_rad for s in tail)
    alt_err = max(abs(s.up_m - H0_M) for s in tail) if tail else math.inf
    speed_err = abs(_mean(s.eas_mps for s in tail) - v)
    if diverged or alt_err > 3.0 or not speed_err < 1.0 or thr > 0.999:
        raise CharacterizationError(
            f"characterize {fl.model}: trim failed at {v:g} m/s (altitude off {alt_err:.1f} m, speed off {speed_err:.1f} m/s, "
            f"throttle {thr:.2f})"
        )
    return thr, theta


def probe_rate(fl: Flights, env: dict[str, float], gains: dict[str, float], climb: bool) -> tuple[float, float]:
    """The largest candidate climb (descent) rate flown within 10 % at full stick, speed kept in the envelope:
    ``(candidate, measured rate)``. A climb counts the energy height gained over the last 6 s, so one that
    bleeds speed for height does not count as sustained."""
    key, stick = ("max_climb_rate_mps", 1.0) if climb else ("max_descent_rate_mps", -1.0)
    candidates = CLIMB_CANDIDATES_MPS if climb else DESCENT_CANDIDATES_MPS
    v_floor = env["min_speed_mps"] + 0.5 * (env["cruise_speed_mps"] - env["min_speed_mps"])
    for rate in candidates:
        p = fl.start(trial_profile(fl.model, dict(env, **{key: rate}), gains))
        run, diverged = fl.fly(p, [(StickCommand(pitch=stick), 20.0)])
        tail = _tail(run, 6.0)
        flown = abs(_mean(s.hdot_mps for s in tail))
        if climb and len(tail) > 1:  # the sustained climb: energy height (h + V^2/2g) gained, not speed traded for height
            dt_s = tail[-1].t_s - tail[0].t_s
            flown += (tail[-1].eas_mps ** 2 - tail[0].eas_mps ** 2) / (2.0 * G_MPS2 * dt_s) if dt_s > 0 else 0.0
        speed_ok = min(s.eas_mps for s in run) >= v_floor if climb else max(s.eas_mps for s in run) <= env["max_speed_mps"]
        if not diverged and flown >= 0.9 * rate and speed_ok:
            return rate, flown
    what = "climb" if climb else "descent"
    raise CharacterizationError(f"characterize {fl.model}: could not fly even a {candidates[-1]:g} m/s {what} at full stick")


# -- gains -----------------------------------------------------------------------------------------
ROLL_SCRIPT = ((StickCommand(roll=1.0), 6.0), (StickCommand(roll=-1.0), 8.0), (StickCommand(), 6.0))
VERTICAL_SCRIPT = (
    (StickCommand(pitch=1.0), 10.0),
    (StickCommand(), 10.0),
    (StickCommand(pitch=-1.0), 10.0),
    (StickCommand(), 10.0),
)
SPEED_SCRIPT = (
    (StickCommand(throttle=-1.0), 15.0),
    (StickCommand(), 15.0),
    (StickCommand(throttle=1.0), 10.0),
    (StickCommand(), 10.0),
)
TURN_SCRIPT = ((StickCommand(roll=1.0), 25.0), (StickCommand(), 10.0))


def _std(xs) -> float:
    xs = list(xs)
    m = _mean(xs)
    return math.sqrt(_mean((x - m) ** 2 for x in xs)) if xs else math.nan


def _roll_cost(run: Sequence[Sample], env: dict[str, float]) -> float:
    """Bank tracking (mean error / max bank) + overshoot beyond 5 % + residual oscillation + altitude lost."""
    bank = math.radians(env["max_bank_deg"])
    err = _mean(abs(s.phi_rad - s.phi_cmd_rad) for s in run) / bank
    over = max(s.phi_rad for s in run[: int(6 * OUTER_HZ)]) / bank - 1.0
    osc = _std(s.phi_rad for s in _tail(run, 3.0)) / bank
    alt = max(abs(s.up_m - H0_M) for s in run) / 20.0
    return err + 2.0 * max(0.0, over - 0.05) + 5.0 * osc + 0.5 * alt


def _vertical_cost(run: Sequence[Sample], env: dict[str, float]) -> float:
    """Climb-rate and pitch tracking, altitude-reference error, residual oscillation of the climb rate."""
    vs = _mean(abs(s.hdot_mps - s.vs_cmd_mps) for s in run) / env["max_climb_rate_mps"]
    th = _mean(abs(s.theta_rad - s.theta_cmd_rad) for s in run) / math.radians(env["max_pitch_deg"])
    alt = _mean(abs(s.h_ref_m - s.up_m) for s in run) / 5.0
    return vs + th + alt + _std(s.hdot_mps for s in _tail(run, 4.0))


def _speed_cost(run: Sequence[Sample], env: dict[str, float]) -> float:
    """Airspeed tracking (mean error / speed span), residual oscillation, altitude held."""
    span = env["cruise_speed_mps"] - env["min_speed_mps"]
    err = _mean(abs(s.eas_mps - s.v_cmd_mps) for s in run) / span
    return err + _std(s.eas_mps for s in _tail(run, 4.0)) + 0.5 * _mean(abs(s.up_m - H0_M) for s in run) / 10.0


CHECKS: dict[str, tuple[tuple[tuple[StickCommand, float], ...], Callable[[Sequence[Sample], dict[str, float]], float]]] = {
    "roll": (ROLL_SCRIPT, _roll_cost),
    "climb/descent": (VERTICAL_SCRIPT, _vertical_cost),
    "speed": (SPEED_SCRIPT, _speed_cost),
}


def score_gains(fl: Flights, env: dict[str, float], gains: dict[str, float]) -> dict[str, float]:
    """Cost per check (lower is better; ``inf`` when the flight diverged)."""
    prof = trial_profile(fl.model, env, gains)
    out = {}
    for name, (script, cost) in CHECKS.items():
        run, diverged = fl.fly(fl.start(prof), script)
        out[name] = math.inf if diverged or not run else cost(run, env)
    return out


def tune_gains(
    fl: Flights, env: dict[str, float], gains: dict[str, float], progress: Callable[[str], None]
) -> tuple[dict[str, float], dict[str, float]]:
    """Coordinate search: each group of :data:`GAIN_GROUPS` scaled by each of :data:`GAIN_SCALES` in turn, the
    lowest total cost kept, :data:`SEARCH_PASSES` passes. Returns ``(gains, cost per check)``."""
    best, best_cost = dict(gains), score_gains(fl, env, gains)
    progress(f"  gains: seed ({SEED_PROFILE}) cost {_fmt_cost(best_cost)}")
    for n in range(SEARCH_PASSES):
        for group, keys in GAIN_GROUPS.items():
            choice = 1.0
            for scale in GAIN_SCALES:
                if scale == 1.0:
                    continue
                trial = dict(best, **{k: best[k] * scale for k in keys})
                cost = score_gains(fl, env, trial)
                if sum(cost.values()) < sum(best_cost.values()):
                    best_trial, best_trial_cost, choice = trial, cost, scale
            if choice != 1.0:
                best, best_cost = best_trial, best_trial_cost
            progress(f"  gains pass {n + 1}, {group}: x{choice:g}, cost {_fmt_cost(best_cost)}")
    return best, best_cost


def _fmt_cost(cost: dict[str, float]) -> str:
    return f"{sum(cost.values()):.3f} (" + ", ".join(f"{k} {v:.3f}" for k, v in cost.items()) + ")"


def check_turn(fl: Flights, env: dict[str, float], gains: dict[str, float]) -> tuple[float, float]:
    """A 25 s max-bank turn then wings level: ``(altitude excursion m, lowest EAS m/s)``. Refuses divergence, an
    altitude excursion over 30 m, or a speed below the envelope's minimum (the turn must not approach the stall)."""
    run, diverged = fl.fly(fl.start(trial_profile(fl.model, env, gains)), TURN_SCRIPT)
    alt = max(abs(s.up_m - H0_M) for s in run) if run else math.inf
    v_low = min(s.eas_mps for s in run) if run else 0.0
    if diverged or alt > 30.0 or v_low < env["min_speed_mps"]:
        raise CharacterizationError(
            f"characterize {fl.model}: could not stabilise the max-bank turn (altitude off {alt:.0f} m, lowest speed "
            f"{v_low:.1f} m/s, min {env['min_speed_mps']:g})"
        )
    return alt, v_low


def choose_bank(fl: Flights, env: dict[str, float], gains: dict[str, float]) -> float:
    """The largest of :data:`BANK_CANDIDATES_DEG` whose max-bank turn :func:`check_turn` accepts (refuses if none)."""
    for bank in BANK_CANDIDATES_DEG[:-1]:
        try:
            check_turn(fl, dict(env, max_bank_deg=bank), gains)
            return bank
        except CharacterizationError:
            continue
    check_turn(fl, dict(env, max_bank_deg=BANK_CANDIDATES_DEG[-1]), gains)
    return BANK_CANDIDATES_DEG[-1]


# -- the whole run ---------------------------------------------------------------------------------
def _seed_envelope() -> tuple[dict[str, float], dict[str, float]]:
    from aircraft.validation import declared_envelope

    seed = load_profile(SEED_PROFILE)
    env = {k: v for k, v in declared_envelope(seed).items() if not k.startswith("drag_")}
    env.update(max_bank_deg=MAX_BANK_DEG, max_pitch_deg=MAX_PITCH_DEG)
    return env, dict(seed.gains)


def _first_guess_speed(weight_n: float, area_m2: float) -> float:
    """EAS of level flight at a lift coefficient of 0.4 (a first guess of cruise, refined by the probes)."""
    return math.sqrt(2.0 * weight_n / (RHO0_KGM3 * area_m2 * 0.4))


def _speeds(fl: Flights, env: dict, gains: dict, v0: float, notes: dict, progress: Callable[[str], None]) -> None:
    """Probe the level-speed range, choose min/cruise/max and the trim seeds (``env``, ``gains``, ``notes`` updated)."""
    lo0, hi0 = 0.75 * v0, 1.25 * v0
    env.update(cruise_speed_mps=v0, min_speed_mps=lo0, max_speed_mps=hi0)
    v_max = probe_max_level_speed(fl, env, gains)
    progress(f"  max level speed, full throttle: {v_max:.1f} m/s EAS [{fl.sim_time_s:.0f} s simulated]")
    v_min = probe_min_level_speed(fl, dict(env, max_speed_mps=max(hi0, v_max)), gains, min(v0, v_max))
    progress(f"  min level speed, speed command ramped down: {v_min:.1f} m/s EAS [{fl.sim_time_s:.0f} s simulated]")
    lo, cruise, hi = choose_speeds(v_min, v_max)
    if not lo < cruise < hi:
        raise CharacterizationError(
            f"characterize {fl.model}: no speed range to fly (level from {v_min:.1f} to {v_max:.1f} m/s EAS)"
        )
    env.update(cruise_speed_mps=cruise, min_speed_mps=lo, max_speed_mps=hi)
    for _ in range(4):  # trim; lower cruise while the throttle has no headroom left
        thr, theta = level_trim(fl, env, gains)
        gains.update({"fc/throttle-trim": round(thr, 3), "fc/theta-trim-rad": round(theta, 4)})
        if thr <= MAX_CRUISE_THROTTLE or env["cruise_speed_mps"] - 2.0 <= lo:
            break
        env["cruise_speed_mps"] = round(2.0 * (env["cruise_speed_mps"] - 0.05 * (hi - lo))) / 2.0
    thr, theta = level_trim(fl, env, gains)  # the seeds at the final cruise, re-flown from themselves
    gains.update({"fc/throttle-trim": round(thr, 3), "fc/theta-trim-rad": round(theta, 4)})
    progress(f"  trim at cruise {env['cruise_speed_mps']:g} m/s: throttle {thr:.3f}, pitch {math.degrees(theta):.2f} deg")
    notes["min_speed_mps"] = f"{MIN_SPEED_MARGIN:g} x min level speed {v_min:.1f} (speed command ramped down at 0.3 m/s/s)"
    notes["max_speed_mps"] = f"{MAX_SPEED_MARGIN:g} x max level speed {v_max:.1f} (full throttle, altitude held)"
    notes["cruise_speed_mps"] = (
        f"min + {CRUISE_FRACTION:g} (max - min), throttle <= {MAX_CRUISE_THROTTLE:g}: level at throttle {thr:.2f}"
    )


def characterize(model: str, aircraft_dir: Path | None = None, progress: Callable[[str], None] = print) -> Characterized:
    """Fly ``model`` and return its profile (see the module docstring); raises :class:`CharacterizationError`."""
    t0 = time.perf_counter()
    if aircraft_dir is not None:
        add_model_dir(aircraft_dir)
    progress(f"characterize {model}: checking the model can be flown")
    weight_n, area_m2 = check_flyable(model)
    fl = Flights(model)
    env, gains = _seed_envelope()
    notes: dict[str, str] = {}
    v0 = min(_first_guess_speed(weight_n, area_m2), 140.0)
    env.update(cruise_speed_mps=v0, min_speed_mps=0.75 * v0, max_speed_mps=1.25 * v0)
    lever, thrust_n = probe_propeller(fl, env, gains, weight_n)
    gains[ADVANCE] = lever
    progress(
        f"  engine runs: {thrust_n:.0f} N at full throttle, propeller lever {lever:g}; first guess of cruise {v0:.1f} m/s EAS"
    )
    _speeds(fl, env, gains, v0, notes, progress)
    for climb, key in ((True, "max_climb_rate_mps"), (False, "max_descent_rate_mps")):
        rate, flown = probe_rate(fl, env, gains, climb)
        env[key] = rate
        notes[key] = (
            f"largest of {', '.join(f'{c:g}' for c in (CLIMB_CANDIDATES_MPS if climb else DESCENT_CANDIDATES_MPS))} flown within 10 % (flew {flown:.2f}{' energy height' if climb else ''}), speed in the envelope"
        )
        progress(
            f"  {'climb' if climb else 'descent'} rate at full stick: {rate:g} m/s (flew {flown:.2f}) [{fl.sim_time_s:.0f} s simulated]"
        )
    env["max_bank_deg"] = choose_bank(fl, env, gains)
    notes["max_bank_deg"] = (f"FC setting: largest of {', '.join(f'{b:g}' for b in BANK_CANDIDATES_DEG)} whose level turn "
                             "at cruise keeps the speed above min")  # fmt: skip
    progress(f"  max bank: {env['max_bank_deg']:g} deg (level turn at cruise holds) [{fl.sim_time_s:.0f} s simulated]")
    gains, cost = tune_gains(fl, env, gains, progress)
    for name, c in cost.items():
        if not math.isfinite(c):
            raise CharacterizationError(f"characterize {model}: could not stabilise the {name} loop with any gain set tried")
    alt, v_low = check_turn(fl, env, gains)
    progress(f"  max-bank turn: altitude within {alt:.1f} m, lowest speed {v_low:.1f} m/s [{fl.sim_time_s:.0f} s simulated]")
    progress("  measuring the envelope (aircraft.validation manoeuvres)")
    m = measure_platform(trial_profile(model, env, gains))
    doc = profile_doc(model, env, gains, m, notes)
    result = Characterized(model, doc, notes, m, fl.sim_time_s + m.sim_time_s, time.perf_counter() - t0)
    result.mismatches = [str(x) for x in check_profile(m, parse_profile(doc, model, f"characterize {model}"))]
    for line in result.mismatches:
        progress(f"  warning: validate-models --check-profiles would report {line}")
    return result


BOUND_FACTORS = {"braking_decel_mps2": 0.9, "vertical_accel_mps2": 0.9, "reaction_time_s": 1.1}
"""Bounds the geofence's margins grow with, declared 10 % on the safe side of the measurement
(:data:`aircraft.validation.CONSERVATIVE_SIDE`: lower decelerations, a longer reaction)."""


def profile_doc(model: str, env: dict[str, float], gains: dict[str, float], m: Measurement, notes: dict[str, str]) -> dict:
    """The profile mapping: FC settings as flown, measured figures (bounds on their safe side); ``notes`` per key."""
    measured = m.envelope
    out = dict(env)
    for key, factor in BOUND_FACTORS.items():
        value = measured[key] * factor
        out[key] = round(value, 2)
        notes[key] = f"{factor:g} x measured {measured[key]:.3g} (bound, safe side)"
    out["max_yaw_rate_deg_s"] = round(measured["max_yaw_rate_deg_s"], 1)
    notes["max_yaw_rate_deg_s"] = f"turn rate at max bank and cruise: measured {measured['max_yaw_rate_deg_s']:.2f}"
    notes["max_bank_deg"] += f"; steady bank at full roll stick measured {measured['max_bank_deg']:.1f}"
    notes["max_pitch_deg"] = "FC setting (pitch attitude limit)"
    for key in ("max_climb_rate_mps", "max_descent_rate_mps"):
        notes[key] += f"; validation measured {measured[key]:.2f}"
    for key in ("cruise_speed_mps", "min_speed_mps", "max_speed_mps"):
        notes[key] += f"; validation measured {measured[key]:.1f} TAS"
    doc = {"model": model, "measured_on": model, "kind": "fixed_wing", "frame_rate_hz": 120, "envelope": out,
           "gains": {k: round(v, 4) for k, v in gains.items()}}  # fmt: skip
    parse_profile(doc, model, f"characterize {model}")  # the loader's own checks
    return doc


def profile_text(c: Characterized, command: str, when: datetime.date) -> str:
    """The profile YAML with its provenance header (how and when each figure was measured)."""
    import yaml

    lines = [
        f"# {c.model}: profile characterised in the sim by `{command}` on {when.isoformat()} (UTC).",
        f"# Flown by aircraft/systems/fixedwing_fc.xml in JSBSim, calm air, air start at {H0_M:.0f} m AGL over ground at",
        f"# {FRAME.h0_m:.0f} m AMSL, 40 Hz sticks; speeds are equivalent airspeeds (what the FC holds). Gains: a coordinate",
        f"# search from the {SEED_PROFILE} gains (aircraft/characterization.py), scored by roll, climb/descent and",
        "# throttle steps; trim seeds flown level at cruise. Envelope figures measured with aircraft/validation.py's",
        f"# manoeuvres ({c.sim_time_s:.0f} s simulated in {c.wall_time_s:.0f} s wall). Per figure:",
    ]
    lines += [f"#   {k}: {c.notes[k]}" for k in c.doc["envelope"] if k in c.notes]
    lines.append(
        "# Checked against that measurement as validate-models --check-profiles does: " + ("OK." if not c.mismatches else "off:")
    )
    lines += [f"#   {x}" for x in c.mismatches]
    return "\n".join(lines) + "\n" + yaml.safe_dump(c.doc, sort_keys=False)
