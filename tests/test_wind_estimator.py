"""The geofence unit's steady-wind estimate, fed by its own (simulated) sensors and state estimator."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aircraft.sensors import SensorConfig, SensorSuite
from geofence.estimator import GeofenceEstimator
from geofence.geodesy import LocalFrame
from geofence.interface import Envelope, PlatformKind, VehicleState
from geofence.wind_estimator import G_MPS2, WindEstimator, WindEstimatorConfig

FRAME = LocalFrame(47.0, 8.0, 400.0)
DT = 0.025

QUAD = Envelope(PlatformKind.MULTIROTOR, 15.0, 28.5, 0.0, math.radians(30), math.radians(30), math.radians(90),
                3.0, 2.0, 5.6, 4.5, 0.25)


def circling(wind_e, wind_n, va=20.0, radius=80.0):
    """Constant-airspeed circle in a steady wind: heading turns at va/radius, the track drifts downwind."""
    w = va / radius
    roll = math.atan(va * w / G_MPS2)

    def truth(t):
        psi = w * t
        ve, vn = va * math.sin(psi) + wind_e, va * math.cos(psi) + wind_n
        e = radius * (1.0 - math.cos(psi)) + wind_e * t
        n = radius * math.sin(psi) + wind_n * t
        lat, lon, h = FRAME.to_geodetic(e, n, 60.0)
        return VehicleState(t, lat, lon, h, e, n, 60.0, 60.0, ve, vn, 0.0, roll, 0.03, psi % (2 * math.pi), va)

    return truth


def run(truth_fn, seconds, wind_est, has_pitot=True, seed=2, sensors=None):
    suite = SensorSuite(sensors or SensorConfig(), has_pitot=has_pitot, seed=seed)
    est = GeofenceEstimator(FRAME)
    history = []
    for k in range(int(round(seconds / DT))):
        t = k * DT
        fix, air, att = suite.sample(truth_fn(t))
        s = est.step(DT, fix, air, att)
        history.append((t, *wind_est.update(s, air.airspeed_mps, DT, est.position_valid)))
    return history


@pytest.mark.parametrize("seed", [1, 2, 3, 16])
@pytest.mark.parametrize("wind", [(6.0, -3.0), (0.0, 0.0), (-4.0, 8.0)])
def test_fixed_wing_converges_on_circling_flight(wind, seed):
    we = WindEstimator(config=WindEstimatorConfig(prior_enu=(0.0, 0.0)))
    hist = run(circling(*wind), 120.0, we, seed=seed)
    e, n = we.wind_enu
    err = math.hypot(e - wind[0], n - wind[1])
    print(f"wind {wind}: estimate ({e:.2f}, {n:.2f}), error {err:.2f} m/s")
    assert err < 0.5
    assert we.converged
    # and it was already close after ~3 tau
    t, e60, n60 = hist[int(60.0 / DT)]
    assert math.hypot(e60 - wind[0], n60 - wind[1]) < 1.0


def test_prior_until_samples_arrive():
    prior = (3.0, -2.0)
    we = WindEstimator(config=WindEstimatorConfig(prior_enu=prior, prior_sigma_mps=4.0))
    s = VehicleState(agl_m=0.2, v_east_mps=10.0, airspeed_mps=15.0)
    for _ in range(100):
        assert we.update(s, 15.0, DT) == prior  # on the ground: no samples
    assert we.update(VehicleState(agl_m=50.0), 15.0, DT, position_valid=False) == prior
    assert not we.converged and we.sigma_mps == pytest.approx(4.0)
    # the prior's weight fades as samples arrive
    air = VehicleState(agl_m=50.0, v_east_mps=0.0, v_north_mps=20.0, yaw_rad=0.0)
    for _ in range(int(2.0 / DT)):
        we.update(air, 20.0, DT)
    e, n = we.wind_enu
    assert 0.5 < e < 2.5 and -1.5 < n < 0.0  # about half way after prior_weight_s (2 s) of zero-wind samples
    assert we.sigma_mps < 4.0


def multirotor_cruise(wind_e, wind_n, v_e=0.0, v_n=8.0):
    """Steady multirotor flight at a constant ground velocity; tilt from the quadratic drag law of QUAD."""
    c2 = G_MPS2 * math.tan(QUAD.max_bank_rad) / QUAD.max_speed_mps**2
    ae, an = v_e - wind_e, v_n - wind_n
    va = math.hypot(ae, an)
    k = c2 * va * va / G_MPS2  # tan(tilt)
    ue, un = (ae / va, an / va) if va > 0 else (0.0, 0.0)
    pitch = -math.atan(k * un)
    roll = math.atan(k * ue * math.cos(pitch))

    def truth(t):
        lat, lon, h = FRAME.to_geodetic(v_e * t, v_n * t, 30.0)
        return VehicleState(t, lat, lon, h, v_e * t, v_n * t, 30.0, 30.0, v_e, v_n, 0.0, roll, pitch, 0.0, va)

    return truth


@pytest.mark.parametrize("wind", [(5.0, 0.0), (-3.0, -6.0)])
def test_multirotor_tilt_model(wind):
    we = WindEstimator(QUAD)
    run(multirotor_cruise(*wind), 90.0, we, has_pitot=False)
    e, n = we.wind_enu
    err = math.hypot(e - wind[0], n - wind[1])
    print(f"multirotor wind {wind}: estimate ({e:.2f}, {n:.2f}), error {err:.2f} m/s")
    assert err < 1.5  # AHRS tilt errors map into v ~ sqrt(tan tilt): see the module docstring
    assert we.sigma_mps >= we.config.multirotor_floor_mps


def test_multirotor_ignores_accelerating_flight():
    we = WindEstimator(QUAD, WindEstimatorConfig(prior_enu=(1.0, 1.0)))
    for k in range(200):
        s = VehicleState(agl_m=20.0, v_north_mps=0.1 * k, pitch_rad=-0.3)  # 4 m/s^2 along north
        we.update(s, None, DT)
    assert we.wind_enu == (1.0, 1.0)


finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
angle = st.floats(-math.pi, math.pi)


@settings(max_examples=80, deadline=None)
@given(st.lists(st.tuples(finite, finite, finite, angle, angle, st.floats(0, 7), st.one_of(st.none(), st.floats(0, 300)),
                          st.floats(0.001, 1.0)), min_size=1, max_size=50))
def test_wind_never_nan(seq):
    for env in (None, QUAD):
        we = WindEstimator(env)
        for ve, vn, vu, roll, pitch, yaw, tas, dt in seq:
            s = VehicleState(agl_m=10.0, v_east_mps=ve, v_north_mps=vn, v_up_mps=vu, roll_rad=roll, pitch_rad=pitch, yaw_rad=yaw)
            e, n = we.update(s, tas, dt)
            assert math.isfinite(e) and math.isfinite(n)
