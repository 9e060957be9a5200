"""The geofence unit's estimate of the current steady (average) wind, from its own state estimate.

Conventions as in :mod:`wind.field`: ENU m/s, the direction the air moves
**toward**. Only the horizontal wind is estimated.

Fixed-wing (a pitot airspeed is given)
    Each step the instantaneous wind is the ground velocity minus the
    air-relative velocity, taken along the heading (small sideslip assumed):
    ``w = v_ground - V_h * (sin yaw, cos yaw)``, with the horizontal airspeed
    ``V_h = sqrt(V_a^2 - v_up^2)`` (still air vertically). Heading and airspeed
    errors average out over turns; a first-order low-pass (``tau_s``, default
    20 s) keeps the steady part and rejects turbulence.

Multirotor (no airspeed sensor)
    In steady flight the horizontal component of the thrust balances the
    drag, so the air-relative velocity points along the tilt and its size
    follows from the drag law. With ``f = g * |horizontal thrust direction| /
    vertical component`` (= ``g tan(tilt)``) and drag ``c1 v + c2 v^2 = f``, we
    get ``v_air`` from the root of that quadratic. By default the drag is
    quadratic (``c1 = 0``) and calibrated from the envelope: the platform's
    ``max_speed_mps`` is reached in still air at ``max_bank_rad``
    (``c2 = g tan(max_tilt) / max_speed^2``). The F450 profile's envelope
    notes (15.7 m/s at 10 deg tilt, 28.7 m/s at 30 deg) fit the quadratic law
    within 2 %. Only quasi-steady samples are used: the estimated horizontal
    acceleration must be below ``max_accel_mps2`` (default 1 m/s^2, the
    velocity's change over the last ``accel_window_s`` from the estimate).
    Limitation: near hover ``v ~ sqrt(tilt)`` is steep, so AHRS tilt errors
    (0.5 deg -> ~3.5 m/s for the F450) map into the wind estimate; they
    average out only if they are not biased. Use a pitot-less estimate with
    that in mind (``sigma_mps`` stays at least ``multirotor_floor_mps``).

Prior and convergence
    Until enough samples have been seen, the estimate leans on the configured
    prior (e.g. a forecast) with its stated uncertainty: the filter starts at
    the prior and its gain is ``dt / min(tau, prior_weight_s + t_used)``, i.e.
    a growing-memory average in which the prior counts as ``prior_weight_s``
    seconds of data, turning into the fixed ``tau`` low-pass once ``t_used``
    (the time of accepted samples) exceeds ``tau - prior_weight_s``.
    ``converged`` becomes True after ``tau`` seconds of accepted samples.
    ``sigma_mps`` is a rough 1-sigma: the prior's sigma shrinking with the
    accepted time, down to a floor.

Per-step cost is a few plain-float operations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from geofence.interface import Envelope, VehicleState

G_MPS2 = 9.80665


@dataclass(frozen=True)
class WindEstimatorConfig:
    """Tuning of :class:`WindEstimator` (SI)."""

    tau_s: float = 20.0
    prior_enu: tuple[float, float] = (0.0, 0.0)
    prior_sigma_mps: float = 5.0
    prior_weight_s: float = 2.0
    min_airspeed_mps: float = 3.0
    max_bank_rad: float = math.radians(60.0)
    max_accel_mps2: float = 1.0
    accel_window_s: float = 0.5
    min_agl_m: float = 1.0
    drag_c1_per_s: float | None = None  # multirotor linear drag (1/s); None: 0
    drag_c2_per_m: float | None = None  # multirotor quadratic drag (1/m); None: from the envelope
    fixed_wing_floor_mps: float = 0.5
    multirotor_floor_mps: float = 1.5

    def __post_init__(self) -> None:
        for name in ("tau_s", "prior_weight_s", "accel_window_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"wind_estimator.{name}: must be a finite number > 0, got {v!r}")
        if len(self.prior_enu) != 2 or not all(math.isfinite(x) for x in self.prior_enu):
            raise ValueError(f"wind_estimator.prior_enu: expected two finite numbers, got {self.prior_enu!r}")


class WindEstimator:
    """Steady-wind estimate of the geofence unit (see the module docstring).

    ``update(est, airspeed_mps, dt_s)`` once per outer-loop step with the
    estimator's state and the pitot airspeed (None for a multirotor); returns
    ``(wind_east_mps, wind_north_mps)``, also available as :attr:`wind_enu`.
    """

    def __init__(self, envelope: Envelope | None = None, config: WindEstimatorConfig | None = None) -> None:
        self.config = cfg = config or WindEstimatorConfig()
        self._we, self._wn = float(cfg.prior_enu[0]), float(cfg.prior_enu[1])
        self.t_used_s = 0.0
        c2 = cfg.drag_c2_per_m
        if c2 is None and envelope is not None and envelope.max_speed_mps > 0.0 and envelope.max_bank_rad > 0.0:
            c2 = G_MPS2 * math.tan(envelope.max_bank_rad) / envelope.max_speed_mps**2
        self._c1 = cfg.drag_c1_per_s or 0.0
        self._c2 = c2 or 0.0
        # short history of the ground velocity (for the quasi-steady gate of the multirotor model)
        self._hist: list[tuple[float, float, float]] = []
        self._t = 0.0
        self.last_sample: tuple[float, float] | None = None
        self._last_kind_mr = False

    @property
    def wind_enu(self) -> tuple[float, float]:
        """Current estimate (east, north) in m/s, toward."""
        return (self._we, self._wn)

    @property
    def converged(self) -> bool:
        return self.t_used_s >= self.config.tau_s

    @property
    def sigma_mps(self) -> float:
        cfg = self.config
        floor = cfg.multirotor_floor_mps if self._last_kind_mr else cfg.fixed_wing_floor_mps
        s = cfg.prior_sigma_mps * math.sqrt(cfg.prior_weight_s / (cfg.prior_weight_s + self.t_used_s))
        return max(s, floor)

    def update(self, est: VehicleState, airspeed_mps: float | None, dt_s: float, position_valid: bool = True) -> tuple[float, float]:
        cfg = self.config
        if not (dt_s > 0.0) or not math.isfinite(dt_s):
            return (self._we, self._wn)
        self._t += dt_s
        sample = None
        if position_valid and est.agl_m >= cfg.min_agl_m:
            if airspeed_mps is not None:
                sample = self._fixed_wing_sample(est, airspeed_mps)
            else:
                self._last_kind_mr = True
                sample = self._multirotor_sample(est)
        self.last_sample = sample
        if sample is not None:
            we, wn = sample
            if math.isfinite(we) and math.isfinite(wn):
                memory = min(cfg.tau_s, cfg.prior_weight_s + self.t_used_s)
                k = dt_s / (memory + dt_s)
                self._we += k * (we - self._we)
                self._wn += k * (wn - self._wn)
                self.t_used_s += dt_s
        return (self._we, self._wn)

    def _fixed_wing_sample(self, s: VehicleState, va: float) -> tuple[float, float] | None:
        cfg = self.config
        if not math.isfinite(va) or va < cfg.min_airspeed_mps or abs(s.roll_rad) > cfg.max_bank_rad:
            return None
        vu = s.v_up_mps
        vh2 = va * va - vu * vu
        vh = math.sqrt(vh2) if vh2 > 0.0 else 0.0
        y = s.yaw_rad
        return (s.v_east_mps - vh * math.sin(y), s.v_north_mps - vh * math.cos(y))

    def _multirotor_sample(self, s: VehicleState) -> tuple[float, float] | None:
        cfg = self.config
        # quasi-steady gate: horizontal acceleration over the last accel_window_s
        h = self._hist
        h.append((self._t, s.v_east_mps, s.v_north_mps))
        while len(h) > 2 and h[1][0] <= self._t - cfg.accel_window_s:
            h.pop(0)
        t0, ve0, vn0 = h[0]
        span = self._t - t0
        if span < 0.5 * cfg.accel_window_s:
            return None
        ae, an = (s.v_east_mps - ve0) / span, (s.v_north_mps - vn0) / span
        if ae * ae + an * an > cfg.max_accel_mps2**2 or self._c2 <= 0.0 and self._c1 <= 0.0:
            return None
        # horizontal direction of the thrust (body -z) in ENU, and the vertical component
        cr, sr = math.cos(s.roll_rad), math.sin(s.roll_rad)
        cp, sp = math.cos(s.pitch_rad), math.sin(s.pitch_rad)
        cy, sy = math.cos(s.yaw_rad), math.sin(s.yaw_rad)
        t_n = -(cy * sp * cr + sy * sr)
        t_e = -(sy * sp * cr - cy * sr)
        t_up = cp * cr
        if t_up < 0.2:
            return None
        f = G_MPS2 * math.hypot(t_e, t_n) / t_up  # = g tan(tilt): drag per unit mass in steady flight
        c1, c2 = self._c1, self._c2
        if c2 > 0.0:
            v_air = (-c1 + math.sqrt(c1 * c1 + 4.0 * c2 * f)) / (2.0 * c2)
        else:
            v_air = f / c1
        norm = math.hypot(t_e, t_n)
        if norm < 1e-9:
            return (s.v_east_mps, s.v_north_mps)
        ue, un = t_e / norm, t_n / norm
        return (s.v_east_mps - v_air * ue, s.v_north_mps - v_air * un)
