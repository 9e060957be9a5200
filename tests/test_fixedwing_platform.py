"""Closed-loop tests of the fixed-wing platform (Tern and the shipped J3Cub).

Each test flies the JSBSim model with the fixedwing_fc inner loop for at most
~25 simulated seconds and checks one line of the stick table against the
profile's envelope.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import replace

import pytest

from aircraft.factory import build_platform
from aircraft.fixedwing import FixedWingPlatform
from aircraft.jsbsim_model import FT_TO_M, OWN_MODELS
from aircraft.profile import load_profile
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import StickCommand
from geofence.physics.dynamics import isa_density_ratio
from wind.config import parse_wind, wind_from_config

G = 9.80665
FRAME = LocalFrame(47.0, 8.0, 400.0)
START_AGL_M = 300.0
MODELS = ["Tern", "J3Cub", "c172x"]


def eas(s) -> float:
    """Equivalent airspeed (what the FC holds and the envelope states) from the true airspeed, m/s."""
    return s.airspeed_mps * math.sqrt(isa_density_ratio(s.alt_m))


@pytest.fixture(scope="module", params=MODELS)
def plane(request) -> FixedWingPlatform:
    return FixedWingPlatform(load_profile(request.param))


def fly(p: FixedWingPlatform, cmd: StickCommand, seconds: float, sample_s: float = 0.1, heading_deg: float = 0.0):
    """Reset at cruise, hold ``cmd`` for ``seconds``; return the sampled truth states."""
    p.reset(FRAME, 47.0, 8.0, START_AGL_M, heading_deg, 0.0)
    p.command(cmd)
    n = int(round(sample_s / p.dt_s))
    out = []
    for _ in range(int(round(seconds / sample_s))):
        p.step(n)
        out.append(p.truth())
    return out


def test_reset_places_aircraft_at_cruise(plane):
    s0 = fly(plane, StickCommand(), 0.1, heading_deg=90.0)[0]
    env = plane.envelope
    assert abs(s0.t_s - 0.1) < 0.02
    assert math.hypot(s0.east_m, s0.north_m) < 0.1 * s0.airspeed_mps + 0.5  # 0.1 s of flight plus placement error
    assert abs(s0.up_m - START_AGL_M) < 0.5
    assert abs((math.degrees(s0.yaw_rad) - 90.0 + 180.0) % 360.0 - 180.0) < 3.0
    assert abs(eas(s0) - env.cruise_speed_mps) < 1.0
    assert abs(s0.roll_rad) < math.radians(3.0)
    assert not s0.on_ground


def test_command_clips_sticks(plane):
    plane.command(StickCommand(roll=3.0, pitch=-2.0, yaw=0.5, throttle=9.0))
    assert plane.fc("fc/stick-roll") == 1.0
    assert plane.fc("fc/stick-pitch") == -1.0
    assert plane.fc("fc/stick-yaw") == 0.5
    assert plane.fc("fc/stick-throttle") == 1.0


def test_zero_sticks_hold_altitude_and_cruise(plane):
    env = plane.envelope
    track = fly(plane, StickCommand(), 20.0)
    assert max(abs(s.up_m - START_AGL_M) for s in track) < 3.0
    assert max(abs(eas(s) - env.cruise_speed_mps) for s in track) < 1.0
    assert max(abs(s.roll_rad) for s in track) < math.radians(5.0)


def test_full_roll_stick_banks_to_max_and_turns_at_coordinated_radius(plane):
    env = plane.envelope
    track = fly(plane, StickCommand(roll=1.0), 25.0)
    steady = [s for s in track if s.t_s >= 10.0]
    bank = sum(s.roll_rad for s in steady) / len(steady)
    assert abs(bank - env.max_bank_rad) < 0.10 * env.max_bank_rad
    # turn radius from the heading rate over the steady part (still air: track rate = heading rate)
    yaw = [s.yaw_rad for s in steady]
    unwrapped = [yaw[0]]
    for y in yaw[1:]:
        d = (y - unwrapped[-1] + math.pi) % (2.0 * math.pi) - math.pi
        unwrapped.append(unwrapped[-1] + d)
    rate = (unwrapped[-1] - unwrapped[0]) / (steady[-1].t_s - steady[0].t_s)
    assert rate > 0.0  # right stick turns right
    v_air = sum(s.airspeed_mps for s in steady) / len(steady)
    v_gnd = sum(s.ground_speed_mps for s in steady) / len(steady)
    r_measured = v_gnd / rate
    r_theory = v_air**2 / (G * math.tan(bank))
    assert abs(r_measured - r_theory) < 0.15 * r_theory
    # the turn is level
    assert max(abs(s.up_m - START_AGL_M) for s in track) < 5.0


def test_full_pitch_stick_climbs_at_max_rate(plane):
    env = plane.envelope
    track = fly(plane, StickCommand(pitch=1.0), 15.0)
    rates = [s.v_up_mps for s in track if s.t_s >= 5.0]
    climb = sum(rates) / len(rates)
    assert abs(climb - env.max_climb_rate_mps) < 0.2 * env.max_climb_rate_mps
    assert min(eas(s) for s in track) > env.min_speed_mps


def test_full_down_stick_descends_at_max_rate(plane):
    env = plane.envelope
    track = fly(plane, StickCommand(pitch=-1.0), 15.0)
    rates = [s.v_up_mps for s in track if s.t_s >= 5.0]
    descent = -sum(rates) / len(rates)
    assert abs(descent - env.max_descent_rate_mps) < 0.2 * env.max_descent_rate_mps


def test_full_throttle_stick_accelerates_toward_max_speed(plane):
    env = plane.envelope
    track = fly(plane, StickCommand(throttle=1.0), 20.0)
    v_end = sum(eas(s) for s in track[-20:]) / 20
    assert v_end > env.cruise_speed_mps + 0.8 * (env.max_speed_mps - env.cruise_speed_mps)
    assert v_end < env.max_speed_mps + 1.5
    assert max(abs(s.up_m - START_AGL_M) for s in track) < 3.0


def test_idle_throttle_stick_slows_to_min_speed(plane):
    env = plane.envelope
    track = fly(plane, StickCommand(throttle=-1.0), 25.0)
    v_end = sum(eas(s) for s in track[-20:]) / 20
    assert abs(v_end - env.min_speed_mps) < 2.0
    assert max(abs(s.up_m - START_AGL_M) for s in track) < 3.0
    # the declared braking deceleration is available: cruise -> 90 % of the way to min speed
    target = env.min_speed_mps + 0.1 * (env.cruise_speed_mps - env.min_speed_mps)
    t_reach = next(s.t_s for s in track if eas(s) <= target)
    assert (env.cruise_speed_mps - target) / t_reach >= 0.8 * env.braking_decel_mps2


def test_reaction_time_reaches_max_bank(plane):
    env = plane.envelope
    track = fly(plane, StickCommand(roll=-1.0), 4.0, sample_s=0.05)
    t90 = next(s.t_s for s in track if s.roll_rad <= -0.9 * env.max_bank_rad)
    assert t90 <= env.reaction_time_s + 0.1


# -- Tern model sanity -------------------------------------------------------------


def _tern_xml():
    return ET.parse(OWN_MODELS / "Tern" / "Tern.xml").getroot()


def test_tern_model_numbers():
    root = _tern_xml()
    assert float(root.find("mass_balance/emptywt").text) == pytest.approx(2.5, abs=0.3)
    assert root.find("mass_balance/emptywt").get("unit") == "KG"
    assert float(root.find("metrics/wingspan").text) == pytest.approx(2.0, abs=0.1)
    assert root.find("metrics/wingspan").get("unit") == "M"
    p = FixedWingPlatform(load_profile("Tern"))
    mass_kg = p.fc("inertia/mass-slugs") * 14.5939
    span_m = p.fc("metrics/bw-ft") * FT_TO_M
    area_m2 = p.fc("metrics/Sw-sqft") * FT_TO_M**2
    assert mass_kg == pytest.approx(2.5, abs=0.3)
    assert span_m == pytest.approx(2.0, abs=0.1)
    # stall speed from the lift table's CL max at sea level
    lift = next(f for f in root.iter("function") if f.get("name") == "aero/force/Lift_alpha")
    rows = [line.split() for line in lift.find(".//tableData").text.strip().splitlines()]
    cl_max = max(float(r[1]) for r in rows)
    v_stall = math.sqrt(2.0 * mass_kg * G / (1.225 * area_m2 * cl_max))
    assert 9.0 <= v_stall <= 10.0
    assert p.envelope.min_speed_mps >= 1.2 * v_stall


def test_tern_stall_region():
    """Tern holds altitude at 10.5 m/s but cannot at 8 m/s (it stalls or sinks)."""
    p = FixedWingPlatform(load_profile("Tern"))

    def slow_flight(speed_mps):
        p.reset(FRAME, 47.0, 8.0, START_AGL_M, 0.0, 0.0)
        p.model.set("fc/min-speed-mps", speed_mps)
        p.model.set("fc/stall-guard-margin-mps", 20.0)  # guard off: the pitch loop pulls regardless
        p.command(StickCommand(throttle=-1.0))
        worst_alt, max_alpha = 0.0, -90.0
        for _ in range(250):
            p.step(12)
            s = p.truth()
            worst_alt = max(worst_alt, abs(s.up_m - START_AGL_M))
            max_alpha = max(max_alpha, p.fc("aero/alpha-deg"))
        return worst_alt, max_alpha, s.airspeed_mps

    alt_err, alpha, v = slow_flight(10.5)
    assert alt_err < 3.0 and alpha < 12.0 and abs(v - 10.5) < 1.0
    alt_err, alpha, v = slow_flight(8.0)
    assert alt_err > 3.0 or alpha > 12.0


def test_tern_sits_on_its_gear():
    p = FixedWingPlatform(load_profile("Tern"))
    p.reset(FRAME, 47.0, 8.0, 0.0, 0.0, 0.0)
    p.step(360)
    s = p.truth()
    assert s.on_ground or s.agl_m < 0.2
    assert abs(s.roll_rad) < math.radians(3.0) and abs(s.pitch_rad) < math.radians(5.0)
    assert math.hypot(s.east_m, s.north_m) < 0.5


def test_initial_crosswind_is_steady_not_a_gust(plane):
    """A wind set right after reset re-settles the start: the track drifts with the air mass."""
    plane.set_wind_enu(0.0, 0.0, 0.0)
    plane.reset(FRAME, 47.0, 8.0, START_AGL_M, 0.0, 0.0)
    plane.set_wind_enu(6.0, 0.0, 0.0)  # air moving east
    plane.command(StickCommand())
    s0 = plane.truth()
    assert s0.t_s == 0.0 and math.hypot(s0.east_m, s0.north_m) < 0.5
    assert s0.v_east_mps == pytest.approx(6.0, abs=1.0)
    assert abs((math.degrees(s0.yaw_rad) + 180.0) % 360.0 - 180.0) < 3.0  # nose on the requested heading, crabbing
    plane.step(int(round(10.0 / plane.dt_s)))
    s1 = plane.truth()
    assert s1.east_m == pytest.approx(60.0, rel=0.15)
    plane.set_wind_enu(0.0, 0.0, 0.0)


@pytest.mark.parametrize("model", ["J3Cub", "c172x"])
def test_a_piston_engine_is_leaned_for_altitude_and_climbs_at_a_high_site(model):
    """Full rich, the J3Cub's engine quits above about 2,500 m (it has no mixture control of its own); the FC
    leans it with the ambient pressure as a pilot does, so at a 2,700 m site it holds its height at cruise and
    still climbs at full stick."""
    p = FixedWingPlatform(load_profile(model))
    high = LocalFrame(39.7, 111.4, 2606.0)
    p.reset(high, 39.7, 111.4, 100.0, 0.0, 0.0)
    n = int(round(0.1 / p.dt_s))
    p.command(StickCommand())
    for _ in range(300):
        p.step(n)
    s = p.truth()
    assert p.model.get("fcs/mixture-pos-norm") == pytest.approx(p.model.get("atmosphere/P-psf") / 2116.22, rel=0.02)
    assert abs(s.up_m - 100.0) < 5.0 and abs(eas(s) - p.envelope.cruise_speed_mps) < 2.0
    h0 = s.up_m
    p.command(StickCommand(pitch=1.0, throttle=1.0))
    for _ in range(150):
        p.step(n)
    assert p.truth().up_m - h0 > 10.0  # 15 s at full climb stick


def _throttle_in_turbulence(profile) -> list[float]:
    """The throttle position, every 40 Hz step for 10 s, of ``profile`` holding cruise at a 2,639 m site in moderate
    turbulence (a J3Cub's floor-gap campaign case)."""
    field = wind_from_config(parse_wind({"speed_mps": 2.0, "from_deg": 25.0, "turbulence": {"severity": "moderate"}}), seed=7)
    p = build_platform(profile)
    p.reset(LocalFrame(-27.66, 132.74, 2639.0), -27.66, 132.74, 50.0, 0.0, p.envelope.cruise_speed_mps)
    p.command(StickCommand(roll=0.0, pitch=0.0, yaw=0.0, throttle=0.0))
    out, t = [], 0.0
    for _ in range(400):
        s = p.truth()
        p.set_wind_enu(*field.sample(t, s.east_m, s.north_m, s.agl_m, s.airspeed_mps))
        p.step(3)
        t += 0.025
        out.append(p.model.fdm["fcs/throttle-pos-norm"])
    return out


def test_the_j3cub_airspeed_loop_does_not_chatter_in_turbulence():
    """With a derivative gain on the turbulent airspeed (``fc/speed-kd: 0.3``, the J3Cub's until stop 26) the throttle
    went 0 <-> 1 every other step and the engine gave about half its power. The shipped profile holds it steady."""

    def flips(thr):
        return sum(abs(a - b) > 0.5 for a, b in zip(thr, thr[1:]))

    shipped = load_profile("J3Cub")
    steady = _throttle_in_turbulence(shipped)
    assert flips(steady) <= 4, flips(steady)
    chattering = _throttle_in_turbulence(replace(shipped, gains={**shipped.gains, "fc/speed-kd": 0.3}))
    assert flips(chattering) > 100  # the old gain: the test can tell
    assert sum(chattering) < 0.8 * sum(steady)  # ... and it cost power
