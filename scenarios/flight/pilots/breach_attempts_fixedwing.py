"""The breach-attempts pilot of a fixed-wing: the multirotor's attempts, flown from an orbit.

A fixed-wing cannot hover, so its home is an **orbit**: clockwise, radius
``max(1.5 x the envelope's turn radius at cruise, 30 m)``, centred on the start
point at ``home_agl_m`` above the ground. The pilot

1. **joins** the orbit (the first attempt only);
2. per attempt ``k`` (direction ``directions[k % len]``, speed drawn as the
   multirotor pilot draws it, :func:`~scenarios.flight.pilots.breach_attempts.draw_speeds`):
   **aligns**: keeps orbiting until the course points along the attempt's
   bearing and rolls out (at once if it already does); a horizontal push is
   flown straight along the bearing (a line from the roll-out point, so the
   wind does not carry it off) at an airspeed of the drawn speed clipped to
   [1.1 x min speed, max speed], with the height held; ``up``/``down`` climbs
   or descends at the drawn rate (capped by the envelope) along the course it
   had, at cruise;
3. the **push** ends after ``push_m`` of travel (along the bearing, or in
   height), when the aircraft has been **turned away** (course more than 60 deg
   off the push after having flown along it: the geofence took over), when a
   vertical push is pulled back (climbing against it), ``down`` at
   :data:`GROUND_CLEARANCE_M`, or after ``push_m / speed +``
   :data:`PUSH_SLACK_S`;
4. **returns** to the orbit, **rests** ``rest_s`` on it, next attempt.

It sees only the vehicle state (never the geofence mode) and flies with the
mission autopilot's :class:`~scenarios.flight.pilots.nav_laws.FixedWingNavigator`
(orbit and line vector fields). Its ``attempt_log`` has the multirotor pilot's
keys, plus ``t_push_start_s`` (the roll-out; ``t_start_s`` is when the attempt
began, the alignment included).
"""

from __future__ import annotations

import math

from geofence.interface import Envelope, StickCommand, VehicleState
from geofence.physics.control_laws import climb_rate_to_stick, ground_course_rad, wrap_pi
from scenarios.definition.schema import BreachAttemptsConfig, BreachDirection, VerticalSense
from scenarios.flight.pilots.breach_attempts import BreachAttemptsSchedule, PushEnd, push_progress
from scenarios.flight.pilots.nav_laws import FixedWingNavigator

ORBIT_TURN_RADII = 1.5
"""The home orbit's radius in turn radii at cruise (the envelope's bank limit) ..."""
MIN_ORBIT_RADIUS_M = 30.0
"""... and at least this."""
MIN_PUSH_SPEED_FACTOR = 1.1
"""A horizontal push is flown no slower than this times the envelope's min speed."""
ON_ORBIT_FRACTION = 0.2
"""Within this fraction of the radius of the orbit's circle, and ..."""
HEIGHT_TOLERANCE_M = 5.0
"""... this close to the home height, the aircraft counts as on its home orbit."""
JOIN_MAX_S = 120.0
RETURN_MAX_S = 180.0
ALIGN_MAX_ORBITS = 2.0
"""After this many orbits' time without the course along the bearing, the push starts anyway."""
ALIGN_TOLERANCE_RAD = math.radians(5.0)
"""Course this close to the bearing: roll out at once."""
ALONG_RAD = math.radians(20.0)
"""Course this close to the push's bearing: the aircraft has flown along it ..."""
TURNED_AWAY_RAD = math.radians(60.0)
"""... and once more than this off it again, it was turned away (the geofence took over): the push ends."""
PULLED_BACK_MPS = 0.5
"""A vertical push ends once the aircraft moves against it faster than this (after having moved with it)."""
PUSH_SLACK_S = 20.0
GROUND_CLEARANCE_M = 15.0
"""A ``down`` push ends this high above the ground."""


class FixedWingBreachAttemptsPilot(BreachAttemptsSchedule):
    """The fixed-wing's breach attempts from an orbit over the start point (see the module docstring)."""

    JOIN, ALIGN, PUSH, RETURN, REST, DONE = "join", "align", "push", "return", "rest", "done"

    def __init__(self, config: BreachAttemptsConfig, env: Envelope, start: VehicleState, dt_s: float):
        if env.is_multirotor:
            raise ValueError("FixedWingBreachAttemptsPilot flies fixed-wings (a multirotor: BreachAttemptsPilot)")
        super().__init__(config, env)
        self.dt_s = dt_s
        self.nav = FixedWingNavigator(env)
        self.orbit_radius_m = max(ORBIT_TURN_RADII * self.nav.min_turn_radius_m(), MIN_ORBIT_RADIUS_M)
        self.home = (start.east_m, start.north_m, start.up_m + (config.home_agl_m - start.agl_m))
        self.phase = self.JOIN
        self.phase_since_s = start.t_s
        self._push_origin = (0.0, 0.0, 0.0)
        self._push_unit_en = (0.0, 1.0)
        self._push_bearing_rad = 0.0
        self._flown_along = False
        self._moved_with_push = False

    # -- speeds ----------------------------------------------------------------
    def speed(self, k: int) -> float:
        """Attempt ``k``'s airspeed (m/s, clipped to [1.1 min, max]) or, for ``up``/``down``, its capped rate."""
        if self.direction(k).is_vertical:
            return self.vertical_rate(k)
        env = self.env
        lo = min(MIN_PUSH_SPEED_FACTOR * env.min_speed_mps, env.max_speed_mps)
        return min(max(float(self.speeds[k]), lo), env.max_speed_mps)

    # -- helpers ---------------------------------------------------------------
    def _enter(self, phase: str, t_s: float) -> None:
        self.phase = phase
        self.phase_since_s = t_s

    def _orbit(self, s: VehicleState) -> tuple[StickCommand, float]:
        """Sticks that fly the home orbit at cruise, and the distance from its centre (m)."""
        he, hn, hu = self.home
        course, d = self.nav.course_on_orbit(s, he, hn, self.orbit_radius_m)
        return self.nav.sticks(s, course, hu, self.env.cruise_speed_mps), d

    def _on_orbit(self, s: VehicleState, d_m: float) -> bool:
        return abs(d_m - self.orbit_radius_m) <= ON_ORBIT_FRACTION * self.orbit_radius_m and (
            abs(s.up_m - self.home[2]) <= HEIGHT_TOLERANCE_M
        )

    def _aligned(self, s: VehicleState, bearing_rad: float, at_once: bool) -> bool:
        """Roll out now? The course is at the bearing, or (clockwise orbit) will be within the roll-out's lead."""
        course = ground_course_rad(s.v_east_mps, s.v_north_mps, s.yaw_rad)
        if abs(wrap_pi(bearing_rad - course)) <= ALIGN_TOLERANCE_RAD:
            return True
        if at_once:
            return False
        ahead = (bearing_rad - course) % (2.0 * math.pi)  # still to turn, clockwise
        lead = 0.5 * self.env.reaction_time_s * s.ground_speed_mps / self.orbit_radius_m
        return ahead <= lead

    def _start_attempt(self, s: VehicleState) -> StickCommand:
        k = self.attempt
        self.log_start(k, self.speed(k), s.t_s)
        self._enter(self.ALIGN, s.t_s)
        d = self.direction(k)
        if d.is_vertical or (d.bearing_rad is not None and self._aligned(s, d.bearing_rad, at_once=True)):
            return self._start_push(s, d)
        return self._orbit(s)[0]

    def _start_push(self, s: VehicleState, d: BreachDirection) -> StickCommand:
        course = ground_course_rad(s.v_east_mps, s.v_north_mps, s.yaw_rad)
        self._push_bearing_rad = course if d.bearing_rad is None else d.bearing_rad
        self._push_unit_en = d.unit_en if not d.is_vertical else (math.sin(course), math.cos(course))
        self._push_origin = (s.east_m, s.north_m, s.up_m)
        self._flown_along = False
        self._moved_with_push = False
        self.log_time("t_push_start_s", s.t_s)
        self._enter(self.PUSH, s.t_s)
        return self._push_sticks(s, d, self.speed(self.attempt))

    def _push_end(self, s: VehicleState, d: BreachDirection, speed: float, in_phase_s: float) -> PushEnd | None:
        travel, v_along = push_progress(d, self._push_origin, s, self._push_unit_en)
        off = abs(wrap_pi(ground_course_rad(s.v_east_mps, s.v_north_mps, s.yaw_rad) - self._push_bearing_rad))
        if off <= ALONG_RAD:
            self._flown_along = True
        if d.is_vertical and v_along > 0.5 * speed:
            self._moved_with_push = True
        if travel >= self.config.push_m:
            return PushEnd.TRAVEL
        if self._flown_along and off > TURNED_AWAY_RAD:
            return PushEnd.TURNED_AWAY
        if self._moved_with_push and v_along < -PULLED_BACK_MPS:
            return PushEnd.PULLED_BACK
        if d.vertical is VerticalSense.DOWN and s.agl_m <= GROUND_CLEARANCE_M:
            return PushEnd.GROUND
        if in_phase_s >= self.config.push_m / speed + PUSH_SLACK_S:
            return PushEnd.TIMEOUT
        return None

    def _push_sticks(self, s: VehicleState, d: BreachDirection, speed: float) -> StickCommand:
        e0, n0, u0 = self._push_origin
        ue, un = self._push_unit_en
        far = 2.0 * self.config.push_m + 1000.0  # the line only needs a direction
        course, _, _ = self.nav.course_on_line(s, e0, n0, e0 + far * ue, n0 + far * un)
        if not d.is_vertical:  # along the bearing at the drawn airspeed, the home height held
            return self.nav.sticks(s, course, self.home[2], speed)
        climb_stick = climb_rate_to_stick(float(d.vertical) * speed, self.env)
        return self.nav.sticks(s, course, u0, self.env.cruise_speed_mps, climb_stick)

    # -- the per-step entry point ----------------------------------------------
    def command(self, s: VehicleState) -> StickCommand:
        t = s.t_s
        in_phase = t - self.phase_since_s
        if self.phase == self.JOIN:
            cmd, d_m = self._orbit(s)
            if self._on_orbit(s, d_m) or in_phase >= JOIN_MAX_S:
                return self._start_attempt(s)
            return cmd
        if self.phase == self.ALIGN:
            d = self.direction(self.attempt)
            assert d.bearing_rad is not None, "a vertical push starts at once"
            orbit_s = 2.0 * math.pi * self.orbit_radius_m / self.env.cruise_speed_mps
            if self._aligned(s, d.bearing_rad, at_once=False) or in_phase >= ALIGN_MAX_ORBITS * orbit_s:
                return self._start_push(s, d)
            return self._orbit(s)[0]
        if self.phase == self.PUSH:
            d = self.direction(self.attempt)
            speed = self.speed(self.attempt)
            why = self._push_end(s, d, speed, in_phase)
            if why is None:
                return self._push_sticks(s, d, speed)
            self.log_push_end(t, why)
            self._enter(self.RETURN, t)
            return self._orbit(s)[0]
        if self.phase == self.RETURN:
            cmd, d_m = self._orbit(s)
            if self._on_orbit(s, d_m) or in_phase >= RETURN_MAX_S:
                self.log_time("t_return_end_s", t)
                self._enter(self.REST, t)
            return cmd
        if self.phase == self.REST:
            if in_phase >= self.config.rest_s:
                if self.next_attempt(t):
                    return self._start_attempt(s)
                self._enter(self.DONE, t)
            return self._orbit(s)[0]
        return self._orbit(s)[0]  # DONE: orbit home
