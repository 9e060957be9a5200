"""Rare-event estimates: subset simulation and plain Monte Carlo of P[g(X) <= c] on the unit cube.

Owns the algorithms and their error statements, not what a point means: ``evaluate(points, tag)`` takes
an (n, d) array of points of [0, 1]^d and returns g per point (for the testbed, a flight's minimum margin;
``tag`` names the batch). The input distribution is X uniform and independent on [0, 1]^d, written as
X = Phi(U) with U standard normal, so the sampler works in U.

Subset simulation (Au and Beck 2001, Probabilistic Engineering Mechanics 16(4)) writes the small
probability as a product of larger conditional ones: level 0 draws ``N`` points at random; each next
level sets its threshold ``b`` at the ``p0`` quantile of the last level's g and grows ``N p0`` Markov
chains from the points below it, until a threshold reaches ``c``. The chains use conditional sampling
(the preconditioned Crank-Nicolson proposal of Papaioannou et al. 2015, Probabilistic Engineering
Mechanics 41): a candidate ``rho u + sqrt(1 - rho^2) xi`` keeps the standard normal law exactly, so a
candidate is accepted when its g is at or below ``b`` and the chain stays put otherwise. As in their
adaptive variant, the spread ``sqrt(1 - rho^2)`` adapts after each step of the chains (which step
together, one batch per step) toward an acceptance of 0.44, so chains deep in the event keep moving.
Should a level's chains find nothing below the last threshold (g has a floor there, or the chains are
stuck), sampling stops and the result is the probability of that threshold, an upper bound.

The coefficient of variation of the estimate is Au and Beck's: each level's
``(1 - p) / (p N) (1 + gamma)`` with ``gamma`` from the correlation of the failure indicator along the
chains, summed over levels (levels taken as uncorrelated, their approximation; the estimate is also
biased by O(1/N), small beside the CoV for N >= 100).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import beta, norm

from geofence.validation import ConfigError

Evaluate = Callable[[np.ndarray, str], np.ndarray]
"""``evaluate(points, tag) -> g``: points an (n, d) array in [0, 1]^d, g an (n,) array (failure: g <= c)."""
CONFIDENCE = 0.95
TARGET_ACCEPTANCE = 0.44
"""The chains' acceptance rate the proposal's spread adapts toward (Papaioannou et al. 2015's choice)."""
MIN_SPREAD, MAX_SPREAD = 0.05, 1.0


@dataclass(frozen=True)
class SubsetOptions:
    """How subset simulation samples: ``samples_per_level`` N, the level probability ``p0`` (N p0 chains of
    1 / p0 states each), at most ``max_levels`` conditional levels, the chains' correlation ``rho`` and the seed."""

    samples_per_level: int = 100
    p0: float = 0.1
    max_levels: int = 8
    rho: float = 0.8
    seed: int = 1

    def __post_init__(self) -> None:
        chains = self.samples_per_level * self.p0
        if not 0.0 < self.p0 <= 0.5 or abs(chains - round(chains)) > 1e-9 or round(chains) < 1:
            raise ConfigError(
                f"subset simulation: p0 {self.p0:g} x N {self.samples_per_level} must be a whole number >= 1 of chains, p0 in (0, 0.5]"
            )
        if self.samples_per_level % round(chains):
            raise ConfigError(
                f"subset simulation: N {self.samples_per_level} must split into {round(chains)} chains of equal length"
            )
        if not 0.0 < self.rho < 1.0:
            raise ConfigError(f"subset simulation: rho must be in (0, 1), got {self.rho:g}")
        if not 1 <= self.max_levels <= 30:
            raise ConfigError(f"subset simulation: max_levels must be 1..30, got {self.max_levels}")

    @property
    def chains(self) -> int:
        return round(self.samples_per_level * self.p0)

    @property
    def chain_length(self) -> int:
        return self.samples_per_level // self.chains


@dataclass(frozen=True)
class Level:
    """One level: its g threshold (the event's ``c`` at the last level), the conditional probability of
    falling at or below it, that probability's CoV and chain correlation factor, and the g evaluated."""

    threshold: float
    probability: float
    cov: float
    gamma: float
    evaluations: int
    spread: float
    """The proposal's spread sqrt(1 - rho^2) the level's chains started with (level 0: the initial one)."""


@dataclass
class Estimate:
    """An estimate of P[g <= c]: the value, its CoV, the evaluations it took, and every point and g."""

    method: str
    threshold: float
    probability: float
    cov: float
    evaluations: int
    reached: bool
    """False when subset simulation stopped above ``c`` (at ``max_levels``, or stalled): ``probability`` is then
    P[g <= the last threshold], an upper bound of P[g <= c]."""
    stalled: bool = False
    """A level's chains found no g below the last threshold (a floor of g, or chains stuck): sampling stopped there."""
    levels: list[Level] = field(default_factory=list)
    points: list[np.ndarray] = field(default_factory=list)
    """Per level (one entry for plain Monte Carlo): the (N, d) points of the level."""
    values: list[np.ndarray] = field(default_factory=list)
    """Per level: g of those points."""
    interval: tuple[float, float] | None = None
    """Plain Monte Carlo: the exact (Clopper-Pearson) two-sided interval at :data:`CONFIDENCE`."""

    def monte_carlo_equivalent(self) -> float:
        """Flights plain Monte Carlo needs for the same CoV at this probability: (1 - p) / (p CoV^2)."""
        if self.probability <= 0.0 or self.cov <= 0.0:
            return math.inf
        return (1.0 - self.probability) / (self.probability * self.cov**2)


def clopper_pearson(k: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The exact two-sided binomial interval for k successes in n trials."""
    a = (1.0 - confidence) / 2.0
    low = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    high = 1.0 if k == n else float(beta.ppf(1.0 - a, k + 1, n - k))
    return low, high


def monte_carlo(evaluate: Evaluate, dimension: int, threshold: float, samples: int, seed: int = 1) -> Estimate:
    """Plain Monte Carlo: ``samples`` points uniform on the cube, the fraction at or below ``threshold``."""
    if samples < 1:
        raise ConfigError(f"monte carlo: samples must be >= 1, got {samples}")
    x = np.random.default_rng(seed).random((samples, dimension))
    g = np.asarray(evaluate(x, "mc"), dtype=float)
    k = int(np.count_nonzero(g <= threshold))
    p = k / samples
    cov = math.sqrt((1.0 - p) / (p * samples)) if k else math.inf
    return Estimate(
        "monte-carlo", threshold, p, cov, samples, reached=True, points=[x], values=[g], interval=clopper_pearson(k, samples)
    )


def subset_simulation(evaluate: Evaluate, dimension: int, threshold: float, options: SubsetOptions) -> Estimate:
    """Subset simulation of P[g <= ``threshold``] (see the module docstring)."""
    rng = np.random.default_rng(options.seed)
    n = options.samples_per_level
    u = rng.standard_normal((n, dimension))
    g = _evaluate(evaluate, u, "l0")
    chains_g = g.reshape(n, 1)  # level 0: independent draws, one "chain" of length 1 each
    est = Estimate("subset", threshold, 1.0, 0.0, n, reached=False, points=[norm.cdf(u)], values=[g])
    factor, cov2, spread = 1.0, 0.0, math.sqrt(1.0 - options.rho**2)
    previous = math.inf
    for level in range(options.max_levels + 1):
        order = np.argsort(g, kind="stable")
        b = 0.5 * (g[order[options.chains - 1]] + g[order[options.chains]])
        if b >= previous:  # the chains found nothing lower: stop at the last threshold reached
            est.stalled = True
            break
        b = max(b, threshold)
        p = float(np.mean(g <= b))
        d2, gamma = _level_cov2(chains_g <= b, p, n)
        cov2 += d2
        factor *= p
        est.levels.append(Level(float(b), p, math.sqrt(d2), gamma, n if level == 0 else n - options.chains, spread))
        if b == threshold or level == options.max_levels:
            break
        seeds = order[: options.chains]
        u, g, chains_g, spread = _grow_chains(evaluate, u[seeds], g[seeds], b, spread, options, rng, level + 1)
        est.points.append(norm.cdf(u))
        est.values.append(g)
        est.evaluations += n - options.chains
        previous = b
    est.reached = est.levels[-1].threshold == threshold
    est.probability, est.cov = factor, math.sqrt(cov2)
    return est


def _evaluate(evaluate: Evaluate, u: np.ndarray, tag: str) -> np.ndarray:
    g = np.asarray(evaluate(norm.cdf(u), tag), dtype=float)
    if g.shape != (len(u),) or not np.all(np.isfinite(g)):
        raise ValueError(f"subset simulation: evaluate({tag}) must return {len(u)} finite values, got shape {g.shape}")
    return g


def _grow_chains(evaluate, seeds_u, seeds_g, b, spread: float, options: SubsetOptions, rng, level: int):
    """From each seed a chain of ``chain_length`` states conditional on g <= b (the seed is its first), all
    chains stepping together; after each step the proposal's spread adapts toward :data:`TARGET_ACCEPTANCE`.
    Returns the level's points and g flattened chain by chain, g as (chains, chain_length), and the spread."""
    chains, length = options.chains, options.chain_length
    states_u = np.empty((chains, length, seeds_u.shape[1]))
    states_g = np.empty((chains, length))
    states_u[:, 0], states_g[:, 0] = seeds_u, seeds_g
    for step in range(1, length):
        cur_u, cur_g = states_u[:, step - 1], states_g[:, step - 1]
        cand = math.sqrt(1.0 - spread**2) * cur_u + spread * rng.standard_normal(cur_u.shape)
        cand_g = _evaluate(evaluate, cand, f"l{level}-s{step:02d}")
        accept = cand_g <= b
        states_u[:, step] = np.where(accept[:, None], cand, cur_u)
        states_g[:, step] = np.where(accept, cand_g, cur_g)
        spread = min(max(spread * math.exp(float(np.mean(accept)) - TARGET_ACCEPTANCE), MIN_SPREAD), MAX_SPREAD)
    return states_u.reshape(-1, seeds_u.shape[1]), states_g.reshape(-1), states_g, spread


def _level_cov2(indicator: np.ndarray, p: float, n: int) -> tuple[float, float]:
    """Au and Beck's squared CoV of a level's probability from its failure indicator, (chains, length)."""
    if p <= 0.0:
        return math.inf, 0.0
    if p >= 1.0:
        return 0.0, 0.0
    chains, length = indicator.shape
    ind = indicator.astype(float)
    r0 = p * (1.0 - p)
    gamma = 0.0
    for k in range(1, length):
        rk = float(np.sum(ind[:, : length - k] * ind[:, k:])) / (n - k * chains) - p * p
        gamma += 2.0 * (1.0 - k / length) * rk / r0
    gamma = max(gamma, 0.0)
    return (1.0 - p) / (p * n) * (1.0 + gamma), gamma
