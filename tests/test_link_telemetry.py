"""The MAVLink vocabulary (scenarios.link): every encoder/decoder round-trips through packed MAVLink 2 bytes within
its field's quantisation, the ISA conversion against the standard table, and the vehicle's override record."""

from __future__ import annotations

import math

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from geofence.estimation.measurements import AirData, AttitudeSample, GpsFix
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import PlatformKind, StickCommand, VehicleState
from geofence.physics.dynamics import isa_density_ratio
from scenarios.link import sticks, telemetry
from scenarios.link.sticks import Autopilot, OverrideInput

mav = telemetry.mav

sticks_values = st.floats(-1.0, 1.0, allow_nan=False)
lat_values = st.floats(-89.0, 89.0, allow_nan=False)
lon_values = st.floats(-180.0, 180.0, allow_nan=False)
alt_values = st.floats(-400.0, 5000.0, allow_nan=False)
speed_values = st.floats(-60.0, 60.0, allow_nan=False)
angle_values = st.floats(-math.pi, math.pi, allow_nan=False)


def wire(msg, src_system: int = 1, src_component: int = 1):
    """``msg`` packed as MAVLink 2 bytes and parsed back (what the other end receives)."""
    link = mav.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
    data = msg.pack(link)
    assert data[0] == 0xFD  # MAVLink 2
    return mav.MAVLink(None).decode(bytearray(data))


# --------------------------------------------------------------------------- sticks


@given(sticks_values)
def test_pwm_within_half_a_microsecond_of_the_linear_map(x):
    pwm = sticks.stick_to_pwm(x)
    assert 1000 <= pwm <= 2000
    assert abs(pwm - (1500.0 + 500.0 * x)) <= 0.5
    assert abs(sticks.pwm_to_stick(pwm) - x) <= 0.5 / 500.0 + 1e-12


@given(st.integers(1000, 2000))
def test_pwm_round_trips_exactly(pwm):
    assert sticks.stick_to_pwm(sticks.pwm_to_stick(pwm)) == pwm


@given(sticks_values, sticks_values, sticks_values, sticks_values)
def test_rc_override_round_trip(roll, pitch, yaw, throttle):
    cmd = StickCommand(roll, pitch, yaw, throttle)
    got = wire(sticks.rc_override(cmd, 1), src_system=255)
    assert [got.chan5_raw, got.chan6_raw, got.chan7_raw, got.chan8_raw] == [sticks.CHANNEL_IGNORE] * 4
    values = sticks.rc_override_channels(got)
    for name, v in zip(sticks.STICK_CHANNELS, values):
        assert isinstance(v, float) and abs(v - getattr(cmd, name)) <= 1e-3 + 1e-12


@given(sticks_values, sticks_values, sticks_values, sticks_values)
def test_manual_control_round_trip(roll, pitch, yaw, throttle):
    got = sticks.manual_control_sticks(wire(sticks.manual_control(StickCommand(roll, pitch, yaw, throttle), 1)))
    assert abs(got.roll - roll) <= 5e-4 + 1e-12 and abs(got.pitch - pitch) <= 5e-4 + 1e-12
    assert abs(got.yaw - yaw) <= 5e-4 + 1e-12 and abs(got.throttle - throttle) <= 1e-3 + 1e-12


def test_release_and_ignore_channels():
    released = sticks.rc_override_channels(wire(sticks.rc_release(1)))
    assert released == (None, None, None, None)
    msg = mav.MAVLink_rc_channels_override_message(1, 1, 65535, 2000, 0, 65535, 0, 0, 0, 0)
    assert sticks.rc_override_channels(msg) == (False, 1.0, None, False)


def test_ardupilot_override_per_channel_timeout_release_and_sender():
    pilot = StickCommand(0.1, 0.2, 0.3, 0.4)
    ov = OverrideInput(Autopilot.ARDUPILOT)
    assert not ov.receive(wire(sticks.rc_override(StickCommand(-1, -1, -1, -1), 1), src_system=1), 0.0)  # not the GCS
    assert ov.sticks(pilot, 0.0) == (pilot, False)
    assert ov.receive(wire(sticks.rc_override(StickCommand(1.0, -0.5, 0.0, 0.5), 1), src_system=255), 1.0)
    assert ov.sticks(pilot, 1.0) == (StickCommand(1.0, -0.5, 0.0, 0.5), True)
    # chan1 refreshed at 3.5 s, the others not: at 4.2 s only roll is still overridden
    partial = mav.MAVLink_rc_channels_override_message(1, 1, 1000, *([65535] * 7))
    assert ov.receive(wire(partial, src_system=255), 3.5)
    assert ov.sticks(pilot, 3.99) == (StickCommand(-1.0, -0.5, 0.0, 0.5), True)
    assert ov.sticks(pilot, 4.2) == (StickCommand(-1.0, 0.2, 0.3, 0.4), True)
    assert ov.receive(wire(sticks.rc_release(1), src_system=255), 4.3)
    assert ov.sticks(pilot, 4.3) == (pilot, False)
    assert ov.accepted == 3 and ov.rejected == 1
    assert not ov.receive(wire(sticks.manual_control(pilot, 1)), 5.0)  # PX4's message on an ArduPilot


def test_px4_manual_control_times_out():
    pilot = StickCommand()
    ov = OverrideInput(Autopilot.PX4, manual_timeout_s=0.5)
    assert not ov.receive(wire(sticks.manual_control(StickCommand(roll=1.0), 7)), 0.0)  # another vehicle's
    assert ov.receive(wire(sticks.manual_control(StickCommand(roll=1.0), 1)), 0.0)
    assert ov.sticks(pilot, 0.49)[1] and ov.sticks(pilot, 0.49)[0].roll == 1.0
    assert ov.sticks(pilot, 0.5) == (pilot, False)


# --------------------------------------------------------------------------- ISA


def test_isa_pressure_matches_the_standard_table():
    # ICAO standard atmosphere (geopotential height): 0 m 101325 Pa, 1000 m 89875 Pa, 5000 m 54020 Pa, 11000 m 22632 Pa
    for h, p in ((0.0, 101325.0), (1000.0, 89875.0), (5000.0, 54020.0), (11000.0, 22632.0)):
        assert telemetry.isa_pressure_pa(h) == pytest.approx(p, rel=1e-4)


@given(st.floats(-500.0, 11000.0, allow_nan=False))
def test_isa_inverse_and_density_agree(h):
    p = telemetry.isa_pressure_pa(h)
    assert telemetry.isa_altitude_m(p) == pytest.approx(h, abs=1e-6)
    t_ratio = 1.0 - telemetry.ISA_LAPSE_K_PER_M / telemetry.ISA_T0_K * h
    assert (p / telemetry.ISA_P0_PA) / t_ratio == pytest.approx(isa_density_ratio(h), rel=1e-4)


# --------------------------------------------------------------------------- telemetry


@given(st.floats(0.0, 3600.0, allow_nan=False), angle_values, angle_values, st.floats(-10.0, 10.0, allow_nan=False))
@example(0.0, 0.0, 0.0, -4.7947272932916524e-26)  # (a tiny negative yaw: % 2 pi alone gives 2 pi, not in [0, 2 pi))
def test_attitude_round_trip(t, roll, pitch, yaw):
    got = telemetry.attitude_sample(wire(telemetry.attitude(AttitudeSample(t, roll, pitch / 2, yaw))))
    assert got.t_s == round(t * 1000.0) / 1000.0
    assert got.roll_rad == pytest.approx(roll, abs=1e-6) and got.pitch_rad == pytest.approx(pitch / 2, abs=1e-6)
    d = (got.yaw_rad - yaw) % (2 * math.pi)
    assert 0.0 <= got.yaw_rad < 2 * math.pi and min(d, 2 * math.pi - d) <= 2e-6


@given(lat_values, lon_values, alt_values, speed_values, speed_values, st.floats(-20, 20), angle_values)
def test_global_position_int_round_trip(lat, lon, alt, ve, vn, vu, yaw):
    frame = LocalFrame(lat, lon, 100.0)
    s = VehicleState(t_s=12.3456, lat_deg=lat, lon_deg=lon, alt_m=alt, v_east_mps=ve, v_north_mps=vn, v_up_mps=vu, yaw_rad=yaw)
    got = telemetry.vehicle_state(wire(telemetry.global_position_int(s, home_alt_m=100.0)), None, frame)
    assert got.t_s == 12.346
    assert abs(got.lat_deg - lat) <= 5e-8 + 1e-12 and abs(got.lon_deg - lon) <= 5e-8 + 1e-12
    assert abs(got.alt_m - alt) <= 5e-4 + 1e-9 and abs(got.agl_m - (alt - 100.0)) <= 5e-4 + 1e-9
    for a, b in ((got.v_east_mps, ve), (got.v_north_mps, vn), (got.v_up_mps, vu)):
        assert abs(a - b) <= 5e-3 + 1e-9
    e, n, u = frame.to_enu(got.lat_deg, got.lon_deg, got.alt_m)
    assert (got.east_m, got.north_m, got.up_m) == (e, n, u)


@given(lat_values, lon_values, alt_values, st.floats(-40, 40), st.floats(-40, 40), st.floats(-10, 10), st.floats(0.01, 50))
def test_gps_raw_int_round_trip(lat, lon, alt, ve, vn, vu, acc):
    fix = GpsFix(7.25, lat, lon, alt, ve, vn, vu, acc, 2 * acc, True)
    got = telemetry.gps_fix(wire(telemetry.gps_raw_int(fix)), v_up_mps=vu)
    assert got.valid and got.t_s == 7.25 and got.v_up_mps == vu
    assert abs(got.lat_deg - lat) <= 5e-8 + 1e-12 and abs(got.lon_deg - lon) <= 5e-8 + 1e-12
    assert abs(got.alt_m - alt) <= 5e-4 + 1e-9
    # speed to 0.5 cm/s, course to 0.005 deg
    bound = 5e-3 + math.hypot(ve, vn) * math.radians(0.005) + 1e-9
    assert math.hypot(got.v_east_mps - ve, got.v_north_mps - vn) <= bound
    assert abs(got.horizontal_accuracy_m - acc) <= 5e-4 + 1e-9 and abs(got.vertical_accuracy_m - 2 * acc) <= 5e-4 + 1e-9


def test_gps_raw_int_without_a_fix():
    nan = math.nan
    msg = wire(telemetry.gps_raw_int(GpsFix(3.0, nan, nan, nan, nan, nan, nan, math.inf, math.inf, False)))
    assert msg.fix_type == 0 and msg.time_usec == 3_000_000
    got = telemetry.gps_fix(msg, 0.0)
    assert not got.valid and math.isnan(got.lat_deg) and got.horizontal_accuracy_m == math.inf


@given(alt_values, st.floats(0.0, 60.0, allow_nan=False), st.booleans())
def test_air_data_round_trip(baro_alt, airspeed, has_pitot):
    air = AirData(1.5, airspeed if has_pitot else None, baro_alt)
    state = VehicleState(alt_m=baro_alt)
    got = telemetry.air_data(wire(telemetry.scaled_pressure(air)), wire(telemetry.vfr_hud(air, state)), has_pitot)
    assert got.t_s == 1.5
    assert abs(got.baro_alt_m - baro_alt) <= 2e-3  # float32 hPa: under 1 mm of altitude below 5 km
    if has_pitot:
        assert got.airspeed_mps == pytest.approx(airspeed, abs=1e-5)
    else:
        assert got.airspeed_mps is None


@given(st.floats(-30, 30), st.floats(-30, 30), st.floats(-5, 5))
def test_wind_round_trip(we, wn, wu):
    got = telemetry.wind_enu(wire(telemetry.wind((we, wn, wu))))
    for a, b in zip(got, (we, wn, wu)):
        assert a == pytest.approx(b, abs=1e-4)


def test_wind_direction_is_where_it_comes_from():
    assert wire(telemetry.wind((0.0, -5.0, 0.0))).direction == pytest.approx(0.0)  # blowing south: from the north
    assert wire(telemetry.wind((-5.0, 0.0, 0.0))).direction == pytest.approx(90.0)  # from the east


def test_heartbeat_identities():
    hb = wire(telemetry.heartbeat(PlatformKind.FIXED_WING, Autopilot.PX4, powering_off=True))
    assert (hb.type, hb.autopilot, hb.system_status) == (mav.MAV_TYPE_FIXED_WING, mav.MAV_AUTOPILOT_PX4, mav.MAV_STATE_POWEROFF)
    hb = wire(telemetry.heartbeat(PlatformKind.MULTIROTOR, Autopilot.ARDUPILOT))
    assert (hb.type, hb.autopilot, hb.system_status) == (
        mav.MAV_TYPE_QUADROTOR,
        mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
        mav.MAV_STATE_ACTIVE,
    )


def test_gf_margin_clipped_and_named():
    for margin, sent in ((math.inf, 1e6), (-math.inf, -1e6), (math.nan, -1e6), (12.5, 12.5)):
        msg = wire(telemetry.gf_margin(4321, margin), src_system=255, src_component=191)
        assert telemetry.named_value_name(msg) == telemetry.GF_MARGIN_NAME and msg.time_boot_ms == 4321
        assert msg.value == pytest.approx(sent)
