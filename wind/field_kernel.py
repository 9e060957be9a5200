"""The wind field, compiled: a steady + Dryden + gusts field's ``sample`` on arrays.

One question: what wind does the vehicle feel at this time and place? For the
fields :func:`wind.config.wind_from_config` builds (a steady wind with its
height profile, Dryden turbulence and a gust train convected by it, or any of
them alone) :class:`WindArrays` answers it as the field objects'
``sample`` does, bit for bit (``tests/test_wind_kernel.py``), in one compiled
call: the same float operations in the same order, the Dryden filter's state
and its noise pool (the same seeded blocks, five normals a step) and the gusts'
distances travelled held in arrays. The objects (:class:`~wind.steady.SteadyWind`,
:class:`~wind.dryden.DrydenTurbulence`, :class:`~wind.gust.GustTrain`,
:class:`~wind.field.CompositeWind`) stay the readable reference; their module
docstrings state the models. :func:`compiled_wind` returns None for any other
field (the simulated flight then samples the objects).
"""

from __future__ import annotations

import math
from dataclasses import replace
from math import sqrt
from typing import Callable

import numpy as np

from geofence.jit import COMPILED, entry_point, jitable, numba
from wind.dryden import FT_M, NORMALS_PER_STEP, POOL_NORMALS, DrydenTurbulence, turbulence_step
from wind.field import CalmWind, CompositeWind, Vec3, WindField, toward_unit
from wind.gust import MAX_VELOCITY_DT_S, GustTrain
from wind.steady import LogLawProfile, PowerLawProfile, SteadyWind

__all__ = ["WindArrays", "compiled_wind"]

# constants F: which parts, the steady wind and its profile, the turbulence's constants
HAS_STEADY, HAS_DRYDEN, HAS_GUSTS, N_PARTS, STEADY_E, STEADY_N, PROFILE, PROFILE_A, PROFILE_B = range(9)
DRY_MIN_SPEED, DRY_HMIN_FT, DRY_SIGMA_W, DRY_HAS_MEAN, GUST_HAS_MEAN = range(9, 14)
N_CONST = 14
UNIFORM, POWER_LAW, LOG_LAW = 0, 1, 2
# state Z: the turbulence's (time, filter states, output) and the gust train's (time, position, output, first live)
D_HAS_T, D_T, D_XU, D_XV1, D_XV2, D_XW1, D_XW2, D_OUT_E, D_OUT_N, D_OUT_U = range(10)
G_HAS_T, G_T, G_HAS_POS, G_POS_E, G_POS_N, G_OUT_E, G_OUT_N, G_OUT_U, G_FIRST_LIVE, POOL_IDX = range(10, 20)
N_STATE = 20
# gust table rows: onset, amplitude, length, hold, vertical, penetration speed (nan: convected), speed floor,
# toward east, toward north; then (the state) the distance travelled and the passed flag (1.0)
GUST_COLUMNS = 9


@jitable
def _steady_mean(F: np.ndarray, up_m: float) -> tuple[float, float]:
    """:meth:`SteadyWind.mean` (horizontal; its up part is 0)."""
    kind = F[PROFILE]
    if kind == UNIFORM:
        return F[STEADY_E], F[STEADY_N]
    if kind == POWER_LAW:
        k = 0.0 if not up_m > 0.0 else (up_m / F[PROFILE_B]) ** F[PROFILE_A]
    else:
        z0 = F[PROFILE_A]
        k = 0.0 if not up_m > z0 else math.log(up_m / z0) / math.log(F[PROFILE_B] / z0)
    return F[STEADY_E] * k, F[STEADY_N] * k


@jitable
def _dryden(F: np.ndarray, Z: np.ndarray, pool: np.ndarray, t_s: float, up_m: float, airspeed_mps: float) -> tuple[float, float, float]:  # fmt: skip
    """:meth:`DrydenTurbulence.sample` (the position does not enter)."""
    has_last = Z[D_HAS_T] != 0.0
    last = Z[D_T]
    if has_last and t_s == last:
        return Z[D_OUT_E], Z[D_OUT_N], Z[D_OUT_U]
    if has_last and not t_s > last:
        raise ValueError("DrydenTurbulence.sample: time went backwards")
    me, mn = _steady_mean(F, up_m) if F[DRY_HAS_MEAN] != 0.0 else (0.0, 0.0)
    i = int(Z[POOL_IDX])
    Z[POOL_IDX] = i + NORMALS_PER_STEP
    state, out = turbulence_step(
        (Z[D_XU], Z[D_XV1], Z[D_XV2], Z[D_XW1], Z[D_XW2]), has_last, t_s - last if has_last else 0.0, me, mn, up_m,
        airspeed_mps, F[DRY_MIN_SPEED], F[DRY_HMIN_FT], F[DRY_SIGMA_W], pool[i], pool[i + 1], pool[i + 2], pool[i + 3],
        pool[i + 4],
    )  # fmt: skip
    Z[D_XU], Z[D_XV1], Z[D_XV2], Z[D_XW1], Z[D_XW2] = state
    Z[D_T] = t_s
    Z[D_HAS_T] = 1.0
    Z[D_OUT_E], Z[D_OUT_N], Z[D_OUT_U] = out
    return Z[D_OUT_E], Z[D_OUT_N], Z[D_OUT_U]


@jitable
def _gust_shape(length: float, hold: float, x_m: float) -> float:
    """:meth:`Gust.shape`."""
    d = length
    if x_m <= 0.0:
        return 0.0
    if x_m < d:
        return 0.5 * (1.0 - math.cos(math.pi * x_m / d))
    x_m -= d + hold
    if x_m <= 0.0:
        return 1.0
    if x_m < d:
        return 0.5 * (1.0 + math.cos(math.pi * x_m / d))
    return 0.0


@jitable
def _gusts(F: np.ndarray, Z: np.ndarray, G: np.ndarray, xs: np.ndarray, passed: np.ndarray, t_s: float, east_m: float, north_m: float, up_m: float, airspeed_mps: float) -> tuple[float, float, float]:  # fmt: skip
    """:meth:`GustTrain.sample`."""
    has_last = Z[G_HAS_T] != 0.0
    last = Z[G_T]
    if has_last and t_s == last:
        return Z[G_OUT_E], Z[G_OUT_N], Z[G_OUT_U]
    if has_last and not t_s > last:
        raise ValueError("GustTrain.sample: time went backwards")
    Z[G_T] = t_s
    Z[G_HAS_T] = 1.0
    has_pos = Z[G_HAS_POS] != 0.0
    pe, pn = Z[G_POS_E], Z[G_POS_N]
    Z[G_HAS_POS], Z[G_POS_E], Z[G_POS_N] = 1.0, east_m, north_m
    n_gusts = G.shape[0]
    live = int(Z[G_FIRST_LIVE])
    if live == n_gusts or t_s <= G[live, 0]:
        Z[G_OUT_E] = Z[G_OUT_N] = Z[G_OUT_U] = 0.0
        return 0.0, 0.0, 0.0
    me = mn = 0.0
    if F[GUST_HAS_MEAN] != 0.0:
        me, mn = _steady_mean(F, up_m)
    dt = t_s - last if has_last else 0.0
    if has_pos and 0.0 < dt <= MAX_VELOCITY_DT_S:
        re = (east_m - pe) / dt - me
        rn = (north_m - pn) / dt - mn
        v = sqrt(re * re + rn * rn)
    else:
        w = sqrt(me * me + mn * mn)
        v = airspeed_mps if airspeed_mps > w else w
    e = n = u = 0.0
    for i in range(live, n_gusts):
        onset = G[i, 0]
        if t_s <= onset:
            break
        if passed[i] != 0.0:
            continue
        if not math.isnan(G[i, 5]):
            x = G[i, 5] * (t_s - onset)
        else:
            t0 = onset if not has_last or last < onset else last
            f = G[i, 6]
            x = xs[i] + (v if v > f else f) * (t_s - t0)
            xs[i] = x
        k = _gust_shape(G[i, 2], G[i, 3], x)
        if k != 0.0:
            a = G[i, 1] * k
            e += a * G[i, 7]
            n += a * G[i, 8]
            u += G[i, 4] * k
        elif x - (G[i, 2] + G[i, 3]) >= G[i, 2]:  # Gust.passed
            passed[i] = 1.0
            while live < n_gusts and passed[live] != 0.0:
                live += 1
            Z[G_FIRST_LIVE] = live
    Z[G_OUT_E], Z[G_OUT_N], Z[G_OUT_U] = e, n, u
    return e, n, u


def _wind_sample(
    FZ: np.ndarray, pool: np.ndarray, GX: np.ndarray, t_s: float, east_m: float, north_m: float, up_m: float,
    airspeed_mps: float,
) -> tuple[float, float, float, bool]:  # fmt: skip
    """The field's ``sample``: ``(east, north, up, the turbulence's noise pool needs its next block)``.

    Three arrays (a compiled call pays per array): the constants then the state (``FZ``), the turbulence's
    noise, and the gust table with each gust's distance travelled and passed flag as its last two columns."""
    F, Z = FZ[:N_CONST], FZ[N_CONST:]
    G, xs, passed = GX[:, :GUST_COLUMNS], GX[:, GUST_COLUMNS], GX[:, GUST_COLUMNS + 1]
    e = n = u = 0.0
    single = F[N_PARTS] == 1.0  # one part alone: its own numbers (no sum from 0.0, which would turn -0.0 into 0.0)
    if F[HAS_STEADY] != 0.0:
        se, sn = _steady_mean(F, up_m)
        if single:
            return se, sn, 0.0, False
        e += se
        n += sn
        u += 0.0
    if F[HAS_DRYDEN] != 0.0:
        de, dn, du = _dryden(F, Z, pool, t_s, up_m, airspeed_mps)
        if single:
            return de, dn, du, Z[POOL_IDX] + NORMALS_PER_STEP > pool.shape[0]
        e += de
        n += dn
        u += du
    if F[HAS_GUSTS] != 0.0:
        ge, gn, gu = _gusts(F, Z, G, xs, passed, t_s, east_m, north_m, up_m, airspeed_mps)
        if single:
            return ge, gn, gu, False
        e += ge
        n += gn
        u += gu
    return e, n, u, Z[POOL_IDX] + NORMALS_PER_STEP > pool.shape[0]


wind_sample = numba.njit(cache=True)(_wind_sample) if COMPILED else _wind_sample
"""The compiled :func:`_wind_sample` (the Python function itself without numba)."""


class WindArrays:
    """A wind field's configuration and state as the arrays :func:`wind_sample` steps (see :func:`compiled_wind`).

    :meth:`sample` and :meth:`first_activation` stand in for the field's own; the field object itself is not
    advanced.
    """

    def __init__(self, steady: SteadyWind | None, dryden: DrydenTurbulence | None, gusts: GustTrain | None) -> None:
        F = np.zeros(N_CONST)
        F[HAS_STEADY], F[HAS_DRYDEN], F[HAS_GUSTS] = (float(x is not None) for x in (steady, dryden, gusts))
        F[N_PARTS] = F[HAS_STEADY] + F[HAS_DRYDEN] + F[HAS_GUSTS]
        if steady is not None:
            F[STEADY_E], F[STEADY_N] = steady.reference_enu_mps
            p = steady.profile
            if isinstance(p, PowerLawProfile):
                F[PROFILE], F[PROFILE_A], F[PROFILE_B] = POWER_LAW, p.exponent, p.reference_height_m
            elif isinstance(p, LogLawProfile):
                F[PROFILE], F[PROFILE_A], F[PROFILE_B] = LOG_LAW, p.roughness_length_m, p.reference_height_m
        Z = np.zeros(N_STATE)
        self._rng = None
        self.pool = np.zeros(NORMALS_PER_STEP)
        if dryden is not None:
            F[DRY_MIN_SPEED], F[DRY_HMIN_FT], F[DRY_SIGMA_W] = (
                dryden.min_speed_mps,
                dryden.min_height_m / FT_M,
                0.1 * dryden.w20_mps,
            )
            F[DRY_HAS_MEAN] = float(dryden.mean_wind is not None)
            self._rng = np.random.default_rng(dryden.seed)  # a fresh copy of its generator: the same blocks
            self.pool = self._rng.standard_normal(POOL_NORMALS)
        self._gusts = gusts
        if gusts is not None:
            F[GUST_HAS_MEAN] = float(gusts.mean_wind is not None)
            gusts.reset()
        self._FZ = np.concatenate((F, Z))
        self._kernel: Callable = wind_sample
        self.F, self.Z = self._FZ[:N_CONST], self._FZ[N_CONST:]  # views
        self._set_gusts(gusts.gusts if gusts is not None else (), np.zeros(len(gusts.gusts) if gusts is not None else 0))
        self._armed = False

    def _set_gusts(self, gusts: tuple, xs: np.ndarray) -> None:
        """The gust table of ``gusts`` (sorted by onset) with their distances travelled ``xs``; none passed yet."""
        train = self._gusts
        rows = [
            (
                g.onset_s,
                g.amplitude_mps,
                g.length_m,
                g.hold_m,
                g.vertical_mps,
                math.nan if g.penetration_speed_mps is None else g.penetration_speed_mps,
                max(train.min_speed_mps, g.length_m / train.max_rise_time_s) if train is not None else 0.0,
                *toward_unit(g.from_deg),
            )  # fmt: skip
            for g in gusts
        ]
        G = np.array(rows, dtype=np.float64).reshape(-1, GUST_COLUMNS)
        self._GX = np.column_stack((G, np.asarray(xs, dtype=np.float64), np.zeros(len(gusts))))
        self.Z[G_FIRST_LIVE] = 0.0
        self._gust_list = tuple(gusts)

    def sample(self, t_s: float, east_m: float, north_m: float, up_m: float, airspeed_mps: float) -> Vec3:
        """The field's ``sample`` (the same numbers)."""
        kernel = self._kernel
        e, n, u, low = kernel(self._FZ, self.pool, self._GX, t_s, east_m, north_m, up_m, airspeed_mps)
        if kernel is wind_sample:  # after its first call, by its entry point (geofence.jit: the arrays are ours,
            self._kernel = entry_point(kernel)  # the pool rebuilt as it was made: float64, 1-D, C)
        if low:
            self.refill()
        return (e, n, u)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:func:`wind_sample`'s arrays ``(FZ, pool, GX)``, for a caller whose own compiled step samples the field
        (:mod:`scenarios.flight.step_kernel`). The pool is a new array after :meth:`refill`, the gust table after
        :meth:`first_activation`: ask again after either."""
        return self._FZ, self.pool, self._GX

    def refill(self) -> None:
        """The turbulence's next block of noise, after a sample said its pool runs low (the pool is a new array)."""
        if self._rng is not None:
            i = int(self.Z[POOL_IDX])
            self.pool = np.concatenate((self.pool[i:], self._rng.standard_normal(POOL_NORMALS)))
            self.Z[POOL_IDX] = 0.0

    def first_activation(self, t_s: float) -> None:
        """:meth:`GustTrain.first_activation`: the activation-timed gusts join the schedule, onsets from ``t_s``."""
        train = self._gusts
        if self._armed or train is None or not train.after_first_activation:
            self._armed = True
            return
        self._armed = True
        pairs = list(zip(self._gust_list, self._GX[:, GUST_COLUMNS].tolist())) + [
            (replace(g, onset_s=t_s + g.onset_s), 0.0) for g in train.after_first_activation
        ]
        pairs.sort(key=lambda p: p[0].onset_s)
        self._set_gusts(tuple(g for g, _ in pairs), np.array([x for _, x in pairs]))


def compiled_wind(field: WindField) -> WindArrays | None:
    """:class:`WindArrays` for a field :func:`wind.config.wind_from_config` builds, else None.

    Supported: a :class:`SteadyWind` (any profile), a :class:`DrydenTurbulence` and a :class:`GustTrain`, each
    at most once and in that order, alone or in a :class:`CompositeWind`, the turbulence and the gusts convected
    by that steady wind (or by none). The field must be fresh (not sampled yet).
    """
    if isinstance(field, CalmWind):
        return None
    parts = field.components if isinstance(field, CompositeWind) else (field,)
    steady = dryden = gusts = None
    order = 0
    for p in parts:
        if type(p) is SteadyWind and order < 1:
            steady, order = p, 1
        elif type(p) is DrydenTurbulence and order < 2:
            dryden, order = p, 2
        elif type(p) is GustTrain and order < 3:
            gusts, order = p, 3
        else:
            return None
    for convected in (dryden, gusts):
        if convected is not None and convected.mean_wind is not None and convected.mean_wind is not steady:
            return None
    return WindArrays(steady, dryden, gusts)
