"""The fixed-wing recovery's step (:func:`geofence.recovery.guidance.fixed_wing_step_on`) against oracles of its manoeuvre.

A point mass flies the sticks of :class:`~geofence.recovery.guidance.FixedWingRecovery` at cruise (roll stick 1 = the bank
limit, turn rate ``g·tan(bank)/V``): its first turn reverses the course inside the room of the turn-radius
formula, at the bank limit, and rolls out where the air heading points at the roll-out point; after it, the
vehicle settles on the orbit round the route's end that the vector field and the proportional course loop
solve for. Flown on a planned route (the compiled step on its arrays), on a straight route and from outside the
fence (the same step interpreted on the route's own methods). One conformance test holds the compiled entry
point :data:`~geofence.recovery.guidance.fixed_wing_step` to its source interpreted.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support import FRAME, FW, G, close_fields, latlon

from geofence.geometry.fence import Fence
from geofence.interface import VehicleState
from geofence.jit import COMPILED
from geofence.physics.control_laws import wrap_pi
from geofence.physics.rooms import turn_radius_m
from geofence.recovery import RecoveryPlanner, guidance
from geofence.recovery.guidance import COURSE_GAIN_PER_S, ROLL_OUT_TOLERANCE_RAD, FixedWingRecovery, Route, StraightRoute

DT_S = 0.025
V_MPS = FW.cruise_speed_mps
R_M = turn_radius_m(V_MPS, FW.max_bank_rad)
STEP_M = V_MPS * DT_S
HALF_SIDE_M = 1500.0
CLEARANCE_M = 20.0


class Sample(NamedTuple):
    e: float
    n: float
    yaw: float
    roll: float
    turning: bool
    rollout_e: float  # the route's roll-out point before the step
    rollout_n: float


def _square_planner() -> RecoveryPlanner:
    side = HALF_SIDE_M
    square = [(-side, -side), (side, -side), (side, side), (-side, side)]
    fence = Fence(keep_in=tuple(latlon(e, n) for e, n in square), ceiling_m=120.0)
    return RecoveryPlanner(fence.to_local(FRAME), CLEARANCE_M)


def _state(e: float, n: float, yaw: float, wind: tuple[float, float]) -> VehicleState:
    return VehicleState(
        east_m=e, north_m=n, v_east_mps=V_MPS * math.sin(yaw) + wind[0], v_north_mps=V_MPS * math.cos(yaw) + wind[1],
        yaw_rad=yaw, airspeed_mps=V_MPS,
    )  # fmt: skip


def _fly(
    route: Route, e: float, n: float, yaw: float, seconds: float, wind: tuple[float, float] = (0.0, 0.0), **start
) -> list[Sample]:
    """The recovery's sticks flown by a point mass at cruise in a steady wind, its bank the roll stick's."""
    rec = FixedWingRecovery(FW, list(wind))
    rec.start(_state(e, n, yaw, wind), route, 60.0, 60.0, 0.0, **start)
    out = []
    for k in range(round(seconds / DT_S)):
        s = _state(e, n, yaw, wind)
        re, rn = route.rollout_point(e, n, rec.lookahead_m)
        cmd = rec.sticks(s, 60.0, k * DT_S, DT_S)
        out.append(Sample(e, n, yaw, cmd.roll, rec.turning, re, rn))
        yaw += G * math.tan(cmd.roll * FW.max_bank_rad) / V_MPS * DT_S
        e += s.v_east_mps * DT_S
        n += s.v_north_mps * DT_S
    return out


def _routes() -> dict[str, Route]:
    planned = _square_planner().plan((0.0, 0.0), (0.0, -900.0))
    assert planned is not None and len(planned.points) == 2
    return {"planned": planned, "straight": StraightRoute(0.0, -900.0)}


def _rollout_turn_rad(kind: str, turn_sign: int) -> float:
    """The first heading change at which a circle of radius R, flown from (0, 0) heading north, has the heading
    within :data:`ROLL_OUT_TOLERANCE_RAD` of the bearing to the roll-out point: on the route due south, the
    projection plus 1.5 R (the orbit radius the recovery looks ahead); on a straight route, its end."""
    theta = 0.0
    while theta < 2.0 * math.pi:
        pe, pn = -turn_sign * R_M * (1.0 - math.cos(theta)), R_M * math.sin(theta)
        te, tn = (0.0, -(max(0.0, -pn) + 1.5 * R_M)) if kind == "planned" else (0.0, -900.0)
        if abs(wrap_pi(math.atan2(te - pe, tn - pn) + turn_sign * theta)) < ROLL_OUT_TOLERANCE_RAD:
            return theta
        theta += 1e-5
    raise AssertionError("no roll-out")


@pytest.mark.parametrize("kind", ["planned", "straight"])
@pytest.mark.parametrize("turn_sign", [1, -1])
def test_the_turn_reverses_the_course_within_the_turn_radius_room(kind: str, turn_sign: int) -> None:
    """Heading north with the route behind: a circle of radius ``V²/(g·tan φ_max)`` at the bank limit (forward room
    R, lateral 2R, to one step's flight) through the heading change the circle's geometry gives for the roll-out
    (to two steps' turn); on the planned route, then back over the start's track, due south."""
    flight = _fly(_routes()[kind], 0.0, 0.0, 0.0, 40.0, turn_sign=turn_sign)
    turn = [p for p in flight if p.turning]
    assert all(p.roll == -turn_sign for p in turn)  # the bank limit, +1 left = negative roll stick
    assert max(p.n for p in turn) <= R_M + STEP_M
    side = [-turn_sign * p.e for p in turn]  # toward the turn (a left turn goes west)
    assert min(side) >= -STEP_M and max(side) <= 2.0 * R_M + STEP_M
    rate_step_rad = G * math.tan(FW.max_bank_rad) / V_MPS * DT_S
    assert abs(len(turn) * rate_step_rad - _rollout_turn_rad(kind, turn_sign)) < 2.0 * rate_step_rad
    if kind == "planned":
        later = flight[round(25.0 / DT_S) :]
        assert all(abs(p.e) < 0.1 and abs(wrap_pi(p.yaw - math.pi)) < math.radians(0.5) for p in later)


@settings(max_examples=25, deadline=None)
@given(
    yaw=st.floats(-math.pi, math.pi),
    goal_bearing=st.floats(-math.pi, math.pi),
    wind_mps=st.floats(0.0, 0.6 * FW.min_speed_mps),
    wind_dir=st.floats(-math.pi, math.pi),
)
def test_roll_out_is_at_the_wind_corrected_heading_of_the_roll_out_point(yaw, goal_bearing, wind_mps, wind_dir) -> None:
    """The turn ends the first step the air heading is within :data:`ROLL_OUT_TOLERANCE_RAD` of the heading whose
    ground track (wind triangle at cruise) points at the roll-out point; the roll stick never passes the limit."""
    wind = (wind_mps * math.sin(wind_dir), wind_mps * math.cos(wind_dir))
    route = StraightRoute(700.0 * math.sin(goal_bearing), 700.0 * math.cos(goal_bearing))
    flight = _fly(route, 0.0, 0.0, yaw, 30.0, wind)

    def heading_error(p: Sample) -> float:
        course = math.atan2(p.rollout_e - p.e, p.rollout_n - p.n)
        cross = wind[0] * math.cos(course) - wind[1] * math.sin(course)
        return abs(wrap_pi(course - math.asin(cross / V_MPS) - p.yaw))

    assert all(abs(p.roll) <= 1.0 for p in flight)
    k = next(i for i, p in enumerate(flight) if not p.turning)
    assert heading_error(flight[k]) < ROLL_OUT_TOLERANCE_RAD
    assert all(heading_error(p) >= ROLL_OUT_TOLERANCE_RAD for p in flight[:k])


def test_the_turn_ends_at_its_scored_limit() -> None:
    """A turn limit shorter than the reversal: the turn is committed to it (and the tolerance), no further."""
    limit = 0.5 * math.pi
    flight = _fly(_routes()["planned"], 0.0, 0.0, 0.0, 10.0, turn_sign=1, turn_limit_rad=limit)
    turn = [p for p in flight if p.turning]
    turned = G * math.tan(FW.max_bank_rad) / V_MPS * DT_S * len(turn)
    assert limit + ROLL_OUT_TOLERANCE_RAD - 0.02 <= turned <= limit + ROLL_OUT_TOLERANCE_RAD + 0.02


def _steady_orbit_radius_m(r: float) -> float:
    """The orbit radius ``d`` the point mass settles on: the course rate ``V/d`` a circle needs is the course loop's
    ``k·error``, and the vector field (Beard & McLain, gain 2) commands the tangent plus ``atan(2(d - r)/r)``
    toward the turn: so ``d > r``, where the two meet (by bisection)."""
    lo, hi = r, 3.0 * r
    for _ in range(100):
        d = 0.5 * (lo + hi)
        if math.atan(2.0 * (d - r) / r) < V_MPS / (COURSE_GAIN_PER_S * d):
            lo = d
        else:
            hi = d
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("turn_sign", [1, -1])
def test_at_the_route_end_it_settles_on_the_orbit(turn_sign: int) -> None:
    """Near the route's end it circles the end (counter-clockwise after a left turn) at the radius the orbit law
    solves for, to 1 %."""
    route = _square_planner().plan((0.0, 0.0), (0.0, -250.0))
    assert route is not None
    flight = _fly(route, 0.0, 0.0, 0.0, 150.0, turn_sign=turn_sign)
    last = flight[-round(40.0 / DT_S) :]
    ge, gn = route.points[-1]
    radii = [math.hypot(p.e - ge, p.n - gn) for p in last]
    want = _steady_orbit_radius_m(FixedWingRecovery(FW, [0.0, 0.0]).orbit_radius_m)
    assert max(abs(d - want) for d in radii) < 0.01 * want
    rate = [wrap_pi(b.yaw - a.yaw) for a, b in zip(last, last[1:])]
    assert all(-turn_sign * w > 0.0 for w in rate)  # +1 left: counter-clockwise, the heading decreasing


def test_from_outside_the_fence_it_turns_back_in() -> None:
    """A breached vehicle (its chords certified by the route's own methods): the same turn, then back inside."""
    planner = _square_planner()
    start = (0.0, HALF_SIDE_M + 50.0)
    route = planner.plan(start, (0.0, 0.0))
    assert route is not None
    flight = _fly(route, *start, 0.0, 40.0)
    turn = [p for p in flight if p.turning]
    assert turn and all(abs(p.roll) == 1.0 for p in turn)
    assert max(p.n for p in turn) <= start[1] + R_M + STEP_M
    assert flight[-1].n < HALF_SIDE_M - CLEARANCE_M


@pytest.mark.skipif(not COMPILED, reason="numba absent: the step is its source interpreted")
@settings(max_examples=200, deadline=None)
@given(
    e=st.floats(-1400.0, 1400.0),
    n=st.floats(-1400.0, 1400.0),
    v=st.tuples(st.floats(-30.0, 30.0), st.floats(-30.0, 30.0)),
    yaw=st.floats(-math.pi, math.pi),
    airspeed=st.floats(0.0, 30.0),
    wind=st.tuples(st.floats(-12.0, 12.0), st.floats(-12.0, 12.0)),
    turning=st.booleans(),
    turned=st.floats(0.0, 7.0),
    progress=st.floats(0.0, 1.0),
)
def test_compiled_step_conforms_to_its_interpreted_source(e, n, v, yaw, airspeed, wind, turning, turned, progress):
    """:data:`~geofence.recovery.guidance.fixed_wing_step` against its ``py_func`` (the same source, interpreted), on a
    planned route's arrays: every field within 1e-9 relative."""
    route = _square_planner().plan((-600.0, 400.0), (500.0, -300.0))
    assert route is not None
    rec = FixedWingRecovery(FW, [wind[0], wind[1]])
    rec.start(_state(-600.0, 400.0, 1.0, wind), route, 60.0, 60.0, 0.0, turn_sign=1, turn_limit_rad=3.0)
    arrays = rec.compiled_step()
    assert arrays is not None
    R, P, Q, K, thr, clearance = arrays
    args = (R, P, Q, K, progress * route.length_m, thr, clearance, e, n, *v, yaw, airspeed, math.hypot(*v), 60.0,
            *wind, turning, turned, yaw - 0.1)  # fmt: skip
    got, want = guidance.fixed_wing_step(*args), guidance.fixed_wing_step.py_func(*args)  # type: ignore[attr-defined]
    assert got[4] == want[4]  # turning
    assert close_fields(got, want, rel=1e-9), (got, want)
