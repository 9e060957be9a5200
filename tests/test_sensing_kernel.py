"""Property: the compiled sensing chain gives the reference objects' numbers, bit for bit.

:func:`aircraft.sensor_kernel.sensors_step` is the array form of :class:`~aircraft.sensors.SensorSuite` (the
state and wind estimators are written once: ``tests/test_estimator.py``, ``tests/test_wind_estimator.py``). Stepped
side by side along random manoeuvring flights (turns,
climbs, a stop, GNSS outages and a receiver failure, sensor tunings that switch the barometer from primary to
calibrated, no latency, no pre-filled fix, both platform kinds, past the noise pools' refills) every sample must
be equal as floats' bits.
Whole flights fly the same either way (:mod:`scenarios.flight.sensing` switches with :func:`geofence.jit.use_compiled`).
"""

import math
import random
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_lateral_kernel import fly_both_ways

from aircraft.sensor_kernel import MAX_DRAWS_PER_STEP, SensorArrays, sensors_step
from aircraft.sensors import SensorConfig, SensorSuite
from geofence.geodesy import LocalFrame
from geofence.interface import VehicleState
from scenarios.spec.schema import load_scenario

ROOT = Path(__file__).resolve().parents[1]
FRAME = LocalFrame(47.3, 8.5, 420.0)


def _bits(x) -> str:
    return "None" if x is None else float(x).hex()


def truth_states(seed: int, n: int, dt: float, multirotor: bool):
    """A random manoeuvring flight's truth: turns, climbs and descents, speed changes and a hover (multirotor)."""
    rng = random.Random(seed)
    e = n_ = 0.0
    up = 50.0
    psi = rng.uniform(0, 2 * math.pi)
    v = 5.0 if multirotor else 18.0
    vu = 0.0
    roll = pitch = 0.0
    t = 0.0
    for k in range(n):
        if k % 80 == 0:
            roll = rng.uniform(-0.5, 0.5)
            vu = rng.uniform(-2.0, 2.0)
            v = rng.uniform(0.0, 12.0) if multirotor else rng.uniform(14.0, 24.0)
            pitch = rng.uniform(-0.3, 0.3) if multirotor else 0.05
        psi += 9.81 * math.tan(roll) / max(v, 5.0) * dt
        ve, vn = v * math.sin(psi), v * math.cos(psi)
        e += ve * dt
        n_ += vn * dt
        up += vu * dt
        lat, lon, alt = FRAME.to_geodetic(e, n_, up)
        yield VehicleState(
            t, lat, lon, alt, e, n_, up, up, ve, vn, vu, roll, pitch, psi % (2 * math.pi), math.hypot(v, 3.0), False
        )
        t += dt


def sensor_configs():
    return st.builds(
        SensorConfig,
        gps_rate_hz=st.sampled_from([1.0, 5.0, 10.0]),
        gps_latency_s=st.sampled_from([0.0, 0.11, 0.2, 0.55]),
        gps_h_bias_m=st.sampled_from([0.0, 1.5]),
        gps_v_bias_m=st.sampled_from([0.5, 3.0]),
        baro_drift_m=st.sampled_from([0.0, 1.0, 4.0]),
        ahrs_tau_s=st.sampled_from([0.0, 5.0]),
        gps_fail_at_s=st.sampled_from([None, 61.0]),
        gps_outages=st.sampled_from([(), ((12.0, 14.5), (30.0, 31.0))]),
    )


@settings(max_examples=12, deadline=None)
@given(
    cfg=sensor_configs(),
    seed=st.integers(0, 10_000),
    multirotor=st.booleans(),
    prefill=st.booleans(),
)
def test_the_compiled_sensors_are_the_reference_sensors(cfg, seed, multirotor, prefill):
    dt = 0.025
    suite = SensorSuite(cfg, has_pitot=not multirotor, seed=seed, prefill=prefill)
    arrays = SensorArrays(cfg, has_pitot=not multirotor, seed=seed, prefill=prefill)
    refills = 0
    for truth in truth_states(seed, 3000, dt, multirotor):  # 75 s: every pool refills at least once
        fix, air, att = suite.sample(truth)
        args = arrays.args()
        S, C, out, pend, gps, baro, pitot, ahrs, idx, fix_row = args
        delivered, a_ind, baro_alt, r, p, y = sensors_step(
            *args, truth.t_s, truth.lat_deg, truth.lon_deg, truth.alt_m, truth.v_east_mps, truth.v_north_mps,
            truth.v_up_mps, truth.airspeed_mps, truth.roll_rad, truth.pitch_rad, truth.yaw_rad,
        )  # fmt: skip
        assert delivered == (fix is not None)
        if fix is not None:
            assert [_bits(v) for v in fix] == [_bits(v) for v in fix_row], truth.t_s
        ref_air = air.airspeed_mps if air.airspeed_mps is not None else math.nan
        assert [_bits(v) for v in (ref_air, air.baro_alt_m, *att[1:])] == [_bits(v) for v in (a_ind, baro_alt, r, p, y)]
        assert max(g.shape[0] - i for g, i in zip((gps, baro, pitot, ahrs), idx)) >= MAX_DRAWS_PER_STEP
        refills += arrays.refill()

    assert refills >= 2


@pytest.mark.parametrize(
    "name, seconds",
    [("geofence_gps_loss_fixedwing.yaml", 60.0), ("geofence_multicopter_adversarial_wind.yaml", 40.0)],
)
def test_a_flight_senses_the_same_compiled_and_in_python(name, seconds):
    """The unit's whole view of a flight (its estimate and wind estimate are recorded) is the same either way:
    a fixed-wing that loses its GNSS, and a multirotor against an adversarial pilot in wind."""
    fly_both_ways(replace(load_scenario(ROOT / "scenarios" / name), duration_s=seconds))


def test_a_latency_of_many_fix_periods_is_sensed_the_same():
    """The pending GNSS ring is sized by the configuration (here 90 messages in flight), not a fixed capacity."""
    cfg = SensorConfig(gps_rate_hz=10.0, gps_latency_s=9.0, seed=4)
    suite = SensorSuite(cfg, has_pitot=True)
    arrays = SensorArrays(cfg, has_pitot=True)
    delivered_count = 0
    for truth in truth_states(4, 1200, 0.025, False):
        fix, _air, _att = suite.sample(truth)
        delivered, *_ = sensors_step(
            *arrays.args(), truth.t_s, truth.lat_deg, truth.lon_deg, truth.alt_m, truth.v_east_mps, truth.v_north_mps,
            truth.v_up_mps, truth.airspeed_mps, truth.roll_rad, truth.pitch_rad, truth.yaw_rad,
        )  # fmt: skip
        arrays.refill()
        assert delivered == (fix is not None)
        if fix is not None:
            delivered_count += 1
            assert [_bits(v) for v in fix] == [_bits(v) for v in arrays.fix]
    assert delivered_count > 100
