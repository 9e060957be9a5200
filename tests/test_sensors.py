"""Sensor models of the geofence unit: noise statistics, rates, latency, outages, reproducibility, YAML block."""

import math

import numpy as np
import pytest

from aircraft.sensors import (
    AHRS_STREAM,
    BARO_STREAM,
    GPS_STREAM,
    NORMAL_BLOCK,
    PITOT_STREAM,
    SensorConfig,
    SensorSuite,
    parse_sensors,
    stream_generator,
)
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import VehicleState
from geofence.physics.dynamics import isa_density_ratio

FRAME = LocalFrame(47.0, 8.0, 400.0)
DT = 0.025


def hover_truth(t: float) -> VehicleState:
    lat, lon, h = FRAME.to_geodetic(0.0, 0.0, 30.0)
    return VehicleState(t, lat, lon, h, 0.0, 0.0, 30.0, 30.0, 0.0, 0.0, 0.0, 0.1, -0.05, 1.0, 20.0)


def run(suite: SensorSuite, seconds: float, truth_fn=hover_truth):
    out = []
    for k in range(int(round(seconds / DT))):
        t = k * DT
        out.append((t, *suite.sample(truth_fn(t))))
    return out


def test_gps_rate_and_latency():
    suite = SensorSuite(SensorConfig(gps_rate_hz=5.0, gps_latency_s=0.2), seed=1)
    rows = run(suite, 20.0)
    fixes = [(t, f) for t, f, _, _ in rows if f is not None]
    # 5 Hz for 20 s, plus the pre-filled fix at step 0
    assert len(fixes) == pytest.approx(100, abs=1)
    assert fixes[0][0] == 0.0 and fixes[0][1].t_s == pytest.approx(-0.2)
    for t, f in fixes:
        assert t - f.t_s == pytest.approx(0.2, abs=1e-9)
    gaps = np.diff([t for t, _ in fixes])
    assert np.allclose(gaps, 0.2, atol=1e-9)


def test_no_prefill_first_fix_after_latency():
    suite = SensorSuite(SensorConfig(gps_latency_s=0.3), seed=1, prefill=False)
    rows = run(suite, 2.0)
    first = next(t for t, f, _, _ in rows if f is not None)
    assert first == pytest.approx(0.3, abs=1e-9)


def test_gps_noise_statistics():
    cfg = SensorConfig(gps_bias_tau_s=1.0)  # short tau so a long run samples the bias distribution
    suite = SensorSuite(cfg, seed=2)
    rows = run(suite, 600.0)
    enu = np.array([FRAME.to_enu(f.lat_deg, f.lon_deg, f.alt_m) for _, f, _, _ in rows if f is not None])
    vel = np.array([(f.v_east_mps, f.v_north_mps, f.v_up_mps) for _, f, _, _ in rows if f is not None])
    err = enu - np.array([0.0, 0.0, 30.0])
    assert abs(err[:, 0].mean()) < 0.3 and abs(err[:, 1].mean()) < 0.3
    assert err[:, 0].std() == pytest.approx(cfg.gps_h_sigma_m, rel=0.12)
    assert err[:, 1].std() == pytest.approx(cfg.gps_h_sigma_m, rel=0.12)
    assert err[:, 2].std() == pytest.approx(cfg.gps_v_sigma_m, rel=0.12)
    assert vel[:, 0].std() == pytest.approx(0.1, rel=0.1)
    assert vel[:, 2].std() == pytest.approx(0.2, rel=0.1)


def test_gps_bias_is_slow():
    """With the default tau = 60 s, consecutive fixes share most of their error (lag-1 correlation ~ 0.9)."""
    suite = SensorSuite(SensorConfig(), seed=4)
    rows = run(suite, 300.0)
    e = np.array([FRAME.to_enu(f.lat_deg, f.lon_deg, f.alt_m)[0] for _, f, _, _ in rows if f is not None])
    r1 = np.corrcoef(e[:-1], e[1:])[0, 1]
    assert r1 > 0.8


def test_baro_airspeed_ahrs_noise():
    cfg = SensorConfig(baro_drift_m=0.0, ahrs_tau_s=0.0)
    suite = SensorSuite(cfg, seed=5)
    rows = run(suite, 200.0)
    truth = hover_truth(0.0)
    baro = np.array([a.baro_alt_m for _, _, a, _ in rows]) - truth.alt_m
    ias = 20.0 * math.sqrt(isa_density_ratio(truth.alt_m))  # the pitot reads IAS (about 19.6 m/s at 430 m AMSL)
    tas = np.array([a.airspeed_mps for _, _, a, _ in rows]) - ias
    roll = np.array([x.roll_rad for _, _, _, x in rows]) - truth.roll_rad
    yaw = np.array([x.yaw_rad for _, _, _, x in rows]) - truth.yaw_rad
    assert baro.std() == pytest.approx(0.3, rel=0.05) and abs(baro.mean()) < 0.02
    assert tas.std() == pytest.approx(0.3, rel=0.05) and abs(tas.mean()) < 0.02
    assert np.degrees(roll.std()) == pytest.approx(0.5, rel=0.05)
    assert np.degrees(yaw.std()) == pytest.approx(2.0, rel=0.05)


@pytest.mark.parametrize("alt_m, ias_over_tas", [(0.0, 1.0), (1000.0, 0.9526), (2800.0, 0.8704)])
def test_pitot_reads_indicated_airspeed(alt_m, ias_over_tas):
    """IAS = TAS sqrt(rho/rho0); ISA table: sigma = 0.9075 at 1 km (sqrt 0.9526), 0.7576 at 2.8 km (sqrt 0.8704)."""
    suite = SensorSuite(SensorConfig(airspeed_noise_mps=0.0), seed=3)
    _, air, _ = suite.sample(VehicleState(t_s=0.0, alt_m=alt_m, airspeed_mps=25.0))
    assert air.airspeed_mps == pytest.approx(25.0 * ias_over_tas, rel=2e-4)
    assert isa_density_ratio(alt_m) == pytest.approx(ias_over_tas**2, rel=4e-4)


def test_multirotor_has_no_airspeed():
    suite = SensorSuite(seed=1, has_pitot=False)
    _, air, _ = suite.sample(hover_truth(0.0))
    assert air.airspeed_mps is None


def test_reproducible_by_seed_and_streams_independent():
    a = run(SensorSuite(seed=7), 5.0)
    b = run(SensorSuite(seed=7), 5.0)
    c = run(SensorSuite(seed=8), 5.0)
    assert a == b
    assert a != c
    # changing the pitot noise leaves the GNSS stream untouched
    d = run(SensorSuite(SensorConfig(airspeed_noise_mps=1.0), seed=7), 5.0)
    assert [r[1] for r in a] == [r[1] for r in d]
    assert [r[2] for r in a] != [r[2] for r in d]


def test_gps_fail_and_outage_windows():
    suite = SensorSuite(SensorConfig(gps_outages=((3.0, 5.0),), gps_fail_at_s=10.0), seed=3)
    rows = run(suite, 15.0)
    fixes = [f for _, f, _, _ in rows if f is not None]
    for f in fixes:
        lost = 3.0 <= f.t_s < 5.0 or f.t_s >= 10.0
        assert f.valid is (not lost)
        if lost:
            assert math.isnan(f.lat_deg) and math.isinf(f.horizontal_accuracy_m)
        else:
            assert math.isfinite(f.lat_deg)
    assert any(not f.valid for f in fixes) and any(f.valid for f in fixes)


def test_parse_sensors():
    assert parse_sensors(None) == SensorConfig()
    cfg = parse_sensors({"gps_rate_hz": 10, "gps_outages": [[1, 2]], "gps_fail_at_s": 30, "seed": 4}, "x.yaml: sensors")
    assert cfg.gps_rate_hz == 10.0 and cfg.gps_outages == ((1.0, 2.0),) and cfg.gps_fail_at_s == 30.0 and cfg.seed == 4
    bad = [
        ({"gps_rat_hz": 5}, "x: sensors.gps_rat_hz: unknown key (did you mean 'gps_rate_hz'?"),
        ({"gps_rate_hz": 0}, "x: sensors.gps_rate_hz: must be > 0"),
        ({"baro_noise_m": -1}, "x: sensors.baro_noise_m: must be >= 0"),
        ({"gps_latency_s": "0.2"}, "x: sensors.gps_latency_s: expected a number"),
        ({"gps_outages": [[5, 2]]}, "x: sensors.gps_outages[0]: end_s must be > start_s"),
        ({"gps_outages": 3}, "x: sensors.gps_outages: expected a list"),
        ({"seed": -1}, "x: sensors.seed: must be >= 0"),
        ([1, 2], "x: sensors: expected a mapping"),
    ]
    for raw, msg in bad:
        with pytest.raises(ValueError) as exc:
            parse_sensors(raw, "x: sensors")
        assert str(exc.value).startswith(msg), str(exc.value)
        assert "\n" not in str(exc.value)


def test_the_estimator_is_tuned_to_the_sensors_through_one_map():
    """One noise specification: SensorConfig -> EstimatorConfig in one place, and the two defaults agree."""
    from dataclasses import fields as dc_fields
    from dataclasses import replace as dc_replace

    from aircraft.sensors import ESTIMATOR_NOISE_FIELDS, SensorConfig
    from geofence.estimation.estimator import EstimatorConfig

    assert SensorConfig().estimator_config() == EstimatorConfig()
    noisy = dc_replace(SensorConfig(), **{k: 2.0 * getattr(SensorConfig(), k) + 0.1 for k in ESTIMATOR_NOISE_FIELDS})
    est = noisy.estimator_config(timeout_s=2.0)
    for ours, theirs in ESTIMATOR_NOISE_FIELDS.items():
        assert getattr(est, theirs) == getattr(noisy, ours)
    assert est.timeout_s == 2.0
    assert set(ESTIMATOR_NOISE_FIELDS) <= {f.name for f in dc_fields(SensorConfig)}


def test_each_sensor_draws_its_own_stream_in_order_across_refills():
    """The noise order (what keeps flights identical): each message takes its stream's next normals, in the order
    of the module docstring, straight through the pools' refills. With the Gauss-Markov errors switched off or
    white, every sample is the truth plus sigma times a known draw of ``stream_generator(seed, stream)``."""
    cfg = SensorConfig(gps_rate_hz=10.0, gps_h_bias_m=0.0, gps_v_bias_m=0.0, baro_drift_m=0.0, ahrs_tau_s=0.0)
    seed, n = 9, NORMAL_BLOCK + 400  # every pool refills (the GNSS one six times)
    suite = SensorSuite(cfg, seed=seed, prefill=False)
    normals = {
        k: stream_generator(seed, k).standard_normal(8 * NORMAL_BLOCK)
        for k in (GPS_STREAM, BARO_STREAM, PITOT_STREAM, AHRS_STREAM)
    }
    truth = hover_truth(0.0)
    rp, yaw = math.radians(cfg.ahrs_roll_pitch_deg), math.radians(cfg.ahrs_yaw_deg)
    fixes = 0
    for k in range(n):
        t = k * 0.1
        fix, air, att = suite.sample(hover_truth(t))
        assert air.baro_alt_m == pytest.approx(truth.alt_m + 0.3 * normals[BARO_STREAM][k], abs=1e-9)
        ias = 20.0 * math.sqrt(isa_density_ratio(truth.alt_m))
        assert air.airspeed_mps == pytest.approx(max(ias + 0.3 * normals[PITOT_STREAM][k], 0.0), abs=1e-12)
        a = normals[AHRS_STREAM][3 * k : 3 * k + 3]  # the start's three draws at step 0 (no time passed), then 3 a step
        assert att.roll_rad == pytest.approx(truth.roll_rad + rp * a[0], abs=1e-12)
        assert att.pitch_rad == pytest.approx(truth.pitch_rad + rp * a[1], abs=1e-12)
        assert att.yaw_rad == pytest.approx((truth.yaw_rad + yaw * a[2]) % (2.0 * math.pi), abs=1e-12)
        if fix is not None:
            g = normals[GPS_STREAM][6 * fixes : 6 * fixes + 6]  # e, n, u, then the velocities
            assert (fix.v_east_mps, fix.v_north_mps, fix.v_up_mps) == pytest.approx(
                (0.1 * g[3], 0.1 * g[4], 0.2 * g[5]), abs=1e-12
            )
            e, nn, u = FRAME.to_enu(fix.lat_deg, fix.lon_deg, fix.alt_m)
            assert (e, nn, u - 30.0) == pytest.approx((0.5 * g[0], 0.5 * g[1], 1.0 * g[2]), abs=1e-6)
            fixes += 1
    assert 6 * fixes > 2 * NORMAL_BLOCK


def test_a_latency_of_many_fix_periods_is_delivered_in_order():
    """The pending GNSS ring is sized by the configuration (here 90 messages in flight), not a fixed capacity."""
    suite = SensorSuite(SensorConfig(gps_rate_hz=10.0, gps_latency_s=9.0, seed=4))
    fixes = [(t, f) for t, f, _, _ in run(suite, 30.0) if f is not None]
    assert len(fixes) == pytest.approx(30.0 * 10.0 - 90.0 + 1, abs=2)
    for t, f in fixes:
        assert t - f.t_s == pytest.approx(9.0, abs=0.025)
    assert fixes[0][1].t_s == pytest.approx(-9.0)  # the pre-filled one, then one a fix period from t = 0
    assert np.diff([f.t_s for _, f in fixes[1:]]) == pytest.approx(np.full(len(fixes) - 2, 0.1), abs=1e-9)


@pytest.mark.parametrize("multirotor", [False, True])
def test_compiled_step_conforms_to_its_interpreted_source(multirotor):
    """Conformance of the one entry point: compiled and interpreted (its own source, ``py_func``) agree to 1e-9
    (deg, m, m/s, rad) along a noisy climbing turn with an outage and a receiver failure, past the pools' refills."""
    from aircraft.sensors import FIX0, OUTAGES0, sensors_step

    if not hasattr(sensors_step, "py_func"):
        pytest.skip("numba is not compiling here: the interpreted run is the only one")
    cfg = SensorConfig(gps_outages=((10.0, 12.0),), gps_fail_at_s=60.0)
    a, b = (SensorSuite(cfg, has_pitot=not multirotor, seed=3) for _ in range(2))

    def climbing_turn(t: float) -> VehicleState:
        lat, lon, h = FRAME.to_geodetic(50.0 * math.sin(0.2 * t), 50.0 * math.cos(0.2 * t), 30.0 + t)
        return VehicleState(t, lat, lon, h, 0.0, 0.0, 30.0 + t, 30.0 + t, 10.0, -5.0, 1.0, 0.3, 0.05, 0.2 * t, 20.0)

    for k in range(int(80.0 / DT)):
        s = climbing_turn(k * DT)
        fields = (s.t_s, s.lat_deg, s.lon_deg, s.alt_m, s.v_east_mps, s.v_north_mps, s.v_up_mps, s.airspeed_mps)
        got = sensors_step(a.memory, a.pools, a.idx, *fields, s.roll_rad, s.pitch_rad, s.yaw_rad)
        ref = sensors_step.py_func(b.memory, b.pools, b.idx, *fields, s.roll_rad, s.pitch_rad, s.yaw_rad)
        assert got == pytest.approx(ref, abs=1e-9, nan_ok=True), k
        assert a.memory[FIX0:OUTAGES0] == pytest.approx(b.memory[FIX0:OUTAGES0], abs=1e-9, nan_ok=True)
        assert got[-1] == a.refill() | False and ref[-1] == b.refill() | False
    assert (a.idx == b.idx).all() and a.gps_bias_enu_m == pytest.approx(b.gps_bias_enu_m, abs=1e-9)
