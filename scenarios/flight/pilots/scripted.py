"""The scripted ("adversarial") pilot: timed segments of raw sticks or blunt behaviours.

Used to provoke breaches: "fly course 090 at full speed", "climb at max",
"hold these sticks". Each segment lasts ``duration_s``; after the last one the
pilot keeps flying it. Behaviours use the same navigation laws as the mission
autopilot but with saturated speed/climb demands.
"""

from __future__ import annotations

import math

from geofence.interface import Envelope, StickCommand, VehicleState
from scenarios.flight.pilots.nav_laws import FixedWingNavigator, MultirotorNavigator
from scenarios.spec.schema import ScriptSegment

_CLIMB_STICK = {"hold": 0.0, "max": 1.0, "descend": -1.0}


class ScriptedPilot:
    def __init__(self, segments: tuple[ScriptSegment, ...], env: Envelope, start: VehicleState, dt_s: float):
        self.segments = segments
        self.env = env
        self.dt_s = dt_s
        self.ends_s = list(_cumulative(s.duration_s for s in segments))
        self.mc = MultirotorNavigator(env) if env.is_multirotor else None
        self.fw = None if env.is_multirotor else FixedWingNavigator(env)
        self._hold_up_m = start.up_m
        self._hold_yaw_rad = start.yaw_rad
        self._segment_index = -1
        self.finished = False  # a script has no goal: it flies until the scenario's duration ends

    @property
    def items_total(self) -> int:
        return len(self.segments)

    @property
    def items_reached(self) -> int:
        return max(self._segment_index, 0)

    def _segment_at(self, t_s: float) -> tuple[ScriptSegment, int]:
        i = 0
        while i < len(self.ends_s) - 1 and t_s >= self.ends_s[i]:
            i += 1
        return self.segments[i], i

    def command(self, s: VehicleState) -> StickCommand:
        seg, i = self._segment_at(s.t_s)
        if i != self._segment_index:
            self._segment_index = i
            self._hold_up_m = s.up_m
            self._hold_yaw_rad = s.yaw_rad
        if seg.sticks is not None:
            return StickCommand(*seg.sticks)
        assert seg.course_deg is not None  # the schema: a segment has sticks or a course
        course = math.radians(seg.course_deg)
        env = self.env
        speed = {"max": env.max_speed_mps, "cruise": env.cruise_speed_mps, "min": env.min_speed_mps}[seg.speed]
        if self.mc is not None:
            vz = {"hold": 0.0, "max": env.max_climb_rate_mps, "descend": -env.max_descent_rate_mps}[seg.climb]
            if seg.climb == "hold":
                vz = max(-env.max_descent_rate_mps, min(env.max_climb_rate_mps, self._hold_up_m - s.up_m))
            return self.mc.sticks_for_velocity(
                s, speed * math.sin(course), speed * math.cos(course), vz, self._hold_yaw_rad, self.dt_s
            )
        assert self.fw is not None  # not a multirotor
        cmd = self.fw.sticks(s, course, self._hold_up_m, speed)
        if seg.climb != "hold":
            cmd = StickCommand(cmd.roll, _CLIMB_STICK[seg.climb], cmd.yaw, cmd.throttle)
        return cmd


def _cumulative(values):
    total = 0.0
    for v in values:
        total += v
        yield total
