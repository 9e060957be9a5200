"""The breach-attempts pilot on both platforms: its schema (bearings, down, pilot kinds), the direction type, and
short closed-loop flights (a fixed-wing rolls out of its orbit onto the bearing and is turned away by the
geofence; a multirotor's ``down`` attempt descends in place)."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence.geometry.geodesy import LocalFrame
from geofence.interface import VehicleState
from geofence.validation import ConfigError
from scenarios.definition.schema import (
    BreachAttemptsConfig,
    BreachDirection,
    PilotKind,
    VerticalSense,
    parse_scenario,
)
from scenarios.flight.pilots import build_pilot
from scenarios.flight.pilots.breach_attempts import BreachAttemptsPilot, PushEnd
from scenarios.flight.pilots.breach_attempts_fixedwing import FixedWingBreachAttemptsPilot
from scenarios.flight.runner import fly

SITE = {"lat_deg": -35.363262, "lon_deg": 149.165237, "ground_alt_m": 584.0}
FRAME = LocalFrame(SITE["lat_deg"], SITE["lon_deg"], SITE["ground_alt_m"])


def doc(aircraft="F450", agl_m=10.0, heading_deg=0.0, duration_s=20.0, **pilot):
    return {
        "aircraft": aircraft,
        "duration_s": duration_s,
        "seed": 2,
        "start": dict(SITE, agl_m=agl_m, heading_deg=heading_deg),
        "pilot": {"type": "breach_attempts", **pilot},
    }


def breach_of(document):
    sc = parse_scenario(document, "ba.yaml")
    assert sc.pilot.kind is PilotKind.BREACH_ATTEMPTS
    return sc.pilot.breach


def angle_between_rad(a, b):
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


# --------------------------------------------------------------------------- schema
def test_bearings_and_down_parse_beside_the_names():
    cfg = breach_of(doc(directions=[20, -90, 450.5, "down", "west", "up", 0]))
    d = cfg.directions
    assert d == ("bearing 20", "bearing 270", "bearing 90.5", "down", "west", "up", "bearing 0")
    assert [x.bearing_rad for x in d[:3]] == pytest.approx([math.radians(20), math.radians(270), math.radians(90.5)])
    assert d[3].vertical is VerticalSense.DOWN and d[3].bearing_rad is None and d[3].is_vertical
    assert d[5].vertical is VerticalSense.UP
    assert all(x.vertical is VerticalSense.LEVEL for x in (d[0], d[1], d[2], d[4], d[6]))
    assert cfg.direction(7) is d[0]  # the list repeats


def test_the_names_keep_their_exact_axes():
    """The seed flights' names: the same strings, pushing exactly along the axes (no sin/cos rounding)."""
    cfg = breach_of(doc(directions=["north", "east", "south", "west", "up"]))
    assert cfg.directions == ("north", "east", "south", "west", "up")
    assert [x.unit_en for x in cfg.directions] == [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0), (0.0, 0.0)]
    assert BreachAttemptsConfig(directions=("west", "north", "up")) == BreachAttemptsConfig()  # Python names still work
    assert all(type(x) is BreachDirection for x in BreachAttemptsConfig(directions=("west", 33.0)).directions)


@pytest.mark.parametrize(
    "aircraft, pilot, field, problem",
    [
        ("F450", {"directions": ["west", "nw"]}, "pilot.directions[1]", "'nw' is not one of north, east, south, west, up, down"),
        ("F450", {"directions": [True]}, "pilot.directions[0]", "expected one of north"),
        ("F450", {"directions": [[90]]}, "pilot.directions[0]", "expected one of north"),
        ("F450", {"directions": ["90"]}, "pilot.directions[0]", "or a bearing in degrees"),
        ("F450", {"directions": [float("nan")]}, "pilot.directions[0]", "must be a finite number"),
        ("F450", {"directions": [float("inf")]}, "pilot.directions[0]", "must be a finite number"),
        ("F450", {"directions": []}, "pilot.directions", "non-empty list"),
        ("F450", {"directions": "west"}, "pilot.directions", "non-empty list"),
        ("F450", {"speed_mps": [2.0, 1.0]}, "pilot.speed_mps[1]", ">= 2"),
        ("F450", {"speed_mps": [0.0, 1.0]}, "pilot.speed_mps[0]", "> 0"),
        ("F450", {"speed_mps": [1.0, 31.0]}, "pilot.speed_mps[1]", "<= 30"),
        ("Tern", {"speed_mps": [14.0, 101.0]}, "pilot.speed_mps[1]", "<= 100"),
        ("Tern", {"speed_mps": [14.0, "fast"]}, "pilot.speed_mps[1]", "expected a number"),
        ("Tern", {"speed_mps": 16}, "pilot.speed_mps", "expected [low, high]"),
        ("Tern", {"push_m": 0}, "pilot.push_m", "> 0"),
        ("Tern", {"home_agl_m": -5}, "pilot.home_agl_m", "> 0"),
        ("Tern", {"bearing": 20}, "pilot.bearing", "unknown key"),
    ],
)
def test_bad_breach_settings_are_one_line_errors_naming_the_field(aircraft, pilot, field, problem):
    with pytest.raises(ConfigError) as info:
        parse_scenario(doc(aircraft, agl_m=60.0, **pilot), "ba.yaml")
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"ba.yaml: {field}: "), message
    assert problem in message, message


def test_pilot_type_is_an_enum_with_a_one_line_error():
    assert parse_scenario(doc(), "ba.yaml").pilot.kind is PilotKind.BREACH_ATTEMPTS
    scripted = doc()
    scripted["pilot"] = {"type": "scripted", "segments": [{"duration_s": 1, "course_deg": 0}]}
    assert parse_scenario(scripted, "s.yaml").pilot.kind is PilotKind.SCRIPTED
    with pytest.raises(ConfigError, match=r"^s\.yaml: pilot\.type: 'breach' is not one of mission, scripted, breach_attempts$"):
        parse_scenario({**scripted, "pilot": {"type": "breach"}}, "s.yaml")


def test_fixed_wing_defaults_are_its_own():
    tern = breach_of(doc("Tern", agl_m=70.0))
    assert tern.speed_mps == (16.0, 24.0)  # the Tern's cruise and max speed
    assert tern.push_m == 400.0 and tern.rest_s == 10.0
    assert tern.home_agl_m == 70.0  # an air start: home at the start height
    assert breach_of(doc("Tern", agl_m=0.0)).home_agl_m == 60.0
    assert breach_of(doc("F450")) == BreachAttemptsConfig()  # a multirotor keeps the indoor quad's
    given_ = breach_of(doc("Tern", agl_m=70.0, speed_mps=[14, 20], push_m=250, home_agl_m=50))
    assert (given_.speed_mps, given_.push_m, given_.home_agl_m) == ((14.0, 20.0), 250.0, 50.0)


def test_build_pilot_picks_the_platform_s_pilot():
    for aircraft, cls in (("F450", BreachAttemptsPilot), ("Tern", FixedWingBreachAttemptsPilot)):
        sc = parse_scenario(doc(aircraft, agl_m=60.0), "ba.yaml")
        env = sc.profile.envelope
        pilot = build_pilot(sc, FRAME, env, VehicleState(up_m=60.0, agl_m=60.0), 0.025)
        assert type(pilot) is cls
    tern = parse_scenario(doc("Tern", agl_m=60.0), "ba.yaml")
    with pytest.raises(ValueError, match="multirotors"):
        BreachAttemptsPilot(tern.pilot.breach, tern.profile.envelope, VehicleState(), 0.025)
    fw = FixedWingBreachAttemptsPilot(tern.pilot.breach, tern.profile.envelope, VehicleState(), 0.025)
    # the home orbit: 1.5 turn radii at cruise (16^2 / (g tan 40 deg) = 31.1 m), at least 30 m
    assert fw.orbit_radius_m == pytest.approx(1.5 * 16.0**2 / (9.80665 * math.tan(math.radians(40.0))), rel=1e-3)
    # airspeeds clipped to [1.1 min, max] = [13.2, 24]; climbs and descents capped by the envelope
    cfg = BreachAttemptsConfig(attempts=4, directions=("north", 90.0, "up", "down"), speed_mps=(30.0, 30.0))
    fw = FixedWingBreachAttemptsPilot(cfg, tern.profile.envelope, VehicleState(), 0.025)
    assert [fw.speed(k) for k in range(4)] == [24.0, 24.0, 5.0, 3.0]
    slow = FixedWingBreachAttemptsPilot(
        BreachAttemptsConfig(attempts=1, directions=(10.0,), speed_mps=(1.0, 1.0)), tern.profile.envelope, VehicleState(), 0.025
    )
    assert slow.speed(0) == pytest.approx(13.2)


def test_a_multirotor_returns_home_at_its_slowest_push_speed():
    """Indoors (the seed flights) 0.4 m/s within 15 s; outdoors the slowest push speed, with time to fly back."""
    f450 = parse_scenario(doc("F450"), "ba.yaml").profile.envelope
    indoor = BreachAttemptsPilot(BreachAttemptsConfig(speed_mps=(0.2, 1.0), push_m=1.5), f450, VehicleState(), 0.025)
    assert indoor.return_speed_mps == pytest.approx(0.4) and indoor.return_max_s == pytest.approx(15.0)
    outdoor = BreachAttemptsPilot(BreachAttemptsConfig(speed_mps=(5.0, 10.0), push_m=120.0), f450, VehicleState(), 0.025)
    assert outdoor.return_speed_mps == pytest.approx(5.0)
    assert outdoor.return_max_s >= 2.0 * 120.0 / 5.0


# --------------------------------------------------------------------------- the direction type
@given(st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False))
@settings(max_examples=300, deadline=None)
def test_a_bearing_s_push_is_a_unit_vector_and_round_trips(bearing_deg):
    d = BreachDirection.of(bearing_deg)
    assert not d.is_vertical and d.vertical is VerticalSense.LEVEL
    assert 0.0 <= d.bearing_rad < 2.0 * math.pi
    e, n, u = d.unit_enu
    assert math.hypot(e, n, u) == pytest.approx(1.0, abs=1e-12) and u == 0.0
    assert angle_between_rad(math.atan2(e, n), d.bearing_rad) < 1e-9  # the vector points along the bearing
    assert angle_between_rad(d.bearing_rad, math.radians(bearing_deg)) < 1e-9  # the bearing given, mod 360
    again = BreachDirection.of(math.degrees(d.bearing_rad))
    assert angle_between_rad(again.bearing_rad, d.bearing_rad) < 1e-9
    copy = pickle.loads(pickle.dumps(d))
    assert copy == d and copy.bearing_rad == d.bearing_rad and copy.unit_enu == d.unit_enu


@given(st.sampled_from(["up", "down"]))
def test_a_vertical_push_is_a_unit_vector_straight_up_or_down(name):
    d = BreachDirection.of(name)
    assert d == name and d.bearing_rad is None and d.is_vertical
    assert d.unit_enu == (0.0, 0.0, 1.0 if name == "up" else -1.0)


# --------------------------------------------------------------------------- closed loop
@pytest.mark.closed_loop
def test_fixed_wing_rolls_out_of_its_orbit_onto_the_bearing_and_pushes():
    """From the start (the orbit's centre, heading east) the Tern joins its orbit, rolls out on 200 deg and
    flies straight along it at the drawn airspeed, the height held."""
    res = fly(
        parse_scenario(doc("Tern", agl_m=60.0, heading_deg=90.0, directions=[200], speed_mps=[18, 18], push_m=300), "fw.yaml")
    )
    log = res.pilot.attempt_log
    assert type(res.pilot) is FixedWingBreachAttemptsPilot and len(log) == 1
    a = log[0]
    assert a["direction"] == "bearing 200" and a["speed_mps"] == 18.0
    assert a["t_start_s"] <= a["t_push_start_s"] < 10.0
    r = res.recorder
    t = r.column("time_s")
    push = (t >= a["t_push_start_s"]) & (t < a.get("t_push_end_s", math.inf))
    assert t[push][-1] - t[push][0] > 8.0
    course = np.arctan2(r.column("v_east_mps")[push], r.column("v_north_mps")[push])
    off_deg = np.degrees(np.abs((course - math.radians(200.0) + math.pi) % (2 * math.pi) - math.pi))
    assert off_deg.max() < 15.0, off_deg.max()
    e, n = r.column("east_m")[push], r.column("north_m")[push]
    ue, un = math.sin(math.radians(200.0)), math.cos(math.radians(200.0))
    travel = (e[-1] - e[0]) * ue + (n[-1] - n[0]) * un
    assert travel > 100.0  # pushing, not orbiting
    assert np.abs(r.column("agl_m")[push] - 60.0).max() < 5.0
    assert r.column("airspeed_mps")[push][-40:].mean() == pytest.approx(18.0, abs=1.0)
    # before the roll-out it was orbiting the start point at the orbit's radius
    joined = (t > a["t_start_s"]) & (t < a["t_push_start_s"])
    d = np.hypot(r.column("east_m")[joined], r.column("north_m")[joined])
    assert np.abs(d - res.pilot.orbit_radius_m).max() < 0.2 * res.pilot.orbit_radius_m + 1.0


@pytest.mark.closed_loop
def test_fixed_wing_lets_go_when_the_geofence_turns_it_away():
    """The same push at a fence edge 200 m away: the geofence turns the Tern before the line and the pilot
    lets go (``turned away``), then heads back for its orbit."""
    corners = [(-400.0, -200.0), (400.0, -200.0), (400.0, 400.0), (-400.0, 400.0)]
    document = doc("Tern", agl_m=60.0, heading_deg=90.0, directions=[180], speed_mps=[20, 20], push_m=600)
    document["geofence"] = {"fence": {"keep_in": [list(FRAME.to_geodetic(e, n, 0.0)[:2]) for e, n in corners], "ceiling_m": 120}}
    res = fly(parse_scenario(document, "fw-fence.yaml"))
    a = res.pilot.attempt_log[0]
    s = res.summary
    assert s["activations"] >= 1 and s["max_excursion_m"] < 0.0
    assert a["push_end"] == PushEnd.TURNED_AWAY, a
    assert res.pilot.phase in (res.pilot.RETURN, res.pilot.REST)
    first_override = s["mode_transitions"][0]["t_s"]
    assert a["t_push_start_s"] < first_override < a["t_push_end_s"]


@pytest.mark.closed_loop
def test_multirotor_down_attempt_descends_with_the_position_held():
    res = fly(
        parse_scenario(
            doc(
                "F450RD",
                agl_m=10.0,
                duration_s=16.0,
                attempts=1,
                directions=["down"],
                speed_mps=[1.0, 1.0],
                push_m=4.0,
                home_agl_m=10.0,
            ),
            "down.yaml",
        )
    )
    a = res.pilot.attempt_log[0]
    assert a["direction"] == "down" and a["push_end"] == PushEnd.TRAVEL, a
    r = res.recorder
    t = r.column("time_s")
    push = (t >= a["t_start_s"]) & (t <= a["t_push_end_s"])
    agl = r.column("agl_m")[push]
    assert agl[0] - agl.min() >= 3.9  # it went down the 4 m it meant to
    steady = push & (t >= a["t_start_s"] + 1.5)
    assert r.column("v_up_mps")[steady].mean() == pytest.approx(-1.0, abs=0.15)  # at the drawn rate
    e, n = r.column("east_m")[push], r.column("north_m")[push]
    assert np.hypot(e - e[0], n - n[0]).max() < 0.5  # in place
    assert r.column("agl_m")[-1] == pytest.approx(10.0, abs=0.5)  # and back home afterwards
