"""The geofence unit's own state estimator, fed by the sensor models on synthetic trajectories."""

import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aircraft.sensors import SensorConfig, SensorSuite
from geofence.estimation.estimator import EstimatorConfig, GeofenceEstimator
from geofence.estimation.measurements import AirData, AttitudeSample, GpsFix
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import VehicleState

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


# -- the oracle: the module docstring's model as a textbook matrix-form Kalman filter --------------------------------


def _ca_model(d: float, q_jerk: float, q_wander: float) -> tuple[np.ndarray, np.ndarray]:
    """``(F, Q)`` of one horizontal axis's constant-acceleration model over ``d`` s: white jerk of spectral density
    ``q_jerk`` plus the GNSS bias wander ``q_wander`` on the position."""
    F = np.array([[1.0, d, 0.5 * d * d], [0.0, 1.0, d], [0.0, 0.0, 1.0]])
    Q = q_jerk * np.array(
        [[d**5 / 20.0, d**4 / 8.0, d**3 / 6.0], [d**4 / 8.0, d**3 / 3.0, d**2 / 2.0], [d**3 / 6.0, d**2 / 2.0, d]]
    )
    Q[0, 0] += q_wander * d
    return F, Q


def _kalman_update(x: np.ndarray, P: np.ndarray, H: np.ndarray, z: np.ndarray, R: np.ndarray):
    """The textbook update: ``K = P H^T (H P H^T + R)^-1``, ``x + K (z - H x)``, ``(I - K H) P``."""
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    return x + K @ (z - H @ x), (np.eye(len(P)) - K @ H) @ P


class TextbookEstimator:
    """The estimator's model in matrix form, written from the module docstring of :mod:`geofence.estimation.estimator`: per
    horizontal axis ``(p, v, a)`` at the newest fix's time of validity (the fusion horizon), predicted there and
    updated with the fix's position and velocity (one joint update: the same as the two scalar ones), then
    extrapolated to the current time; the vertical ``(up, v_up, baro offset)`` at the current time, the baro every
    step (``H = (1, 0, 1)``), the GNSS vertical velocity with its latency's process noise, the GNSS height only when
    the barometer is not the reference."""

    def __init__(self, frame: LocalFrame, cfg: EstimatorConfig) -> None:
        self.frame, self.cfg = frame, cfg
        self.baro_primary = cfg.baro_referenced and cfg.baro_drift_m < cfg.gps_v_bias_m
        self.q_wander = 2.0 * cfg.gps_h_bias_m**2 / cfg.gps_bias_tau_s
        self.q_baro = 2.0 * cfg.baro_drift_m**2 / cfg.baro_drift_tau_s
        if not self.baro_primary:
            self.q_baro += 2.0 * cfg.gps_v_bias_m**2 / cfg.gps_bias_tau_s
        self.xh = self.Ph = self.t_d = None  # (3, 2): the east and north axes' columns
        self.xv = self.Pv = None
        self.v_up0 = self.pending_baro = None
        self.last_arrival_s = -math.inf

    def step(self, t: float, dt: float, fix: GpsFix | None, air: AirData) -> dict:
        cfg = self.cfg
        if self.xv is not None:
            F = np.array([[1.0, dt, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
            q = cfg.accel_psd_v
            Q = np.array([[q * dt**3 / 3.0, q * dt**2 / 2.0, 0.0], [q * dt**2 / 2.0, q * dt, 0.0], [0.0, 0.0, 0.0]])
            Q[2, 2] = self.q_baro * dt
            self.xv, self.Pv = F @ self.xv, F @ self.Pv @ F.T + Q
        if fix is not None and fix.valid:
            self._fuse(t, fix)
        self._baro(air.baro_alt_m - self.frame.h0_m)
        return self._output(t)

    def _fuse(self, t: float, fix: GpsFix) -> None:
        cfg = self.cfg
        e, n, u = self.frame.to_enu(fix.lat_deg, fix.lon_deg, fix.alt_m)
        lag = max(t - fix.t_s, 0.0)
        z_h = np.array([[e, n], [fix.v_east_mps, fix.v_north_mps]])
        if self.xh is None:
            self.xh = np.vstack([z_h, np.zeros((1, 2))])
            self.Ph = np.diag([cfg.gps_h_white_m**2, cfg.gps_vel_h_mps**2, 4.0])
            self.t_d = fix.t_s
            self._init_vertical(u + fix.v_up_mps * lag, fix.v_up_mps)
        elif fix.t_s > self.t_d:
            F, Q = _ca_model(fix.t_s - self.t_d, cfg.jerk_psd_h, self.q_wander)
            self.xh, self.Ph = F @ self.xh, F @ self.Ph @ F.T + Q
            self.t_d = fix.t_s
            H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
            self.xh, self.Ph = _kalman_update(self.xh, self.Ph, H, z_h, np.diag([cfg.gps_h_white_m**2, cfg.gps_vel_h_mps**2]))
            q = cfg.accel_psd_v
            if not self.baro_primary:  # the height, stamped lag s ago: up(t - lag) = up - lag v_up
                r = cfg.gps_v_white_m**2 + q * lag**3 / 3.0
                self.xv, self.Pv = _kalman_update(self.xv, self.Pv, np.array([[1.0, -lag, 0.0]]), np.array([u]), np.array([[r]]))
            r = cfg.gps_vel_v_mps**2 + q * lag
            self.xv, self.Pv = _kalman_update(
                self.xv, self.Pv, np.array([[0.0, 1.0, 0.0]]), np.array([fix.v_up_mps]), np.array([[r]])
            )
        else:
            return
        self.last_arrival_s = t

    def _init_vertical(self, up: float, v_up: float) -> None:
        cfg = self.cfg
        self.v_up0 = v_up
        if self.baro_primary:
            if self.pending_baro is not None:
                self._init_from_baro(self.pending_baro)
            return
        if self.pending_baro is not None:
            b, var_b = self.pending_baro - up, cfg.gps_v_white_m**2 + cfg.baro_noise_m**2
        else:
            b, var_b = 0.0, cfg.baro_drift_m**2 + cfg.gps_v_bias_m**2 + 100.0
        self.xv = np.array([up, v_up, b])
        self.Pv = np.diag([cfg.gps_v_white_m**2, cfg.gps_vel_v_mps**2, var_b])

    def _init_from_baro(self, z: float) -> None:
        cfg = self.cfg
        var_b = cfg.baro_drift_m**2
        self.xv = np.array([z, self.v_up0, 0.0])
        self.Pv = np.array([[cfg.baro_noise_m**2 + var_b, 0.0, -var_b], [0.0, cfg.gps_vel_v_mps**2, 0.0], [-var_b, 0.0, var_b]])

    def _baro(self, z: float) -> None:
        if self.xv is None:
            self.pending_baro = z
            if self.xh is not None and self.baro_primary:
                self._init_from_baro(z)
            return
        R = np.array([[self.cfg.baro_noise_m**2]])
        self.xv, self.Pv = _kalman_update(self.xv, self.Pv, np.array([[1.0, 0.0, 1.0]]), np.array([z]), R)

    def _output(self, t: float) -> dict:
        cfg = self.cfg
        d = max(t - self.t_d, 0.0)
        F, Q = _ca_model(d, cfg.jerk_psd_h, self.q_wander)
        x = F @ self.xh
        var = (F @ self.Ph @ F.T + Q)[0, 0]
        var_bias_v = 0.0 if self.baro_primary else cfg.gps_v_bias_m**2
        return {
            "east_m": x[0, 0], "north_m": x[0, 1], "v_east_mps": x[1, 0], "v_north_mps": x[1, 1],
            "up_m": self.xv[0], "v_up_mps": self.xv[1], "baro_offset_m": self.xv[2],
            "sigma_h_m": math.sqrt(var + cfg.gps_h_bias_m**2), "sigma_v_m": math.sqrt(self.Pv[0, 0] + var_bias_v),
            "position_valid": t - self.last_arrival_s <= cfg.timeout_s, "data_age_s": d,
        }  # fmt: skip


ORACLE_TOLERANCE = {"m": 1e-6, "mps": 1e-6, "sigma": 1e-9}
"""How far the estimator may be from the oracle: round-off only (1 µm, 1 µm/s; sigmas relative 1e-9)."""


@pytest.mark.parametrize(
    "sensors, baro_referenced",
    [
        (SensorConfig(), True),  # the barometer is the height reference
        (SensorConfig(gps_outages=((20.0, 24.0),), baro_drift_m=4.0), True),  # drifts more: the GNSS height fused
        (SensorConfig(gps_latency_s=0.11, gps_rate_hz=10.0), False),
    ],
)
def test_the_estimator_is_the_textbook_kalman_filter(sensors, baro_referenced):
    """On a noisy turning flight (with an outage, both vertical references), the estimator's every output is the
    matrix-form filter's for the same model, within :data:`ORACLE_TOLERANCE`."""
    cfg = sensors.estimator_config(baro_referenced=baro_referenced)
    suite = SensorSuite(sensors, seed=11)
    est, oracle = GeofenceEstimator(FRAME, cfg), TextbookEstimator(FRAME, cfg)
    for k in range(int(60.0 / DT)):
        t = k * DT
        fix, air, att = suite.sample(turning(t))
        s = est.step(DT, fix, air, att)
        want = oracle.step(t, DT, fix, air)
        for name in ("east_m", "north_m", "up_m"):
            assert getattr(s, name) == pytest.approx(want[name], abs=ORACLE_TOLERANCE["m"]), (t, name)
        for name in ("v_east_mps", "v_north_mps", "v_up_mps"):
            assert getattr(s, name) == pytest.approx(want[name], abs=ORACLE_TOLERANCE["mps"]), (t, name)
        assert est.baro_offset_m == pytest.approx(want["baro_offset_m"], abs=ORACLE_TOLERANCE["m"])
        for name in ("sigma_h_m", "sigma_v_m"):
            assert getattr(est, name) == pytest.approx(want[name], rel=ORACLE_TOLERANCE["sigma"]), (t, name)
        assert est.position_valid == want["position_valid"], t
        assert est.data_age_s == pytest.approx(want["data_age_s"], abs=1e-9)
    assert est.fixes_used > 250


def test_compiled_step_conforms_to_its_interpreted_source():
    """Conformance of the one entry point: compiled and interpreted (its own source, ``py_func``) agree to 1e-9 (m,
    m/s, rad) along a noisy flight with an outage and a receiver failure."""
    from geofence.estimation.estimator import FIX_SIZE, STATE_SIZE, estimator_step

    if not hasattr(estimator_step, "py_func"):
        pytest.skip("numba is not compiling here: the interpreted run is the only one")
    suite = SensorSuite(SensorConfig(gps_outages=((10.0, 13.0),), gps_fail_at_s=40.0), seed=5)
    a, b = GeofenceEstimator(FRAME), GeofenceEstimator(FRAME)
    fix_row = np.zeros(FIX_SIZE)
    for k in range(int(50.0 / DT)):
        fix, air, att = suite.sample(turning(k * DT))
        if fix is not None:
            fix_row[:] = fix
        args = (DT, fix is not None, fix_row, air.t_s, air.airspeed_mps, air.baro_alt_m, *att[1:])
        got = estimator_step(a.memory[:STATE_SIZE], a.memory[STATE_SIZE:], *args)
        ref = estimator_step.py_func(b.memory[:STATE_SIZE], b.memory[STATE_SIZE:], *args)
        assert got == pytest.approx(ref, abs=1e-9, nan_ok=True), k
        assert (a.position_valid, a.fixes_used, a.fixes_rejected) == (b.position_valid, b.fixes_used, b.fixes_rejected)
        assert a.sigma_h_m == pytest.approx(b.sigma_h_m, rel=1e-12) and a.horizon_state() == pytest.approx(b.horizon_state())


def test_the_sensing_chain_s_facades_read_its_own_slots():
    """:class:`scenarios.flight.sensing.GeofenceSensing` runs one call a step over one packed array; its estimator,
    wind estimator and sensors are façades over that array's slices, so they answer what the step wrote, and the
    façades stepped on their own from the same truths give the same numbers (same sources, same noise)."""
    from support import ROOT

    from aircraft.profile import load_profile
    from geofence.estimation.wind_estimator import WindEstimator, WindEstimatorConfig
    from scenarios.definition.schema import load_scenario
    from scenarios.flight.sensing import GeofenceSensing

    sc = load_scenario(ROOT / "scenarios" / "geofence_gps_loss_fixedwing.yaml")
    env = load_profile("Tern").envelope
    chain = GeofenceSensing(sc, sc.geofence, sc.frame, env)
    sensors = SensorSuite(sc.sensors, has_pitot=not env.is_multirotor, seed=sc.seed)
    est = GeofenceEstimator(sc.frame, sc.sensors.estimator_config())
    wind = WindEstimator(env, WindEstimatorConfig(prior_enu=sc.geofence.wind_prior_enu))
    frame = sc.frame
    for k in range(int(30.0 / DT)):
        t = k * DT
        lat, lon, h = frame.to_geodetic(15.0 * t, 0.0, 60.0)
        truth = VehicleState(t, lat, lon, h, 15.0 * t, 0.0, 60.0, 60.0, 15.0, 0.0, 0.0, 0.0, 0.05, 0.5 * math.pi, 16.0)
        got = chain.sense(truth, DT)
        fix, air, att = sensors.sample(truth)
        s = est.step(DT, fix, air, att)
        assert (got.estimate.east_m, got.estimate.up_m) == pytest.approx((s.east_m, s.up_m), abs=1e-9)
        assert got.wind_en == pytest.approx(wind.update(s, air.airspeed_mps, DT, est.position_valid), abs=1e-9)
        assert (chain.estimator.sigma_h_m, chain.estimator.position_valid) == (got.sigma_h_m, got.position_valid)
        assert chain.estimator.horizon_state() == chain.horizon and chain.wind.wind_enu == got.wind_en
        assert chain.sensors.gps_bias_enu_m == sensors.gps_bias_enu_m
    assert chain.estimator.fixes_used == est.fixes_used > 100
