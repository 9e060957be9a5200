"""Closed-loop checks of the F450 multicopter platform against its stick semantics and envelope.

Each test flies a few simulated seconds through the Platform protocol only
(reset / command / step / truth), with a 40 Hz outer loop like the simulation's.
"""

from __future__ import annotations

import math

import pytest
from support import fly

from aircraft.multicopter import MulticopterPlatform
from aircraft.profile import load_profile
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import StickCommand

LAT0, LON0, H0 = 44.7258, -93.0759, 285.0
FRAME = LocalFrame(LAT0, LON0, H0)


@pytest.fixture(scope="module")
def quad() -> MulticopterPlatform:
    return MulticopterPlatform(load_profile("F450"))


def start(pl: MulticopterPlatform, agl_m: float = 30.0, heading_deg: float = 0.0) -> None:
    pl.set_wind_enu(0.0, 0.0, 0.0)
    pl.reset(FRAME, LAT0, LON0, agl_m, heading_deg, 0.0)


def test_zero_sticks_hold_altitude_level_and_position(quad):
    start(quad, agl_m=30.0)
    states = fly(quad, StickCommand(), 10.0)
    assert max(abs(s.up_m - 30.0) for s in states) < 0.3
    assert max(max(abs(s.roll_rad), abs(s.pitch_rad)) for s in states) < math.radians(1.0)
    assert max(math.hypot(s.east_m, s.north_m) for s in states) < 0.3
    assert not any(s.on_ground for s in states)


@pytest.mark.parametrize("axis", ["roll", "pitch"])
@pytest.mark.parametrize("stick", [0.5, -1.0])
def test_tilt_stick_commands_tilt_angle(quad, axis, stick):
    env = quad.envelope
    limit = env.max_bank_rad if axis == "roll" else env.max_pitch_rad
    target = stick * limit
    start(quad)
    states = fly(quad, StickCommand(**{axis: stick}), 3.0)
    angle = [(s.t_s, s.roll_rad if axis == "roll" else s.pitch_rad) for s in states]
    settled = [a for t, a in angle if t >= 1.5]
    assert all(abs(a - target) <= 0.1 * abs(target) for a in settled)
    # peak overshoot stays modest and the sign is right from the start
    assert max(abs(a) for _, a in angle) < 1.2 * abs(target)
    assert all(a * target >= -1e-3 for _, a in angle)
    other = [s.pitch_rad if axis == "roll" else s.roll_rad for s in states]
    assert max(abs(a) for a in other) < math.radians(1.0)


def test_positive_roll_banks_right_and_positive_pitch_flies_backwards(quad):
    start(quad, heading_deg=0.0)  # nose north
    s = fly(quad, StickCommand(roll=0.5), 3.0)[-1]
    assert s.roll_rad > 0 and s.v_east_mps > 1.0  # right bank -> moves east
    start(quad, heading_deg=0.0)
    s = fly(quad, StickCommand(pitch=0.5), 3.0)[-1]
    assert s.pitch_rad > 0 and s.v_north_mps < -1.0  # nose up -> moves backwards (south)


@pytest.mark.parametrize("stick", [1.0, -1.0, 0.5])
def test_throttle_stick_commands_climb_rate(quad, stick):
    env = quad.envelope
    target = stick * (env.max_climb_rate_mps if stick > 0 else env.max_descent_rate_mps)
    start(quad, agl_m=30.0)
    states = fly(quad, StickCommand(throttle=stick), 4.0)
    rates = [s.v_up_mps for s in states if s.t_s >= 2.0]
    assert all(abs(v - target) <= 0.15 * abs(target) for v in rates)
    dz = states[-1].up_m - 30.0
    assert dz * target > 0 and abs(dz) > 0.5 * abs(target) * 4.0


def test_throttle_release_arrests_climb_within_vertical_envelope(quad):
    env = quad.envelope
    start(quad, agl_m=30.0)
    fly(quad, StickCommand(throttle=1.0), 3.0)
    s0 = quad.truth()
    v0 = s0.v_up_mps
    states = fly(quad, StickCommand(), 5.0)
    stop = next(s for s in states if s.v_up_mps <= 0.0)
    predicted = v0 * env.reaction_time_s + v0**2 / (2.0 * env.vertical_accel_mps2)
    assert stop.up_m - s0.up_m <= 1.3 * predicted
    # then holds the new altitude
    assert abs(states[-1].up_m - stop.up_m) < 0.3 and abs(states[-1].v_up_mps) < 0.1


@pytest.mark.parametrize("stick", [0.5, -1.0])
def test_yaw_stick_commands_heading_rate(quad, stick):
    target = stick * quad.envelope.max_yaw_rate_radps
    start(quad)
    fly(quad, StickCommand(yaw=stick), 1.0)
    a = quad.truth()
    fly(quad, StickCommand(yaw=stick), 2.0)
    b = quad.truth()
    dpsi = (b.yaw_rad - a.yaw_rad + math.pi) % (2.0 * math.pi) - math.pi
    if abs(target * (b.t_s - a.t_s)) > math.pi:  # unwrap using the expected direction
        dpsi += math.copysign(2.0 * math.pi, target)
    rate = dpsi / (b.t_s - a.t_s)
    assert rate == pytest.approx(target, rel=0.1)
    assert abs(b.up_m - 30.0) < 0.3


def test_ground_start_idles_then_lifts_off_and_lands(quad):
    start(quad, agl_m=0.0)
    s = quad.truth()
    assert s.agl_m < 0.3 and abs(s.v_up_mps) < 0.1
    rest = fly(quad, StickCommand(), 2.0)  # zero throttle on the ground: stays down
    assert max(r.agl_m for r in rest) < 0.3
    climb = fly(quad, StickCommand(throttle=0.5), 3.0)
    assert climb[-1].agl_m > 2.0
    assert climb[-1].v_up_mps == pytest.approx(0.5 * quad.envelope.max_climb_rate_mps, rel=0.2)
    # full descent to touchdown, then sits still without bouncing or diverging
    land = fly(quad, StickCommand(throttle=-1.0), 8.0)
    assert land[-1].agl_m < 0.3 and abs(land[-1].v_up_mps) < 0.05
    assert max(max(abs(x.roll_rad), abs(x.pitch_rad)) for x in land) < math.radians(15.0)


def test_full_forward_stick_reaches_max_speed_then_brakes_within_envelope(quad):
    env = quad.envelope
    start(quad, agl_m=30.0, heading_deg=0.0)
    run = fly(quad, StickCommand(pitch=-1.0), 8.0)
    s0 = run[-1]
    assert s0.ground_speed_mps >= 0.8 * env.max_speed_mps
    assert s0.v_north_mps > 0.95 * s0.ground_speed_mps  # forward = along the heading (north)
    assert min(s.up_m for s in run) > 28.0  # altitude held while accelerating
    v0 = s0.v_north_mps
    brake = fly(quad, StickCommand(pitch=1.0), 15.0, until=lambda s: s.v_north_mps <= 0.0)
    assert brake[-1].v_north_mps <= 0.0
    distance = brake[-1].north_m - s0.north_m
    predicted = v0 * env.reaction_time_s + v0**2 / (2.0 * env.braking_decel_mps2)
    assert distance == pytest.approx(predicted, rel=0.3)
    assert min(s.up_m for s in brake) > 28.0


def test_zero_sticks_drift_downwind(quad):
    start(quad, agl_m=30.0)
    quad.set_wind_enu(5.0, 0.0, 0.0)  # air moves toward the east
    states = fly(quad, StickCommand(), 10.0)
    end = states[-1]
    assert end.east_m > 2.0 and end.v_east_mps > 0.5
    assert abs(end.north_m) < 0.5 and abs(end.up_m - 30.0) < 0.3
    quad.set_wind_enu(0.0, 0.0, 0.0)


def test_sticks_beyond_unit_range_are_clipped(quad):
    start(quad)
    over = fly(quad, StickCommand(roll=3.0, throttle=-7.0), 2.0)[-1]
    start(quad)
    full = fly(quad, StickCommand(roll=1.0, throttle=-1.0), 2.0)[-1]
    assert over.roll_rad == pytest.approx(full.roll_rad, abs=1e-6)
    assert over.up_m == pytest.approx(full.up_m, abs=1e-6)


def test_reset_is_repeatable_and_keeps_the_wind(quad):
    start(quad)
    quad.set_wind_enu(0.0, 3.0, 0.0)
    a = fly(quad, StickCommand(roll=0.4, yaw=0.3, throttle=0.6), 2.0)[-1]
    quad.reset(FRAME, LAT0, LON0, 30.0, 0.0, 0.0)  # wind still 3 m/s toward north
    b = fly(quad, StickCommand(roll=0.4, yaw=0.3, throttle=0.6), 2.0)[-1]
    assert (b.east_m, b.north_m, b.up_m, b.yaw_rad) == pytest.approx((a.east_m, a.north_m, a.up_m, a.yaw_rad), abs=1e-9)
    assert b.t_s == pytest.approx(2.0, abs=quad.dt_s)
    start(quad)  # calm again
    c = fly(quad, StickCommand(roll=0.4, yaw=0.3, throttle=0.6), 2.0)[-1]
    assert abs(c.north_m - a.north_m) > 0.05
