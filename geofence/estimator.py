"""The geofence unit's own state estimator: GNSS + baro + AHRS -> a :class:`VehicleState` estimate.

The unit must not trust the autopilot's navigation, so it runs its own small
linear Kalman filter on its own sensors (:mod:`geofence.measurements`).

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
    (:func:`geofence.dynamics.isa_density_ratio`), or the ground speed
    without a pitot.

Everything per step is plain Python floats (no numpy); see the tests for the
measured cost (a few microseconds).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from geofence.dynamics import isa_density_ratio
from geofence.geodesy import LocalFrame, radii_of_curvature_m
from geofence.interface import FixState, VehicleState
from geofence.measurements import AirData, AttitudeSample, GpsFix


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


class _Axis:
    """One horizontal axis's state (p, v, a); its covariance is the :class:`_AxisCovariance` both axes share."""

    __slots__ = ("p", "v", "a")

    def __init__(self, p: float, v: float) -> None:
        self.p, self.v, self.a = p, v, 0.0

    def predict(self, dt: float) -> None:
        """Constant-acceleration extrapolation over ``dt``."""
        if dt <= 0.0:
            return
        h = 0.5 * dt * dt
        self.p += self.v * dt + self.a * h
        self.v += self.a * dt

    def correct(self, y: float, k: tuple[float, float, float]) -> None:
        """Scalar Kalman correction with the innovation ``y`` and the gain ``k``."""
        k0, k1, k2 = k
        self.p += k0 * y
        self.v += k1 * y
        self.a += k2 * y


class _AxisCovariance:
    """Covariance of one horizontal axis's (p, v, a), symmetric, stored as 6 floats.

    East and north have the same model, process noise and measurement noise, and a covariance does not
    depend on the measured values, so the two axes' covariances are equal at all times: one instance serves
    both, and each update's gain is computed once for both (an axis-specific noise would need one each).
    """

    __slots__ = ("P00", "P01", "P02", "P11", "P12", "P22")

    def __init__(self, var_p: float, var_v: float, var_a: float) -> None:
        self.P00, self.P01, self.P02, self.P11, self.P12, self.P22 = var_p, 0.0, 0.0, var_v, 0.0, var_a

    def predict(self, dt: float, qj: float, qp: float) -> None:
        if dt <= 0.0:
            return
        h = 0.5 * dt * dt
        P00, P01, P02, P11, P12, P22 = self.P00, self.P01, self.P02, self.P11, self.P12, self.P22
        # F = [[1, dt, h], [0, 1, dt], [0, 0, 1]];  F P F^T + Q (white jerk) + position wander
        r00, r01, r02 = P00 + dt * P01 + h * P02, P01 + dt * P11 + h * P12, P02 + dt * P12 + h * P22  # row 0 of F P
        r10, r11, r12 = P01 + dt * P02, P11 + dt * P12, P12 + dt * P22  # row 1 of F P
        d2, d3 = dt * dt, dt * dt * dt
        self.P00 = r00 + dt * r01 + h * r02 + qj * d3 * d2 / 20.0 + qp * dt
        self.P01 = r10 + dt * r11 + h * r12 + qj * d2 * d2 / 8.0
        self.P02 = r02 + qj * d3 / 6.0
        self.P11 = r11 + dt * r12 + qj * d3 / 3.0
        self.P12 = r12 + qj * d2 / 2.0
        self.P22 = P22 + qj * dt

    def update_p(self, r: float) -> tuple[float, float, float]:
        """Scalar update with a position measurement of variance ``r`` (H = [1, 0, 0]); returns the gain."""
        return self._update(self.P00 + r, self.P00, self.P01, self.P02)

    def update_v(self, r: float) -> tuple[float, float, float]:
        """Scalar update with a velocity measurement of variance ``r`` (H = [0, 1, 0]); returns the gain."""
        return self._update(self.P11 + r, self.P01, self.P11, self.P12)

    def _update(self, s: float, c0: float, c1: float, c2: float) -> tuple[float, float, float]:
        """Scalar Kalman update of P: innovation variance ``s``, ``(c0, c1, c2) = P H^T``; returns the gain."""
        k0, k1, k2 = c0 / s, c1 / s, c2 / s
        self.P00 -= k0 * c0
        self.P01 -= k0 * c1
        self.P02 -= k0 * c2
        self.P11 -= k1 * c1
        self.P12 -= k1 * c2
        self.P22 -= k2 * c2
        return (k0, k1, k2)


class EstimatorConstants(NamedTuple):
    """The estimator's per-flight constants, derived once from its frame and tuning (SI; variances in m², (m/s)²)."""

    h0_m: float
    deg_per_m_n: float
    """Latitude per metre north at the origin (deg/m), from the meridian radius."""
    deg_per_m_e: float
    """Longitude per metre east at the origin (deg/m), from the prime-vertical radius."""
    inv_2r_per_m: float
    """``1 / 2R`` of the Earth-curvature drop ``(e² + n²) / 2R`` (R the Gaussian mean radius at the origin)."""
    q_jerk_h: float
    q_wander_h: float
    """The GNSS bias wander as horizontal position process noise, ``2 σ² / τ``."""
    q_accel_v: float
    baro_primary: bool
    """A referenced barometer drifting less than the GNSS height is biased: it is the height reference."""
    q_baro: float
    r_p: float
    r_v: float
    r_pu: float
    r_vu: float
    r_baro: float
    var_bias_h: float
    var_bias_v: float
    var_baro_drift: float


def estimator_constants(frame: LocalFrame, cfg: EstimatorConfig) -> EstimatorConstants:
    """:class:`EstimatorConstants` of an estimator in ``frame`` tuned by ``cfg`` (the one home of these formulas)."""
    lat0 = math.radians(frame.lat0_deg)
    n_rad, m_rad = radii_of_curvature_m(lat0)
    baro_primary = cfg.baro_referenced and cfg.baro_drift_m < cfg.gps_v_bias_m
    q_baro = 2.0 * cfg.baro_drift_m**2 / cfg.baro_drift_tau_s
    if not baro_primary:  # the offset also absorbs the wander of the GNSS height it is tied to
        q_baro += 2.0 * cfg.gps_v_bias_m**2 / cfg.gps_bias_tau_s
    return EstimatorConstants(
        h0_m=frame.h0_m,
        deg_per_m_n=math.degrees(1.0) / (m_rad + frame.h0_m),
        deg_per_m_e=math.degrees(1.0) / ((n_rad + frame.h0_m) * math.cos(lat0)),
        inv_2r_per_m=0.5 / math.sqrt(m_rad * n_rad),
        q_jerk_h=cfg.jerk_psd_h,
        q_wander_h=2.0 * cfg.gps_h_bias_m**2 / cfg.gps_bias_tau_s,
        q_accel_v=cfg.accel_psd_v,
        baro_primary=baro_primary,
        q_baro=q_baro,
        r_p=cfg.gps_h_white_m**2,
        r_v=cfg.gps_vel_h_mps**2,
        r_pu=cfg.gps_v_white_m**2,
        r_vu=cfg.gps_vel_v_mps**2,
        r_baro=cfg.baro_noise_m**2,
        var_bias_h=cfg.gps_h_bias_m**2,
        var_bias_v=0.0 if baro_primary else cfg.gps_v_bias_m**2,
        var_baro_drift=cfg.baro_drift_m**2,
    )


class GeofenceEstimator:
    """GNSS/baro/AHRS state estimator of the geofence unit (see the module docstring).

    Per outer-loop step::

        est = estimator.step(dt_s, fix, air, att)   # fix may be None; air/att may be None
        estimator.position_valid, estimator.sigma_h_m, estimator.sigma_v_m

    The estimator's clock advances by ``dt_s`` and is re-synchronised to the
    sensor time stamps (``air.t_s`` or ``att.t_s``) when they are given.
    """

    def __init__(self, frame: LocalFrame, config: EstimatorConfig | None = None) -> None:
        self.frame = frame
        self.config = cfg = config or EstimatorConfig()
        self.t_s = 0.0
        self._clock_set = False
        k = estimator_constants(frame, cfg)
        self._h0 = k.h0_m
        self._deg_per_m_n, self._deg_per_m_e, self._inv_2r = k.deg_per_m_n, k.deg_per_m_e, k.inv_2r_per_m
        self._lat0_deg, self._lon0_deg = frame.lat0_deg, frame.lon0_deg
        self._timeout_s = cfg.timeout_s
        self._qj, self._qp_h, self._qv, self._qb = k.q_jerk_h, k.q_wander_h, k.q_accel_v, k.q_baro
        self._baro_primary = k.baro_primary
        self._r_p, self._r_v, self._r_pu, self._r_vu, self._r_baro = k.r_p, k.r_v, k.r_pu, k.r_vu, k.r_baro
        self._var_bias_h, self._var_bias_v, self._var_baro_drift = k.var_bias_h, k.var_bias_v, k.var_baro_drift
        # horizontal (delayed horizon at t_d)
        self._east: _Axis | None = None
        self._north: _Axis | None = None
        self._P_h: _AxisCovariance | None = None  # the covariance of each axis (the same for both)
        self._t_d = 0.0
        self._horizon: FixState | None = None  # the fused state at t_d, rebuilt when a fix is fused
        # vertical (current time): up, v_up, baro offset b
        self._u = self._vu = self._b = 0.0
        self._V = (0.0,) * 6  # P00 P01 P02 P11 P12 P22 (a tuple, replaced as a whole by each predict/update)
        self._vq_dt = math.nan  # the dt of the cached vertical prediction coefficients (nan: none yet)
        self._vq = (0.0,) * 6
        self._v_init = False
        self._pending_baro: float | None = None
        # bookkeeping
        self._last_fix_arrival_s = -math.inf
        self.fixes_used = 0
        self.fixes_rejected = 0
        self._att = (0.0, 0.0, 0.0)
        self._airspeed: float | None = None
        self.position_valid = False
        self.sigma_h_m = math.inf
        self.sigma_v_m = math.inf
        self.var_e_m2 = self.var_n_m2 = math.inf
        self.state = VehicleState()

    # -- public per-step entry point ------------------------------------------------
    def step(
        self,
        dt_s: float,
        fix: GpsFix | None = None,
        air: AirData | None = None,
        att: AttitudeSample | None = None,
    ) -> VehicleState:
        """Predict by ``dt_s``, fuse whatever arrived this step, and return the current estimate."""
        self.predict(dt_s)
        stamp = air.t_s if air is not None else (att.t_s if att is not None else None)
        if stamp is not None and math.isfinite(stamp):
            if not self._clock_set or stamp >= self.t_s - 1.0:
                self.t_s = stamp
                self._clock_set = True
        if att is not None:
            self.update_attitude(att)
        if fix is not None:
            self.update_gps(fix)
        if air is not None:
            self.update_air(air)
        return self.output()

    def predict(self, dt_s: float) -> None:
        """Advance the estimator clock and the vertical filter by ``dt_s`` (horizontal: extrapolated at output)."""
        if not (dt_s > 0.0) or not math.isfinite(dt_s):
            return
        self.t_s += dt_s
        if not self._v_init:
            return
        dt = dt_s
        if dt != self._vq_dt:  # the outer loop's dt is constant: its coefficients are computed once
            self._vq_dt = dt
            self._vq = self._vertical_coefficients(dt)
        two_dt, dt2, q_uu, q_uv, q_vv, q_bb = self._vq
        P00, P01, P02, P11, P12, P22 = self._V
        self._u += self._vu * dt
        # F = [[1, dt, 0], [0, 1, 0], [0, 0, 1]];  F P F^T + Q
        self._V = (
            P00 + two_dt * P01 + dt2 * P11 + q_uu,
            P01 + dt * P11 + q_uv,
            P02 + dt * P12,
            P11 + q_vv,
            P12,
            P22 + q_bb,
        )

    def _vertical_coefficients(self, dt: float) -> tuple[float, float, float, float, float, float]:
        """``(2 dt, dt^2, Q_uu, Q_uv, Q_vv, Q_bb)`` of the vertical prediction over ``dt``.

        Q is the white-acceleration noise (``q dt^3/3``, ``q dt^2/2``, ``q dt``) plus the baro offset's wander.
        """
        q = self._qv
        return (2.0 * dt, dt * dt, q * dt * dt * dt / 3.0, 0.5 * q * dt * dt, q * dt, self._qb * dt)

    def update_attitude(self, att: AttitudeSample) -> None:
        r, p, y = att.roll_rad, att.pitch_rad, att.yaw_rad
        if math.isfinite(r) and math.isfinite(p) and math.isfinite(y):
            self._att = (r, p, y)

    def update_air(self, air: AirData) -> None:
        """Baro altitude (every step) and pitot airspeed."""
        a = air.airspeed_mps
        self._airspeed = a if (a is not None and math.isfinite(a)) else None
        z = air.baro_alt_m
        if not math.isfinite(z):
            return
        z -= self._h0
        if not self._v_init:
            self._pending_baro = z  # used to initialise the offset at the first fix
            if self._east is not None and self._baro_primary:
                self._init_vertical_from_baro(z)  # the first fix came before the first baro sample
            return
        self._baro_update(z)

    def update_gps(self, fix: GpsFix) -> None:
        """Fuse one GNSS message (its ``t_s`` is the time of validity; arrival is the current time)."""
        if not fix.valid:
            return
        isfinite = math.isfinite
        finite = (
            isfinite(fix.t_s)
            and isfinite(fix.lat_deg)
            and isfinite(fix.lon_deg)
            and isfinite(fix.alt_m)
            and isfinite(fix.v_east_mps)
            and isfinite(fix.v_north_mps)
            and isfinite(fix.v_up_mps)
        )
        if not finite or abs(fix.lat_deg) > 90.0:
            self.fixes_rejected += 1
            return
        e, n, u = self.frame.to_enu(fix.lat_deg, fix.lon_deg, fix.alt_m)
        t_m = fix.t_s
        lag = self.t_s - t_m
        if lag < 0.0:
            lag = 0.0
        if self._east is None:
            self._init(e, n, u, fix, t_m, lag)
            self._last_fix_arrival_s = self.t_s
            self.fixes_used += 1
            return
        if t_m <= self._t_d:  # stale or duplicate
            self.fixes_rejected += 1
            return
        dt = t_m - self._t_d
        ex, nx, P = self._east, self._north, self._P_h
        if ex is None or nx is None or P is None:  # not reached: the first fix initialised the axes above
            return
        ex.predict(dt)
        nx.predict(dt)
        P.predict(dt, self._qj, self._qp_h)
        self._t_d = t_m
        # position, then velocity: each gain serves both axes (their covariances are equal)
        ye, yn = e - ex.p, n - nx.p
        k = P.update_p(self._r_p)
        ex.correct(ye, k)
        nx.correct(yn, k)
        ye, yn = fix.v_east_mps - ex.v, fix.v_north_mps - nx.v
        k = P.update_v(self._r_v)
        ex.correct(ye, k)
        nx.correct(yn, k)
        self._horizon = FixState(t_m, ex.p, nx.p, ex.v, nx.v)
        # vertical: current-time filter, first-order latency compensation
        q = self._qv
        if not self._baro_primary:
            self._v_update(1.0, -lag, 0.0, u, self._r_pu + q * lag * lag * lag / 3.0)
        self._v_update(0.0, 1.0, 0.0, fix.v_up_mps, self._r_vu + q * lag)
        self._last_fix_arrival_s = self.t_s
        self.fixes_used += 1

    @property
    def data_age_s(self) -> float:
        """Age (s) of the newest fused GNSS data: now minus its time of validity.

        The horizontal estimate is that data extrapolated over this age; an
        acceleration that started within it is not yet in the estimate, so the
        geofence adds it to its reaction time (up to latency + one GNSS period).
        """
        return max(self.t_s - self._t_d, 0.0) if self._east is not None else 0.0

    # -- output --------------------------------------------------------------------
    def output(self) -> VehicleState:
        """A new estimate at the current estimator time (also kept as ``self.state``)."""
        now = self.t_s
        self.position_valid = (now - self._last_fix_arrival_s) <= self._timeout_s
        ex, nx, P = self._east, self._north, self._P_h
        roll, pitch, yaw = self._att
        if ex is None or nx is None or P is None:
            self.sigma_h_m = self.sigma_v_m = math.inf
            self.state = VehicleState(t_s=now, roll_rad=roll, pitch_rad=pitch, yaw_rad=yaw)
            return self.state
        d = now - self._t_d
        if d < 0.0:
            d = 0.0
        h = 0.5 * d * d
        e = ex.p + ex.v * d + ex.a * h
        n = nx.p + nx.v * d + nx.a * h
        ve = ex.v + ex.a * d
        vn = nx.v + nx.a * d
        # position variance extrapolated from the horizon: g P g^T + Q, g = (1, d, h); the same for both axes
        qd = self._qj * d * d * d * d * d / 20.0 + self._qp_h * d
        var = P.P00 + 2.0 * d * P.P01 + 2.0 * h * P.P02 + d * d * P.P11 + 2.0 * d * h * P.P12 + h * h * P.P22 + qd
        self.var_e_m2 = self.var_n_m2 = var
        self.sigma_h_m = math.sqrt(var + self._var_bias_h)
        self.sigma_v_m = math.sqrt(self._V[0] + self._var_bias_v)
        u = self._u
        curv = (e * e + n * n) * self._inv_2r
        alt = self._h0 + u + curv
        a = self._airspeed
        if a is not None:  # indicated -> true airspeed at the estimated altitude
            a = a / math.sqrt(isa_density_ratio(alt))
        st = VehicleState(
            now,
            self._lat0_deg + n * self._deg_per_m_n,
            self._lon0_deg + e * self._deg_per_m_e,
            alt,
            e,
            n,
            u,
            u + curv,
            ve,
            vn,
            self._vu,
            roll,
            pitch,
            yaw,
            a if a is not None else math.sqrt(ve * ve + vn * vn),
            False,
        )
        self.state = st
        return st

    @property
    def baro_offset_m(self) -> float:
        """Estimated baro offset (baro altitude - origin height - up) in m."""
        return self._b

    def horizon_state(self) -> FixState | None:
        """The fused horizontal state at the newest fix's time of validity (None before the first fix)."""
        return self._horizon

    @property
    def accel_en_mps2(self) -> tuple[float, float]:
        """Estimated horizontal acceleration (east, north) at the fusion horizon, m/s^2."""
        ex, nx = self._east, self._north
        if ex is None or nx is None:
            return (0.0, 0.0)
        return (ex.a, nx.a)

    # -- internals -----------------------------------------------------------------
    def _init(self, e: float, n: float, u: float, fix: GpsFix, t_m: float, lag: float) -> None:
        var_a = 4.0  # (2 m/s^2)^2: unknown initial acceleration
        self._east = ex = _Axis(e, fix.v_east_mps)
        self._north = nx = _Axis(n, fix.v_north_mps)
        self._P_h = _AxisCovariance(self._r_p, self._r_v, var_a)
        self._t_d = t_m
        self._horizon = FixState(t_m, ex.p, nx.p, ex.v, nx.v)
        self._u = u + fix.v_up_mps * lag
        self._vu = fix.v_up_mps
        if self._baro_primary:
            # the barometer reads the true altitude up to its drift: it sets the height, b ~ 0
            if self._pending_baro is not None:
                self._init_vertical_from_baro(self._pending_baro)
            return
        if self._pending_baro is not None:
            self._b = self._pending_baro - self._u
            var_b = self._r_pu + self._r_baro
        else:
            self._b = 0.0
            var_b = self._var_baro_drift + self._var_bias_v + 100.0
        self._V = (self._r_pu, 0.0, 0.0, self._r_vu, 0.0, var_b)
        self._v_init = True

    def _init_vertical_from_baro(self, z: float) -> None:
        """Vertical state from a referenced barometer: up = baro - b with b ~ 0 (the baro drift)."""
        var_b = self._var_baro_drift
        self._b = 0.0
        self._u = z
        # up and b are correlated: up = z - b
        self._V = (self._r_baro + var_b, 0.0, -var_b, self._r_vu, 0.0, var_b)
        self._v_init = True

    def _v_update(self, h0: float, h1: float, h2: float, z: float, r: float) -> None:
        """Scalar update of the vertical filter with H = (h0, h1, h2)."""
        P00, P01, P02, P11, P12, P22 = self._V
        c0 = P00 * h0 + P01 * h1 + P02 * h2
        c1 = P01 * h0 + P11 * h1 + P12 * h2
        c2 = P02 * h0 + P12 * h1 + P22 * h2
        s = h0 * c0 + h1 * c1 + h2 * c2 + r
        y = z - (h0 * self._u + h1 * self._vu + h2 * self._b)
        self._v_correct(y, s, c0, c1, c2)

    def _baro_update(self, z: float) -> None:
        """Scalar update with the baro height ``z`` (above the origin): H = (1, 0, 1), every step.

        This is ``_v_update(1.0, 0.0, 1.0, z, r_baro)`` written out without its products by 1 and by 0: the
        dropped terms are exact zeros, so the numbers are the same, for a third of the operations.
        """
        P00, P01, P02, P11, P12, P22 = self._V
        c0 = P00 + P02
        c1 = P01 + P12
        c2 = P02 + P22
        self._v_correct(z - (self._u + self._b), c0 + c2 + self._r_baro, c0, c1, c2)

    def _v_correct(self, y: float, s: float, c0: float, c1: float, c2: float) -> None:
        """Scalar Kalman update of the vertical filter: innovation ``y``, its variance ``s``, ``(c0, c1, c2) = P H^T``."""
        if not s > 0.0:
            return
        P00, P01, P02, P11, P12, P22 = self._V
        k0, k1, k2 = c0 / s, c1 / s, c2 / s
        self._u += k0 * y
        self._vu += k1 * y
        self._b += k2 * y
        self._V = (P00 - k0 * c0, P01 - k0 * c1, P02 - k0 * c2, P11 - k1 * c1, P12 - k1 * c2, P22 - k2 * c2)
