"""The wind field's compiled functions against independent oracles, the compiled calls against their sources.

Oracles: the Dryden transfer functions of MIL-HDBK-1797 (``scipy.signal.freqs``) for the spectra of the
turbulence the compiled sampler blows, ``scipy.signal.lsim`` of the continuous filters for the exact
discretisation's transition, the power and log laws and the 1-cos gust written out as closed forms, and the
sum of a field's parts sampled alone for :func:`wind.field_kernel.compiled_wind`'s assembly. Each compiled entry
point (:func:`wind.dryden.dryden_sample`, :func:`wind.gust.gusts_sample`, :func:`wind.field_kernel.wind_sample`)
is held to its own source run by the interpreter (``py_func``) at 1e-9 relative; a seed gives the same bytes.
"""

import math
import random

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from geofence.jit import COMPILED
from wind.config import GustConfig, GustOnset, ProfileConfig, RandomGustsConfig, TurbulenceConfig, WindConfig, wind_from_config
from wind.dryden import (
    NORMALS_PER_STEP,
    OUTPUT_WEIGHTS,
    POOL_NORMALS,
    SEVERITY_W20_MPS,
    DrydenTurbulence,
    dryden_sample,
    dryden_scales,
    turbulence_step,
)
from wind.field import CalmWind, CompositeWind, notify_first_activation, toward_unit
from wind.field_kernel import compiled_wind, wind_sample
from wind.gust import MAX_RISE_TIME_S, Gust, GustTrain, gusts_sample
from wind.steady import LogLawProfile, PowerLawProfile, SteadyWind

gusts = st.builds(
    GustConfig,
    onset_s=st.floats(0.0, 40.0),
    amplitude_mps=st.floats(0.0, 8.0),
    length_m=st.floats(1.0, 80.0),
    from_deg=st.one_of(st.none(), st.floats(0.0, 360.0)),
    vertical_mps=st.sampled_from([0.0, -1.5, 2.0]),
    hold_m=st.sampled_from([0.0, 15.0, math.inf]),
    penetration_speed_mps=st.sampled_from([None, None, 12.0]),
    onset_after=st.sampled_from(list(GustOnset)),
)
configs = st.builds(
    WindConfig,
    speed_mps=st.sampled_from([0.0, 0.0, 3.0, 9.5]),
    from_deg=st.sampled_from([0.0, 90.0, 225.0, 301.7]),
    profile=st.one_of(
        st.none(),
        st.just(ProfileConfig("power", exponent=0.2, reference_height_m=12.0)),
        st.just(ProfileConfig("log", roughness_length_m=0.1, reference_height_m=10.0)),
    ),
    turbulence=st.one_of(st.none(), st.just(TurbulenceConfig(severity="light")), st.just(TurbulenceConfig(w20_mps=9.0))),
    gusts=st.lists(gusts, max_size=5).map(tuple),
    random_gusts=st.one_of(st.none(), st.just(RandomGustsConfig(3, 5.0, 30.0, (1.0, 5.0), (10.0, 60.0), spread_deg=40.0))),
    seed=st.integers(0, 1000),
)

needs_numba = pytest.mark.skipif(not COMPILED, reason="conformance of compiled code needs numba (NUMBA_DISABLE_JIT unset)")


def _path(path_seed: int, steps: int):
    """``(k, t, east, north, up, airspeed, activate)`` along a random path: hovering or flying, climbing through
    the ground and above the Dryden model's top, a step repeated now and then and some longer than a second; the
    first activation at a random moment."""
    rng = random.Random(path_seed)
    e = n = t = 0.0
    up = rng.uniform(-2.0, 60.0)
    ve, vn = rng.uniform(-15, 15), rng.uniform(-15, 15)
    arm_at, armed = rng.uniform(0.0, 50.0), False
    for k in range(steps):
        activate = not armed and t >= arm_at
        armed = armed or activate
        yield k, t, e, n, up, rng.uniform(0.0, 25.0), activate
        r = rng.random()
        if r < 0.02:
            continue  # the same time again: the last sample
        dt = 1.5 if r < 0.025 else 1.0 if r < 0.03 else 0.025
        if rng.random() < 0.01:
            ve, vn = rng.uniform(-15, 15), rng.uniform(-15, 15)
        t += dt
        e += ve * dt
        n += vn * dt
        up = min(max(up + rng.uniform(-0.5, 0.5), -3.0), 400.0)


STEPS = POOL_NORMALS // NORMALS_PER_STEP + 300  # past the turbulence's first noise block


# --------------------------------------------------------------------------- the assembly


@settings(max_examples=20, deadline=None)
@given(cfg=configs, seed=st.integers(0, 10_000), path_seed=st.integers(0, 10_000))
def test_the_compiled_field_is_the_sum_of_its_parts_sampled_alone(cfg, seed, path_seed):
    """:func:`compiled_wind` assembles the parts :func:`wind_from_config` builds: its sample is the sum of the
    parts' own samples (each sampled alone, as a field of its own), within 1e-12 m/s."""
    field = wind_from_config(cfg, seed)
    arrays = compiled_wind(wind_from_config(cfg, seed))
    if isinstance(field, CalmWind):
        assert arrays is None
        return
    assert arrays is not None
    parts = field.components if isinstance(field, CompositeWind) else (field,)
    for _, t, e, n, up, airspeed, activate in _path(path_seed, STEPS):
        total = np.sum([p.sample(t, e, n, up, airspeed) for p in parts], axis=0)
        assert arrays.sample(t, e, n, up, airspeed) == pytest.approx(total, abs=1e-12, rel=0.0), t
        if activate:
            for p in parts:
                notify_first_activation(p, t)
            arrays.first_activation(t)


def test_fields_it_does_not_know_are_left_to_the_objects():
    steady = SteadyWind(5.0, 270.0)
    other = SteadyWind(3.0, 90.0)
    assert compiled_wind(CalmWind()) is None
    assert compiled_wind(CompositeWind([steady, steady])) is None  # a part twice
    assert compiled_wind(CompositeWind([DrydenTurbulence(5.0), steady])) is None  # out of order
    assert compiled_wind(CompositeWind([steady, DrydenTurbulence(5.0, mean_wind=other)])) is None  # another mean wind
    assert compiled_wind(CompositeWind([steady, DrydenTurbulence(5.0, mean_wind=steady)])) is not None


def test_the_same_seed_blows_the_same_bytes_and_another_seed_does_not():
    cfg = WindConfig(speed_mps=6.0, from_deg=250.0, turbulence=TurbulenceConfig(severity="moderate"),
                     random_gusts=RandomGustsConfig(4, 2.0, 40.0, (1.0, 5.0), (10.0, 60.0), spread_deg=40.0))  # fmt: skip

    def series(seed: int) -> bytes:
        arrays = compiled_wind(wind_from_config(cfg, seed))
        assert arrays is not None
        return np.array([arrays.sample(t, e, n, up, a) for _, t, e, n, up, a, _ in _path(5, STEPS)]).tobytes()

    assert series(3) == series(3)
    assert series(3) != series(4)


# --------------------------------------------------------------------------- oracles


def test_the_steady_wind_follows_the_power_and_log_laws():
    """The compiled steady wind against the closed forms, 1e-12 relative, above and below the ground."""
    for profile, law in (
        (PowerLawProfile(0.2, 12.0), lambda z: (z / 12.0) ** 0.2 if z > 0.0 else 0.0),
        (LogLawProfile(0.1, 10.0), lambda z: math.log(z / 0.1) / math.log(10.0 / 0.1) if z > 0.1 else 0.0),
        (None, lambda z: 1.0),
    ):
        arrays = compiled_wind(SteadyWind(7.0, 301.7, profile))
        assert arrays is not None
        ue, un = -math.sin(math.radians(301.7)), -math.cos(math.radians(301.7))
        for z in (-3.0, 0.0, 0.05, 0.1, 2.0, 12.0, 80.0, 450.0):
            k = 7.0 * law(z)
            assert arrays.sample(0.0, 0.0, 0.0, z, 10.0) == pytest.approx((k * ue, k * un, 0.0), rel=1e-12, abs=1e-15)


@settings(max_examples=60, deadline=None)
@given(
    length=st.floats(2.0, 80.0),
    hold=st.sampled_from([0.0, 15.0]),
    onset=st.floats(0.5, 10.0),
    ground=st.tuples(st.floats(-20.0, 20.0), st.floats(-20.0, 20.0)),
    wind_speed=st.floats(0.0, 12.0),
    from_deg=st.floats(0.0, 360.0),
)
def test_a_convected_gust_is_the_1_cos_shape_at_the_relative_distance(length, hold, onset, ground, wind_speed, from_deg):
    """A vehicle at a constant ground velocity in a steady wind meets the gust at ``x = max(|v - W|, floor)
    (t - onset)``; the compiled field's gust part is ``A (1 - cos(pi x / d)) / 2`` rising, ``A`` held,
    ``A (1 + cos(pi (x - d - hold) / d)) / 2`` falling, 0 after (MIL-F-8785C), within 1e-9 m/s."""
    steady = SteadyWind(wind_speed, 90.0)
    train = GustTrain([Gust(onset, 4.0, length, from_deg, vertical_mps=-1.0, hold_m=hold)], mean_wind=steady)
    arrays = compiled_wind(CompositeWind([steady, train]))
    assert arrays is not None
    we, wn, _ = steady.mean(20.0)
    relative = max(math.hypot(ground[0] - we, ground[1] - wn), 1.0, length / MAX_RISE_TIME_S)
    ue, un = toward_unit(from_deg)
    dt = 0.025
    for k in range(int((onset + (2 * length + hold) / relative + 2.0) / dt)):
        t = k * dt
        x = relative * (t - onset)
        if x <= 0.0:
            shape = 0.0
        elif x < length:
            shape = 0.5 * (1.0 - math.cos(math.pi * x / length))
        elif x <= length + hold:
            shape = 1.0
        elif x < 2 * length + hold:
            shape = 0.5 * (1.0 + math.cos(math.pi * (x - length - hold) / length))
        else:
            shape = 0.0
        e, n, u = arrays.sample(t, ground[0] * t, ground[1] * t, 20.0, relative)
        assert (e - we, n - wn, u) == pytest.approx((4.0 * shape * ue, 4.0 * shape * un, -shape), abs=1e-9), t


def test_the_exact_discretisation_is_the_continuous_filters_free_response():
    """Without noise a step of the filters is the continuous filters' response over the step
    (``scipy.signal.lsim`` of ``1/(1 + tau s)`` and of its cascade, from the same state), 1e-9 relative."""
    tau, dt = 2.5, 0.3
    lu, lw, _, _ = dryden_scales(30.0, 1.0)
    v = lw / tau  # the convection speed that makes tau_w = tau (and tau_u = L_u / v)
    lag = ([[-1.0 / tau, 0.0], [1.0 / tau, -1.0 / tau]], [[1.0 / tau], [0.0]], np.eye(2), [[0.0], [0.0]])
    times = np.arange(11) * dt
    x0 = (0.7, -1.2)
    _, _, states = signal.lsim(lag, np.zeros(len(times)), times, X0=x0)
    state = (1.0, 0.0, 0.0) + x0
    for k in range(1, len(times)):
        state, _ = turbulence_step(state, True, dt, 0.0, 0.0, 30.0, v, 0.5, 10.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        assert state[3:] == pytest.approx(tuple(states[k]), rel=1e-9)
        assert state[0] == pytest.approx(math.exp(-k * dt * v / lu), rel=1e-9)


@pytest.fixture(scope="module")
def compiled_turbulence():
    """8,000 s at 50 Hz of light turbulence from the compiled field 2 m above the ground (the scales of the
    10 ft floor: the corners at 0.14 Hz for u and v, 1 Hz for w) at 20 m/s, in 8 m/s from 270."""
    dt, h, v = 0.02, 2.0, 20.0
    cfg = WindConfig(speed_mps=8.0, from_deg=270.0, turbulence=TurbulenceConfig(severity="light"))
    arrays = compiled_wind(wind_from_config(cfg, 12345))
    assert arrays is not None
    x = np.array([arrays.sample(k * dt, 0.0, 0.0, h, v) for k in range(400_000)])
    return x - (8.0, 0.0, 0.0), dt, h, v  # the mean wind from 270: u is east, v north, w up


def test_the_turbulence_has_the_mil_hdbk_1797_dryden_spectra(compiled_turbulence):
    """Welch spectra of the compiled turbulence against ``|H(j omega)|^2`` of the MIL-HDBK-1797 Dryden filters
    ``H_u = sigma_u sqrt(2 L_u / (pi V)) / (1 + L_u/V s)``, ``H_w = sigma_w sqrt(L_w / (pi V)) (1 + sqrt(3) L_w/V s)
    / (1 + L_w/V s)^2`` (the same for v with L_u), one-sided in omega: per Hz ``2 pi |H|^2``. From half to five
    times each corner, the spectrum averaged over bands of a sixth of a decade within 12 % (some 250 degrees of
    freedom in the lowest band: 6 % of noise, 5 % seen; the sampling's aliasing is below 2 % there; a length
    30 % off or a first-order filter for a second-order one is 20 % to 35 % off); the variance within
    10 % (some 7,000 correlation times)."""
    x, dt, h, v = compiled_turbulence
    lu, lw, su, sw = dryden_scales(h, SEVERITY_W20_MPS["light"])
    f, p = signal.welch(x, fs=1.0 / dt, nperseg=8192, axis=0)
    for axis, length, sigma, second_order in ((0, lu, su, False), (1, lu, su, True), (2, lw, sw, True)):
        tau = length / v
        gain = sigma * math.sqrt(length / (math.pi * v))
        if second_order:
            b, a = gain * np.array([math.sqrt(3.0) * tau, 1.0]), [tau * tau, 2.0 * tau, 1.0]
        else:
            b, a = [gain * math.sqrt(2.0)], [tau, 1.0]
        _, hw = signal.freqs(b, a, worN=2.0 * np.pi * f)
        theory = 2.0 * np.pi * np.abs(hw) ** 2
        edges = np.geomspace(0.5, 5.0, 7) / (2.0 * np.pi * tau)
        for lo, hi in zip(edges[:-1], edges[1:]):
            band = (f >= lo) & (f < hi)
            assert band.sum() >= 4
            assert p[band, axis].mean() == pytest.approx(theory[band].mean(), rel=0.12), (axis, lo)
        # the filter's spectrum integrates to sigma^2 (its normalisation), and the series' variance is sigma^2
        omega = np.geomspace(1e-5, 1e5, 400_001) / tau
        _, hf = signal.freqs(b, a, worN=omega)
        assert np.trapezoid(np.abs(hf) ** 2, omega) == pytest.approx(sigma**2, rel=1e-3)
        assert x[:, axis].var() == pytest.approx(sigma**2, rel=0.10)


def test_the_output_weights_give_unit_variance_and_the_spec_correlation():
    """``c1 x1 + c2 x2`` with the stationary covariance [[1, 1/2], [1/2, 1/2]] has unit variance, and the
    cascade's autocorrelation ``(1 - r/2) e^-r`` (MIL-F-8785C) at lag r, from the transition of the lsim test."""
    c = np.array(OUTPUT_WEIGHTS)
    p = np.array([[1.0, 0.5], [0.5, 0.5]])
    assert c @ p @ c == pytest.approx(1.0, rel=1e-12)
    for r in (0.1, 1.0, 3.0):
        phi = math.exp(-r) * np.array([[1.0, 0.0], [r, 1.0]])
        assert c @ phi @ p @ c == pytest.approx((1.0 - r / 2.0) * math.exp(-r), rel=1e-12)


# --------------------------------------------------------------------------- conformance


@needs_numba
@given(cfg=configs, seed=st.integers(0, 10_000), path_seed=st.integers(0, 10_000))
@settings(max_examples=10, deadline=None)
def test_wind_sample_compiled_is_its_source(cfg, seed, path_seed):
    compiled_, interpreted = compiled_wind(wind_from_config(cfg, seed)), compiled_wind(wind_from_config(cfg, seed))
    if compiled_ is None or interpreted is None:
        return
    for _, t, e, n, up, a, activate in _path(path_seed, STEPS):
        *x, low = wind_sample(*compiled_.arrays(), t, e, n, up, a)
        *y, low_y = wind_sample.py_func(*interpreted.arrays(), t, e, n, up, a)
        assert x == pytest.approx(y, rel=1e-9, abs=1e-12) and low == low_y
        if low:
            compiled_.refill()
            interpreted.refill()
        if activate:
            compiled_.first_activation(t)
            interpreted.first_activation(t)


@needs_numba
def test_dryden_sample_compiled_is_its_source():
    a, b = (DrydenTurbulence(w20_mps=9.0, seed=4) for _ in range(2))
    for k, t, _, _, up, airspeed, _ in _path(11, STEPS):
        *x, low = dryden_sample(a.memory, a.pool, t, up, airspeed, 3.0, -4.0)
        *y, low_y = dryden_sample.py_func(b.memory, b.pool, t, up, airspeed, 3.0, -4.0)
        assert x == pytest.approx(y, rel=1e-9, abs=1e-12) and low == low_y, k
        if low:
            a.refill()
            b.refill()


@needs_numba
def test_gusts_sample_compiled_is_its_source():
    rng = random.Random(8)
    gusts = [Gust(rng.uniform(0, 40), rng.uniform(0, 8), rng.uniform(1, 80), rng.uniform(0, 360), -1.0, rng.choice([0.0, 15.0, math.inf]),
                  rng.choice([None, 12.0])) for _ in range(6)]  # fmt: skip
    a, b = (GustTrain(gusts, after_first_activation=gusts[:2]) for _ in range(2))
    for k, t, e, n, _, airspeed, activate in _path(12, STEPS):
        x = gusts_sample(a.memory, a.table, t, e, n, airspeed, 2.0, 1.0)
        y = gusts_sample.py_func(b.memory, b.table, t, e, n, airspeed, 2.0, 1.0)
        assert x == pytest.approx(y, rel=1e-9, abs=1e-12), k
        if activate:
            a.first_activation(t)
            b.first_activation(t)
