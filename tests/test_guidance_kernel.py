"""The compiled fixed-wing recovery step (:data:`geofence.guidance.fixed_wing_step`) against its Python reference.

Two :class:`~geofence.guidance.FixedWingRecovery` start on the same route (planned twice: a route keeps its
progress) and are stepped side by side through random states, one with the compiled kernels
(:func:`geofence.jit.use_compiled` on), one on the plain-Python reference: every stick, the turn state and the
route's progress stay equal bit for bit, the states outside the fence (where the compiled follower does not
answer and the Python step does) and a hold below a floor included. The laws the step compiles are checked
one by one too, and a kernel off by one unit in the last place is caught.
"""

from __future__ import annotations

import math
import random
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support import FRAME, FW, random_fence

from geofence import guidance
from geofence.control_laws import air_heading_to_rad, cpython_hypot, orbit_course_rad
from geofence.guidance import FixedWingRecovery, fixed_wing_follow_roll, rolls_out
from geofence.interface import VehicleState
from geofence.jit import COMPILED, numba, use_compiled
from geofence.recovery import RecoveryPlanner

pytestmark = pytest.mark.skipif(not COMPILED, reason="numba absent: no compiled step to compare")

CLEARANCE_M = 20.0


def _bits(x: float) -> bytes:
    return struct.pack("<d", x)


def _snapshot(rec: FixedWingRecovery, cmd: tuple) -> tuple:
    """Everything a step sets, as bits (so -0.0 and 0.0, or two NaNs, are told apart or matched exactly)."""
    floats = (*cmd, rec.turned_rad, rec._last_yaw, rec.route.progress_m)  # type: ignore[attr-defined]
    return (tuple(_bits(float(v)) for v in floats), rec.turning, rec.hold_below_m, type(cmd).__name__)


def _random_state(rng: random.Random, e: float, n: float, spread_m: float) -> VehicleState:
    return VehicleState(
        east_m=e + rng.uniform(-spread_m, spread_m),
        north_m=n + rng.uniform(-spread_m, spread_m),
        v_east_mps=rng.choice([rng.uniform(-30.0, 30.0), rng.uniform(-0.4, 0.4)]),  # nearly stopped: the heading
        v_north_mps=rng.uniform(-30.0, 30.0),
        yaw_rad=rng.uniform(-math.pi, math.pi),
        airspeed_mps=rng.choice([rng.uniform(0.0, 35.0), 0.5]),
    )


def _fly_pair(seed: int, dense: bool, steps: int = 120, kernel=guidance.fixed_wing_step) -> tuple[int, int]:
    """Step a compiled and a Python recovery side by side; ``(steps the kernel answered, orbit-branch steps)``."""
    rng = random.Random(seed)
    fence = random_fence(seed, 300 if dense else rng.randrange(3, 9), rng.randrange(0, 2), rng.randrange(0, 2), dense=dense)
    lf = fence.to_local(FRAME)
    planner = RecoveryPlanner(lf, CLEARANCE_M)
    assert planner._follower_scans == (lf.grid() is None)
    ki = lf.keep_in.vertices
    a, b = ki[rng.randrange(len(ki))], ki[rng.randrange(len(ki))]
    start = (0.7 * a[0] + rng.uniform(-30, 30), 0.7 * a[1] + rng.uniform(-30, 30))
    goal = (0.3 * b[0], 0.3 * b[1]) if rng.random() < 0.7 else (start[0] + rng.uniform(-40, 40), start[1] + rng.uniform(-40, 40))
    paths = [planner.plan(start, goal), planner.plan(start, goal)]
    if paths[0] is None:
        return 0, 0
    assert paths[0].points == paths[1].points
    wind = [rng.uniform(-12.0, 12.0), rng.uniform(-12.0, 12.0)]
    calls = [0, 0]  # asked, answered (a positive chord threshold)

    def counted(*args):
        out = kernel(*args)
        calls[0] += 1
        calls[1] += out[0] > 0.0
        return out

    recs = [FixedWingRecovery(FW, wind, step=counted), FixedWingRecovery(FW, wind)]
    s0 = _random_state(rng, *start, 5.0)
    turn_sign = rng.choice([0, 1, -1])
    turn_limit = rng.choice([math.inf, rng.uniform(0.0, 2.0 * math.pi)])
    hold = rng.choice([None, None, 80.0])
    goal_h = rng.uniform(40.0, 120.0)

    def start(s0: VehicleState) -> None:
        for rec, path, compiled in zip(recs, paths, (True, False)):
            previous = use_compiled(compiled)
            try:
                rec.start(s0, path, goal_h, 60.0, 0.0, turn_sign, turn_limit, hold)
            finally:
                use_compiled(previous)

    start(s0)
    assert recs[0]._path is paths[0]
    orbit = 0
    route = paths[0].points
    for k in range(steps):
        p = route[min(len(route) - 1, k * len(route) // steps)]
        s = _random_state(rng, p[0], p[1], rng.choice([2.0, 60.0, 400.0]))  # on the route, near it, far outside
        h = rng.uniform(50.0, 110.0)
        if k % 15 == 14:  # a new override: the turn again
            start(s)
        wind[0] += rng.uniform(-0.5, 0.5)  # the unit updates the shared estimate between steps
        snaps = []
        for rec, compiled in zip(recs, (True, False)):
            previous = use_compiled(compiled)
            try:
                cmd = rec.sticks(s, h, 0.025 * k, 0.025)
            finally:
                use_compiled(previous)
            snaps.append(_snapshot(rec, cmd))
        assert snaps[0] == snaps[1], f"step {k}: compiled {snaps[0]} != Python {snaps[1]}"
        if not recs[1].turning and recs[1].hold_below_m is None:
            orbit += recs[1].route.remaining_m(s.east_m, s.north_m) <= 1.2 * recs[1].orbit_radius_m  # type: ignore[attr-defined]
    assert calls[0] > 0  # the compiled step was asked (the Python one answered only where it does not)
    return calls[1], orbit


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_compiled_step_equals_python_on_small_fences(seed: int) -> None:
    _fly_pair(seed, dense=False)


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_compiled_step_equals_python_on_indexed_fences(seed: int) -> None:
    """A fence with an index: the chord threshold is found in Python and handed to the kernel."""
    _fly_pair(seed, dense=True, steps=60)


def test_both_branches_are_flown() -> None:
    """Over a few seeds the kernel answers many steps, the orbit round the route's end among them."""
    answered = orbit = 0
    for seed in range(12):
        a, o = _fly_pair(seed, dense=False)
        answered += a
        orbit += o
    assert answered > 300 and orbit > 20


def test_a_kernel_one_ulp_off_is_caught() -> None:
    kernel = guidance.fixed_wing_step

    def off(*args):
        thr, roll, *rest = kernel(*args)
        return (thr, math.nextafter(roll, math.inf), *rest)

    with pytest.raises(AssertionError, match="compiled"):
        for seed in range(12):
            _fly_pair(seed, dense=False, kernel=off)


@settings(max_examples=300, deadline=None)
@given(
    st.tuples(*[st.floats(-500.0, 500.0)] * 4),
    st.floats(1.0, 200.0),
    st.floats(-40.0, 40.0),
    st.floats(-40.0, 40.0),
    st.floats(-math.pi, math.pi),
    st.floats(0.0, 40.0),
    st.floats(-15.0, 15.0),
    st.floats(-15.0, 15.0),
    st.floats(0.0, 400.0),
    st.sampled_from([1.0, -1.0]),
)
def test_laws_compiled_equal_python(en, radius, ve, vn, yaw, airspeed, we, wn, remaining, sign) -> None:
    """The jitable laws the step calls, compiled from the same source, give the interpreter's floats."""
    e, n, ce, cn = en
    s = VehicleState(east_m=e, north_m=n, v_east_mps=ve, v_north_mps=vn, yaw_rad=yaw, airspeed_mps=airspeed)
    st_ = guidance._StateFloats(e, n, ve, vn, yaw, airspeed)
    env = guidance._EnvelopeFloats(FW.max_bank_rad, FW.max_climb_rate_mps, FW.max_descent_rate_mps, FW.min_speed_mps)
    gs = s.ground_speed_mps
    assert _bits(_compiled["hypot"](e - ce, n - cn)) == _bits(math.hypot(e - ce, n - cn)) == _bits(cpython_hypot(e - ce, n - cn))
    assert _bits(_compiled["orbit"](e, n, ce, cn, radius, sign < 0)) == _bits(
        orbit_course_rad(e, n, ce, cn, radius, clockwise=sign < 0)[0]
    )
    assert _bits(_compiled["heading"](st_, ce, cn, we, wn, FW.min_speed_mps)) == _bits(
        air_heading_to_rad(s, ce, cn, we, wn, FW.min_speed_mps)
    )
    assert _compiled["rolls_out"](st_, ce, cn, we, wn, FW.min_speed_mps, remaining / 100.0, 2.0) == rolls_out(
        s, ce, cn, we, wn, FW.min_speed_mps, remaining / 100.0, 2.0
    )
    assert _bits(_compiled["roll"](st_, gs, ce, cn, remaining, ce, cn, radius, sign, env)) == _bits(
        fixed_wing_follow_roll(s, gs, ce, cn, remaining, ce, cn, radius, sign, FW)
    )


_compiled = (
    {
        "hypot": numba.njit(lambda x, y: cpython_hypot(x, y)),
        "orbit": numba.njit(lambda e, n, ce, cn, r, cw: orbit_course_rad(e, n, ce, cn, r, clockwise=cw)[0]),
        "heading": numba.njit(air_heading_to_rad),
        "rolls_out": numba.njit(rolls_out),
        "roll": numba.njit(fixed_wing_follow_roll),
    }
    if COMPILED
    else {}
)
