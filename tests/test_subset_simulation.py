"""Subset simulation and plain Monte Carlo against exact probabilities (limit states with a closed form)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import norm

from geofence.validation import ConfigError
from scenarios.campaign.subset_simulation import SubsetOptions, clopper_pearson, monte_carlo, subset_simulation


def linear(beta: float, direction: np.ndarray):
    """g = beta - a.u in standard normal space: P[g <= 0] = Phi(-beta) exactly."""
    a = direction / np.linalg.norm(direction)

    def g(points, tag):
        return beta - norm.ppf(points) @ a

    return g


def series(beta: float):
    """g = beta - max(u0, u1): P[g <= 0] = 1 - Phi(beta)^2 exactly."""

    def g(points, tag):
        return beta - np.max(norm.ppf(points[:, :2]), axis=1)

    return g


@pytest.mark.parametrize("beta", [2.0, 3.0, 3.5])
def test_subset_simulation_finds_a_linear_limit_state_within_its_own_error(beta):
    exact = float(norm.cdf(-beta))
    estimates = [subset_simulation(linear(beta, np.ones(6)), 6, 0.0, SubsetOptions(200, 0.1, seed=s)) for s in range(1, 31)]
    p = np.array([e.probability for e in estimates])
    assert all(e.reached for e in estimates)
    # the mean of 30 runs within 3 standard errors of the exact value; the stated CoV the spread's, within a factor 2
    assert abs(p.mean() - exact) < 3.0 * p.std(ddof=1) / math.sqrt(len(p))
    stated = np.median([e.cov for e in estimates])
    assert 0.5 < stated / (p.std(ddof=1) / exact) < 2.0
    # and it is cheaper than Monte Carlo at that CoV once the event is rare
    if beta >= 3.0:
        assert np.median([e.monte_carlo_equivalent() for e in estimates]) > 2.0 * estimates[0].evaluations


def test_subset_simulation_on_a_series_system_of_two_modes():
    beta = 3.0
    exact = 1.0 - norm.cdf(beta) ** 2
    p = np.array([subset_simulation(series(beta), 4, 0.0, SubsetOptions(300, 0.1, seed=s)).probability for s in range(1, 21)])
    assert abs(np.log(p.mean() / exact)) < 0.25


def test_the_flight_count_is_n_plus_the_new_states_of_each_level():
    est = subset_simulation(linear(3.0, np.ones(3)), 3, 0.0, SubsetOptions(100, 0.1, seed=4))
    conditional = len(est.levels) - 1
    assert est.evaluations == 100 + conditional * 90
    assert [len(v) for v in est.values] == [100] * len(est.levels)
    thresholds = [lv.threshold for lv in est.levels]
    assert thresholds == sorted(thresholds, reverse=True) and thresholds[-1] == 0.0


def test_an_event_that_is_not_rare_is_one_level():
    est = subset_simulation(linear(0.0, np.ones(2)), 2, 0.0, SubsetOptions(100, 0.1, seed=1))
    assert len(est.levels) == 1 and 0.35 < est.probability < 0.65 and est.evaluations == 100


def test_stopping_at_max_levels_says_it_is_an_upper_bound():
    est = subset_simulation(linear(6.0, np.ones(2)), 2, 0.0, SubsetOptions(100, 0.1, max_levels=2, seed=1))
    assert not est.reached
    assert len(est.levels) == 3 and est.levels[-1].threshold > 0.0
    assert 0.5e-3 < est.probability < 2e-3 and est.probability > norm.cdf(-6.0)  # P[g <= the last threshold]


def test_monte_carlo_interval_covers_the_exact_value():
    exact = float(norm.cdf(-2.0))
    covered = 0
    for seed in range(1, 41):
        low, high = monte_carlo(linear(2.0, np.ones(3)), 3, 0.0, 400, seed=seed).interval
        covered += low <= exact <= high
    assert covered >= 35  # a 95 % interval: 38 of 40 expected, 35 is far in the tail


@given(st.integers(0, 60), st.integers(1, 60))
@settings(max_examples=200, deadline=None)
def test_clopper_pearson_brackets_the_fraction_and_stays_in_unit_interval(k, extra):
    n = k + extra
    low, high = clopper_pearson(k, n)
    assert 0.0 <= low <= k / n <= high <= 1.0
    if k == 0:
        assert low == 0.0 and high == pytest.approx(1.0 - 0.025 ** (1.0 / n))


@pytest.mark.parametrize(
    "kwargs",
    [dict(samples_per_level=100, p0=0.07), dict(samples_per_level=100, p0=0.6), dict(rho=1.0), dict(max_levels=0)],
)
def test_options_that_cannot_sample_are_refused(kwargs):
    with pytest.raises(ConfigError):
        SubsetOptions(**kwargs)


def test_a_floor_of_g_above_the_event_stops_the_levels_and_is_reported_as_stalled():
    # g never falls below 1: the chains cannot go lower, and the answer is P[g <= the last threshold reached]
    est = subset_simulation(
        lambda x, tag: np.maximum(linear(2.0, np.ones(2))(x, tag), 1.0), 2, 0.0, SubsetOptions(100, 0.1, seed=3)
    )
    assert est.stalled and not est.reached
    assert est.levels[-1].threshold >= 1.0 and est.probability >= norm.cdf(-1.0) * 0.5


def test_the_chains_keep_moving_deep_in_the_event():
    est = subset_simulation(linear(4.0, np.ones(9)), 9, 0.0, SubsetOptions(200, 0.1, seed=5))
    assert est.reached and not est.stalled
    assert abs(math.log10(est.probability / norm.cdf(-4.0))) < 0.5
    assert all(lv.gamma < 8.0 for lv in est.levels)  # adapted: correlated, not stuck


def test_an_evaluator_that_returns_garbage_is_an_error_not_an_estimate():
    with pytest.raises(ValueError, match="finite"):
        subset_simulation(lambda x, tag: np.full(len(x), np.nan), 2, 0.0, SubsetOptions(100, 0.1))


@given(
    beta=st.floats(-1.0, 5.0),
    dimension=st.integers(1, 8),
    chains=st.integers(1, 10),
    length=st.integers(2, 10),
    seed=st.integers(1, 10_000),
)
@settings(max_examples=60, deadline=None)
def test_any_run_is_a_probability_with_falling_thresholds_and_its_flight_count(beta, dimension, chains, length, seed):
    n = chains * length
    est = subset_simulation(linear(beta, np.ones(dimension)), dimension, 0.0, SubsetOptions(n, 1.0 / length, seed=seed))
    assert 0.0 < est.probability <= 1.0 and est.cov >= 0.0
    thresholds = [lv.threshold for lv in est.levels]
    assert all(a > b for a, b in zip(thresholds, thresholds[1:]))
    assert est.evaluations == n + (n - chains) * (len(est.values) - 1)
    assert est.reached == (thresholds[-1] == 0.0) and all(t >= 0.0 for t in thresholds)
    assert all(len(v) == n for v in est.values) and all(np.all((p > 0) & (p < 1)) for p in est.points)
