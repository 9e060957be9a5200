"""A pilot's compiled law (:mod:`scenarios.flight.pilots.law_kernel`) against its objects: the sticks
:func:`law_sticks` flies from a scripted pilot's law array are the sticks the pilot's own ``command`` sends,
bit for bit, compiled or not, for any state and course segment (fixed-wing courses at any speed and climb, raw
sticks); a multirotor's course segment leaves its sticks to its navigator."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence import jit
from geofence.interface import Envelope, PlatformKind, VehicleState
from scenarios.definition.schema import ScriptSegment
from scenarios.flight.pilots import CompiledLawPilot
from scenarios.flight.pilots import law_kernel as lk
from scenarios.flight.pilots.scripted import ScriptedPilot

TERN = Envelope(
    PlatformKind.FIXED_WING, 16.0, 24.0, 12.0, math.radians(40), math.radians(25), math.radians(28), 5.0, 3.0, 0.6, 5.0, 1.1
)
QUAD = Envelope(
    PlatformKind.MULTIROTOR, 8.0, 15.0, 0.0, math.radians(30), math.radians(30), math.radians(90), 3.0, 2.0, 5.6, 4.5, 0.25
)
compiled_law = jit.numba.njit(lk.law_sticks) if jit.COMPILED else None


def _state(t, e, n, up, ve, vn, vu, yaw):
    return VehicleState(
        t_s=t, east_m=e, north_m=n, up_m=up, agl_m=up, alt_m=100.0 + up, v_east_mps=ve, v_north_mps=vn, v_up_mps=vu,
        yaw_rad=yaw, airspeed_mps=math.hypot(ve, vn),
    )  # fmt: skip


speed = st.floats(-40.0, 40.0, allow_nan=False)
course_segment = st.builds(
    ScriptSegment,
    duration_s=st.just(5.0),
    course_deg=st.floats(0.0, 360.0),
    speed=st.sampled_from(["max", "cruise", "min"]),
    climb=st.sampled_from(["hold", "max", "descend"]),
)
stick = st.floats(-1.0, 1.0)
raw_segment = st.builds(ScriptSegment, duration_s=st.just(5.0), sticks=st.tuples(stick, stick, stick, stick))


@settings(max_examples=150, deadline=None)
@given(
    segments=st.lists(course_segment | raw_segment, min_size=1, max_size=3),
    start_up=st.floats(0.0, 300.0),
    steps=st.lists(
        st.tuples(st.floats(-500, 500), st.floats(-500, 500), st.floats(0.0, 300.0), speed, speed, st.floats(-5, 5),
                  st.floats(-4.0, 4.0)),
        min_size=1, max_size=6,
    ),
)  # fmt: skip
def test_a_scripted_fixed_wing_law_array_flies_the_pilots_sticks(segments, start_up, steps):
    start = _state(0.0, 0.0, 0.0, start_up, 0.0, 20.0, 0.0, 0.0)
    pilot = ScriptedPilot(tuple(segments), TERN, start, 0.025)
    twin = ScriptedPilot(tuple(segments), TERN, start, 0.025)
    assert isinstance(pilot, CompiledLawPilot)
    for k, (e, n, up, ve, vn, vu, yaw) in enumerate(steps):
        s = _state(2.0 * k, e, n, up, ve, vn, vu, yaw)  # (a new segment every few steps)
        expected = pilot.command(s)
        assert twin.decide(s) is None  # every fixed-wing segment has a compiled law
        A = twin.law_array()
        got = lk.law_sticks(A, ve, vn, yaw, up)
        assert tuple(map(float, got)) == tuple(map(float, expected))
        if compiled_law is not None:
            assert compiled_law(A, ve, vn, yaw, up) == tuple(map(float, expected))


def test_a_multirotor_course_is_its_navigators_and_raw_sticks_are_held():
    start = _state(0.0, 0.0, 0.0, 20.0, 0.0, 0.0, 0.0, 0.0)
    segments = (
        ScriptSegment(duration_s=5.0, course_deg=90.0, speed="max", climb="hold"),
        ScriptSegment(duration_s=5.0, sticks=(0.5, -0.25, 0.0, 0.75)),
    )
    pilot = ScriptedPilot(segments, QUAD, start, 0.025)
    twin = ScriptedPilot(segments, QUAD, start, 0.025)
    s = _state(1.0, 0.0, 0.0, 20.0, 3.0, 0.0, 0.0, 0.0)
    assert twin.decide(s) == pilot.command(s)  # the velocity loop: the navigator's (its integrator is there)
    assert lk.law_kind(twin.law_array()) == lk.GIVEN
    s = _state(6.0, 0.0, 0.0, 20.0, 3.0, 0.0, 0.0, 0.0)
    assert twin.decide(s) is None
    assert lk.law_sticks(twin.law_array(), 3.0, 0.0, 0.0, 20.0) == pytest.approx(pilot.command(s), abs=0.0)
