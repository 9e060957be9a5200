"""Recovery guidance: the sticks the geofence flies while it overrides the pilot.

Each law is started with the state at activation and a goal (a point in ENU m
and a height in the fence's altitude reference), then asked for sticks every
step. They see only the estimate and the :class:`Envelope`.

* :class:`MultirotorVelocityRecovery` (default): brake at the tilt limit, then
  fly back toward the recovery point at a moderate speed and stop there
  (PI velocity loop with a braking-limited approach), altitude to the goal.
* :class:`SeedPDRecovery`: the published law of the seed flights, per axis
  ``u = K_P·δx + K_D·δẋ`` on the error to a set-point that ramps linearly from
  the breach state to the goal over ``ramp_s``, with per-axis saturation and
  deadbands on height and yaw (gains in stick units, see ``SeedPDGains``).
* :class:`FixedWingRecovery`: bank at the limit in the turn direction the
  boundary-shift computation scored best (the one that keeps the aircraft
  inside given the wind), until the air heading points at the recovery point
  (wind-corrected), then track to it and orbit it; arrest climb/descent toward
  the goal height; cruise airspeed.
* :class:`LandingGuidance`: go to a landing point (a floor gap) and descend;
  a fixed-wing spirals down over it.

Angles rad, positions ENU m, heights m, speeds m/s.
"""

from __future__ import annotations

import math

from geofence.config import SeedPDGains
from geofence.control_laws import (
    VelocityController,
    airspeed_to_stick,
    altitude_to_climb_rate,
    approach_velocity,
    bank_stick_for_course,
    climb_rate_to_stick,
    clip,
    orbit_course_rad,
    wrap_pi,
    yaw_stick_for_heading,
)
from geofence.interface import Envelope, StickCommand, VehicleState

ALTITUDE_GAIN_PER_S = 1.0
FIXED_WING_ALTITUDE_GAIN_PER_S = 0.35
COURSE_GAIN_PER_S = 0.9
ROLL_OUT_TOLERANCE_RAD = math.radians(15.0)
LEVEL_TOUCHDOWN_BELOW_M = 1.5


class MultirotorVelocityRecovery:
    def __init__(self, env: Envelope, speed_mps: float | None = None):
        self.env = env
        self.speed_mps = speed_mps if speed_mps is not None else 0.5 * env.cruise_speed_mps
        self.velocity = VelocityController(env)
        self.goal = (0.0, 0.0, 0.0)
        self.yaw_hold = 0.0

    def start(self, s: VehicleState, goal_e: float, goal_n: float, goal_h: float, h: float, t_s: float, turn_sign: int = 0) -> None:
        self.goal = (goal_e, goal_n, goal_h)
        self.yaw_hold = s.yaw_rad
        self.velocity.reset()

    def sticks(self, s: VehicleState, h: float, t_s: float, dt_s: float) -> StickCommand:
        ge, gn, gh = self.goal
        ve, vn = approach_velocity(s.east_m, s.north_m, ge, gn, self.speed_mps, 0.8, 0.5 * self.env.braking_decel_mps2)
        roll, pitch = self.velocity.tilt_sticks(s.v_east_mps, s.v_north_mps, ve, vn, s.yaw_rad, dt_s)
        return StickCommand(
            roll=roll,
            pitch=pitch,
            yaw=yaw_stick_for_heading(self.yaw_hold, s.yaw_rad, self.env),
            throttle=climb_rate_to_stick(altitude_to_climb_rate(gh, h, self.env, ALTITUDE_GAIN_PER_S), self.env),
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

    def start(self, s: VehicleState, goal_e: float, goal_n: float, goal_h: float, h: float, t_s: float, turn_sign: int = 0) -> None:
        self.start_point = (s.east_m, s.north_m, h)
        self.goal = (goal_e, goal_n, goal_h)
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


class FixedWingRecovery:
    def __init__(self, env: Envelope, wind_enu: list[float]):
        self.env = env
        self.wind = wind_enu  # shared, updated by the unit
        self.goal = (0.0, 0.0, 0.0)
        self.turn_sign = 0
        self.turning = True
        self.orbit_radius_m = 1.5 * env.cruise_speed_mps**2 / (9.80665 * math.tan(env.max_bank_rad))

    def start(self, s: VehicleState, goal_e: float, goal_n: float, goal_h: float, h: float, t_s: float, turn_sign: int = 0) -> None:
        self.goal = (goal_e, goal_n, goal_h)
        self.turn_sign = turn_sign if turn_sign else (1 if wrap_pi(self._heading_to_goal(s) - s.yaw_rad) < 0 else -1)
        self.turning = True

    def _heading_to_goal(self, s: VehicleState) -> float:
        """Air heading whose ground track points at the goal (wind triangle at cruise airspeed)."""
        ge, gn, _ = self.goal
        course = math.atan2(ge - s.east_m, gn - s.north_m)
        we, wn = self.wind
        cross = we * math.cos(course) - wn * math.sin(course)  # wind component to the right of the course
        v = max(s.airspeed_mps, self.env.min_speed_mps, 1.0)
        return course - math.asin(clip(cross / v, -1.0, 1.0))

    def sticks(self, s: VehicleState, h: float, t_s: float, dt_s: float) -> StickCommand:
        ge, gn, gh = self.goal
        env = self.env
        pitch = climb_rate_to_stick(altitude_to_climb_rate(gh, h, env, FIXED_WING_ALTITUDE_GAIN_PER_S), env)
        throttle = airspeed_to_stick(env.cruise_speed_mps, env)
        if self.turning:
            if abs(wrap_pi(self._heading_to_goal(s) - s.yaw_rad)) < ROLL_OUT_TOLERANCE_RAD:
                self.turning = False
            else:
                # turn_sign +1 = left (counter-clockwise) = negative roll stick
                return StickCommand(roll=-float(self.turn_sign), pitch=pitch, yaw=0.0, throttle=throttle)
        d = math.hypot(ge - s.east_m, gn - s.north_m)
        if d > 1.2 * self.orbit_radius_m:
            course_cmd = math.atan2(ge - s.east_m, gn - s.north_m)
        else:
            course_cmd, _ = orbit_course_rad(s.east_m, s.north_m, ge, gn, self.orbit_radius_m, clockwise=self.turn_sign < 0)
        roll = bank_stick_for_course(s, course_cmd, env, COURSE_GAIN_PER_S)
        return StickCommand(roll=roll, pitch=pitch, yaw=0.0, throttle=throttle)


class LandingGuidance:
    """Fly to a landing point at a safe height, then descend onto it (fixed-wing: spiral down over it)."""

    def __init__(self, env: Envelope, spiral_radius_m: float):
        self.env = env
        self.velocity = VelocityController(env) if env.is_multirotor else None
        self.spiral_radius_m = spiral_radius_m
        self.point = (0.0, 0.0)
        self.cruise_h = 0.0

    def start(self, point_e: float, point_n: float, cruise_h: float) -> None:
        self.point = (point_e, point_n)
        self.cruise_h = cruise_h
        if self.velocity:
            self.velocity.reset()

    def over_point(self, s: VehicleState) -> bool:
        pe, pn = self.point
        return math.hypot(pe - s.east_m, pn - s.north_m) < (2.0 if self.env.is_multirotor else 1.5 * self.spiral_radius_m)

    def sticks(self, s: VehicleState, h: float, dt_s: float, descend: bool | None = None) -> StickCommand:
        """Sticks toward the landing point; descend when ``descend`` (default: when over the point)."""
        env = self.env
        pe, pn = self.point
        over = self.over_point(s) if descend is None else descend
        if self.velocity is not None:
            ve, vn = approach_velocity(s.east_m, s.north_m, pe, pn, 0.5 * env.cruise_speed_mps, 0.8, 0.5 * env.braking_decel_mps2)
            roll, pitch = self.velocity.tilt_sticks(s.v_east_mps, s.v_north_mps, ve, vn, s.yaw_rad, dt_s)
            if over and h < LEVEL_TOUCHDOWN_BELOW_M:  # touch down level: a tilted landing gear tips over
                roll = pitch = 0.0
            climb = -min(1.0, env.max_descent_rate_mps) if over else altitude_to_climb_rate(self.cruise_h, h, env, ALTITUDE_GAIN_PER_S)
            return StickCommand(roll=roll, pitch=pitch, yaw=0.0, throttle=climb_rate_to_stick(climb, env))
        course_cmd, _ = orbit_course_rad(s.east_m, s.north_m, pe, pn, self.spiral_radius_m)
        roll = bank_stick_for_course(s, course_cmd, env, COURSE_GAIN_PER_S)
        climb = -env.max_descent_rate_mps if over else altitude_to_climb_rate(self.cruise_h, h, env, FIXED_WING_ALTITUDE_GAIN_PER_S)
        return StickCommand(roll=roll, pitch=climb_rate_to_stick(climb, env), yaw=0.0, throttle=airspeed_to_stick(env.min_speed_mps, env))
