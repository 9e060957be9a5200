"""``characterize MODEL``: refusals, the shipped characterised profiles against what their models fly, a mission.

The drift tests fly each profile that ``characterize MODEL`` wrote (``aircraft/profiles/*.yaml`` whose header
says so) at the validation site and fail when the model no longer flies what the profile declares: cruise held,
the speed at full throttle stick, the sustained climb, and the turn radius and rate at max bank (within 10 % of
the declared envelope's ``V²/(g tan phi)``).
"""

from __future__ import annotations

import math
import shutil
import subprocess
import sys

import numpy as np
import pytest

from aircraft.characterization import MAX_SPEED_MARGIN, MIN_SPEED_MARGIN, check_flyable, choose_speeds
from aircraft.fixedwing import FixedWingPlatform
from aircraft.jsbsim_model import model_folder
from aircraft.profile import PROFILES_DIR, available_profiles, load_profile, parse_profile
from aircraft.validation import FRAME, LAT0_DEG, LON0_DEG, START_AGL_M
from geofence.geometry.geodesy import geodesic_destination
from geofence.interface import PlatformKind, StickCommand
from geofence.physics.dynamics import isa_density_ratio
from geofence.physics.rooms import turn_radius_m
from scenarios.definition.schema import parse_scenario
from scenarios.flight.runner import fly as fly_scenario
from tests.support import ROOT, fly

CHARACTERISED = sorted(
    n for n in available_profiles() if "profile characterised in the sim by" in (PROFILES_DIR / f"{n}.yaml").read_text()
)


def _cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "characterize", *args],
        capture_output=True,
        text=True,
        cwd=cwd or ROOT,
        env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
        timeout=120,
    )


@pytest.mark.parametrize(
    "model, phrase",
    [
        ("ball", "no engine"),
        ("SGS", "no engine"),
        ("F450", "fixed-wing only in this version"),
        ("c310", "2 engines"),
        ("paraglider", "no fcs/rudder-cmd-norm"),
        ("Submarine_Scout", "gives no thrust"),  # an airship: its engine gives no thrust at any propeller lever
        ("wrightFlyer1903", "trim failed"),  # two propellers on one engine; level flight at 12.5 m/s not held
    ],
)
def test_an_unflyable_model_is_refused_with_one_line_exit_2(tmp_path, model, phrase):
    out = tmp_path / "p.yaml"
    r = _cli(model, "--out", str(out))
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, r.stderr
    assert len(lines) == 1 and phrase in lines[0] and model in lines[0], r.stderr
    assert not out.exists()


def test_a_model_in_aircraft_dir_is_found_there(tmp_path):
    """A model only in --aircraft-dir is loaded from it (here a renamed ball: refused for having no engine)."""
    folder = tmp_path / "models" / "myball"
    shutil.copytree(model_folder("ball"), folder)
    (folder / "ball.xml").rename(folder / "myball.xml")
    r = _cli("myball", "--aircraft-dir", str(tmp_path / "models"), "--out", str(tmp_path / "p.yaml"))
    assert r.returncode == 2 and "characterize myball: no engine" in r.stderr, r.stderr
    r = _cli("myball", "--aircraft-dir", str(folder), "--out", str(tmp_path / "p.yaml"))  # the model's own folder
    assert r.returncode == 2 and "characterize myball: no engine" in r.stderr, r.stderr
    r = _cli("nosuch", "--aircraft-dir", str(tmp_path / "models"), "--out", str(tmp_path / "p.yaml"))
    assert r.returncode == 2 and "holds no nosuch/nosuch.xml" in r.stderr, r.stderr


def test_a_derived_model_of_ours_passes_the_controls_check_through_its_base():
    """C172W is c172x plus a propeller-drag element: its controls live in the base's files."""
    weight_n, area_m2 = check_flyable("C172W")
    assert 9000.0 < weight_n < 12000.0 and 15.0 < area_m2 < 17.0


def test_model_and_from_params_together_are_refused(tmp_path):
    r = _cli("pa28", "--from-params", "x.param", "--out", str(tmp_path / "p.yaml"))
    assert r.returncode == 2 and "one or the other" in r.stderr, r.stderr


def test_measured_on_defaults_to_the_model_and_is_inherited_through_base():
    assert load_profile("c172x").measured_on == "C172W"
    assert load_profile("pa28").measured_on == "pa28"
    inline = parse_profile({"base": "c172x"}, "pa28", "scenario.yaml")
    assert inline.model == "pa28" and inline.measured_on == "C172W"
    with pytest.raises(ValueError, match="measured_on"):
        parse_profile({"base": "c172x", "measured_on": 3}, "pa28", "scenario.yaml")


def test_speeds_are_chosen_inside_the_level_range_with_the_stated_margins():
    lo, cruise, hi = choose_speeds(30.6, 50.9)
    assert lo >= MIN_SPEED_MARGIN * 30.6 and hi <= MAX_SPEED_MARGIN * 50.9
    assert lo < cruise < hi and cruise % 0.5 == 0.0


def test_the_shipped_characterised_profiles_are_the_expected_ones():
    assert {"pa28", "c182", "pc7"} <= set(CHARACTERISED)
    for name in CHARACTERISED:
        text = (PROFILES_DIR / f"{name}.yaml").read_text()
        assert f"geofence-testbed characterize {name}" in text and "(UTC)" in text
        assert load_profile(name).measured_on == name


def _eas(p: FixedWingPlatform) -> float:
    return p.fc("fc/airspeed-mps")


@pytest.mark.closed_loop
@pytest.mark.parametrize("name", CHARACTERISED)
def test_a_characterised_profile_still_matches_what_its_model_flies(name):
    prof = load_profile(name)
    env = prof.envelope
    assert prof.kind is PlatformKind.FIXED_WING
    p = FixedWingPlatform(prof)
    h0 = START_AGL_M[PlatformKind.FIXED_WING]
    p.reset(FRAME, LAT0_DEG, LON0_DEG, h0, 0.0, 0.0)
    level = fly(p, StickCommand(), 30.0)  # after a turbine's spool-up (the pc7 needs ~15 s)
    assert abs(level[-1].up_m - h0) < 3.0
    assert _eas(p) == pytest.approx(env.cruise_speed_mps, rel=0.05), "cruise speed does not hold"
    run = fly(p, StickCommand(roll=1.0), 30.0)
    tail = run[-int(10 * 40) :]
    turn = sum((b.yaw_rad - a.yaw_rad + math.pi) % (2 * math.pi) - math.pi for a, b in zip(tail, tail[1:]))
    rate = turn / (tail[-1].t_s - tail[0].t_s)
    v = float(np.mean([s.airspeed_mps for s in tail]))
    tas_cruise = env.cruise_speed_mps / math.sqrt(isa_density_ratio(FRAME.h0_m + h0))
    assert v / rate == pytest.approx(turn_radius_m(tas_cruise, env.max_bank_rad), rel=0.10), "turn radius at max bank"
    assert rate == pytest.approx(env.max_yaw_rate_radps, rel=0.10), "turn rate at max bank"
    assert min(s.up_m for s in run) > h0 - 15.0
    fly(p, StickCommand(), 10.0)
    fly(p, StickCommand(throttle=1.0), 40.0)
    assert _eas(p) == pytest.approx(env.max_speed_mps, rel=0.05), "max speed at full throttle stick"
    fly(p, StickCommand(), 20.0)
    climb = fly(p, StickCommand(pitch=1.0), 15.0)
    assert np.mean([s.v_up_mps for s in climb[-200:]]) >= 0.85 * env.max_climb_rate_mps, "climb rate at full stick"


SITE = {"lat_deg": 47.0, "lon_deg": 8.0, "ground_alt_m": 400.0}


@pytest.mark.closed_loop
def test_pa28_with_its_characterised_profile_flies_a_mission_to_completion():
    """The known problem was a pa28 on the c172x profile diverging after ~59 s; its own profile flies a square."""
    size_m = 1500.0
    items = []
    for e, n in ((0.0, size_m), (size_m, size_m), (size_m, 0.0)):
        lat, lon = geodesic_destination(SITE["lat_deg"], SITE["lon_deg"], math.degrees(math.atan2(e, n)), math.hypot(e, n))
        items.append({"type": "waypoint", "lat_deg": lat, "lon_deg": lon, "agl_m": 300.0})
    doc = {
        "aircraft": "pa28",
        "duration_s": 200.0,
        "start": dict(SITE, agl_m=300.0, heading_deg=0.0),
        "mission": {"acceptance_radius_m": 80.0, "items": items},
    }
    res = fly_scenario(parse_scenario(doc, "pa28.yaml"))
    assert res.summary["error"] is None and res.summary["completed"], res.summary
    assert res.summary["waypoints_reached"] == len(items)
    ve, vn, up = (res.recorder.column(c) for c in ("v_east_mps", "v_north_mps", "up_m"))
    assert np.hypot(ve, vn).max() < 1.2 * res.scenario.profile.envelope.max_speed_mps
    assert np.ptp(up) < 60.0


@pytest.mark.closed_loop
@pytest.mark.parametrize("airframe", CHARACTERISED)
def test_a_characterised_airframe_holds_generated_adversarial_cases(airframe):
    """The campaign generator's head-on/shallow/corner attacks, a keep-out in the way and a ceiling, calm and
    windy (its draws), on the airframe's characterised profile: the predictive geofence holds (0 m outside, no
    keep-out entered). docs/validation.md has the larger run, and the same cases on a borrowed c172x profile."""
    from scenarios.campaign.generator import CaseFamily, Variant, generate_cases

    families = [CaseFamily.CONVEX_BOX, CaseFamily.ACUTE_CORNER, CaseFamily.KEEP_OUT, CaseFamily.CEILING]
    cases = generate_cases(40, 20261203, platforms=[airframe], families=families, max_duration_s=60.0)[:6]
    assert len(cases) >= 3, "the generator found few fences this airframe fits"  # (a fast one fits fewer sites)
    for case in cases:
        s = fly_scenario(parse_scenario(case.documents[Variant.PREDICTIVE], f"{case.case_id}.yaml")).summary
        assert s["max_excursion_m"] <= 0.0 and not s["breached_keep_out"], (case.case_id, s["max_excursion_m"])
