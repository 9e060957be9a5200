"""Activation-boundary math: closed forms, a numerical trochoid check, and the state function."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence.geometry.fence import FenceError, parse_fence
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import Envelope, PlatformKind, VehicleState
from geofence.margins.boundary_shift import (
    activation_margins,
    activation_margins_for_state,
    check_shift_feasible,
    uncertainty_margin_m,
)
from geofence.physics.dynamics import G_MPS2, drag_coefficients, wind_push_mps2
from geofence.physics.rooms import (
    climb_back_drift_m,
    course_reversal_time_s,
    fixed_wing_room_from_velocity_m,
    fixed_wing_room_m,
    gap_circle_turn_rad,
    multicopter_stopping_distance_m,
    turn_constants,
    turn_excursion_m,
    turn_radius_m,
    turn_rate_radps,
    vertical_arrest_distance_m,
    worst_case_lateral_shift_m,
)

BANK = math.radians(35.0)
FW = Envelope(
    PlatformKind.FIXED_WING,
    cruise_speed_mps=18.0,
    max_speed_mps=25.0,
    min_speed_mps=12.0,
    max_bank_rad=BANK,
    max_pitch_rad=0.3,
    max_yaw_rate_radps=1.0,
    max_climb_rate_mps=3.0,
    max_descent_rate_mps=3.0,
    braking_decel_mps2=2.0,
    vertical_accel_mps2=3.0,
    reaction_time_s=0.2,
)
MC = Envelope(
    PlatformKind.MULTIROTOR,
    cruise_speed_mps=5.0,
    max_speed_mps=12.0,
    min_speed_mps=0.0,
    max_bank_rad=math.radians(30.0),
    max_pitch_rad=0.5,
    max_yaw_rate_radps=1.0,
    max_climb_rate_mps=3.0,
    max_descent_rate_mps=2.0,
    braking_decel_mps2=5.0,
    vertical_accel_mps2=4.0,
    reaction_time_s=0.1,
)


def square_fence(half_m: float, lat0: float = 47.4, lon0: float = 8.5, **kw):
    """A square keep-in of +-half_m about (lat0, lon0), projected in a frame there."""
    fr = LocalFrame(lat0, lon0, 0.0)
    ll = [fr.to_geodetic(x, y, 0.0)[:2] for x, y in ((-half_m, -half_m), (half_m, -half_m), (half_m, half_m), (-half_m, half_m))]
    m = {"keep_in": [list(p) for p in ll], "ceiling_m": 120.0, "floor_m": 10.0}
    m.update(kw)
    return parse_fence(m, "test").to_local(fr)


# ------------------------------------------------------------------ fixed-wing closed forms
def test_turn_basics():
    v = 20.0
    r = turn_radius_m(v, BANK)
    assert r == pytest.approx(v * v / (G_MPS2 * math.tan(BANK)))
    assert turn_rate_radps(v, BANK) == pytest.approx(v / r)
    assert course_reversal_time_s(v, BANK) == pytest.approx(math.pi * r / v)


def test_head_on_calm_needs_one_radius_along_the_normal():
    v = 20.0
    r = turn_radius_m(v, BANK)
    # the extreme point of a 180 deg turn entered perpendicular to the edge is R ahead
    assert turn_excursion_m(v, BANK, 0.0, 0.0) == pytest.approx(r)
    assert turn_excursion_m(v, BANK, 0.0, 0.0, turn_sign=1, turn_angle_rad=math.pi) == pytest.approx(r)
    assert fixed_wing_room_m(v, BANK, 0.0, 0.0, 0.5) == pytest.approx(r + v * 0.5)
    # parallel approach in calm air needs nothing...
    assert turn_excursion_m(v, BANK, math.pi / 2, 0.0) == 0.0
    # ...unless it reverses by turning towards the edge: then the sideways 2R lands on the normal
    assert turn_excursion_m(v, BANK, math.pi / 2, 0.0, turn_sign=-1, turn_angle_rad=math.pi) == pytest.approx(2 * r)
    # oblique approach at angle a: R (1 - sin a)
    a = math.radians(40.0)
    assert turn_excursion_m(v, BANK, a, 0.0) == pytest.approx(r * (1 - math.sin(a)))
    assert turn_excursion_m(v, BANK, -a, 0.0) == pytest.approx(r * (1 - math.sin(a)))
    # receding: nothing
    assert fixed_wing_room_m(v, BANK, math.radians(120.0), 0.0, 1.0) == 0.0


def test_head_on_with_wind_closed_form():
    v = 20.0
    r = turn_radius_m(v, BANK)
    for w in (-15.0, -5.0, 0.0, 5.0, 15.0, 19.0):
        u = w / v
        expected = r * (math.sqrt(1 - u * u) + u * math.acos(-u))
        assert turn_excursion_m(v, BANK, 0.0, w) == pytest.approx(expected)
    # limits: tailwind -> airspeed gives pi R; w >= V cannot be turned against
    assert turn_excursion_m(v, BANK, 0.0, v * (1 - 1e-9)) == pytest.approx(math.pi * r, rel=1e-4)
    assert turn_excursion_m(v, BANK, 0.0, v) == math.inf
    assert turn_excursion_m(v, BANK, 0.0, -v) == 0.0


def _integrate_excursion(v, bank, psi0, w, s, turn_angle=None, steps=20000):
    """Brute-force trochoid: Euler-integrate the turn and take the largest normal excursion."""
    omega = turn_rate_radps(v, bank)
    if turn_angle is None:
        if v * math.cos(psi0) + w <= 0:
            return 0.0
        turn_angle = 4 * math.pi
        stop_when_receding = True
    else:
        stop_when_receding = False
    theta = np.linspace(0.0, turn_angle, steps + 1)
    psi = psi0 + s * theta
    xdot = v * np.cos(psi) + w  # d x / d t
    x = np.concatenate([[0.0], np.cumsum(0.5 * (xdot[1:] + xdot[:-1]) * np.diff(theta) / omega)])
    if stop_when_receding:
        k = np.argmax(xdot <= 0.0)
        x = x[: k + 1]
    return max(0.0, float(x.max()))


@settings(max_examples=150, deadline=None)
@given(
    st.floats(10.0, 40.0),
    st.floats(-math.pi, math.pi),
    st.floats(-0.95, 0.95),
    st.sampled_from([1, -1]),
    st.one_of(st.none(), st.floats(0.0, 2 * math.pi)),
)
def test_excursion_matches_numerical_trochoid(v, psi0, u, s, turn_angle):
    w = u * v
    closed = turn_excursion_m(v, BANK, psi0, w, turn_sign=s, turn_angle_rad=turn_angle)
    numeric = _integrate_excursion(v, BANK, psi0, w, s, turn_angle)
    r = turn_radius_m(v, BANK)
    assert closed == pytest.approx(numeric, abs=2e-3 * r)


@settings(max_examples=150, deadline=None)
@given(st.floats(10.0, 40.0), st.floats(0.0, math.pi / 2), st.floats(-0.9, 0.9), st.floats(0.0, 0.09))
def test_room_grows_monotonically_with_tailwind(v, a, u1, du):
    w1, w2 = u1 * v, (u1 + du) * v
    assert fixed_wing_room_m(v, BANK, a, w2, 0.3) >= fixed_wing_room_m(v, BANK, a, w1, 0.3) - 1e-9
    # headwind < calm < tailwind, head-on
    r0 = fixed_wing_room_m(v, BANK, 0.0, 0.0, 0.0)
    assert fixed_wing_room_m(v, BANK, 0.0, -0.3 * v, 0.0) < r0 < fixed_wing_room_m(v, BANK, 0.0, 0.3 * v, 0.0)


def test_room_from_ground_velocity():
    # ground velocity 25 m/s straight at the edge with 5 m/s tailwind: airspeed 20 head-on
    v, w = 20.0, 5.0
    got = fixed_wing_room_from_velocity_m(25.0, 0.0, w, 0.0, BANK, 0.4)
    assert got == pytest.approx(25.0 * 0.4 + turn_excursion_m(v, BANK, 0.0, w))
    # a crosswind does not change the room along the normal for the same air heading
    assert fixed_wing_room_from_velocity_m(25.0, 7.0, w, 7.0, BANK, 0.4) == pytest.approx(got)


# ------------------------------------------------------------------ multicopter and vertical closed forms
def test_multicopter_braking_closed_form():
    v, t, a = 8.0, 0.25, 4.0
    assert multicopter_stopping_distance_m(v, t, a) == pytest.approx(v * t + v * v / (2 * a))
    # oblique: the straight stopping path projected on the normal
    vn = v * math.cos(math.radians(60))
    assert multicopter_stopping_distance_m(vn, t, a, speed_mps=v) == pytest.approx(vn * t + vn * v / (2 * a))
    assert multicopter_stopping_distance_m(-1.0, t, a) == 0.0
    # wind pushing towards the edge reduces the braking deceleration
    push = wind_push_mps2(0.0, 9.80665 * math.tan(math.radians(30.0)) / 144.0, 6.0, 6.0)
    assert push == pytest.approx(G_MPS2 * math.tan(math.radians(30.0)) * 36.0 / 144.0)
    assert multicopter_stopping_distance_m(v, t, a, wind_push_mps2=push) == pytest.approx(v * t + v * v / (2 * (a - push)))
    assert multicopter_stopping_distance_m(v, t, a, wind_push_mps2=a) == math.inf
    # wind away from the edge: no credit taken
    assert wind_push_mps2(0.0, 9.80665 * math.tan(math.radians(30.0)) / 144.0, 6.0, -6.0) == 0.0


def test_vertical_arrest_closed_form():
    assert vertical_arrest_distance_m(3.0, 0.2, 4.0, 0.0) == pytest.approx(3.0 * 0.2 + 9.0 / 8.0)
    assert vertical_arrest_distance_m(-3.0, 0.2, 4.0, 0.0) == 0.0
    assert vertical_arrest_distance_m(3.0, 0.2, 0.0, 0.0) == math.inf
    # the pilot keeps accelerating towards the limit through the reaction, up to the platform's rate
    assert vertical_arrest_distance_m(0.0, 1.0, 2.0, 5.0) == pytest.approx(0.5 * 2.0 + 2.0**2 / 4.0)  # a·t²
    assert vertical_arrest_distance_m(0.0, 1.0, 2.0, 1.0) == pytest.approx(0.25 + 0.5 + 0.25)  # at the rate after 0.5 s
    assert vertical_arrest_distance_m(3.0, 0.2, 4.0, 3.0) == pytest.approx(3.0 * 0.2 + 9.0 / 8.0)  # at the rate already
    assert vertical_arrest_distance_m(-3.0, 1.0, 2.0, 5.0) == 0.0  # still moving away when the override acts
    assert vertical_arrest_distance_m(-1.0, 1.0, 2.0, 5.0) == pytest.approx(1.0**2 / 4.0)  # back where it started, then 1 m/s
    assert vertical_arrest_distance_m(-0.5, 1.0, 2.0, 5.0) == pytest.approx(-0.5 + 1.0 + 1.5**2 / 4.0)


@settings(max_examples=300, deadline=None)
@given(
    v0=st.floats(-5.0, 5.0),
    t_r=st.floats(0.0, 2.0),
    a_z=st.floats(0.3, 8.0),
    v_max=st.floats(0.0, 6.0),
)
def test_vertical_arrest_is_the_farthest_point_of_the_worst_pilot(v0, t_r, a_z, v_max):
    # integrate the worst pilot (accelerating towards the limit at a_z, up to v_max, for t_r) and the
    # override's arrest at a_z: the farthest point reached towards the limit is the closed form
    dt = 1e-4
    x = peak = 0.0
    v = v0
    t = 0.0
    while t < t_r:
        step = min(dt, t_r - t)
        a = a_z if v < v_max else 0.0
        v_next = min(v + a * step, max(v_max, v)) if a > 0.0 else v
        x += 0.5 * (v + v_next) * step
        v = v_next
        peak = max(peak, x)
        t += step
    if v > 0.0:
        peak = max(peak, x + v * v / (2.0 * a_z))
    d = vertical_arrest_distance_m(v0, t_r, a_z, v_max)
    assert d == pytest.approx(peak, abs=2e-3 * (1.0 + abs(v0) + v_max))


def test_uncertainty_margin():
    assert uncertainty_margin_m(None) == (0.0, 0.0)
    h, v = uncertainty_margin_m([[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 9.0]], k_sigma=3.0)
    assert (h, v) == (pytest.approx(6.0), pytest.approx(9.0))
    # correlated: largest eigenvalue of [[2, 1], [1, 2]] is 3
    h, v = uncertainty_margin_m(np.array([[2.0, 1.0], [1.0, 2.0]]), k_sigma=2.0)
    assert h == pytest.approx(2.0 * math.sqrt(3.0)) and v == 0.0


# ------------------------------------------------------------------ activation margins for a state
def test_multicopter_activation_head_on():
    lf = square_fence(200.0)
    e, n = 150.0, 0.0  # 50 m from the east edge
    v = 8.0
    res = activation_margins(lf, e, n, 50.0, v, 0.0, 0.0, MC)
    # worst case: full-tilt acceleration toward the edge during the reaction time, then braking
    t, a_p = MC.reaction_time_s, 9.80665 * math.tan(MC.max_bank_rad)
    v1 = v + a_p * t
    shift = v * t + 0.5 * a_p * t * t + v1 * v1 / (2 * MC.braking_decel_mps2)
    d = 200.0 - e
    assert (res.feature, res.edge) == ("keep_in", 1)
    assert (res.normal_e, res.normal_n) == pytest.approx((1.0, 0.0))
    assert res.edge_distance_m == pytest.approx(d, abs=1e-3)
    assert res.lateral_shift_m == pytest.approx(shift)
    assert res.lateral_activation_m == pytest.approx(d - shift, abs=1e-3)
    assert res.time_to_breach_s == pytest.approx(d / v, abs=1e-3)
    dive = vertical_arrest_distance_m(0.0, t, MC.vertical_accel_mps2, MC.max_descent_rate_mps)  # from rest, the pilot's dive
    assert res.activation_margin_m == pytest.approx(min(d - shift, 40.0 - dive), abs=1e-3)
    # moving away: no shift, no breach in sight
    away = activation_margins(lf, e, n, 50.0, -v, 0.0, 0.0, MC)
    assert away.time_to_breach_s == math.inf and away.lateral_activation_m == pytest.approx(d, abs=1e-3)
    # climbing while braking: the collective cut of the climb arrest costs extra room
    climbing = activation_margins(lf, e, n, 50.0, v, 0.0, 2.0, MC)
    assert climbing.lateral_shift_m > res.lateral_shift_m
    # a tailwind towards the edge increases the shift; uncertainty adds on top
    # (the wind's push adds to the pilot's acceleration during the reaction, and slows the braking)
    windy = activation_margins(lf, e, n, 50.0, v, 0.0, 0.0, MC, 6.0, 0.0, h_uncertainty_m=3.0)
    push = wind_push_mps2(*drag_coefficients(MC), 6.0, 6.0)
    a_pw = a_p + push
    v1w = v + a_pw * t
    assert windy.lateral_shift_m == pytest.approx(v * t + 0.5 * a_pw * t * t + v1w * v1w / (2 * (5.0 - push)) + 3.0)


def test_fixed_wing_activation_head_on_calm():
    lf = square_fence(1000.0)  # recovery point at the centre, behind the aircraft
    e = 800.0
    v = 20.0
    res = activation_margins(lf, e, 0.0, 50.0, v, 0.0, 0.0, FW)
    r = turn_radius_m(v, BANK)
    assert (res.feature, res.edge) == ("keep_in", 1)
    assert res.lateral_shift_m == pytest.approx(v * FW.reaction_time_s + r, rel=1e-6)
    assert res.lateral_activation_m == pytest.approx(200.0 - v * FW.reaction_time_s - r, abs=1e-3)
    assert res.turn_sign in (1, -1)
    # tailwind along the approach makes the activation margin smaller, headwind larger
    tail = activation_margins(lf, e, 0.0, 50.0, v + 5.0, 0.0, 0.0, FW, 5.0, 0.0)
    head = activation_margins(lf, e, 0.0, 50.0, v - 5.0, 0.0, 0.0, FW, -5.0, 0.0)
    assert tail.lateral_activation_m < res.lateral_activation_m < head.lateral_activation_m
    assert tail.lateral_shift_m == pytest.approx((v + 5.0) * FW.reaction_time_s + turn_excursion_m(v, BANK, 0.0, 5.0), rel=1e-6)


def test_fixed_wing_turns_away_from_the_near_edge():
    lf = square_fence(1000.0)
    # flying east close to the north edge; the recovery point is to the south-west
    res = activation_margins(lf, 300.0, 900.0, 50.0, 20.0, 0.0, 0.0, FW)
    assert res.turn_sign == -1  # right turn, away from the north edge
    r = turn_radius_m(20.0, BANK)
    # turning left would cost 2R against the north edge; turning right costs nothing there
    assert res.lateral_activation_m > 100.0 - 2 * r


def test_vertical_margins_and_time_to_breach():
    lf = square_fence(200.0)
    res = activation_margins(lf, 0.0, 0.0, 100.0, 0.0, 0.0, 2.0, MC, v_uncertainty_m=1.0)
    cs = vertical_arrest_distance_m(2.0, MC.reaction_time_s, MC.vertical_accel_mps2, MC.max_climb_rate_mps) + 1.0
    assert res.ceiling_margin_m == pytest.approx(20.0) and res.ceiling_shift_m == pytest.approx(cs)
    assert res.vertical_activation_m == pytest.approx(20.0 - cs)
    assert res.vertical_time_to_breach_s == pytest.approx(10.0)
    down = activation_margins(lf, 0.0, 0.0, 20.0, 0.0, 0.0, -2.0, MC)
    assert down.floor_margin_m == pytest.approx(10.0)
    assert down.floor_shift_m == pytest.approx(vertical_arrest_distance_m(2.0, 0.1, 4.0, MC.max_descent_rate_mps))
    assert down.vertical_time_to_breach_s == pytest.approx(5.0)
    assert down.activation_margin_m == pytest.approx(10.0 - down.floor_shift_m)


def test_breached_state_has_negative_margins():
    lf = square_fence(200.0)
    res = activation_margins(lf, 210.0, 0.0, 50.0, 5.0, 0.0, 0.0, MC)
    assert res.lateral_margin_m == pytest.approx(-10.0, abs=1e-3)
    assert res.lateral_activation_m <= -10.0 + 1e-3 and res.time_to_breach_s == 0.0


def test_state_wrapper_uses_the_fence_altitude_reference():
    lf = square_fence(200.0)
    st_ = VehicleState(east_m=0.0, north_m=0.0, up_m=-3.0, agl_m=50.0, alt_m=500.0)
    res = activation_margins_for_state(lf, st_, MC)
    assert res.ceiling_margin_m == pytest.approx(70.0)


# ------------------------------------------------------------------ feasibility
def test_shifted_fence_vanishes_for_a_fast_fixed_wing_in_a_small_fence():
    small = square_fence(60.0)
    with pytest.raises(FenceError, match=r"shifted fence vanishes: worst-case lateral shift .* >= inradius 60\.0 m"):
        check_shift_feasible(small, FW, 5.0)
    big = square_fence(1000.0)
    rep = check_shift_feasible(big, FW, 5.0)
    assert rep.lateral_shift_m == pytest.approx(worst_case_lateral_shift_m(FW, 5.0))
    assert rep.lateral_shift_m < rep.inradius_m == pytest.approx(1000.0, abs=0.5)
    # wind at the maximum airspeed: impossible anywhere
    with pytest.raises(FenceError, match="infinite"):
        check_shift_feasible(big, FW, 30.0)
    # multicopter: fine in the small fence, not in a gale it cannot hold against
    check_shift_feasible(small, MC, 5.0)
    with pytest.raises(FenceError, match="wind push"):
        check_shift_feasible(small, MC, 12.0)


def test_worst_case_shift_closed_forms():
    w = 4.0
    expected = max(fixed_wing_room_m(v, BANK, 0.0, w, FW.reaction_time_s) for v in (12.0, 18.0, 25.0))
    assert worst_case_lateral_shift_m(FW, w) == pytest.approx(expected)
    push = wind_push_mps2(*drag_coefficients(MC), w, w)
    assert worst_case_lateral_shift_m(MC, w, 2.0) == pytest.approx(12.0 * 0.1 + 144.0 / (2 * (5.0 - push)) + 2.0)


def test_shifted_fence_vanishes_vertically():
    thin = square_fence(1000.0, ceiling_m=12.0, floor_m=10.0)
    with pytest.raises(FenceError, match="vanishes vertically"):
        check_shift_feasible(thin, MC, 0.0)


def _gap_fence(gap_half_m: float, floor_m: float = 40.0):
    fr = LocalFrame(47.4, 8.5, 0.0)
    h = gap_half_m
    gap = [list(fr.to_geodetic(x, y, 0.0)[:2]) for x, y in ((-h, -h), (h, -h), (h, h), (-h, h))]
    return square_fence(1500.0, ceiling_m=600.0, floor_m=floor_m, floor_gaps=[gap])


def _circle_leaves_gap(lf, e, n, h, ve, vn, vu, we, wn, r, steps: int = 2000) -> float:
    """The deepest point outside the gap (m, > 0: out) of the circle the margins score for a fixed-wing below the
    floor in it: its reaction (straight, not banked), then the turn ``r.turn_sign`` at the bank limit for as long
    as the climb back from its deepest point takes (:func:`gap_circle_turn_rad`), in the wind ``(we, wn)``."""
    env = FW
    vae, van = ve - we, vn - wn
    psi = math.atan2(van, vae)
    v = max(math.hypot(vae, van), env.cruise_speed_mps, env.min_speed_mps)
    _, inv_omega = turn_constants(v, env.max_bank_rad)
    deepest = h - vertical_arrest_distance_m(-vu, env.reaction_time_s, env.vertical_accel_mps2, env.max_descent_rate_mps)
    angle = gap_circle_turn_rad(lf.floor_m - deepest, env.max_climb_rate_mps, inv_omega)
    gap = lf.floor_gaps[0]
    x, y, worst = e, n, -math.inf
    for duration, rate in ((env.reaction_time_s, 0.0), (angle * inv_omega, r.turn_sign / inv_omega)):
        dt = duration / steps
        for _ in range(steps):
            x += (v * math.cos(psi + 0.5 * rate * dt) + we) * dt
            y += (v * math.sin(psi + 0.5 * rate * dt) + wn) * dt
            psi += rate * dt
            worst = max(worst, -gap.signed_distance(x, y))  # + outside
    return worst


@settings(max_examples=300, deadline=None)
@given(
    st.floats(60.0, 300.0), st.floats(-0.8, 0.8), st.floats(-0.8, 0.8), st.floats(5.0, 38.0), st.floats(-math.pi, math.pi),
    st.floats(0.0, 12.0), st.floats(-math.pi, math.pi), st.floats(0.0, 3.0),
)  # fmt: skip
def test_a_fixed_wing_below_the_floor_in_a_gap_is_scored_on_its_whole_climb_back_circle(half, fx, fy, h, course, w, wd, sink):
    """Below the floor inside a gap, a fixed-wing cannot hover: the override keeps it circling at the bank limit
    until it has climbed back above the floor, and the circle drifts with the wind. That whole circle, flown
    numerically, leaves the gap only if the floor activation is negative (where its descent cannot be arrested
    above the floor). It was scored as the turn to its roll-out heading plus a drift: a J3Cub that
    flew that turn, then straight for the route, left a 300 m gap 1.1 m below the floor (a campaign attack)."""
    lf = _gap_fence(half)
    e, n = fx * half, fy * half
    speed = FW.cruise_speed_mps
    we, wn = w * math.cos(wd), w * math.sin(wd)
    ve, vn = speed * math.cos(course) + we, speed * math.sin(course) + wn
    r = activation_margins(lf, e, n, h, ve, vn, -sink, FW, we, wn)
    arrest_ok = (
        h - lf.floor_m - vertical_arrest_distance_m(sink, FW.reaction_time_s, FW.vertical_accel_mps2, FW.max_descent_rate_mps)
        >= 0.0
    )
    if r.vertical_activation_m >= 0.0 and not arrest_ok:
        assert _circle_leaves_gap(lf, e, n, h, ve, vn, -sink, we, wn, r) <= 1e-6, (half, e, n, h, r)


def test_the_climb_back_circle_is_longer_the_deeper_it_starts():
    """10 m deeper is 10 m more to climb: the circle turns farther, so the floor activation is no larger; a
    multirotor holds its position while it climbs, so its activation does not change."""
    lf = _gap_fence(200.0)

    def floor_act(env, h, wind_e):
        vn = env.cruise_speed_mps if env is FW else 0.0
        return activation_margins(lf, 0.0, 0.0, h, 0.0, vn, -2.0, env, wind_e, 0.0).vertical_activation_m

    for wind in (0.0, 8.0):
        assert floor_act(FW, 20.0, wind) <= floor_act(FW, 30.0, wind)
    assert floor_act(FW, 20.0, 8.0) < floor_act(FW, 30.0, 8.0) - 8.0 * 10.0 / FW.max_climb_rate_mps + 2.0 * turn_radius_m(
        FW.cruise_speed_mps, FW.max_bank_rad
    )
    assert floor_act(MC, 30.0, 8.0) == pytest.approx(floor_act(MC, 20.0, 8.0))
    assert gap_circle_turn_rad(0.0, 3.0, 1.0) == 0.0 and gap_circle_turn_rad(-5.0, 3.0, 1.0) == 0.0
    assert climb_back_drift_m(0.0, 3.0, 8.0) == 0.0 and climb_back_drift_m(-5.0, 3.0, 8.0) == 0.0
