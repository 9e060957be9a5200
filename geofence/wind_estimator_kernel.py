"""The geofence unit's steady-wind estimate, compiled: :class:`geofence.wind_estimator.WindEstimator`'s update on arrays.

One question: given this step's state estimate, what is the steady wind?
:func:`wind_estimator_update` answers it as :meth:`WindEstimator.update` does,
bit for bit (``tests/test_sensing_kernel.py``), with the estimator's state in a
float vector so the simulated flight's compiled sensing step can call it. The
class stays the readable reference; its module docstring states both models
(the fixed-wing's pitot triangle, the multirotor's force balance).
"""

from __future__ import annotations

import math

import numpy as np

from geofence.dynamics import G_MPS2, airspeed_for_drag_mps, isa_density_ratio
from geofence.jit import COMPILED, jitable, numba
from geofence.wind_estimator import WindEstimator

__all__ = ["wind_estimator_arrays", "wind_estimator_update"]

# state W
WE, WN, T_USED, VAR, HAS_LP, LP_E, LP_N, LP_U, LP_FE, LP_FN, LAST_KIND_MR, LAST_WEIGHT = range(12)
N_STATE = 12
# constants
TAU, PRIOR_WEIGHT, MIN_AIRSPEED, MAX_BANK, INDICATED, ACCEL_WINDOW, ACCEL_REF2, MIN_AGL, K1, K2 = range(10)
N_CONST = 10
_MIN_G_UP_MPS2 = 0.2 * G_MPS2


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


@jitable
def _multirotor_sample(W: np.ndarray, C: np.ndarray, dt_s: float, ve: float, vn: float, vu: float, roll: float, pitch: float, yaw: float) -> tuple[bool, float, float, float]:  # fmt: skip
    """:meth:`WindEstimator._multirotor_sample`: ``(sampled, wind e, wind n, weight)``."""
    k1, k2 = C[K1], C[K2]
    if k1 <= 0.0 and k2 <= 0.0:
        return False, 0.0, 0.0, 0.0
    if not (math.isfinite(ve) and math.isfinite(vn) and math.isfinite(vu)):
        return False, 0.0, 0.0, 0.0
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    t_n = -(cy * sp * cr + sy * sr)
    t_e = -(sy * sp * cr - cy * sr)
    t_up = cp * cr
    if t_up < 0.2:
        W[HAS_LP] = 0.0
        return False, 0.0, 0.0, 0.0
    if W[HAS_LP] == 0.0:
        W[HAS_LP] = 1.0
        W[LP_E], W[LP_N], W[LP_U], W[LP_FE], W[LP_FN] = ve, vn, vu, G_MPS2 * t_e / t_up, G_MPS2 * t_n / t_up
        return False, 0.0, 0.0, 0.0
    lp_e, lp_n, lp_u, lp_fe, lp_fn = W[LP_E], W[LP_N], W[LP_U], W[LP_FE], W[LP_FN]
    tau_dt = C[ACCEL_WINDOW] + dt_s
    ae = (ve - lp_e) / tau_dt
    an = (vn - lp_n) / tau_dt
    au = (vu - lp_u) / tau_dt
    alpha = dt_s / tau_dt
    lp_e += alpha * (ve - lp_e)
    lp_n += alpha * (vn - lp_n)
    lp_u += alpha * (vu - lp_u)
    g_up = G_MPS2 + au
    if g_up < _MIN_G_UP_MPS2:
        g_up = _MIN_G_UP_MPS2
    lp_fe += alpha * (g_up * t_e / t_up - lp_fe)
    lp_fn += alpha * (g_up * t_n / t_up - lp_fn)
    W[LP_E], W[LP_N], W[LP_U], W[LP_FE], W[LP_FN] = lp_e, lp_n, lp_u, lp_fe, lp_fn
    de, dn = lp_fe - ae, lp_fn - an
    d = math.sqrt(de * de + dn * dn)
    v_air = airspeed_for_drag_mps(k1, k2, d)
    if not math.isfinite(v_air):
        return False, 0.0, 0.0, 0.0
    if d > 1e-12:
        we, wn = lp_e - v_air * de / d, lp_n - v_air * dn / d
    else:
        we, wn = lp_e, lp_n
    q = (ae * ae + an * an) / C[ACCEL_REF2]
    return True, we, wn, 1.0 / (1.0 + q)


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
            va = airspeed
            if math.isfinite(va) and not va < C[MIN_AIRSPEED] and not abs(roll) > C[MAX_BANK]:
                if C[INDICATED] != 0.0:
                    va /= math.sqrt(isa_density_ratio(alt)) if math.isfinite(alt) else 1.0
                vh2 = va * va - vu * vu
                vh = math.sqrt(vh2) if vh2 > 0.0 else 0.0
                sampled, we, wn = True, ve - vh * math.sin(yaw), vn - vh * math.cos(yaw)
        else:
            W[LAST_KIND_MR] = 1.0
            sampled, we, wn, weight = _multirotor_sample(W, C, dt_s, ve, vn, vu, roll, pitch, yaw)
    else:
        W[HAS_LP] = 0.0  # the force balance restarts from fresh filter states
    if not sampled:
        W[LAST_WEIGHT] = 0.0
        return (W[WE], W[WN])
    W[LAST_WEIGHT] = weight
    if weight > 0.0 and math.isfinite(we) and math.isfinite(wn):
        t_used = W[T_USED]
        memory = C[PRIOR_WEIGHT] + t_used
        if not memory < C[TAU]:
            memory = C[TAU]
        wdt = weight * dt_s
        k = wdt / (memory + wdt)
        mean_e = W[WE] + k * (we - W[WE])
        mean_n = W[WN] + k * (wn - W[WN])
        W[WE], W[WN] = mean_e, mean_n
        W[T_USED] = t_used + wdt
        de, dn = we - mean_e, wn - mean_n
        W[VAR] += k * (0.5 * (de * de + dn * dn) - W[VAR])
        return (mean_e, mean_n)
    return (W[WE], W[WN])


wind_estimator_update = numba.njit(cache=True)(_wind_estimator_update) if COMPILED else _wind_estimator_update
"""The compiled :func:`_wind_estimator_update` (the Python function itself without numba)."""
