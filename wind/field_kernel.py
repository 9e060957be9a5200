"""The wind field in one compiled call: a steady + Dryden + gusts field's ``sample`` on three arrays.

One question: what wind does the vehicle feel at this time and place, inside a caller's compiled step
(:mod:`scenarios.flight.step_kernel`)? For the fields :func:`wind.config.wind_from_config` builds (a steady wind
with its height profile, Dryden turbulence and a gust train convected by it, or any of them alone)
:func:`wind_sample` sums the parts by the functions their objects sample with (:func:`wind.steady.steady_mean`,
:func:`wind.dryden.dryden_sample`, :func:`wind.gust.gusts_sample`). :class:`WindArrays` holds a fresh copy of
each part living in one float array (the :data:`WIND_PARTS` header, then the turbulence's and the gust train's
memory), so the part objects draw the noise and schedule the gusts here as they do alone.
:func:`compiled_wind` returns None for any other field (the simulated flight then samples the objects).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from geofence.jit import compiled, entry_point
from wind.dryden import DRYDEN_SIZE, NORMALS_PER_STEP, DrydenTurbulence, dryden_sample
from wind.field import CalmWind, CompositeWind, Vec3, WindField
from wind.gust import GUST_COLUMNS, GUST_TRAIN_SIZE, GustTrain, gusts_sample
from wind.steady import SteadyWind, steady_mean

__all__ = ["WindArrays", "compiled_wind", "wind_sample"]

WIND_PARTS = np.dtype(
    (
        np.record,
        [
            ("has_steady", np.float64),  # which parts (1.0) and how many
            ("has_dryden", np.float64),
            ("has_gusts", np.float64),
            ("n_parts", np.float64),
            ("dryden_convected", np.float64),  # 1: the turbulence's mean wind is the steady part, else none
            ("gusts_convected", np.float64),  # 1: the gusts' mean wind is the steady part, else none
            ("steady_east_mps", np.float64),  # the steady wind at the reference height
            ("steady_north_mps", np.float64),
            ("profile_law", np.float64),  # its profile's coefficients (wind.steady.profile_factor)
            ("profile_a", np.float64),
            ("profile_b", np.float64),
        ],
    )
)
"""The header of :class:`WindArrays`' memory: which parts, and the steady wind's constants."""
HEADER_SIZE = WIND_PARTS.itemsize // 8
DRYDEN_AT = HEADER_SIZE
GUSTS_AT = DRYDEN_AT + DRYDEN_SIZE
MEMORY_SIZE = GUSTS_AT + GUST_TRAIN_SIZE
"""Float64 slots of the memory: the header, the turbulence's (:data:`wind.dryden.DRYDEN`), the gust train's
(:data:`wind.gust.GUST_TRAIN`)."""


@compiled
def wind_sample(
    FZ: np.ndarray, pool: np.ndarray, GX: np.ndarray, t_s: float, east_m: float, north_m: float, up_m: float,
    airspeed_mps: float,
) -> tuple[float, float, float, bool]:  # fmt: skip
    """The field's ``sample``: ``(east, north, up, the turbulence's noise pool needs its next block)``.

    Three arrays (a compiled call pays per array): the memory ``FZ`` (:data:`MEMORY_SIZE` slots), the
    turbulence's noise and the gust table (:func:`wind.gust.gust_table`)."""
    h = FZ[:HEADER_SIZE].view(WIND_PARTS)[0]
    e = n = u = 0.0
    se = sn = 0.0
    single = h.n_parts == 1.0  # one part alone: its own numbers (no sum from 0.0, which would turn -0.0 into 0.0)
    if h.has_steady != 0.0:
        se, sn = steady_mean(h.steady_east_mps, h.steady_north_mps, h.profile_law, h.profile_a, h.profile_b, up_m)
        if single:
            return se, sn, 0.0, False
        e += se
        n += sn
        u += 0.0
    low = False
    if h.has_dryden != 0.0:
        me, mn = (se, sn) if h.dryden_convected != 0.0 else (0.0, 0.0)
        de, dn, du, low = dryden_sample(FZ[DRYDEN_AT:GUSTS_AT], pool, t_s, up_m, airspeed_mps, me, mn)
        if single:
            return de, dn, du, low
        e += de
        n += dn
        u += du
    if h.has_gusts != 0.0:
        me, mn = (se, sn) if h.gusts_convected != 0.0 else (0.0, 0.0)
        ge, gn, gu = gusts_sample(FZ[GUSTS_AT:MEMORY_SIZE], GX, t_s, east_m, north_m, airspeed_mps, me, mn)
        if single:
            return ge, gn, gu, False
        e += ge
        n += gn
        u += gu
    return e, n, u, low


class WindArrays:
    """A wind field's parts living in the arrays :func:`wind_sample` steps (see :func:`compiled_wind`).

    :meth:`sample` and :meth:`first_activation` stand in for the field's own; the field object itself is not
    advanced (its parts are copied, fresh).
    """

    def __init__(self, steady: SteadyWind | None, dryden: DrydenTurbulence | None, gusts: GustTrain | None) -> None:
        self._FZ = np.zeros(MEMORY_SIZE)
        h = self._FZ[:HEADER_SIZE].view(WIND_PARTS)[0]
        h.has_steady, h.has_dryden, h.has_gusts = (float(x is not None) for x in (steady, dryden, gusts))
        h.n_parts = h.has_steady + h.has_dryden + h.has_gusts
        if steady is not None:
            h.steady_east_mps, h.steady_north_mps = steady.reference_enu_mps
            h.profile_law, h.profile_a, h.profile_b = steady.profile.coefficients
        self._dryden = dryden.copy_into(self._FZ[DRYDEN_AT:GUSTS_AT]) if dryden is not None else None
        self._gusts = gusts.copy_into(self._FZ[GUSTS_AT:MEMORY_SIZE]) if gusts is not None else None
        h.dryden_convected = float(dryden is not None and dryden.mean_wind is not None)
        h.gusts_convected = float(gusts is not None and gusts.mean_wind is not None)
        self._no_pool = np.zeros(NORMALS_PER_STEP)
        self._no_gusts = np.zeros((0, GUST_COLUMNS))
        self._kernel: Callable = wind_sample
        self._args = self.arrays()

    def sample(self, t_s: float, east_m: float, north_m: float, up_m: float, airspeed_mps: float) -> Vec3:
        """The field's ``sample`` (the same numbers)."""
        kernel = self._kernel
        e, n, u, low = kernel(*self._args, t_s, east_m, north_m, up_m, airspeed_mps)
        if kernel is wind_sample:  # after its first call, by its entry point (geofence.jit: the arrays are ours,
            self._kernel = entry_point(kernel)  # the pool and the table rebuilt as they were made: float64, C)
        if low:
            self.refill()
        return (e, n, u)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:func:`wind_sample`'s arrays ``(FZ, pool, GX)``, for a caller whose own compiled step samples the field
        (:mod:`scenarios.flight.step_kernel`). The pool is a new array after :meth:`refill`, the gust table after
        :meth:`first_activation`: ask again after either."""
        pool = self._dryden.pool if self._dryden is not None else self._no_pool
        table = self._gusts.table if self._gusts is not None else self._no_gusts
        return self._FZ, pool, table

    def refill(self) -> None:
        """The turbulence's next block of noise, after a sample said its pool runs low (the pool is a new array)."""
        if self._dryden is not None:
            self._dryden.refill()
            self._args = self.arrays()

    def first_activation(self, t_s: float) -> None:
        """:meth:`GustTrain.first_activation`: the activation-timed gusts join the schedule, onsets from ``t_s``."""
        if self._gusts is not None:
            self._gusts.first_activation(t_s)
            self._args = self.arrays()


def compiled_wind(field: WindField) -> WindArrays | None:
    """:class:`WindArrays` for a field :func:`wind.config.wind_from_config` builds, else None.

    Supported: a :class:`SteadyWind` (any profile), a :class:`DrydenTurbulence` and a :class:`GustTrain`, each
    at most once and in that order, alone or in a :class:`CompositeWind`, the turbulence and the gusts convected
    by that steady wind (or by none).
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
