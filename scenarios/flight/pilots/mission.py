"""The GPS mission autopilot: sequences mission items and flies them with the navigation laws.

Mission items (takeoff, waypoint, loiter, land) are given in WGS-84 and
converted once to the local ENU frame; the per-step work is plain float math.
A waypoint is reached inside the acceptance radius (multirotor: also within
2 m of its height) or, for a fixed-wing, when the aircraft has passed the end
of the leg. Progress is counted in items reached.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from geofence.geometry.geodesy import LocalFrame
from geofence.interface import Envelope, StickCommand, VehicleState
from scenarios.definition.schema import MissionConfig
from scenarios.flight.pilots.nav_laws import FixedWingNavigator, MultirotorNavigator, climb_rate_to_stick

MULTIROTOR_VERTICAL_TOLERANCE_M = 2.0
LAND_SLOW_BELOW_AGL_M = 3.0
LAND_FINAL_DESCENT_MPS = 0.5
TURN_COMMIT_RAD = math.radians(150.0)
"""A fixed-wing's course change of more than this keeps the direction it began in (autopilots' L1 guidance
does the same near a reversal; see :meth:`FixedWingNavigator.course_error_rad`)."""
LAND_DESCENT_MPS = 1.5


@dataclass
class _Target:
    kind: str
    east_m: float
    north_m: float
    up_m: float
    duration_s: float = 0.0
    radius_m: float = 0.0


class MissionAutopilot:
    """Flies a :class:`MissionConfig` on a multirotor or a fixed-wing, emitting sticks."""

    def __init__(self, mission: MissionConfig, frame: LocalFrame, env: Envelope, start: VehicleState, dt_s: float):
        self.env = env
        self.dt_s = dt_s
        self.acceptance_m = mission.acceptance_radius_m
        self.speed_mps = mission.speed_mps or env.cruise_speed_mps
        self.multirotor = env.is_multirotor
        self.mc = MultirotorNavigator(env) if self.multirotor else None
        self.fw = None if self.multirotor else FixedWingNavigator(env, turn_commit_rad=TURN_COMMIT_RAD)
        self.targets = [self._to_target(item, frame, start) for item in mission.items]
        self.index = 0
        self.finished = False
        self.landed = False
        self._leg_start = (start.east_m, start.north_m)
        self._hold_yaw_rad = start.yaw_rad
        self._loiter_started_s: float | None = None
        self._last_up_m = start.up_m

    @staticmethod
    def _to_target(item, frame: LocalFrame, start: VehicleState) -> _Target:
        if item.lat_deg is not None:
            e, n, _ = frame.to_enu(item.lat_deg, item.lon_deg, frame.h0_m)
        else:
            e, n = math.nan, math.nan  # filled in when the item starts (current position)
        up = item.agl_m if item.agl_m is not None else math.nan
        return _Target(item.kind, e, n, up, item.duration_s, item.radius_m)

    # -- progress ----------------------------------------------------------
    @property
    def items_total(self) -> int:
        return len(self.targets)

    @property
    def items_reached(self) -> int:
        return len(self.targets) if self.finished else self.index

    def _advance(self, s: VehicleState) -> None:
        done = self.targets[self.index]
        if not math.isnan(done.east_m):
            self._leg_start = (done.east_m, done.north_m)
        else:
            self._leg_start = (s.east_m, s.north_m)
        self._last_up_m = done.up_m if not math.isnan(done.up_m) else s.up_m
        self.index += 1
        self._loiter_started_s = None
        if self.index >= len(self.targets):
            self.finished = True

    def _current(self, s: VehicleState) -> _Target:
        tgt = self.targets[self.index]
        if math.isnan(tgt.east_m):  # takeoff / land without position: here
            tgt.east_m, tgt.north_m = s.east_m, s.north_m
        if math.isnan(tgt.up_m):
            tgt.up_m = self._last_up_m
        return tgt

    # -- the per-step command ----------------------------------------------
    def _mc(self) -> MultirotorNavigator:
        assert self.mc is not None, "multirotor navigation on a fixed-wing"
        return self.mc

    def _fw(self) -> FixedWingNavigator:
        assert self.fw is not None, "fixed-wing navigation on a multirotor"
        return self.fw

    def notice_control(self, in_control: bool) -> None:
        """Ignored: this pilot judges only from the vehicle's state (see the module docstring)."""

    def command(self, s: VehicleState) -> StickCommand:
        if self.finished:
            return self._after_mission(s)
        tgt = self._current(s)
        return self._fly_multirotor(s, tgt) if self.multirotor else self._fly_fixed_wing(s, tgt)

    def _after_mission(self, s: VehicleState) -> StickCommand:
        if self.landed:
            return StickCommand(throttle=-1.0)
        last = self.targets[-1]
        if self.multirotor:
            return self._mc().sticks_to_point(
                s, last.east_m, last.north_m, last.up_m, self.speed_mps, self._hold_yaw_rad, self.dt_s
            )
        radius = max(last.radius_m, 1.5 * self._fw().min_turn_radius_m())
        course, _ = self._fw().course_on_orbit(s, last.east_m, last.north_m, radius)
        return self._fw().sticks(s, course, last.up_m, self.speed_mps)

    def _fly_multirotor(self, s: VehicleState, tgt: _Target) -> StickCommand:
        mc = self.mc
        assert mc is not None, "multirotor navigation on a fixed-wing"  # (inline: per step, a call costs more)
        if tgt.kind == "takeoff":
            if s.up_m >= tgt.up_m - 1.0:
                self._advance(s)
            return mc.sticks_to_point(s, tgt.east_m, tgt.north_m, tgt.up_m, self.speed_mps, self._hold_yaw_rad, self.dt_s)
        if tgt.kind == "land":
            d = math.hypot(tgt.east_m - s.east_m, tgt.north_m - s.north_m)
            if d > self.acceptance_m:
                return mc.sticks_to_point(s, tgt.east_m, tgt.north_m, s.up_m, self.speed_mps, self._hold_yaw_rad, self.dt_s)
            if s.on_ground and abs(s.v_up_mps) < 0.3:
                self.landed = True
                self._advance(s)
                return StickCommand(throttle=-1.0)
            rate = (
                LAND_FINAL_DESCENT_MPS
                if s.agl_m < LAND_SLOW_BELOW_AGL_M
                else min(LAND_DESCENT_MPS, self.env.max_descent_rate_mps)
            )
            ve, vn = mc.velocity_toward(s, tgt.east_m, tgt.north_m, self.speed_mps)
            return mc.sticks_for_velocity(s, ve, vn, -rate, self._hold_yaw_rad, self.dt_s)
        d = math.hypot(tgt.east_m - s.east_m, tgt.north_m - s.north_m)
        close = d <= self.acceptance_m and abs(tgt.up_m - s.up_m) <= MULTIROTOR_VERTICAL_TOLERANCE_M
        if tgt.kind == "loiter" and close:
            if self._loiter_started_s is None:
                self._loiter_started_s = s.t_s
            if s.t_s - self._loiter_started_s >= tgt.duration_s:
                self._advance(s)
        elif tgt.kind == "waypoint" and close:
            self._advance(s)
        return mc.sticks_to_point(s, tgt.east_m, tgt.north_m, tgt.up_m, self.speed_mps, self._hold_yaw_rad, self.dt_s)

    def _fly_fixed_wing(self, s: VehicleState, tgt: _Target) -> StickCommand:
        fw = self.fw
        assert fw is not None, "fixed-wing navigation on a multirotor"  # (inline: per step, a call costs more)
        if tgt.kind == "takeoff":  # climb out straight ahead on the start heading
            if s.up_m >= tgt.up_m - 3.0:
                self._advance(s)
            return fw.sticks(s, self._hold_yaw_rad, tgt.up_m, self.speed_mps)
        if tgt.kind == "loiter":
            radius = max(tgt.radius_m, 1.5 * fw.min_turn_radius_m())
            course, d = fw.course_on_orbit(s, tgt.east_m, tgt.north_m, radius)
            if self._loiter_started_s is None and abs(d - radius) < max(self.acceptance_m, 0.2 * radius):
                self._loiter_started_s = s.t_s
            if self._loiter_started_s is not None and s.t_s - self._loiter_started_s >= tgt.duration_s:
                self._advance(s)
            return fw.sticks(s, course, tgt.up_m, self.speed_mps)
        if tgt.kind == "land":
            return self._fixed_wing_landing(s, tgt)
        e0, n0 = self._leg_start
        course, along, length = fw.course_on_line(s, e0, n0, tgt.east_m, tgt.north_m)
        d = math.hypot(tgt.east_m - s.east_m, tgt.north_m - s.north_m)
        if d <= self.acceptance_m or (length > 0.0 and along >= length):
            self._advance(s)
        return fw.sticks(s, course, tgt.up_m, self.speed_mps)

    def _fixed_wing_landing(self, s: VehicleState, tgt: _Target) -> StickCommand:
        """Straight-in approach to the land point on a 5 deg glide path, slowest airspeed, then flare."""
        fw = self._fw()
        e0, n0 = self._leg_start
        course, along, length = fw.course_on_line(s, e0, n0, tgt.east_m, tgt.north_m)
        to_go = max(length - along, 0.0)
        glide_up = to_go * math.tan(math.radians(5.0))
        if s.on_ground:
            self.landed = True
            self._advance(s)
            return StickCommand(throttle=-1.0)
        cmd = fw.sticks(s, course, min(glide_up, self._last_up_m), self.env.min_speed_mps * 1.15)
        if s.agl_m < 2.0:  # flare: small sink rate, wings level
            return StickCommand(roll=0.0, pitch=climb_rate_to_stick(-0.4, self.env), throttle=-1.0)
        return cmd
