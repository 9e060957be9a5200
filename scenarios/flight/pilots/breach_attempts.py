"""The breach-attempts pilot: pushes gently across the fence again and again (the seed flights' indoor pilot).

The seed work's pilot hovered a small quadrotor near the launch point and
pushed it slowly across the fence line, many times, along x, along y and up
toward the ceiling. This pilot does the same, reproducibly:

1. **climb** to ``home_agl_m`` above the start point (from the ground or an
   air start) and **settle** there;
2. per attempt ``k``: fly toward ``directions[k % len]`` at a speed drawn
   uniformly from ``speed_mps`` (numpy ``default_rng(seed)``, all speeds drawn
   up front, so the schedule does not depend on the flight): a compass
   direction is flown at that ground speed with the height held, ``up`` climbs
   at that rate (capped at the envelope's climb rate) with the position held;
3. the **push** ends after ``push_m`` of travel from where it began, when the
   aircraft is clearly being pulled back against the push (the pilot feels
   the geofence take over and lets go), or after ``push_m / speed + 3 s``;
4. **return** to the home hover, **rest** ``rest_s``, next attempt.

It sees only the vehicle state (never the geofence mode) and flies with the
mission autopilot's :class:`~scenarios.flight.pilots.nav_laws.MultirotorNavigator`.
``attempt_log`` holds, per attempt, its index, direction, drawn speed and the
start/end times of its phases (s, flight time) for the analysis
(:mod:`scenarios.app.seed_reproduction`).
"""

from __future__ import annotations

import math

import numpy as np

from geofence.interface import Envelope, StickCommand, VehicleState
from scenarios.flight.pilots.nav_laws import MultirotorNavigator
from scenarios.spec.schema import BreachAttemptsConfig, SpeedDraw

DIRECTION_UNIT = {"north": (0.0, 1.0), "east": (1.0, 0.0), "south": (0.0, -1.0), "west": (-1.0, 0.0)}

HOME_TOLERANCE_M = 0.10
"""Within this distance (horizontal and vertical) of home, and ..."""
HOME_SPEED_TOLERANCE_MPS = 0.12
"""... slower than this, the aircraft counts as back in the home hover."""
SETTLE_MIN_S = 1.0
SETTLE_MAX_S = 6.0
RETURN_SPEED_MPS = 0.4
RETURN_MAX_S = 15.0
PUSH_SLACK_S = 3.0
PULLED_BACK_MPS = 0.03
"""The pilot lets go once the aircraft moves against the push faster than this (after having moved with it)."""


def draw_speeds(config: BreachAttemptsConfig) -> np.ndarray:
    """The per-attempt approach speeds (m/s): uniform in ``speed_mps``, from ``default_rng(seed)``.

    ``speed_draw: per_round`` draws one speed per round of ``directions`` and gives it to every
    attempt of that round.
    """
    lo, hi = config.speed_mps
    rng = np.random.default_rng(config.seed)
    if config.speed_draw is SpeedDraw.PER_ROUND:
        k = len(config.directions)
        rounds = -(-config.attempts // k)
        return np.repeat(rng.uniform(lo, hi, rounds), k)[: config.attempts]
    return rng.uniform(lo, hi, config.attempts)


class BreachAttemptsPilot:
    CLIMB, SETTLE, PUSH, RETURN, REST, DONE = "climb", "settle", "push", "return", "rest", "done"

    def __init__(self, config: BreachAttemptsConfig, env: Envelope, start: VehicleState, dt_s: float):
        if not env.is_multirotor:
            raise ValueError("the breach_attempts pilot flies multirotors only")
        self.config = config
        self.env = env
        self.dt_s = dt_s
        self.nav = MultirotorNavigator(env)
        self.home = (start.east_m, start.north_m, start.up_m + (config.home_agl_m - start.agl_m))
        self.yaw_hold = start.yaw_rad
        self.speeds = draw_speeds(config)
        self.attempt_log: list[dict] = []
        self.phase = self.CLIMB
        self.phase_since_s = start.t_s
        self.attempt = 0
        self.finished = False
        self._push_origin = (0.0, 0.0, 0.0)
        self._moved_with_push = False

    # -- progress --------------------------------------------------------------
    @property
    def items_total(self) -> int:
        return self.config.attempts

    @property
    def items_reached(self) -> int:
        return self.attempt

    def direction(self, k: int) -> str:
        return self.config.directions[k % len(self.config.directions)]

    def speed(self, k: int) -> float:
        """The approach speed of attempt ``k`` (m/s; a climb is capped at the envelope's climb rate)."""
        v = float(self.speeds[k])
        return min(v, self.env.max_climb_rate_mps) if self.direction(k) == "up" else v

    # -- helpers ---------------------------------------------------------------
    def _enter(self, phase: str, t_s: float) -> None:
        self.phase = phase
        self.phase_since_s = t_s
        self.nav.velocity.reset()

    def _at_home(self, s: VehicleState) -> bool:
        he, hn, hu = self.home
        return (
            math.hypot(s.east_m - he, s.north_m - hn) < HOME_TOLERANCE_M
            and abs(s.up_m - hu) < HOME_TOLERANCE_M
            and math.sqrt(s.v_east_mps**2 + s.v_north_mps**2 + s.v_up_mps**2) < HOME_SPEED_TOLERANCE_MPS
        )

    def _hold_home(self, s: VehicleState, speed_mps: float = RETURN_SPEED_MPS) -> StickCommand:
        he, hn, hu = self.home
        return self.nav.sticks_to_point(s, he, hn, hu, speed_mps, self.yaw_hold, self.dt_s)

    def _start_push(self, s: VehicleState) -> None:
        k = self.attempt
        self._push_origin = (s.east_m, s.north_m, s.up_m)
        self._moved_with_push = False
        self.attempt_log.append(
            {"attempt": k, "direction": self.direction(k), "speed_mps": round(self.speed(k), 4), "t_start_s": round(s.t_s, 3)}
        )
        self._enter(self.PUSH, s.t_s)

    def _push_progress(self, s: VehicleState) -> tuple[float, float]:
        """(travel along the push from where it began m, velocity along the push m/s)."""
        d = self.direction(self.attempt)
        e0, n0, u0 = self._push_origin
        if d == "up":
            return s.up_m - u0, s.v_up_mps
        ue, un = DIRECTION_UNIT[d]
        return (s.east_m - e0) * ue + (s.north_m - n0) * un, s.v_east_mps * ue + s.v_north_mps * un

    # -- the per-step entry point ----------------------------------------------
    def notice_control(self, in_control: bool) -> None:
        """Ignored: this pilot judges only from the vehicle's state (see the module docstring)."""

    def command(self, s: VehicleState) -> StickCommand:
        t = s.t_s
        in_phase = t - self.phase_since_s
        if self.phase == self.CLIMB:
            if abs(s.up_m - self.home[2]) < HOME_TOLERANCE_M:
                self._enter(self.SETTLE, t)
            return self._hold_home(s)
        if self.phase == self.SETTLE:
            if (in_phase >= SETTLE_MIN_S and self._at_home(s)) or in_phase >= SETTLE_MAX_S:
                self._start_push(s)
                return self.command(s)
            return self._hold_home(s)
        if self.phase == self.PUSH:
            k = self.attempt
            speed = self.speed(k)
            travel, v_along = self._push_progress(s)
            if v_along > 0.5 * speed:
                self._moved_with_push = True
            pulled_back = self._moved_with_push and v_along < -PULLED_BACK_MPS
            if travel >= self.config.push_m or pulled_back or in_phase >= self.config.push_m / speed + PUSH_SLACK_S:
                self.attempt_log[-1]["t_push_end_s"] = round(t, 3)
                self.attempt_log[-1]["push_end"] = (
                    "travel" if travel >= self.config.push_m else ("pulled back" if pulled_back else "timeout")
                )
                self._enter(self.RETURN, t)
                return self._hold_home(s)
            return self._push_sticks(s, k, speed)
        if self.phase == self.RETURN:
            if self._at_home(s) or in_phase >= RETURN_MAX_S:
                self.attempt_log[-1]["t_return_end_s"] = round(t, 3)
                self._enter(self.REST, t)
            return self._hold_home(s)
        if self.phase == self.REST:
            if in_phase >= self.config.rest_s:
                self.attempt_log[-1]["t_end_s"] = round(t, 3)
                self.attempt += 1
                if self.attempt >= self.config.attempts:
                    self.finished = True
                    self._enter(self.DONE, t)
                else:
                    self._start_push(s)
                    return self.command(s)
            return self._hold_home(s)
        return self._hold_home(s)  # DONE: hover at home

    def _push_sticks(self, s: VehicleState, k: int, speed: float) -> StickCommand:
        he, hn, hu = self.home
        d = self.direction(k)
        nav = self.nav
        if d == "up":  # climb at the drawn rate, horizontal position held
            ve, vn = nav.velocity_toward(s, he, hn, RETURN_SPEED_MPS)
            return nav.sticks_for_velocity(s, ve, vn, speed, self.yaw_hold, self.dt_s)
        ue, un = DIRECTION_UNIT[d]
        # ground speed along the push; the cross-track offset from home is held
        cross = (s.east_m - he) * un - (s.north_m - hn) * ue  # + right of the push line
        kc = nav.kp
        ve = speed * ue - kc * cross * un
        vn = speed * un + kc * cross * ue
        vz = max(-self.env.max_descent_rate_mps, min(self.env.max_climb_rate_mps, nav.kh * (hu - s.up_m)))
        return nav.sticks_for_velocity(s, ve, vn, vz, self.yaw_hold, self.dt_s)
