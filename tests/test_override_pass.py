"""An override's hand-back decision, written once (:func:`geofence.unit.passes.hand_back`, which both
:meth:`geofence.unit.geofence_unit.GeofenceUnit.update` and the compiled override step, :func:`~geofence.unit.passes.no_hand_back`,
ask), against its rule; and the vertical hysteresis at a goal short of the band
(:func:`~geofence.unit.passes.vertical_handback_m`) against its closed form."""

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from geofence.physics.rooms import vertical_arrest_distance_m
from geofence.unit.passes import hand_back, vertical_handback_m

near = st.floats(-3.0, 12.0)  # round the hysteresis thresholds (5 m lateral)


@settings(max_examples=400, deadline=None)
@given(
    climb_back=st.none() | st.floats(0.0, 60.0),
    h=st.floats(0.0, 150.0),
    vertical_ok=st.booleans(),
    lateral=near,
    closing=st.floats(-3.0, 3.0),
    margin=st.floats(0.0, 10.0),
    distance=st.floats(0.0, 100.0),
    radius=st.floats(0.0, 50.0),
)
def test_the_hand_back_follows_its_rule(climb_back, h, vertical_ok, lateral, closing, margin, distance, radius):
    """Below the climb-back height: neither; at or above it the climb is done. Then: back only with the vertical
    hysteresis met and either the lateral one (the margin, not closing) or the recovery point reached."""
    climbed, ok = hand_back(
        math.nan if climb_back is None else climb_back, h, vertical_ok, lateral, closing, margin, distance, radius
    )
    if climb_back is not None and h < climb_back:
        assert not climbed and not ok
        return
    assert climbed == (climb_back is not None)
    lateral_ok = lateral >= margin and closing <= 0.0
    assert ok == (vertical_ok and (lateral_ok or distance <= radius))


@settings(max_examples=300, deadline=None)
@given(
    floor=st.none() | st.floats(5.0, 30.0),
    band=st.floats(2.0, 120.0),
    goal=st.none() | st.floats(0.0, 150.0),
    hysteresis=st.floats(0.1, 10.0),
    reaction=st.floats(0.2, 2.0),
    accel=st.floats(0.5, 5.0),
    climb=st.floats(1.0, 6.0),
    descent=st.floats(1.0, 6.0),
    uncertainty=st.floats(0.0, 10.0),
)
def test_the_vertical_hysteresis_is_half_the_room_at_rest_at_a_goal_short_of_the_band(
    floor, band, goal, hysteresis, reaction, accel, climb, descent, uncertainty
):
    """The configured hysteresis for a goal in the band (NaN); for a goal short of it, the smaller of that and half
    the vertical room at rest there (the ceiling's and floor's arrest distances from 0 m/s and the uncertainty
    off), never below 0."""
    ceiling = (floor or 0.0) + band
    got = vertical_handback_m(
        hysteresis, math.nan if goal is None else goal, ceiling, math.nan if floor is None else floor, reaction, accel,
        climb, descent, uncertainty,
    )  # fmt: skip
    if goal is None:
        assert got == hysteresis
        return
    rest = ceiling - goal - vertical_arrest_distance_m(0.0, reaction, accel, climb)
    if floor is not None:
        rest = min(rest, goal - floor - vertical_arrest_distance_m(0.0, reaction, accel, descent))
    rest -= uncertainty
    want = hysteresis if not rest > 0.0 else min(hysteresis, 0.5 * rest)
    assert math.isclose(got, want, rel_tol=1e-12, abs_tol=1e-12)
    assert 0.0 < got <= hysteresis
