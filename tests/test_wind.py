"""Tests of the wind package: steady wind and profiles, Dryden turbulence, 1-cos gusts, config."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wind import (
    SEVERITY_W20_MPS,
    CalmWind,
    CompositeWind,
    DrydenTurbulence,
    Gust,
    GustTrain,
    LogLawProfile,
    PowerLawProfile,
    SteadyWind,
    WindConfig,
    WindField,
    dryden_scales,
    from_deg_of,
    parse_wind,
    wind_from_config,
)
from wind.gust import MAX_RISE_TIME_S

FT = 0.3048
KT = 1852.0 / 3600.0


# --------------------------------------------------------------------------- steady wind


@pytest.mark.parametrize(
    ("from_deg", "expected"),
    [(0.0, (0.0, -8.0, 0.0)), (90.0, (-8.0, 0.0, 0.0)), (180.0, (0.0, 8.0, 0.0)), (270.0, (8.0, 0.0, 0.0))],
)
def test_steady_wind_blows_toward_the_opposite_of_from(from_deg, expected):
    w = SteadyWind(8.0, from_deg)
    assert w.sample(0.0, 0.0, 0.0, 50.0, 0.0) == pytest.approx(expected, abs=1e-12)
    assert w.mean(50.0) == pytest.approx(expected, abs=1e-12)


@given(speed=st.floats(0.1, 60.0), from_deg=st.floats(0.0, 359.999), h=st.floats(0.0, 500.0))
def test_steady_wind_magnitude_and_direction_round_trip(speed, from_deg, h):
    e, n, u = SteadyWind(speed, from_deg).mean(h)
    assert math.hypot(e, n) == pytest.approx(speed, rel=1e-12)
    assert u == 0.0
    diff = (from_deg_of(e, n) - from_deg + 180.0) % 360.0 - 180.0
    assert abs(diff) < 1e-9


def test_power_and_log_profiles_at_reference_height_and_known_points():
    p = PowerLawProfile(exponent=0.14, reference_height_m=10.0)
    assert p.factor(10.0) == pytest.approx(1.0)
    assert p.factor(40.0) == pytest.approx(4.0**0.14)
    assert p.factor(0.0) == 0.0 and p.factor(-3.0) == 0.0
    lg = LogLawProfile(roughness_length_m=0.03, reference_height_m=10.0)
    assert lg.factor(10.0) == pytest.approx(1.0)
    assert lg.factor(100.0) == pytest.approx(math.log(100 / 0.03) / math.log(10 / 0.03))
    assert lg.factor(0.03) == 0.0 and lg.factor(0.01) == 0.0 and lg.factor(-1.0) == 0.0
    w = SteadyWind(8.0, 270.0, p)
    assert w.mean(10.0) == pytest.approx((8.0, 0.0, 0.0))
    assert w.speed_at(40.0) == pytest.approx(8.0 * 4.0**0.14)


heights = st.floats(-50.0, 2000.0, allow_nan=False)


@given(exponent=st.floats(0.01, 1.0), zref=st.floats(0.5, 200.0), z1=heights, z2=heights)
def test_power_profile_is_monotone_non_negative_and_finite(exponent, zref, z1, z2):
    p = PowerLawProfile(exponent, zref)
    lo, hi = sorted((z1, z2))
    f_lo, f_hi = p.factor(lo), p.factor(hi)
    assert math.isfinite(f_lo) and math.isfinite(f_hi)
    assert 0.0 <= f_lo <= f_hi
    assert p.factor(zref) == pytest.approx(1.0)


@given(z0=st.floats(0.0002, 2.0), ratio=st.floats(1.5, 1000.0), z1=heights, z2=heights)
def test_log_profile_is_monotone_non_negative_and_finite(z0, ratio, z1, z2):
    p = LogLawProfile(z0, z0 * ratio)
    lo, hi = sorted((z1, z2))
    f_lo, f_hi = p.factor(lo), p.factor(hi)
    assert math.isfinite(f_lo) and math.isfinite(f_hi)
    assert 0.0 <= f_lo <= f_hi
    assert p.factor(z0 * ratio) == pytest.approx(1.0)


def test_profile_rejects_nonsense():
    with pytest.raises(ValueError):
        PowerLawProfile(-0.1, 10.0)
    with pytest.raises(ValueError):
        LogLawProfile(0.5, 0.1)
    with pytest.raises(ValueError):
        SteadyWind(-1.0, 0.0)


# --------------------------------------------------------------------------- Dryden turbulence


def test_dryden_scales_match_mil_f_8785c_low_altitude_formulas():
    w20 = SEVERITY_W20_MPS["light"]
    assert w20 == pytest.approx(15 * KT)
    assert SEVERITY_W20_MPS["moderate"] == pytest.approx(30 * KT)
    assert SEVERITY_W20_MPS["severe"] == pytest.approx(45 * KT)
    for h_ft in (10.0, 50.0, 100.0, 400.0, 1000.0):
        d = 0.177 + 0.000823 * h_ft
        lu, lw, su, sw = dryden_scales(h_ft * FT, w20)
        assert lw == pytest.approx(h_ft * FT)
        assert lu == pytest.approx(h_ft / d**1.2 * FT)
        assert sw == pytest.approx(0.1 * w20)
        assert su == pytest.approx(0.1 * w20 / d**0.4)
    # clamped near the ground (10 ft) and held above 1000 ft (isotropic there)
    assert dryden_scales(0.0, w20) == dryden_scales(10 * FT, w20) == dryden_scales(-5.0, w20)
    lu, lw, su, sw = dryden_scales(2000.0, w20)
    assert lu == pytest.approx(lw) == pytest.approx(1000 * FT)
    assert su == pytest.approx(sw)


def _series(turb: WindField, n: int, dt: float, h: float, v: float) -> np.ndarray:
    return np.array([turb.sample(k * dt, 0.0, 0.0, h, v) for k in range(n)])


def _acf(x: np.ndarray, max_lag: int) -> np.ndarray:
    x = x - x.mean()
    n = len(x)
    f = np.fft.rfft(x, 2 * n)
    r = np.fft.irfft(f * np.conj(f))[:max_lag] / n
    return r / r[0]


def _first_below(acf: np.ndarray, level: float) -> int:
    return int(np.argmax(acf < level))


@pytest.fixture(scope="module")
def long_series():
    """100,000 steps of light turbulence at 20 m AGL, 20 m/s, mean wind 8 m/s from 270 (T = 5000 s)."""
    dt, h, v = 0.05, 20.0, 20.0
    turb = DrydenTurbulence(severity="light", seed=12345, mean_wind=SteadyWind(8.0, 270.0))
    return _series(turb, 100_000, dt, h, v), dt, h, v


def test_dryden_statistics_match_the_spec(long_series):
    x, dt, h, v = long_series
    lu, lw, su, sw = dryden_scales(h, SEVERITY_W20_MPS["light"])
    # mean wind from 270 -> u axis = east, v axis = north, w = up
    u, vv, w = x[:, 0], x[:, 1], x[:, 2]
    for comp, sigma in ((u, su), (vv, su), (w, sw)):
        assert abs(comp.mean()) < 0.15 * sigma
        assert comp.std() == pytest.approx(sigma, rel=0.15)
    # time correlation: u is exp(-t/tau), v and w are (1 - t/(2 tau)) exp(-t/tau), tau = L / V
    tau_u, tau_w = lu / v, lw / v
    acf_u, acf_v, acf_w = (_acf(c, int(5 * tau_u / dt)) for c in (u, vv, w))
    assert _first_below(acf_u, math.exp(-1.0)) * dt == pytest.approx(tau_u, rel=0.30)
    assert _first_below(acf_v, 0.5 * math.exp(-1.0)) * dt == pytest.approx(tau_u, rel=0.30)
    assert _first_below(acf_w, 0.5 * math.exp(-1.0)) * dt == pytest.approx(tau_w, rel=0.30)
    # integral time scale of u (integrate the ACF to its first zero crossing, ~tau for a long record)
    k0 = _first_below(acf_u, 0.0) or len(acf_u)
    assert np.sum(acf_u[:k0]) * dt == pytest.approx(tau_u, rel=0.30)
    # the whole ACF shape, lags 0..3 tau
    for acf, tau, second_order in ((acf_u, tau_u, False), (acf_w, tau_w, True)):
        lags = np.arange(int(3 * tau / dt)) * dt / tau
        theory = (1.0 - 0.5 * lags) * np.exp(-lags) if second_order else np.exp(-lags)
        assert np.max(np.abs(acf[: len(lags)] - theory)) < 0.12
    # no cross-correlation between components
    assert abs(np.corrcoef(u, w)[0, 1]) < 0.05


def test_dryden_exact_discretization_is_step_size_independent():
    """Sampled at 2 Hz instead of 20 Hz, the variances are unchanged (no discretization loss)."""
    h, v = 20.0, 20.0
    lu, lw, su, sw = dryden_scales(h, SEVERITY_W20_MPS["moderate"])
    turb = DrydenTurbulence(severity="moderate", seed=3)
    x = _series(turb, 40_000, 0.5, h, v)
    assert x[:, 0].std() == pytest.approx(su, rel=0.15)
    assert x[:, 1].std() == pytest.approx(su, rel=0.15)
    assert x[:, 2].std() == pytest.approx(sw, rel=0.15)
    # with dt >> tau_w consecutive w samples are nearly independent: lag-1 ACF = (1 - r/2) e^-r, r = 10
    r = 0.5 * v / lw
    assert _acf(x[:, 2], 2)[1] == pytest.approx((1 - r / 2) * math.exp(-r), abs=0.03)


def test_dryden_does_not_vanish_when_hovering():
    """Airspeed 0 in calm air: convected at the 1 m/s floor; in wind: by the mean wind."""
    h = 15.0
    lu, lw, su, sw = dryden_scales(h, SEVERITY_W20_MPS["light"])
    calm = _series(DrydenTurbulence(severity="light", seed=1), 20_000, 0.25, h, 0.0)
    assert calm[:, 2].std() > 0.5 * sw and calm[:, 0].std() > 0.4 * su
    windy = _series(DrydenTurbulence(severity="light", seed=1, mean_wind=SteadyWind(10.0, 0.0)), 40_000, 0.05, h, 0.0)
    # mean wind from north: u axis points south, so -north is u
    acf_w = _acf(windy[:, 2], 400)
    assert _first_below(acf_w, 0.5 * math.exp(-1.0)) * 0.05 == pytest.approx(lw / 10.0, rel=0.30)
    assert windy[:, 2].std() == pytest.approx(sw, rel=0.15)


def test_dryden_reproducible_by_seed_and_different_for_another_seed():
    kw = {"severity": "light", "mean_wind": SteadyWind(5.0, 90.0)}
    a = _series(DrydenTurbulence(seed=7, **kw), 500, 0.025, 30.0, 12.0)
    b = _series(DrydenTurbulence(seed=7, **kw), 500, 0.025, 30.0, 12.0)
    c = _series(DrydenTurbulence(seed=8, **kw), 500, 0.025, 30.0, 12.0)
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)
    t = DrydenTurbulence(seed=7, **kw)
    first = _series(t, 500, 0.025, 30.0, 12.0)
    t.reset()
    assert np.array_equal(first, _series(t, 500, 0.025, 30.0, 12.0))


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    dts=st.lists(st.floats(1e-4, 5.0), min_size=1, max_size=60),
    h=st.floats(-5.0, 1500.0),
    v=st.floats(0.0, 40.0),
)
def test_dryden_any_dt_is_finite_repeatable_and_idempotent(seed, dts, h, v):
    t1 = DrydenTurbulence(w20_mps=10.0, seed=seed, mean_wind=SteadyWind(3.0, 45.0))
    t2 = DrydenTurbulence(w20_mps=10.0, seed=seed, mean_wind=SteadyWind(3.0, 45.0))
    t = 0.0
    for dt in dts:
        t += dt
        a = t1.sample(t, 0.0, 0.0, h, v)
        assert t1.sample(t, 0.0, 0.0, h, v) == a  # same t twice -> same value
        assert t2.sample(t, 0.0, 0.0, h, v) == a
        assert all(math.isfinite(c) for c in a)
    assert t1.mean(h) == (0.0, 0.0, 0.0)


def test_dryden_rejects_time_going_backwards_and_bad_arguments():
    t = DrydenTurbulence(severity="severe", seed=0)
    t.sample(1.0, 0.0, 0.0, 10.0, 5.0)
    with pytest.raises(ValueError, match="backwards"):
        t.sample(0.5, 0.0, 0.0, 10.0, 5.0)
    with pytest.raises(ValueError, match="severity"):
        DrydenTurbulence(severity="hurricane")
    with pytest.raises(ValueError):
        DrydenTurbulence(w20_mps=5.0, severity="light")


def test_dryden_two_state_noise_keeps_the_stationary_covariance():
    """Phi P Phi^T + Q == P for the closed-form Q used in sample(), small and large steps."""
    p = np.array([[1.0, 0.5], [0.5, 0.5]])
    for r in (1e-6, 1e-3, 0.04, 1.0, 30.0):
        a = math.exp(-r)
        phi = a * np.array([[1.0, 0.0], [r, 1.0]])
        q11 = -math.expm1(-2 * r)
        q12 = 0.5 * q11 - a * a * r
        q22 = 0.5 * q11 - a * a * r * (r + 1)
        # Van Loan / direct integral: Q = int_0^r e^{-2s} [[1, s], [s, s^2]] 2 ds
        s = np.linspace(0.0, r, 20001)
        f = np.exp(-2 * s) * 2
        direct = [np.trapezoid(f, s), np.trapezoid(f * s, s), np.trapezoid(f * s * s, s)]
        assert [q11, q12, q22] == pytest.approx(direct, rel=1e-6, abs=1e-18)
        assert np.allclose(phi @ p @ phi.T + np.array([[q11, q12], [q12, q22]]), p, atol=1e-14)


# --------------------------------------------------------------------------- gusts


def test_gust_shape_exact_at_known_points():
    g = Gust(onset_s=20.0, amplitude_mps=5.0, length_m=30.0, from_deg=270.0)
    train = GustTrain([g])
    # 10 m/s through calm air -> rise over 3 s, fall over the next 3 s. The vehicle really moves: the
    # penetration speed comes from its motion relative to the mean air (frozen field), not the airspeed argument.
    dt, v = 0.025, 10.0
    out = {}
    for k in range(int(30.0 / dt) + 1):
        t = k * dt
        out[round(t, 3)] = train.sample(t, 0.0, v * t, 50.0, v)
    assert out[19.0] == (0.0, 0.0, 0.0)
    assert out[20.0] == (0.0, 0.0, 0.0)
    assert out[21.5] == pytest.approx((2.5, 0.0, 0.0), abs=1e-9)  # x = d/2: V_m / 2
    assert out[23.0] == pytest.approx((5.0, 0.0, 0.0), abs=1e-9)  # x = d: peak V_m
    assert out[24.5] == pytest.approx((2.5, 0.0, 0.0), abs=1e-9)
    assert out[26.0] == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)
    assert out[28.0] == (0.0, 0.0, 0.0)
    assert max(e for e, _, _ in out.values()) == pytest.approx(5.0)
    assert min(e for e, _, _ in out.values()) == 0.0
    assert train.mean(50.0) == (0.0, 0.0, 0.0)


def test_gust_rise_and_hold_vertical_and_time_based():
    g = Gust(0.0, 4.0, 20.0, from_deg=0.0, vertical_mps=-2.0, hold_m=math.inf, penetration_speed_mps=5.0)
    assert g.vector(10.0) == pytest.approx((0.0, -2.0, -1.0))
    assert g.vector(20.0) == pytest.approx((0.0, -4.0, -2.0))
    assert g.vector(1e6) == pytest.approx((0.0, -4.0, -2.0))
    train = GustTrain([g])
    # time-based: x = 5 m/s * t whatever the airspeed
    assert train.sample(2.0, 0, 0, 10, 30.0) == pytest.approx((0.0, -2.0, -1.0))
    assert train.sample(4.0, 0, 0, 10, 0.0) == pytest.approx((0.0, -4.0, -2.0))


def test_gust_hovering_vehicle_is_convected_by_the_mean_wind():
    g = Gust(onset_s=0.0, amplitude_mps=3.0, length_m=16.0, from_deg=90.0)
    train = GustTrain([g], mean_wind=SteadyWind(8.0, 90.0))
    train.sample(0.0, 0, 0, 10, 0.0)
    assert train.sample(1.0, 0, 0, 10, 0.0) == pytest.approx((-1.5, 0.0, 0.0))  # x = 8 m = d/2
    assert train.sample(2.0, 0, 0, 10, 0.0) == pytest.approx((-3.0, 0.0, 0.0))  # peak


def _peak_time_s(train, wind_toward_e, v_ground_e, seconds=30.0, dt=0.025):
    """Time of the largest gust sample for a vehicle flying due east at ``v_ground_e`` (onset at t = 0)."""
    best_t, best = 0.0, -1.0
    for k in range(int(seconds / dt) + 1):
        t = k * dt
        e, n, _ = train.sample(t, v_ground_e * t, 0.0, 20.0, abs(v_ground_e - wind_toward_e))
        a = math.hypot(e, n)
        if a > best + 1e-12:
            best_t, best = t, a
    return best_t, best


def test_gust_on_hovering_vehicle_in_wind_peaks_at_length_over_wind_speed():
    g = Gust(onset_s=0.0, amplitude_mps=4.0, length_m=40.0, from_deg=270.0)
    t, peak = _peak_time_s(GustTrain([g], mean_wind=SteadyWind(8.0, 270.0)), 8.0, 0.0)
    assert peak == pytest.approx(4.0)
    assert t == pytest.approx(40.0 / 8.0, abs=0.03)


def test_gust_in_calm_air_peaks_within_the_documented_rise_time():
    # the old model (airspeed with a 1 m/s floor) took 40 s to bring a 40 m gust to a hovering vehicle
    for length in (4.0, 40.0, 120.0):
        g = Gust(onset_s=0.0, amplitude_mps=4.0, length_m=length, from_deg=0.0)
        t, peak = _peak_time_s(GustTrain([g]), 0.0, 0.0)
        assert peak == pytest.approx(4.0)
        assert 0.0 < t <= MAX_RISE_TIME_S + 0.03
        assert t == pytest.approx(length / max(length / MAX_RISE_TIME_S, 1.0), abs=0.03)  # 4 m: 1 m/s floor


def test_gust_on_aircraft_flying_into_headwind_peaks_at_relative_speed():
    # 8 m/s wind from the west (toward east); the aircraft flies west at 16 m/s over the ground (24 m/s airspeed):
    # the gust front comes toward it at 8 m/s while it goes toward the front at 16 m/s
    g = Gust(onset_s=0.0, amplitude_mps=4.0, length_m=40.0, from_deg=270.0)
    t, _ = _peak_time_s(GustTrain([g], mean_wind=SteadyWind(8.0, 270.0)), 8.0, -16.0, seconds=5.0)
    assert t == pytest.approx(40.0 / 24.0, abs=0.03)
    # drifting downwind with the air mass at 8 m/s (zero airspeed): only the documented floor sweeps it
    t, _ = _peak_time_s(GustTrain([g], mean_wind=SteadyWind(8.0, 270.0)), 8.0, 8.0)
    assert t == pytest.approx(MAX_RISE_TIME_S, abs=0.03)


def test_gust_timing_ignores_the_airspeed_the_gust_itself_causes():
    # a hovering vehicle hit by a strong gust reports a large airspeed; the frozen field still passes at |W|
    g = Gust(onset_s=0.0, amplitude_mps=10.0, length_m=16.0, from_deg=90.0)
    train = GustTrain([g], mean_wind=SteadyWind(8.0, 90.0))
    train.sample(0.0, 0, 0, 10, 8.0)
    assert train.sample(1.0, 0, 0, 10, 30.0) == pytest.approx((-5.0, 0.0, 0.0))  # x = 8 m = d/2
    with pytest.raises(ValueError, match="max_rise_time_s"):
        GustTrain([g], max_rise_time_s=0.0)


@given(
    length=st.floats(0.5, 200.0),
    hold=st.floats(0.0, 100.0),
    x=st.floats(-100.0, 600.0),
)
def test_gust_shape_bounded_and_symmetric(length, hold, x):
    g = Gust(0.0, 1.0, length, 0.0, hold_m=hold)
    k = g.shape(x)
    assert 0.0 <= k <= 1.0
    assert k == pytest.approx(g.shape(g.extent_m - x), abs=1e-9)


@given(
    length=st.floats(0.5, 200.0),
    hold=st.one_of(st.floats(0.0, 100.0), st.just(math.inf)),
    x=st.floats(-100.0, 600.0),
    dx=st.floats(0.0, 1000.0),
)
def test_a_gust_that_has_passed_stays_at_zero(length, hold, x, dx):
    """GustTrain skips a gust once Gust.passed: its shape must be 0 there and at every larger distance."""
    g = Gust(0.0, 1.0, length, 0.0, hold_m=hold)
    if g.passed(x):
        assert g.shape(x) == 0.0 and g.shape(x + dx) == 0.0 and g.passed(x + dx)
    if math.isinf(hold):
        assert not g.passed(x)  # rise-and-hold never ends
    if x >= g.extent_m + 1e-6 * g.extent_m:
        assert g.passed(x)


def test_random_gust_train_reproducible_and_within_ranges():
    kw = dict(count=5, start_s=10.0, end_s=60.0, amplitude_mps=(2.0, 6.0), length_m=(10.0, 40.0), from_deg=270.0, spread_deg=30.0)
    a, b, c = GustTrain.random(3, **kw), GustTrain.random(3, **kw), GustTrain.random(4, **kw)
    assert a.gusts == b.gusts and a.gusts != c.gusts
    for g in a.gusts:
        assert 10.0 <= g.onset_s <= 60.0 and 2.0 <= g.amplitude_mps <= 6.0 and 10.0 <= g.length_m <= 40.0
        assert min(abs(g.from_deg - 270.0), 360 - abs(g.from_deg - 270.0)) <= 30.0
    assert [g.onset_s for g in a.gusts] == sorted(g.onset_s for g in a.gusts)


# --------------------------------------------------------------------------- composite and config

EXAMPLE = {
    "speed_mps": 8,
    "from_deg": 270,
    "profile": {"law": "power", "exponent": 0.14, "reference_height_m": 10},
    "turbulence": {"severity": "light"},
    "gusts": [{"onset_s": 20, "amplitude_mps": 5, "length_m": 30, "from_deg": 270}],
    "seed": 7,
}


def test_parse_the_documented_example():
    import yaml

    doc = yaml.safe_load(
        """
wind:
  speed_mps: 8
  from_deg: 270
  profile: {law: power, exponent: 0.14, reference_height_m: 10}   # optional
  turbulence: {severity: light}        # or {w20_mps: 7.7}; optional
  gusts:                               # optional
    - {onset_s: 20, amplitude_mps: 5, length_m: 30, from_deg: 270}
  seed: 7                              # optional; else the scenario seed is used
"""
    )
    cfg = parse_wind(doc["wind"], "x.yaml: wind")
    assert cfg == parse_wind(EXAMPLE)
    assert cfg.speed_mps == 8.0 and cfg.from_deg == 270.0 and cfg.seed == 7
    assert cfg.profile.law == "power" and cfg.profile.exponent == 0.14
    assert cfg.turbulence.resolved_w20_mps == pytest.approx(15 * KT)
    assert cfg.gusts[0].length_m == 30.0
    field = wind_from_config(cfg, seed=99)
    assert isinstance(field, CompositeWind) and isinstance(field, WindField)
    assert field.mean(10.0) == pytest.approx((8.0, 0.0, 0.0))
    assert field.mean(0.0) == (0.0, 0.0, 0.0)
    # the config seed wins over the scenario seed; the scenario seed is used otherwise
    s1 = [wind_from_config(cfg, seed=1).sample(k * 0.025, 0, 0, 30, 0) for k in range(50)]
    s2 = [wind_from_config(cfg, seed=2).sample(k * 0.025, 0, 0, 30, 0) for k in range(50)]
    assert s1 == s2
    nos = parse_wind({**EXAMPLE, "seed": None})
    r1 = [wind_from_config(nos, seed=1).sample(k * 0.025, 0, 0, 30, 0) for k in range(50)]
    r2 = [wind_from_config(nos, seed=2).sample(k * 0.025, 0, 0, 30, 0) for k in range(50)]
    assert r1 != r2


def test_parse_other_forms_and_calm():
    assert parse_wind(None) == WindConfig()
    assert isinstance(wind_from_config(parse_wind({})), CalmWind)
    assert isinstance(wind_from_config(None), CalmWind)
    assert parse_wind({}).is_calm
    cfg = parse_wind(
        {
            "speed_mps": 5,
            "from_deg": 360,
            "profile": {"law": "log", "roughness_length_m": 0.1},
            "turbulence": {"w20_mps": 7.7},
            "random_gusts": {"count": 3, "start_s": 5, "end_s": 50, "amplitude_mps": [1, 4], "length_m": 20},
            "gusts": [{"onset_s": 1, "amplitude_mps": 2, "length_m": 10, "hold_m": float("inf"), "vertical_mps": -1}],
        }
    )
    assert cfg.from_deg == 0.0 and cfg.profile.reference_height_m == 10.0
    assert cfg.random_gusts.length_m == (20.0, 20.0)
    field = wind_from_config(cfg, seed=5)
    gust_train = field.components[-1]
    assert len(gust_train.gusts) == 4 and gust_train.gusts[0].from_deg == 0.0
    assert all(math.isfinite(c) for k in range(400) for c in field.sample(k * 0.1, 0, 0, 20, 3.0))
    only_turb = wind_from_config(parse_wind({"turbulence": {"severity": "moderate"}}), seed=1)
    assert isinstance(only_turb, DrydenTurbulence)
    assert wind_from_config(parse_wind({"turbulence": {"severity": "none"}})).sample(1, 0, 0, 10, 5) == (0, 0, 0)


@pytest.mark.parametrize(
    ("mapping", "field", "words"),
    [
        ({"speed_mps": -2, "from_deg": 0}, "w.yaml: wind.speed_mps:", ">= 0, got -2"),
        ({"sped_mps": 3}, "w.yaml: wind.sped_mps:", "did you mean 'speed_mps'"),
        ({"speed_mps": 3}, "w.yaml: wind.from_deg:", "missing"),
        ({"speed_mps": 3, "from_deg": 400}, "w.yaml: wind.from_deg:", "<= 360"),
        ({"speed_mps": True, "from_deg": 0}, "w.yaml: wind.speed_mps:", "expected a number"),
        ({"turbulence": {"severity": "extreme"}}, "w.yaml: wind.turbulence.severity:", "'extreme'"),
        ({"turbulence": {"severity": "light", "w20_mps": 3}}, "w.yaml: wind.turbulence:", "exactly one"),
        ({"turbulence": {"w20_mps": -1}}, "w.yaml: wind.turbulence.w20_mps:", ">= 0"),
        ({"turbulence": {"severity": "light", "seed": 3}}, "w.yaml: wind.turbulence.seed:", "unknown key"),
        ({"profile": {"law": "cubic"}}, "w.yaml: wind.profile.law:", "'cubic'"),
        ({"profile": {"law": "log", "exponent": 0.2}}, "w.yaml: wind.profile.exponent:", "not used by law 'log'"),
        ({"profile": {"law": "power", "exponent": 0}}, "w.yaml: wind.profile.exponent:", "> 0"),
        ({"profile": {"law": "log", "roughness_length_m": 20}}, "w.yaml: wind.profile.reference_height_m:", "> roughness"),
        ({"gusts": {"onset_s": 1}}, "w.yaml: wind.gusts:", "expected a list"),
        (
            {"gusts": [{"onset_s": 1, "amplitude_mps": 1, "length_m": 5}, {"onset_s": 2, "amplitude_mps": -3, "length_m": 5}]},
            "w.yaml: wind.gusts[1].amplitude_mps:",
            "must be >= 0, got -3",
        ),
        ({"gusts": [{"onset_s": 1, "amplitude_mps": 1}]}, "w.yaml: wind.gusts[0].length_m:", "missing"),
        (
            {"gusts": [{"onset_s": 1, "amplitude_mps": 1, "length_m": 5, "lenght_m": 3}]},
            "w.yaml: wind.gusts[0].lenght_m:",
            "unknown key (did you mean 'length_m'?",
        ),
        ({"gusts": [{"onset_s": 1, "amplitude_mps": 1, "length_m": 0}]}, "w.yaml: wind.gusts[0].length_m:", "> 0"),
        (
            {"random_gusts": {"count": 2, "start_s": 9, "end_s": 5, "amplitude_mps": 1, "length_m": 5}},
            "w.yaml: wind.random_gusts.end_s:",
            ">= start_s",
        ),
        (
            {"random_gusts": {"count": 2, "start_s": 0, "end_s": 5, "amplitude_mps": [4, 1], "length_m": 5}},
            "w.yaml: wind.random_gusts.amplitude_mps:",
            "low must be <= high",
        ),
        ({"seed": -1}, "w.yaml: wind.seed:", ">= 0"),
        ({"seed": 1.5}, "w.yaml: wind.seed:", "integer"),
        ([1, 2], "w.yaml: wind:", "expected a mapping"),
    ],
)
def test_config_errors_name_the_field_on_one_line(mapping, field, words):
    with pytest.raises(ValueError) as info:
        parse_wind(mapping, "w.yaml: wind")
    msg = str(info.value)
    assert msg.startswith(field), msg
    assert words in msg, msg
    assert "\n" not in msg


@settings(max_examples=50, deadline=None)
@given(
    speed=st.floats(0.0, 30.0),
    from_deg=st.floats(0.0, 360.0),
    law=st.sampled_from(["uniform", "power", "log"]),
    severity=st.sampled_from([None, "light", "moderate", "severe", "none"]),
    n_gusts=st.integers(0, 3),
    seed=st.integers(0, 1000),
)
def test_any_valid_config_builds_a_finite_field(speed, from_deg, law, severity, n_gusts, seed):
    raw = {"speed_mps": speed, "from_deg": from_deg, "profile": {"law": law}}
    if severity is not None:
        raw["turbulence"] = {"severity": severity}
    raw["gusts"] = [{"onset_s": 2.0 * i, "amplitude_mps": 3.0, "length_m": 10.0} for i in range(n_gusts)]
    field = wind_from_config(parse_wind(raw, "h.yaml: wind"), seed=seed)
    for k in range(200):
        s = field.sample(k * 0.05, 0.0, 0.0, 0.1 * k, 5.0)
        assert all(math.isfinite(c) for c in s)
    m = field.mean(10.0)
    assert math.hypot(m[0], m[1]) == pytest.approx(speed, abs=1e-9)


def test_a_gust_timed_from_the_first_activation_waits_for_it_then_matches_a_timed_twin():
    """``onset_after: first_activation``: nothing before the event; after it, the same gust as one timed from the start."""
    from wind.config import GustOnset, parse_wind, wind_from_config
    from wind.field import notify_first_activation

    base = {"speed_mps": 6, "from_deg": 270}
    gust = {"onset_s": 1.5, "amplitude_mps": 4, "length_m": 20}
    evented = wind_from_config(parse_wind({**base, "gusts": [{**gust, "onset_after": "first_activation"}]}, "w"), seed=1)
    t_act = 7.3
    twin = wind_from_config(parse_wind({**base, "gusts": [{**gust, "onset_s": t_act + 1.5}]}, "w"), seed=1)
    assert (
        parse_wind({**base, "gusts": [{**gust, "onset_after": "first_activation"}]}, "w").gusts[0].onset_after
        is GustOnset.FIRST_ACTIVATION
    )
    t, told, peak = 0.0, False, 0.0
    while t < 30.0:
        if t >= t_act and not told:
            notify_first_activation(evented, t)
            notify_first_activation(evented, t + 5.0)  # a later activation changes nothing
            told = True
        a = evented.sample(t, 0.1 * t, 0.0, 20.0, 0.0)
        b = twin.sample(t, 0.1 * t, 0.0, 20.0, 0.0)
        assert a == pytest.approx(b, abs=1e-12), t
        if t < t_act + 1.5:
            assert a == pytest.approx((6.0, 0.0, 0.0), abs=1e-12)  # the steady wind only
        peak = max(peak, a[0] - 6.0)
        t = round(t + 0.05, 10)
    assert peak == pytest.approx(4.0, abs=0.05)
    with pytest.raises(ValueError, match=r"w.gusts\[0\].onset_after: 'later' is not one of start, first_activation"):
        parse_wind({**base, "gusts": [{**gust, "onset_after": "later"}]}, "w")
