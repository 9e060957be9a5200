"""The breach-attempts pilot of a multirotor (the seed flights' indoor pilot), and what both platforms' pilots share.

This module owns the attempt schedule and log every breach-attempts pilot keeps
(:func:`draw_speeds`, :class:`BreachAttemptsSchedule`) and the multirotor's
pilot (:class:`BreachAttemptsPilot`); the fixed-wing's is
:class:`~scenarios.flight.pilots.breach_attempts_fixedwing.FixedWingBreachAttemptsPilot`.

The seed work's pilot hovered a small quadrotor near the launch point and
pushed it slowly across the fence line, many times, along x, along y and up
toward the ceiling. This pilot does the same, reproducibly:

1. **climb** to ``home_agl_m`` above the start point (from the ground or an
   air start) and **settle** there;
2. per attempt ``k``: fly toward ``directions[k % len]`` at a speed drawn
   uniformly from ``speed_mps`` (numpy ``default_rng(seed)``, all speeds drawn
   up front, so the schedule does not depend on the flight): a compass
   direction or a bearing (a :class:`~scenarios.definition.schema.BreachDirection`)
   is flown at that ground speed with the height held, ``up`` climbs at that
   rate (capped at the envelope's climb rate) and ``down`` descends at it
   (capped at the descent rate) with the position held;
3. the **push** ends after ``push_m`` of travel from where it began, when the
   aircraft is clearly being pulled back against the push (the pilot feels
   the geofence take over and lets go), after ``push_m / speed + 3 s``, or
   (``down``) at :data:`GROUND_CLEARANCE_M` above the ground;
4. **return** to the home hover, **rest** ``rest_s``, next attempt.

It sees only the vehicle state (never the geofence mode) and flies with the
mission autopilot's :class:`~scenarios.flight.pilots.nav_laws.MultirotorNavigator`.
``attempt_log`` holds, per attempt, its index, direction (its readable label),
speed and the start/end times of its phases (s, flight time) for the analysis
(:mod:`scenarios.app.seed_reproduction`): ``attempt``, ``direction``,
``speed_mps``, ``t_start_s``, ``t_push_end_s``, ``push_end`` (why the push
ended: :class:`PushEnd`), ``t_return_end_s``, ``t_end_s``.
"""

from __future__ import annotations

import math
from enum import StrEnum
from typing import Any

import numpy as np

from geofence.interface import Envelope, StickCommand, VehicleState
from scenarios.definition.schema import BreachAttemptsConfig, BreachDirection, SpeedDraw, VerticalSense
from scenarios.flight.pilots.nav_laws import MultirotorNavigator

HOME_TOLERANCE_M = 0.10
"""Within this distance (horizontal and vertical) of home, and ..."""
HOME_SPEED_TOLERANCE_MPS = 0.12
"""... slower than this, the aircraft counts as back in the home hover."""
SETTLE_MIN_S = 1.0
SETTLE_MAX_S = 6.0
RETURN_SPEED_MPS = 0.4
"""The slowest return home (m/s; the seed flights' indoor pilot); faster pilots return at their slowest push speed."""
RETURN_MAX_S = 15.0
"""The shortest time allowed for the return home (s); a longer push gets the time to fly it back, twice over."""
PUSH_SLACK_S = 3.0
PULLED_BACK_MPS = 0.03
"""The pilot lets go once the aircraft moves against the push faster than this (after having moved with it)."""
GROUND_CLEARANCE_M = 0.2
"""A ``down`` push ends this high above the ground (the pilot does not fly into it)."""


class PushEnd(StrEnum):
    """Why a push ended (the attempt log's ``push_end``)."""

    TRAVEL = "travel"
    """``push_m`` of travel along the push."""
    PULLED_BACK = "pulled back"
    """The aircraft moved against the push after having moved with it: the geofence took over."""
    TURNED_AWAY = "turned away"
    """(fixed-wing) The course turned more than 60 deg off the push after having flown along it."""
    GROUND = "ground"
    """(``down``) The ground clearance was reached."""
    TIMEOUT = "timeout"
    """``push_m / speed`` plus a slack elapsed."""


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


def push_progress(
    d: BreachDirection, origin_enu: tuple[float, float, float], s: VehicleState, unit_en: tuple[float, float] | None = None
) -> tuple[float, float]:
    """(travel along the push from ``origin_enu`` m, velocity along the push m/s).

    A vertical push counts height (+ in its sense); a horizontal one the distance along ``unit_en``
    (default: the direction's bearing).
    """
    e0, n0, u0 = origin_enu
    if d.is_vertical:
        sense = float(d.vertical)
        return sense * (s.up_m - u0), sense * s.v_up_mps
    ue, un = d.unit_en if unit_en is None else unit_en
    return (s.east_m - e0) * ue + (s.north_m - n0) * un, s.v_east_mps * ue + s.v_north_mps * un


class BreachAttemptsSchedule:
    """What every breach-attempts pilot shares: the drawn speeds, the attempt counter, progress and the log.

    A pilot subclasses it and calls :meth:`log_start`, :meth:`log_push_end` and :meth:`log_time`
    as its phases pass, and :meth:`next_attempt` after each rest.
    """

    def __init__(self, config: BreachAttemptsConfig, env: Envelope):
        self.config = config
        self.env = env
        self.speeds = draw_speeds(config)
        self.attempt_log: list[dict[str, Any]] = []
        self.attempt = 0
        self.finished = False

    # -- progress --------------------------------------------------------------
    @property
    def items_total(self) -> int:
        return self.config.attempts

    @property
    def items_reached(self) -> int:
        return self.attempt

    def notice_control(self, in_control: bool) -> None:
        """Ignored: a breach-attempts pilot judges only from the vehicle's state (never the geofence's mode)."""

    def direction(self, k: int) -> BreachDirection:
        return self.config.direction(k)

    def vertical_rate(self, k: int) -> float:
        """The drawn speed of attempt ``k`` as a climb (descent) rate, capped at the envelope's climb (descent) rate."""
        v = float(self.speeds[k])
        cap = self.env.max_climb_rate_mps if self.direction(k).vertical is VerticalSense.UP else self.env.max_descent_rate_mps
        return min(v, cap)

    # -- the log ---------------------------------------------------------------
    def log_start(self, k: int, speed_mps: float, t_s: float) -> None:
        self.attempt_log.append(
            {"attempt": k, "direction": str(self.direction(k)), "speed_mps": round(speed_mps, 4), "t_start_s": round(t_s, 3)}
        )

    def log_time(self, key: str, t_s: float) -> None:
        self.attempt_log[-1][key] = round(t_s, 3)

    def log_push_end(self, t_s: float, why: PushEnd) -> None:
        self.log_time("t_push_end_s", t_s)
        self.attempt_log[-1]["push_end"] = str(why)

    def next_attempt(self, t_s: float) -> bool:
        """Close the current attempt's log entry and count it; True while attempts remain."""
        self.log_time("t_end_s", t_s)
        self.attempt += 1
        if self.attempt >= self.config.attempts:
            self.finished = True
        return not self.finished


class BreachAttemptsPilot(BreachAttemptsSchedule):
    """The multirotor's breach attempts from a hover over the start point (see the module docstring)."""

    CLIMB, SETTLE, PUSH, RETURN, REST, DONE = "climb", "settle", "push", "return", "rest", "done"

    def __init__(self, config: BreachAttemptsConfig, env: Envelope, start: VehicleState, dt_s: float):
        if not env.is_multirotor:
            raise ValueError("BreachAttemptsPilot flies multirotors (a fixed-wing: FixedWingBreachAttemptsPilot)")
        super().__init__(config, env)
        self.dt_s = dt_s
        self.nav = MultirotorNavigator(env)
        self.home = (start.east_m, start.north_m, start.up_m + (config.home_agl_m - start.agl_m))
        self.yaw_hold = start.yaw_rad
        self.phase = self.CLIMB
        self.phase_since_s = start.t_s
        self._push_origin = (0.0, 0.0, 0.0)
        self._moved_with_push = False
        self.return_speed_mps = max(RETURN_SPEED_MPS, config.speed_mps[0])
        """Home is flown back to at the slowest push speed (at least :data:`RETURN_SPEED_MPS`)."""
        self.return_max_s = max(RETURN_MAX_S, 2.0 * config.push_m / self.return_speed_mps + 5.0)

    def speed(self, k: int) -> float:
        """The approach speed of attempt ``k`` (m/s; a climb or descent is capped at the envelope's rate)."""
        return self.vertical_rate(k) if self.direction(k).is_vertical else float(self.speeds[k])

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

    def _hold_home(self, s: VehicleState) -> StickCommand:
        he, hn, hu = self.home
        return self.nav.sticks_to_point(s, he, hn, hu, self.return_speed_mps, self.yaw_hold, self.dt_s)

    def _start_push(self, s: VehicleState) -> None:
        k = self.attempt
        self._push_origin = (s.east_m, s.north_m, s.up_m)
        self._moved_with_push = False
        self.log_start(k, self.speed(k), s.t_s)
        self._enter(self.PUSH, s.t_s)

    # -- the per-step entry point ----------------------------------------------
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
            d = self.direction(k)
            speed = self.speed(k)
            travel, v_along = push_progress(d, self._push_origin, s)
            if v_along > 0.5 * speed:
                self._moved_with_push = True
            why = None
            if travel >= self.config.push_m:
                why = PushEnd.TRAVEL
            elif self._moved_with_push and v_along < -PULLED_BACK_MPS:
                why = PushEnd.PULLED_BACK
            elif d.vertical is VerticalSense.DOWN and s.agl_m <= GROUND_CLEARANCE_M:
                why = PushEnd.GROUND
            elif in_phase >= self.config.push_m / speed + PUSH_SLACK_S:
                why = PushEnd.TIMEOUT
            if why is not None:
                self.log_push_end(t, why)
                self._enter(self.RETURN, t)
                return self._hold_home(s)
            return self._push_sticks(s, d, speed)
        if self.phase == self.RETURN:
            if self._at_home(s) or in_phase >= self.return_max_s:
                self.log_time("t_return_end_s", t)
                self._enter(self.REST, t)
            return self._hold_home(s)
        if self.phase == self.REST:
            if in_phase >= self.config.rest_s:
                if self.next_attempt(t):
                    self._start_push(s)
                    return self.command(s)
                self._enter(self.DONE, t)
            return self._hold_home(s)
        return self._hold_home(s)  # DONE: hover at home

    def _push_sticks(self, s: VehicleState, d: BreachDirection, speed: float) -> StickCommand:
        he, hn, hu = self.home
        nav = self.nav
        if d.is_vertical:  # climb or descend at the drawn rate, horizontal position held
            ve, vn = nav.velocity_toward(s, he, hn, RETURN_SPEED_MPS)
            return nav.sticks_for_velocity(s, ve, vn, float(d.vertical) * speed, self.yaw_hold, self.dt_s)
        ue, un = d.unit_en
        # ground speed along the push; the cross-track offset from home is held
        cross = (s.east_m - he) * un - (s.north_m - hn) * ue  # + right of the push line
        kc = nav.kp
        ve = speed * ue - kc * cross * un
        vn = speed * un + kc * cross * ue
        vz = max(-self.env.max_descent_rate_mps, min(self.env.max_climb_rate_mps, nav.kh * (hu - s.up_m)))
        return nav.sticks_for_velocity(s, ve, vn, vz, self.yaw_hold, self.dt_s)
