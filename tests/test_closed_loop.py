"""Closed-loop behaviour in JSBSim: hover hold, GPS missions on both platforms, wind drift.

Each test flies a short scenario (simulated seconds, not minutes) through the
same runner the CLI uses and checks the recorded truth trajectory.
"""

import math
from pathlib import Path

import numpy as np
import pytest

from geofence.geometry.geodesy import LocalFrame, geodesic_destination
from scenarios.definition.schema import PilotKind, parse_scenario
from scenarios.flight.runner import fly

pytestmark = pytest.mark.closed_loop

SITE = {"lat_deg": -35.363262, "lon_deg": 149.165237, "ground_alt_m": 584.0}


def scenario(aircraft, duration_s, **blocks):
    doc = {"aircraft": aircraft, "duration_s": duration_s, "start": dict(SITE), **blocks}
    for key in ("agl_m", "heading_deg"):
        if key in blocks.get("start_extra", {}):
            doc["start"][key] = blocks["start_extra"][key]
    doc.pop("start_extra", None)
    return parse_scenario(doc, "test.yaml")


def offset(east_m, north_m):
    """Lat/lon of a point east_m/north_m from the site (geodesic)."""
    dist = math.hypot(east_m, north_m)
    azi = math.degrees(math.atan2(east_m, north_m))
    return geodesic_destination(SITE["lat_deg"], SITE["lon_deg"], azi, dist)


def track(result, *names):
    return [result.recorder.column(n) for n in names]


def test_multicopter_holds_hover_within_1m_for_30s_in_calm_air():
    lat, lon = SITE["lat_deg"], SITE["lon_deg"]
    sc = scenario(
        "F450",
        40.0,
        start_extra={"agl_m": 10.0},
        mission={
            "acceptance_radius_m": 1.0,
            "items": [{"type": "loiter", "lat_deg": lat, "lon_deg": lon, "agl_m": 10.0, "duration_s": 35.0}],
        },
    )
    res = fly(sc)
    t, e, n, u = track(res, "time_s", "east_m", "north_m", "up_m")
    window = (t >= 2.0) & (t <= 32.0)  # 30 s after a 2 s settle from the air start
    dev = np.sqrt(e[window] ** 2 + n[window] ** 2 + (u[window] - 10.0) ** 2)
    assert window.sum() > 1000
    assert dev.max() < 1.0, f"hover deviation {dev.max():.2f} m"
    # the stepping loop's own time (what bench/closed_loop.py compares with bare JSBSim) is part of the flight's
    s = res.summary
    assert 0.0 < s["loop_wall_time_s"] <= s["wall_time_s"] + 1e-3


@pytest.mark.parametrize("aircraft, agl_m, size_m, acceptance_m", [("F450", 0.0, 60.0, 3.0), ("Tern", 60.0, 400.0, 15.0)])
def test_platform_reaches_every_waypoint_of_a_4_waypoint_mission(aircraft, agl_m, size_m, acceptance_m):
    corners = [(0.0, size_m), (size_m, size_m), (size_m, 0.0), (0.0, 0.0)]
    items = [{"type": "takeoff", "agl_m": 20.0}] if agl_m == 0.0 else []
    wp_agl = 20.0 if agl_m == 0.0 else 70.0
    for e, n in corners:
        lat, lon = offset(e, n)
        items.append({"type": "waypoint", "lat_deg": lat, "lon_deg": lon, "agl_m": wp_agl})
    sc = scenario(aircraft, 200.0, start_extra={"agl_m": agl_m}, mission={"acceptance_radius_m": acceptance_m, "items": items})
    res = fly(sc)
    assert res.summary["completed"], res.summary
    assert res.summary["waypoints_reached"] == len(items)
    # independent check on the recorded track: it passed near each waypoint in order
    frame = LocalFrame(SITE["lat_deg"], SITE["lon_deg"], SITE["ground_alt_m"])
    e, n = track(res, "east_m", "north_m")
    k = 0
    for ce, cn in corners:
        we, wn, _ = frame.to_enu(*offset(ce, cn), SITE["ground_alt_m"])
        d = np.hypot(e[k:] - we, n[k:] - wn)
        assert d.min() <= max(acceptance_m, 0.1 * size_m), f"closest approach to ({ce}, {cn}) was {d.min():.1f} m"
        k += int(np.argmin(d))


@pytest.mark.parametrize("aircraft, agl_m", [("Tern", 80.0)])
def test_fixed_wing_uncorrected_crosswind_drift_matches_wind_times_time(aircraft, agl_m):
    """Wings level, no course correction, 6 m/s wind from the west: the track drifts east by W*t (within 15%)."""
    wind_mps, duration_s = 6.0, 30.0
    sc = scenario(
        aircraft,
        duration_s,
        start_extra={"agl_m": agl_m, "heading_deg": 0.0},
        pilot={"type": "scripted", "segments": [{"duration_s": duration_s, "sticks": {}}]},
        wind={"speed_mps": wind_mps, "from_deg": 270.0},
    )
    calm = scenario(
        aircraft,
        duration_s,
        start_extra={"agl_m": agl_m, "heading_deg": 0.0},
        pilot={"type": "scripted", "segments": [{"duration_s": duration_s, "sticks": {}}]},
    )
    windy_e = fly(sc).recorder.column("east_m")
    calm_e = fly(calm).recorder.column("east_m")
    drift = (windy_e[-1] - windy_e[0]) - (calm_e[-1] - calm_e[0])
    assert drift == pytest.approx(wind_mps * duration_s, rel=0.15)


def test_multicopter_with_zero_sticks_drifts_with_the_air_mass():
    """Hands off in air moving east at 5 m/s, the quad is carried east and accelerates toward wind speed.

    The shipped F450 has drag-only aerodynamics (no rotor drag), so it takes
    tens of seconds to pick up the wind; it must never outrun the air mass.
    """
    sc = scenario(
        "F450",
        40.0,
        start_extra={"agl_m": 20.0},
        pilot={"type": "scripted", "segments": [{"duration_s": 40.0, "sticks": {}}]},
        wind={"speed_mps": 5.0, "from_deg": 270.0},
    )
    res = fly(sc)
    t, e, n, ve = track(res, "time_s", "east_m", "north_m", "v_east_mps")
    assert e[-1] > 20.0 and abs(n[-1]) < 0.1 * e[-1]
    assert ve.max() <= 5.0 + 0.05
    assert np.mean(ve[t > 30.0]) > np.mean(ve[(t > 5.0) & (t < 15.0)]) > 0.3


def test_any_wheel_fixed_wing_with_standard_controls_flies_from_an_inline_profile():
    """c172p has no shipped profile; the c172x one (same controls) flies it straight and level."""
    doc = {
        "aircraft": "c172p",
        "profile": {"base": "c172x"},
        "duration_s": 20.0,
        "start": dict(SITE, agl_m=300.0, heading_deg=90.0),
        "pilot": {"type": "scripted", "segments": [{"duration_s": 20.0, "sticks": {}}]},
    }
    res = fly(parse_scenario(doc, "c172p.yaml"))
    up, tas = track(res, "up_m", "airspeed_mps")
    assert res.summary["completed"]
    assert np.ptp(up) < 10.0
    assert abs(np.mean(tas) - res.scenario.profile.envelope.cruise_speed_mps) < 3.0


EXAMPLES = sorted((Path(__file__).parents[1] / "scenarios").glob("*.yaml"))


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_every_shipped_example_flies_to_completion(path):
    from scenarios.definition.schema import load_scenario

    res = fly(load_scenario(path))
    assert res.summary["completed"], res.summary
    assert res.summary["error"] is None
    if res.scenario.pilot.kind is PilotKind.MISSION and not res.summary.get("ended_by_geofence"):
        assert res.summary["waypoints_reached"] == res.summary["waypoints_total"]


def test_fixed_wing_lands_on_a_straight_in_approach():
    """Downwind leg, turn, straight-in glide to the land point, flare: the mission ends on the ground."""
    far_lat, far_lon = offset(0.0, 400.0)
    base_lat, base_lon = offset(0.0, -300.0)
    sc = scenario(
        "Tern",
        200.0,
        start_extra={"agl_m": 40.0, "heading_deg": 0.0},
        mission={
            "acceptance_radius_m": 15.0,
            "items": [
                {"type": "waypoint", "lat_deg": far_lat, "lon_deg": far_lon, "agl_m": 40.0},
                {"type": "waypoint", "lat_deg": base_lat, "lon_deg": base_lon, "agl_m": 30.0},
                {"type": "land", "lat_deg": SITE["lat_deg"], "lon_deg": SITE["lon_deg"]},
            ],
        },
    )
    res = fly(sc)
    assert res.summary["completed"] and res.summary["mission_progress"] == "3/3", res.summary
    agl, vu, n, e = track(res, "agl_m", "v_up_mps", "north_m", "east_m")
    assert agl[-1] < 0.5  # on its gear
    touchdown = int(np.argmax(agl < 0.5))
    assert vu[touchdown] > -1.5, f"hard landing: {vu[touchdown]:.1f} m/s"
    assert abs(e[-1]) < 10.0 and -50.0 < n[-1] < 200.0  # on the runway line, near the aim point
