"""Sensor models for the geofence unit: truth :class:`VehicleState` -> what its own sensors measure.

The geofence unit carries its own GNSS receiver, barometer, pitot (fixed-wing
only) and AHRS. :class:`SensorSuite` turns the simulation truth into the
messages of :mod:`geofence.estimation.measurements`, once per outer-loop step::

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
  ``valid = False`` (no fix). Both are rows of the suite's fault table (GNSS_LOSS), as a
  scenario's ``faults:`` are.
* **Faults** (:func:`fault_row`, a scenario's ``faults:`` block via :mod:`scenarios.definition.faults`): a
  GNSS loss, a degraded receiver (its rate, latency and wandering bias), a walk-off (position drifting at a
  constant velocity, the reported velocity consistent with it), a barometer offset or drift, a pitot frozen at
  its reading, a heading error. None draws noise: the streams stay as they are without it.
* **Barometer**: white 0.3 m (MS5611-class sensor in flight, prop-wash
  included; the datasheet's 0.012 mbar RMS at OSR 4096 is ~0.1 m static)
  plus a Gauss-Markov drift, 1 m sigma, tau = 300 s (weather and temperature
  drift of a few dm per minute).
* **Pitot airspeed**: reads the *indicated* airspeed, as a real pitot does
  (a differential pressure q = rho V_t^2 / 2 calibrated at sea-level density
  rho0): ``IAS = TAS * sqrt(rho / rho0)``, ISA troposphere density from the
  true altitude (:func:`geofence.physics.dynamics.isa_density_ratio`; 13 % below TAS
  at 2,800 m AMSL), plus white 0.3 m/s (MS4525DO-class differential pressure
  sensor at cruise speeds); ``None`` for platforms without a pitot. Users
  that need TAS convert back with their own altitude estimate (the wind
  estimator does).
* **Downward rangefinder** (optional, ``rangefinder:``; off by default): the slant range to the flat ground
  (the scenario's ``ground_alt_m``) along the body's down axis, ``agl / (cos roll cos pitch)``, plus white noise
  ``max(noise_m, noise_fraction * range)`` (Benewake TFmini: 0.3-12 m, +-4 cm to 6 m and 1 % beyond, 100 Hz);
  no reading (NaN) outside ``[min_range_m, max_range_m]`` or tilted beyond ``max_tilt_deg`` (PX4 EKF2 accepts a
  range up to 45 deg of tilt). Sampled at ``rate_hz``; NaN on the steps without a new sample.
* **Optical flow** (optional, ``optical_flow:``; off by default; PX4Flow class): the body-frame ground velocity
  (forward, right) as the angular flow (velocity / height) plus white noise, times the *measured* range (so range
  errors scale it). Its angular noise falls from ``noise_max_radps`` at no quality to ``noise_min_radps`` at full
  quality (PX4 EKF2_OF_N_MAX 0.5 / EKF2_OF_N_MIN 0.15 rad/s), so the velocity noise grows with height; the quality
  is ``light_level`` x 1 below ``full_quality_below_m`` falling linearly to 0 at ``zero_quality_at_m``. No
  reading without a valid range or under ``min_quality``.
* **AHRS attitude**: Gauss-Markov errors, 0.5 deg roll/pitch and 2 deg yaw
  sigma with tau = 5 s (VectorNav VN-100-class figures: 0.5 deg pitch/roll and
  2 deg magnetic heading, dynamic; cheaper MEMS AHRS are worse). A tau of 0
  makes them white.

Reproducibility: all noise comes from ``numpy.random.SeedSequence(seed)`` with
an independent stream per sensor (spawn keys), so enabling or retuning one
sensor leaves the others' noise unchanged. A stream is a row of drawn normals
and a read index (:attr:`SensorSuite.pools`, :attr:`SensorSuite.idx`), topped
up in place between steps (a step draws at most :data:`MAX_DRAWS_PER_STEP`
from a stream; a stream's numbers do not depend on how many are drawn at a time).

The step is written once: :func:`sensors_step`, compiled by :func:`geofence.jit.compiled` (the same source
interpreted without numba or with ``NUMBA_DISABLE_JIT=1``). Its state and constants are the records
:data:`SENSOR_STATE` and :data:`SENSOR_CONST` over float memory, followed by the delivered GNSS message, the
fault table (:func:`fault_table`: the outage windows, the failure and the faults) and the ring of pending messages (solved, not yet delivered; rows of
:data:`geofence.estimation.estimator.GPS_FIX`), so that the unit's compiled sensing chain (:mod:`scenarios.flight.sensing`)
keeps them in its packed array; :class:`SensorSuite` is a façade that owns (or is given) that memory.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from geofence.estimation.estimator import FIX_SIZE, GPS_FIX, EstimatorConfig
from geofence.estimation.measurements import AirData, AttitudeSample, GpsFix, RangeFlowSample
from geofence.geometry.geodesy import radii_of_curvature_m
from geofence.interface import VehicleState
from geofence.jit import compiled, jitable
from geofence.physics.dynamics import isa_density_ratio
from geofence.validation import ConfigError, integer, kind, number, reject_unknown_keys, require_mapping

_TWO_PI = 2.0 * math.pi
_EPS_S = 1e-9

GPS_STREAM, BARO_STREAM, PITOT_STREAM, AHRS_STREAM, RANGE_STREAM, FLOW_STREAM = range(6)
SENSOR_STREAMS = (GPS_STREAM, BARO_STREAM, PITOT_STREAM, AHRS_STREAM, RANGE_STREAM, FLOW_STREAM)
"""The independent noise streams, one per sensor: the spawn key of each stream's seed sequence."""
NORMAL_BLOCK = 4096
"""Normals drawn from a stream at a time."""
MAX_DRAWS_PER_STEP = 32
"""The most normals one step can take from one stream (two GNSS solutions of nine draws each, at the first step)."""


def stream_generator(seed: int, stream: int) -> np.random.Generator:
    """The random generator of one sensor's noise stream for a flight's ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(stream,)))


@dataclass(frozen=True)
class RangefinderConfig:
    """A downward rangefinder (Benewake TFmini-class lidar by default; see the module docstring and
    docs/validation.md "Optical flow and rangefinder")."""

    min_range_m: float = 0.3
    max_range_m: float = 12.0
    noise_m: float = 0.04
    noise_fraction: float = 0.01
    rate_hz: float = 100.0
    max_tilt_deg: float = 45.0


@dataclass(frozen=True)
class OpticalFlowConfig:
    """A downward optical-flow velocity sensor (PX4Flow class; needs a valid range to scale its flow)."""

    rate_hz: float = 100.0
    noise_min_radps: float = 0.15
    noise_max_radps: float = 0.5
    full_quality_below_m: float = 3.0
    zero_quality_at_m: float = 20.0
    light_level: float = 1.0
    min_quality: float = 0.2


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
    rangefinder: RangefinderConfig | None = None
    optical_flow: OpticalFlowConfig | None = None
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


def _float_record(*names: str) -> np.dtype:
    """A record dtype of float64 fields, viewable over float memory."""
    return np.dtype((np.record, [(name, np.float64) for name in names]))


SENSOR_STATE = _float_record(
    "t_last_s", "has_t_last",  # the previous sample's time (has_*: 1 once set)
    "next_epoch_s", "has_next_epoch", "last_epoch_s", "has_last_epoch",  # the receiver's solution epochs
    "next_arrival_s",  # when the oldest pending message is delivered (inf: none pending)
    "ring_head", "ring_count",  # the pending messages' ring: its oldest row and how many
    "gps_bias_e_m", "gps_bias_n_m", "gps_bias_u_m", "baro_drift_m",  # the Gauss-Markov errors
    "ahrs_roll_err_rad", "ahrs_pitch_err_rad", "ahrs_yaw_err_rad",
    "rng_next_s", "range_m",  # the rangefinder: its next sample's time; this step's slant range (NaN: none)
    "flow_next_s", "flow_fwd_mps", "flow_right_mps", "flow_quality",  # the flow sensor: this step's (NaN: none)
)  # fmt: skip
"""The sensors' state, a record over float memory (every field float64: a flag is 0 or 1, a count a whole number)."""

SENSOR_CONST = _float_record(
    "period_s", "latency_s", "prefill", "has_pitot",
    "gps_h_white_m", "gps_v_white_m", "gps_vel_h_mps", "gps_vel_v_mps", "baro_noise_m", "airspeed_noise_mps",
    "h_acc_m", "v_acc_m", "n_faults",  # n_faults: rows of the fault table (outages and failure included)
    "gps_h_bias_m", "gps_v_bias_m", "gps_bias_tau_s", "baro_drift_sigma_m", "baro_drift_tau_s",
    "ahrs_roll_pitch_rad", "ahrs_yaw_rad", "ahrs_tau_s",
    "ground_m", "has_range", "rng_period_s", "rng_min_m", "rng_max_m", "rng_noise_m", "rng_noise_frac", "rng_cos_tilt",
    "has_flow", "flow_period_s", "flow_n_min", "flow_n_max", "flow_q_full_m", "flow_q_zero_m", "flow_light",
    "flow_q_min",
)  # fmt: skip
"""The sensors' constants from their :class:`SensorConfig` (SI, angles in rad)."""

STATE_SIZE = SENSOR_STATE.itemsize // 8
CONST_SIZE = SENSOR_CONST.itemsize // 8
FIX0 = STATE_SIZE + CONST_SIZE
"""The slot of the delivered GNSS message (:data:`~geofence.estimation.estimator.GPS_FIX`) in a suite's memory."""
OUTAGES0 = FIX0 + FIX_SIZE
"""The slot of the fault table (:data:`FAULT_COLUMNS` per row: the outage windows, the failure and a scenario's
``faults:``), then the pending messages' ring (:func:`ring_rows` messages)."""

# The sensor fault table: one row per fault, FAULT_COLUMNS floats. The kernel reads a row as active at t when
# onset_s <= t < end_s; a row that starts at the unit's first activation has onset_s = end_s = inf until
# SensorSuite.trigger_faults writes them (onset = activation + delay_s, end = onset + duration_s).
FAULT_COLUMNS = 9
F_KIND, F_ONSET, F_END, F_P0, F_P1, F_P2, F_AFTER_ACTIVATION, F_DELAY, F_DURATION = range(FAULT_COLUMNS)
GNSS_LOSS, GNSS_DEGRADED, GNSS_WALKOFF, BARO_DRIFT, PITOT_BLOCKED, COMPASS_ERROR = 1.0, 2.0, 3.0, 4.0, 5.0, 6.0
"""A row's kind and its parameters (p0, p1, p2; NaN: unchanged): GNSS_LOSS (none); GNSS_DEGRADED (fix period s,
latency s, horizontal bias sigma m); GNSS_WALKOFF (drift east, north m/s); BARO_DRIFT (offset m, rate m/s);
PITOT_BLOCKED (the reading it froze at, NaN until its onset); COMPASS_ERROR (heading error rad)."""


def fault_row(
    kind: float, onset_s: float = 0.0, duration_s: float = math.inf, params: tuple[float, ...] = (),
    after_activation: bool = False,
) -> np.ndarray:  # fmt: skip
    """One row of the sensor fault table: from ``onset_s`` (or, ``after_activation``, that long after the unit's
    first activation) for ``duration_s``; ``params``: up to three, NaN for those not given."""
    row = np.full(FAULT_COLUMNS, math.nan)
    row[F_KIND] = kind
    row[F_P0 : F_P0 + len(params)] = params
    row[F_AFTER_ACTIVATION], row[F_DELAY], row[F_DURATION] = float(after_activation), onset_s, duration_s
    row[F_ONSET], row[F_END] = (math.inf, math.inf) if after_activation else (onset_s, onset_s + duration_s)
    return row


def fault_table(cfg: SensorConfig, faults: np.ndarray | None = None) -> np.ndarray:
    """The fault table of a suite: ``cfg``'s outage windows and failure (GNSS_LOSS rows), then ``faults``."""
    rows = [fault_row(GNSS_LOSS, a, b - a) for a, b in cfg.gps_outages]
    if cfg.gps_fail_at_s is not None:
        rows.append(fault_row(GNSS_LOSS, cfg.gps_fail_at_s))
    table = np.array(rows).reshape(-1, FAULT_COLUMNS)
    return table if faults is None else np.vstack([table, np.asarray(faults, float).reshape(-1, FAULT_COLUMNS)])


def ring_rows(cfg: SensorConfig, faults: np.ndarray | None = None) -> int:
    """Rows of the pending GNSS messages' ring: more than are ever pending, the solutions of one latency (one per
    fix period) plus the pre-filled first one and a margin; with degraded-receiver ``faults``, their longest
    latency at the fastest rate."""
    latency_s, rate_hz = cfg.gps_latency_s, cfg.gps_rate_hz
    for row in () if faults is None else np.asarray(faults).reshape(-1, FAULT_COLUMNS):
        if row[F_KIND] == GNSS_DEGRADED:
            latency_s = max(latency_s, 0.0 if math.isnan(row[F_P1]) else row[F_P1])
            rate_hz = max(rate_hz, 0.0 if math.isnan(row[F_P0]) else 1.0 / row[F_P0])
    return int(math.ceil(latency_s * rate_hz)) + 4


def memory_size(cfg: SensorConfig, faults: np.ndarray | None = None) -> int:
    """Float64 slots of the memory a :class:`SensorSuite` of ``cfg`` (and sensor ``faults``) lives in: its state,
    constants, delivered message, fault table and pending ring."""
    return OUTAGES0 + fault_table(cfg, faults).size + FIX_SIZE * ring_rows(cfg, faults)


@compiled
def sensors_step(
    M: np.ndarray, pools: np.ndarray, idx: np.ndarray, t: float, lat_deg: float, lon_deg: float, alt: float,
    ve: float, vn: float, vu: float, airspeed_true: float, roll: float, pitch: float, yaw: float,
) -> tuple[bool, float, float, float, float, float, bool]:  # fmt: skip
    """The sensors' sample of one truth state: ``(fix delivered, airspeed, baro, roll, pitch, yaw, a noise pool
    runs low)``. ``M``: a suite's memory (:func:`memory_size`), updated in place; a delivered message is written
    to its slots at :data:`FIX0`. ``pools``, ``idx``: a row of drawn normals per stream and its read index.
    ``airspeed`` is NaN without a pitot; the air data and attitude are of time ``t``."""
    s = M[:STATE_SIZE].view(SENSOR_STATE)[0]
    c = M[STATE_SIZE:FIX0].view(SENSOR_CONST)[0]
    n_rows = int(c.n_faults)
    faults = M[OUTAGES0 : OUTAGES0 + FAULT_COLUMNS * n_rows].reshape(-1, FAULT_COLUMNS)
    ring = M[OUTAGES0 + FAULT_COLUMNS * n_rows :].view(GPS_FIX)
    dt = 0.0 if s.has_t_last == 0.0 else t - s.t_last_s
    if dt < 0.0:
        raise ValueError("sensor time went backwards")
    s.t_last_s = t
    s.has_t_last = 1.0
    gnss_epochs(s, c, faults, ring, pools, idx, t, lat_deg, lon_deg, alt, ve, vn, vu)
    delivered = False
    if t >= s.next_arrival_s:
        deliver(s, c, faults, ring, M[FIX0:OUTAGES0].view(GPS_FIX), t)
        delivered = True
    # barometer: pressure altitude referenced at start-up to the true altitude (+ drift)
    if dt > 0.0:
        s.baro_drift_m = gauss_markov(s.baro_drift_m, c.baro_drift_sigma_m, c.baro_drift_tau_s, dt, pools, idx, BARO_STREAM)
    baro = alt + s.baro_drift_m + c.baro_noise_m * draw(pools, idx, BARO_STREAM) + baro_fault_m(faults, t)
    airspeed = math.nan
    if c.has_pitot != 0.0:  # indicated airspeed: the true airspeed scaled by sqrt(rho / rho0)
        ias = pitot_fault_ias(faults, t, airspeed_true * math.sqrt(isa_density_ratio(alt)))
        airspeed = ias + c.airspeed_noise_mps * draw(pools, idx, PITOT_STREAM)
        if airspeed < 0.0:
            airspeed = 0.0
    if dt > 0.0:
        rp, tau = c.ahrs_roll_pitch_rad, c.ahrs_tau_s
        s.ahrs_roll_err_rad = gauss_markov(s.ahrs_roll_err_rad, rp, tau, dt, pools, idx, AHRS_STREAM)
        s.ahrs_pitch_err_rad = gauss_markov(s.ahrs_pitch_err_rad, rp, tau, dt, pools, idx, AHRS_STREAM)
        s.ahrs_yaw_err_rad = gauss_markov(s.ahrs_yaw_err_rad, c.ahrs_yaw_rad, tau, dt, pools, idx, AHRS_STREAM)
    range_and_flow(s, c, pools, idx, t, alt, ve, vn, roll, pitch, yaw)
    low = False
    for k in range(pools.shape[0]):
        if pools.shape[1] - idx[k] < MAX_DRAWS_PER_STEP:
            low = True
    yaw_err = s.ahrs_yaw_err_rad + compass_fault_rad(faults, t)
    return (
        delivered, airspeed, baro, roll + s.ahrs_roll_err_rad, pitch + s.ahrs_pitch_err_rad,
        (yaw + yaw_err) % _TWO_PI, low,
    )  # fmt: skip


@jitable
def range_and_flow(
    s: Any, c: Any, pools: np.ndarray, idx: np.ndarray, t: float, alt: float, ve: float, vn: float, roll: float,
    pitch: float, yaw: float,
) -> None:  # fmt: skip
    """This step's rangefinder and optical-flow samples into ``s`` (NaN: none this step, out of range, tilted
    beyond the cone, or flow without a valid range or quality). Each draws from its own stream only when it
    samples, so a suite without them draws exactly what it drew before."""
    s.range_m = s.flow_fwd_mps = s.flow_right_mps = s.flow_quality = math.nan
    agl = alt - c.ground_m
    cos_tilt = math.cos(roll) * math.cos(pitch)
    if c.has_range != 0.0 and t >= s.rng_next_s - _EPS_S:
        s.rng_next_s = t + c.rng_period_s
        true_r = agl / cos_tilt if cos_tilt > 1e-6 else math.inf
        n = draw(pools, idx, RANGE_STREAM)
        if cos_tilt >= c.rng_cos_tilt and c.rng_min_m <= true_r <= c.rng_max_m:
            s.range_m = true_r + max(c.rng_noise_m, c.rng_noise_frac * true_r) * n
    if c.has_flow != 0.0 and t >= s.flow_next_s - _EPS_S:
        s.flow_next_s = t + c.flow_period_s
        n_fwd, n_right = draw(pools, idx, FLOW_STREAM), draw(pools, idx, FLOW_STREAM)
        span = c.flow_q_zero_m - c.flow_q_full_m
        fall = (agl - c.flow_q_full_m) / span if span > 0.0 else (0.0 if agl <= c.flow_q_full_m else 1.0)
        q = c.flow_light * min(1.0, max(0.0, 1.0 - fall))
        if math.isfinite(s.range_m) and q >= c.flow_q_min and agl > 0.0:
            sigma = c.flow_n_min + (c.flow_n_max - c.flow_n_min) * (1.0 - q)  # angular flow noise, rad/s
            h_meas = s.range_m * cos_tilt
            sy, cy = math.sin(yaw), math.cos(yaw)
            s.flow_fwd_mps = ((ve * sy + vn * cy) / agl + sigma * n_fwd) * h_meas
            s.flow_right_mps = ((ve * cy - vn * sy) / agl + sigma * n_right) * h_meas
            s.flow_quality = q


@jitable
def active(f: np.ndarray, kind: float, t: float) -> bool:
    """Fault row ``f`` is of ``kind`` and active at ``t`` (``onset_s <= t < end_s``)."""
    return f[F_KIND] == kind and f[F_ONSET] <= t < f[F_END]


@jitable
def baro_fault_m(faults: np.ndarray, t: float) -> float:
    """The barometer's added error at ``t`` from its drift faults (offset + rate x time since onset)."""
    err = 0.0
    for k in range(faults.shape[0]):
        f = faults[k]
        if active(f, BARO_DRIFT, t):
            err += (0.0 if math.isnan(f[F_P0]) else f[F_P0]) + (0.0 if math.isnan(f[F_P1]) else f[F_P1] * (t - f[F_ONSET]))
    return err


@jitable
def pitot_fault_ias(faults: np.ndarray, t: float, ias: float) -> float:
    """The pitot's noise-free reading at ``t``: ``ias``, or while blocked the reading it froze at its onset."""
    for k in range(faults.shape[0]):
        f = faults[k]
        if active(f, PITOT_BLOCKED, t):
            if math.isnan(f[F_P0]):
                f[F_P0] = ias
            return f[F_P0]
    return ias


@jitable
def compass_fault_rad(faults: np.ndarray, t: float) -> float:
    """The heading's added error at ``t`` from its compass faults, rad."""
    err = 0.0
    for k in range(faults.shape[0]):
        if active(faults[k], COMPASS_ERROR, t):
            err += faults[k, F_P0]
    return err


@jitable
def degraded(faults: np.ndarray, t: float, column: int, nominal: float) -> float:
    """A degraded receiver's ``column`` (fix period, latency or bias sigma) at ``t``, else ``nominal``."""
    for k in range(faults.shape[0]):
        f = faults[k]
        if active(f, GNSS_DEGRADED, t) and not math.isnan(f[column]):
            return f[column]
    return nominal


@jitable
def walkoff_m(faults: np.ndarray, t: float) -> tuple[float, float, float, float]:
    """The walk-off faults' position offset (east, north, m) and velocity offset (east, north, m/s) at ``t``."""
    oe = on = we = wn = 0.0
    for k in range(faults.shape[0]):
        f = faults[k]
        if active(f, GNSS_WALKOFF, t):
            oe += f[F_P0] * (t - f[F_ONSET])
            on += f[F_P1] * (t - f[F_ONSET])
            we += f[F_P0]
            wn += f[F_P1]
    return oe, on, we, wn


@jitable
def draw(pools: np.ndarray, idx: np.ndarray, stream: int) -> float:
    """The next standard normal of a noise stream."""
    i = idx[stream]
    idx[stream] = i + 1
    return pools[stream, i]


@jitable
def gauss_markov(value: float, sigma: float, tau_s: float, dt: float, pools: np.ndarray, idx: np.ndarray, stream: int) -> float:  # fmt: skip
    """A first-order Gauss-Markov process's next value after ``dt`` (stationary ``sigma``, correlation time
    ``tau_s``; 0: white), drawing from ``stream``; 0 without drawing when ``sigma`` is 0."""
    if sigma <= 0.0:
        return 0.0
    a = math.exp(-dt / tau_s) if tau_s > 0.0 else 0.0
    b = sigma * math.sqrt(max(0.0, 1.0 - a * a))
    return a * value + b * draw(pools, idx, stream)


@jitable
def gnss_epochs(
    s: Any, c: Any, faults: np.ndarray, ring: np.ndarray, pools: np.ndarray, idx: np.ndarray, t: float,
    lat_deg: float, lon_deg: float, alt: float, ve: float, vn: float, vu: float,
) -> None:  # fmt: skip
    """The receiver's solutions due by ``t`` queued: at the first call with ``prefill`` the previous epoch's (the
    receiver was already running: truth extrapolated back at constant velocity), then one per epoch."""
    if s.has_next_epoch == 0.0:
        lat = c.latency_s
        if c.prefill != 0.0 and lat > 0.0:
            lat_r = math.radians(lat_deg)
            n_rad, m_rad = radii_of_curvature_m(lat_r)
            de, dn, du = ve * lat, vn * lat, vu * lat
            solve(
                s, c, faults, ring, pools, idx, t - lat, lat_deg - math.degrees(dn / (m_rad + alt)),
                lon_deg - math.degrees(de / ((n_rad + alt) * math.cos(lat_r))), alt - du, ve, vn, vu,
            )  # fmt: skip
            s.next_epoch_s = t - lat + c.period_s
        else:
            s.next_epoch_s = t
        s.has_next_epoch = 1.0
    if t >= s.next_epoch_s - _EPS_S:
        solve(s, c, faults, ring, pools, idx, t, lat_deg, lon_deg, alt, ve, vn, vu)
        period = degraded(faults, t, F_P0, c.period_s)
        while s.next_epoch_s <= t + _EPS_S:
            s.next_epoch_s += period


@jitable
def gps_lost(faults: np.ndarray, t: float) -> bool:
    """The receiver has no fix at ``t`` (a GNSS_LOSS row: the failure, an outage window or a fault)."""
    for k in range(faults.shape[0]):
        if active(faults[k], GNSS_LOSS, t):
            return True
    return False


@jitable
def solve(
    s: Any, c: Any, faults: np.ndarray, ring: np.ndarray, pools: np.ndarray, idx: np.ndarray, t: float,
    lat_deg: float, lon_deg: float, alt: float, ve: float, vn: float, vu: float,
) -> None:  # fmt: skip
    """The receiver's solution at an epoch (time of validity ``t``), appended to the pending ring; the bias keeps
    wandering through an outage, as the real error sources do."""
    dt = c.period_s if s.has_last_epoch == 0.0 else t - s.last_epoch_s
    s.last_epoch_s = t
    s.has_last_epoch = 1.0
    tau = c.gps_bias_tau_s
    be = gauss_markov(s.gps_bias_e_m, c.gps_h_bias_m, tau, dt, pools, idx, GPS_STREAM)
    bn = gauss_markov(s.gps_bias_n_m, c.gps_h_bias_m, tau, dt, pools, idx, GPS_STREAM)
    bu = gauss_markov(s.gps_bias_u_m, c.gps_v_bias_m, tau, dt, pools, idx, GPS_STREAM)
    s.gps_bias_e_m, s.gps_bias_n_m, s.gps_bias_u_m = be, bn, bu
    # a degraded receiver's bias: the same wandering process scaled to its sigma (horizontal; vertical twice it)
    h_scale = degraded(faults, t, F_P2, c.gps_h_bias_m) / c.gps_h_bias_m if c.gps_h_bias_m > 0.0 else 1.0
    v_scale = 2.0 * degraded(faults, t, F_P2, 0.5 * c.gps_v_bias_m) / c.gps_v_bias_m if c.gps_v_bias_m > 0.0 else 1.0
    oe, on, we, wn = walkoff_m(faults, t)
    de = h_scale * be + oe + c.gps_h_white_m * draw(pools, idx, GPS_STREAM)
    dn = h_scale * bn + on + c.gps_h_white_m * draw(pools, idx, GPS_STREAM)
    du = v_scale * bu + c.gps_v_white_m * draw(pools, idx, GPS_STREAM)
    nve = we + c.gps_vel_h_mps * draw(pools, idx, GPS_STREAM)
    nvn = wn + c.gps_vel_h_mps * draw(pools, idx, GPS_STREAM)
    nvu = c.gps_vel_v_mps * draw(pools, idx, GPS_STREAM)
    count = int(s.ring_count)
    if count >= ring.shape[0]:  # not reached: ring_rows() holds every solution of one latency and more
        raise ValueError("the pending GNSS messages' ring is full")
    r = ring[(int(s.ring_head) + count) % ring.shape[0]]
    s.ring_count = count + 1
    if count == 0:
        s.next_arrival_s = t + degraded(faults, t, F_P1, c.latency_s) - _EPS_S
    r.t_s = t
    if gps_lost(faults, t):
        r.lat_deg = r.lon_deg = r.alt_m = r.v_east_mps = r.v_north_mps = r.v_up_mps = math.nan
        r.horizontal_accuracy_m = r.vertical_accuracy_m = math.inf
        r.valid = 0.0
        return
    lat = math.radians(lat_deg)
    n_rad, m_rad = radii_of_curvature_m(lat)  # prime vertical, meridian
    r.lat_deg = lat_deg + math.degrees(dn / (m_rad + alt))
    r.lon_deg = lon_deg + math.degrees(de / ((n_rad + alt) * math.cos(lat)))
    r.alt_m = alt + du
    r.v_east_mps, r.v_north_mps, r.v_up_mps = ve + nve, vn + nvn, vu + nvu
    r.horizontal_accuracy_m, r.vertical_accuracy_m = c.h_acc_m, c.v_acc_m
    r.valid = 1.0


@jitable
def deliver(s: Any, c: Any, faults: np.ndarray, ring: np.ndarray, fix: np.ndarray, t: float) -> None:
    """The pending messages that have arrived by ``t`` (at least one) popped off the ring; if several are due (a
    slow caller), the newest wins: it is written to ``fix[0]``. A message's latency is the receiver's at its time
    of validity (a degraded receiver's while one is)."""
    head = int(s.ring_head)
    count = int(s.ring_count)
    fix[0] = ring[head]
    head = (head + 1) % ring.shape[0]
    count -= 1
    while count > 0 and t >= ring[head].t_s + degraded(faults, ring[head].t_s, F_P1, c.latency_s) - _EPS_S:
        fix[0] = ring[head]
        head = (head + 1) % ring.shape[0]
        count -= 1
    s.ring_head = head
    s.ring_count = count
    t_v = ring[head].t_s
    s.next_arrival_s = t_v + degraded(faults, t_v, F_P1, c.latency_s) - _EPS_S if count > 0 else math.inf


class SensorSuite:
    """The geofence unit's sensors, sampled from truth once per outer-loop step: a façade over their memory.

    ``sample(truth)`` returns ``(fix, air, att)``: ``fix`` is a :class:`GpsFix`
    on the steps where a GNSS message arrives (every ``1/gps_rate_hz`` s, each
    ``gps_latency_s`` after its time of validity), else None; ``air`` and
    ``att`` are fresh every step. Call it with non-decreasing ``truth.t_s``.
    Both run :func:`sensors_step`, the one implementation.

    ``seed`` is used unless ``config.seed`` is set. With ``prefill`` (default)
    the receiver is taken to be running before the first call: the first call
    already delivers the fix of ``gps_latency_s`` earlier (truth extrapolated
    back at constant velocity), so an estimator has a position from step 0.

    ``memory``: a float64 array of :func:`memory_size` slots to live in (a caller's compiled step that packs its
    states into one array passes its slice); a fresh array when omitted. The noise is in :attr:`pools` (a row of
    drawn normals per stream, read from :attr:`idx` on), topped up by :meth:`refill`. ``faults``: rows of
    :func:`fault_row` (a scenario's sensor faults, :func:`scenarios.definition.faults.sensor_fault_rows`), after
    ``config``'s outages and failure in :attr:`faults`; those timed from the unit's first activation start at
    :meth:`trigger_faults`. ``ground_alt_m``: the flat ground's altitude (the rangefinder's and the flow's).
    :meth:`range_flow` reads the last step's rangefinder and flow samples.
    """

    def __init__(
        self, config: SensorConfig | None = None, *, has_pitot: bool = True, seed: int | None = None,
        prefill: bool = True, memory: np.ndarray | None = None, faults: np.ndarray | None = None,
        ground_alt_m: float = 0.0,
    ) -> None:  # fmt: skip
        self.config = cfg = config or SensorConfig()
        self.has_pitot = has_pitot
        self.prefill = prefill
        self.seed = s = cfg.seed if cfg.seed is not None else (seed if seed is not None else 0)
        table = fault_table(cfg, faults)
        size = memory_size(cfg, faults)
        if memory is None:
            memory = np.zeros(size)
        if memory.shape != (size,) or memory.dtype != np.float64 or not memory.flags.c_contiguous:
            raise ValueError(f"SensorSuite memory: expected {size} contiguous float64 slots")
        self.memory = memory
        self._rngs = [stream_generator(s, k) for k in SENSOR_STREAMS]
        self.pools = np.stack([rng.standard_normal(NORMAL_BLOCK) for rng in self._rngs])
        """One row of normals per stream, read from ``idx[stream]`` on (refilled in place)."""
        self.idx = np.zeros(len(SENSOR_STREAMS), np.int64)
        memory[:] = 0.0
        self._state = memory[:STATE_SIZE].view(SENSOR_STATE)[0]
        _fill_constants(memory[STATE_SIZE:FIX0].view(SENSOR_CONST)[0], cfg, has_pitot, prefill, len(table))
        _fill_range_flow(memory[STATE_SIZE:FIX0].view(SENSOR_CONST)[0], cfg, ground_alt_m)
        self._state.range_m = self._state.flow_fwd_mps = self._state.flow_right_mps = math.nan
        self._state.flow_quality = math.nan
        self.faults = memory[OUTAGES0 : OUTAGES0 + table.size].reshape(-1, FAULT_COLUMNS)
        """The fault table (:data:`FAULT_COLUMNS` per row), in the suite's memory: the step reads it."""
        self.faults[:] = table
        self._start_stationary()
        self._state.next_arrival_s = math.inf
        self._fix = memory[FIX0:OUTAGES0]

    def _start_stationary(self) -> None:
        """Each Gauss-Markov error starts in its stationary distribution (one draw each, in the streams' order)."""
        st, cfg = self._state, self.config
        rp, yaw = math.radians(cfg.ahrs_roll_pitch_deg), math.radians(cfg.ahrs_yaw_deg)
        starts = (
            ("gps_bias_e_m", cfg.gps_h_bias_m, GPS_STREAM), ("gps_bias_n_m", cfg.gps_h_bias_m, GPS_STREAM),
            ("gps_bias_u_m", cfg.gps_v_bias_m, GPS_STREAM), ("baro_drift_m", cfg.baro_drift_m, BARO_STREAM),
            ("ahrs_roll_err_rad", rp, AHRS_STREAM), ("ahrs_pitch_err_rad", rp, AHRS_STREAM),
            ("ahrs_yaw_err_rad", yaw, AHRS_STREAM),
        )  # fmt: skip
        for name, sigma, stream in starts:
            if sigma > 0.0:
                setattr(st, name, sigma * self.pools[stream][self.idx[stream]])
                self.idx[stream] += 1

    def sample(self, truth: VehicleState) -> tuple[GpsFix | None, AirData, AttitudeSample]:
        t = truth.t_s
        delivered, airspeed, baro, roll, pitch, yaw, low = sensors_step(
            self.memory, self.pools, self.idx, t, truth.lat_deg, truth.lon_deg, truth.alt_m, truth.v_east_mps,
            truth.v_north_mps, truth.v_up_mps, truth.airspeed_mps, truth.roll_rad, truth.pitch_rad, truth.yaw_rad,
        )  # fmt: skip
        if low:
            self.refill()
        fix = None
        if delivered:
            t_m, lat, lon, alt, ve, vn, vu, h_acc, v_acc, valid = self._fix.tolist()
            fix = GpsFix(t_m, lat, lon, alt, ve, vn, vu, h_acc, v_acc, valid != 0.0)
        return fix, AirData(t, airspeed if self.has_pitot else None, baro), AttitudeSample(t, roll, pitch, yaw)

    def refill(self) -> bool:
        """Top up the streams that fell below :data:`MAX_DRAWS_PER_STEP` unread normals: the unread ones move to
        the row's start and the stream's next draws fill the rest (a stream's numbers do not depend on how many
        are drawn at a time). True when one was."""
        low = False
        cap = self.pools.shape[1]
        for k in range(len(SENSOR_STREAMS)):
            i = int(self.idx[k])
            if cap - i < MAX_DRAWS_PER_STEP:
                row = self.pools[k]
                row[: cap - i] = row[i:].copy()
                row[cap - i :] = self._rngs[k].standard_normal(i)
                self.idx[k] = 0
                low = True
        return low

    def trigger_faults(self, t_s: float) -> None:
        """The unit first activated at ``t_s``: the faults that start then (``at_first_activation``) are timed."""
        for f in self.faults:
            if f[F_AFTER_ACTIVATION] != 0.0 and math.isinf(f[F_ONSET]):
                f[F_ONSET] = t_s + f[F_DELAY]
                f[F_END] = f[F_ONSET] + f[F_DURATION]

    def range_flow(self) -> RangeFlowSample:
        """The last step's rangefinder and optical-flow samples (NaN: none)."""
        st = self._state
        return RangeFlowSample(
            float(st.t_last_s), float(st.range_m), float(st.flow_fwd_mps), float(st.flow_right_mps),
            float(st.flow_quality),
        )  # fmt: skip

    # -- introspection (tests, logs) ---------------------------------------------
    @property
    def gps_bias_enu_m(self) -> tuple[float, float, float]:
        """The current GNSS position bias (east, north, up) in m (truth, for logs and tests)."""
        st = self._state
        return (float(st.gps_bias_e_m), float(st.gps_bias_n_m), float(st.gps_bias_u_m))


def _fill_constants(c: Any, cfg: SensorConfig, has_pitot: bool, prefill: bool, n_faults: int) -> None:
    """The :data:`SENSOR_CONST` record ``c`` of a suite tuned by ``cfg``."""
    c.period_s, c.latency_s, c.prefill, c.has_pitot = 1.0 / cfg.gps_rate_hz, cfg.gps_latency_s, prefill, has_pitot
    c.gps_h_white_m, c.gps_v_white_m = cfg.gps_h_white_m, cfg.gps_v_white_m
    c.gps_vel_h_mps, c.gps_vel_v_mps = cfg.gps_vel_h_noise_mps, cfg.gps_vel_v_noise_mps
    c.baro_noise_m, c.airspeed_noise_mps = cfg.baro_noise_m, cfg.airspeed_noise_mps
    c.h_acc_m, c.v_acc_m = cfg.gps_h_sigma_m, cfg.gps_v_sigma_m
    c.n_faults = n_faults
    c.gps_h_bias_m, c.gps_v_bias_m, c.gps_bias_tau_s = cfg.gps_h_bias_m, cfg.gps_v_bias_m, cfg.gps_bias_tau_s
    c.baro_drift_sigma_m, c.baro_drift_tau_s = cfg.baro_drift_m, cfg.baro_drift_tau_s
    c.ahrs_roll_pitch_rad, c.ahrs_yaw_rad = math.radians(cfg.ahrs_roll_pitch_deg), math.radians(cfg.ahrs_yaw_deg)
    c.ahrs_tau_s = cfg.ahrs_tau_s


def _fill_range_flow(c: Any, cfg: SensorConfig, ground_alt_m: float) -> None:
    """The rangefinder's and the flow sensor's constants in ``c`` (zeros: not fitted)."""
    c.ground_m = ground_alt_m
    r, f = cfg.rangefinder, cfg.optical_flow
    if r is not None:
        c.has_range, c.rng_period_s, c.rng_min_m, c.rng_max_m = 1.0, 1.0 / r.rate_hz, r.min_range_m, r.max_range_m
        c.rng_noise_m, c.rng_noise_frac, c.rng_cos_tilt = r.noise_m, r.noise_fraction, math.cos(math.radians(r.max_tilt_deg))
    if f is not None:
        c.has_flow, c.flow_period_s, c.flow_n_min, c.flow_n_max = 1.0, 1.0 / f.rate_hz, f.noise_min_radps, f.noise_max_radps
        c.flow_q_full_m, c.flow_q_zero_m, c.flow_light = f.full_quality_below_m, f.zero_quality_at_m, f.light_level
        c.flow_q_min = f.min_quality


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
    """The unit's estimator tuned to these sensors: their GNSS and baro noise (and, where fitted, the
    rangefinder's and the flow's), plus any other ``tuning``."""
    fitted: dict[str, Any] = {}
    if sensors.rangefinder is not None:
        fitted["range_noise_m"] = sensors.rangefinder.noise_m
        fitted["range_noise_fraction"] = sensors.rangefinder.noise_fraction
    if sensors.optical_flow is not None:
        f = sensors.optical_flow
        fitted["flow_noise_radps"] = 0.5 * (f.noise_min_radps + f.noise_max_radps)
    noise: dict[str, Any] = {est: getattr(sensors, ours) for ours, est in ESTIMATOR_NOISE_FIELDS.items()}
    return EstimatorConfig(**noise, **fitted, **tuning)


_NESTED: dict[str, Any] = {"rangefinder": RangefinderConfig, "optical_flow": OpticalFlowConfig}
_NESTED_POSITIVE = {"rate_hz", "max_range_m", "max_tilt_deg"}


def _parse_nested(raw: Any, cls: Any, where: str) -> Any:
    """A ``rangefinder:`` / ``optical_flow:`` block (``{}`` or ``true``: the defaults) into its config."""
    if raw is True or raw is None:
        return cls()
    require_mapping(raw, where)
    names = tuple(f.name for f in fields(cls))
    reject_unknown_keys(raw, names, where)
    out = {k: number(v, f"{where}.{k}", minimum=0.0, strictly_positive=k in _NESTED_POSITIVE) for k, v in raw.items()}
    cfg = cls(**out)
    if isinstance(cfg, RangefinderConfig):
        if not cfg.max_range_m > cfg.min_range_m:
            raise ConfigError(f"{where}.max_range_m: must be > min_range_m ({cfg.min_range_m!r}), got {cfg.max_range_m!r}")
        if cfg.max_tilt_deg >= 90.0:
            raise ConfigError(f"{where}.max_tilt_deg: must be < 90, got {cfg.max_tilt_deg!r}")
    else:
        for k in ("light_level", "min_quality"):
            if getattr(cfg, k) > 1.0:
                raise ConfigError(f"{where}.{k}: must be in [0, 1], got {getattr(cfg, k)!r}")
        if cfg.noise_max_radps < cfg.noise_min_radps:
            raise ConfigError(f"{where}.noise_max_radps: must be >= noise_min_radps, got {cfg.noise_max_radps!r}")
    return cfg


def parse_sensors(raw: Any, where: str = "sensors") -> SensorConfig:
    """Validate an optional ``sensors:`` YAML block into a :class:`SensorConfig` (None -> defaults).

    Every key is optional and named like the :class:`SensorConfig` field it sets::

        sensors:
          gps_rate_hz: 5
          gps_latency_s: 0.2
          gps_fail_at_s: 40            # the fix is lost for good at t = 40 s
          gps_outages: [[10, 15]]      # ... or lost inside these [start, end) windows
          ahrs_yaw_deg: 3
          rangefinder: {max_range_m: 12}   # optional downward rangefinder ({} or true: the defaults)
          optical_flow: {}                 # optional optical flow (needs the rangefinder)
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
        elif key in _NESTED:
            out[key] = None if value is False else _parse_nested(value, _NESTED[key], w)
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
    if out.get("optical_flow") is not None and out.get("rangefinder") is None:
        raise ConfigError(f"{where}.optical_flow: needs a rangefinder (the flow is scaled by the measured range)")
    return SensorConfig(**out)
