"""One-sided exact 95 % upper bounds of the rates a campaign reports: exits or breaches per flight (binomial,
Clopper-Pearson) and per flight hour (Poisson). Numbers in, numbers out."""

from __future__ import annotations

import math

from scipy.stats import beta, chi2

CONFIDENCE = 0.95


def clopper_pearson_upper(k: int, n: int, confidence: float = CONFIDENCE) -> float:
    """One-sided exact upper confidence bound of a binomial proportion (k successes in n trials)."""
    if n <= 0:
        return math.nan
    if not 0 <= k <= n:
        raise ValueError(f"k must be in [0, n], got k={k}, n={n}")
    if k == n:
        return 1.0
    return float(beta.ppf(confidence, k + 1, n - k))


def poisson_rate_upper(k: int, exposure: float, confidence: float = CONFIDENCE) -> float:
    """One-sided upper confidence bound of a Poisson rate: k events in ``exposure`` (e.g. hours)."""
    if exposure <= 0.0:
        return math.nan
    return float(chi2.ppf(confidence, 2 * k + 2) / 2.0 / exposure)
