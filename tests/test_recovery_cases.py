"""The recovery holds on fences it was not tuned for: one closed-loop test per root cause of issue 8.

Each case is a small scenario built here in local ENU metres (converted to
WGS-84 at the site) and flown in closed loop with the unit's own sensors:

* a U-shaped fence with the recovery point in the other arm (the straight
  return would cross the notch);
* a multirotor whose recovery point lies behind a keep-out circle;
* a legal descent below the floor inside a large gap, then a dash toward the
  gap's edge (gap edges are lateral boundaries below the floor);
* a take-off from a small floor gap (climb inside it before anything sideways);
* a fixed-wing activated right at the recovery point;
* a high site (2,780 m) where the envelope must be scaled by air density;
* a mission 10 m below the ceiling (no vertical chatter, never overridden);
* a multirotor landing in a gap in wind (touchdown nearly stopped);
* a fixed-wing that loses GPS near the boundary (campaign case u_fence-0569: its landing turn
  swung out 170 m across the boundary; the first turn now goes the way the margin scored safe);
* a fixed-wing that loses GPS in an override's turn (star-0588): its landing spiral goes on that way;
* a fixed-wing that loses GPS in an override's turn with its landing point the other way (random-0255): its
  landing goes on with the override's turn;
* a fixed-wing overridden at the ceiling after a climb its engine could not give (ceiling-0241): its flight
  controller arrests it;
* a multirotor that loses GPS deep inside comes down at its full descent rate, not 1 m/s;
* a fixed-wing flown into the ground inside a floor gap at cruise (campaign case floor_gaps-0170):
  rolling, not sitting, it must not roll out of the gap below the floor;
* a fixed-wing turning in a wind of half its airspeed inside a circle (campaign case circle-0169): its
  margin must see the edge far along the circle that the drifting turn leaves through;
* fixed-wings below the floor in a gap (floor_gaps-0086, -0215): circle, climb, hand back only above it;
* a Tern in a corridor narrower than its turn (corridor-0455): it rolls out towards its route ahead;
* a multirotor landing in a gap with its estimate metres off (floor_gaps-0143): it keeps k·σ_h from the edge;
* a fixed-wing below the floor in a gap, its keep-in's turn leading out of the gap (floor_gaps-0305): the turn
  is chosen for both;
* fixed-wings started inside their activation boundary in a corridor and a wedge narrower than their turn
  (corridor-1922, acute-0364): a first turn that does not fit is flown at the minimum speed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from geofence.geometry.geodesy import LocalFrame
from scenarios.definition.schema import load_scenario, parse_scenario
from scenarios.flight.runner import fly

pytestmark = pytest.mark.closed_loop

SITE = {"lat_deg": 47.3, "lon_deg": 8.5, "ground_alt_m": 450.0}
FRAME = LocalFrame(SITE["lat_deg"], SITE["lon_deg"], SITE["ground_alt_m"])


def ll(points, frame=FRAME):
    return [list(frame.to_geodetic(e, n, 0.0)[:2]) for e, n in points]


def box(half_e, half_n=None, ce=0.0, cn=0.0):
    half_n = half_e if half_n is None else half_n
    return [(ce - half_e, cn - half_n), (ce + half_e, cn - half_n), (ce + half_e, cn + half_n), (ce - half_e, cn + half_n)]


def scenario(
    aircraft,
    start_en,
    agl,
    heading_deg,
    segments,
    fence,
    *,
    wind=None,
    duration_s=90.0,
    site=SITE,
    frame=FRAME,
    sensors=None,
    mission=None,
    seed=3,
):
    lat, lon, _ = frame.to_geodetic(start_en[0], start_en[1], 0.0)
    doc = {
        "aircraft": aircraft,
        "duration_s": duration_s,
        "seed": seed,
        "start": {"lat_deg": lat, "lon_deg": lon, "ground_alt_m": site["ground_alt_m"], "agl_m": agl, "heading_deg": heading_deg},
        "pilot": {"type": "mission"} if mission else {"type": "scripted", "segments": segments},
        "geofence": {"fence": fence},
    }
    if mission:
        doc["mission"] = mission
    if wind:
        doc["wind"] = wind
    if sensors:
        doc["sensors"] = sensors
    return doc


def fly_doc(doc, name):
    return fly(parse_scenario(doc, f"{name}.yaml"))


def assert_held(res, what):
    s = res.summary
    assert s["error"] is None, s["error"]
    assert s["max_lateral_excursion_m"] <= 0.0, f"{what}: left the keep-in by {s['max_lateral_excursion_m']:.1f} m"
    assert not s["breached_keep_out"], f"{what}: entered a keep-out"
    assert s["max_excursion_m"] <= 0.0, (
        f"{what}: breached by {s['max_excursion_m']:.1f} m (vertical {s['max_vertical_excursion_m']:.1f} m)"
    )
    assert not s["landed_outside_gap"], f"{what}: landed outside a gap"


def test_fixed_wing_in_a_u_fence_returns_around_the_notch():
    # arms x in [-600, -200] and [200, 600], joined below y = -150; the notch is open to the north
    u = [(-600, -450), (600, -450), (600, 450), (200, 450), (200, -150), (-200, -150), (-200, 450), (-600, 450)]
    rp = list(FRAME.to_geodetic(400.0, 250.0, 0.0)[:2])
    fence = {"keep_in": ll(u), "ceiling_m": 150, "recovery_point": rp}
    doc = scenario(
        "Tern",
        (-400.0, -100.0),
        60.0,
        0.0,
        [{"duration_s": 120, "course_deg": 0, "speed": "max", "climb": "hold"}],
        fence,
        duration_s=120.0,
    )
    res = fly_doc(doc, "u_fence")
    assert res.summary["activations"] >= 1
    assert_held(res, "U fence")


def test_multirotor_returns_around_a_keep_out_in_the_way():
    fence = {
        "keep_in": ll(box(150.0)),
        "ceiling_m": 60,
        "keep_out_circles": [{"center": list(FRAME.to_geodetic(60.0, 0.0, 0.0)[:2]), "radius_m": 35.0}],
    }
    doc = scenario(
        "F450",
        (110.0, 0.0),
        20.0,
        90.0,
        [{"duration_s": 60, "course_deg": 90, "speed": "max", "climb": "hold"}],
        fence,
        duration_s=60.0,
    )
    res = fly_doc(doc, "keep_out_in_the_way")
    assert res.summary["activations"] >= 1
    assert_held(res, "keep-out in the way")


def test_legal_descent_in_a_large_gap_is_stopped_at_the_gap_edge():
    fence = {"keep_in": ll(box(300.0)), "ceiling_m": 100, "floor_m": 30, "floor_gaps": [ll(box(100.0))]}
    segs = [
        {
            "duration_s": 20,
            "sticks": {"roll": 0.0, "pitch": 0.0, "yaw": 0.0, "throttle": -1.0},
        },  # descend legally inside the gap to ~10 m
        {"duration_s": 40, "course_deg": 90, "speed": "max", "climb": "hold"},
    ]  # then dash at the gap's east edge
    doc = scenario("F450", (0.0, 0.0), 45.0, 90.0, segs, fence, duration_s=60.0)
    res = fly_doc(doc, "descent_in_gap")
    agl = res.recorder.column("agl_m")
    assert agl.min() < 30.0 - 5.0  # it really was below the floor
    assert res.summary["activations"] >= 1
    assert_held(res, "gap edge below the floor")


def test_take_off_from_a_small_gap_climbs_inside_it():
    fence = {"keep_in": ll(box(200.0)), "ceiling_m": 80, "floor_m": 20, "floor_gaps": [ll(box(6.0))]}
    segs = [
        {"duration_s": 15, "sticks": {"roll": 0.0, "pitch": 0.0, "yaw": 0.0, "throttle": 1.0}},
        {"duration_s": 25, "course_deg": 45, "speed": "cruise", "climb": "hold"},
    ]
    doc = scenario("F450", (0.0, 0.0), 0.0, 0.0, segs, fence, duration_s=40.0)
    res = fly_doc(doc, "takeoff_small_gap")
    assert_held(res, "take-off from a small gap")
    # below the floor it never left the gap
    e, n, agl = (res.recorder.column(c) for c in ("east_m", "north_m", "agl_m"))
    low = agl < 20.0
    assert np.all(np.maximum(np.abs(e[low]), np.abs(n[low])) <= 6.0)


@pytest.mark.parametrize("course_deg", [0.0, 90.0, 200.0])
def test_fixed_wing_activated_at_the_recovery_point_stays_inside(course_deg):
    # a fence barely larger than the Tern needs: the activation happens near the recovery point
    fence = {"keep_in": ll(box(330.0, 260.0)), "ceiling_m": 150}
    doc = scenario(
        "Tern",
        (0.0, 0.0),
        60.0,
        course_deg,
        [{"duration_s": 90, "course_deg": course_deg, "speed": "max", "climb": "hold"}],
        fence,
        duration_s=90.0,
    )
    res = fly_doc(doc, f"fw_at_rp_{course_deg:.0f}")
    assert_held(res, f"fixed-wing at the recovery point, course {course_deg}")


def test_high_site_fixed_wing_holds_and_never_touches_the_ground():
    site = {"lat_deg": -16.5, "lon_deg": -68.15, "ground_alt_m": 2780.0}
    frame = LocalFrame(site["lat_deg"], site["lon_deg"], site["ground_alt_m"])
    fence = {"keep_in": ll(box(330.0, 260.0), frame), "ceiling_m": 200}
    doc = scenario(
        "Tern",
        (0.0, -150.0),
        80.0,
        0.0,
        [{"duration_s": 90, "course_deg": 0, "speed": "max", "climb": "hold"}],
        fence,
        duration_s=90.0,
        site=site,
        frame=frame,
    )
    res = fly_doc(doc, "high_site")
    assert_held(res, "high site")
    assert res.recorder.column("agl_m").min() > 20.0


def test_mission_ten_metres_below_the_ceiling_is_never_overridden():
    fence = {"keep_in": ll(box(200.0)), "ceiling_m": 40}
    wps = [(60.0, 60.0), (-60.0, 60.0), (-60.0, -60.0), (60.0, -60.0)]
    items = [{"type": "takeoff", "agl_m": 30.0}]
    for e, n in wps:
        lat, lon, _ = FRAME.to_geodetic(e, n, 0.0)
        items.append({"type": "waypoint", "lat_deg": lat, "lon_deg": lon, "agl_m": 30.0})
    items.append({"type": "land"})
    doc = scenario("F450", (0.0, 0.0), 0.0, 0.0, [], fence, mission={"items": items}, duration_s=200.0)
    res = fly_doc(doc, "mission_under_ceiling")
    assert res.summary["mission_finished"], res.summary["mission_progress"]
    assert res.summary["activations"] == 0, res.summary["mode_transitions"]


def test_multirotor_lands_in_a_gap_nearly_stopped_in_wind():
    # a wind at 90 % of what the quad can fly against: the pilot lets it drift downwind, the unit holds it
    # off the east edge, finds return impossible and lands in the downwind gap, nearly stopped over the ground
    fence = {"keep_in": ll(box(250.0)), "ceiling_m": 80, "floor_m": 20, "floor_gaps": [ll(box(40.0, 40.0, 190.0, 0.0))]}
    hover = {"roll": 0.0, "pitch": 0.0, "yaw": 0.0, "throttle": 0.0}
    doc = scenario(
        "F450RD",
        (-100.0, 0.0),
        40.0,
        0.0,
        [{"duration_s": 260, "sticks": hover}],
        fence,
        wind={"speed_mps": 9.5, "from_deg": 270.0},
        duration_s=260.0,
    )
    doc["geofence"]["wind_prior"] = {"speed_mps": 9.5, "from_deg": 270.0}
    res = fly_doc(doc, "landing_in_wind")
    s = res.summary
    assert s["final_mode"] in ("LAND_IN_GAP", "TERMINATE"), s["mode_transitions"]
    assert s["ended_by_geofence"], "it never touched down"
    assert not s["landed_outside_gap"]
    gs, agl = res.recorder.column("ground_speed_mps"), res.recorder.column("agl_m")
    k = int(np.argmax(agl < 0.3))
    assert k > 0 and gs[max(k - 8, 0) : k + 1].max() < 1.0, f"touched down at {gs[k]:.1f} m/s"


def test_fixed_wing_losing_gps_near_the_boundary_turns_the_safe_way():
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_u_fence_0569_gps_outage.yaml"))
    assert any("position source lost" in t.reason for t in res.unit.transitions)
    assert_held(res, "J3Cub landing after a GPS outage")


def test_fixed_wing_landing_spiral_goes_on_the_way_its_first_turn_went():
    # campaign case star-0588 (seed 26112033): a J3Cub dashing downwind at 46 m/s over the ground lost GPS
    # 1.3 s into an override's left turn; the landing spiral, always clockwise, reversed the turn and flew
    # 370 m downwind, 53.8 m out of the fence
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_star_0588_gps_outage_orbit.yaml"))
    assert any("position source lost" in t.reason for t in res.unit.transitions)
    assert_held(res, "J3Cub spiralling down after a GPS outage in a turn")


@pytest.mark.parametrize(
    "case", ["campaign_random_0255_gps_outage_landing_turn.yaml", "campaign_l_fence_0595_gps_fail_in_turn.yaml"]
)
def test_fixed_wing_landing_mid_override_goes_on_with_the_overrides_turn(case):
    # campaign case random-0255 (seed 26112038, --families random): a J3Cub lost GPS 4.5 s into an override's
    # right turn. The landing's first turn, scored afresh after the right bank's reaction arc, was 3 degrees to
    # the left; the landing guidance flew that left turn until it faced its route, 50 degrees to the right of
    # the heading it had: 310 degrees round, out across the edge by 51.4 m. A landing begun in an override's
    # turn now goes on with that turn for what is left of its scored angle, and spirals that way. l_fence-0595
    # (seed 26112030): a Tern whose GPS failed in an override's right turn, held by 1.9 m before, by 30 m now.
    res = fly(load_scenario(Path(__file__).parent / "data" / case))
    assert any("position source lost" in t.reason for t in res.unit.transitions)
    assert res.unit.landing.orbit_clockwise  # both overrides turned right
    assert_held(res, f"{res.summary['aircraft']} landing after a GPS fault in an override's turn")


def test_fixed_wing_after_a_power_limited_climb_arrests_it_at_the_ceiling():
    # campaign case ceiling-0241 (seed 26112034): a J3Cub at a 2,538 m site, the pilot asking full climb for
    # 30 s in moderate turbulence. Its flight controller's climb-rate integrator had wound up for the climb
    # the engine could not give; overridden at the ceiling, the nose kept rising for 3 s under a full-descent
    # command and it went 3.1 m over. The integrator now holds at full throttle.
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_ceiling_0241_power_limited_climb.yaml"))
    assert any(t.reason.startswith("vertical") for t in res.unit.transitions)
    assert_held(res, "J3Cub overridden at the ceiling after a power-limited climb")


def test_multirotor_losing_gps_deep_inside_descends_at_its_full_rate():
    fence = {"keep_in": ll(box(300.0)), "ceiling_m": 120}
    hover = {"roll": 0.0, "pitch": 0.0, "yaw": 0.0, "throttle": 0.0}
    doc = scenario(
        "F450RD",
        (0.0, 0.0),
        60.0,
        0.0,
        [{"duration_s": 90, "sticks": hover}],
        fence,
        sensors={"gps_fail_at_s": 5.0},
        duration_s=90.0,
    )
    res = fly_doc(doc, "gps_loss_deep_inside")
    assert res.summary["ended_by_geofence"], res.summary["mode_transitions"]
    t, agl = res.recorder.column("time_s"), res.recorder.column("agl_m")
    touchdown_s = float(t[int(np.argmax(agl < 0.3))]) - 5.0
    rate = res.unit.env.max_descent_rate_mps
    assert touchdown_s < 60.0 / rate + 10.0, f"took {touchdown_s:.0f} s from 60 m (1 m/s would take 60 s)"
    assert_held(res, "multirotor landing by dead reckoning")


def test_a_multirotor_losing_gps_in_a_hard_brake_dead_reckons_from_its_last_fix():
    """GPS fails 1.2 s after a full-power take-off while the override brakes at 40 deg (campaign seed 20261201,
    floor_gaps-0161). The last fresh estimate was extrapolated 0.5 s past its fix with the filter's acceleration
    (6 m/s off by then); dead reckoning from the fix's own time, replaying the attitude, starts 3x closer."""
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_floor_gaps_0161_gps_fail_braking.yaml"))
    lost = next(t for t in res.unit.transitions if "position source lost" in t.reason)
    c = res.recorder.column
    k = int(np.searchsorted(c("time_s"), lost.t_s)) + 1
    err = float(np.hypot(c("east_m")[k] - c("est_east_m")[k], c("north_m")[k] - c("est_north_m")[k]))
    assert err < 3.0, f"dead-reckoned position {err:.1f} m off when it took over"  # 6.4 m from the extrapolation


def test_a_fixed_wing_touching_down_at_flying_speed_in_a_gap_does_not_roll_out_of_it():
    """A c172x's pilot descends at cruise into a floor gap and touches down at 48 m/s with cruise power (campaign
    seed 26112026, floor_gaps-0170). The unit treated any vehicle on the ground as sitting there and let it roll
    out of the gap below the floor (33 m). Rolling faster than :data:`geofence.unit.geofence_unit.SITTING_MAX_GROUND_SPEED_MPS`,
    its margins count: the override lifts it off and it climbs back above the floor inside the gap."""
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_floor_gaps_0170_touchdown_rollout.yaml"))
    c = res.recorder.column
    touchdown = float(c("time_s")[np.argmax(c("agl_m") < 2.0)])
    assert 20.0 < touchdown < 35.0  # the pilot did fly it into the ground
    assert any(t.t_s > touchdown and t.to_mode.name == "OVERRIDE" for t in res.unit.transitions)  # acted while rolling
    assert res.summary["max_excursion_m"] < 0.0, res.summary["max_excursion_m"]


def test_a_fixed_wing_turning_in_strong_wind_inside_a_circle_stays_in():
    """A c172x at a 2,751 m site in 26.7 m/s of wind, in a steep turn at full power inside a 1,935 m circle
    (campaign seed 27112026, circle-0169). Its margin scored each edge at its segment distance: the drifting
    recovery turn left 86 m through an edge whose segment was 1,220 m away but whose line was 829 m away.
    Inside a convex keep-in each edge is scored at its line distance: it acts earlier and stays inside."""
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_circle_0169_turn_in_strong_wind.yaml"))
    assert res.fence is not None and res.fence.line_scored_edges() == 309
    assert res.summary["activations"] >= 1
    assert res.summary["max_excursion_m"] < 0.0, res.summary["max_excursion_m"]


def test_a_fixed_wing_below_the_floor_in_a_gap_circles_until_it_has_climbed_back():
    """A J3Cub 12 m below the floor inside a floor gap dashes for its edge (a campaign attack). The override turned
    to its route's roll-out heading and then flew straight for the route, still below the floor: out of the gap
    1.1 m below it. It now circles at the bank limit, climbing, until above the floor, then follows its route."""
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_gap_dash_0086_circle_until_climbed.yaml"))
    c = res.recorder.column
    assert res.fence is not None and res.fence.floor_m is not None
    below = (c("geofence_mode") == 1) & (c("agl_m") < res.fence.floor_m)
    assert below.any()  # the override acted below the floor
    assert np.all(np.abs(c("cmd_roll")[below]) == 1.0)  # ... circling at the bank limit all the while
    assert res.summary["max_excursion_m"] < 0.0, res.summary["max_excursion_m"]


def test_an_override_below_the_floor_hands_back_only_above_it():
    """A J3Cub in 14 m/s of wind dashes for a gap's edge 13 m below the floor. The circling override handed back
    while still below it (its margins were wide at that heading), the pilot's dash re-activated it a step later
    with the other turn, and it left the gap 3 m below the floor. It hands back only above its climb-back height."""
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_gap_dash_0215_no_handback_below_floor.yaml"))
    assert res.fence is not None and res.fence.floor_m is not None
    c = res.recorder.column
    t, agl = c("time_s"), c("agl_m")
    for tr in res.unit.transitions:
        if tr.to_mode.name == "RECOVERED":
            assert agl[np.searchsorted(t, tr.t_s)] >= res.fence.floor_m, tr
    assert res.summary["max_excursion_m"] < 0.0, res.summary["max_excursion_m"]


def test_a_fixed_wing_in_a_corridor_rolls_out_towards_its_route_ahead():
    """A Tern in a corridor narrower than its turn (campaign seed 3122026, corridor-0455). Its margin scored the turn
    towards its route's first point: a vertex a few metres behind it once it had passed it. Handed back with a
    margin of 31 m, re-activated 0.25 s later, it turned away from the corridor and left by 23 m. The turn rolls
    out towards the route a turn's length ahead (:meth:`RecoveryPath.rollout_point`), in the margin and the
    guidance alike: it turns into the corridor and stays inside."""
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_corridor_0455_rollout_ahead.yaml"))
    assert res.summary["activations"] >= 1
    assert res.summary["max_excursion_m"] < 0.0, res.summary["max_excursion_m"]


@pytest.mark.parametrize("case", ["campaign_corridor_1922_slow_turn.yaml", "campaign_acute_0364_no_forecast_slow_turn.yaml"])
def test_a_fixed_wing_started_inside_its_activation_boundary_turns_at_its_minimum_speed(case):
    """A Tern in a zigzag corridor (campaign seed 26112702, corridor-1922) and a J3Cub in an acute wedge without a
    forecast (seed 26112701, acute-0364), each at its maximum speed and already inside its activation boundary at
    the start: no turn fits. Turning at cruise they left by 9.9 m and 16.9 m. A first turn that lacks more than
    a tenth of its room is flown at the minimum speed (:meth:`GeofenceUnit._turn_does_not_fit`; radius
    ``V²/(g·tan φ)``, rate ``g·tan φ / V``): both stay inside."""
    res = fly(load_scenario(Path(__file__).parent / "data" / case))
    assert res.unit is not None and res.unit.first_activation_s == 0.0  # overridden at the first step
    assert res.summary["max_excursion_m"] < 0.0, res.summary["max_excursion_m"]


def test_a_fixed_wing_in_a_city_does_not_score_the_far_side_of_a_building():
    """A Tern among 200 buildings (campaign seed 2711, city-0058): the far side of a building, an edge facing away
    from it with its foot on the edge, was scored along its normal, a wall behind the vehicle that made the
    scored turn flip within a step. Handed back with 32 m, re-activated 0.05 s later at -44 m, it turned the
    long way round into a building (+1.4 m at 48.2 s). From the free space such an edge is scored towards its
    nearest point (:func:`geofence.geometry.elements.edge_scored`): it stays out of every building."""
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_city_0058_far_side_of_a_building.yaml"))
    assert res.summary["activations"] >= 1
    assert res.summary["max_excursion_m"] < 0.0 and not res.summary["breached_keep_out"], res.summary["max_excursion_m"]


def test_a_multirotor_lands_in_a_gap_beyond_its_position_uncertainty():
    """An F450RD in a wind beyond its authority lands in a floor gap (campaign seed 3122026, floor_gaps-0143). It
    aimed 3 m inside the gap's upwind edge and descended wherever its estimate was 2 m inside; the estimate was
    3.2 m off (k·σ_h = 4.6 m) and it touched down 0.5 m outside the gap. Both now keep the estimate's
    uncertainty margin too (:meth:`GeofenceUnit._landing_edge_margin_m`)."""
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_floor_gaps_0143_land_beyond_uncertainty.yaml"))
    assert res.unit is not None and res.unit.mode.name == "LAND_IN_GAP"
    assert not res.summary["landed_outside_gap"]
    assert res.summary["max_excursion_m"] < 0.0, res.summary["max_excursion_m"]


def test_a_fixed_wing_below_the_floor_in_a_gap_turns_the_way_its_circle_stays_in_the_gap():
    """A J3Cub circling 9 m below the floor inside a floor gap, 88 m from its edge (campaign seed 26112029,
    floor_gaps-0305, 1,280 m site). The margins scored its climb-back circle in the turn that was best for the
    keep-in, 500 m away; as its heading swept round, that turn flipped to the one leading out of the gap and the
    floor activation fell from +37 m to -24 m in a step. The override flew that turn, climbing slowly at the
    site, and left the gap 4.1 m below the floor. The turn is now chosen for the keep-in and the gap together
    (the other turn is scored, and flown, where it keeps the gap better and the keep-in allows it)."""
    res = fly(load_scenario(Path(__file__).parent / "data" / "campaign_floor_gaps_0305_gap_turn.yaml"))
    assert res.fence is not None and res.fence.floor_m is not None
    c = res.recorder.column
    below = (c("geofence_mode") == 1) & (c("agl_m") < res.fence.floor_m)
    assert below.any()  # the override acted below the floor
    assert res.summary["max_excursion_m"] < 0.0, res.summary["max_excursion_m"]
