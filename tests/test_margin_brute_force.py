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
"""

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from aircraft.profile import load_profile
from geofence.boundary_shift import activation_margins
from geofence.config import parse_geofence
from geofence.dynamics import G_MPS2, drag_coefficients, wind_push_mps2
from geofence.geodesy import LocalFrame

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
