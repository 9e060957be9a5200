"""The geofence in closed loop: adversarial pilots never get either platform across the fence.

An adversarial pilot flies straight at each keep-in edge at full speed, or
climbs at max toward the ceiling, in calm air and in 8 m/s wind from the worst
direction (a tailwind toward the edge). The geofence must activate before the
line, keep the truth trajectory inside the keep-in polygon and below the
ceiling, and hand control back afterwards.
"""

import math
from pathlib import Path

import pytest

from geofence.geometry.geodesy import LocalFrame
from scenarios.definition.schema import parse_scenario
from scenarios.flight.runner import fly

pytestmark = pytest.mark.closed_loop

ROOT_SCENARIOS = Path(__file__).parents[1] / "scenarios"
SITE = {"lat_deg": -35.363262, "lon_deg": 149.165237, "ground_alt_m": 584.0}
FRAME = LocalFrame(SITE["lat_deg"], SITE["lon_deg"], SITE["ground_alt_m"])
# per platform: fence half-size (m), start height AGL (m), ceiling (m)
PLATFORMS = {"F450": (150.0, 20.0, 60.0), "Tern": (300.0, 60.0, 100.0)}


def box(half_m):
    corners = [(-half_m, -half_m), (half_m, -half_m), (half_m, half_m), (-half_m, half_m)]
    return [list(FRAME.to_geodetic(e, n, 0.0)[:2]) for e, n in corners]


def adversarial(aircraft, course_deg, wind_mps, climb="hold", duration_s=60.0):
    half, agl, ceiling = PLATFORMS[aircraft]
    doc = {
        "aircraft": aircraft,
        "duration_s": duration_s,
        "seed": 5,
        "start": dict(SITE, agl_m=agl, heading_deg=course_deg),
        "pilot": {
            "type": "scripted",
            "segments": [{"duration_s": duration_s, "course_deg": course_deg, "speed": "max", "climb": climb}],
        },
        "geofence": {"fence": {"keep_in": box(half), "ceiling_m": ceiling}},
    }
    if wind_mps:
        doc["wind"] = {"speed_mps": wind_mps, "from_deg": (course_deg + 180.0) % 360.0}  # tailwind toward the edge
    return fly(parse_scenario(doc, f"{aircraft}-{course_deg}.yaml"))


def assert_fence_held(res):
    s = res.summary
    transitions = s["mode_transitions"]
    assert s["activations"] >= 1, "the geofence never activated"
    assert s["max_excursion_m"] <= 0.0, f"crossed the fence by {s['max_excursion_m']:.2f} m"
    assert s["time_outside_s"] == 0.0
    # it acted before the line: at the first activation the truth margin was positive
    first = transitions[0]
    assert first["to"] == "OVERRIDE"
    assert s["first_activation_s"] == first["t_s"] > 0.0  # the first activation, after a start outside the boundary
    t = res.recorder.column("time_s")
    k = int((t >= first["t_s"] - 1e-9).argmax())
    fence = res.fence
    e, n, agl = (res.recorder.column(c)[k] for c in ("east_m", "north_m", "agl_m"))
    assert fence.margin_m(e, n, agl) > 0.0
    # and control was handed back afterwards
    assert any(tr["to"] == "RECOVERED" for tr in transitions), transitions


@pytest.mark.parametrize("aircraft", list(PLATFORMS))
@pytest.mark.parametrize("course_deg", [0.0, 90.0, 180.0, 270.0])
@pytest.mark.parametrize("wind_mps", [0.0, 8.0])
def test_adversarial_pilot_at_each_edge_never_crosses(aircraft, course_deg, wind_mps):
    assert_fence_held(adversarial(aircraft, course_deg, wind_mps))


@pytest.mark.parametrize("aircraft", list(PLATFORMS))
@pytest.mark.parametrize("wind_mps", [0.0, 8.0])
def test_max_climb_toward_the_ceiling_never_crosses(aircraft, wind_mps):
    res = adversarial(aircraft, 45.0, wind_mps, climb="max")
    assert_fence_held(res)
    ceiling = PLATFORMS[aircraft][2]
    assert res.recorder.column("agl_m").max() < ceiling


def test_without_a_geofence_the_same_pilot_does_cross():
    """Guard against a vacuous pass: the adversarial pilot really would breach."""
    half, agl, _ = PLATFORMS["F450"]
    doc = {
        "aircraft": "F450",
        "duration_s": 30.0,
        "start": dict(SITE, agl_m=agl),
        "pilot": {"type": "scripted", "segments": [{"duration_s": 30.0, "course_deg": 90.0, "speed": "max"}]},
    }
    res = fly(parse_scenario(doc, "nofence.yaml"))
    assert res.recorder.column("east_m").max() > half + 50.0
    assert math.isfinite(res.summary["sim_time_s"])


def test_position_loss_over_a_floor_ends_with_a_termination_inside_the_floor_gap():
    """Return impossible (GPS lost): the unit dead-reckons to the floor gap and ends the flight inside it."""
    from scenarios.definition.schema import load_scenario

    res = fly(load_scenario(ROOT_SCENARIOS / "geofence_gps_loss_fixedwing.yaml"))
    s = res.summary
    assert s["completed"] and s["ended_by_geofence"], s
    modes = [tr["to"] for tr in s["mode_transitions"]]
    assert modes[0] == "LAND_IN_GAP" and "position source lost" in s["mode_transitions"][0]["reason"]
    assert modes[-1] in ("TERMINATE", "LAND_IN_GAP")
    fence = res.fence
    e, n = res.recorder.column("east_m")[-1], res.recorder.column("north_m")[-1]
    assert fence.in_floor_gap(e, n), f"ended at ({e:.0f}, {n:.0f}) m, outside the gap"
    assert not s["landed_outside_gap"]
    assert s["max_excursion_m"] <= 0.0  # never below the floor outside the gap, never outside the fence


def test_a_gust_timed_from_the_first_activation_hits_during_the_override():
    """``onset_after: first_activation``: the gust starts the given time after the unit first overrides, and the
    fence holds through it (a gust at the worst moment, whenever that comes)."""
    half, agl, ceiling = PLATFORMS["F450"]
    doc = {
        "aircraft": "F450",
        "duration_s": 40.0,
        "seed": 5,
        "start": dict(SITE, agl_m=agl, heading_deg=90.0),
        "pilot": {"type": "scripted", "segments": [{"duration_s": 40.0, "course_deg": 90.0, "speed": "max", "climb": "hold"}]},
        "geofence": {"fence": {"keep_in": box(half), "ceiling_m": ceiling}},
        "wind": {
            "speed_mps": 3,
            "from_deg": 270,
            "gusts": [{"onset_s": 0.5, "onset_after": "first_activation", "amplitude_mps": 3, "length_m": 10, "from_deg": 270}],
        },
    }
    res = fly(parse_scenario(doc, "gust-at-activation.yaml"))
    t_act = res.summary["mode_transitions"][0]["t_s"]
    t = res.recorder.column("time_s")
    we = res.recorder.column("wind_east_mps")
    assert t_act > 1.0
    assert abs(we[t <= t_act + 0.5] - 3.0).max() < 1e-9  # steady wind only until 0.5 s after the first override
    assert we[(t > t_act + 0.5) & (t < t_act + 10.0)].max() == pytest.approx(6.0, abs=0.05)  # then the 3 m/s gust
    assert_fence_held(res)


def test_a_segment_can_end_on_handback_or_on_reaching_a_point():
    """Event-triggered script: push east until the geofence hands back, then fly west until a point is reached,
    then north. Each segment starts at its event, not at a time."""
    half, agl, ceiling = PLATFORMS["F450"]
    west_point = FRAME.to_geodetic(-60.0, 0.0, 0.0)[:2]
    doc = {
        "aircraft": "F450",
        "duration_s": 60.0,
        "seed": 5,
        "start": dict(SITE, agl_m=agl, heading_deg=90.0),
        "pilot": {
            "type": "scripted",
            "segments": [
                {"duration_s": 50.0, "course_deg": 90.0, "speed": "max", "climb": "hold", "end_on": "handback"},
                {
                    "duration_s": 50.0,
                    "course_deg": 270.0,
                    "speed": "cruise",
                    "climb": "hold",
                    "end_on": "reach",
                    "reach": {"lat_deg": west_point[0], "lon_deg": west_point[1], "radius_m": 10.0},
                },
                {"duration_s": 50.0, "course_deg": 0.0, "speed": "cruise", "climb": "hold"},
            ],
        },
        "geofence": {"fence": {"keep_in": box(half), "ceiling_m": ceiling}},
    }
    res = fly(parse_scenario(doc, "events.yaml"))
    t = res.recorder.column("time_s")
    item = res.recorder.column("mission_item")
    e = res.recorder.column("east_m")
    handback = next(tr["t_s"] for tr in res.summary["mode_transitions"] if tr["to"] == "RECOVERED")
    t2 = t[int((item >= 1).argmax())]
    assert handback < t2 <= handback + 0.1  # the second segment starts the step after the hand-back
    t3 = t[int((item >= 2).argmax())]
    k3 = int((item >= 2).argmax())
    assert t3 < 50.0 and abs(e[k3] - (-60.0)) <= 10.5  # the third starts on reaching the point, well before 50 s
    assert_fence_held(res)
