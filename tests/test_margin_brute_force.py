"""Property: the activation margin's room equals a brute-force simulation of the manoeuvre it scores.

For random states near one edge of a large fence, :func:`activation_margins` reports the room it
needs against that edge. Here the same manoeuvre is integrated numerically as a point mass:

* fixed-wing: keep the current (straight) course for the reaction time, then turn at the bank limit
  in the direction the margin chose, by exactly the angle it scored (to the roll-out heading), in a
  steady wind, at the override's airspeed (cruise, or the current airspeed when faster: the
  override accelerates a slow aircraft to cruise, which widens its turn); the room is the largest
  displacement along the edge's outward normal;
* multirotor, head-on: accelerate toward the edge at the tilt limit plus the wind's push for the
  reaction time, then brake at the braking deceleration minus the push until stopped.

The closed forms must agree with the integration (to the integration step), so the margin is exactly
the manoeuvre it claims to score — no more, no less.

The index (:class:`~geofence.geometry.fence_grid.FenceGrid`) only chooses which elements are scored: on random fences the
same fence with and without it gives the same margins (every field within 1e-9 m, the same binding element),
for both platform kinds at states next to vertices, inside keep-outs, outside and far inside.

The room formulas themselves (:mod:`geofence.physics.rooms`, the one home each: the compiled kernels call them) are held
to brute-force integrations too: the trochoid excursion of a turn in wind and the turn-back room, the bounds the
binding searches prune with, the braking distance with and without a climb arrest, the stopping distance and the
vertical arrest; and to properties (more speed or more wind towards the edge never needs less room).
"""

import math
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support import FRAME as FENCE_FRAME
from support import probe_points, random_fence, random_margin_call, same_margins

from aircraft.profile import load_profile
from geofence.geometry.geodesy import LocalFrame
from geofence.margins.boundary_shift import activation_margins
from geofence.physics.dynamics import G_MPS2, drag_coefficients, wind_push_mps2
from geofence.physics.rooms import (
    braking_room_m,
    fixed_wing_room_bound_m,
    fixed_wing_room_m,
    head_on_room_m,
    multicopter_stopping_distance_m,
    multirotor_room_m,
    reaction_arc_bound_m,
    reaction_arc_sines_m,
    reaction_arc_terms_m,
    trochoid_excursion_bound_m,
    trochoid_excursion_m,
    turn_constants,
    turn_rate_radps,
    vertical_arrest_distance_m,
)
from geofence.unit.config import parse_geofence

FRAME = LocalFrame(10.0, 20.0, 0.0)
HALF = 5000.0
FENCE = parse_geofence(
    {
        "fence": {
            "keep_in": [
                list(FRAME.to_geodetic(e, n, 0.0)[:2]) for e, n in ((-HALF, -HALF), (HALF, -HALF), (HALF, HALF), (-HALF, HALF))
            ],
            "ceiling_m": 500.0,
        }
    }
).fence.to_local(FRAME)
FW = load_profile("Tern").envelope
MC = load_profile("F450RD").envelope


def simulate_fixed_wing(e, n, v_air, psi, we, wn, t_react, turn_sign, turn_angle, dt=0.002):
    """Largest eastward displacement (toward the east edge) of the scored manoeuvre, m."""
    omega = G_MPS2 * math.tan(FW.max_bank_rad) / v_air
    x, best, t, turned = 0.0, 0.0, 0.0, 0.0
    while t < t_react:
        x += (v_air * math.cos(psi) + we) * dt
        best = max(best, x)
        t += dt
    while turned < turn_angle:
        step = min(omega * dt, turn_angle - turned)
        psi += turn_sign * step
        turned += step
        x += (v_air * math.cos(psi) + we) * (step / omega)
        best = max(best, x)
    return best


@settings(max_examples=150, deadline=None)
@given(
    v_air=st.floats(12.0, 24.0),
    heading=st.floats(-1.3, 1.3),  # air heading relative to the east edge's normal (rad)
    wind=st.floats(0.0, 9.0),
    wind_dir=st.floats(-math.pi, math.pi),
    dist=st.floats(150.0, 600.0),
)
def test_fixed_wing_room_matches_the_integrated_turn(v_air, heading, wind, wind_dir, dist):
    we, wn = wind * math.cos(wind_dir), wind * math.sin(wind_dir)
    e, n = HALF - dist, 0.0
    ve, vn = v_air * math.cos(heading) + we, v_air * math.sin(heading) + wn
    r = activation_margins(FENCE, e, n, 100.0, ve, vn, 0.0, FW, we, wn)
    if (r.feature, r.edge) != ("keep_in", 1):
        return  # another edge binds: not this test's subject
    v_fly = max(v_air, FW.cruise_speed_mps)
    room_sim = simulate_fixed_wing(e, n, v_fly, heading, we, wn, FW.reaction_time_s, r.turn_sign, r.turn_angle_rad)
    assert abs(room_sim - r.lateral_shift_m) <= 0.01 * r.lateral_shift_m + 0.2, (room_sim, r)


@settings(max_examples=150, deadline=None)
@given(speed=st.floats(0.0, 10.0), wind=st.floats(0.0, 5.0), dist=st.floats(60.0, 400.0))
def test_multirotor_head_on_room_matches_the_integrated_stop(speed, wind, dist):
    e = HALF - dist
    r = activation_margins(FENCE, e, 0.0, 100.0, speed, 0.0, 0.0, MC, wind, 0.0)
    k1, k2 = drag_coefficients(MC)
    push = wind_push_mps2(k1, k2, wind, wind)
    a_tilt = G_MPS2 * math.tan(MC.max_bank_rad)
    # integrate: accelerate (tilt limit while below max airspeed, plus the push) for the reaction time, then brake
    dt, x, v, t = 1e-4, 0.0, speed, 0.0
    while t < MC.reaction_time_s:
        a = (a_tilt if abs(speed - wind) < MC.max_speed_mps else 0.0) + push
        v += a * dt
        x += v * dt
        t += dt
    a_brake = MC.braking_decel_mps2 - push
    while v > 0.0:
        v -= a_brake * dt
        x += max(v, 0.0) * dt
    assert abs(x - r.lateral_shift_m) <= 0.005 * r.lateral_shift_m + 0.02, (x, r.lateral_shift_m)


# ------------------------------------------------------------------ the room formulas against brute-force integrations
def integrate_turn(v, bank, psi0, w_n, s, turn_angle, dt_rad=2e-4):
    """Largest displacement along the normal of a max-bank turn in a wind ``w_n`` towards the edge, stepped in
    heading (``dt_rad``) by the midpoint rule; ``turn_angle=None``: until the ground track stops closing."""
    omega = G_MPS2 * math.tan(bank) / v
    x, best, psi, turned = 0.0, 0.0, psi0, 0.0
    if turn_angle is None and v * math.cos(psi0) + w_n <= 0.0:
        return 0.0
    while turn_angle is None or turned < turn_angle:
        step = dt_rad if turn_angle is None else min(dt_rad, turn_angle - turned)
        mid = psi + 0.5 * s * step
        if turn_angle is None and v * math.cos(mid) + w_n <= 0.0:
            break
        x += (v * math.cos(mid) + w_n) * step / omega
        psi += s * step
        turned += step
        best = max(best, x)
    return best


speeds_fw = st.floats(8.0, 40.0)
banks_fw = st.floats(0.3, 1.0)
headings = st.floats(-math.pi, math.pi)


@settings(max_examples=120, deadline=None)
@given(
    v=speeds_fw, bank=banks_fw, psi0=headings, u=st.floats(-0.9, 0.9), s=st.sampled_from([1.0, -1.0]), delta=st.floats(0.0, 6.2)
)
def test_trochoid_excursion_matches_the_integrated_turn(v, bank, psi0, u, s, delta):
    """A turn of exactly ``delta`` in wind: the closed form's maximum over the turn is the integration's."""
    radius, inv_omega = turn_constants(v, bank)
    got = trochoid_excursion_m(radius, inv_omega, v, u * v, psi0, s, delta)
    want = integrate_turn(v, bank, psi0, u * v, s, delta)
    assert got == pytest.approx(want, rel=1e-5, abs=1e-6 * (1.0 + radius))


@settings(max_examples=120, deadline=None)
@given(v=speeds_fw, bank=banks_fw, psi0=headings, u=st.floats(-0.9, 0.9), t_r=st.floats(0.0, 3.0))
def test_fixed_wing_room_matches_the_integrated_reversal(v, bank, psi0, u, t_r):
    """:func:`fixed_wing_room_m` (reaction travel + closed form (1), the better turn) is the integrated manoeuvre:
    straight for ``t_r`` then turning until no longer closing, the better of the two directions."""
    w_n = u * v
    closing = v * math.cos(psi0) + w_n
    react = max(closing, 0.0) * t_r
    want = react + min(integrate_turn(v, bank, psi0, w_n, s, None) for s in (1.0, -1.0))
    got = fixed_wing_room_m(v, bank, psi0, w_n, t_r)
    assert got == pytest.approx(want, rel=1e-5, abs=1e-4)


@settings(max_examples=200, deadline=None)
@given(
    v=speeds_fw,
    bank=banks_fw,
    psi0=headings,
    w_n=st.floats(-30.0, 30.0),
    s=st.sampled_from([1.0, -1.0]),
    delta=st.floats(0.0, 6.3),
)
def test_the_excursion_bound_bounds_the_excursion(v, bank, psi0, w_n, s, delta):
    radius, inv_omega = turn_constants(v, bank)
    ex = trochoid_excursion_m(radius, inv_omega, v, w_n, psi0, s, delta)
    assert ex <= trochoid_excursion_bound_m(radius, inv_omega, w_n, math.sin(psi0), s, delta)


@settings(max_examples=200, deadline=None)
@given(
    v=speeds_fw, bank=banks_fw, psi0=headings, roll=st.floats(-1.0, 1.0), t=st.floats(0.05, 3.0), theta=headings,
    w_n=st.floats(-20.0, 20.0),
)  # fmt: skip
def test_the_reaction_arc_fast_form_and_bound(v, bank, psi0, roll, t, theta, w_n):
    """The trig-free reaction arc equals :func:`reaction_arc_m` to round-off, and the arc's farthest travel
    (its end plus its gap) is at most :func:`reaction_arc_bound_m`."""
    omega = turn_rate_radps(v, bank * roll) if abs(roll) > 1e-6 else 1e-12
    rot = max(-math.pi, min(math.pi, omega * t))
    nx, ny = math.cos(theta), math.sin(theta)
    straight = abs(rot) < 1e-6
    arc = v * t if straight else v / omega
    fast = reaction_arc_sines_m(
        arc, math.sin(psi0), math.cos(psi0), math.sin(psi0 - rot), math.cos(psi0 - rot), straight, t, nx, ny, w_n
    )
    end, gap = reaction_arc_terms_m(v, psi0, rot, omega, t, nx, ny, w_n)
    assert fast == pytest.approx(end, abs=1e-9 * (1.0 + abs(arc) + abs(w_n) * t))
    assert end + gap <= reaction_arc_bound_m(v, w_n, t)


@settings(max_examples=150, deadline=None)
@given(v=speeds_fw, bank=banks_fw, psi0=headings, u=st.floats(0.0, 0.9), t=st.floats(0.0, 3.0), delta=st.floats(0.0, 6.28))
def test_the_fixed_wing_room_bound_bounds_the_integrated_manoeuvre(v, bank, psi0, u, t, delta):
    """Straight reaction then any turn of up to 2 pi in a wind of ``|W| = u·v`` from any direction: the
    integrated room is at most :func:`fixed_wing_room_bound_m`."""
    radius, inv_omega = turn_constants(v, bank)
    bound = fixed_wing_room_bound_m(radius, inv_omega, v, u * v, t)
    for w_n in (u * v, 0.0, -u * v):
        react = (v * math.cos(psi0) + w_n) * t
        for s in (1.0, -1.0):
            assert max(react, react + integrate_turn(v, bank, psi0, w_n, s, delta, 1e-3)) <= bound + 1e-9


def integrate_stop(v_n, v, t_r, a_pilot, a_brake, arrest=(0.0, 0.0), dt=1e-5):
    """Displacement along the normal of a worst-case pilot then a stop along the velocity, by Euler steps: the
    pilot accelerates along the normal at ``a_pilot`` for ``t_r``; then the vehicle brakes along its velocity at
    ``a_brake``, only ``a_brake·(1 - loss)`` for the first ``t_arrest`` s. Closing from the start (``v_n > 0``)."""
    x, u_n, u, t = 0.0, v_n, v, 0.0
    while t < t_r:
        u_n += a_pilot * dt
        u += a_pilot * dt
        x += u_n * dt
        t += dt
    u = max(u, u_n)
    t_arrest, loss = arrest
    t = 0.0
    while u > 0.0:
        a = a_brake * (1.0 - loss) if t < t_arrest else a_brake
        du = min(a * dt, u)
        x += (u_n / u) * (u - 0.5 * du) * dt
        u_n *= (u - du) / u
        u -= du
        t += dt
    return x


@settings(max_examples=60, deadline=None)
@given(
    v=st.floats(0.5, 15.0), frac=st.floats(0.05, 1.0), t_r=st.floats(0.0, 1.5), a_brake=st.floats(2.0, 10.0),
    push=st.floats(0.0, 1.5),
)  # fmt: skip
def test_stopping_distance_matches_the_integrated_stop(v, frac, t_r, a_brake, push):
    """:func:`multicopter_stopping_distance_m` (reaction at constant speed, then :func:`braking_room_m` along the
    velocity, projected on the normal) against the integrated stop."""
    v_n = frac * v
    want = v_n * t_r + integrate_stop(v_n, v, 0.0, 0.0, a_brake - push)
    got = multicopter_stopping_distance_m(v_n, t_r, a_brake, v, push)
    assert got == pytest.approx(want, rel=1e-3, abs=1e-4)


@settings(max_examples=60, deadline=None)
@given(
    v=st.floats(0.5, 15.0), frac=st.floats(0.05, 1.0), t_r=st.floats(0.0, 1.0), a_p=st.floats(0.0, 6.0),
    a_brake=st.floats(2.0, 10.0), t_arrest=st.floats(0.0, 2.0), loss=st.floats(0.0, 0.9),
)  # fmt: skip
def test_multirotor_room_with_a_climb_arrest_matches_the_integrated_stop(v, frac, t_r, a_p, a_brake, t_arrest, loss):
    v_n = frac * v
    want = integrate_stop(v_n, v, t_r, a_p, a_brake, (t_arrest, loss))
    got = multirotor_room_m(v_n, v, t_r, a_p, a_brake, (t_arrest, loss))
    assert got == pytest.approx(want, rel=1e-3, abs=1e-4)


@settings(max_examples=100, deadline=None)
@given(v=st.floats(-8.0, 8.0), t_r=st.floats(0.0, 2.0), a_z=st.floats(0.5, 8.0), v_max=st.floats(0.0, 8.0))
def test_vertical_arrest_matches_the_integrated_arrest(v, t_r, a_z, v_max):
    """The pilot accelerates towards the limit at ``a_z`` up to ``v_max`` for ``t_r``, then the override
    decelerates at ``a_z`` until it moves away: the largest displacement towards the limit."""
    dt, x, u, t, best = 1e-5, 0.0, v, 0.0, 0.0
    while t < t_r:
        a = a_z if u < v_max else 0.0
        du = min(a * dt, max(v_max - u, 0.0))
        x += (u + 0.5 * du) * dt
        u += du
        t += dt
        best = max(best, x)
    while u > 0.0:
        du = min(a_z * dt, u)
        x += (u - 0.5 * du) * dt
        u -= du
        best = max(best, x)
    got = vertical_arrest_distance_m(v, t_r, a_z, v_max)
    assert got == pytest.approx(best, rel=1e-3, abs=1e-3)


# ------------------------------------------------------------------ properties of the rooms
envelopes_both = st.sampled_from([FW, MC])


@settings(max_examples=200, deadline=None)
@given(env=envelopes_both, v=st.floats(1.0, 30.0), dv=st.floats(0.0, 10.0), w=st.floats(0.0, 8.0), dw=st.floats(0.0, 4.0))
def test_head_on_room_grows_with_speed_and_tailwind(env, v, dv, w, dw):
    """Faster, or with more wind towards the edge, needs at least as much room, and a tailwind at least the
    calm-air room (for a fixed-wing, while the wind stays below the airspeed)."""
    if env is FW and w + dw >= v:
        return
    room = head_on_room_m(env, v, w, w)
    assert head_on_room_m(env, v + dv, w, w) >= room * (1.0 - 1e-12)
    assert head_on_room_m(env, v, w + dw, w + dw) >= room * (1.0 - 1e-12)
    assert room >= head_on_room_m(env, v, 0.0, 0.0) * (1.0 - 1e-12)


@settings(max_examples=200, deadline=None)
@given(
    v_n=st.floats(0.0, 15.0), extra=st.floats(0.0, 10.0), t_r=st.floats(0.0, 2.0), a=st.floats(1.0, 10.0),
    push=st.floats(0.0, 0.9), more=st.floats(0.0, 0.09),
)  # fmt: skip
def test_stopping_distance_grows_with_speed_and_wind_push(v_n, extra, t_r, a, push, more):
    d = multicopter_stopping_distance_m(v_n, t_r, a, v_n + extra, push * a)
    assert multicopter_stopping_distance_m(v_n, t_r, a, v_n + extra + 1.0, push * a) >= d
    assert multicopter_stopping_distance_m(v_n + 0.5, t_r, a, v_n + extra + 0.5, push * a) >= d
    assert multicopter_stopping_distance_m(v_n, t_r, a, v_n + extra, (push + more) * a) >= d
    assert d >= multicopter_stopping_distance_m(v_n, t_r, a, v_n + extra, 0.0)
    assert d == pytest.approx(v_n * t_r + braking_room_m(v_n, max(v_n + extra, v_n), a - push * a, (0.0, 0.0)))


# ------------------------------------------------------------------ the index is only an index
@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(40, 600), n_squares=st.integers(0, 25), n_circles=st.integers(0, 8))
def test_a_fence_with_an_index_has_the_margins_of_the_same_fence_without(seed, n_vertices, n_squares, n_circles):
    fence = random_fence(seed, n_vertices, n_squares, n_circles)
    indexed = fence.to_local(FENCE_FRAME, index=True)
    scanned = fence.to_local(FENCE_FRAME, index=False)
    assert indexed.grid() is not None and scanned.grid() is None
    rng = random.Random(seed)
    for e, n in probe_points(indexed, rng, 100):
        for env in (MC, FW):
            args, kw = random_margin_call(rng, e, n, env, bank_rad=0.7, wrap_heading=True, rollout=True)
            a, b = activation_margins(indexed, *args, **kw), activation_margins(scanned, *args, **kw)
            assert same_margins(a, b), (e, n, env.kind, a, b)
