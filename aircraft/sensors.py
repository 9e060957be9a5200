"""Sensor models for the geofence unit: truth :class:`VehicleState` -> what its own sensors measure.

The geofence unit carries its own GNSS receiver, barometer, pitot (fixed-wing
only) and AHRS. :class:`SensorSuite` turns the simulation truth into the
messages of :mod:`geofence.measurements`, once per outer-loop step::

    suite = SensorSuite(SensorConfig(), has_pitot=not env.is_multirotor, seed=scenario.seed)
    fix, air, att = suite.sample(truth)      # fix is None on steps without a new GNSS message

Error models (defaults in :class:`SensorConfig`, all overridable from a
scenario's optional ``sensors:`` block, see :func:`parse_sensors`):

* **GNSS position**: truth + white noise + a first-order Gauss-Markov bias per
  axis (stationary sigma, correlation time tau), 1.5 m horizontal / 3 m vertical
  bias sigma, 0.5 m / 1.0 m white, tau = 60 s. Sources: u-blox NEO-M8N
  datasheet, 2.5 m CEP autonomous / 2.0 m CEP with SBAS (CEP 2.0 m is a
  per-axis sigma of 2.0 / 1.1774 = 1.7 m; our sqrt(1.5^2 + 0.5^2) = 1.58 m
  is between the M8 with SBAS and the NEO-M9N's 1.5 m CEP); vertical errors of
  single-frequency GNSS are typically 1.5-2x the horizontal ones. The
  Gauss-Markov structure and tau = 60 s follow PX4's SITL Gazebo GPS plugin
  (``gps_corellation_time = 60 s``), which models GNSS error as mostly slowly
  wandering rather than white.
* **GNSS velocity**: white, 0.1 m/s horizontal / 0.2 m/s vertical (datasheet
  0.05 m/s at 50 %, i.e. about 0.07 m/s sigma static; doubled for dynamics).
* **GNSS timing**: fixes at ``gps_rate_hz`` (5 Hz), delivered ``gps_latency_s``
  (0.2 s) after their time of validity (u-blox navigation latency is
  ~0.1-0.2 s; PX4 EKF2's default ``EKF2_GPS_DELAY`` is 0.11 s).
* **GNSS loss**: from ``gps_fail_at_s`` on, and inside any ``gps_outages``
  window ``[start, end)``, the receiver keeps reporting at its rate but with
  ``valid = False`` (no fix).
* **Barometer**: white 0.3 m (MS5611-class sensor in flight, prop-wash
  included; the datasheet's 0.012 mbar RMS at OSR 4096 is ~0.1 m static)
  plus a Gauss-Markov drift, 1 m sigma, tau = 300 s (weather and temperature
  drift of a few dm per minute).
* **Pitot airspeed**: reads the *indicated* airspeed, as a real pitot does
  (a differential pressure q = rho V_t^2 / 2 calibrated at sea-level density
  rho0): ``IAS = TAS * sqrt(rho / rho0)``, ISA troposphere density from the
  true altitude (:func:`geofence.dynamics.isa_density_ratio`; 13 % below TAS
  at 2,800 m AMSL), plus white 0.3 m/s (MS4525DO-class differential pressure
  sensor at cruise speeds); ``None`` for platforms without a pitot. Users
  that need TAS convert back with their own altitude estimate (the wind
  estimator does).
* **AHRS attitude**: Gauss-Markov errors, 0.5 deg roll/pitch and 2 deg yaw
  sigma with tau = 5 s (VectorNav VN-100-class figures: 0.5 deg pitch/roll and
  2 deg magnetic heading, dynamic; cheaper MEMS AHRS are worse). A tau of 0
  makes them white.

Reproducibility: all noise comes from ``numpy.random.SeedSequence(seed)`` with
an independent stream per sensor (spawn keys), so enabling or retuning one
sensor leaves the others' noise unchanged. Normals are drawn in blocks and
handed out as plain floats, so a step costs a few microseconds.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from geofence.dynamics import isa_density_ratio
from geofence.estimator import EstimatorConfig
from geofence.geodesy import radii_of_curvature_m
from geofence.interface import VehicleState
from geofence.measurements import AirData, AttitudeSample, GpsFix
from geofence.validation import ConfigError, integer, kind, number, reject_unknown_keys, require_mapping

_NAN = float("nan")
_INF = float("inf")
_TWO_PI = 2.0 * math.pi
_EPS_S = 1e-9

GPS_STREAM, BARO_STREAM, PITOT_STREAM, AHRS_STREAM = range(4)
SENSOR_STREAMS = (GPS_STREAM, BARO_STREAM, PITOT_STREAM, AHRS_STREAM)
"""The independent noise streams, one per sensor: the spawn key of each stream's seed sequence."""
NORMAL_BLOCK = 4096
"""Normals drawn from a stream at a time."""


def stream_generator(seed: int, stream: int) -> np.random.Generator:
    """The random generator of one sensor's noise stream for a flight's ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(stream,)))


@dataclass(frozen=True)
class SensorConfig:
    """Noise and timing of the geofence unit's sensors (SI; see the module docstring for sources)."""

    def estimator_config(self, **tuning: Any) -> EstimatorConfig:
        """The estimator tuned to these sensors (:func:`estimator_config`)."""
        return estimator_config(self, **tuning)

    gps_rate_hz: float = 5.0
    gps_latency_s: float = 0.2
    gps_h_white_m: float = 0.5
    gps_h_bias_m: float = 1.5
    gps_v_white_m: float = 1.0
    gps_v_bias_m: float = 3.0
    gps_bias_tau_s: float = 60.0
    gps_vel_h_noise_mps: float = 0.1
    gps_vel_v_noise_mps: float = 0.2
    gps_fail_at_s: float | None = None
    gps_outages: tuple[tuple[float, float], ...] = ()
    baro_noise_m: float = 0.3
    baro_drift_m: float = 1.0
    baro_drift_tau_s: float = 300.0
    airspeed_noise_mps: float = 0.3
    ahrs_roll_pitch_deg: float = 0.5
    ahrs_yaw_deg: float = 2.0
    ahrs_tau_s: float = 5.0
    seed: int | None = None

    @property
    def gps_h_sigma_m(self) -> float:
        """Total per-axis horizontal GNSS position sigma (bias and white)."""
        return math.hypot(self.gps_h_bias_m, self.gps_h_white_m)

    @property
    def gps_v_sigma_m(self) -> float:
        """Total vertical GNSS position sigma (bias and white)."""
        return math.hypot(self.gps_v_bias_m, self.gps_v_white_m)

    def gps_lost(self, t_s: float) -> bool:
        """True when the receiver has no fix at time ``t_s`` (failure or outage window)."""
        if self.gps_fail_at_s is not None and t_s >= self.gps_fail_at_s:
            return True
        for start, end in self.gps_outages:
            if start <= t_s < end:
                return True
        return False


def _normal_stream(rng: np.random.Generator, block: int = NORMAL_BLOCK) -> Callable[[], float]:
    """Standard normal floats from ``rng``: returns a callable that hands out the next one (cheap per call, reproducible).

    The normals are drawn ``block`` at a time and handed out as plain floats. A
    block holds the same numbers as ``block`` single draws (numpy's Generator
    draws an array one value after the other), so the block size does not
    change the stream.
    """
    # iter(f, None) calls f for ever (a list never equals None): an endless iterator of blocks, chained into
    # one iterator of floats. Its bound __next__ costs ~35 ns a draw, a Python __call__ method ~180 ns.
    blocks = iter(lambda: rng.standard_normal(block).tolist(), None)
    return itertools.chain.from_iterable(blocks).__next__


class _GaussMarkov:
    """First-order Gauss-Markov process with stationary sigma and correlation time tau (tau 0: white)."""

    __slots__ = ("sigma", "tau", "value", "_dt", "_a", "_b", "_n")

    def __init__(self, sigma: float, tau_s: float, normals: Callable[[], float]) -> None:
        self.sigma = sigma
        self.tau = tau_s
        self._n = normals
        self.value = sigma * normals() if sigma > 0.0 else 0.0  # start in the stationary distribution
        self._dt = -1.0
        self._a = 0.0
        self._b = sigma

    def step(self, dt_s: float) -> float:
        if self.sigma <= 0.0:
            return 0.0
        if dt_s != self._dt:  # the coefficients are cached for the last dt (the outer loop's is constant)
            self._dt = dt_s
            a = math.exp(-dt_s / self.tau) if self.tau > 0.0 else 0.0
            self._a = a
            self._b = self.sigma * math.sqrt(max(0.0, 1.0 - a * a))
        value = self._a * self.value + self._b * self._n()
        self.value = value
        return value


class SensorSuite:
    """The geofence unit's sensors, sampled from truth once per outer-loop step.

    ``sample(truth)`` returns ``(fix, air, att)``: ``fix`` is a :class:`GpsFix`
    on the steps where a GNSS message arrives (every ``1/gps_rate_hz`` s, each
    ``gps_latency_s`` after its time of validity), else None; ``air`` and
    ``att`` are fresh every step. Call it with non-decreasing ``truth.t_s``.

    ``seed`` is used unless ``config.seed`` is set. With ``prefill`` (default)
    the receiver is taken to be running before the first call: the first call
    already delivers the fix of ``gps_latency_s`` earlier (truth extrapolated
    back at constant velocity), so an estimator has a position from step 0.
    """

    def __init__(
        self, config: SensorConfig | None = None, *, has_pitot: bool = True, seed: int | None = None, prefill: bool = True
    ) -> None:
        self.config = cfg = config or SensorConfig()
        self.has_pitot = has_pitot
        self.prefill = prefill
        s = cfg.seed if cfg.seed is not None else (seed if seed is not None else 0)
        self.seed = s
        gps_n, baro_n, pitot_n, ahrs_n = (_normal_stream(stream_generator(s, k)) for k in SENSOR_STREAMS)
        self._gps_n, self._pitot_n = gps_n, pitot_n
        self._baro_n = baro_n
        tau = cfg.gps_bias_tau_s
        self._gps_bias = (
            _GaussMarkov(cfg.gps_h_bias_m, tau, gps_n),
            _GaussMarkov(cfg.gps_h_bias_m, tau, gps_n),
            _GaussMarkov(cfg.gps_v_bias_m, tau, gps_n),
        )
        self._baro_drift = _GaussMarkov(cfg.baro_drift_m, cfg.baro_drift_tau_s, baro_n)
        rp = math.radians(cfg.ahrs_roll_pitch_deg)
        self._ahrs = (
            _GaussMarkov(rp, cfg.ahrs_tau_s, ahrs_n),
            _GaussMarkov(rp, cfg.ahrs_tau_s, ahrs_n),
            _GaussMarkov(math.radians(cfg.ahrs_yaw_deg), cfg.ahrs_tau_s, ahrs_n),
        )
        self._period_s = 1.0 / cfg.gps_rate_hz
        self._next_epoch_s: float | None = None
        self._last_epoch_s: float | None = None
        self._last_t_s: float | None = None
        self._pending: deque[GpsFix] = deque()
        self._next_arrival_s = _INF  # when the oldest pending fix is delivered (inf: none pending)
        self._h_acc = cfg.gps_h_sigma_m
        self._v_acc = cfg.gps_v_sigma_m

    # -- per step ---------------------------------------------------------------
    def sample(self, truth: VehicleState) -> tuple[GpsFix | None, AirData, AttitudeSample]:
        cfg = self.config
        t = truth.t_s
        last_t = self._last_t_s
        dt = 0.0 if last_t is None else t - last_t
        if dt < 0.0:
            raise ValueError(f"sensor time went backwards: {t} after {last_t}")
        self._last_t_s = t

        # GNSS: solve at the epochs, deliver after the latency
        if self._next_epoch_s is None:
            lat = cfg.gps_latency_s
            if self.prefill and lat > 0.0:
                # the receiver was already running: its previous epoch arrives now
                self._queue(self._solve(_back_dated(truth, lat)))
                self._next_epoch_s = t - lat + self._period_s
            else:
                self._next_epoch_s = t
        if t >= self._next_epoch_s - _EPS_S:
            self._queue(self._solve(truth))
            while self._next_epoch_s <= t + _EPS_S:
                self._next_epoch_s += self._period_s
        fix = self._deliver(t) if t >= self._next_arrival_s else None

        # barometer: pressure altitude, referenced at start-up to the true altitude (+ drift)
        drift = self._baro_drift.step(dt) if dt > 0.0 else self._baro_drift.value
        alt = truth.alt_m
        baro = alt + drift + cfg.baro_noise_m * self._baro_n()
        airspeed = None
        if self.has_pitot:
            # indicated airspeed: the true airspeed scaled by sqrt(rho / rho0)
            airspeed = truth.airspeed_mps * math.sqrt(isa_density_ratio(alt)) + cfg.airspeed_noise_mps * self._pitot_n()
            if airspeed < 0.0:
                airspeed = 0.0
        air = AirData(t, airspeed, baro)

        er, ep, ey = self._ahrs
        if dt > 0.0:
            dr, dp, dy = er.step(dt), ep.step(dt), ey.step(dt)
        else:
            dr, dp, dy = er.value, ep.value, ey.value
        yaw = (truth.yaw_rad + dy) % _TWO_PI
        att = AttitudeSample(t, truth.roll_rad + dr, truth.pitch_rad + dp, yaw)
        return fix, air, att

    def _queue(self, fix: GpsFix) -> None:
        """Hold a solved fix until its arrival, ``gps_latency_s`` after its time of validity."""
        pending = self._pending
        pending.append(fix)
        if len(pending) == 1:
            self._next_arrival_s = self._arrival_s(fix)

    def _deliver(self, t: float) -> GpsFix:
        """Pop the fixes that have arrived by ``t`` (at least one); if several are due (slow caller), the newest wins."""
        pending = self._pending
        fix = pending.popleft()
        while pending and t >= self._arrival_s(pending[0]):
            fix = pending.popleft()
        self._next_arrival_s = self._arrival_s(pending[0]) if pending else _INF
        return fix

    def _arrival_s(self, fix: GpsFix) -> float:
        """The time a fix is delivered: its time of validity plus the latency (less a float tolerance)."""
        return fix.t_s + self.config.gps_latency_s - _EPS_S

    def _solve(self, truth: VehicleState) -> GpsFix:
        """The receiver's solution at this epoch (time of validity = truth time)."""
        cfg = self.config
        t = truth.t_s
        dt = self._period_s if self._last_epoch_s is None else t - self._last_epoch_s
        self._last_epoch_s = t
        bx, by, bz = self._gps_bias
        # the bias keeps wandering through an outage, as the real error sources do
        be, bn, bu = bx.step(dt), by.step(dt), bz.step(dt)
        n = self._gps_n
        de = be + cfg.gps_h_white_m * n()
        dn = bn + cfg.gps_h_white_m * n()
        du = bu + cfg.gps_v_white_m * n()
        nve = cfg.gps_vel_h_noise_mps * n()
        nvn = cfg.gps_vel_h_noise_mps * n()
        nvu = cfg.gps_vel_v_noise_mps * n()
        if cfg.gps_lost(t):
            return GpsFix(t, _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, _INF, _INF, False)
        lat = math.radians(truth.lat_deg)
        n_rad, m_rad = radii_of_curvature_m(lat)  # prime vertical, meridian
        h = truth.alt_m
        lat_deg = truth.lat_deg + math.degrees(dn / (m_rad + h))
        lon_deg = truth.lon_deg + math.degrees(de / ((n_rad + h) * math.cos(lat)))
        return GpsFix(
            t,
            lat_deg,
            lon_deg,
            h + du,
            truth.v_east_mps + nve,
            truth.v_north_mps + nvn,
            truth.v_up_mps + nvu,
            self._h_acc,
            self._v_acc,
            True,
        )

    # -- introspection (tests, logs) ---------------------------------------------
    @property
    def gps_bias_enu_m(self) -> tuple[float, float, float]:
        """The current GNSS position bias (east, north, up) in m (truth, for logs and tests)."""
        return (self._gps_bias[0].value, self._gps_bias[1].value, self._gps_bias[2].value)


def _back_dated(truth: VehicleState, dt_s: float) -> VehicleState:
    """Truth ``dt_s`` earlier, extrapolated back at constant velocity (for the pre-filled first fix)."""
    lat = math.radians(truth.lat_deg)
    n_rad, m_rad = radii_of_curvature_m(lat)
    de, dn, du = truth.v_east_mps * dt_s, truth.v_north_mps * dt_s, truth.v_up_mps * dt_s
    return replace(
        truth,
        t_s=truth.t_s - dt_s,
        lat_deg=truth.lat_deg - math.degrees(dn / (m_rad + truth.alt_m)),
        lon_deg=truth.lon_deg - math.degrees(de / ((n_rad + truth.alt_m) * math.cos(lat))),
        alt_m=truth.alt_m - du,
        east_m=truth.east_m - de,
        north_m=truth.north_m - dn,
        up_m=truth.up_m - du,
        agl_m=truth.agl_m - du,
    )


# --------------------------------------------------------------------------- YAML block

_FLOAT_FIELDS = {
    # name: (minimum, strictly positive)
    "gps_rate_hz": (0.0, True),
    "gps_latency_s": (0.0, False),
    "gps_h_white_m": (0.0, False),
    "gps_h_bias_m": (0.0, False),
    "gps_v_white_m": (0.0, False),
    "gps_v_bias_m": (0.0, False),
    "gps_bias_tau_s": (0.0, True),
    "gps_vel_h_noise_mps": (0.0, False),
    "gps_vel_v_noise_mps": (0.0, False),
    "gps_fail_at_s": (0.0, False),
    "baro_noise_m": (0.0, False),
    "baro_drift_m": (0.0, False),
    "baro_drift_tau_s": (0.0, True),
    "airspeed_noise_mps": (0.0, False),
    "ahrs_roll_pitch_deg": (0.0, False),
    "ahrs_yaw_deg": (0.0, False),
    "ahrs_tau_s": (0.0, False),
}
SENSOR_KEYS: tuple[str, ...] = tuple(f.name for f in fields(SensorConfig))

ESTIMATOR_NOISE_FIELDS: dict[str, str] = {
    "gps_h_white_m": "gps_h_white_m",
    "gps_h_bias_m": "gps_h_bias_m",
    "gps_v_white_m": "gps_v_white_m",
    "gps_v_bias_m": "gps_v_bias_m",
    "gps_bias_tau_s": "gps_bias_tau_s",
    "gps_vel_h_noise_mps": "gps_vel_h_mps",
    "gps_vel_v_noise_mps": "gps_vel_v_mps",
    "baro_noise_m": "baro_noise_m",
    "baro_drift_m": "baro_drift_m",
    "baro_drift_tau_s": "baro_drift_tau_s",
}
"""The one map from the sensors' noise specification to the estimator's tuning (SensorConfig field -> EstimatorConfig field)."""


def estimator_config(sensors: SensorConfig, **tuning: Any) -> EstimatorConfig:
    """The unit's estimator tuned to these sensors: their GNSS and baro noise, plus any other ``tuning``."""
    return EstimatorConfig(**{est: getattr(sensors, ours) for ours, est in ESTIMATOR_NOISE_FIELDS.items()}, **tuning)


def parse_sensors(raw: Any, where: str = "sensors") -> SensorConfig:
    """Validate an optional ``sensors:`` YAML block into a :class:`SensorConfig` (None -> defaults).

    Every key is optional and named like the :class:`SensorConfig` field it sets::

        sensors:
          gps_rate_hz: 5
          gps_latency_s: 0.2
          gps_fail_at_s: 40            # the fix is lost for good at t = 40 s
          gps_outages: [[10, 15]]      # ... or lost inside these [start, end) windows
          ahrs_yaw_deg: 3
          seed: 11                     # optional; else the scenario seed

    Errors are one-line :class:`~geofence.validation.ConfigError` s: ``<where>.<field>: <problem>``; unknown keys are rejected.
    """
    if raw is None:
        return SensorConfig()
    require_mapping(raw, where)
    reject_unknown_keys(raw, SENSOR_KEYS, where)
    out: dict[str, Any] = {}
    for key, value in raw.items():
        w = f"{where}.{key}"
        if key == "seed":
            out[key] = None if value is None else integer(value, w, minimum=0)
        elif key == "gps_outages":
            if not isinstance(value, (list, tuple)):
                raise ConfigError(f"{w}: expected a list of [start_s, end_s] pairs, got {kind(value)}")
            windows = []
            for i, pair in enumerate(value):
                if not isinstance(pair, (list, tuple)) or len(pair) != 2:
                    raise ConfigError(f"{w}[{i}]: expected a [start_s, end_s] pair, got {kind(pair)} {pair!r}")
                a = number(pair[0], f"{w}[{i}]", minimum=0.0)
                b = number(pair[1], f"{w}[{i}]", minimum=0.0)
                if not b > a:
                    raise ConfigError(f"{w}[{i}]: end_s must be > start_s, got [{pair[0]!r}, {pair[1]!r}]")
                windows.append((a, b))
            out[key] = tuple(windows)
        elif key == "gps_fail_at_s" and value is None:
            out[key] = None
        else:
            minimum, positive = _FLOAT_FIELDS[key]
            out[key] = number(value, w, minimum=minimum, strictly_positive=positive)
    return SensorConfig(**out)
