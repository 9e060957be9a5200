"""The scripted pilot: each segment's demands are latched when it starts, and its end is found in time."""

import pytest

from aircraft.profile import load_profile
from geofence.interface import StickCommand, VehicleState
from scenarios.flight.pilots.scripted import ScriptedPilot
from scenarios.spec.schema import ScriptSegment

DT = 0.025
SEGMENTS = (
    ScriptSegment(duration_s=1.0, sticks=(0.2, -0.3, 0.1, 0.4)),
    ScriptSegment(duration_s=1.0, course_deg=90.0, speed="max", climb="max"),
    ScriptSegment(duration_s=1.0, course_deg=0.0, speed="cruise", climb="hold"),
)


def state(t: float, up_m: float) -> VehicleState:
    return VehicleState(t_s=t, up_m=up_m, agl_m=up_m, v_north_mps=15.0, airspeed_mps=15.0)


@pytest.mark.parametrize("model", ["Tern", "F450"])
def test_segments_follow_in_time_with_their_own_demands(model):
    env = load_profile(model).envelope
    pilot = ScriptedPilot(SEGMENTS, env, state(0.0, 50.0), DT)
    commands: dict[int, list[StickCommand]] = {0: [], 1: [], 2: []}
    for k in range(200):  # 5 s: the last segment is kept after its duration
        t = k * DT
        # 50 m until after the third segment starts (the height it holds), then 10 m below it
        cmd = pilot.command(state(t, 50.0 if t < 2.5 else 40.0))
        commands[pilot.items_reached].append(cmd)
        assert isinstance(cmd, StickCommand)
    assert [len(c) for c in commands.values()] == [40, 40, 120]
    assert set(commands[0]) == {StickCommand(0.2, -0.3, 0.1, 0.4)}  # raw sticks, as given
    climb_stick = commands[1][-1].throttle if env.is_multirotor else commands[1][-1].pitch
    assert climb_stick > 0.9  # climb: max
    hold_stick = commands[2][-1].throttle if env.is_multirotor else commands[2][-1].pitch
    assert hold_stick > 0.0  # below the height latched at the segment's start: climb back
    assert not pilot.finished
