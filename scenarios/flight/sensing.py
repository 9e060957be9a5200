"""The geofence unit's own view of a simulated flight: sensors -> state estimator -> wind estimator, per step.

:class:`GeofenceSensing` runs the chain as one call per step, :func:`sense_step` (compiled by
:func:`geofence.jit.compiled`; the same source interpreted without numba or with ``NUMBA_DISABLE_JIT=1``). Each
link is written once (:func:`aircraft.sensors.sensors_step`, :func:`geofence.estimation.estimator.estimator_step`,
:func:`geofence.estimation.wind_estimator.wind_estimator_update`); the chain keeps their memories in one packed array, and
:attr:`GeofenceSensing.sensors`, :attr:`GeofenceSensing.estimator` and :attr:`GeofenceSensing.wind` are façades
over its slices: nothing is copied or synchronised.

With ``state_source: truth`` (e.g. indoor motion capture) the unit gets the
true state and the true steady wind instead (a scenario's sensor faults then change nothing).
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

import numpy as np

from aircraft import sensors as sk
from aircraft.sensors import SENSOR_CONST, SENSOR_STATE, SensorSuite, sensors_step
from geofence import jit
from geofence.estimation import estimator as ek
from geofence.estimation import wind_estimator as wk
from geofence.estimation.estimator import EST_STATE, HORIZON_FIELDS, GeofenceEstimator, estimator_step
from geofence.estimation.wind_estimator import WindEstimator, WindEstimatorConfig, turbulence_sigma_mps, wind_estimator_update
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import Envelope, FixState, VehicleState
from geofence.unit.config import GeofenceConfig, StateSource
from scenarios.definition.faults import sensor_fault_rows
from scenarios.definition.schema import Scenario
from wind.config import wind_from_config


class Sensed(NamedTuple):
    """What the geofence unit's own sensing gives it for one step."""

    estimate: VehicleState
    wind_en: tuple[float, float]
    """Wind estimate (east, north), m/s, toward."""
    position_valid: bool
    sigma_h_m: float
    sigma_v_m: float
    horizon: FixState | None = None
    """The estimate at its newest fix's time of validity (None with a truth source)."""
    data_age_s: float = 0.0
    """Age of the position data behind the estimate, s (0 for a perfect, immediate source)."""
    turbulence_sigma_mps: float | None = None
    """The wind estimator's turbulence intensity, m/s 1-sigma (None with a truth source: the unit is told nothing)."""


# The chain's memories, packed end to end in one float array (a compiled call pays about 0.1 us per array
# argument): the state estimator's (state, constants), the wind estimator's and, last, the sensors' (state,
# constants, the delivered fix, the fault table and the pending GNSS ring: its size follows their configuration).
_X0 = 0
_K0 = _X0 + ek.STATE_SIZE
_W0 = _K0 + ek.CONST_SIZE
_WC0 = _W0 + wk.STATE_SIZE
_S0 = _WC0 + wk.CONST_SIZE
_FIX0, _FIX1 = _S0 + sk.FIX0, _S0 + sk.OUTAGES0


def _sense_step(
    P: np.ndarray, pools: np.ndarray, idx: np.ndarray, dt_s: float, t: float, lat: float, lon: float, alt: float,
    ve: float, vn: float, vu: float, airspeed: float, roll: float, pitch: float, yaw: float,
) -> tuple[tuple[float, ...], float, float, bool, float, float, bool, float, float, bool]:  # fmt: skip
    """One step of the chain from the truth's fields: ``(estimate fields, wind e, wind n, position valid,
    sigma_h, sigma_v, new horizon, data age, turbulence sigma, a noise pool runs low)``. ``P``: the packed
    memories; ``pools``, ``idx``: the sensors' noise rows and read indices (:attr:`SensorSuite.pools`)."""
    X, K, W, WC = P[_X0:_K0], P[_K0:_W0], P[_W0:_WC0], P[_WC0:_S0]
    delivered, a_ind, baro_alt, r, p, y, low = sensors_step(
        P[_S0:], pools, idx, t, lat, lon, alt, ve, vn, vu, airspeed, roll, pitch, yaw
    )
    rf = P[_S0 : _S0 + sk.STATE_SIZE].view(SENSOR_STATE)[0]  # this step's rangefinder and flow samples (NaN: none)
    est = estimator_step(
        X, K, dt_s, delivered, P[_FIX0:_FIX1], t, a_ind, baro_alt, r, p, y, rf.range_m, rf.flow_fwd_mps,
        rf.flow_right_mps,
    )  # fmt: skip
    x = X.view(EST_STATE)[0]
    valid = x.position_valid != 0.0
    has_pitot = P[_S0 + sk.STATE_SIZE : _FIX0].view(SENSOR_CONST)[0].has_pitot != 0.0
    we, wn = wind_estimator_update(
        W, WC, has_pitot, a_ind, dt_s, valid, est[3], est[7], est[8], est[9], est[10], est[11], est[12], est[13]
    )
    age = x.t_s - x.t_d_s if x.has_fix != 0.0 else 0.0
    return (
        est, we, wn, valid, x.sigma_h_m, x.sigma_v_m, x.horizon_new != 0.0, age if age > 0.0 else 0.0,
        turbulence_sigma_mps(W), low,
    )  # fmt: skip


_new_tuple = tuple.__new__

HORIZON_IN_P = slice(_X0 + HORIZON_FIELDS.start, _X0 + HORIZON_FIELDS.stop)
"""The fusion horizon's fields in the chain's packed array (for a caller's compiled step that runs the chain)."""
_HORIZON = HORIZON_FIELDS
"""The fusion horizon's fields in the estimator's state, in :class:`FixState`'s order (read as one slice: a
generator over the five indices costs three times as much, on every step with a new fix)."""

sense_step: Callable[..., tuple[Any, ...]] = jit.compiled(_sense_step)
"""The compiled :func:`_sense_step` (the Python function itself without numba): a caller's compiled step composes
it (:mod:`scenarios.flight.step_kernel`)."""


class GeofenceSensing:
    """The geofence unit's own view of the flight: sensors -> state estimator -> wind estimator.

    One call of :func:`sense_step` a step over one packed array; ``sensors``, ``estimator`` and ``wind`` are
    façades over its slices (they read what the step writes). With ``state_source: truth`` the unit is given the
    truth and the true steady wind instead (``compiled`` is then False: the chain does not run).
    """

    def __init__(self, scenario: Scenario, cfg: GeofenceConfig, frame: LocalFrame, env: Envelope) -> None:
        self.truth_source = cfg.state_source is StateSource.TRUTH
        self.compiled = not self.truth_source
        """The chain runs (and a caller's compiled step may run it: :meth:`kernel_arrays`)."""
        sc = scenario.sensors
        self._truth_wind = None
        if self.truth_source and scenario.wind is not None:
            self._truth_wind = wind_from_config(scenario.wind, scenario.seed)
        faults = sensor_fault_rows(scenario.faults)  # (the unit's sensors give them; the unit is not told)
        P = np.zeros(_S0 + sk.memory_size(sc, faults))  # the step reads and writes P; the objects are façades over it
        self.estimator = GeofenceEstimator(frame, sc.estimator_config(), memory=P[_X0:_W0])
        self.wind = WindEstimator(env, WindEstimatorConfig(prior_enu=cfg.wind_prior_enu), memory=P[_W0:_S0])
        self.sensors = SensorSuite(
            sc, has_pitot=not env.is_multirotor, seed=scenario.seed, memory=P[_S0:], faults=faults, ground_alt_m=frame.h0_m
        )  # fmt: skip
        self._X = P[_X0:_K0]
        self._args: tuple[Any, ...] = (P, self.sensors.pools, self.sensors.idx)
        self._kernel: Callable[..., tuple[Any, ...]] = sense_step
        self._horizon: FixState | None = None

    def sense(self, truth: VehicleState, dt_s: float) -> Sensed:
        """The unit's estimate, wind estimate, position validity and sigmas for this step."""
        if self.truth_source:
            we, wn = (self._truth_wind.mean(truth.agl_m)[:2]) if self._truth_wind is not None else (0.0, 0.0)
            return Sensed(truth, (we, wn), True, 0.0, 0.0)
        s = truth
        P, pools, idx = self._args  # (unpacked: a call with *self._args costs 0.09 us more, measured)
        kernel = self._kernel
        fields, we, wn, valid, sigma_h, sigma_v, new_horizon, age, turbulence, low = kernel(
            P, pools, idx, dt_s, s.t_s, s.lat_deg, s.lon_deg, s.alt_m, s.v_east_mps, s.v_north_mps, s.v_up_mps,
            s.airspeed_mps, s.roll_rad, s.pitch_rad, s.yaw_rad,
        )  # fmt: skip
        if kernel is sense_step:  # after its first call, by its entry point (geofence.jit: the arrays are ours)
            self._kernel = jit.entry_point(kernel)
        horizon = self.stepped(new_horizon, low)
        est = VehicleState(*fields)
        est.on_ground = truth.on_ground  # touchdown switch / the flight controller's land detector
        # (tuple.__new__: Sensed's own constructor is a Python function, at twice the cost per step)
        return _new_tuple(Sensed, (est, (we, wn), valid, sigma_h, sigma_v, horizon, age, turbulence))

    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The compiled chain's arrays ``(P, pools, idx)`` (:func:`sense_step`'s first three arguments), for a caller
        whose own compiled step runs the chain (:mod:`scenarios.flight.step_kernel`); the same arrays all flight."""
        P, pools, idx = self._args
        return P, pools, idx

    @property
    def horizon(self) -> FixState | None:
        """The newest fusion horizon the chain gave (None before its first fix)."""
        return self._horizon

    def stepped(self, new_horizon: bool, low: bool) -> FixState | None:
        """After a compiled step of the chain (:meth:`sense`'s, or a caller's that runs it): keep the fusion horizon
        when it moved (``new_horizon``), refill the noise pools when they run ``low``; returns the horizon."""
        if new_horizon:
            self._horizon = _new_tuple(FixState, self._X[_HORIZON].tolist())  # (Python floats, as float(X[i]))
        if low:
            self.sensors.refill()  # in place: the pools stay the same array
        return self._horizon
