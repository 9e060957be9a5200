"""The mission autopilot's fixed-wing course law: a reversal keeps the direction it began in."""

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from aircraft.profile import load_profile
from geofence.interface import VehicleState
from scenarios.flight.pilots.mission import TURN_COMMIT_RAD
from scenarios.flight.pilots.nav_laws import FixedWingNavigator

TERN = load_profile("Tern").envelope


def flying(course_deg: float, speed_mps: float = 20.0) -> VehicleState:
    c = math.radians(course_deg)
    return VehicleState(v_east_mps=speed_mps * math.sin(c), v_north_mps=speed_mps * math.cos(c), yaw_rad=c, up_m=80.0, agl_m=80.0)


def bank_stick(nav: FixedWingNavigator, s: VehicleState, course_cmd_rad: float) -> float:
    """The roll stick the navigator flies toward ``course_cmd_rad`` (height held, at cruise)."""
    return nav.sticks(s, course_cmd_rad, s.up_m, TERN.cruise_speed_mps).roll


def test_without_commitment_a_reversal_flips_with_the_track():
    nav = FixedWingNavigator(TERN)
    # commanded course 180 deg: from a track of 5 deg the short way is right, from -5 deg it is left
    assert bank_stick(nav, flying(5.0), math.pi) > 0.0
    assert bank_stick(nav, flying(-5.0), math.pi) < 0.0


@settings(max_examples=200, deadline=None)
@given(start=st.floats(-20.0, 20.0), swings=st.lists(st.floats(-25.0, 25.0), min_size=1, max_size=12))
def test_a_committed_reversal_never_rolls_the_other_way_while_the_error_stays_large(start, swings):
    """Whatever the track does while the course error stays beyond the commitment angle, the bank keeps its sign."""
    nav = FixedWingNavigator(TERN, turn_commit_rad=TURN_COMMIT_RAD)
    first = bank_stick(nav, flying(start), math.pi)
    for track in swings:
        err = math.remainder(math.pi - math.radians(track), 2.0 * math.pi)
        stick = bank_stick(nav, flying(track), math.pi)
        if abs(err) > TURN_COMMIT_RAD:
            assert stick * first > 0.0
        else:
            break  # below the commitment angle the law is the plain one again


def test_commitment_ends_when_the_error_is_small_again():
    nav = FixedWingNavigator(TERN, turn_commit_rad=TURN_COMMIT_RAD)
    assert bank_stick(nav, flying(5.0), math.pi) > 0.0  # begins to the right
    assert bank_stick(nav, flying(90.0), math.pi) > 0.0  # well into the turn
    # the error fell below the commitment angle there, so a new reversal from the other side starts afresh:
    # the short way, to the left (a committed law would still roll right)
    assert bank_stick(nav, flying(-5.0), math.pi) < 0.0
