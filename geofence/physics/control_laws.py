"""Pure control-law primitives shared by every outer loop: maps from physical demands to sticks.

Plain-float functions with no state, used by the geofence's recovery guidance
and by the testbed's mission autopilot alike (they are the stick semantics of
:mod:`geofence.interface` written as math, not a navigation strategy):

* horizontal acceleration demand (ENU, m/s²) -> multirotor tilt sticks;
* climb-rate demand (m/s) -> climb-rate stick (multirotor throttle, fixed-wing pitch);
* course error (rad) -> fixed-wing sticks (:func:`fixed_wing_sticks`: bank of a coordinated turn);
* airspeed demand (m/s) -> fixed-wing throttle stick;
* a course onto a circle (:func:`orbit_course_rad`) and the air heading whose ground track points at a target
  in the wind (:func:`air_heading_to_rad`);
* :class:`VelocityController`: a multirotor PI ground-velocity loop on top of
  the tilt mapping, which also tells when the vehicle loses ground at its tilt limit
  (:class:`LosingGround`: a wind beyond its authority, measured), and :func:`approach_velocity`
  (stop at a point without overshoot).

The laws of floats are :func:`geofence.jit.jitable`: the compiled fixed-wing recovery step
(:data:`geofence.recovery.guidance.fixed_wing_step`) calls them from the same source. Those taking a state ``s`` or an
envelope ``env`` read only named float attributes, so compiled code passes a named tuple of those fields.
"""

from __future__ import annotations

import math

from geofence.interface import Envelope, StickCommand, VehicleState
from geofence.jit import jitable
from geofence.physics.dynamics import G_MPS2, drag_coefficients


@jitable
def clip(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else (hi if x > hi else x)


@jitable
def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def max_horizontal_accel_mps2(env: Envelope) -> float:
    """The horizontal acceleration a tilt-limited multirotor can command, g·tan(tilt_max)."""
    return G_MPS2 * math.tan(min(env.max_bank_rad, env.max_pitch_rad))


def tilt_sticks_for_accel(accel_east_mps2: float, accel_north_mps2: float, yaw_rad: float, env: Envelope) -> tuple[float, float]:
    """(roll, pitch) sticks that tilt a multirotor to accelerate horizontally as demanded.

    Forward acceleration needs nose-down pitch (negative pitch stick), rightward
    acceleration needs right bank.
    """
    sy, cy = math.sin(yaw_rad), math.cos(yaw_rad)
    a_fwd = accel_north_mps2 * cy + accel_east_mps2 * sy
    a_right = accel_east_mps2 * cy - accel_north_mps2 * sy
    pitch = -math.atan(a_fwd / G_MPS2)
    roll = math.atan(a_right / G_MPS2)
    return clip(roll / env.max_bank_rad, -1.0, 1.0), clip(pitch / env.max_pitch_rad, -1.0, 1.0)


@jitable
def climb_rate_to_stick(v_up_mps: float, env: Envelope) -> float:
    """Climb-rate demand (m/s, + up) -> the climb-rate stick of either platform kind."""
    if v_up_mps >= 0.0:
        return clip(v_up_mps / env.max_climb_rate_mps, 0.0, 1.0)
    return clip(v_up_mps / env.max_descent_rate_mps, -1.0, 0.0)


@jitable
def stick_to_climb_rate(stick: float, env: Envelope) -> float:
    """The climb-rate stick of either platform kind (clipped to [-1, 1]) -> the climb rate it commands (m/s, + up):
    the inverse of :func:`climb_rate_to_stick` within the envelope."""
    return climb_rate_of_stick(stick, env.max_climb_rate_mps, env.max_descent_rate_mps)


@jitable
def climb_rate_of_stick(stick: float, max_climb_mps: float, max_descent_mps: float) -> float:
    """:func:`stick_to_climb_rate` on the envelope's two rates (m/s, + up)."""
    stick = clip(stick, -1.0, 1.0)
    return stick * (max_climb_mps if stick >= 0.0 else max_descent_mps)


@jitable
def altitude_to_climb_rate(target_m: float, height_m: float, env: Envelope, gain_per_s: float) -> float:
    """Proportional altitude law: climb-rate demand in m/s, limited by the envelope."""
    return clip(gain_per_s * (target_m - height_m), -env.max_descent_rate_mps, env.max_climb_rate_mps)


@jitable
def course_error_rad(s: VehicleState, course_cmd_rad: float) -> float:
    """The commanded course minus the ground course, the short way (-pi, pi]: + turns right."""
    return wrap_pi(course_cmd_rad - ground_course_rad(s.v_east_mps, s.v_north_mps, s.yaw_rad))


def fixed_wing_sticks(
    s: VehicleState, course_err_rad: float, course_gain_per_s: float, pitch_stick: float, throttle_stick: float, env: Envelope
) -> StickCommand:
    """Fixed-wing course law: turn rate ω = gain · course error, flown as a coordinated bank (+ right).

    Bank = atan(V·ω/g) (V the ground speed, at least 1 m/s), as a fraction of the bank limit; the climb-rate
    (pitch) and throttle sticks are the caller's. Yaw stick 0.
    """
    roll = fixed_wing_roll_stick(s.ground_speed_mps, course_err_rad, course_gain_per_s, env)
    # (roll, pitch, yaw, throttle): tuple.__new__ costs a third of the named tuple's generated constructor
    return tuple.__new__(StickCommand, (roll, pitch_stick, 0.0, throttle_stick))


@jitable
def fixed_wing_roll_stick(ground_speed_mps: float, course_err_rad: float, course_gain_per_s: float, env: Envelope) -> float:
    """:func:`fixed_wing_sticks`' roll stick: ``atan(V·gain·error/g)`` over the bank limit, ``V`` at least 1 m/s."""
    v = ground_speed_mps
    if v < 1.0:
        v = 1.0
    return clip(math.atan(v * (course_gain_per_s * course_err_rad) / G_MPS2) / env.max_bank_rad, -1.0, 1.0)


def airspeed_to_stick(airspeed_mps: float, env: Envelope) -> float:
    """Airspeed demand -> fixed-wing throttle stick (−1 min, 0 cruise, +1 max)."""
    if airspeed_mps >= env.cruise_speed_mps:
        span = env.max_speed_mps - env.cruise_speed_mps
    else:
        span = env.cruise_speed_mps - env.min_speed_mps
    return clip((airspeed_mps - env.cruise_speed_mps) / span, -1.0, 1.0) if span > 0 else 0.0


def yaw_stick_for_heading(yaw_cmd_rad: float, yaw_rad: float, env: Envelope, gain_per_s: float = 1.5) -> float:
    """Multirotor yaw-rate stick that turns the nose toward ``yaw_cmd_rad``."""
    return clip(gain_per_s * wrap_pi(yaw_cmd_rad - yaw_rad) / env.max_yaw_rate_radps, -1.0, 1.0)


@jitable
def ground_course_rad(v_east_mps: float, v_north_mps: float, fallback_rad: float) -> float:
    """Ground course clockwise from north; ``fallback_rad`` (the heading) when nearly stopped."""
    if v_east_mps * v_east_mps + v_north_mps * v_north_mps < 0.25:
        return fallback_rad
    return math.atan2(v_east_mps, v_north_mps)


def approach_velocity(
    east_m: float, north_m: float, target_e: float, target_n: float, speed_mps: float, gain_per_s: float, decel_mps2: float
) -> tuple[float, float]:
    """Ground-velocity demand (E, N m/s) toward a point: min(speed, k·d, sqrt(2·a·d)) so it stops there."""
    de, dn = target_e - east_m, target_n - north_m
    d = math.hypot(de, dn)
    if d < 1e-6:
        return 0.0, 0.0
    v = min(speed_mps, gain_per_s * d, math.sqrt(2.0 * decel_mps2 * d))
    return v * de / d, v * dn / d


LOSING_GROUND_PERSIST_S = 3.0
"""How long (s, beyond the time a brake takes to stop what it moved away at) a multirotor must move against its
full-tilt push before :class:`LosingGround` says it is losing ground: the unit's own persistence for a wind
estimate beyond authority (:data:`geofence.unit.geofence_unit.WIND_BEYOND_AUTHORITY_PERSIST_S`), and the time
constant of its averages."""
BRAKE_FRACTION = 0.5
"""The least fraction of the tilt limit's acceleration ``g tan(tilt)`` a brake at the tilt limit is allowed
(the attitude's lag while it tilts over; the drag, which helps, left out): a brake slower than that from the
speed it had is taken for a wind beyond authority."""
STEADY_PUSH = 0.9
"""The least length of the push direction's average (unit vectors) for a steady push: a velocity loop chasing a
jumping estimate (a degraded receiver's fixes) pushes one way and the other, braking what it sees each time."""
LOSING_GROUND_MIN_MPS = 0.5
"""The least average speed against a steady push that counts as losing ground (m/s): below it, the wind is at
the authority and the estimate's own wander (a degraded receiver's bias walk) could be all there is."""


class LosingGround:
    """Whether a multirotor pushed at its tilt limit still moves the other way: the wind beyond its authority,
    measured on its own ground velocity instead of inferred from a wind estimate that lags it.

    Each saturated step of :class:`VelocityController` gives the ground velocity and the push (the acceleration
    demand's direction); an unsaturated step ends the episode. Over the episode both are averaged (first-order,
    time constant :data:`LOSING_GROUND_PERSIST_S`, started at the first step's values). The vehicle is *losing
    ground* once the episode has lasted :data:`LOSING_GROUND_PERSIST_S` plus the time a brake at
    :data:`BRAKE_FRACTION` of the tilt limit's acceleration takes to stop the speed it had against the push at
    the start (braking looks the same until then), the average push is steady (:data:`STEADY_PUSH`), and the
    average velocity along it is at least :data:`LOSING_GROUND_MIN_MPS` against it. While it holds, the wind is
    at least the one the vehicle's top airspeed along the push leaves (:meth:`implied_wind_enu`).
    """

    __slots__ = ("seconds", "need_s", "push_e", "push_n", "v_east_mps", "v_north_mps")

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        """End the episode (an unsaturated step)."""
        self.seconds = 0.0
        """How long the push has been at the tilt limit without a break (s)."""
        self.need_s = math.inf
        self.push_e = self.push_n = 0.0
        """The push direction's average (east, north; length <= 1)."""
        self.v_east_mps = self.v_north_mps = 0.0
        """The ground velocity's average (m/s)."""

    def step(self, v_east_mps: float, v_north_mps: float, push_e: float, push_n: float, dt_s: float, a_max: float) -> None:
        """A saturated step: the ground velocity and the push's unit direction (ENU)."""
        if self.seconds == 0.0:
            away = -(v_east_mps * push_e + v_north_mps * push_n)
            self.need_s = LOSING_GROUND_PERSIST_S + max(away, 0.0) / (BRAKE_FRACTION * max(a_max, 0.1))
            self.push_e, self.push_n, self.v_east_mps, self.v_north_mps = push_e, push_n, v_east_mps, v_north_mps
        else:
            k = min(dt_s / LOSING_GROUND_PERSIST_S, 1.0)
            self.push_e += k * (push_e - self.push_e)
            self.push_n += k * (push_n - self.push_n)
            self.v_east_mps += k * (v_east_mps - self.v_east_mps)
            self.v_north_mps += k * (v_north_mps - self.v_north_mps)
        self.seconds += dt_s

    @property
    def away_mps(self) -> float:
        """The average ground speed against the average push (m/s; 0 without a steady push)."""
        p = math.hypot(self.push_e, self.push_n)
        if p < STEADY_PUSH:
            return 0.0
        return -(self.v_east_mps * self.push_e + self.v_north_mps * self.push_n) / p

    @property
    def lost(self) -> bool:
        """The vehicle is losing ground: against a steady full-tilt push, for the time it needs."""
        return self.seconds >= self.need_s and self.away_mps >= LOSING_GROUND_MIN_MPS

    def implied_wind_enu(self, max_airspeed_mps: float) -> tuple[float, float]:
        """The wind (m/s, toward) that leaves the average ground velocity to a vehicle flying at
        ``max_airspeed_mps`` along its average push: a lower bound of the true wind while it is losing ground."""
        p = max(math.hypot(self.push_e, self.push_n), 1e-9)
        return (
            self.v_east_mps - max_airspeed_mps * self.push_e / p,
            self.v_north_mps - max_airspeed_mps * self.push_n / p,
        )


class VelocityController:
    """Multirotor PI ground-velocity loop: velocity error -> acceleration -> tilt sticks.

    With a wind estimate (``wind_enu``, a shared [east, north] list, m/s
    toward) the loop adds the drag feed-forward: the thrust that holds the
    commanded velocity against the air, ``(k1 + k2·|v_a|)·v_a`` with
    ``v_a = v_cmd - W`` and the platform's drag law
    (:mod:`geofence.physics.dynamics`). Without it, a P loop in a steady wind
    settles ``a_drag/k_v`` m/s off the command (2 m/s for a small quad in
    9 m/s of wind) until the integrator catches up, seconds later. The
    integrator trims what is left; it is frozen while the acceleration demand
    saturates at g·tan(tilt_max) (anti-windup).
    """

    def __init__(
        self, env: Envelope, gain_per_s: float = 1.6, integral_gain_per_s2: float = 0.35, wind_enu: list[float] | None = None
    ):
        self.env = env
        self.kv = gain_per_s
        self.ki = integral_gain_per_s2
        self.a_max = max_horizontal_accel_mps2(env)
        self.wind = wind_enu
        self._k1, self._k2 = drag_coefficients(env)
        self._int_e = 0.0
        self._int_n = 0.0
        self.losing = LosingGround()
        """Whether the vehicle is losing ground at its tilt limit (updated by :meth:`tilt_sticks`)."""

    def reset(self) -> None:
        self._int_e = self._int_n = 0.0
        self.losing.clear()

    def wind_balance_sticks(self, yaw_rad: float) -> tuple[float, float]:
        """(roll, pitch) sticks of the steady tilt that holds the ground position against the wind estimate.

        The drag feed-forward alone, no feedback: level in calm air or without a wind estimate.
        """
        if self.wind is None:
            return 0.0, 0.0
        we, wn = -self.wind[0], -self.wind[1]  # air velocity of a vehicle at rest over the ground
        k = self._k1 + self._k2 * math.hypot(we, wn)
        return tilt_sticks_for_accel(k * we, k * wn, yaw_rad, self.env)

    def tilt_sticks(
        self, v_east_mps: float, v_north_mps: float, ve_cmd: float, vn_cmd: float, yaw_rad: float, dt_s: float
    ) -> tuple[float, float]:
        """(roll, pitch) sticks driving the ground velocity to (ve_cmd, vn_cmd)."""
        ee, en = ve_cmd - v_east_mps, vn_cmd - v_north_mps
        ae = self.kv * ee + self.ki * self._int_e
        an = self.kv * en + self.ki * self._int_n
        if self.wind is not None:
            vae, van = ve_cmd - self.wind[0], vn_cmd - self.wind[1]
            k = self._k1 + self._k2 * math.hypot(vae, van)
            ae += k * vae
            an += k * van
        a = math.hypot(ae, an)
        if a > self.a_max:
            ae, an = ae * self.a_max / a, an * self.a_max / a
            self.losing.step(v_east_mps, v_north_mps, ae / self.a_max, an / self.a_max, dt_s, self.a_max)
        else:
            self._int_e += ee * dt_s
            self._int_n += en * dt_s
            if self.losing.seconds:  # (an episode ends; most steps have none to end)
                self.losing.clear()
        return tilt_sticks_for_accel(ae, an, yaw_rad, self.env)


@jitable
def orbit_course_rad(
    east_m: float, north_m: float, center_e: float, center_n: float, radius_m: float, gain: float = 2.0, clockwise: bool = True
) -> tuple[float, float]:
    """Vector-field course onto a circle (Beard & McLain): (course rad, distance from the centre m)."""
    d = math.hypot(east_m - center_e, north_m - center_n)
    bearing = math.atan2(east_m - center_e, north_m - center_n)
    lam = 1.0 if clockwise else -1.0
    return bearing + lam * (0.5 * math.pi + math.atan(gain * (d - radius_m) / radius_m)), d


@jitable
def air_heading_to_rad(
    s: VehicleState, target_e: float, target_n: float, wind_e: float, wind_n: float, min_speed_mps: float
) -> float:
    """Air heading whose ground track from ``s`` points at the target (ENU m): the wind triangle at the current
    airspeed (at least ``min_speed_mps`` and 1 m/s), wind ``(wind_e, wind_n)`` m/s toward."""
    course = math.atan2(target_e - s.east_m, target_n - s.north_m)
    cross = wind_e * math.cos(course) - wind_n * math.sin(course)  # wind component to the right of the course
    v = max(s.airspeed_mps, min_speed_mps, 1.0)
    return course - math.asin(clip(cross / v, -1.0, 1.0))
