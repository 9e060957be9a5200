"""Recovery guidance: the sticks the geofence flies while it overrides the pilot.

Each law is started with the state at activation, a **route** (a polyline
inside the allowed area that ends at the goal, planned by
:mod:`geofence.recovery`, or a :class:`StraightRoute` where no planner
is used) and a goal height in the fence's altitude reference, then asked for
sticks every step. They see only the estimate and the :class:`Envelope`.

* :class:`MultirotorVelocityRecovery` (default): brake at the tilt limit until
  (nearly) stopped, then follow the route at a moderate speed (carrot on the
  route, braking-limited so it stops at the end), altitude to the goal. With
  ``hold_below_m`` set (below the floor inside a gap) it holds its position
  and climbs above that height before moving sideways.
* :class:`SeedPDRecovery`: the published law of the seed flights, per axis
  ``u = K_P·δx + K_D·δẋ`` on the error to a set-point that ramps linearly from
  the breach state to the goal over ``ramp_s``, with per-axis saturation and
  deadbands on height and yaw (gains in stick units, see ``SeedPDGains``).
* :class:`FixedWingRecovery`: bank at the limit in the turn direction the
  boundary-shift computation scored best (the one that keeps the aircraft
  inside given the wind), until the air heading points at the route's carrot
  (wind-corrected) -- but never turn further than the scored turn plus a
  tolerance (the manoeuvre that was checked is the one that is flown) -- then
  follow the route and orbit its end; arrest climb/descent toward the goal
  height; cruise airspeed. With ``hold_below_m`` set (below the floor inside a
  gap) it keeps circling at the bank limit the way it turned, climbing at its
  limit, until above that height: the circle the margins scored
  (:func:`geofence.physics.rooms.gap_circle_turn_rad`); a straight leg to the route
  would leave the gap below the floor.
* :class:`LandingGuidance`: go to a landing point (a floor gap) and descend;
  a multirotor descends only while nearly stopped over it
  (``TOUCHDOWN_MAX_GROUND_SPEED_MPS``), a fixed-wing spirals down over it.

The fixed-wing recovery's step is written once, :func:`fixed_wing_step_on`, over its route's two queries (the
roll-out point, the follower's step) and the jitable laws below (:func:`fixed_wing_recovery_pitch`,
:func:`turned_through_rad`, :func:`rolls_out`, :func:`fixed_wing_follow_roll`) and those of
:mod:`geofence.physics.control_laws`. On a planned route's arrays it is one compiled call (:data:`fixed_wing_step`: the
route follower of :mod:`geofence.recovery` and the stick law together), which the unit's compiled override
pass calls too; where that follower does not answer (a breached vehicle, whose chords only the route's Python
methods certify; a :class:`StraightRoute`) :meth:`FixedWingRecovery.sticks` runs the same function interpreted,
on the route's own methods.

Angles rad, positions ENU m, heights m, speeds m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, NamedTuple, Protocol

import numpy as np

from geofence import jit as _jit
from geofence.interface import Envelope, StickCommand, VehicleState
from geofence.jit import compiled, jitable
from geofence.physics.control_laws import (
    VelocityController,
    air_heading_to_rad,
    airspeed_to_stick,
    altitude_to_climb_rate,
    approach_velocity,
    climb_rate_to_stick,
    clip,
    course_error_rad,
    fixed_wing_roll_stick,
    fixed_wing_sticks,
    ground_course_rad,
    orbit_course_rad,
    wrap_pi,
    yaw_stick_for_heading,
)
from geofence.physics.rooms import turn_radius_m
from geofence.recovery import RecoveryPath, route_arrays, route_follow, route_rollout

ALTITUDE_GAIN_PER_S = 1.0
FIXED_WING_ALTITUDE_GAIN_PER_S = 0.35
COURSE_GAIN_PER_S = 0.9
ROLL_OUT_TOLERANCE_RAD = math.radians(15.0)
LEVEL_TOUCHDOWN_BELOW_M = 1.5
"""Below this height AGL a multirotor landing that has (nearly) stopped over its point holds the wind-balance tilt."""
TOUCHDOWN_MAX_GROUND_SPEED_MPS = 0.7
"""Slower than this over the ground a multirotor touches down gently (a moving touchdown tips over); faster, a
wind it cannot beat is carrying it away, and it keeps descending at the full rate."""
HURRIED_SLOW_BELOW_M = 5.0
"""A hurried landing (position source lost) descends at the full rate down to this height, then levels off
(wind-balance tilt) and touches down at 1 m/s."""
SLOW_DESCENT_BELOW_M = 3.0
"""A multirotor landing descends at its full rate down to this height AGL, then at touchdown speed
(as ArduPilot's LAND mode: LAND_SPEED_HIGH down to LAND_ALT_LOW, then LAND_SPEED)."""
TOUCHDOWN_DESCENT_MPS = 1.0
"""A multirotor's descent rate for the last metres (m/s)."""
FLARE_SIGMA_V_M = 0.3
"""A multirotor landing flares (:meth:`LandingGuidance.flare_rate_mps`) when the unit knows its height to within
this (1-sigma, m): a downward rangefinder in range. A barometer alone is known to its drift (about 1 m)."""
FLARE_FINAL_MPS = 0.5
"""A flared landing's descent rate at and below :data:`FLARE_FINAL_BELOW_M` (m/s)."""
FLARE_FINAL_BELOW_M = 1.0
"""Below this measured height a flared landing descends at :data:`FLARE_FINAL_MPS`."""
FLARE_GAIN_PER_S = 0.5
"""A flared landing's descent rate grows by this per metre above :data:`FLARE_FINAL_BELOW_M` (up to the full rate)."""
FLARE_HOLD_BELOW_M = 3.0
"""Below this measured height a flared landing over its point nulls its horizontal velocity (it holds)."""
FLARE_PAUSE_BELOW_M = 1.5
"""Below this measured height a flared landing still moving faster than :data:`FLARE_MAX_GROUND_SPEED_MPS`
stops descending until it has braked (a moving touchdown tips over)."""
FLARE_MAX_GROUND_SPEED_MPS = 0.4
"""The fastest a flared landing touches down over the ground (m/s)."""
FLARE_PAUSE_MAX_S = 10.0
"""The longest a flared landing pauses for its ground speed (s): in gusts it may never brake below
:data:`FLARE_MAX_GROUND_SPEED_MPS`, and hovering a metre up does not end the exposure."""


@dataclass(frozen=True)
class SeedPDGains:
    """The seed work's decoupled PD law, in stick units (1 stick = 500 µs of RC PWM; see README).

    ``*_limit`` are the per-axis saturations of the override command,
    ``*_deadband`` the dead zones inside which an axis gets the neutral stick.
    """

    kp_xy: float = 0.2  # 100 µs/m
    kd_xy: float = 0.4  # 200 µs/(m/s)
    kp_z: float = 0.4  # 200 µs/m
    kd_z: float = 0.0
    kp_yaw: float = 0.5  # per rad; yaw is purely proportional
    xy_limit: float = 0.24  # ±120 µs
    z_limit: float = 0.15  # ±75 µs
    yaw_limit: float = 0.15  # ±75 µs
    z_deadband_m: float = 0.05
    yaw_deadband_rad: float = 0.009


class Route(Protocol):
    """What a guidance law needs of a planned route (see :class:`geofence.recovery.RecoveryPath`).

    ``points``: the polyline (ENU m), start first, ending at the goal.
    """

    points: list[tuple[float, float]]

    def lookahead_point(self, e: float, n: float, lookahead_m: float) -> tuple[float, float]: ...

    def rollout_point(self, e: float, n: float, lookahead_m: float) -> tuple[float, float]: ...

    def remaining_m(self, e: float, n: float) -> float: ...

    def follow(self, e: float, n: float, lookahead_m: float) -> tuple[tuple[float, float], float]:
        """``(lookahead_point(e, n, lookahead_m), remaining_m(e, n))``, in that order."""
        ...


class StraightRoute:
    """A route of one straight leg to ``end`` (ENU m): no planner, or no admissible path."""

    def __init__(self, end_e: float, end_n: float):
        self.points = [(end_e, end_n)]

    def lookahead_point(self, e: float, n: float, lookahead_m: float) -> tuple[float, float]:
        return self.points[-1]

    def rollout_point(self, e: float, n: float, lookahead_m: float) -> tuple[float, float]:
        return self.points[-1]

    def remaining_m(self, e: float, n: float) -> float:
        end = self.points[-1]
        return math.hypot(end[0] - e, end[1] - n)

    def follow(self, e: float, n: float, lookahead_m: float) -> tuple[tuple[float, float], float]:
        end = self.points[-1]
        return end, math.hypot(end[0] - e, end[1] - n)


BRAKE_DONE_MPS = 1.0
"""The multirotor's braking phase ends below this ground speed (or after the time a full stop takes, plus 1 s)."""


class MultirotorVelocityRecovery:
    def __init__(self, env: Envelope, speed_mps: float | None = None, wind_enu: list[float] | None = None):
        self.env = env
        self.speed_mps = speed_mps if speed_mps is not None else 0.5 * env.cruise_speed_mps
        self.velocity = VelocityController(env, wind_enu=wind_enu)
        self.route: Route = StraightRoute(0.0, 0.0)
        self.goal_h = 0.0
        self.yaw_hold = 0.0
        self.hold_below_m: float | None = None
        self.hold_en = (0.0, 0.0)
        self._brake_until_s = 0.0
        self.braking = False

    def start(
        self,
        s: VehicleState,
        route: Route,
        goal_h: float,
        h: float,
        t_s: float,
        turn_sign: int = 0,
        turn_limit_rad: float = math.inf,
        hold_below_m: float | None = None,
        slow_turn: bool = False,
    ) -> None:
        """Begin the override (``turn_sign``, ``turn_limit_rad``, ``slow_turn``: a fixed-wing's, not used here)."""
        self.route = route
        self.goal_h = goal_h
        self.yaw_hold = s.yaw_rad
        self.velocity.reset()
        self.braking = True
        self._brake_until_s = t_s + s.ground_speed_mps / max(self.env.braking_decel_mps2, 0.1) + 1.0
        self.hold_below_m = hold_below_m
        self.hold_en = (s.east_m, s.north_m)

    def sticks(self, s: VehicleState, h: float, t_s: float, dt_s: float) -> StickCommand:
        env = self.env
        ve = vn = 0.0
        goal_h = self.goal_h
        if self.braking and (s.ground_speed_mps < BRAKE_DONE_MPS or t_s >= self._brake_until_s):
            self.braking = False
        if self.hold_below_m is not None and h < self.hold_below_m:
            # below the floor inside a gap: stay over the gap, climb out first
            ve, vn = approach_velocity(s.east_m, s.north_m, *self.hold_en, self.speed_mps, 0.8, 0.5 * env.braking_decel_mps2)
            goal_h = max(goal_h, self.hold_below_m + 1.0)
        elif not self.braking:
            self.hold_below_m = None
            lookahead = max(3.0, self.speed_mps)
            (ce, cn), rem = self.route.follow(s.east_m, s.north_m, lookahead)
            de, dn = ce - s.east_m, cn - s.north_m
            d = math.hypot(de, dn)
            if d > 1e-6:
                v = min(self.speed_mps, 0.8 * rem, math.sqrt(2.0 * 0.5 * env.braking_decel_mps2 * rem))
                ve, vn = v * de / d, v * dn / d
        roll, pitch = self.velocity.tilt_sticks(s.v_east_mps, s.v_north_mps, ve, vn, s.yaw_rad, dt_s)
        return StickCommand(
            roll=roll,
            pitch=pitch,
            yaw=yaw_stick_for_heading(self.yaw_hold, s.yaw_rad, env),
            throttle=climb_rate_to_stick(altitude_to_climb_rate(goal_h, h, env, ALTITUDE_GAIN_PER_S), env),
        )


class SeedPDRecovery:
    """The seed flights' decoupled PD law with a linear set-point ramp (yaw set-point: the heading at breach)."""

    def __init__(self, env: Envelope, gains: SeedPDGains, ramp_s: float):
        self.env = env
        self.g = gains
        self.ramp_s = ramp_s
        self.start_point = (0.0, 0.0, 0.0)
        self.goal = (0.0, 0.0, 0.0)
        self.t0 = 0.0
        self.yaw_hold = 0.0

    def start(
        self,
        s: VehicleState,
        route: Route,
        goal_h: float,
        h: float,
        t_s: float,
        turn_sign: int = 0,
        turn_limit_rad: float = math.inf,
        hold_below_m: float | None = None,
        slow_turn: bool = False,
    ) -> None:
        """The published law ramps straight to the route's end (it has no notion of a path)."""
        self.start_point = (s.east_m, s.north_m, h)
        self.goal = (route.points[-1][0], route.points[-1][1], goal_h)
        self.t0 = t_s
        self.yaw_hold = s.yaw_rad

    def setpoint(self, t_s: float) -> tuple[float, float, float]:
        """The ramped set-point: linear from the breach state to the goal over ``ramp_s``."""
        f = 1.0 if self.ramp_s <= 0.0 else clip((t_s - self.t0) / self.ramp_s, 0.0, 1.0)
        (e0, n0, h0), (e1, n1, h1) = self.start_point, self.goal
        return e0 + f * (e1 - e0), n0 + f * (n1 - n0), h0 + f * (h1 - h0)

    def sticks(self, s: VehicleState, h: float, t_s: float, dt_s: float) -> StickCommand:
        g = self.g
        se, sn, sh = self.setpoint(t_s)
        # world-frame PD -> "acceleration-like" demand, rotated into body axes
        ue = g.kp_xy * (se - s.east_m) - g.kd_xy * s.v_east_mps
        un = g.kp_xy * (sn - s.north_m) - g.kd_xy * s.v_north_mps
        sy, cy = math.sin(s.yaw_rad), math.cos(s.yaw_rad)
        u_fwd = un * cy + ue * sy
        u_right = ue * cy - un * sy
        dz = sh - h
        throttle = 0.0 if abs(dz) <= g.z_deadband_m else clip(g.kp_z * dz - g.kd_z * s.v_up_mps, -g.z_limit, g.z_limit)
        dyaw = wrap_pi(self.yaw_hold - s.yaw_rad)
        yaw = 0.0 if abs(dyaw) <= g.yaw_deadband_rad else clip(g.kp_yaw * dyaw, -g.yaw_limit, g.yaw_limit)
        return StickCommand(
            roll=clip(u_right, -g.xy_limit, g.xy_limit),
            pitch=clip(-u_fwd, -g.xy_limit, g.xy_limit),  # forward demand = nose down = negative pitch stick
            yaw=yaw,
            throttle=throttle,
        )


@jitable
def fixed_wing_recovery_pitch(goal_h: float, h: float, env: Envelope) -> float:
    """The fixed-wing recovery's pitch (climb-rate) stick: arrest the climb or descent toward ``goal_h``."""
    return climb_rate_to_stick(altitude_to_climb_rate(goal_h, h, env, FIXED_WING_ALTITUDE_GAIN_PER_S), env)


@jitable
def turned_through_rad(turned_rad: float, last_yaw_rad: float, yaw_rad: float) -> float:
    """The recovery turn's heading change so far, ``turned_rad``, after the heading moved to ``yaw_rad``."""
    return turned_rad + abs(wrap_pi(yaw_rad - last_yaw_rad))


@jitable
def rolls_out(
    s: VehicleState,
    rollout_e: float,
    rollout_n: float,
    wind_e: float,
    wind_n: float,
    min_speed_mps: float,
    turned_rad: float,
    turn_limit_rad: float,
) -> bool:
    """The recovery turn ends: the air heading points at the roll-out point (the route a turn ahead, wind-corrected)
    within :data:`ROLL_OUT_TOLERANCE_RAD`, or the scored turn is used up (commit: no re-aiming past it)."""
    heading = air_heading_to_rad(s, rollout_e, rollout_n, wind_e, wind_n, min_speed_mps)
    return abs(wrap_pi(heading - s.yaw_rad)) < ROLL_OUT_TOLERANCE_RAD or turned_rad >= turn_limit_rad


@jitable
def fixed_wing_follow_roll(
    s: VehicleState,
    ground_speed_mps: float,
    target_e: float,
    target_n: float,
    remaining_m: float,
    goal_e: float,
    goal_n: float,
    orbit_radius_m: float,
    turn_sign: float,
    env: Envelope,
) -> float:
    """The roll stick after the roll-out: toward the route's carrot (``target``), or, within 1.2 orbit radii of
    the route's end (``remaining_m`` along it), onto the orbit round its end (clockwise for ``turn_sign < 0``);
    ``ground_speed_mps``: the state's."""
    if remaining_m > 1.2 * orbit_radius_m:
        course_cmd = math.atan2(target_e - s.east_m, target_n - s.north_m)
    else:
        course_cmd, _ = orbit_course_rad(s.east_m, s.north_m, goal_e, goal_n, orbit_radius_m, clockwise=turn_sign < 0)
    return fixed_wing_roll_stick(ground_speed_mps, course_error_rad(s, course_cmd), COURSE_GAIN_PER_S, env)


class _EnvelopeFloats(NamedTuple):
    """The :class:`Envelope` fields the fixed-wing recovery's laws read, for compiled code."""

    max_bank_rad: float
    max_climb_rate_mps: float
    max_descent_rate_mps: float
    min_speed_mps: float


class _StateFloats(NamedTuple):
    """The :class:`VehicleState` fields the fixed-wing recovery's laws read, for compiled code."""

    east_m: float
    north_m: float
    v_east_mps: float
    v_north_mps: float
    yaw_rad: float
    airspeed_mps: float


FIXED_WING_STEP_CONSTANTS = 11
"""The length of the fixed-wing step's constants ``K``: goal height, lookahead, orbit radius, turn sign, turn limit
(rad), the envelope's bank limit, climb and descent rates and minimum speed, then the route's end (east, north)."""


StepAnswer = tuple[float, float, float, float, bool, float, float]
"""A fixed-wing override step's answer ``(thr, roll, pitch, progress, turning, turned, last yaw)``: the route's
chord threshold (not positive: its queries did not answer, nothing else counts), the roll and pitch sticks, the
route's progress after the step (on the arrays; the route's own methods keep theirs, NaN), the turn state after
it. (A plain tuple: compiled code returns a named tuple through its constructor, a microsecond a step.)"""

FollowAnswer = tuple[float, float, float, float, float]
"""A route's follower query's answer ``(thr, progress, carrot east, carrot north, remaining)``."""


@jitable
def fixed_wing_step_on(
    route: object, rollout: Callable[..., tuple[float, float, float]],
    follow: Callable[..., FollowAnswer], K: np.ndarray | tuple[float, ...], s0: float,
    thr: float, e: float, n: float, ve: float, vn: float, yaw: float, airspeed: float, ground_speed: float, h: float,
    wind_e: float, wind_n: float, turning: bool, turned_rad: float, last_yaw: float,
) -> StepAnswer:  # fmt: skip
    """The fixed-wing override's step after any hold below a floor (a :data:`StepAnswer`): the first turn at the
    bank limit until :func:`rolls_out`, then :func:`fixed_wing_follow_roll` on the route's carrot, and
    :func:`fixed_wing_recovery_pitch`. The route answers two queries, each taking and returning the chord
    threshold ``thr``: ``rollout(route, thr, e, n, lookahead) -> (thr, east, north)`` (the roll-out point) and
    ``follow(route, thr, e, n, lookahead) -> (thr, progress, carrot east, carrot north, remaining)`` (the
    follower's step); ``s0`` the route's progress before the step. ``K``: the recovery's constants
    (:data:`FIXED_WING_STEP_CONSTANTS`); the state's floats, then the turn state before the step."""
    # the laws read these fields by name, as they read an Envelope's and a VehicleState's
    env: Envelope = _EnvelopeFloats(K[5], K[6], K[7], K[8])  # type: ignore[assignment]
    s: VehicleState = _StateFloats(e, n, ve, vn, yaw, airspeed)  # type: ignore[assignment]
    pitch = fixed_wing_recovery_pitch(K[0], h, env)
    if turning:
        turned_rad = turned_through_rad(turned_rad, last_yaw, yaw)
        last_yaw = yaw
        # roll out heading for the route a turn ahead (the turn the margin scored), or once that turn is used up
        thr, re, rn = rollout(route, thr, e, n, K[1])
        if not thr > 0.0:
            return thr, 0.0, pitch, s0, turning, turned_rad, last_yaw
        if not rolls_out(s, re, rn, wind_e, wind_n, env.min_speed_mps, turned_rad, K[4]):
            return thr, -K[3], pitch, s0, turning, turned_rad, last_yaw  # turn sign +1 = left = negative roll stick
        turning = False
    thr, progress, te, tn, remaining = follow(route, thr, e, n, K[1])
    if not thr > 0.0:
        return thr, 0.0, pitch, s0, turning, turned_rad, last_yaw
    roll = fixed_wing_follow_roll(s, ground_speed, te, tn, remaining, K[9], K[10], K[2], K[3], env)
    return thr, roll, pitch, progress, turning, turned_rad, last_yaw


@jitable
def _rollout_on_arrays(route: tuple, thr: float, e: float, n: float, lookahead_m: float) -> tuple[float, float, float]:
    """The roll-out query on a route's packed arrays ``(R, P, Q, progress, clearance)``
    (:func:`geofence.recovery.route_rollout`)."""
    R, P, Q, s0, clearance_m = route
    return route_rollout(R, P, Q, s0, e, n, lookahead_m, thr, clearance_m)


@jitable
def _follow_on_arrays(route: tuple, thr: float, e: float, n: float, lookahead_m: float) -> FollowAnswer:
    """The follower query on a route's packed arrays (:func:`geofence.recovery.route_follow`), the length left
    after the projection as :meth:`~geofence.recovery.RecoveryPath.follow` gives it."""
    R, P, Q, s0, clearance_m = route
    thr, progress, te, tn, s_after = route_follow(R, P, Q, s0, e, n, lookahead_m, thr, clearance_m)
    _pts, cum = route_arrays(R)
    return thr, progress, te, tn, max(0.0, cum[cum.shape[0] - 1] - s_after)


def _rollout_by_methods(route: Route, thr: float, e: float, n: float, lookahead_m: float) -> tuple[float, float, float]:
    """The roll-out query by the route's own methods (:meth:`Route.rollout_point`)."""
    re, rn = route.rollout_point(e, n, lookahead_m)
    return thr, re, rn


def _follow_by_methods(route: Route, thr: float, e: float, n: float, lookahead_m: float) -> FollowAnswer:
    """The follower query by the route's own methods (:meth:`Route.follow`, which moves the route's progress
    itself: the progress answered is NaN)."""
    (te, tn), remaining = route.follow(e, n, lookahead_m)
    return thr, math.nan, te, tn, remaining


def _fixed_wing_step(
    R: np.ndarray, P: np.ndarray, Q: np.ndarray, K: np.ndarray, s0: float, thr: float, clearance_m: float, e: float,
    n: float, ve: float, vn: float, yaw: float, airspeed: float, ground_speed: float, h: float, wind_e: float,
    wind_n: float, turning: bool, turned_rad: float, last_yaw: float,
) -> StepAnswer:  # fmt: skip
    """:func:`fixed_wing_step_on` on a route's and its planner's packed arrays (``R``, ``P``, ``Q``, the progress
    ``s0``, the chord threshold ``thr``, NaN or not, and the clearance of
    :func:`geofence.recovery.route_follow`). A threshold that is not positive answers nothing (the vehicle's
    chords are not tested exactly: :meth:`FixedWingRecovery.sticks` asks the route's methods)."""
    return fixed_wing_step_on(
        (R, P, Q, s0, clearance_m), _rollout_on_arrays, _follow_on_arrays, K, s0, thr, e, n, ve, vn, yaw, airspeed,
        ground_speed, h, wind_e, wind_n, turning, turned_rad, last_yaw,
    )  # fmt: skip


fixed_wing_step = compiled(_fixed_wing_step)
"""The fixed-wing override's step on a planned route's arrays, compiled (:func:`_fixed_wing_step`; interpreted
without numba)."""


class FixedWingRecovery:
    def __init__(self, env: Envelope, wind_enu: list[float]):
        self.env = env
        self.wind = wind_enu  # shared, updated by the unit
        self._step = fixed_wing_step  # (its entry point after the first call: geofence.jit.entry_point)
        self.route: Route = StraightRoute(0.0, 0.0)
        self.goal_h = 0.0
        self.turn_sign = 0
        self.turning = True
        self.turn_limit_rad = math.inf
        self.turned_rad = 0.0
        self._last_yaw = 0.0
        self.hold_below_m: float | None = None
        self.orbit_radius_m = 1.5 * turn_radius_m(env.cruise_speed_mps, env.max_bank_rad)
        self._throttle = airspeed_to_stick(env.cruise_speed_mps, env)  # the override flies at cruise
        self._slow_throttle = airspeed_to_stick(env.min_speed_mps, env)  # (a first turn that does not fit: minimum)
        self._turn_throttle = self._throttle  # the first turn's (start)
        self._path: RecoveryPath | None = None  # the route, when it is a planned one (its arrays: the compiled step)
        self._constants = np.zeros(FIXED_WING_STEP_CONSTANTS)  # the step's constants (set by start)
        self._constant_floats: tuple[float, ...] = tuple(self._constants.tolist())  # (the same, for the interpreter)

    @property
    def lookahead_m(self) -> float:
        return self.orbit_radius_m

    def start(
        self,
        s: VehicleState,
        route: Route,
        goal_h: float,
        h: float,
        t_s: float,
        turn_sign: int = 0,
        turn_limit_rad: float = math.inf,
        hold_below_m: float | None = None,
        slow_turn: bool = False,
    ) -> None:
        """Begin the override. ``slow_turn``: the first turn does not fit at the current speed (the unit's call,
        :data:`geofence.unit.geofence_unit.SLOW_TURN_SHORTFALL`): it is flown at the minimum speed (still above the stall at
        the bank limit: the profiles measure it as a steady speed). A turn's radius is ``V²/(g·tan φ)`` and
        its rate ``g·tan φ / V``: the slower, the tighter and the quicker, and the less the wind drifts it
        meanwhile; the margin scored it at the airspeed the vehicle has now, so slowing down only adds room.
        Not always: flown at the minimum speed in every override, 6,899 fixed-wing campaign flights gave 31
        breaches instead of 13 (a slow turn sinks near a floor, and a wind near the minimum speed keeps the
        vehicle from ever facing its route)."""
        self.route = route
        self._turn_throttle = self._slow_throttle if slow_turn else self._throttle
        self.goal_h = goal_h
        target = route.rollout_point(s.east_m, s.north_m, self.lookahead_m)
        self.turn_sign = turn_sign if turn_sign else (1 if wrap_pi(self._heading_to(s, target) - s.yaw_rad) < 0 else -1)
        self.turning = True
        self.turn_limit_rad = turn_limit_rad + ROLL_OUT_TOLERANCE_RAD
        self.turned_rad = 0.0
        self._last_yaw = s.yaw_rad
        self.hold_below_m = hold_below_m
        self._path = route if isinstance(route, RecoveryPath) else None
        env = self.env
        goal_e, goal_n = route.points[-1]
        self._constants = np.array(
            [
                goal_h,
                self.lookahead_m,
                self.orbit_radius_m,
                float(self.turn_sign),
                self.turn_limit_rad,
                env.max_bank_rad,
                env.max_climb_rate_mps,
                env.max_descent_rate_mps,
                env.min_speed_mps,
                goal_e,
                goal_n,
            ]
        )
        self._constant_floats = tuple(self._constants.tolist())

    def turn_left_rad(self) -> float | None:
        """What is left of the first turn its margin scored (rad, the roll-out tolerance not counted), or None
        once it has rolled out or turned to its limit."""
        if not self.turning or self.turned_rad >= self.turn_limit_rad:
            return None
        return max(self.turn_limit_rad - ROLL_OUT_TOLERANCE_RAD - self.turned_rad, 0.0)

    def _heading_to(self, s: VehicleState, target: tuple[float, float]) -> float:
        """Air heading whose ground track points at ``target`` (wind triangle at the current airspeed)."""
        return air_heading_to_rad(s, target[0], target[1], self.wind[0], self.wind[1], self.env.min_speed_mps)

    def compiled_step(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, float] | None:
        """The arrays and chord arguments its compiled step (:data:`fixed_wing_step`) takes for a route that needs no
        per-position argument (a fence without an index: :meth:`RecoveryPath.constant_kernel_arguments`), ``(R, P,
        Q, K, thr, clearance)``, for a caller's compiled step; None where :meth:`sticks` must answer (circling up in
        a floor gap, a route that is not planned, a fence with an index: its threshold is found per position). With
        :meth:`step_state` and :meth:`set_step_state` a caller steps it as :meth:`sticks` does."""
        path = self._path
        if self.hold_below_m is not None or path is None:
            return None
        args = path.constant_kernel_arguments()
        if args is None:
            return None
        P, Q, thr, clearance = args
        return path._arrays(), P, Q, self._constants, thr, clearance

    def step_state(self) -> tuple[float, bool, float, float, float, float]:
        """``(route progress, turning, turned, last yaw, throttle while turning, throttle after)``: what its step
        reads besides the state (see :meth:`compiled_step`)."""
        assert self._path is not None
        return self._path.progress_m, self.turning, self.turned_rad, self._last_yaw, self._turn_throttle, self._throttle

    def set_step_state(self, progress_m: float, turning: bool, turned_rad: float, last_yaw_rad: float) -> None:
        """Take in a caller's steps (see :meth:`compiled_step`): the route's progress and the turn's state after them."""
        assert self._path is not None
        self._path.progress_m = progress_m
        self.turning = turning
        self.turned_rad = turned_rad
        self._last_yaw = last_yaw_rad

    def sticks(self, s: VehicleState, h: float, t_s: float, dt_s: float) -> StickCommand:
        """The override's sticks: its first turn at the bank limit, then the route, at cruise; a first turn that does
        not fit (``slow_turn`` at :meth:`start`) at the minimum speed (see there). Circling up inside a floor gap
        it keeps the cruise throttle (the climb rate it was measured to have).

        The step is :func:`fixed_wing_step_on`: compiled on a planned route's arrays (:data:`fixed_wing_step`)
        where its compiled follower answers (the vehicle more than 1e-9 m inside the allowed area), else
        interpreted on the route's own methods (a breached vehicle's chords are certified by
        :meth:`~geofence.recovery.RecoveryPlanner.chord_ok` in Python; a straight route)."""
        if self.hold_below_m is not None:
            if h < self.hold_below_m:  # circling inside the gap, climbing at the limit
                self._last_yaw = s.yaw_rad
                return StickCommand(roll=-float(self.turn_sign), pitch=1.0, yaw=0.0, throttle=self._throttle)
            self.hold_below_m = None
        throttle = self._turn_throttle if self.turning else self._throttle
        path = self._path
        args = path._kernel_arguments(s.east_m, s.north_m) if path is not None else None
        if args is not None:
            assert path is not None
            P, Q, thr, clearance = args
            step = self._step
            out = step(
                path._arrays(), P, Q, self._constants, path.progress_m, thr, clearance, s.east_m, s.north_m,
                s.v_east_mps, s.v_north_mps, s.yaw_rad, s.airspeed_mps, s.ground_speed_mps, h, self.wind[0],
                self.wind[1], self.turning, self.turned_rad, self._last_yaw,
            )  # fmt: skip
            if step is fixed_wing_step:  # after its first call, by its entry point (geofence.jit: the route's
                self._step = _jit.entry_point(step)  # and the planner's arrays: 1-D, C
            if out[0] > 0.0:
                path.progress_m = out[3]
                return self._take(out, throttle)
        out = fixed_wing_step_on(
            self.route, _rollout_by_methods, _follow_by_methods, self._constant_floats, 0.0, 1.0, s.east_m, s.north_m,
            s.v_east_mps, s.v_north_mps, s.yaw_rad, s.airspeed_mps, s.ground_speed_mps, h, self.wind[0], self.wind[1],
            self.turning, self.turned_rad, self._last_yaw,
        )  # fmt: skip
        return self._take(out, throttle)

    def _take(self, out: StepAnswer, throttle: float) -> StickCommand:
        """Keep a step's turn state (its answer ``out``); its sticks with ``throttle``."""
        _thr, roll, pitch, _progress, self.turning, self.turned_rad, self._last_yaw = out
        # (roll, pitch, yaw, throttle; a named tuple's generated constructor with keywords costs three times
        # tuple.__new__)
        return tuple.__new__(StickCommand, (roll, pitch, 0.0, throttle))


class LandingGuidance:
    """Fly to a landing point at a safe height, then descend onto it (fixed-wing: spiral down over it)."""

    def __init__(self, env: Envelope, spiral_radius_m: float, wind_enu: list[float] | None = None):
        self.env = env
        self.velocity = VelocityController(env, wind_enu=wind_enu) if env.is_multirotor else None
        self.spiral_radius_m = spiral_radius_m
        self.point = (0.0, 0.0)
        self.cruise_h = 0.0
        self.route: Route = StraightRoute(0.0, 0.0)
        self.turn_sign = 0
        self.turn_limit_rad = math.inf
        self.turned_rad = 0.0
        self._last_yaw: float | None = None
        self.orbit_clockwise = True
        self.paused_s = 0.0
        """How long a flared landing has paused for its ground speed (s)."""

    def start(
        self,
        point_e: float,
        point_n: float,
        cruise_h: float,
        route: Route | None = None,
        turn_sign: int = 0,
        turn_limit_rad: float = math.inf,
    ) -> None:
        """Land at ``(point_e, point_n)``, flying ``route`` there (default: straight) at ``cruise_h``.

        ``turn_sign`` (fixed-wing; +1 left, -1 right): the direction of the first turn onto the route,
        at the bank limit -- the one the activation margin scored as safe against every edge (the
        shorter turn is not always: it can swing out across the nearby boundary). 0: the shorter turn.
        ``turn_limit_rad``: the turn the margin scored; the committed turn ends once the heading has
        turned that much (and :data:`ROLL_OUT_TOLERANCE_RAD`) either way, as the override's does
        (:class:`FixedWingRecovery`).
        """
        self.point = (point_e, point_n)
        self.cruise_h = cruise_h
        self.route = route if route is not None else StraightRoute(point_e, point_n)
        self.turn_sign = turn_sign
        self.turn_limit_rad = turn_limit_rad + ROLL_OUT_TOLERANCE_RAD
        self.turned_rad = 0.0
        self._last_yaw = None
        # The spiral goes on the way the first turn went: a clockwise spiral after a left turn reverses the
        # turn at once, and a fast fixed-wing flies a turn diameter downwind doing it, far enough to leave the
        # fence (case history: docs/campaigns.md#breach-classes-found-and-fixed). With no first turn: clockwise.
        self.orbit_clockwise = turn_sign <= 0
        self.paused_s = 0.0
        if self.velocity:
            self.velocity.reset()

    def touchdown_rate_mps(self, ground_speed_mps: float) -> float:
        """A multirotor's descent rate below :data:`SLOW_DESCENT_BELOW_M` (m/s): touchdown speed, or the full
        rate while a wind it cannot beat carries it faster than :data:`TOUCHDOWN_MAX_GROUND_SPEED_MPS`."""
        full = self.env.max_descent_rate_mps
        return full if ground_speed_mps > TOUCHDOWN_MAX_GROUND_SPEED_MPS else min(TOUCHDOWN_DESCENT_MPS, full)

    @staticmethod
    def flares(sigma_v_m: float) -> bool:
        """A multirotor landing flares on its measured height: it is known to :data:`FLARE_SIGMA_V_M` or better."""
        return sigma_v_m <= FLARE_SIGMA_V_M

    def flare_rate_mps(self, agl_m: float) -> float:
        """A flared landing's descent rate at the measured height ``agl_m`` (m/s): :data:`FLARE_FINAL_MPS` below
        :data:`FLARE_FINAL_BELOW_M`, :data:`FLARE_GAIN_PER_S` more per metre above it, at most the full rate."""
        rate = FLARE_FINAL_MPS + FLARE_GAIN_PER_S * max(agl_m - FLARE_FINAL_BELOW_M, 0.0)
        return min(rate, self.env.max_descent_rate_mps)

    def time_to_touchdown_s(self, agl_m: float, ground_speed_mps: float = 0.0) -> float:
        """How long a multirotor's descent from ``agl_m`` over the point takes (s): the full rate down to
        :data:`SLOW_DESCENT_BELOW_M`, :meth:`touchdown_rate_mps` below it."""
        high = max(agl_m - SLOW_DESCENT_BELOW_M, 0.0)
        slow = self.touchdown_rate_mps(ground_speed_mps)
        return high / max(self.env.max_descent_rate_mps, 1e-3) + (max(agl_m, 0.0) - high) / max(slow, 1e-3)

    def over_point(self, s: VehicleState) -> bool:
        pe, pn = self.point
        return math.hypot(pe - s.east_m, pn - s.north_m) < (2.0 if self.env.is_multirotor else 1.5 * self.spiral_radius_m)

    def sticks(
        self, s: VehicleState, h: float, dt_s: float, descend: bool | None = None, hurry: bool = False,
        flare: bool = False, brakes: bool = True,
    ) -> StickCommand:  # fmt: skip
        """Sticks toward the landing point; descend when ``descend`` (default: when over the point).

        ``hurry`` (multirotor, position source lost, or a wind beyond its authority): while ``descend`` allows
        it, descend at the full rate *on the way* instead of over the point -- it drifts with every second in
        the air -- and below :data:`HURRIED_SLOW_BELOW_M` stop manoeuvring and touch down where it is.
        ``flare`` (multirotor, its height measured: :meth:`flares`): the descent is scheduled on the measured
        height instead (:meth:`flared_sticks`), hurried or not; ``brakes`` False (a wind beyond its authority
        carries it) touches down without pausing for a ground speed it cannot brake.
        """
        env = self.env
        over = self.over_point(s) if descend is None else descend
        if self.velocity is not None:
            ce, cn = self.route.lookahead_point(s.east_m, s.north_m, max(3.0, 0.5 * env.cruise_speed_mps))
            ve, vn = approach_velocity(s.east_m, s.north_m, ce, cn, 0.5 * env.cruise_speed_mps, 0.8, 0.5 * env.braking_decel_mps2)
            if flare:
                return self.flared_sticks(s, h, dt_s, over, ve, vn, brakes)
            roll, pitch = self.velocity.tilt_sticks(s.v_east_mps, s.v_north_mps, ve, vn, s.yaw_rad, dt_s)
            if hurry and over:
                if s.agl_m > HURRIED_SLOW_BELOW_M:
                    climb = -env.max_descent_rate_mps
                else:
                    roll, pitch = self.velocity.wind_balance_sticks(s.yaw_rad)
                    climb = -min(1.0, env.max_descent_rate_mps)
                return StickCommand(roll=roll, pitch=pitch, yaw=0.0, throttle=climb_rate_to_stick(climb, env))
            if over and s.agl_m < LEVEL_TOUCHDOWN_BELOW_M and s.ground_speed_mps <= TOUCHDOWN_MAX_GROUND_SPEED_MPS:
                # touch down without manoeuvring (a tilted, moving gear tips over), but keep the steady
                # tilt into the wind: levelled in a strong wind, the vehicle is blown away near the ground.
                # Still moving (a gust the mean-wind tilt does not balance), it keeps flying to the point.
                roll, pitch = self.velocity.wind_balance_sticks(s.yaw_rad)
            if over and s.agl_m > SLOW_DESCENT_BELOW_M:
                # high over the point: down at the full rate, moving or not (in a strong or gusty wind the
                # vehicle never stops over the point, and every second in the air drifts it)
                climb = -env.max_descent_rate_mps
            elif over:  # the last metres at touchdown speed, unless a wind it cannot beat is carrying it away
                climb = -self.touchdown_rate_mps(s.ground_speed_mps)
            else:
                climb = altitude_to_climb_rate(self.cruise_h, h, env, ALTITUDE_GAIN_PER_S)
            return StickCommand(roll=roll, pitch=pitch, yaw=0.0, throttle=climb_rate_to_stick(climb, env))
        return self.spiral_sticks(s, h, over)

    def flared_sticks(
        self, s: VehicleState, h: float, dt_s: float, over: bool, ve: float, vn: float, brakes: bool = True
    ) -> StickCommand:  # fmt: skip
        """A multirotor's landing flared on its measured height: toward the point at the velocity ``(ve, vn)``,
        holding (horizontal velocity nulled on the estimate: the fix's or the optical flow's) below
        :data:`FLARE_HOLD_BELOW_M` over it, descending at :meth:`flare_rate_mps` while ``over``, and, where it
        ``brakes``, pausing below :data:`FLARE_PAUSE_BELOW_M` while faster than :data:`FLARE_MAX_GROUND_SPEED_MPS`
        over the ground (for :data:`FLARE_PAUSE_MAX_S` at most)."""
        env, velocity = self.env, self.velocity
        assert velocity is not None
        agl = s.agl_m
        if over and agl < FLARE_HOLD_BELOW_M:
            ve = vn = 0.0
        roll, pitch = velocity.tilt_sticks(s.v_east_mps, s.v_north_mps, ve, vn, s.yaw_rad, dt_s)
        if not over:
            climb = altitude_to_climb_rate(self.cruise_h, h, env, ALTITUDE_GAIN_PER_S)
        elif (
            brakes and agl < FLARE_PAUSE_BELOW_M and s.ground_speed_mps > FLARE_MAX_GROUND_SPEED_MPS
            and self.paused_s < FLARE_PAUSE_MAX_S
        ):  # fmt: skip
            climb = 0.0
            self.paused_s += dt_s
        else:
            climb = -self.flare_rate_mps(agl)
        return StickCommand(roll=roll, pitch=pitch, yaw=0.0, throttle=climb_rate_to_stick(climb, env))

    def spiral_sticks(self, s: VehicleState, h: float, over: bool) -> StickCommand:
        """A fixed-wing's landing: the route to the point, then a spiral down over it."""
        env = self.env
        pe, pn = self.point
        if self.route.remaining_m(s.east_m, s.north_m) > 2.0 * self.spiral_radius_m:
            ce, cn = self.route.lookahead_point(s.east_m, s.north_m, self.spiral_radius_m)
            course_cmd = math.atan2(ce - s.east_m, cn - s.north_m)
        else:
            course_cmd, _ = orbit_course_rad(s.east_m, s.north_m, pe, pn, self.spiral_radius_m, clockwise=self.orbit_clockwise)
        course = ground_course_rad(s.v_east_mps, s.v_north_mps, s.yaw_rad)
        climb = (
            -env.max_descent_rate_mps if over else altitude_to_climb_rate(self.cruise_h, h, env, FIXED_WING_ALTITUDE_GAIN_PER_S)
        )
        pitch, throttle = climb_rate_to_stick(climb, env), airspeed_to_stick(env.min_speed_mps, env)
        course_err = wrap_pi(course_cmd - course)
        if self.turn_sign and abs(course_err) > ROLL_OUT_TOLERANCE_RAD:
            if self._last_yaw is not None:
                self.turned_rad = turned_through_rad(self.turned_rad, self._last_yaw, s.yaw_rad)
            self._last_yaw = s.yaw_rad
            if self.turned_rad <= self.turn_limit_rad:  # the committed first turn (+1 left = negative roll stick)
                return StickCommand(roll=-float(self.turn_sign), pitch=pitch, yaw=0.0, throttle=throttle)
        self.turn_sign = 0
        return fixed_wing_sticks(s, course_err, COURSE_GAIN_PER_S, pitch, throttle, env)
