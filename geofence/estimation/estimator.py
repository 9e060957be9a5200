"""The geofence unit's own state estimator: GNSS + baro + AHRS -> a :class:`VehicleState` estimate.

The unit must not trust the autopilot's navigation, so it runs its own small
linear Kalman filter on its own sensors (:mod:`geofence.estimation.measurements`).

Horizontal (east and north, independent axes)
    A constant-acceleration kinematic model per axis, state ``(p, v, a)``,
    driven by white jerk (``jerk_psd_h``). Acceleration is a state because the
    GNSS is 5 Hz and 0.2 s late: a plain constant-velocity filter would report
    the velocity of up to 0.4 s ago, ~2 m/s off in a 30 deg-bank turn; with the
    acceleration state the extrapolation follows turns and stick steps.

    **Latency** is handled exactly, by a *delayed fusion horizon*: the filter
    lives at the time of validity of the last fix, ``t_d``. A new fix stamped
    ``t_m > t_d`` is fused by predicting the horizon to ``t_m`` and updating
    there (position, then velocity, as scalar updates). Every step the output is
    the horizon state extrapolated to the current time with the same model,
    covariance included. For a linear model whose only delayed measurement is
    the GNSS this is the same as buffering states and re-propagating, at a
    fraction of the cost (the per-step work is one extrapolation).

Vertical
    A current-time filter with state ``(up, v_up, b)``: ``b`` is the baro offset
    (baro altitude - frame origin height - up). The barometer (no latency)
    updates every step; the GNSS vertical velocity updates ``v_up`` (its
    latency ``L`` adds ``q L`` to the variance). With ``baro_referenced``
    (default: the barometer was set to the field elevation at start-up, as
    autopilots do) and a baro drift below the GNSS height bias (1 m vs 3 m by
    default) the barometer is the height reference: ``b`` starts at 0
    with the baro drift as its uncertainty and the GNSS height is not fused,
    because its bias (~3 m, wandering over a minute) is three times the baro
    drift; ``sigma_v`` is then about the baro drift (1 m) instead of the GNSS
    bias. Without it, a GNSS height stamped ``L`` s ago updates through
    ``up(t - L) ~= up - L * v_up`` (first-order latency compensation; its
    neglected process noise ``q L^3 / 3`` is added to the measurement
    variance), ``b`` is initialised from the first fix and the GNSS bias
    wander is part of its process noise.

GNSS bias
    A single-antenna receiver's error is mostly a slowly wandering bias
    (metres, tau ~ 60 s), which no filter can separate from the position
    without a second absolute source. The filters therefore track the
    *receiver's* position (white noise only in the measurement model, the bias
    wander ``2 sigma^2 / tau`` as extra position process noise) and the
    reported standard deviations add the bias sigma:
    ``sigma_h = sqrt(P_ee + gps_h_bias_m^2)`` (``P_nn = P_ee``: both axes have
    the same model and noise, so one covariance serves both),
    ``sigma_v = sqrt(P_uu + gps_v_bias_m^2)``. These are the figures the
    geofence turns into an extra boundary margin (``k * sigma``).

Loss of the position source
    ``position_valid`` is False until the first valid fix and whenever no valid
    fix arrived for longer than ``timeout_s`` (default 1 s); the state keeps
    being extrapolated (with a growing covariance) so the unit can still fly
    a landing, but the geofence must treat the position as lost.

Output
    :meth:`GeofenceEstimator.step` returns a :class:`VehicleState` in the
    frame's ENU. ``alt_m`` adds the Earth-curvature drop ``(e^2 + n^2) / 2R``
    to ``h0 + up`` and ``agl_m = alt_m - h0`` (flat ground at the origin
    height, like the simulation's). ``lat_deg``/``lon_deg`` use the origin's
    radii of curvature (linearized: < 0.5 m off within 2 km of the origin;
    the geofence works in ENU). Attitude is the latest AHRS sample;
    ``airspeed_mps`` is the true airspeed: the pitot's indicated reading
    converted with the ISA density at the estimated altitude
    (:func:`geofence.physics.dynamics.isa_density_ratio`), or the ground speed
    without a pitot.

The step is written once: :func:`estimator_step`, compiled by :func:`geofence.jit.compiled` (the same source
interpreted without numba or with ``NUMBA_DISABLE_JIT=1``), its formulas the ``jitable`` functions below. Its
state and constants are the records :data:`EST_STATE` and :data:`EST_CONST` over float memory, so that the
unit's compiled sensing chain (:mod:`scenarios.flight.sensing`) keeps them in its packed array;
:class:`GeofenceEstimator` is a façade that owns (or is given) those slots and calls the step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from geofence.estimation.measurements import AirData, AttitudeSample, GpsFix, RangeFlowSample
from geofence.geometry.geodesy import LocalFrame, enu_of, radii_of_curvature_m
from geofence.interface import FixState, VehicleState
from geofence.jit import compiled, jitable
from geofence.physics.dynamics import isa_density_ratio


@dataclass(frozen=True)
class EstimatorConfig:
    """Tuning of :class:`GeofenceEstimator`; the GNSS/baro figures should match the unit's sensors.

    The defaults match :class:`aircraft.sensors.SensorConfig`'s defaults.
    ``jerk_psd_h`` (m^2/s^5) is the horizontal white-jerk spectral density,
    ``accel_psd_v`` (m^2/s^3) the vertical white-acceleration one.
    """

    jerk_psd_h: float = 3.0
    accel_psd_v: float = 2.0
    gps_h_white_m: float = 0.5
    gps_h_bias_m: float = 1.5
    gps_v_white_m: float = 1.0
    gps_v_bias_m: float = 3.0
    gps_bias_tau_s: float = 60.0
    gps_vel_h_mps: float = 0.1
    gps_vel_v_mps: float = 0.2
    baro_noise_m: float = 0.3
    baro_drift_m: float = 1.0
    baro_drift_tau_s: float = 300.0
    timeout_s: float = 1.0
    range_noise_m: float = 0.05
    """A downward rangefinder's noise floor (its slant range), m (used only when one gives readings)."""
    range_noise_fraction: float = 0.01
    """... and its noise as a fraction of the range, where that is larger."""
    flow_noise_radps: float = 0.3
    """An optical-flow sensor's angular-flow noise, rad/s: its velocity noise is this times the height."""
    baro_referenced: bool = True
    """The barometer was set to the field elevation at start-up (QNH/zeroed at home). If it also drifts
    less than the GNSS height is biased, it is the height reference and the GNSS height is not fused."""

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            v = getattr(self, name)
            if name == "baro_referenced":
                continue
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0.0):
                raise ValueError(f"estimator.{name}: must be a finite number >= 0, got {v!r}")
        for name in ("gps_bias_tau_s", "baro_drift_tau_s", "timeout_s"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"estimator.{name}: must be > 0, got {getattr(self, name)!r}")


def _float_record(*fields: str | tuple[str, int]) -> np.dtype:
    """A record dtype of float64 fields (a ``(name, n)`` pair: a field of ``n`` floats), viewable over float memory."""
    spec = [(f, np.float64) if isinstance(f, str) else (f[0], np.float64, (f[1],)) for f in fields]
    return np.dtype((np.record, spec))


EST_STATE = _float_record(
    "t_s", "clock_set", "has_fix",  # the estimator's clock; 1 once a time stamp set it; 1 once a fix was fused
    "east_m", "v_east_mps", "a_east_mps2", "north_m", "v_north_mps", "a_north_mps2",  # the axes at the horizon
    "ph00", "ph01", "ph02", "ph11", "ph12", "ph22",  # the covariance of each horizontal axis's (p, v, a)
    "t_d_s",  # the fusion horizon: the newest fused fix's time of validity
    "up_m", "v_up_mps", "baro_offset_m",  # the vertical filter (current time)
    "pv00", "pv01", "pv02", "pv11", "pv12", "pv22",  # its covariance
    "v_init", "has_pending_baro", "pending_baro_m",  # 1 once the vertical filter started; the baro height before
    "last_fix_arrival_s", "fixes_used", "fixes_rejected",
    "roll_rad", "pitch_rad", "yaw_rad",  # the latest AHRS sample
    "has_airspeed", "airspeed_mps",  # the latest pitot reading (indicated)
    "position_valid", "sigma_h_m", "sigma_v_m", "var_h_m2",  # the outputs of the last step
    "horizon_new",  # 1 when the last step moved the horizon
    "horizon_t_s", "horizon_east_m", "horizon_north_m", "horizon_v_east_mps", "horizon_v_north_mps",  # FixState's order
    "flow_aided",  # 1 while the horizontal state is carried forward on optical-flow velocity (no fix since)
)  # fmt: skip
"""The estimator's state, a record over float memory (every field float64: a flag is 0 or 1, a count a whole
number), so that a caller's compiled step keeps it in one float array with its other states and the façade reads
the same memory."""

EST_CONST = _float_record(
    "h0_m", "deg_per_m_n", "deg_per_m_e", "inv_2r_per_m", "lat0_deg", "lon0_deg", "timeout_s",
    "q_jerk_h", "q_wander_h", "q_accel_v", "baro_primary", "q_baro",
    "r_p", "r_v", "r_pu", "r_vu", "r_baro", "var_bias_h", "var_bias_v", "var_baro_drift",
    "range_noise_m", "range_noise_fraction", "flow_noise_radps",
    ("enu_table", 12),
)  # fmt: skip
"""The estimator's constants from its frame and :class:`EstimatorConfig` (:func:`estimator_constants`)."""

GPS_FIX = _float_record(*GpsFix._fields)
"""A GNSS message as floats, :class:`~geofence.estimation.measurements.GpsFix`'s fields in order (``valid`` 0 or 1): the row
the simulated receiver delivers (:mod:`aircraft.sensors`) and :func:`estimator_step` fuses."""

STATE_SIZE = EST_STATE.itemsize // 8
CONST_SIZE = EST_CONST.itemsize // 8
MEMORY_SIZE = STATE_SIZE + CONST_SIZE
"""Float64 slots of the memory a :class:`GeofenceEstimator` lives in: its state, then its constants."""
FIX_SIZE = GPS_FIX.itemsize // 8


def estimator_constants(K: np.ndarray, frame: LocalFrame, cfg: EstimatorConfig) -> None:
    """Fill ``K`` (:data:`EST_CONST`'s slots) for an estimator in ``frame`` tuned by ``cfg`` (the one home of these
    formulas; variances in m², (m/s)²)."""
    c = K.view(EST_CONST)[0]
    lat0 = math.radians(frame.lat0_deg)
    n_rad, m_rad = radii_of_curvature_m(lat0)
    baro_primary = cfg.baro_referenced and cfg.baro_drift_m < cfg.gps_v_bias_m
    q_baro = 2.0 * cfg.baro_drift_m**2 / cfg.baro_drift_tau_s
    if not baro_primary:  # the offset also absorbs the wander of the GNSS height it is tied to
        q_baro += 2.0 * cfg.gps_v_bias_m**2 / cfg.gps_bias_tau_s
    c.h0_m, c.lat0_deg, c.lon0_deg, c.timeout_s = frame.h0_m, frame.lat0_deg, frame.lon0_deg, cfg.timeout_s
    c.deg_per_m_n = math.degrees(1.0) / (m_rad + frame.h0_m)  # latitude per metre north (meridian radius)
    c.deg_per_m_e = math.degrees(1.0) / ((n_rad + frame.h0_m) * math.cos(lat0))  # longitude per metre east
    c.inv_2r_per_m = 0.5 / math.sqrt(m_rad * n_rad)  # of the Earth-curvature drop (e² + n²) / 2R
    c.q_jerk_h, c.q_accel_v, c.q_baro = cfg.jerk_psd_h, cfg.accel_psd_v, q_baro
    c.q_wander_h = 2.0 * cfg.gps_h_bias_m**2 / cfg.gps_bias_tau_s  # the GNSS bias wander as process noise
    c.baro_primary = float(baro_primary)  # a referenced barometer drifting less: the height reference
    c.r_p, c.r_v, c.r_pu = cfg.gps_h_white_m**2, cfg.gps_vel_h_mps**2, cfg.gps_v_white_m**2
    c.r_vu, c.r_baro = cfg.gps_vel_v_mps**2, cfg.baro_noise_m**2
    c.var_bias_h, c.var_baro_drift = cfg.gps_h_bias_m**2, cfg.baro_drift_m**2
    c.var_bias_v = 0.0 if baro_primary else cfg.gps_v_bias_m**2
    c.range_noise_m, c.range_noise_fraction, c.flow_noise_radps = (
        cfg.range_noise_m,
        cfg.range_noise_fraction,
        cfg.flow_noise_radps,
    )
    c.enu_table = frame.enu_table


def estimator_reset(X: np.ndarray) -> None:
    """``X`` (:data:`EST_STATE`'s slots) as a fresh estimator's: no fix, no estimate."""
    X[:] = 0.0
    x = X.view(EST_STATE)[0]
    x.last_fix_arrival_s = -math.inf
    x.sigma_h_m = x.sigma_v_m = x.var_h_m2 = math.inf


@compiled
def estimator_step(
    X: np.ndarray, K: np.ndarray, dt_s: float, has_fix: bool, fix: np.ndarray, t_air: float, airspeed: float,
    baro_alt_m: float, roll: float, pitch: float, yaw: float, range_m: float = math.nan,
    flow_fwd_mps: float = math.nan, flow_right_mps: float = math.nan,
) -> tuple[float, ...]:  # fmt: skip
    """One step of the estimator (see the module docstring): predict by ``dt_s``, take the sensor time ``t_air``
    (NaN: none), the attitude (NaN: none), the GNSS message ``fix`` (:data:`GPS_FIX`'s slots) when ``has_fix``,
    then the pitot's ``airspeed`` (NaN: none) and the baro altitude (NaN: none), a downward rangefinder's slant
    range and an optical-flow's body velocity (NaN: none; :func:`update_range`, :func:`update_flow`). ``X``: :data:`EST_STATE`'s slots,
    updated in place; ``K``: :data:`EST_CONST`'s.

    Returns the estimate's :class:`~geofence.interface.VehicleState` fields in order, ``on_ground`` left out
    (``t, lat, lon, alt, e, n, up, agl, ve, vn, vu, roll, pitch, yaw, airspeed``); the validity, sigmas and the
    fusion horizon are in ``X`` (``horizon_new`` set when a fix moved the horizon this step)."""
    x = X.view(EST_STATE)[0]
    c = K.view(EST_CONST)[0]
    x.horizon_new = 0.0
    predict(x, c, dt_s)
    if math.isfinite(t_air):
        if x.clock_set == 0.0 or t_air >= x.t_s - 1.0:
            x.t_s = t_air
            x.clock_set = 1.0
    if math.isfinite(roll) and math.isfinite(pitch) and math.isfinite(yaw):
        x.roll_rad, x.pitch_rad, x.yaw_rad = roll, pitch, yaw
    if has_fix:
        update_gps(x, c, fix.view(GPS_FIX)[0])
    update_air(x, c, airspeed, baro_alt_m)
    if range_m == range_m:  # (not NaN)
        update_range(x, c, range_m)
    if flow_fwd_mps == flow_fwd_mps and flow_right_mps == flow_right_mps:
        update_flow(x, c, flow_fwd_mps, flow_right_mps)
    return output(x, c)


@jitable
def update_range(x: Any, c: Any, range_m: float) -> None:
    """A rangefinder's slant range levelled by the AHRS attitude: the height above the flat ground the frame's
    origin is on (the estimate's ``agl``), a scalar update of the vertical filter with ``H = (1, 0, 0)`` (the
    Earth-curvature drop at the horizon's position taken off). It also calibrates the baro offset."""
    if x.v_init == 0.0:
        return
    level = math.cos(x.roll_rad) * math.cos(x.pitch_rad)
    curv = (x.east_m * x.east_m + x.north_m * x.north_m) * c.inv_2r_per_m
    sigma = max(c.range_noise_m, c.range_noise_fraction * range_m)
    v_update(x, 1.0, 0.0, 0.0, range_m * level - curv, sigma * sigma)


@jitable
def update_flow(x: Any, c: Any, fwd: float, right: float) -> None:
    """An optical-flow body velocity, rotated to ENU by the AHRS heading, while no fix arrived for ``timeout_s``:
    the horizon is carried to the current time and updated with it (a velocity update, its variance the angular
    noise times the height); a later fix is fused from its own time again (:func:`update_gps`)."""
    if x.has_fix == 0.0 or x.t_s - x.last_fix_arrival_s <= c.timeout_s:
        return
    sy, cy = math.sin(x.yaw_rad), math.cos(x.yaw_rad)
    ve, vn = fwd * sy + right * cy, fwd * cy - right * sy
    dt = x.t_s - x.t_d_s
    if dt > 0.0:
        h = 0.5 * dt * dt
        x.east_m += x.v_east_mps * dt + x.a_east_mps2 * h
        x.v_east_mps += x.a_east_mps2 * dt
        x.north_m += x.v_north_mps * dt + x.a_north_mps2 * h
        x.v_north_mps += x.a_north_mps2 * dt
        covariance_predict(x, dt, c.q_jerk_h, c.q_wander_h)
        x.t_d_s = x.t_s
    height = x.up_m if x.up_m > 0.3 else 0.3
    r = (c.flow_noise_radps * height) ** 2
    correct(x, ve - x.v_east_mps, vn - x.v_north_mps, covariance_update(x, x.ph11 + r, x.ph01, x.ph11, x.ph12))
    x.flow_aided = 1.0


@jitable
def predict(x: Any, c: Any, dt_s: float) -> None:
    """Advance the clock and the vertical filter by ``dt_s`` (the horizontal state is extrapolated at the output).

    ``F = [[1, dt, 0], [0, 1, 0], [0, 0, 1]]``; Q is the white-acceleration noise (``q dt^3/3``, ``q dt^2/2``,
    ``q dt``) plus the baro offset's wander."""
    if not (dt_s > 0.0 and math.isfinite(dt_s)):
        return
    x.t_s += dt_s
    if x.v_init == 0.0:
        return
    dt = dt_s
    q = c.q_accel_v
    two_dt, dt2, q_uu, q_uv, q_vv, q_bb = 2.0 * dt, dt * dt, q * dt * dt * dt / 3.0, 0.5 * q * dt * dt, q * dt, c.q_baro * dt
    P00, P01, P02, P11, P12, P22 = x.pv00, x.pv01, x.pv02, x.pv11, x.pv12, x.pv22
    x.up_m += x.v_up_mps * dt
    set_vertical_covariance(
        x, P00 + two_dt * P01 + dt2 * P11 + q_uu, P01 + dt * P11 + q_uv, P02 + dt * P12, P11 + q_vv, P12, P22 + q_bb
    )


@jitable
def set_vertical_covariance(x: Any, p00: float, p01: float, p02: float, p11: float, p12: float, p22: float) -> None:
    x.pv00, x.pv01, x.pv02, x.pv11, x.pv12, x.pv22 = p00, p01, p02, p11, p12, p22


@jitable
def update_air(x: Any, c: Any, airspeed: float, baro_alt_m: float) -> None:
    """The pitot reading (kept for the output) and the baro height: a scalar update with ``H = (1, 0, 1)`` (written
    out without its products by 1 and by 0: the dropped terms are exact zeros), every step."""
    x.has_airspeed = 1.0 if math.isfinite(airspeed) else 0.0
    x.airspeed_mps = airspeed
    z = baro_alt_m
    if not math.isfinite(z):
        return
    z -= c.h0_m
    if x.v_init == 0.0:
        x.pending_baro_m = z  # used to initialise the offset at the first fix
        x.has_pending_baro = 1.0
        if x.has_fix != 0.0 and c.baro_primary != 0.0:
            init_vertical_from_baro(x, c, z)  # the first fix came before the first baro sample
        return
    c0 = x.pv00 + x.pv02
    c1 = x.pv01 + x.pv12
    c2 = x.pv02 + x.pv22
    v_correct(x, z - (x.up_m + x.baro_offset_m), c0 + c2 + c.r_baro, c0, c1, c2)


@jitable
def v_correct(x: Any, y: float, s: float, c0: float, c1: float, c2: float) -> None:
    """Scalar Kalman update of the vertical filter: innovation ``y``, its variance ``s``, ``(c0, c1, c2) = P H^T``."""
    if not s > 0.0:
        return
    k0, k1, k2 = c0 / s, c1 / s, c2 / s
    x.up_m += k0 * y
    x.v_up_mps += k1 * y
    x.baro_offset_m += k2 * y
    x.pv00 = x.pv00 - k0 * c0
    x.pv01 = x.pv01 - k0 * c1
    x.pv02 = x.pv02 - k0 * c2
    x.pv11 = x.pv11 - k1 * c1
    x.pv12 = x.pv12 - k1 * c2
    x.pv22 = x.pv22 - k2 * c2


@jitable
def v_update(x: Any, h0: float, h1: float, h2: float, z: float, r: float) -> None:
    """Scalar update of the vertical filter with the measurement ``z`` of variance ``r``, ``H = (h0, h1, h2)``."""
    P00, P01, P02, P11, P12, P22 = x.pv00, x.pv01, x.pv02, x.pv11, x.pv12, x.pv22
    c0 = P00 * h0 + P01 * h1 + P02 * h2
    c1 = P01 * h0 + P11 * h1 + P12 * h2
    c2 = P02 * h0 + P12 * h1 + P22 * h2
    s = h0 * c0 + h1 * c1 + h2 * c2 + r
    y = z - (h0 * x.up_m + h1 * x.v_up_mps + h2 * x.baro_offset_m)
    v_correct(x, y, s, c0, c1, c2)


@jitable
def init_vertical_from_baro(x: Any, c: Any, z: float) -> None:
    """Vertical state from a referenced barometer: up = baro - b with b ~ 0 (the baro drift); up and b correlated."""
    var_b = c.var_baro_drift
    x.baro_offset_m = 0.0
    x.up_m = z
    set_vertical_covariance(x, c.r_baro + var_b, 0.0, -var_b, c.r_vu, 0.0, var_b)
    x.v_init = 1.0


@jitable
def init_from_fix(x: Any, c: Any, e: float, n: float, u: float, f: Any, lag: float) -> None:
    """The state from the first fix ``f`` (a :data:`GPS_FIX` record) at ENU ``(e, n, u)``, ``lag`` s old."""
    x.has_fix = 1.0
    x.east_m, x.v_east_mps, x.a_east_mps2 = e, f.v_east_mps, 0.0
    x.north_m, x.v_north_mps, x.a_north_mps2 = n, f.v_north_mps, 0.0
    x.ph00, x.ph01, x.ph02, x.ph11, x.ph12, x.ph22 = c.r_p, 0.0, 0.0, c.r_v, 0.0, 4.0  # (2 m/s^2)^2: unknown accel.
    x.t_d_s = f.t_s
    set_horizon(x, f.t_s)
    x.up_m = u + f.v_up_mps * lag
    x.v_up_mps = f.v_up_mps
    if c.baro_primary != 0.0:
        # the barometer reads the true altitude up to its drift: it sets the height, b ~ 0
        if x.has_pending_baro != 0.0:
            init_vertical_from_baro(x, c, x.pending_baro_m)
        return
    if x.has_pending_baro != 0.0:
        x.baro_offset_m = x.pending_baro_m - x.up_m
        var_b = c.r_pu + c.r_baro
    else:
        x.baro_offset_m = 0.0
        var_b = c.var_baro_drift + c.var_bias_v + 100.0
    set_vertical_covariance(x, c.r_pu, 0.0, 0.0, c.r_vu, 0.0, var_b)
    x.v_init = 1.0


@jitable
def set_horizon(x: Any, t_m: float) -> None:
    x.horizon_t_s, x.horizon_east_m, x.horizon_north_m = t_m, x.east_m, x.north_m
    x.horizon_v_east_mps, x.horizon_v_north_mps = x.v_east_mps, x.v_north_mps
    x.horizon_new = 1.0


@jitable
def update_gps(x: Any, c: Any, f: Any) -> None:
    """Fuse one GNSS message ``f`` (a :data:`GPS_FIX` record; its ``t_s`` is the time of validity, its arrival the
    current time): the horizon predicted to its time and updated there, the vertical filter at the current time
    (first-order latency compensation)."""
    if f.valid == 0.0:
        return
    t_m, lat, lon, alt = f.t_s, f.lat_deg, f.lon_deg, f.alt_m
    finite = (
        math.isfinite(t_m) and math.isfinite(lat) and math.isfinite(lon) and math.isfinite(alt)
        and math.isfinite(f.v_east_mps) and math.isfinite(f.v_north_mps) and math.isfinite(f.v_up_mps)
    )  # fmt: skip
    if not finite or abs(lat) > 90.0:
        x.fixes_rejected += 1.0
        return
    e, n, u = enu_of(c.enu_table, lat, lon, alt)
    lag = x.t_s - t_m
    if lag < 0.0:
        lag = 0.0
    if x.has_fix == 0.0:
        init_from_fix(x, c, e, n, u, f, lag)
    elif t_m <= x.t_d_s and x.flow_aided == 0.0:  # stale or duplicate
        x.fixes_rejected += 1.0
        return
    else:  # (after flow: the horizon moves back to the fix's time, extrapolated from there again)
        x.flow_aided = 0.0
        fuse_horizontal(x, c, t_m, e, n, f.v_east_mps, f.v_north_mps)
        q = c.q_accel_v
        if c.baro_primary == 0.0:
            v_update(x, 1.0, -lag, 0.0, u, c.r_pu + q * lag * lag * lag / 3.0)
        v_update(x, 0.0, 1.0, 0.0, f.v_up_mps, c.r_vu + q * lag)
    x.last_fix_arrival_s = x.t_s
    x.fixes_used += 1.0


@jitable
def fuse_horizontal(x: Any, c: Any, t_m: float, e: float, n: float, ve: float, vn: float) -> None:
    """The horizon predicted to ``t_m`` and updated with the position ``(e, n)``, then the velocity ``(ve, vn)``:
    scalar updates whose gain serves both axes (their covariances are equal)."""
    dt = t_m - x.t_d_s
    if dt > 0.0:  # constant-acceleration extrapolation
        h = 0.5 * dt * dt
        x.east_m += x.v_east_mps * dt + x.a_east_mps2 * h
        x.v_east_mps += x.a_east_mps2 * dt
        x.north_m += x.v_north_mps * dt + x.a_north_mps2 * h
        x.v_north_mps += x.a_north_mps2 * dt
        covariance_predict(x, dt, c.q_jerk_h, c.q_wander_h)
    x.t_d_s = t_m
    ye, yn = e - x.east_m, n - x.north_m
    correct(x, ye, yn, covariance_update(x, x.ph00 + c.r_p, x.ph00, x.ph01, x.ph02))  # H = [1, 0, 0]
    ye, yn = ve - x.v_east_mps, vn - x.v_north_mps
    correct(x, ye, yn, covariance_update(x, x.ph11 + c.r_v, x.ph01, x.ph11, x.ph12))  # H = [0, 1, 0]
    set_horizon(x, t_m)


@jitable
def covariance_predict(x: Any, dt: float, qj: float, qp: float) -> None:
    """``F P F^T + Q`` of each horizontal axis, ``F = [[1, dt, h], [0, 1, dt], [0, 0, 1]]``, Q the white jerk ``qj``
    plus the position wander ``qp``."""
    h = 0.5 * dt * dt
    P00, P01, P02, P11, P12, P22 = x.ph00, x.ph01, x.ph02, x.ph11, x.ph12, x.ph22
    r00, r01, r02 = P00 + dt * P01 + h * P02, P01 + dt * P11 + h * P12, P02 + dt * P12 + h * P22  # row 0 of F P
    r10, r11, r12 = P01 + dt * P02, P11 + dt * P12, P12 + dt * P22  # row 1 of F P
    d2, d3 = dt * dt, dt * dt * dt
    x.ph00 = r00 + dt * r01 + h * r02 + qj * d3 * d2 / 20.0 + qp * dt
    x.ph01 = r10 + dt * r11 + h * r12 + qj * d2 * d2 / 8.0
    x.ph02 = r02 + qj * d3 / 6.0
    x.ph11 = r11 + dt * r12 + qj * d3 / 3.0
    x.ph12 = r12 + qj * d2 / 2.0
    x.ph22 = P22 + qj * dt


@jitable
def covariance_update(x: Any, s: float, c0: float, c1: float, c2: float) -> tuple[float, float, float]:
    """Scalar Kalman update of each horizontal axis's covariance: innovation variance ``s``, ``(c0, c1, c2) =
    P H^T``; returns the gain."""
    k0, k1, k2 = c0 / s, c1 / s, c2 / s
    x.ph00 -= k0 * c0
    x.ph01 -= k0 * c1
    x.ph02 -= k0 * c2
    x.ph11 -= k1 * c1
    x.ph12 -= k1 * c2
    x.ph22 -= k2 * c2
    return (k0, k1, k2)


@jitable
def correct(x: Any, y_e: float, y_n: float, k: tuple[float, float, float]) -> None:
    """Both axes' scalar correction with their innovations and the shared gain ``k``."""
    k0, k1, k2 = k
    x.east_m += k0 * y_e
    x.v_east_mps += k1 * y_e
    x.a_east_mps2 += k2 * y_e
    x.north_m += k0 * y_n
    x.v_north_mps += k1 * y_n
    x.a_north_mps2 += k2 * y_n


@jitable
def output(x: Any, c: Any) -> tuple[float, ...]:
    """The estimate at the current time: the horizon extrapolated with its covariance (``g P g^T + Q``, ``g = (1, d,
    h)``, the same for both axes), the vertical filter, the attitude, the true airspeed (indicated converted at the
    estimated altitude; the ground speed without a pitot); the validity and sigmas set in ``x``."""
    now = x.t_s
    x.position_valid = 1.0 if (now - x.last_fix_arrival_s) <= c.timeout_s else 0.0
    r_, p_, y_ = x.roll_rad, x.pitch_rad, x.yaw_rad
    if x.has_fix == 0.0:
        x.sigma_h_m = math.inf
        x.sigma_v_m = math.inf
        return (now, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, r_, p_, y_, 0.0)
    d = now - x.t_d_s
    if d < 0.0:
        d = 0.0
    h = 0.5 * d * d
    e = x.east_m + x.v_east_mps * d + x.a_east_mps2 * h
    n = x.north_m + x.v_north_mps * d + x.a_north_mps2 * h
    ve = x.v_east_mps + x.a_east_mps2 * d
    vn = x.v_north_mps + x.a_north_mps2 * d
    qd = c.q_jerk_h * d * d * d * d * d / 20.0 + c.q_wander_h * d
    var = x.ph00 + 2.0 * d * x.ph01 + 2.0 * h * x.ph02 + d * d * x.ph11 + 2.0 * d * h * x.ph12 + h * h * x.ph22 + qd
    x.var_h_m2 = var
    x.sigma_h_m = math.sqrt(var + c.var_bias_h)
    x.sigma_v_m = math.sqrt(x.pv00 + c.var_bias_v)
    u = x.up_m
    curv = (e * e + n * n) * c.inv_2r_per_m
    alt = c.h0_m + u + curv
    if x.has_airspeed != 0.0:  # indicated -> true airspeed at the estimated altitude
        a = x.airspeed_mps / math.sqrt(isa_density_ratio(alt))
    else:
        a = math.sqrt(ve * ve + vn * vn)
    return (
        now, c.lat0_deg + n * c.deg_per_m_n, c.lon0_deg + e * c.deg_per_m_e, alt, e, n, u, u + curv, ve, vn,
        x.v_up_mps, r_, p_, y_, a,
    )  # fmt: skip


class GeofenceEstimator:
    """GNSS/baro/AHRS state estimator of the geofence unit (see the module docstring): a façade over its record.

    Per outer-loop step::

        est = estimator.step(dt_s, fix, air, att)   # fix may be None; air/att may be None
        estimator.position_valid, estimator.sigma_h_m, estimator.sigma_v_m

    The estimator's clock advances by ``dt_s`` and is re-synchronised to the
    sensor time stamps (``air.t_s`` or ``att.t_s``) when they are given. The step
    is :func:`estimator_step`, the one implementation.

    ``memory``: a float64 array of :data:`MEMORY_SIZE` slots to live in (a caller's compiled step that packs its
    states into one array passes its slice: the façade then reads what the step writes); a fresh array when
    omitted. The state and constants are (re)initialised in it.
    """

    def __init__(self, frame: LocalFrame, config: EstimatorConfig | None = None, memory: np.ndarray | None = None) -> None:
        self.frame = frame
        self.config = cfg = config or EstimatorConfig()
        if memory is None:
            memory = np.zeros(MEMORY_SIZE)
        if memory.shape != (MEMORY_SIZE,) or memory.dtype != np.float64 or not memory.flags.c_contiguous:
            raise ValueError(f"GeofenceEstimator memory: expected {MEMORY_SIZE} contiguous float64 slots")
        self.memory = memory
        self._X, self._K = memory[:STATE_SIZE], memory[STATE_SIZE:]
        self._state = self._X.view(EST_STATE)[0]
        estimator_constants(self._K, frame, cfg)
        estimator_reset(self._X)
        self._fix = np.zeros(FIX_SIZE)
        self.state = VehicleState()
        """The newest estimate (:meth:`step`'s answer)."""

    def step(
        self, dt_s: float, fix: GpsFix | None = None, air: AirData | None = None, att: AttitudeSample | None = None,
        rf: RangeFlowSample | None = None,
    ) -> VehicleState:  # fmt: skip
        """Predict by ``dt_s``, fuse whatever arrived this step (``rf``: a rangefinder and flow sample), and return
        the current estimate."""
        nan = math.nan
        if air is not None:
            t_air, baro = air.t_s, air.baro_alt_m
            airspeed = nan if air.airspeed_mps is None else air.airspeed_mps
        else:  # no air data: the last pitot reading stands
            t_air, baro = (att.t_s if att is not None else nan), nan
            airspeed = float(self._state.airspeed_mps) if self._state.has_airspeed != 0.0 else nan
        roll, pitch, yaw = (att.roll_rad, att.pitch_rad, att.yaw_rad) if att is not None else (nan, nan, nan)
        if fix is not None:
            self._fix[:] = fix
        fields: Any = estimator_step(
            self._X, self._K, float(dt_s), fix is not None, self._fix, float(t_air), float(airspeed), float(baro),
            float(roll), float(pitch), float(yaw), *((nan, nan, nan) if rf is None else rf[1:4]),
        )  # fmt: skip
        self.state = VehicleState(*fields)
        return self.state

    @property
    def t_s(self) -> float:
        """The estimator's clock, s."""
        return float(self._state.t_s)

    @property
    def position_valid(self) -> bool:
        """A valid fix arrived within ``timeout_s`` (as of the last step)."""
        return bool(self._state.position_valid != 0.0)

    @property
    def sigma_h_m(self) -> float:
        """Horizontal position 1-sigma per axis, the GNSS bias included (inf before the first fix)."""
        return float(self._state.sigma_h_m)

    @property
    def sigma_v_m(self) -> float:
        """Vertical position 1-sigma, the GNSS height bias included unless the barometer is the reference."""
        return float(self._state.sigma_v_m)

    @property
    def var_e_m2(self) -> float:
        """The filter's east position variance (the bias left out), m²; the north one is the same."""
        return float(self._state.var_h_m2)

    var_n_m2 = var_e_m2

    @property
    def fixes_used(self) -> int:
        return int(self._state.fixes_used)

    @property
    def fixes_rejected(self) -> int:
        return int(self._state.fixes_rejected)

    @property
    def data_age_s(self) -> float:
        """Age (s) of the newest fused GNSS data: now minus its time of validity.

        The horizontal estimate is that data extrapolated over this age; an
        acceleration that started within it is not yet in the estimate, so the
        geofence adds it to its reaction time (up to latency + one GNSS period).
        """
        x = self._state
        return max(float(x.t_s - x.t_d_s), 0.0) if x.has_fix != 0.0 else 0.0

    @property
    def flow_aided(self) -> bool:
        """The horizontal state is carried forward on optical-flow velocity (no fix since the flow took over)."""
        return bool(self._state.flow_aided != 0.0)

    @property
    def baro_offset_m(self) -> float:
        """Estimated baro offset (baro altitude - origin height - up) in m."""
        return float(self._state.baro_offset_m)

    def horizon_state(self) -> FixState | None:
        """The fused horizontal state at the newest fix's time of validity (None before the first fix)."""
        x = self._state
        if x.has_fix == 0.0:
            return None
        return FixState(*(float(v) for v in self._X[HORIZON_FIELDS]))

    @property
    def accel_en_mps2(self) -> tuple[float, float]:
        """Estimated horizontal acceleration (east, north) at the fusion horizon, m/s^2."""
        x = self._state
        return (float(x.a_east_mps2), float(x.a_north_mps2)) if x.has_fix != 0.0 else (0.0, 0.0)


def _slot(name: str) -> int:
    """The float slot of an :data:`EST_STATE` field."""
    fields = EST_STATE.fields
    assert fields is not None
    return int(fields[name][1]) // 8


HORIZON_FIELDS = slice(_slot("horizon_t_s"), _slot("horizon_v_north_mps") + 1)
"""The fusion horizon's slots in :data:`EST_STATE`, in :class:`FixState`'s order (read as one slice)."""
if HORIZON_FIELDS.stop - HORIZON_FIELDS.start != len(FixState._fields):
    raise ImportError("the estimator's horizon fields are no longer FixState's: update HORIZON_FIELDS")
