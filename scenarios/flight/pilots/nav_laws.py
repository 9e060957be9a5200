"""Outer-loop navigation laws of the mission autopilot, as small stateful controllers.

These turn a navigation goal (a point, a ground velocity, a course, a path or
an orbit) into normalized sticks, using only the platform :class:`Envelope` to
scale them (see :mod:`geofence.interface` for stick semantics). Plain Python
floats throughout: they run on the simulation's per-step path.

* :class:`MultirotorNavigator`: point -> velocity command (braking-limited
  approach) -> PI velocity loop -> tilt sticks; altitude -> climb-rate stick.
* :class:`FixedWingNavigator`: straight-line and orbit vector fields
  (Beard & McLain, *Small Unmanned Aircraft*, ch. 10) -> commanded course ->
  bank stick; altitude -> climb-rate stick; airspeed -> throttle stick. Its law of a course error
  (:func:`course_law_sticks`) is :func:`geofence.jit.jitable`: a pilot's compiled law
  (:mod:`scenarios.flight.pilots.law_kernel`) flies the same function.

Angles are rad, courses and headings clockwise from north, positions ENU m.
The stick mappings themselves are the shared primitives of
:mod:`geofence.physics.control_laws`.
"""

from __future__ import annotations

import math

from geofence.interface import Envelope, StickCommand, VehicleState
from geofence.jit import jitable
from geofence.physics.control_laws import (
    G_MPS2,
    VelocityController,
    airspeed_to_stick,
    altitude_to_climb_rate,
    approach_velocity,
    climb_rate_to_stick,
    course_error_rad,
    fixed_wing_roll_stick,
    orbit_course_rad,
    yaw_stick_for_heading,
)

_TWO_OVER_PI = 2.0 / math.pi


@jitable
def course_law_sticks(
    ground_speed_mps: float, course_err_rad: float, up_m: float, target_up_m: float, climb_stick: float,
    altitude_gain_per_s: float, course_gain_per_s: float, env: Envelope,
) -> tuple[float, float]:  # fmt: skip
    """``(roll, pitch)`` sticks of :meth:`FixedWingNavigator.sticks` for a course error: the coordinated bank of
    :func:`~geofence.physics.control_laws.fixed_wing_roll_stick`, and the climb stick ``climb_stick`` or, where it is NaN,
    the altitude hold of ``target_up_m`` from ``up_m``. ``env``: an :class:`Envelope` or a named tuple of the
    fields it reads (bank limit, climb and descent rates)."""
    if climb_stick != climb_stick:  # (NaN) hold the height
        climb_stick = climb_rate_to_stick(altitude_to_climb_rate(target_up_m, up_m, env, altitude_gain_per_s), env)
    return fixed_wing_roll_stick(ground_speed_mps, course_err_rad, course_gain_per_s, env), climb_stick


class MultirotorNavigator:
    """Position and velocity control of a multirotor through tilt / climb-rate sticks."""

    def __init__(
        self,
        env: Envelope,
        position_gain_per_s: float = 0.8,
        velocity_gain_per_s: float = 1.6,
        velocity_integral_gain_per_s2: float = 0.35,
        altitude_gain_per_s: float = 1.0,
        yaw_gain_per_s: float = 1.5,
        approach_decel_fraction: float = 0.5,
    ):
        self.env = env
        self.kp = position_gain_per_s
        self.kh = altitude_gain_per_s
        self.kpsi = yaw_gain_per_s
        self.a_approach = approach_decel_fraction * env.braking_decel_mps2
        self.velocity = VelocityController(env, velocity_gain_per_s, velocity_integral_gain_per_s2)

    def velocity_toward(self, s: VehicleState, target_e: float, target_n: float, speed_mps: float) -> tuple[float, float]:
        """Ground-velocity command (m/s, E/N) to reach a point and stop there without overshoot."""
        return approach_velocity(s.east_m, s.north_m, target_e, target_n, speed_mps, self.kp, self.a_approach)

    def sticks_for_velocity(
        self, s: VehicleState, ve_cmd: float, vn_cmd: float, v_up_cmd: float, yaw_cmd_rad: float, dt_s: float
    ) -> StickCommand:
        """PI velocity loop -> tilt sticks; climb rate -> throttle stick; yaw toward ``yaw_cmd_rad``."""
        env = self.env
        yaw_rad = s.yaw_rad
        roll, pitch = self.velocity.tilt_sticks(s.v_east_mps, s.v_north_mps, ve_cmd, vn_cmd, yaw_rad, dt_s)
        yaw = yaw_stick_for_heading(yaw_cmd_rad, yaw_rad, env, self.kpsi)
        throttle = climb_rate_to_stick(v_up_cmd, env)
        # (roll, pitch, yaw, throttle): tuple.__new__ skips the named tuple's Python constructor (0.14 -> 0.07 us)
        return tuple.__new__(StickCommand, (roll, pitch, yaw, throttle))

    def sticks_to_point(
        self,
        s: VehicleState,
        target_e: float,
        target_n: float,
        target_up: float,
        speed_mps: float,
        yaw_cmd_rad: float,
        dt_s: float,
    ) -> StickCommand:
        ve, vn = self.velocity_toward(s, target_e, target_n, speed_mps)
        vz = altitude_to_climb_rate(target_up, s.up_m, self.env, self.kh)
        return self.sticks_for_velocity(s, ve, vn, vz, yaw_cmd_rad, dt_s)


class FixedWingNavigator:
    """Course, path and orbit following of a fixed-wing aircraft through bank / climb / airspeed sticks."""

    def __init__(
        self,
        env: Envelope,
        course_gain: float = 0.9,
        path_approach_angle_rad: float = math.radians(60.0),
        path_gain_per_m: float = 0.025,
        orbit_gain: float = 2.0,
        altitude_gain_per_s: float = 0.35,
        turn_commit_rad: float | None = None,
    ):
        """``turn_commit_rad``: once the course error exceeds it, keep turning the way the turn began
        until the error is back below it (None: always turn the short way)."""
        self.env = env
        self.turn_commit_rad = turn_commit_rad
        self._turn_sign = 0.0
        self.k_course = course_gain
        self.chi_inf = path_approach_angle_rad
        self.k_path = path_gain_per_m
        self.k_orbit = orbit_gain
        self.kh = altitude_gain_per_s
        # the throttle stick of the last airspeed demand (a demand is held for many steps: mapped when it changes)
        self._airspeed_demand = math.nan
        self._throttle_stick = 0.0

    def min_turn_radius_m(self, airspeed_mps: float | None = None) -> float:
        v = self.env.cruise_speed_mps if airspeed_mps is None else airspeed_mps
        return v * v / (G_MPS2 * math.tan(self.env.max_bank_rad))

    def course_error_rad(self, s: VehicleState, course_cmd_rad: float) -> float:
        """The course error the course law turns through (+ right): the short way, or with ``turn_commit_rad`` ...

        ... a turn of more than that keeps its direction. A course reversal's error
        sits near 180 deg, where the short way flips with every change of the track (in a strong wind the
        track swings with the crab angle); without the commitment the aircraft rolls one way, then the
        other, and flies on in between.
        """
        err = course_error_rad(s, course_cmd_rad)
        if self.turn_commit_rad is None:
            return err
        if abs(err) > self.turn_commit_rad:
            if self._turn_sign * err < 0.0:
                err += math.copysign(2.0 * math.pi, self._turn_sign)  # the long way: the way it is turning
            elif self._turn_sign == 0.0:
                self._turn_sign = math.copysign(1.0, err)
        else:
            self._turn_sign = 0.0
        return err

    def course_on_line(self, s: VehicleState, e0: float, n0: float, e1: float, n1: float) -> tuple[float, float, float]:
        """Vector-field course to follow the line p0 -> p1.

        Returns (commanded course rad, along-track distance from p0 m, leg length m).
        """
        de, dn = e1 - e0, n1 - n0
        length = math.hypot(de, dn)
        if length < 1e-6:
            return math.atan2(e1 - s.east_m, n1 - s.north_m), 0.0, 0.0
        qe, qn = de / length, dn / length
        pe, pn = s.east_m - e0, s.north_m - n0
        along = pe * qe + pn * qn
        cross_right = pe * qn - pn * qe  # + when right of the path
        chi_q = math.atan2(qe, qn)
        return chi_q - self.chi_inf * _TWO_OVER_PI * math.atan(self.k_path * cross_right), along, length

    def course_on_orbit(
        self, s: VehicleState, ce: float, cn: float, radius_m: float, clockwise: bool = True
    ) -> tuple[float, float]:
        """Vector-field course to converge onto a circle; returns (course rad, distance from center m)."""
        return orbit_course_rad(s.east_m, s.north_m, ce, cn, radius_m, self.k_orbit, clockwise)

    def sticks(
        self,
        s: VehicleState,
        course_cmd_rad: float,
        target_up_m: float,
        airspeed_mps: float,
        climb_stick: float | None = None,
    ) -> StickCommand:
        """Sticks that fly ``course_cmd_rad`` at ``airspeed_mps`` and hold ``target_up_m``.

        ``climb_stick`` given: that climb-rate (pitch) stick instead of the altitude hold (``target_up_m`` unused).
        """
        env = self.env
        if self.turn_commit_rad is None:  # the short way: the law itself (a call fewer per step)
            course_err = course_error_rad(s, course_cmd_rad)
        else:
            course_err = self.course_error_rad(s, course_cmd_rad)
        if airspeed_mps != self._airspeed_demand:
            self._airspeed_demand = airspeed_mps
            self._throttle_stick = airspeed_to_stick(airspeed_mps, env)
        roll, pitch = course_law_sticks(
            s.ground_speed_mps, course_err, s.up_m, target_up_m, math.nan if climb_stick is None else climb_stick,
            self.kh, self.k_course, env,
        )  # fmt: skip
        return tuple.__new__(StickCommand, (roll, pitch, 0.0, self._throttle_stick))
