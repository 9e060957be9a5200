"""Autopilot parameter files -> profile envelope (aircraft.autopilot_params, the characterize command)."""

import math
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from aircraft.autopilot_params import Firmware, derive_envelope, parse_param_text, read_param_file
from aircraft.profile import load_profile, parse_profile
from geofence.interface import PlatformKind
from geofence.validation import ConfigError
from scenarios.app.characterize import profile_text

REPO = Path(__file__).parents[1]
ARDU_COPTER = (
    "# MAVProxy save\nANGLE_MAX 3500\nWPNAV_SPEED,800\nLOIT_SPEED 1250\nPILOT_SPEED_UP 300\nPILOT_SPEED_DN 0\nSERIAL0_BAUD 115\n"
)
PX4_PLANE = (
    "# Onboard parameters for Vehicle 1\n# Vehicle-Id Component-Id Name Value Type\n"
    "1\t1\tFW_R_LIM\t45.000000000000000000\t9\n1\t1\tFW_P_LIM_MAX\t25\t9\n1\t1\tFW_AIRSPD_TRIM\t15\t9\n"
    "1\t1\tFW_AIRSPD_MIN\t10\t9\n1\t1\tFW_AIRSPD_MAX\t20\t9\n1\t1\tFW_T_CLMB_MAX\t5\t9\n1\t1\tFW_T_SINK_MAX\t5\t9\n"
    "1\t1\tSYS_AUTOSTART\t4001\t6\n"
)


def test_ardupilot_copter_units_converted():
    p = parse_param_text(ARDU_COPTER, "a.param")
    assert p.firmware is Firmware.ARDUPILOT
    env = derive_envelope(p, PlatformKind.MULTIROTOR, "a.param")
    assert env["max_bank_deg"].value == pytest.approx(35.0, abs=1e-12)
    assert env["cruise_speed_mps"].value == pytest.approx(8.0, abs=1e-12)
    assert env["max_speed_mps"].value == pytest.approx(12.5, abs=1e-12)
    assert env["max_descent_rate_mps"].value == pytest.approx(3.0, abs=1e-12)  # PILOT_SPEED_DN 0 = same as up


def test_px4_plane_parsed_and_round_trips(tmp_path):
    f = tmp_path / "plane.params"
    f.write_text(PX4_PLANE)
    params = read_param_file(f)
    assert params.firmware is Firmware.PX4
    text = profile_text(params, PlatformKind.FIXED_WING, load_profile("c172x"), "c172x", str(f))
    assert "from FW_R_LIM in" in text and "not measured on this airframe" in text
    prof = parse_profile(yaml.safe_load(text), "x", "out.yaml")
    e = prof.envelope
    for got, want in ((e.max_bank_rad, math.radians(45)), (e.max_pitch_rad, math.radians(25)), (e.cruise_speed_mps, 15),
                      (e.min_speed_mps, 10), (e.max_speed_mps, 20), (e.max_climb_rate_mps, 5)):  # fmt: skip
        assert abs(got - want) < 1e-9
    assert abs(e.reaction_time_s - load_profile("c172x").envelope.reaction_time_s) < 1e-9  # from the base


def test_speed_order_violation_names_parameter():
    p = parse_param_text("WPNAV_SPEED 2000\nLOIT_SPEED 1250\n", "b.param")
    with pytest.raises(ConfigError, match=r"b.param: WPNAV_SPEED: .*must be <= max_speed_mps"):
        profile_text(p, PlatformKind.MULTIROTOR, load_profile("F450"), "F450", "b.param")


@pytest.mark.parametrize(
    "text, match",
    [("SERIAL0_BAUD 57\n", "none of the"), ("", "no parameters"), ("ANGLE_MAX nan\n", "finite"),
     ("ANGLE_MAX 9000\n", "ANGLE_MAX: gives max_bank_deg = 90"), ("A 1 2 3\n", "line 1"), ("X " + "1" * 5000, "longer")],
)  # fmt: skip
def test_refusals_are_one_line(text, match):
    with pytest.raises(ConfigError, match=match) as exc:
        derive_envelope(parse_param_text(text, "f.param"), PlatformKind.MULTIROTOR, "f.param")
    assert "\n" not in str(exc.value)


def test_oversized_file_refused(tmp_path):
    f = tmp_path / "big.param"
    f.write_bytes(b"ANGLE_MAX 3000\n" * 400_000)
    with pytest.raises(ConfigError, match="larger than 5 MB"):
        read_param_file(f)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=300))
def test_parse_never_raises_other_than_config_error(text):
    try:
        parse_param_text(text, "h.param")
    except ConfigError:
        pass


def test_cli_refusal_is_one_line_exit_2(tmp_path):
    f = tmp_path / "bad.param"
    f.write_text("AIRSPEED_CRUISE 30\nAIRSPEED_MAX 25\n")
    r = subprocess.run([sys.executable, "-m", "scenarios.app.cli", "characterize", "--from-params", str(f), "--kind",
                        "fixed_wing", "--out", str(tmp_path / "o.yaml")], capture_output=True, text=True, cwd=REPO)  # fmt: skip
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "AIRSPEED_CRUISE" in r.stderr
    assert not (tmp_path / "o.yaml").exists()


REALWORLD = REPO.parent / "shared" / "realworld"


@pytest.mark.skipif(not any(REALWORLD.glob("*.param*")), reason="no real ArduPilot/PX4 parameter files in ../shared/realworld")
@pytest.mark.parametrize("path", sorted(REALWORLD.glob("*.param*")))
def test_real_parameter_files_parse(path):
    assert read_param_file(path).values
