"""The pre-flight mission check flags the legs, turns and loiters that will meet the activation boundary."""

import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aircraft.profile import load_profile
from geofence.geometry.geodesy import LocalFrame
from geofence.physics.dynamics import return_not_assured
from geofence.unit.config import parse_geofence
from geofence.unit.preflight import PlannedWaypoint, RoutePart, check_route

REPO = Path(__file__).resolve().parents[1]
FRAME = LocalFrame(47.0, 8.0, 400.0)
MC = load_profile("F450RD").envelope
FW = load_profile("Tern").envelope


def fence(half=300.0, ceiling=60.0, **extra):
    corners = [(-half, -half), (half, -half), (half, half), (-half, half)]
    f = {"keep_in": [list(FRAME.to_geodetic(e, n, 0.0)[:2]) for e, n in corners], "ceiling_m": ceiling, **extra}
    return parse_geofence({"fence": f}).fence.to_local(FRAME)


def square(half, h):
    return [
        PlannedWaypoint(-half, -half, h, "A"),
        PlannedWaypoint(half, -half, h, "B"),
        PlannedWaypoint(half, half, h, "C"),
        PlannedWaypoint(-half, half, h, "D"),
        PlannedWaypoint(-half, -half, h, "E"),
    ]


def test_a_comfortable_multirotor_survey_passes():
    assert check_route(fence(), MC, square(150.0, 30.0), 5.3, wind_en=(4.0, 0.0)) == []


def test_a_leg_that_ends_near_the_edge_is_flagged_with_its_edge():
    wps = [PlannedWaypoint(0.0, 0.0, 30.0, "home"), PlannedWaypoint(295.0, 0.0, 30.0, "edge")]
    out = check_route(fence(), MC, wps, 10.0)
    assert len(out) == 1 and out[0].part is RoutePart.LEG and out[0].activation_margin_m <= 0.0
    assert "keep_in edge 1" in out[0].reason and out[0].east_m > 250.0


def test_the_ceiling_and_the_wind_count():
    # climbing at max rate to 2 m below the ceiling: fine with a perfect height, flagged with 2 m of uncertainty
    wps = [PlannedWaypoint(0.0, 0.0, 30.0), PlannedWaypoint(100.0, 0.0, 58.0)]
    assert check_route(fence(), MC, wps, 5.0) == []
    out = check_route(fence(), MC, wps, 5.0, v_uncertainty_m=2.0)
    assert out and "vertical" in out[0].reason
    # a survey that passes in calm air fails in a strong tailwind toward an edge
    wps = [PlannedWaypoint(0.0, 0.0, 30.0), PlannedWaypoint(290.0, 0.0, 30.0)]
    assert check_route(fence(), MC, wps, 5.3) == []
    assert check_route(fence(), MC, wps, 5.3, wind_en=(8.0, 0.0), wind_extra_mps=1.0) != []


def test_fixed_wing_turns_and_loiters_are_checked():
    f = fence(half=600.0, ceiling=150.0)
    r = 16.0**2 / (9.80665 * math.tan(math.radians(40)))
    # a turn at a waypoint close to the edge sweeps outward: flagged as a turn
    x = 600.0 - r - 10.0  # the turn's arc reaches 10 m from the edge
    wps = [PlannedWaypoint(-300.0, 0.0, 80.0), PlannedWaypoint(x, 0.0, 80.0, "near"), PlannedWaypoint(x, 300.0, 80.0)]
    turn = [x for x in check_route(f, FW, wps, 16.0) if x.part is RoutePart.TURN]
    assert turn and turn[0].activation_margin_m <= 0.0
    # a loiter whose orbit crosses the edge
    wps = [PlannedWaypoint(0.0, 0.0, 80.0), PlannedWaypoint(560.0, 0.0, 80.0, "orbit", loiter_radius_m=60.0)]
    assert any(x.part is RoutePart.LOITER for x in check_route(f, FW, wps, 16.0))
    # a comfortable fixed-wing pattern passes
    assert check_route(f, FW, square(250.0, 80.0), 16.0, wind_en=(0.0, 5.0)) == []


def test_a_fixed_wing_is_checked_on_its_orbit_after_the_mission():
    """After its last waypoint a fixed-wing orbits it (``max(radius, 1.5 R)``). A mission that ends 1.5 R from a wall
    passes its legs, but the orbit meets the activation boundary: a loiter finding at the last waypoint. A
    multirotor holds its last point instead: no finding there. (Campaign seed 1122026, ``l_fence-0163``: a Tern
    overridden after an L-fence mission that had passed the check.)"""
    f = fence(half=600.0, ceiling=150.0)
    r = 16.0**2 / (9.80665 * math.tan(math.radians(40)))
    end = 600.0 - 1.6 * r
    wps = [PlannedWaypoint(-300.0, 0.0, 80.0), PlannedWaypoint(0.0, 0.0, 80.0), PlannedWaypoint(end, 0.0, 80.0, "end")]
    out = check_route(f, FW, wps, 16.0)
    assert [(x.part, x.index) for x in out] == [(RoutePart.LOITER, 2)] and "keep_in" in out[0].reason
    assert check_route(f, FW, wps[:2], 16.0) == []  # ending in the middle: its orbit fits
    assert not [x for x in check_route(f, MC, wps, 5.3) if x.part is RoutePart.LOITER]


def test_an_expected_wind_beyond_authority_is_the_one_finding():
    """Mean 8 m/s + one sigma 2.8 m/s >= 90 % of the F450RD's 10.3 m/s: the unit would land at once."""
    route = square(150.0, 30.0)
    assert check_route(fence(), MC, route, 5.3, wind_en=(8.0, 0.0)) == []  # the mean alone: fine
    out = check_route(fence(), MC, route, 5.3, wind_en=(8.0, 0.0), turbulence_sigma_mps=2.8)
    assert len(out) == 1 and out[0].part is RoutePart.WIND and out[0].activation_margin_m == -math.inf
    assert "return impossible" in out[0].reason and "land at once" in out[0].describe()


@settings(max_examples=60, deadline=None)
@given(
    wind_mps=st.floats(0.0, 12.0),
    sigma_mps=st.floats(0.0, 4.0),
    gust_mps=st.floats(0.0, 5.0),
)
def test_a_passing_check_means_the_unit_can_return(wind_mps, sigma_mps, gust_mps):
    """The check never passes a mission in a wind where the unit would judge return not assured."""
    route = square(100.0, 30.0)
    out = check_route(
        fence(),
        MC,
        route,
        5.3,
        wind_en=(wind_mps, 0.0),
        wind_extra_mps=1.5 * sigma_mps + gust_mps,
        turbulence_sigma_mps=sigma_mps,
    )
    if not out:
        assert return_not_assured(wind_mps, sigma_mps, MC) is None


def test_a_fixed_wing_turn_rolls_in_then_circles_in_the_drifting_air():
    """Calm air: past the waypoint by the roll-in, then a circle of the bank limit's radius tangent to the track.
    In wind the same circle drifts downwind with the turn's time."""
    from geofence.physics.rooms import envelope_turn_radius_m
    from geofence.unit.preflight import turn_samples

    a, b, c = PlannedWaypoint(-300.0, 0.0, 80.0), PlannedWaypoint(0.0, 0.0, 80.0), PlannedWaypoint(0.0, 300.0, 80.0)
    r = envelope_turn_radius_m(FW, 16.0)
    calm = turn_samples(FW, a, b, c, 16.0, (0.0, 0.0))
    roll_in_m = 16.0 * FW.reaction_time_s
    assert (calm[1].e, calm[1].n) == (pytest.approx(roll_in_m), pytest.approx(0.0, abs=1e-9))
    centre = (roll_in_m, r)  # a left turn from eastbound: the centre is r to the north of the roll-out point
    assert all(math.hypot(p.e - centre[0], p.n - centre[1]) == pytest.approx(r, rel=1e-9) for p in calm[1:])
    assert math.degrees(math.atan2(calm[-1].vn, calm[-1].ve)) == pytest.approx(90.0, abs=10.0)  # ends on the new leg
    # a 5 m/s tailwind on the way in: the turn sweeps further on (east) by the roll-in's and the turn's drift
    windy = turn_samples(FW, a, b, c, 16.0, (5.0, 0.0))
    assert max(p.e for p in windy) > max(p.e for p in calm) + 15.0
    # and it turns until the track, not the heading, is the new leg's (north)
    assert math.degrees(math.atan2(windy[-1].vn, windy[-1].ve)) == pytest.approx(90.0, abs=10.0)


def test_a_route_must_pass_for_every_wind_within_the_uncertainty():
    # a leg toward the east edge that passes at the expected wind fails when the wind may be 3 m/s stronger toward it
    wps = [PlannedWaypoint(0.0, 0.0, 30.0), PlannedWaypoint(240.0, 0.0, 30.0)]
    f = fence(ceiling=200.0)
    margins = [
        check_route(f, MC, wps, 5.3, wind_en=(4.0, 0.0), wind_uncertainty_mps=u, buffer_m=1e9)[0].activation_margin_m
        for u in (0.0, 1.0, 2.0, 4.0)
    ]
    assert margins == sorted(margins, reverse=True) and margins[-1] < margins[0] - 5.0  # a wider disc, a worse worst wind
    # the buffer decides: passes at the expected wind, fails for a disc whose worst wind leaves less than it
    buffer = 0.5 * (margins[0] + margins[-1])
    assert check_route(f, MC, wps, 5.3, wind_en=(4.0, 0.0), buffer_m=buffer) == []
    assert check_route(f, MC, wps, 5.3, wind_en=(4.0, 0.0), wind_uncertainty_mps=4.0, buffer_m=buffer) != []


def test_the_expected_wind_is_the_forecast_raised_to_the_routes_top_with_its_error_disc():
    from scenarios.definition.preflight import TURBULENCE_IN_ESTIMATE_SIGMAS, WIND_ESTIMATE_ERROR_MPS, expected_wind

    (we, wn), radius = expected_wind((3.0, 4.0), 120.0)
    assert math.hypot(we, wn) == pytest.approx(5.0 * 12.0 ** (1.0 / 7.0)) and we / wn == pytest.approx(0.75)
    assert radius == pytest.approx(WIND_ESTIMATE_ERROR_MPS)
    assert expected_wind((3.0, 4.0), 120.0, 2.0)[1] == pytest.approx(
        WIND_ESTIMATE_ERROR_MPS + 2.0 * TURBULENCE_IN_ESTIMATE_SIGMAS
    )
    assert expected_wind((3.0, 4.0), 2.0)[0] == pytest.approx((3.0, 4.0))  # never weaker than the 10 m forecast
    assert expected_wind((0.0, 0.0), 50.0) == ((0.0, 0.0), WIND_ESTIMATE_ERROR_MPS)


@settings(max_examples=300, deadline=None)
@given(
    speed_mps=st.floats(0.5, 30.0),
    bearing_deg=st.floats(0.0, 360.0),
    scale=st.floats(0.8, 1.2),
    turn_deg=st.floats(-20.0, 20.0),
    radius_mps=st.floats(0.0, 5.0),
)
def test_the_checked_winds_reach_as_far_as_any_wind_the_forecast_allows(speed_mps, bearing_deg, scale, turn_deg, radius_mps):
    """A true mean wind whose forecast is within 20 % and 20 deg of it, estimated within r: the checked winds
    include one at least as strong, one at least as far toward it, and none outside the set."""
    from geofence.unit.preflight import winds_to_check

    b = math.radians(bearing_deg)
    fb = b + math.radians(turn_deg)
    forecast = (scale * speed_mps * math.cos(fb), scale * speed_mps * math.sin(fb))
    winds = winds_to_check(forecast, radius_mps, 0.2, math.radians(20.0))
    assert winds[0] == forecast
    assert max(math.hypot(*w) for w in winds) >= speed_mps + radius_mps - 1e-9
    # the unit's estimate furthest along the true wind's own direction is covered (within the sampling's chord)
    ub = (math.cos(b), math.sin(b))
    reach = max(w[0] * ub[0] + w[1] * ub[1] for w in winds)
    assert reach >= (speed_mps + radius_mps) * math.cos(math.radians(5.0)) - 1e-9
    # and no checked wind lies outside the sector widened by r
    f = math.hypot(*forecast)
    for w in winds:
        v = math.hypot(*w)
        assert v <= f / 0.8 + radius_mps + 1e-9
        if v > 1e-9:
            off = abs(math.remainder(math.atan2(w[1], w[0]) - fb, 2.0 * math.pi))
            assert off <= math.radians(20.0) + math.asin(min(1.0, radius_mps / max(f / 1.2, 1e-9))) + 1e-9


def test_return_must_be_assured_against_the_strongest_wind_the_forecast_allows():
    route = square(100.0, 30.0)
    # 8 m/s forecast: fine on its own for the 10.3 m/s multirotor; as much as 8 / 0.8 = 10 m/s is not
    assert check_route(fence(), MC, route, 5.3, wind_en=(8.0, 0.0)) == []
    out = check_route(fence(), MC, route, 5.3, wind_en=(8.0, 0.0), forecast_speed_error=0.2)
    assert len(out) == 1 and out[0].part is RoutePart.WIND


def test_the_check_adds_the_units_latency_and_it_matches_the_sensors():
    from scenarios.definition.preflight import latency_bound_s
    from scenarios.definition.schema import load_scenario

    wps = [PlannedWaypoint(0.0, 0.0, 30.0), PlannedWaypoint(230.0, 0.0, 30.0)]
    f = fence(ceiling=200.0)
    m0 = check_route(f, MC, wps, 5.3, buffer_m=1e9)[0].activation_margin_m
    m1 = check_route(f, MC, wps, 5.3, latency_s=0.4, buffer_m=1e9)[0].activation_margin_m
    assert m1 <= m0 - 5.3 * 0.4 + 1e-9  # at least the 0.4 s more at 5.3 m/s toward the edge
    sc = load_scenario(REPO / "scenarios" / "geofence_multicopter_adversarial_wind.yaml")
    s = sc.sensors
    assert latency_bound_s(sc) == pytest.approx(1.0 / sc.control_rate_hz + s.gps_latency_s + 1.0 / s.gps_rate_hz)


def test_the_join_from_the_last_waypoint_out_to_its_orbit_is_checked():
    """After its mission a fixed-wing joins the last waypoint's orbit from the waypoint itself, outward along the
    autopilot's vector field. Campaign seed 4122026, ``floor_gaps-0080``: a Tern's mission passed the check (the
    orbit alone fits) and was overridden 1.5 s after its last waypoint, 27 m out and heading nearly straight out
    at 18.5 m/s. The check now flags it, at the last waypoint; and the flight was in fact overridden."""
    from scenarios.definition.preflight import preflight_findings
    from scenarios.definition.schema import load_scenario
    from scenarios.flight.runner import fly

    sc = load_scenario(REPO / "tests" / "data" / "campaign_floor_gaps_0080_orbit_join.yaml")
    out = preflight_findings(sc)
    assert out and all(x.part is RoutePart.LOITER and x.index == 3 for x in out), out
    res = fly(sc)
    assert res.summary["mission_finished"] and res.summary["activations"] >= 1


def _box(north_m: float):
    """A keep-in from -900 m to +900 m east and from -900 m to ``north_m`` north, ceiling 150 m."""
    corners = ((-900.0, -900.0), (900.0, -900.0), (900.0, north_m), (-900.0, north_m))
    keep_in = [list(FRAME.to_geodetic(e, n, 0.0)[:2]) for e, n in corners]
    return parse_geofence({"fence": {"keep_in": keep_in, "ceiling_m": 150.0}}).fence.to_local(FRAME)


def test_a_near_reversal_is_checked_both_ways_round():
    """A fixed-wing turning back onto a leg 170 deg from the incoming one may go either way round: the
    navigator turns the way its course error points when it switches legs, and its vector field's approach
    angle and the crab move that error by tens of degrees (campaign seed 26112030, corridor-0320: a J3Cub
    turned left where the check had turned it right, and was overridden in a mission that had passed). With an
    edge close on the short way's outside the reversal is flagged, and it is flagged the same with the edge on
    the long way's outside; a 90 deg turn is still checked the short way only."""
    from geofence.unit.preflight import BOTH_WAYS_ABOVE_RAD, turn_samples

    a, b = PlannedWaypoint(-400.0, 0.0, 80.0), PlannedWaypoint(0.0, 0.0, 80.0)
    back = PlannedWaypoint(-400.0, -70.0, 80.0)  # 170 deg to the right of the way in (the short way: right)
    right = turn_samples(FW, a, b, back, 16.0, (0.0, 0.0))
    left = turn_samples(FW, a, b, back, 16.0, (0.0, 0.0), 1.0)
    assert max(p.n for p in right) < 1.0 and min(p.n for p in left) > -1.0  # the two ways sweep opposite sides
    assert math.degrees(math.atan2(left[-1].vn, left[-1].ve)) % 360.0 == pytest.approx(190.0, abs=10.0)
    assert math.radians(170.0) > BOTH_WAYS_ABOVE_RAD > math.radians(90.0)
    r = max(p.n for p in left)  # how far the left way sweeps north
    for edge_north in (r + 8.0, 600.0):  # an edge just beyond the left way's sweep, or far
        f = _box(edge_north)
        flagged = [x for x in check_route(f, FW, [a, b, back], 16.0) if x.part is RoutePart.TURN]
        assert bool(flagged) == (edge_north < 600.0), (edge_north, flagged)
    # a right angle goes the short way only: the same edge beyond its long way's sweep is not flagged
    c = PlannedWaypoint(0.0, -300.0, 80.0)
    f = _box(r + 8.0)
    assert not [x for x in check_route(f, FW, [a, b, c], 16.0) if x.part is RoutePart.TURN]
