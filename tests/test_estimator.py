"""The geofence unit's own state estimator, fed by the sensor models on synthetic trajectories."""

import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aircraft.sensors import SensorConfig, SensorSuite
from geofence.estimator import EstimatorConfig, GeofenceEstimator
from geofence.geodesy import LocalFrame
from geofence.interface import VehicleState
from geofence.measurements import AirData, AttitudeSample, GpsFix

FRAME = LocalFrame(47.0, 8.0, 400.0)
DT = 0.025
G = 9.80665


def truth_at(t, e, n, u, ve, vn, vu, roll=0.0, airspeed=20.0):
    lat, lon, h = FRAME.to_geodetic(e, n, u)
    yaw = math.atan2(ve, vn) % (2.0 * math.pi)
    return VehicleState(t, lat, lon, h, e, n, u, u, ve, vn, vu, roll, 0.0, yaw, airspeed)


def constant_velocity(t):
    return truth_at(t, 5.0 * t, 10.0 * t, 50.0, 5.0, 10.0, 0.0)


def turning(t):
    """20 m/s circle of 60 m radius (34 deg bank), slowly climbing and sinking."""
    v, r = 20.0, 60.0
    w = v / r
    th = w * t
    return truth_at(
        t,
        r * math.sin(th),
        r * math.cos(th),
        50.0 + 5.0 * math.sin(0.1 * t),
        v * math.cos(th),
        -v * math.sin(th),
        0.5 * math.cos(0.1 * t),
        math.atan(v * w / G),
    )


def fly(trajectory, seconds, sensors=None, est_cfg=None, seed=3, skip_s=5.0):
    sensors = sensors or SensorConfig()
    est_cfg = est_cfg or EstimatorConfig(gps_h_bias_m=sensors.gps_h_bias_m, gps_v_bias_m=sensors.gps_v_bias_m)
    suite = SensorSuite(sensors, seed=seed)
    est = GeofenceEstimator(FRAME, est_cfg)
    rows = []
    last_fix = None
    cost = 0.0
    for k in range(int(round(seconds / DT))):
        t = k * DT
        tr = trajectory(t)
        fix, air, att = suite.sample(tr)
        t0 = time.perf_counter()
        s = est.step(DT, fix, air, att)
        cost += time.perf_counter() - t0
        if fix is not None and fix.valid:
            last_fix = FRAME.to_enu(fix.lat_deg, fix.lon_deg, fix.alt_m)
        if t >= skip_s:
            be, bn, bu = suite.gps_bias_enu_m
            rows.append(
                (
                    s.east_m - tr.east_m,
                    s.north_m - tr.north_m,
                    s.up_m - tr.up_m,
                    s.v_east_mps - tr.v_east_mps,
                    s.v_north_mps - tr.v_north_mps,
                    last_fix[0] - tr.east_m,
                    last_fix[1] - tr.north_m,
                    be,
                    bn,
                    est.var_e_m2,
                    est.var_n_m2,
                    est.sigma_h_m,
                    est.sigma_v_m,
                    bu,
                )
            )
    return est, np.array(rows), cost / (k + 1) * 1e6


@pytest.mark.parametrize("trajectory", [constant_velocity, turning])
def test_accuracy_white_noise_only(trajectory):
    """Without GNSS bias the filter beats the raw white position noise by far and tracks velocity."""
    cfg = SensorConfig(gps_h_bias_m=0.0, gps_v_bias_m=0.0)
    est, r, us = fly(trajectory, 120.0, cfg)
    pos_rms = math.sqrt(np.mean(r[:, 0] ** 2 + r[:, 1] ** 2))
    raw_rms = math.sqrt(2.0) * cfg.gps_h_white_m
    vel_rms = math.sqrt(np.mean(r[:, 3] ** 2 + r[:, 4] ** 2))
    up_rms = math.sqrt(np.mean(r[:, 2] ** 2))
    print(
        f"{trajectory.__name__}: pos rms {pos_rms:.2f} m (raw white {raw_rms:.2f}), vel rms {vel_rms:.3f} m/s, "
        f"up rms {up_rms:.2f} m, {us:.1f} us/step"
    )
    assert pos_rms < 0.5 * raw_rms
    assert vel_rms < 0.5
    assert up_rms < 0.5 * cfg.gps_v_white_m
    assert est.position_valid


@pytest.mark.parametrize("trajectory", [constant_velocity, turning])
def test_accuracy_with_bias_and_latency(trajectory):
    """With the default (biased) GNSS: the estimate follows the receiver's solution closely, compensates the
    latency (much better than the latest raw fix at the current time), and cannot remove the bias."""
    est, r, _ = fly(trajectory, 120.0)
    pos_rms = math.sqrt(np.mean(r[:, 0] ** 2 + r[:, 1] ** 2))
    latest_fix_rms = math.sqrt(np.mean(r[:, 5] ** 2 + r[:, 6] ** 2))
    vs_receiver = math.sqrt(np.mean((r[:, 0] - r[:, 7]) ** 2 + (r[:, 1] - r[:, 8]) ** 2))
    print(
        f"{trajectory.__name__}: pos rms {pos_rms:.2f}, latest raw fix rms {latest_fix_rms:.2f}, "
        f"vs receiver track {vs_receiver:.2f}"
    )
    assert vs_receiver < 0.75 * math.sqrt(2.0) * 0.5  # below the raw white noise
    assert pos_rms < latest_fix_rms
    vel_rms = math.sqrt(np.mean(r[:, 3] ** 2 + r[:, 4] ** 2))
    assert vel_rms < 0.5


def test_reported_sigma_covers_errors_on_turning_flight():
    """NEES (horizontal, with the bias variance added) is not overconfident over many seeds of a turning flight."""
    nees_h, nees_v = [], []
    for seed in range(30):
        est, r, _ = fly(turning, 30.0, seed=seed, skip_s=29.9)
        ex, en, eu = r[-1, 0], r[-1, 1], r[-1, 2]
        vb = 1.5**2
        nees_h.append(ex * ex / (r[-1, 9] + vb) + en * en / (r[-1, 10] + vb))
        nees_v.append(eu * eu / r[-1, 12] ** 2)
    mh, mv = float(np.mean(nees_h)), float(np.mean(nees_v))
    print(f"turning: mean NEES horizontal {mh:.2f} (dof 2), vertical {mv:.2f} (dof 1)")
    # chi-square 95 % upper bounds of the mean over 30 runs: 2 dof -> 2.65, 1 dof -> 1.57
    assert 0.5 < mh < 2.65
    assert 0.2 < mv < 1.57


def test_nees_chi_square_band_on_model_consistent_truth():
    """Truth drawn from the filter's own model (white jerk): the mean NEES lies in the two-sided 95 % band."""
    cfg = EstimatorConfig()
    q = cfg.jerk_psd_h
    n_runs, seconds = 40, 20.0
    nees = []
    for seed in range(n_runs):
        rng = np.random.default_rng(1000 + seed)
        jerk = rng.standard_normal((int(seconds / DT) + 1, 2)) * math.sqrt(q / DT)
        state = {"p": np.zeros(2), "v": np.array([10.0, 0.0]), "a": np.zeros(2), "k": 0}

        def model_truth(t, state=state, jerk=jerk):
            k = int(round(t / DT))
            while state["k"] < k:
                j = jerk[state["k"]]
                state["p"] += state["v"] * DT + 0.5 * state["a"] * DT * DT
                state["v"] += state["a"] * DT
                state["a"] += j * DT
                state["k"] += 1
            p, v = state["p"], state["v"]
            return truth_at(t, p[0], p[1], 50.0, v[0], v[1], 0.0)

        est, r, _ = fly(model_truth, seconds, seed=seed, skip_s=seconds - 2 * DT)
        ex, en = r[-1, 0], r[-1, 1]
        vb = 1.5**2
        nees.append(ex * ex / (r[-1, 9] + vb) + en * en / (r[-1, 10] + vb))
    m = float(np.mean(nees))
    print(f"model-consistent truth: mean NEES {m:.2f} (2 dof, 95 % band for 40 runs: 1.43-2.67)")
    # chi2(80) 2.5 % / 97.5 % quantiles: 57.15 / 106.63 -> mean per run 1.43 / 2.67
    assert 1.43 < m < 2.67


def test_loss_of_fix_times_out():
    cfg = SensorConfig(gps_outages=((10.0, 20.0),))
    suite = SensorSuite(cfg, seed=1)
    est = GeofenceEstimator(FRAME, EstimatorConfig(timeout_s=1.0))
    valid = {}
    for k in range(int(30.0 / DT)):
        t = k * DT
        est.step(DT, *suite.sample(constant_velocity(t)))
        valid[round(t, 3)] = (est.position_valid, est.sigma_h_m)
    assert all(valid[round(k * DT, 3)][0] for k in range(0, int(10.9 / DT)))
    # last valid fix: validity 9.8 s, arrival 10.0 s -> invalid once 1 s has passed
    assert valid[11.025][0] is False
    assert all(not valid[round(k * DT, 3)][0] for k in range(int(11.05 / DT), int(20.1 / DT)))
    assert valid[11.025][1] > valid[9.0][1]  # the covariance grows while dead-reckoning
    assert valid[21.0][0] is True  # back once fixes return


def test_no_fix_yet_is_invalid():
    est = GeofenceEstimator(FRAME)
    s = est.step(DT, None, AirData(0.0, None, 430.0), AttitudeSample(0.0, 0.0, 0.0, 0.0))
    assert not est.position_valid and math.isinf(est.sigma_h_m)
    assert s.east_m == 0.0


def test_output_geodetic_consistent_with_enu():
    est, _, _ = fly(turning, 10.0)
    s = est.state
    e, n, u = FRAME.to_enu(s.lat_deg, s.lon_deg, s.alt_m)
    assert e == pytest.approx(s.east_m, abs=0.05) and n == pytest.approx(s.north_m, abs=0.05)
    assert u == pytest.approx(s.up_m, abs=0.05)
    assert s.agl_m == pytest.approx(s.alt_m - FRAME.h0_m)


finite = st.floats(-1e4, 1e4, allow_nan=False, allow_infinity=False)


@st.composite
def step_inputs(draw):
    t_fix = draw(st.floats(-5.0, 5.0))
    fix = None
    if draw(st.booleans()):
        fix = GpsFix(
            t_fix,
            draw(st.floats(46.9, 47.1)),
            draw(st.floats(7.9, 8.1)),
            draw(st.floats(-500, 5000)),
            draw(finite),
            draw(finite),
            draw(finite),
            1.0,
            2.0,
            draw(st.booleans()),
        )
    air = AirData(draw(st.floats(0, 100)), draw(st.one_of(st.none(), st.floats(0, 200))), draw(st.floats(-500, 5000)))
    att = AttitudeSample(0.0, draw(st.floats(-3.2, 3.2)), draw(st.floats(-1.6, 1.6)), draw(st.floats(0, 6.3)))
    return draw(st.floats(0.0, 1.0)), fix, air, att


@settings(max_examples=60, deadline=None)
@given(st.lists(step_inputs(), min_size=1, max_size=60))
def test_never_nan_for_finite_inputs(seq):
    est = GeofenceEstimator(FRAME)
    for dt, fix, air, att in seq:
        s = est.step(dt, fix, air, att)
        for name in ("east_m", "north_m", "up_m", "v_east_mps", "v_north_mps", "v_up_mps", "lat_deg", "alt_m"):
            assert math.isfinite(getattr(s, name)), name
        assert not math.isnan(est.sigma_h_m) and not math.isnan(est.sigma_v_m)
        assert est.sigma_h_m > 0.0 and est.sigma_v_m > 0.0
