"""The scripted pilot: each segment's demands are latched when it starts, and its end is found in time."""

import pytest

from aircraft.profile import load_profile
from geofence.interface import StickCommand, VehicleState
from scenarios.definition.schema import ScriptSegment
from scenarios.flight.pilots.scripted import ScriptedPilot

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
    commands: dict[int, list[StickCommand]] = {0: [], 1: [], 2: [], 3: []}
    for k in range(200):  # 5 s: the last segment is kept after its duration (then counted: 3 of 3)
        t = k * DT
        # 50 m until after the third segment starts (the height it holds), then 10 m below it
        cmd = pilot.command(state(t, 50.0 if t < 2.5 else 40.0))
        commands[pilot.items_reached].append(cmd)
        assert isinstance(cmd, StickCommand)
    assert [len(c) for c in commands.values()] == [40, 40, 40, 80]
    assert set(commands[0]) == {StickCommand(0.2, -0.3, 0.1, 0.4)}  # raw sticks, as given
    climb_stick = commands[1][-1].throttle if env.is_multirotor else commands[1][-1].pitch
    assert climb_stick > 0.9  # climb: max
    hold_stick = commands[3][-1].throttle if env.is_multirotor else commands[3][-1].pitch
    assert hold_stick > 0.0  # below the height latched at the segment's start: climb back (the last, kept)
    assert pilot.finished


@pytest.mark.parametrize("model", ["Tern", "F450"])
def test_a_script_run_to_its_end_counts_its_last_segment(model):
    """Issue 41: a script that ran to its end reported ``segments 1/2`` and ``mission_finished: false``."""
    env = load_profile(model).envelope
    segments = SEGMENTS[:2]  # 2 s in all, as a scenario whose duration_s is their sum
    pilot = ScriptedPilot(segments, env, state(0.0, 50.0), DT)
    n_steps = round(2.0 / DT)
    for k in range(n_steps):  # every step before the last
        pilot.command(state(k * DT, 50.0))
    assert (pilot.items_reached, pilot.finished) == (1, False)  # the last segment is still being flown
    pilot.command(state(n_steps * DT, 50.0))  # the flight's last step: the last segment's duration has passed
    assert (pilot.items_reached, pilot.items_total, pilot.finished) == (2, 2, True)
