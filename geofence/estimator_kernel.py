"""The geofence unit's state estimator, compiled: :class:`geofence.estimator.GeofenceEstimator`'s step on arrays.

One question: given this step's sensor samples, what is the unit's state
estimate? :func:`estimator_step` answers it as :meth:`GeofenceEstimator.step`
does with air data and attitude present (as the simulated sensors give them
every step), bit for bit (``tests/test_sensing_kernel.py``): the same float
operations in the same order, on a state vector instead of attributes. The
class stays the readable reference; its module docstring states the filter.

State vector ``X`` (indices below): the clock, the horizontal axes ``(p, v, a)``
and their shared covariance at the fusion horizon ``t_d``, the vertical filter
``(up, v_up, b)`` and its covariance, the pending baro height, the bookkeeping
and the outputs (validity, sigmas) and the horizon's ``FixState`` fields.
Constants ``K``: :class:`~geofence.estimator.EstimatorConstants` and the
frame's table (:attr:`~geofence.geodesy.LocalFrame.enu_table`).
"""

from __future__ import annotations

import math

import numpy as np

from geofence.dynamics import isa_density_ratio
from geofence.estimator import EstimatorConfig, estimator_constants
from geofence.geodesy import LocalFrame, enu_of
from geofence.jit import COMPILED, jitable, numba

__all__ = ["estimator_arrays", "estimator_step"]

# state X
(
    T_S, CLOCK_SET, HAS_H, EP, EV, EA, NP, NV, NA, HP00, HP01, HP02, HP11, HP12, HP22, T_D,
    U, VU, B, V00, V01, V02, V11, V12, V22, V_INIT, HAS_PENDING_BARO, PENDING_BARO, LAST_FIX_ARRIVAL,
    FIXES_USED, FIXES_REJECTED, ROLL, PITCH, YAW, HAS_AIRSPEED, AIRSPEED, POSITION_VALID, SIGMA_H, SIGMA_V,
    VAR_H, HORIZON_NEW, H_T, H_E, H_N, H_VE, H_VN,
) = range(46)  # fmt: skip
N_STATE = 46
# constants K
(
    H0, DEG_PER_M_N, DEG_PER_M_E, INV_2R, LAT0, LON0, TIMEOUT, QJ, QP_H, QV, BARO_PRIMARY, QB,
    R_P, R_V, R_PU, R_VU, R_BARO, VAR_BIAS_H, VAR_BIAS_V, VAR_BARO_DRIFT,
) = range(20)  # fmt: skip
FRAME0 = 20  # the frame's table (LocalFrame.enu_table: ECEF origin, ECEF -> ENU rows)
N_CONST = 32


def estimator_arrays(frame: LocalFrame, config: EstimatorConfig | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(X, K)``: a fresh estimator's state vector and its constants (as ``GeofenceEstimator(frame, config)``)."""
    cfg = config or EstimatorConfig()
    k = estimator_constants(frame, cfg)
    K = np.zeros(N_CONST)
    K[H0], K[DEG_PER_M_N], K[DEG_PER_M_E], K[INV_2R] = k.h0_m, k.deg_per_m_n, k.deg_per_m_e, k.inv_2r_per_m
    K[LAT0], K[LON0], K[TIMEOUT] = frame.lat0_deg, frame.lon0_deg, cfg.timeout_s
    K[QJ], K[QP_H], K[QV], K[BARO_PRIMARY], K[QB] = k.q_jerk_h, k.q_wander_h, k.q_accel_v, float(k.baro_primary), k.q_baro
    K[R_P], K[R_V], K[R_PU], K[R_VU], K[R_BARO] = k.r_p, k.r_v, k.r_pu, k.r_vu, k.r_baro
    K[VAR_BIAS_H], K[VAR_BIAS_V], K[VAR_BARO_DRIFT] = k.var_bias_h, k.var_bias_v, k.var_baro_drift
    K[FRAME0 : FRAME0 + 12] = frame.enu_table
    X = np.zeros(N_STATE)
    X[LAST_FIX_ARRIVAL] = -math.inf
    X[SIGMA_H] = X[SIGMA_V] = X[VAR_H] = math.inf
    return X, K


@jitable
def _v_correct(X: np.ndarray, y: float, s: float, c0: float, c1: float, c2: float) -> None:
    """:meth:`GeofenceEstimator._v_correct`."""
    if not s > 0.0:
        return
    k0, k1, k2 = c0 / s, c1 / s, c2 / s
    X[U] += k0 * y
    X[VU] += k1 * y
    X[B] += k2 * y
    X[V00] = X[V00] - k0 * c0
    X[V01] = X[V01] - k0 * c1
    X[V02] = X[V02] - k0 * c2
    X[V11] = X[V11] - k1 * c1
    X[V12] = X[V12] - k1 * c2
    X[V22] = X[V22] - k2 * c2


@jitable
def _v_update(X: np.ndarray, h0: float, h1: float, h2: float, z: float, r: float) -> None:
    """:meth:`GeofenceEstimator._v_update`."""
    P00, P01, P02, P11, P12, P22 = X[V00], X[V01], X[V02], X[V11], X[V12], X[V22]
    c0 = P00 * h0 + P01 * h1 + P02 * h2
    c1 = P01 * h0 + P11 * h1 + P12 * h2
    c2 = P02 * h0 + P12 * h1 + P22 * h2
    s = h0 * c0 + h1 * c1 + h2 * c2 + r
    y = z - (h0 * X[U] + h1 * X[VU] + h2 * X[B])
    _v_correct(X, y, s, c0, c1, c2)


@jitable
def _set_v(X: np.ndarray, a: float, b: float, c: float, d: float, e: float, f: float) -> None:
    X[V00], X[V01], X[V02], X[V11], X[V12], X[V22] = a, b, c, d, e, f


@jitable
def _init_vertical_from_baro(X: np.ndarray, K: np.ndarray, z: float) -> None:
    """:meth:`GeofenceEstimator._init_vertical_from_baro`."""
    var_b = K[VAR_BARO_DRIFT]
    X[B] = 0.0
    X[U] = z
    _set_v(X, K[R_BARO] + var_b, 0.0, -var_b, K[R_VU], 0.0, var_b)
    X[V_INIT] = 1.0


@jitable
def _set_horizon(X: np.ndarray, t_m: float) -> None:
    X[H_T], X[H_E], X[H_N], X[H_VE], X[H_VN] = t_m, X[EP], X[NP], X[EV], X[NV]
    X[HORIZON_NEW] = 1.0


@jitable
def _init(X: np.ndarray, K: np.ndarray, e: float, n: float, u: float, fve: float, fvn: float, fvu: float, t_m: float, lag: float) -> None:  # fmt: skip
    """:meth:`GeofenceEstimator._init`."""
    X[HAS_H] = 1.0
    X[EP], X[EV], X[EA] = e, fve, 0.0
    X[NP], X[NV], X[NA] = n, fvn, 0.0
    X[HP00], X[HP01], X[HP02], X[HP11], X[HP12], X[HP22] = K[R_P], 0.0, 0.0, K[R_V], 0.0, 4.0  # (2 m/s^2)^2
    X[T_D] = t_m
    _set_horizon(X, t_m)
    X[U] = u + fvu * lag
    X[VU] = fvu
    if K[BARO_PRIMARY] != 0.0:
        if X[HAS_PENDING_BARO] != 0.0:
            _init_vertical_from_baro(X, K, X[PENDING_BARO])
        return
    if X[HAS_PENDING_BARO] != 0.0:
        X[B] = X[PENDING_BARO] - X[U]
        var_b = K[R_PU] + K[R_BARO]
    else:
        X[B] = 0.0
        var_b = K[VAR_BARO_DRIFT] + K[VAR_BIAS_V] + 100.0
    _set_v(X, K[R_PU], 0.0, 0.0, K[R_VU], 0.0, var_b)
    X[V_INIT] = 1.0


@jitable
def _axis_predict(X: np.ndarray, p: int, dt: float) -> None:
    """``_Axis.predict`` of the axis whose ``(p, v, a)`` start at index ``p``."""
    if dt <= 0.0:
        return
    h = 0.5 * dt * dt
    X[p] += X[p + 1] * dt + X[p + 2] * h
    X[p + 1] += X[p + 2] * dt


@jitable
def _cov_predict(X: np.ndarray, dt: float, qj: float, qp: float) -> None:
    """``_AxisCovariance.predict``."""
    if dt <= 0.0:
        return
    h = 0.5 * dt * dt
    P00, P01, P02, P11, P12, P22 = X[HP00], X[HP01], X[HP02], X[HP11], X[HP12], X[HP22]
    r00, r01, r02 = P00 + dt * P01 + h * P02, P01 + dt * P11 + h * P12, P02 + dt * P12 + h * P22
    r10, r11, r12 = P01 + dt * P02, P11 + dt * P12, P12 + dt * P22
    d2, d3 = dt * dt, dt * dt * dt
    X[HP00] = r00 + dt * r01 + h * r02 + qj * d3 * d2 / 20.0 + qp * dt
    X[HP01] = r10 + dt * r11 + h * r12 + qj * d2 * d2 / 8.0
    X[HP02] = r02 + qj * d3 / 6.0
    X[HP11] = r11 + dt * r12 + qj * d3 / 3.0
    X[HP12] = r12 + qj * d2 / 2.0
    X[HP22] = P22 + qj * dt


@jitable
def _cov_update(X: np.ndarray, s: float, c0: float, c1: float, c2: float) -> tuple[float, float, float]:
    """``_AxisCovariance._update``: returns the gain."""
    k0, k1, k2 = c0 / s, c1 / s, c2 / s
    X[HP00] -= k0 * c0
    X[HP01] -= k0 * c1
    X[HP02] -= k0 * c2
    X[HP11] -= k1 * c1
    X[HP12] -= k1 * c2
    X[HP22] -= k2 * c2
    return (k0, k1, k2)


@jitable
def _correct(X: np.ndarray, y_e: float, y_n: float, k: tuple[float, float, float]) -> None:
    """``_Axis.correct`` of both axes with their innovations and the shared gain."""
    k0, k1, k2 = k
    X[EP] += k0 * y_e
    X[EV] += k1 * y_e
    X[EA] += k2 * y_e
    X[NP] += k0 * y_n
    X[NV] += k1 * y_n
    X[NA] += k2 * y_n


@jitable
def _update_gps(X: np.ndarray, K: np.ndarray, fix: np.ndarray) -> None:
    """:meth:`GeofenceEstimator.update_gps` with a fix row ``(t, lat, lon, alt, ve, vn, vu, h_acc, v_acc, valid)``."""
    if fix[9] == 0.0:
        return
    t_m, lat, lon, alt, fve, fvn, fvu = fix[0], fix[1], fix[2], fix[3], fix[4], fix[5], fix[6]
    finite = (
        math.isfinite(t_m)
        and math.isfinite(lat)
        and math.isfinite(lon)
        and math.isfinite(alt)
        and math.isfinite(fve)
        and math.isfinite(fvn)
        and math.isfinite(fvu)
    )
    if not finite or abs(lat) > 90.0:
        X[FIXES_REJECTED] += 1.0
        return
    e, n, u = enu_of(K[FRAME0 : FRAME0 + 12], lat, lon, alt)
    lag = X[T_S] - t_m
    if lag < 0.0:
        lag = 0.0
    if X[HAS_H] == 0.0:
        _init(X, K, e, n, u, fve, fvn, fvu, t_m, lag)
        X[LAST_FIX_ARRIVAL] = X[T_S]
        X[FIXES_USED] += 1.0
        return
    if t_m <= X[T_D]:  # stale or duplicate
        X[FIXES_REJECTED] += 1.0
        return
    dt = t_m - X[T_D]
    _axis_predict(X, EP, dt)
    _axis_predict(X, NP, dt)
    _cov_predict(X, dt, K[QJ], K[QP_H])
    X[T_D] = t_m
    # position, then velocity: each gain serves both axes (their covariances are equal)
    ye, yn = e - X[EP], n - X[NP]
    _correct(X, ye, yn, _cov_update(X, X[HP00] + K[R_P], X[HP00], X[HP01], X[HP02]))
    ye, yn = fve - X[EV], fvn - X[NV]
    _correct(X, ye, yn, _cov_update(X, X[HP11] + K[R_V], X[HP01], X[HP11], X[HP12]))
    _set_horizon(X, t_m)
    # vertical: current-time filter, first-order latency compensation
    q = K[QV]
    if K[BARO_PRIMARY] == 0.0:
        _v_update(X, 1.0, -lag, 0.0, u, K[R_PU] + q * lag * lag * lag / 3.0)
    _v_update(X, 0.0, 1.0, 0.0, fvu, K[R_VU] + q * lag)
    X[LAST_FIX_ARRIVAL] = X[T_S]
    X[FIXES_USED] += 1.0


def _estimator_step(
    X: np.ndarray,
    K: np.ndarray,
    dt_s: float,
    has_fix: bool,
    fix: np.ndarray,
    t_air: float,
    airspeed: float,
    baro_alt_m: float,
    roll: float,
    pitch: float,
    yaw: float,
) -> tuple[float, ...]:
    """:meth:`GeofenceEstimator.step` with air data and an attitude sample of time ``t_air`` (``airspeed``
    NaN without a pitot) and, when ``has_fix``, the GNSS fix row ``fix``.

    Returns the estimate's :class:`~geofence.interface.VehicleState` fields in order, ``on_ground`` left out
    (``t, lat, lon, alt, e, n, up, agl, ve, vn, vu, roll, pitch, yaw, airspeed``); the validity, sigmas and the
    fusion horizon are in ``X`` (``HORIZON_NEW`` set when a fix moved the horizon this step).
    """
    X[HORIZON_NEW] = 0.0
    # predict: the clock and the vertical filter (the horizontal state is extrapolated at the output)
    if dt_s > 0.0 and math.isfinite(dt_s):
        X[T_S] += dt_s
        if X[V_INIT] != 0.0:
            dt = dt_s
            q = K[QV]
            two_dt, dt2, q_uu, q_uv, q_vv, q_bb = 2.0 * dt, dt * dt, q * dt * dt * dt / 3.0, 0.5 * q * dt * dt, q * dt, K[QB] * dt
            V00_, V01_, V02_, V11_, V12_, V22_ = X[V00], X[V01], X[V02], X[V11], X[V12], X[V22]
            X[U] += X[VU] * dt
            _set_v(
                X, V00_ + two_dt * V01_ + dt2 * V11_ + q_uu, V01_ + dt * V11_ + q_uv, V02_ + dt * V12_,
                V11_ + q_vv, V12_, V22_ + q_bb,
            )  # fmt: skip
    if math.isfinite(t_air):
        if X[CLOCK_SET] == 0.0 or t_air >= X[T_S] - 1.0:
            X[T_S] = t_air
            X[CLOCK_SET] = 1.0
    if math.isfinite(roll) and math.isfinite(pitch) and math.isfinite(yaw):
        X[ROLL], X[PITCH], X[YAW] = roll, pitch, yaw
    if has_fix:
        _update_gps(X, K, fix)
    # air data: pitot airspeed and baro height
    X[HAS_AIRSPEED] = 1.0 if math.isfinite(airspeed) else 0.0
    X[AIRSPEED] = airspeed
    z = baro_alt_m
    if math.isfinite(z):
        z -= K[H0]
        if X[V_INIT] == 0.0:
            X[PENDING_BARO] = z  # used to initialise the offset at the first fix
            X[HAS_PENDING_BARO] = 1.0
            if X[HAS_H] != 0.0 and K[BARO_PRIMARY] != 0.0:
                _init_vertical_from_baro(X, K, z)  # the first fix came before the first baro sample
        else:
            V00_, V01_, V02_, V11_, V12_, V22_ = X[V00], X[V01], X[V02], X[V11], X[V12], X[V22]
            c0 = V00_ + V02_
            c1 = V01_ + V12_
            c2 = V02_ + V22_
            _v_correct(X, z - (X[U] + X[B]), c0 + c2 + K[R_BARO], c0, c1, c2)
    # output
    now = X[T_S]
    X[POSITION_VALID] = 1.0 if (now - X[LAST_FIX_ARRIVAL]) <= K[TIMEOUT] else 0.0
    r_, p_, y_ = X[ROLL], X[PITCH], X[YAW]
    if X[HAS_H] == 0.0:
        X[SIGMA_H] = X[SIGMA_V] = math.inf
        return (now, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, r_, p_, y_, 0.0)
    d = now - X[T_D]
    if d < 0.0:
        d = 0.0
    h = 0.5 * d * d
    e = X[EP] + X[EV] * d + X[EA] * h
    n = X[NP] + X[NV] * d + X[NA] * h
    ve = X[EV] + X[EA] * d
    vn = X[NV] + X[NA] * d
    # position variance extrapolated from the horizon: g P g^T + Q, g = (1, d, h); the same for both axes
    qd = K[QJ] * d * d * d * d * d / 20.0 + K[QP_H] * d
    var = X[HP00] + 2.0 * d * X[HP01] + 2.0 * h * X[HP02] + d * d * X[HP11] + 2.0 * d * h * X[HP12] + h * h * X[HP22] + qd
    X[VAR_H] = var
    X[SIGMA_H] = math.sqrt(var + K[VAR_BIAS_H])
    X[SIGMA_V] = math.sqrt(X[V00] + K[VAR_BIAS_V])
    u = X[U]
    curv = (e * e + n * n) * K[INV_2R]
    alt = K[H0] + u + curv
    if X[HAS_AIRSPEED] != 0.0:  # indicated -> true airspeed at the estimated altitude
        a = X[AIRSPEED] / math.sqrt(isa_density_ratio(alt))
    else:
        a = math.sqrt(ve * ve + vn * vn)
    return (
        now, K[LAT0] + n * K[DEG_PER_M_N], K[LON0] + e * K[DEG_PER_M_E], alt, e, n, u, u + curv,
        ve, vn, X[VU], r_, p_, y_, a,
    )  # fmt: skip


estimator_step = numba.njit(cache=True)(_estimator_step) if COMPILED else _estimator_step
"""The compiled :func:`_estimator_step` (the Python function itself without numba)."""
