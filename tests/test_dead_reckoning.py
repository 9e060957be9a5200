"""Dead reckoning starts from the last fix's own time and replays the attitude seen since."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aircraft.profile import load_profile
from geofence.estimation.dead_reckoning import DeadReckoning
from geofence.interface import FixState, VehicleState

MC = load_profile("F450RD").envelope


def tilted(t_s: float, pitch_deg: float, roll_deg: float = 0.0, yaw_deg: float = 30.0) -> VehicleState:
    return VehicleState(
        t_s=t_s, pitch_rad=math.radians(pitch_deg), roll_rad=math.radians(roll_deg), yaw_rad=math.radians(yaw_deg)
    )


@settings(max_examples=100, deadline=None)
@given(
    pitches=st.lists(st.floats(-35.0, 35.0), min_size=1, max_size=20),
    v0=st.tuples(st.floats(-8.0, 8.0), st.floats(-8.0, 8.0)),
    wind=st.tuples(st.floats(-6.0, 6.0), st.floats(-6.0, 6.0)),
)
def test_a_replay_from_the_fix_is_the_steps_it_would_have_taken(pitches, v0, wind):
    fix = FixState(1.0, 3.0, -2.0, v0[0], v0[1])
    history = [tilted(1.0 + 0.025 * (i + 1), p) for i, p in enumerate(pitches)]
    replayed = DeadReckoning(MC)
    replayed.start_at_fix(fix, [tilted(0.9, 0.0), tilted(1.0, 0.0)] + history, wind)  # not after the fix: skipped
    stepped = DeadReckoning(MC)
    stepped.start(VehicleState(t_s=1.0, east_m=3.0, north_m=-2.0, v_east_mps=v0[0], v_north_mps=v0[1]))
    for s in history:
        stepped.step(s, 0.025, wind)
    assert replayed.active
    got = (replayed.e, replayed.n, replayed.ve, replayed.vn)
    assert got == pytest.approx((stepped.e, stepped.n, stepped.ve, stepped.vn), abs=1e-9)  # dt from time differences


def test_a_brake_seen_since_the_fix_reverses_the_velocity():
    """6 m/s north at the fix, then 1 s nose-up 40 deg (heading north): the replay ends going south, where the
    extrapolated estimate would still say 6 m/s north."""
    dr = DeadReckoning(MC)
    history = [tilted(1.0 + 0.025 * (i + 1), 40.0, yaw_deg=0.0) for i in range(40)]
    dr.start_at_fix(FixState(1.0, 0.0, 0.0, 0.0, 6.0), history, (0.0, 0.0))
    assert dr.vn < 0.0 and abs(dr.ve) < 1e-9
