"""The geofence unit's steady-wind estimate, compiled: :class:`geofence.wind_estimator.WindEstimator`'s update on arrays.

One question: given this step's state estimate, what is the steady wind?
:func:`wind_estimator_update` answers it as :meth:`WindEstimator.update` does,
bit for bit (``tests/test_sensing_kernel.py``), with the estimator's state in a
float vector so the simulated flight's compiled sensing step can call it; the
arithmetic (``airmass_sample``, ``force_balance_sample``, ``mean_update``) is
the class's own, compiled. The
class stays the readable reference; its module docstring states both models
(the fixed-wing's pitot triangle, the multirotor's force balance).
"""

from __future__ import annotations

import math

import numpy as np

from geofence.jit import COMPILED, numba
from geofence.wind_estimator import WindEstimator, airmass_sample, force_balance_sample, mean_update

__all__ = ["wind_estimator_arrays", "wind_estimator_update"]

# state W
WE, WN, T_USED, VAR, HAS_LP, LP_E, LP_N, LP_U, LP_FE, LP_FN, LAST_KIND_MR, LAST_WEIGHT = range(12)
N_STATE = 12
# constants
TAU, PRIOR_WEIGHT, MIN_AIRSPEED, MAX_BANK, INDICATED, ACCEL_WINDOW, ACCEL_REF2, MIN_AGL, K1, K2 = range(10)
N_CONST = 10


def wind_estimator_arrays(reference: WindEstimator) -> tuple[np.ndarray, np.ndarray]:
    """``(W, C)``: the state vector and constants of a fresh estimator configured as ``reference``."""
    cfg = reference.config
    k1, k2 = reference.drag_coefficients
    C = np.array(
        [
            cfg.tau_s, cfg.prior_weight_s, cfg.min_airspeed_mps, cfg.max_bank_rad, float(cfg.airspeed_is_indicated),
            cfg.accel_window_s, cfg.accel_ref_mps2 * cfg.accel_ref_mps2, cfg.min_agl_m, k1, k2,
        ],
        dtype=np.float64,
    )  # fmt: skip
    W = np.zeros(N_STATE)
    W[WE], W[WN] = reference.wind_enu
    return W, C


def _wind_estimator_update(
    W: np.ndarray,
    C: np.ndarray,
    has_pitot: bool,
    airspeed: float,
    dt_s: float,
    position_valid: bool,
    alt: float,
    agl: float,
    ve: float,
    vn: float,
    vu: float,
    roll: float,
    pitch: float,
    yaw: float,
) -> tuple[float, float]:
    """:meth:`WindEstimator.update` with the estimate's fields and the pitot reading (``has_pitot`` False: the
    multirotor's force balance, as the reference's ``airspeed_mps=None``). Returns ``(wind east, north)``."""
    if not (dt_s > 0.0) or not math.isfinite(dt_s):
        return (W[WE], W[WN])
    sampled = False
    we = wn = 0.0
    weight = 1.0
    if position_valid and agl >= C[MIN_AGL]:
        if has_pitot:
            sampled, we, wn = airmass_sample(
                airspeed, C[INDICATED] != 0.0, C[MIN_AIRSPEED], C[MAX_BANK], alt, ve, vn, vu, roll, yaw
            )
        else:
            W[LAST_KIND_MR] = 1.0
            has_lp, lp, sampled, we, wn, weight = force_balance_sample(
                (W[LP_E], W[LP_N], W[LP_U], W[LP_FE], W[LP_FN]), W[HAS_LP] != 0.0, dt_s, ve, vn, vu, roll, pitch, yaw,
                C[K1], C[K2], C[ACCEL_WINDOW], C[ACCEL_REF2],
            )  # fmt: skip
            W[HAS_LP] = 1.0 if has_lp else 0.0
            W[LP_E], W[LP_N], W[LP_U], W[LP_FE], W[LP_FN] = lp
    else:
        W[HAS_LP] = 0.0  # the force balance restarts from fresh filter states
    if not sampled:
        W[LAST_WEIGHT] = 0.0
        return (W[WE], W[WN])
    W[LAST_WEIGHT] = weight
    if weight > 0.0 and math.isfinite(we) and math.isfinite(wn):
        W[WE], W[WN], W[T_USED], W[VAR] = mean_update(
            W[WE], W[WN], W[T_USED], W[VAR], we, wn, weight, dt_s, C[PRIOR_WEIGHT], C[TAU]
        )
    return (W[WE], W[WN])


wind_estimator_update = numba.njit(cache=True)(_wind_estimator_update) if COMPILED else _wind_estimator_update
"""The compiled :func:`_wind_estimator_update` (the Python function itself without numba)."""
