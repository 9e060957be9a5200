"""The geofence unit's estimate of the current steady (average) wind, from its own state estimate.

Conventions as in :mod:`wind.field`: ENU m/s, the direction the air moves
**toward**. Only the horizontal wind is estimated.

Fixed-wing (a pitot airspeed is given)
    Each step the instantaneous wind is the ground velocity minus the
    air-relative velocity, taken along the heading (small sideslip assumed):
    ``w = v_ground - V_h * (sin yaw, cos yaw)``, with the horizontal true
    airspeed ``V_h = sqrt(V_t^2 - v_up^2)`` (still air vertically). The pitot
    reads the indicated airspeed (:mod:`aircraft.sensors`); it is converted to
    true airspeed with the unit's own altitude estimate,
    ``V_t = V_i / sqrt(sigma(alt))`` (ISA density ratio,
    :func:`geofence.physics.dynamics.isa_density_ratio`; at 2,800 m AMSL ``V_t`` is
    15 % above ``V_i``, so taking IAS for TAS would bias the wind by
    several m/s upwind). ``airspeed_is_indicated = False`` takes the reading as
    TAS. Heading and airspeed errors average out over turns; a first-order
    low-pass (``tau_s``, default 20 s) keeps the steady part and rejects
    turbulence.

Multirotor (no airspeed sensor): the horizontal force balance
    Per unit mass, in ENU, the vehicle's horizontal acceleration over the
    ground is the horizontal thrust minus the air drag::

        a_ground = f_thrust_h - D(|v_air|) * v_air / |v_air|,    v_air = v_ground - wind

    with ``D(v) = k1 v + k2 v^2`` the platform's drag law
    (:func:`geofence.physics.dynamics.drag_coefficients`, the one home of that
    formula; ``drag_c1_per_s`` / ``drag_c2_per_m`` override k1 / k2). The
    thrust points along the body's -z axis ``t_hat`` (from the attitude); its
    size follows from the vertical balance ``T/m * t_up = g + a_up`` (vertical
    drag neglected), so ``f_thrust_h = (g + a_up) * (t_e, t_n) / t_up``
    (``= g tan(tilt)`` along the tilt in level flight). Hence the drag vector
    ``d = f_thrust_h - a_ground`` points along ``v_air`` and has size
    ``D(|v_air|)``, so::

        v_air = D^-1(|d|) * d / |d|      (geofence.physics.dynamics.airspeed_for_drag_mps)
        wind  = v_ground - v_air

    This holds while the vehicle accelerates, so no sample is thrown away for
    it (the previous estimator gated on |a| < 1 m/s^2 and assumed
    ``a_ground = 0``, which gave the wrong sign for tens of seconds of an
    adversarial flight). ``a_ground`` and ``a_up`` come from the velocity
    estimate through a first-order low-pass of time constant
    ``accel_window_s`` (default 3 s): with ``v_lp`` the low-passed velocity,
    ``a_lp = (v - v_lp) / tau`` is exactly the low-passed derivative, and the
    same low-pass is applied to ``f_thrust_h`` and to the ground velocity, so
    both sides of the balance see the same filter (its lag cancels).

    The low-pass time constant is long enough (3 s) to average the velocity
    estimate's noise out of its derivative: differentiating over 0.5 s made the
    drag of a hovering F450 (0.17 m/s^2 in 5 m/s of wind) drown in noise.

    Sample weights. The balance holds at any acceleration, but the
    acceleration estimate's errors (the velocity estimate's lag behind the
    attitude, GNSS latency, filter transients) grow with the manoeuvre, so each
    sample enters the average with the weight
    ``w = 1 / (1 + (|a_lp| / accel_ref_mps2)^2)`` (1 in steady flight, 0.1 at
    3 x ``accel_ref_mps2``, default 1.5 m/s^2).

    Limitation: with a purely quadratic law near hover (the F450 without rotor
    drag) ``v ~ sqrt(tilt)`` is steep, so AHRS tilt errors (0.5 deg ->
    ~3.5 m/s for the F450) map into the wind estimate and only average out if
    they are not biased; a law with rotor drag (k1 > 0) has a bounded slope
    ``1 / k1``. ``sigma_mps`` stays at least ``multirotor_floor_mps``.

Prior and convergence
    Until enough samples have been seen, the estimate leans on the configured
    prior (e.g. a forecast) with its stated uncertainty: the filter starts at
    the prior and its gain is ``w dt / min(tau, prior_weight_s + t_used)``
    (``w`` = 1 for fixed-wing samples), i.e. a growing-memory average in which
    the prior counts as ``prior_weight_s`` seconds of data, turning into the
    fixed ``tau`` low-pass once ``t_used`` (the weighted time of accepted
    samples) exceeds ``tau - prior_weight_s``. ``converged`` becomes True after
    ``tau`` seconds of (weighted) samples. ``sigma_mps`` is a rough 1-sigma:
    the prior's sigma shrinking with the accepted time, down to a floor.

Per-step cost is a few dozen plain-float operations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from geofence.interface import Envelope, VehicleState
from geofence.jit import compiled, jitable
from geofence.physics.dynamics import G_MPS2, airspeed_for_drag_mps, drag_coefficients, isa_density_ratio

WIND_ESTIMATE_ERROR_MPS = 1.0
"""How far the estimate of the mean wind may be from the true mean once converged (m/s): issue 10's requirement,
measured in ``tests/test_wind_estimator.py``. The unit's dead reckoning drifts at it (plus the turbulence of the
moment), and the pre-flight check widens the forecast by it (:mod:`scenarios.definition.preflight`)."""

_MIN_G_UP_MPS2 = 0.2 * G_MPS2  # the least thrust (per unit mass, vertical) the force balance assumes


@dataclass(frozen=True)
class WindEstimatorConfig:
    """Tuning of :class:`WindEstimator` (SI)."""

    tau_s: float = 20.0
    prior_enu: tuple[float, float] = (0.0, 0.0)
    prior_sigma_mps: float = 5.0
    prior_weight_s: float = 2.0
    min_airspeed_mps: float = 3.0
    max_bank_rad: float = math.radians(60.0)
    airspeed_is_indicated: bool = True  # the pitot reads IAS: converted to TAS with the altitude estimate
    accel_window_s: float = 3.0  # time constant of the low-pass that estimates the acceleration (multirotor)
    accel_ref_mps2: float = 1.5  # a multirotor sample at this horizontal acceleration counts half
    min_agl_m: float = 1.0
    drag_c1_per_s: float | None = None  # multirotor linear drag (1/s); None: the envelope's drag law
    drag_c2_per_m: float | None = None  # multirotor quadratic drag (1/m); None: the envelope's drag law
    fixed_wing_floor_mps: float = 0.5
    multirotor_floor_mps: float = 1.5

    def __post_init__(self) -> None:
        for name in ("tau_s", "prior_weight_s", "accel_window_s", "accel_ref_mps2"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"wind_estimator.{name}: must be a finite number > 0, got {v!r}")
        for name in ("drag_c1_per_s", "drag_c2_per_m"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"wind_estimator.{name}: must be a finite number >= 0 or None, got {v!r}")
        if len(self.prior_enu) != 2 or not all(math.isfinite(x) for x in self.prior_enu):
            raise ValueError(f"wind_estimator.prior_enu: expected two finite numbers, got {self.prior_enu!r}")


WIND_STATE = np.dtype(
    (
        np.record,
        [
            ("east_mps", np.float64),  # the estimate (toward)
            ("north_mps", np.float64),
            ("t_used_s", np.float64),  # weighted time of accepted samples
            ("variance_m2_s2", np.float64),  # spread of the samples about the estimate, per horizontal axis
            ("has_lowpass", np.float64),  # 1: the force balance's low-pass below holds a state
            ("lp_east_mps", np.float64),  # low-passed ground velocity
            ("lp_north_mps", np.float64),
            ("lp_up_mps", np.float64),
            ("lp_thrust_east_mps2", np.float64),  # low-passed horizontal thrust per unit mass
            ("lp_thrust_north_mps2", np.float64),
            ("multirotor_seen", np.float64),  # 1 once a multirotor (force balance) step was taken
            ("last_weight", np.float64),  # the last step's sample weight (0: no sample)
            ("last_sample_east_mps", np.float64),  # the last step's sample (valid while last_weight > 0)
            ("last_sample_north_mps", np.float64),
        ],
    )
)
"""The estimator's state, a record over float memory (all fields float64: a flag is 0 or 1), so that a caller's
compiled step can keep it in one float array with its other states and this module's façade reads the same
memory: nothing is copied or synchronised."""

WIND_CONST = np.dtype(
    (
        np.record,
        [
            ("tau_s", np.float64),
            ("prior_weight_s", np.float64),
            ("min_airspeed_mps", np.float64),
            ("max_bank_rad", np.float64),
            ("airspeed_is_indicated", np.float64),
            ("accel_window_s", np.float64),
            ("accel_ref_sq_m2_s4", np.float64),  # accel_ref_mps2 squared, once
            ("min_agl_m", np.float64),
            ("drag_c1_per_s", np.float64),
            ("drag_c2_per_m", np.float64),
        ],
    )
)
"""The estimator's constants from its :class:`WindEstimatorConfig` and the envelope's drag law, a record as
:data:`WIND_STATE`."""

STATE_SIZE = WIND_STATE.itemsize // 8
CONST_SIZE = WIND_CONST.itemsize // 8
MEMORY_SIZE = STATE_SIZE + CONST_SIZE
"""Float64 slots of the memory a :class:`WindEstimator` lives in: its state, then its constants."""


@compiled
def wind_estimator_update(
    W: np.ndarray, C: np.ndarray, has_pitot: bool, airspeed: float, dt_s: float, position_valid: bool, alt: float,
    agl: float, ve: float, vn: float, vu: float, roll: float, pitch: float, yaw: float,
) -> tuple[float, float]:  # fmt: skip
    """One step of the estimate: the state ``W`` (:data:`WIND_STATE`'s slots) updated in place from the estimate's
    fields and, with ``has_pitot``, the pitot reading ``airspeed`` (else the multirotor's force balance); ``C``:
    :data:`WIND_CONST`'s slots. Returns ``(wind east, wind north)``."""
    w = W.view(WIND_STATE)[0]
    c = C.view(WIND_CONST)[0]
    if not (dt_s > 0.0) or not math.isfinite(dt_s):
        return (w.east_mps, w.north_mps)
    sampled = False
    we = wn = 0.0
    weight = 1.0
    if position_valid and agl >= c.min_agl_m:
        if has_pitot:
            sampled, we, wn = airmass_sample(
                airspeed, c.airspeed_is_indicated != 0.0, c.min_airspeed_mps, c.max_bank_rad, alt, ve, vn, vu, roll,
                yaw,
            )  # fmt: skip
        else:
            w.multirotor_seen = 1.0
            lp = (w.lp_east_mps, w.lp_north_mps, w.lp_up_mps, w.lp_thrust_east_mps2, w.lp_thrust_north_mps2)
            has_lp, lp, sampled, we, wn, weight = force_balance_sample(
                lp, w.has_lowpass != 0.0, dt_s, ve, vn, vu, roll, pitch, yaw, c.drag_c1_per_s, c.drag_c2_per_m,
                c.accel_window_s, c.accel_ref_sq_m2_s4,
            )  # fmt: skip
            w.has_lowpass = 1.0 if has_lp else 0.0
            w.lp_east_mps, w.lp_north_mps, w.lp_up_mps, w.lp_thrust_east_mps2, w.lp_thrust_north_mps2 = lp
    else:
        w.has_lowpass = 0.0  # the force balance restarts from fresh filter states
    if not sampled:
        w.last_weight = 0.0
        return (w.east_mps, w.north_mps)
    w.last_weight = weight
    w.last_sample_east_mps, w.last_sample_north_mps = we, wn
    if weight > 0.0 and math.isfinite(we) and math.isfinite(wn):
        w.east_mps, w.north_mps, w.t_used_s, w.variance_m2_s2 = mean_update(
            w.east_mps, w.north_mps, w.t_used_s, w.variance_m2_s2, we, wn, weight, dt_s, c.prior_weight_s, c.tau_s
        )
    return (w.east_mps, w.north_mps)


@jitable
def turbulence_sigma_mps(W: np.ndarray) -> float:
    """The RMS per axis of the wind samples about the estimate (m/s) of the state ``W``; 0 before any sample."""
    var = W.view(WIND_STATE)[0].variance_m2_s2
    return math.sqrt(var) if var > 0.0 else 0.0


class WindEstimator:
    """Steady-wind estimate of the geofence unit (see the module docstring): a façade over its state record.

    ``update(est, airspeed_mps, dt_s)`` once per outer-loop step with the
    estimator's state and the pitot reading (indicated airspeed; None for a
    multirotor); returns ``(wind_east_mps, wind_north_mps)``, also available as
    :attr:`wind_enu`. Both run :func:`wind_estimator_update`, the one implementation.

    ``memory``: a float64 array of :data:`MEMORY_SIZE` slots to live in (a caller's compiled step that packs
    its states into one array passes its slice: the façade then reads what the step writes); a fresh array
    when omitted. The state and constants are (re)initialised in it.
    """

    def __init__(
        self, envelope: Envelope | None = None, config: WindEstimatorConfig | None = None,
        memory: np.ndarray | None = None,
    ) -> None:  # fmt: skip
        self.config = cfg = config or WindEstimatorConfig()
        if memory is None:
            memory = np.zeros(MEMORY_SIZE)
        if memory.shape != (MEMORY_SIZE,) or memory.dtype != np.float64 or not memory.flags.c_contiguous:
            raise ValueError(f"WindEstimator memory: expected {MEMORY_SIZE} contiguous float64 slots")
        self.memory = memory
        self._W, self._C = memory[:STATE_SIZE], memory[STATE_SIZE:]
        self._state = self._W.view(WIND_STATE)[0]
        k1, k2 = drag_coefficients(envelope) if envelope is not None else (0.0, 0.0)
        const = (
            cfg.tau_s, cfg.prior_weight_s, cfg.min_airspeed_mps, cfg.max_bank_rad, float(cfg.airspeed_is_indicated),
            cfg.accel_window_s, cfg.accel_ref_mps2 * cfg.accel_ref_mps2, cfg.min_agl_m,
            k1 if cfg.drag_c1_per_s is None else float(cfg.drag_c1_per_s),
            k2 if cfg.drag_c2_per_m is None else float(cfg.drag_c2_per_m),
        )  # fmt: skip
        self._C[:] = const
        self._W[:] = 0.0
        self._state.east_mps, self._state.north_mps = float(cfg.prior_enu[0]), float(cfg.prior_enu[1])

    def update(
        self, est: VehicleState, airspeed_mps: float | None, dt_s: float, position_valid: bool = True
    ) -> tuple[float, float]:
        return wind_estimator_update(
            self._W, self._C, airspeed_mps is not None, math.nan if airspeed_mps is None else airspeed_mps, dt_s,
            position_valid, est.alt_m, est.agl_m, est.v_east_mps, est.v_north_mps, est.v_up_mps, est.roll_rad,
            est.pitch_rad, est.yaw_rad,
        )  # fmt: skip

    @property
    def drag_coefficients(self) -> tuple[float, float]:
        """``(k1 per s, k2 per m)`` of the drag law the multirotor model inverts."""
        c = self._C.view(WIND_CONST)[0]
        return (float(c.drag_c1_per_s), float(c.drag_c2_per_m))

    @property
    def wind_enu(self) -> tuple[float, float]:
        """Current estimate (east, north) in m/s, toward."""
        return (float(self._state.east_mps), float(self._state.north_mps))

    @property
    def t_used_s(self) -> float:
        """The weighted time of the samples used so far, s."""
        return float(self._state.t_used_s)

    @property
    def converged(self) -> bool:
        return self.t_used_s >= self.config.tau_s

    @property
    def sigma_mps(self) -> float:
        cfg = self.config
        floor = cfg.multirotor_floor_mps if self._state.multirotor_seen != 0.0 else cfg.fixed_wing_floor_mps
        s = cfg.prior_sigma_mps * math.sqrt(cfg.prior_weight_s / (cfg.prior_weight_s + self.t_used_s))
        return max(s, floor)

    @property
    def last_weight(self) -> float:
        """The weight of the last step's sample (0: the step took none)."""
        return float(self._state.last_weight)

    @property
    def last_sample(self) -> tuple[float, float] | None:
        """The last step's wind sample (east, north), m/s; None when the step took none."""
        st = self._state
        if st.last_weight == 0.0:
            return None
        return (float(st.last_sample_east_mps), float(st.last_sample_north_mps))

    @property
    def turbulence_sigma_mps(self) -> float:
        """Estimated turbulence intensity: the RMS per axis of the wind samples about the estimate (m/s).

        It includes the samples' own noise (sensor and attitude errors) and the
        mean estimate's start-up transient, so it errs on the high side; 0 until
        samples were used.
        """
        return turbulence_sigma_mps(self._W)


@jitable
def mean_update(
    mean_e: float, mean_n: float, t_used_s: float, var: float, we: float, wn: float, weight: float, dt_s: float,
    prior_weight_s: float, tau_s: float,
) -> tuple[float, float, float, float]:  # fmt: skip
    """``(mean east, mean north, weighted time used, turbulence variance)`` after one sample ``(we, wn)`` of weight
    ``weight`` over ``dt_s``: the growing-memory average turning into the ``tau_s`` low-pass (see the module
    docstring), and the spread of the samples about the mean (per horizontal axis)."""
    memory = prior_weight_s + t_used_s
    if not memory < tau_s:  # min(tau, prior_weight_s + t_used)
        memory = tau_s
    wdt = weight * dt_s
    k = wdt / (memory + wdt)
    mean_e = mean_e + k * (we - mean_e)
    mean_n = mean_n + k * (wn - mean_n)
    de, dn = we - mean_e, wn - mean_n
    return mean_e, mean_n, t_used_s + wdt, var + k * (0.5 * (de * de + dn * dn) - var)


@jitable
def airmass_sample(
    va: float, indicated: bool, min_airspeed_mps: float, max_bank_rad: float, alt_m: float, ve: float, vn: float,
    vu: float, roll: float, yaw: float,
) -> tuple[bool, float, float]:  # fmt: skip
    """``(sampled, wind east, wind north)`` from the pitot reading ``va`` (the fixed-wing's triangle: ground velocity
    minus the horizontal airspeed along the heading; not sampled when slow, steeply banked or unread)."""
    if not math.isfinite(va) or va < min_airspeed_mps or abs(roll) > max_bank_rad:
        return False, 0.0, 0.0
    if indicated:
        va /= math.sqrt(isa_density_ratio(alt_m)) if math.isfinite(alt_m) else 1.0
    vh2 = va * va - vu * vu
    vh = math.sqrt(vh2) if vh2 > 0.0 else 0.0
    return True, ve - vh * math.sin(yaw), vn - vh * math.cos(yaw)


@jitable
def force_balance_sample(
    lp: tuple[float, float, float, float, float], has_lp: bool, dt_s: float, ve: float, vn: float, vu: float,
    roll: float, pitch: float, yaw: float, k1: float, k2: float, accel_window_s: float, accel_ref2: float,
) -> tuple[bool, tuple[float, float, float, float, float], bool, float, float, float]:  # fmt: skip
    """The multirotor's force balance for one step: ``(filter kept, its low-passed velocity and thrust, sampled, wind
    east, wind north, weight)`` from the filter state ``lp`` (``has_lp`` False: none yet) and the estimate (see the
    module docstring)."""
    if k1 <= 0.0 and k2 <= 0.0:
        return has_lp, lp, False, 0.0, 0.0, 0.0
    if not (math.isfinite(ve) and math.isfinite(vn) and math.isfinite(vu)):
        return has_lp, lp, False, 0.0, 0.0, 0.0
    # thrust direction (body -z) in ENU
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    t_n = -(cy * sp * cr + sy * sr)
    t_e = -(sy * sp * cr - cy * sr)
    t_up = cp * cr
    if t_up < 0.2:
        return False, lp, False, 0.0, 0.0, 0.0
    # low-passed velocity, its derivative (the acceleration), and the low-passed horizontal thrust
    if not has_lp:
        # the vertical acceleration is unknown on the first step: take level flight
        return True, (ve, vn, vu, G_MPS2 * t_e / t_up, G_MPS2 * t_n / t_up), False, 0.0, 0.0, 0.0
    lp_e, lp_n, lp_u, lp_fe, lp_fn = lp
    tau_dt = accel_window_s + dt_s
    ae = (ve - lp_e) / tau_dt
    an = (vn - lp_n) / tau_dt
    au = (vu - lp_u) / tau_dt
    alpha = dt_s / tau_dt
    lp_e += alpha * (ve - lp_e)
    lp_n += alpha * (vn - lp_n)
    lp_u += alpha * (vu - lp_u)
    g_up = G_MPS2 + au
    if g_up < _MIN_G_UP_MPS2:
        g_up = _MIN_G_UP_MPS2  # free fall or a hard descent: the thrust size is unknown
    lp_fe += alpha * (g_up * t_e / t_up - lp_fe)
    lp_fn += alpha * (g_up * t_n / t_up - lp_fn)
    lp = (lp_e, lp_n, lp_u, lp_fe, lp_fn)
    # drag vector = thrust - acceleration; it points along the air-relative velocity
    de, dn = lp_fe - ae, lp_fn - an
    d = math.sqrt(de * de + dn * dn)
    v_air = airspeed_for_drag_mps(k1, k2, d)
    if not math.isfinite(v_air):
        return True, lp, False, 0.0, 0.0, 0.0
    if d > 1e-12:
        we, wn = lp_e - v_air * de / d, lp_n - v_air * dn / d
    else:
        we, wn = lp_e, lp_n
    # weight: trust falls with the manoeuvre (see the module docstring)
    q = (ae * ae + an * an) / accel_ref2
    return True, lp, True, we, wn, 1.0 / (1.0 + q)
