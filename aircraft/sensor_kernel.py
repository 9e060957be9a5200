"""The geofence unit's sensors, compiled: :class:`aircraft.sensors.SensorSuite`'s step on arrays.

One question: given the truth of this step, what do the unit's GNSS receiver,
barometer, pitot and AHRS report? :class:`SensorArrays` answers it as
:meth:`SensorSuite.sample` does, bit for bit (``tests/test_sensing_kernel.py``),
with its state in float arrays so that the simulated flight's compiled sensing
step (:mod:`scenarios.flight.sensing_kernel`) can call :func:`sensors_step`
from machine code. :class:`SensorSuite` stays the readable reference (and the
one the tests of the error models use); its module docstring states the models.

Noise: the same four seeded streams (``SeedSequence(seed, spawn_key=(k,))``),
consumed in the same order. A stream is a row of drawn normals and a read index;
:meth:`SensorArrays.refill` tops the rows up in place between steps (a step
draws at most :data:`MAX_DRAWS_PER_STEP` from a stream).

The pending GNSS messages (solved, not yet delivered) are a ring of rows
``(t, lat, lon, alt, ve, vn, vu, h_acc, v_acc, valid)``.
"""

from __future__ import annotations

import math

import numpy as np

from aircraft.sensors import (
    AHRS_STREAM,
    BARO_STREAM,
    GPS_STREAM,
    NORMAL_BLOCK,
    PITOT_STREAM,
    SENSOR_STREAMS,
    SensorConfig,
    stream_generator,
)
from geofence.dynamics import isa_density_ratio
from geofence.geodesy import radii_of_curvature_m
from geofence.jit import COMPILED, jitable, numba

__all__ = ["MAX_DRAWS_PER_STEP", "SensorArrays", "ring_rows", "sensors_step"]

_TWO_PI = 2.0 * math.pi
_EPS_S = 1e-9

MAX_DRAWS_PER_STEP = 32
"""The most normals one step can take from one stream (two GNSS solutions of nine draws each, at the first step)."""

# state vector S
T_LAST, HAS_T_LAST, NEXT_EPOCH, HAS_NEXT_EPOCH, LAST_EPOCH, HAS_LAST_EPOCH, NEXT_ARRIVAL, HEAD, COUNT = range(9)
GM0 = 9  # Gauss-Markov values: GNSS bias e, n, u; baro drift; AHRS roll, pitch, yaw
N_STATE = GM0 + 7
# constants C
(
    PERIOD, LATENCY, PREFILL, HAS_PITOT, H_WHITE, V_WHITE, VEL_H, VEL_V, BARO_NOISE, AIRSPEED_NOISE,
    H_ACC, V_ACC, FAIL_AT, N_OUTAGES,
) = range(14)  # fmt: skip
GM_SIGMA0 = 14  # the seven processes' sigma, then their tau
GM_TAU0 = GM_SIGMA0 + 7
N_CONST = GM_TAU0 + 7
# pool read index per stream: GPS, BARO, PITOT, AHRS (aircraft.sensors' stream order)


def ring_rows(cfg: SensorConfig) -> int:
    """Rows of the pending GNSS messages' ring: more than are ever pending, the solutions of one latency (one per
    fix period) plus the pre-filled first one and a margin."""
    return int(math.ceil(cfg.gps_latency_s * cfg.gps_rate_hz)) + 4


@jitable
def _gm_step(S: np.ndarray, C: np.ndarray, k: int, dt: float, pool: np.ndarray, idx: np.ndarray, stream: int) -> float:
    """:meth:`aircraft.sensors._GaussMarkov.step` of process ``k`` drawing from ``pool``."""
    sigma = C[GM_SIGMA0 + k]
    if sigma <= 0.0:
        return 0.0
    tau = C[GM_TAU0 + k]
    a = math.exp(-dt / tau) if tau > 0.0 else 0.0
    b = sigma * math.sqrt(max(0.0, 1.0 - a * a))
    i = idx[stream]
    idx[stream] = i + 1
    value = a * S[GM0 + k] + b * pool[i]
    S[GM0 + k] = value
    return value


@jitable
def _draw(pool: np.ndarray, idx: np.ndarray, stream: int) -> float:
    i = idx[stream]
    idx[stream] = i + 1
    return pool[i]


@jitable
def _gps_lost(C: np.ndarray, outages: np.ndarray, t: float) -> bool:
    """:meth:`SensorConfig.gps_lost` (``FAIL_AT`` is inf without a failure)."""
    if t >= C[FAIL_AT]:
        return True
    for w in range(outages.shape[0]):
        if outages[w, 0] <= t < outages[w, 1]:
            return True
    return False


@jitable
def _solve(
    S: np.ndarray, C: np.ndarray, outages: np.ndarray, pending: np.ndarray, gps: np.ndarray, idx: np.ndarray,
    t: float, lat_deg: float, lon_deg: float, alt: float, ve: float, vn: float, vu: float,
) -> None:  # fmt: skip
    """:meth:`SensorSuite._solve` then :meth:`SensorSuite._queue`: one solution appended to the pending ring."""
    dt = C[PERIOD] if S[HAS_LAST_EPOCH] == 0.0 else t - S[LAST_EPOCH]
    S[LAST_EPOCH] = t
    S[HAS_LAST_EPOCH] = 1.0
    be = _gm_step(S, C, 0, dt, gps, idx, GPS_STREAM)
    bn = _gm_step(S, C, 1, dt, gps, idx, GPS_STREAM)
    bu = _gm_step(S, C, 2, dt, gps, idx, GPS_STREAM)
    de = be + C[H_WHITE] * _draw(gps, idx, GPS_STREAM)
    dn = bn + C[H_WHITE] * _draw(gps, idx, GPS_STREAM)
    du = bu + C[V_WHITE] * _draw(gps, idx, GPS_STREAM)
    nve = C[VEL_H] * _draw(gps, idx, GPS_STREAM)
    nvn = C[VEL_H] * _draw(gps, idx, GPS_STREAM)
    nvu = C[VEL_V] * _draw(gps, idx, GPS_STREAM)
    count = int(S[COUNT])
    ring = pending.shape[0]
    if count >= ring:  # not reached: ring_rows() holds every solution of one latency and more
        raise ValueError("the pending GNSS messages' ring is full")
    row = (int(S[HEAD]) + count) % ring
    S[COUNT] = count + 1
    if count == 0:
        S[NEXT_ARRIVAL] = t + C[LATENCY] - _EPS_S
    r = pending[row]
    if _gps_lost(C, outages, t):
        r[0] = t
        r[1:7] = math.nan
        r[7] = math.inf
        r[8] = math.inf
        r[9] = 0.0
        return
    lat = math.radians(lat_deg)
    n_rad, m_rad = radii_of_curvature_m(lat)  # prime vertical, meridian
    r[0] = t
    r[1] = lat_deg + math.degrees(dn / (m_rad + alt))
    r[2] = lon_deg + math.degrees(de / ((n_rad + alt) * math.cos(lat)))
    r[3] = alt + du
    r[4] = ve + nve
    r[5] = vn + nvn
    r[6] = vu + nvu
    r[7] = C[H_ACC]
    r[8] = C[V_ACC]
    r[9] = 1.0


def _sensors_step(
    S: np.ndarray,
    C: np.ndarray,
    outages: np.ndarray,
    pending: np.ndarray,
    gps: np.ndarray,
    baro_pool: np.ndarray,
    pitot: np.ndarray,
    ahrs: np.ndarray,
    idx: np.ndarray,
    fix: np.ndarray,
    t: float,
    lat_deg: float,
    lon_deg: float,
    alt: float,
    ve: float,
    vn: float,
    vu: float,
    airspeed_true: float,
    roll: float,
    pitch: float,
    yaw: float,
) -> tuple[bool, float, float, float, float, float]:
    """:meth:`SensorSuite.sample` of one truth state: ``(fix delivered, airspeed, baro, roll, pitch, yaw)``.

    A delivered fix is written to ``fix`` (a ring row's ten fields); the air data and attitude samples carry
    the time ``t``. ``airspeed`` is NaN without a pitot.
    """
    dt = 0.0 if S[HAS_T_LAST] == 0.0 else t - S[T_LAST]
    if dt < 0.0:
        raise ValueError("sensor time went backwards")
    S[T_LAST] = t
    S[HAS_T_LAST] = 1.0
    period = C[PERIOD]
    # GNSS: solve at the epochs, deliver after the latency
    if S[HAS_NEXT_EPOCH] == 0.0:
        lat = C[LATENCY]
        if C[PREFILL] != 0.0 and lat > 0.0:
            # the receiver was already running: its previous epoch (truth extrapolated back) arrives now
            lat_r = math.radians(lat_deg)
            n_rad, m_rad = radii_of_curvature_m(lat_r)
            de, dn, du = ve * lat, vn * lat, vu * lat
            _solve(
                S, C, outages, pending, gps, idx, t - lat,
                lat_deg - math.degrees(dn / (m_rad + alt)),
                lon_deg - math.degrees(de / ((n_rad + alt) * math.cos(lat_r))),
                alt - du, ve, vn, vu,
            )  # fmt: skip
            S[NEXT_EPOCH] = t - lat + period
        else:
            S[NEXT_EPOCH] = t
        S[HAS_NEXT_EPOCH] = 1.0
    if t >= S[NEXT_EPOCH] - _EPS_S:
        _solve(S, C, outages, pending, gps, idx, t, lat_deg, lon_deg, alt, ve, vn, vu)
        while S[NEXT_EPOCH] <= t + _EPS_S:
            S[NEXT_EPOCH] += period
    delivered = False
    if t >= S[NEXT_ARRIVAL]:
        # the fixes that have arrived by t (at least one); if several are due, the newest wins
        head = int(S[HEAD])
        count = int(S[COUNT])
        fix[:] = pending[head]
        head = (head + 1) % pending.shape[0]
        count -= 1
        while count > 0 and t >= pending[head, 0] + C[LATENCY] - _EPS_S:
            fix[:] = pending[head]
            head = (head + 1) % pending.shape[0]
            count -= 1
        S[HEAD] = head
        S[COUNT] = count
        S[NEXT_ARRIVAL] = pending[head, 0] + C[LATENCY] - _EPS_S if count > 0 else math.inf
        delivered = True
    # barometer: pressure altitude referenced at start-up to the true altitude (+ drift)
    drift = _gm_step(S, C, 3, dt, baro_pool, idx, BARO_STREAM) if dt > 0.0 else S[GM0 + 3]
    baro = alt + drift + C[BARO_NOISE] * _draw(baro_pool, idx, BARO_STREAM)
    airspeed = math.nan
    if C[HAS_PITOT] != 0.0:
        airspeed = airspeed_true * math.sqrt(isa_density_ratio(alt)) + C[AIRSPEED_NOISE] * _draw(pitot, idx, PITOT_STREAM)
        if airspeed < 0.0:
            airspeed = 0.0
    if dt > 0.0:
        dr = _gm_step(S, C, 4, dt, ahrs, idx, AHRS_STREAM)
        dp = _gm_step(S, C, 5, dt, ahrs, idx, AHRS_STREAM)
        dy = _gm_step(S, C, 6, dt, ahrs, idx, AHRS_STREAM)
    else:
        dr, dp, dy = S[GM0 + 4], S[GM0 + 5], S[GM0 + 6]
    return delivered, airspeed, baro, roll + dr, pitch + dp, (yaw + dy) % _TWO_PI


sensors_step = numba.njit(cache=True)(_sensors_step) if COMPILED else _sensors_step
"""The compiled :func:`_sensors_step` (the Python function itself without numba)."""


class SensorArrays:
    """A :class:`~aircraft.sensors.SensorSuite`'s configuration and state as the arrays :func:`sensors_step` steps.

    Built from the same arguments as the suite; ``args()`` gives the arrays in :func:`sensors_step`'s order,
    then ``refill()`` after each step keeps every noise pool :data:`MAX_DRAWS_PER_STEP` deep.
    """

    def __init__(
        self, config: SensorConfig | None = None, *, has_pitot: bool = True, seed: int | None = None, prefill: bool = True
    ) -> None:
        cfg = config or SensorConfig()
        s = cfg.seed if cfg.seed is not None else (seed if seed is not None else 0)
        self._rngs = [stream_generator(s, k) for k in SENSOR_STREAMS]
        self.pools = np.stack([rng.standard_normal(NORMAL_BLOCK) for rng in self._rngs])
        """One row of normals per stream, read from ``idx[stream]`` on (refilled in place)."""
        self.idx = np.zeros(len(SENSOR_STREAMS), np.int64)
        rp = math.radians(cfg.ahrs_roll_pitch_deg)
        sigmas = (cfg.gps_h_bias_m, cfg.gps_h_bias_m, cfg.gps_v_bias_m, cfg.baro_drift_m, rp, rp, math.radians(cfg.ahrs_yaw_deg))
        taus = (cfg.gps_bias_tau_s,) * 3 + (cfg.baro_drift_tau_s,) + (cfg.ahrs_tau_s,) * 3
        streams = (GPS_STREAM,) * 3 + (BARO_STREAM,) + (AHRS_STREAM,) * 3
        C = np.zeros(N_CONST)
        C[PERIOD] = 1.0 / cfg.gps_rate_hz
        C[LATENCY] = cfg.gps_latency_s
        C[PREFILL] = float(prefill)
        C[HAS_PITOT] = float(has_pitot)
        C[H_WHITE], C[V_WHITE] = cfg.gps_h_white_m, cfg.gps_v_white_m
        C[VEL_H], C[VEL_V] = cfg.gps_vel_h_noise_mps, cfg.gps_vel_v_noise_mps
        C[BARO_NOISE], C[AIRSPEED_NOISE] = cfg.baro_noise_m, cfg.airspeed_noise_mps
        C[H_ACC], C[V_ACC] = cfg.gps_h_sigma_m, cfg.gps_v_sigma_m
        C[FAIL_AT] = cfg.gps_fail_at_s if cfg.gps_fail_at_s is not None else math.inf
        C[N_OUTAGES] = len(cfg.gps_outages)
        S = np.zeros(N_STATE)
        for k, (sigma, tau, stream) in enumerate(zip(sigmas, taus, streams)):
            C[GM_SIGMA0 + k], C[GM_TAU0 + k] = sigma, tau
            if sigma > 0.0:  # start in the stationary distribution (the suite's construction order)
                S[GM0 + k] = sigma * self.pools[stream][self.idx[stream]]
                self.idx[stream] += 1
        S[NEXT_ARRIVAL] = math.inf
        self.state, self.const = S, C
        self.outages = np.array(cfg.gps_outages, dtype=np.float64).reshape(-1, 2)
        self.pending = np.zeros((ring_rows(cfg), 10))
        self.fix = np.zeros(10)

    def args(self) -> tuple[np.ndarray, ...]:
        """``(S, C, outages, pending, gps, baro, pitot, ahrs, idx, fix)``: :func:`sensors_step`'s array arguments
        (the pools are views of :attr:`pools`' rows; they stay valid across :meth:`refill`)."""
        return (self.state, self.const, self.outages, self.pending, *self.pools, self.idx, self.fix)

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
