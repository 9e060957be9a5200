"""geofence.physics.rooms: each fast form agrees with its reference form, and the upper bounds bound the rooms.

The per-step loop uses fast forms of the room formulas (precomputed turn
constants, one call per edge, an inlined skip-shortcut bound). Each is held to
the reference form next to it within 1e-9 relative, so the two cannot drift.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import geofence.estimation.wind_estimator as wind_estimator
import geofence.margins.boundary_shift as boundary_shift
import geofence.physics.dynamics as dynamics
from geofence.interface import Envelope, PlatformKind
from geofence.physics.control_laws import wrap_pi
from geofence.physics.rooms import (
    G_MPS2,
    TWO_PI,
    braking_room_m,
    climb_arrest_phase,
    fixed_wing_room_bound_m,
    fixed_wing_room_m,
    head_on_room_m,
    multicopter_stopping_distance_m,
    multirotor_room_m,
    reaction_arc_gap_m,
    reaction_arc_m,
    room_upper_bounds_fast_m,
    room_upper_bounds_m,
    tilt_accel_mps2,
    trochoid_excursion_m,
    turn_constants,
    turn_radius_m,
    turn_rate_radps,
    vertical_arrest_distance_m,
)

REL = 1e-9
ROOT = Path(__file__).resolve().parents[1]


def close(a: float, b: float, rel: float = REL) -> bool:
    """Equal within ``rel`` relative (and 1e-12 m absolute, for values near 0); both infinite counts as equal."""
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= rel * max(abs(a), abs(b)) + 1e-12


speeds = st.floats(1.0, 80.0)
banks = st.floats(0.1, 1.3)
angles = st.floats(-math.pi, math.pi)


def envelopes():
    """Random envelopes of both kinds (drag law identified or not; vertical acceleration up to above g)."""
    return st.builds(
        lambda kind, cruise, vmax_f, bank, climb, desc, brake, az, t_r, k1, k2: Envelope(
            kind,
            cruise,
            cruise * vmax_f,
            0.6 * cruise if kind is PlatformKind.FIXED_WING else 0.0,
            bank,
            0.4,
            1.0,
            climb,
            desc,
            brake,
            az,
            t_r,
            drag_linear_per_s=k1,
            drag_quadratic_per_m=k2,
        ),
        st.sampled_from(list(PlatformKind)),
        st.floats(3.0, 60.0),
        st.floats(1.0, 2.0),
        banks,
        st.floats(0.5, 8.0),
        st.floats(0.5, 8.0),
        st.floats(1.0, 10.0),
        st.floats(0.5, 15.0),
        st.floats(0.0, 1.5),
        st.sampled_from([0.0, 0.3, 0.6]),
        st.sampled_from([0.0, 0.01, 0.05]),
    )


# ------------------------------------------------------------------ one gravity
def test_one_gravity_constant():
    assert boundary_shift.G_MPS2 is dynamics.G_MPS2
    assert wind_estimator.G_MPS2 is dynamics.G_MPS2
    assert G_MPS2 is dynamics.G_MPS2
    assignment = re.compile(r"^\s*\w+(\s*:\s*\w+)?\s*=\s*9\.8", re.M)
    packages = ("aircraft", "analysis", "geofence", "scenarios", "wind")
    files = [p for pkg in packages for p in (ROOT / pkg).rglob("*.py")]
    defining = sorted(str(p.relative_to(ROOT)) for p in files if assignment.search(p.read_text()))
    assert defining == ["geofence/physics/dynamics.py"]
    literal = re.compile(r"[^\w.]9\.8\d*\s*\*|\*\s*9\.8|/\s*\(?9\.8")  # g written as a number in an expression
    assert sorted(str(p.relative_to(ROOT)) for p in files if literal.search(p.read_text())) == []


# ------------------------------------------------------------------ fixed-wing fast forms
@settings(max_examples=300, deadline=None)
@given(speeds, banks)
def test_turn_constants_match_radius_and_rate(v, bank):
    radius, inv_omega = turn_constants(v, bank)
    assert close(radius, turn_radius_m(v, bank))
    assert close(inv_omega, 1.0 / turn_rate_radps(v, bank))


@settings(max_examples=400, deadline=None)
@given(speeds, banks, angles, st.floats(-0.99, 1.2), st.floats(0.0, 3.0), angles)
def test_per_edge_fixed_wing_room_matches_the_reference(v, bank, psi0, u, t_r, normal_angle):
    """Reaction travel + trochoid excursion as the margin evaluates them per edge = :func:`fixed_wing_room_m`."""
    w = u * v
    radius, inv_omega = turn_constants(v, bank)
    nx, ny = math.cos(normal_angle), math.sin(normal_angle)
    psi_abs = normal_angle + psi0  # the air heading in ENU
    react = reaction_arc_m(v, psi_abs, 0.0, 0.0, t_r, nx, ny, w)
    psi_rel = wrap_pi(psi0)
    turn = min(trochoid_excursion_m(radius, inv_omega, v, w, psi_rel, s, None) for s in (1.0, -1.0))
    ref = fixed_wing_room_m(v, bank, psi0, w, t_r)
    if math.isinf(ref):
        assert react + turn == ref
    else:  # 1e-9 relative to the manoeuvre's scale (the room itself may cancel to ~0)
        assert abs(react + turn - ref) <= REL * max(ref, v * t_r, radius)


@settings(max_examples=200, deadline=None)
@given(st.floats(5.0, 80.0), banks, angles, st.floats(-1.0, 1.0), st.floats(0.05, 3.0), angles, st.floats(-10.0, 10.0))
def test_reaction_arc_matches_its_integral(v, bank, psi0, bank_frac, t, normal_angle, w_n):
    """The arc's closed form = the integral of ``V·cos(psi(t) - theta_n)`` (Simpson, 2000 panels)."""
    omega = turn_rate_radps(v, bank * bank_frac) if bank_frac else 0.0
    rot = omega * t
    nx, ny = math.cos(normal_angle), math.sin(normal_angle)
    n = 2000
    h = t / n
    f = [v * math.cos(psi0 - omega * i * h - normal_angle) for i in range(n + 1)]
    integral = h / 3.0 * (f[0] + f[-1] + 4.0 * sum(f[1:-1:2]) + 2.0 * sum(f[2:-1:2]))
    expected = max(integral + w_n * t, 0.0)
    # (below |rot| = 1e-6 the arc is taken straight: off by at most V·t·|rot|/2)
    assert reaction_arc_m(v, psi0, rot, omega, t, nx, ny, w_n) == pytest.approx(expected, rel=1e-7, abs=1e-6 * v * t + 1e-6)


@settings(max_examples=300, deadline=None)
@given(
    speeds,
    banks,
    angles,
    st.floats(-1.0, 1.0),
    st.floats(0.0, 3.0),
    angles,
    st.floats(0.0, 15.0),
    st.sampled_from([1.0, -1.0]),
    st.floats(0.0, TWO_PI),
    st.floats(0.3, 1.0),
)
def test_fixed_wing_bound_bounds_every_turn(v, bank, psi0, bank_frac, t, normal_angle, wind, s, delta, v_frac):
    """``2R + |W|·2pi/omega + (v + |W|)·t`` >= reaction travel + excursion for any turn of up to 2 pi."""
    v_turn = v_frac * v
    radius, inv_omega = turn_constants(v, bank)  # the bound at the larger speed
    r_turn, inv_turn = turn_constants(v_turn, bank)
    omega_now = turn_rate_radps(v_turn, bank * bank_frac) if bank_frac else 0.0
    nx, ny = math.cos(normal_angle), math.sin(normal_angle)
    w_n = wind * math.cos(normal_angle)
    room = reaction_arc_m(v_turn, psi0, omega_now * t, omega_now, t, nx, ny, w_n)
    room += trochoid_excursion_m(r_turn, inv_turn, v_turn, w_n, wrap_pi(psi0 - normal_angle), s, delta)
    assert room <= fixed_wing_room_bound_m(radius, inv_omega, v, wind, t) * (1 + 1e-12) + 1e-9


# ------------------------------------------------------------------ multirotor fast forms
@settings(max_examples=400, deadline=None)
@given(st.floats(-20.0, 30.0), st.floats(0.0, 30.0), st.floats(0.0, 2.0), st.floats(0.5, 10.0), st.floats(0.0, 12.0))
def test_multirotor_room_without_pilot_is_the_stopping_distance(v_n, speed, t_r, a_brake, push):
    """With no pilot acceleration and no climb arrest, the per-edge form = :func:`multicopter_stopping_distance_m`."""
    ref = multicopter_stopping_distance_m(v_n, t_r, a_brake, speed, push)
    assert close(multirotor_room_m(v_n, speed, t_r, 0.0, a_brake - push, (0.0, 0.0)), ref)


@settings(max_examples=300, deadline=None)
@given(
    st.floats(0.0, 30.0),
    st.floats(0.0, 1.0),
    st.floats(0.0, 2.0),
    st.floats(0.0, 8.0),
    st.floats(0.5, 10.0),
    st.floats(0.0, 6.0),
    st.floats(0.5, 9.0),
)
def test_braking_with_a_climb_arrest_matches_its_integral(v, frac, t_r, a_p, a_brake, v_up, a_z):
    """:func:`multirotor_room_m` = the integrated manoeuvre: accelerate ``t_r``, brake at ``a·(1 - a_z/g)`` while
    the climb is arrested, then at ``a`` (head-on, ``v_n = v``)."""
    v0 = v * frac
    arrest = climb_arrest_phase(v_up, a_z)
    # piecewise-constant acceleration, stepped exactly: the reaction, the arrest phase, the rest of the stop
    x = v0 * t_r + 0.5 * a_p * t_r * t_r
    u = v0 + a_p * t_r
    for a, duration in ((a_brake * (1.0 - arrest[1]), arrest[0]), (a_brake, math.inf)):
        step = min(duration, u / a)
        x += u * step - 0.5 * a * step * step
        u -= a * step
    assert multirotor_room_m(v0, v0, t_r, a_p, a_brake, arrest) == pytest.approx(x, rel=1e-9, abs=1e-12)


def test_braking_room_edge_cases():
    assert braking_room_m(3.0, 5.0, 0.0, (0.0, 0.0)) == math.inf
    assert braking_room_m(3.0, 5.0, 2.0, (0.0, 0.0)) == pytest.approx(3.0 * 5.0 / 4.0)
    assert climb_arrest_phase(-1.0, 4.0) == (0.0, 0.0)
    assert climb_arrest_phase(2.0, 4.0) == (0.5, 4.0 / G_MPS2)
    assert tilt_accel_mps2(math.radians(30.0)) == pytest.approx(G_MPS2 * math.tan(math.radians(30.0)))


# ------------------------------------------------------------------ the skip shortcut's bound
@settings(max_examples=500, deadline=None)
@given(envelopes(), st.floats(0.0, 80.0), st.floats(0.0, 80.0), st.floats(-10.0, 10.0), st.floats(0.0, 25.0), st.floats(0.0, 3.0))
def test_upper_bound_fast_form_matches_the_reference(env, gs, va, vu, w, t):
    fast = room_upper_bounds_fast_m(env, gs, va, vu, w, t)
    ref = room_upper_bounds_m(env, gs, va, vu, w, t)
    assert close(fast[0], ref[0]) and close(fast[1], ref[1]), (fast, ref)


@settings(max_examples=400, deadline=None)
@given(
    envelopes(),
    st.floats(0.0, 1.0),
    st.floats(-1.0, 1.0),
    st.floats(-10.0, 10.0),
    st.floats(0.0, 15.0),
    st.floats(0.0, 1.0),
    st.floats(0.0, 2.0),
)
def test_upper_bound_bounds_the_multirotor_room(env, speed_frac, normal_frac, vu, w, wn_frac, t):
    """The multirotor lateral bound >= the per-edge room for any closing speed, push, climb and shorter reaction."""
    if env.kind is not PlatformKind.MULTIROTOR:
        return
    speed = speed_frac * env.max_speed_mps
    lateral, vertical = room_upper_bounds_m(env, speed, speed, vu, w, t)
    k1, k2 = dynamics.drag_coefficients(env)
    push = dynamics.wind_push_mps2(k1, k2, w, wn_frac * w)
    room = multirotor_room_m(
        normal_frac * speed,
        speed,
        0.5 * t,
        tilt_accel_mps2(env.max_bank_rad) + push,
        env.braking_decel_mps2 - push,
        climb_arrest_phase(vu, env.vertical_accel_mps2),
    )
    assert room <= lateral * (1 + 1e-12) + 1e-9
    assert vertical_arrest_distance_m(abs(vu), 0.5 * t, env.vertical_accel_mps2, 0.0) <= vertical * (1 + 1e-12) + 1e-9


# ------------------------------------------------------------------ envelope-level rooms
@settings(max_examples=200, deadline=None)
@given(envelopes(), st.floats(0.5, 60.0), st.floats(-10.0, 10.0), st.floats(0.0, 12.0))
def test_head_on_room_is_the_closed_form(env, v, w_toward, w_speed):
    room = head_on_room_m(env, v, w_toward, w_speed)
    if env.kind is PlatformKind.FIXED_WING:
        assert room == fixed_wing_room_m(v, env.max_bank_rad, 0.0, w_toward, env.reaction_time_s)
    else:
        push = dynamics.wind_push_mps2(*dynamics.drag_coefficients(env), w_speed, w_toward)
        assert room == multicopter_stopping_distance_m(v, env.reaction_time_s, env.braking_decel_mps2, v, push)


@settings(max_examples=300, deadline=None)
@given(
    v=st.floats(5.0, 80.0),
    psi0=st.floats(-math.pi, math.pi),
    bank=st.floats(-0.8, 0.8),
    t=st.floats(0.1, 4.0),
    theta=st.floats(-math.pi, math.pi),
    w_n=st.floats(-40.0, 40.0),
)
def test_the_reaction_arc_gap_is_its_farthest_point_beyond_its_end(v, psi0, bank, t, theta, w_n):
    """``reaction_arc_m + reaction_arc_gap_m`` is the farthest the reaction arc gets along the normal (the arc sampled
    finely, the rotation clipped to pi as the margin clips it), and the gap is 0 where the end is the farthest."""
    omega = turn_rate_radps(v, bank) if abs(bank) > 1e-9 else 1e-12
    rot = max(-math.pi, min(math.pi, omega * t))
    nx, ny = math.cos(theta), math.sin(theta)
    end = reaction_arc_m(v, psi0, rot, omega, t, nx, ny, w_n)
    gap = reaction_arc_gap_m(v, psi0, rot, omega, t, nx, ny, w_n)
    assert gap >= 0.0
    a = psi0 - theta
    if abs(rot) < 1e-6:
        sampled = max(0.0, (v * math.cos(a) + w_n) * t)
    else:
        sampled = max(
            max(0.0, (v / omega) * (math.sin(a) - math.sin(a - rot * k / 4000)) + w_n * t * k / 4000) for k in range(4001)
        )
    assert end + gap == pytest.approx(sampled, abs=1e-6 * (1.0 + v * t + abs(w_n) * t))
