"""Discrete "1-cosine" gusts (MIL-F-8785C shape) and schedules of them.

Shape, as a function of the distance x the gust front has travelled past the
aircraft since onset (x < 0 before onset)::

    rise   0 <= x <= d            v = (V_m / 2) (1 - cos(pi x / d))
    hold   d <= x <= d + hold     v = V_m
    fall   d + hold <= x <= 2d + hold
                                  v = (V_m / 2) (1 - cos(pi (2d + hold - x) / d))
    after  x >= 2d + hold         v = 0

with d = ``length_m`` (the MIL-F-8785C gust length d_m: the distance to reach
the peak). ``hold_m = 0`` (the default) is the usual full 1-cos gust, rising
and falling over 2 d; ``hold_m = math.inf`` is the MIL-F-8785C rise-and-hold
(ramp-to-a-new-level) form. The horizontal part has amplitude
``amplitude_mps`` toward the opposite of ``from_deg`` (a gust from 270 pushes
east); ``vertical_mps`` (signed, + up) follows the same shape.

Time: a frozen field convected by the mean wind. By default a gust is a
spatial pattern frozen into the mean air mass, which moves over the ground at
the mean wind ``W`` (the steady wind at the vehicle's height; zero without a
``mean_wind``). The vehicle moves through that air mass at its velocity
relative to it, ``v_ground - W``, so x grows at the *relative* speed of the
vehicle and the gust front::

    dx/dt = max(|v_ground - W|, V_floor),   V_floor = max(min_speed_mps, length_m / max_rise_time_s)

(horizontal speeds; the ground velocity comes from successive sampled
positions, so the gust's own push on the vehicle does not feed back into its
timing). Examples: a vehicle hovering in a mean wind W is swept at |W| (a 40 m
gust in 8 m/s peaks after 5 s); an aircraft flying upwind at 16 m/s ground
speed into an 8 m/s headwind (airspeed 24 m/s) meets it at 24 m/s (peak after
40/24 s); a faster aircraft crosses the gust sooner.

The floor ``V_floor`` is the documented minimum for slow vehicles in light or
calm air, where the mean air barely moves relative to the vehicle (hovering in
calm air, or drifting with the wind): a real gust front still passes, and
without a floor a 40 m gust would take 40 s to rise (a ramp, not a gust).
With the defaults (``min_speed_mps`` = 1 m/s, ``max_rise_time_s`` =
:data:`MAX_RISE_TIME_S` = 5 s) every convected gust reaches its peak within
5 s of its onset (and a gust of length d >= 5 m is swept at >= d / 5 s); in a
mean wind or at airspeed the physics (|v_ground - W|) takes over as soon as it
is faster than that.

x is integrated step by step (the speed held over each step at its value over
that step). The first sample of a train has no previous position: then the
``airspeed_mps`` argument stands in for |v_ground - W| (max of airspeed and
|W|), as do steps longer than 1 s. Give ``penetration_speed_mps`` to make a
gust purely time-based instead: then x = penetration_speed_mps * (t - onset),
and the rise time is length_m / penetration_speed_mps for every platform
(useful to apply the identical disturbance to different aircraft).

Written once: the shape is :func:`gust_shape` (and :func:`gust_passed`), a
train's sample :func:`gusts_sample`, a compiled function over the train's
:data:`GUST_TRAIN` record and its gust table (a row a gust, columns
:data:`GUST_COLUMNS`); :class:`GustTrain` is the façade that owns them (or
lives in a caller's slice of memory: the compiled sampler
:mod:`wind.field_kernel`) and schedules the gusts.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np

from geofence.jit import compiled, jitable
from wind.field import ZERO, Vec3, WindField, toward_unit

MAX_RISE_TIME_S = 5.0
"""Default upper bound on a convected gust's rise time (s): its speed floor is ``length_m / MAX_RISE_TIME_S``."""

MAX_VELOCITY_DT_S = 1.0
"""Longer steps (s): the positions are too far apart to difference into a velocity (the airspeed stands in)."""

ONSET, AMPLITUDE, LENGTH, HOLD, VERTICAL, PENETRATION, FLOOR, TOWARD_E, TOWARD_N, TRAVELLED, PASSED = range(11)
"""The gust table's columns: onset (s), amplitude (m/s), length and hold (m), vertical (m/s), penetration speed
(m/s; NaN: convected), speed floor (m/s), the unit vector toward (east, north); then the state: the distance
travelled (m) and whether the gust has gone by (1.0)."""
GUST_COLUMNS = 11

GUST_TRAIN = np.dtype(
    (
        np.record,
        [
            ("has_t", np.float64),  # 1 once sampled: t_s holds
            ("t_s", np.float64),  # the last sample's time
            ("has_pos", np.float64),  # 1 once a position was given
            ("east_m", np.float64),  # the last sample's position
            ("north_m", np.float64),
            ("wind_east_mps", np.float64),  # the last sample
            ("wind_north_mps", np.float64),
            ("wind_up_mps", np.float64),
            ("first_live", np.float64),  # the first gust of the table that has not gone by
        ],
    )
)
"""A gust train's state, a record over float memory (a flag is 0 or 1)."""
GUST_TRAIN_SIZE = GUST_TRAIN.itemsize // 8
"""Float64 slots of the memory a :class:`GustTrain` lives in."""


@jitable
def gust_shape(length_m: float, hold_m: float, x_m: float) -> float:
    """The 1-cos shape factor in [0, 1] of a gust of ``length_m`` and ``hold_m`` at penetration distance ``x_m``."""
    d = length_m
    if x_m <= 0.0:
        return 0.0
    if x_m < d:
        return 0.5 * (1.0 - math.cos(math.pi * x_m / d))
    x_m -= d + hold_m
    if x_m <= 0.0:
        return 1.0
    if x_m < d:
        return 0.5 * (1.0 + math.cos(math.pi * x_m / d))
    return 0.0


@jitable
def gust_passed(length_m: float, hold_m: float, x_m: float) -> bool:
    """Whether the gust has gone by at ``x_m``: :func:`gust_shape`'s last branch (never for rise-and-hold);
    ``x - (d + hold)`` grows with x, so once true it stays true for every larger distance."""
    return x_m - (length_m + hold_m) >= length_m


@jitable
def _relative_speed_mps(
    s: np.record, has_last: bool, dt: float, east_m: float, north_m: float, airspeed_mps: float, mean_e: float,
    mean_n: float,
) -> float:  # fmt: skip
    """The speed of the vehicle relative to the mean air mass that carries the frozen gusts: from the positions
    of this and the last sample, or (none, or a step over :data:`MAX_VELOCITY_DT_S`) max(airspeed, |mean|)."""
    if s.has_pos != 0.0 and 0.0 < dt <= MAX_VELOCITY_DT_S:
        re = (east_m - s.east_m) / dt - mean_e
        rn = (north_m - s.north_m) / dt - mean_n
        return math.sqrt(re * re + rn * rn)
    w = math.sqrt(mean_e * mean_e + mean_n * mean_n)
    return airspeed_mps if airspeed_mps > w else w


@compiled
def gusts_sample(
    S: np.ndarray, G: np.ndarray, t_s: float, east_m: float, north_m: float, airspeed_mps: float, mean_e: float,
    mean_n: float,
) -> tuple[float, float, float]:  # fmt: skip
    """The sum of the gusts of table ``G`` (a row a gust, sorted by onset; its last two columns advanced in place)
    at ``t_s`` and the position (``east_m``, ``north_m``), in the mean wind ``(mean_e, mean_n)``; ``S``:
    :data:`GUST_TRAIN`'s slots, advanced in place. The same time again gives the last sample."""
    s = S.view(GUST_TRAIN)[0]
    has_last = s.has_t != 0.0
    last = s.t_s
    if has_last and t_s == last:
        return s.wind_east_mps, s.wind_north_mps, s.wind_up_mps
    if has_last and not t_s > last:
        raise ValueError("GustTrain.sample: time went backwards; call reset()")
    dt = t_s - last if has_last else 0.0
    v = _relative_speed_mps(s, has_last, dt, east_m, north_m, airspeed_mps, mean_e, mean_n)
    s.t_s, s.has_t = t_s, 1.0
    s.has_pos, s.east_m, s.north_m = 1.0, east_m, north_m
    n_gusts = G.shape[0]
    live = int(s.first_live)
    e = n = u = 0.0
    for i in range(live, n_gusts):
        g = G[i]
        if t_s <= g[ONSET]:
            break  # sorted by onset
        if g[PASSED] != 0.0:
            continue  # gone by: no more wind from it
        if not math.isnan(g[PENETRATION]):
            x = g[PENETRATION] * (t_s - g[ONSET])
        else:
            t0 = g[ONSET] if not has_last or last < g[ONSET] else last
            x = g[TRAVELLED] + (v if v > g[FLOOR] else g[FLOOR]) * (t_s - t0)
            g[TRAVELLED] = x
        k = gust_shape(g[LENGTH], g[HOLD], x)
        if k != 0.0:
            a = g[AMPLITUDE] * k
            e += a * g[TOWARD_E]
            n += a * g[TOWARD_N]
            u += g[VERTICAL] * k
        elif gust_passed(g[LENGTH], g[HOLD], x):
            g[PASSED] = 1.0
            while live < n_gusts and G[live, PASSED] != 0.0:
                live += 1
            s.first_live = live
    s.wind_east_mps, s.wind_north_mps, s.wind_up_mps = e, n, u
    return e, n, u


@dataclass(frozen=True, slots=True)
class Gust:
    """One discrete gust (see the module docstring for the shape and timing)."""

    onset_s: float
    amplitude_mps: float
    length_m: float
    from_deg: float
    vertical_mps: float = 0.0
    hold_m: float = 0.0
    penetration_speed_mps: float | None = None

    def __post_init__(self) -> None:
        if not math.isfinite(self.onset_s):
            raise ValueError(f"gust onset_s must be finite, got {self.onset_s!r}")
        if not (math.isfinite(self.amplitude_mps) and self.amplitude_mps >= 0.0):
            raise ValueError(f"gust amplitude_mps must be >= 0, got {self.amplitude_mps!r}")
        if not (math.isfinite(self.length_m) and self.length_m > 0.0):
            raise ValueError(f"gust length_m must be > 0, got {self.length_m!r}")
        if not math.isfinite(self.from_deg):
            raise ValueError(f"gust from_deg must be finite, got {self.from_deg!r}")
        if not math.isfinite(self.vertical_mps):
            raise ValueError(f"gust vertical_mps must be finite, got {self.vertical_mps!r}")
        if math.isnan(self.hold_m) or self.hold_m < 0.0:
            raise ValueError(f"gust hold_m must be >= 0, got {self.hold_m!r}")
        p = self.penetration_speed_mps
        if p is not None and not (math.isfinite(p) and p > 0.0):
            raise ValueError(f"gust penetration_speed_mps must be > 0, got {p!r}")

    def shape(self, x_m: float) -> float:
        """Shape factor in [0, 1] at penetration distance ``x_m`` past the onset (:func:`gust_shape`)."""
        return gust_shape(self.length_m, self.hold_m, x_m)

    def passed(self, x_m: float) -> bool:
        """Whether the gust has gone by at penetration distance ``x_m`` (:func:`gust_passed`): :meth:`shape` is 0
        there and beyond."""
        return gust_passed(self.length_m, self.hold_m, x_m)

    @property
    def extent_m(self) -> float:
        """Total penetration distance over which the gust is non-zero (inf for rise-and-hold)."""
        return 2.0 * self.length_m + self.hold_m

    def vector(self, x_m: float) -> Vec3:
        """Gust wind vector ENU m/s at penetration distance ``x_m``."""
        k = self.shape(x_m)
        if k == 0.0:
            return (0.0, 0.0, 0.0)
        e, n = toward_unit(self.from_deg)
        a = self.amplitude_mps * k
        return (a * e, a * n, self.vertical_mps * k)


def gust_table(gusts: tuple[Gust, ...], travelled_m: np.ndarray, min_speed_mps: float, max_rise_time_s: float) -> np.ndarray:
    """The table :func:`gusts_sample` steps: a row of :data:`GUST_COLUMNS` a gust (``gusts`` sorted by onset), the
    distances travelled so far ``travelled_m``, none gone by; float64, C order, whatever the number of gusts."""
    G = np.zeros((len(gusts), GUST_COLUMNS))
    for row, g in zip(G, gusts, strict=True):
        p = math.nan if g.penetration_speed_mps is None else g.penetration_speed_mps
        floor = max(min_speed_mps, g.length_m / max_rise_time_s)
        row[:PASSED] = (g.onset_s, g.amplitude_mps, g.length_m, g.hold_m, g.vertical_mps, p, floor, *toward_unit(g.from_deg), 0.0)
    G[:, TRAVELLED] = travelled_m
    return G


class GustTrain:
    """A schedule of discrete gusts, a :class:`~wind.field.WindField` (zero mean).

    ``mean_wind`` (the air mass that convects the gusts), ``min_speed_mps``
    and ``max_rise_time_s`` set the penetration speed of the gusts that have no
    fixed ``penetration_speed_mps`` (see the module docstring). Overlapping
    gusts add. ``memory``: :data:`GUST_TRAIN_SIZE` contiguous float64 slots to
    live in (a caller's compiled step reads and writes the same state); fresh
    when omitted.
    """

    __slots__ = (
        "gusts", "mean_wind", "min_speed_mps", "max_rise_time_s", "after_first_activation", "memory", "table",
        "_mean_fn", "_timed", "_armed",
    )  # fmt: skip

    def __init__(
        self,
        gusts: Iterable[Gust],
        mean_wind: WindField | None = None,
        min_speed_mps: float = 1.0,
        max_rise_time_s: float = MAX_RISE_TIME_S,
        after_first_activation: Iterable[Gust] = (),
        memory: np.ndarray | None = None,
    ) -> None:
        self._timed: tuple[Gust, ...] = tuple(sorted(gusts, key=lambda g: g.onset_s))
        self.after_first_activation: tuple[Gust, ...] = tuple(after_first_activation)
        """Gusts whose ``onset_s`` counts from the geofence's first activation (see :meth:`first_activation`)."""
        if not (math.isfinite(min_speed_mps) and min_speed_mps > 0.0):
            raise ValueError(f"gust min_speed_mps must be > 0, got {min_speed_mps!r}")
        if math.isnan(max_rise_time_s) or not max_rise_time_s > 0.0:
            raise ValueError(f"gust max_rise_time_s must be > 0 (inf: no length floor), got {max_rise_time_s!r}")
        if memory is None:
            memory = np.zeros(GUST_TRAIN_SIZE)
        if memory.shape != (GUST_TRAIN_SIZE,) or memory.dtype != np.float64 or not memory.flags.c_contiguous:
            raise ValueError(f"GustTrain memory: expected {GUST_TRAIN_SIZE} contiguous float64 slots")
        self.memory = memory
        self.mean_wind = mean_wind
        self.min_speed_mps = float(min_speed_mps)
        self.max_rise_time_s = float(max_rise_time_s)
        self._mean_fn = mean_wind.mean if mean_wind is not None else None
        self.reset()

    def copy_into(self, memory: np.ndarray) -> GustTrain:
        """A fresh copy of this train (the same gusts and speeds, not yet sampled, unarmed) living in ``memory``."""
        return GustTrain(
            self._timed, self.mean_wind, self.min_speed_mps, self.max_rise_time_s, self.after_first_activation, memory
        )

    def _schedule(self, gusts: tuple[Gust, ...], travelled_m: np.ndarray) -> None:
        """Set the gusts in effect (sorted by onset) and their distances travelled so far; none gone by."""
        self.gusts: tuple[Gust, ...] = gusts
        self.table: np.ndarray = gust_table(gusts, travelled_m, self.min_speed_mps, self.max_rise_time_s)
        """The gusts as :func:`gusts_sample` steps them (a new array after :meth:`first_activation`)."""
        self.memory.view(GUST_TRAIN)[0].first_live = 0.0

    def reset(self) -> None:
        """Back to the start: no distance travelled into any gust; the activation-timed gusts unarmed again."""
        self.memory[:] = 0.0
        self._armed = False
        self._schedule(self._timed, np.zeros(len(self._timed)))

    def first_activation(self, t_s: float) -> None:
        """The geofence overrode the pilot for the first time at ``t_s``: schedule the activation-timed gusts.

        Each starts ``onset_s`` after ``t_s``. Later calls do nothing (the first activation happens once).
        """
        if self._armed or not self.after_first_activation:
            self._armed = True
            return
        self._armed = True
        pairs = list(zip(self.gusts, self.table[:, TRAVELLED].tolist()))
        pairs += [(replace(g, onset_s=t_s + g.onset_s), 0.0) for g in self.after_first_activation]
        pairs.sort(key=lambda p: p[0].onset_s)
        self._schedule(tuple(g for g, _ in pairs), np.array([x for _, x in pairs]))

    @classmethod
    def random(
        cls,
        seed: int | np.random.SeedSequence,
        count: int,
        start_s: float,
        end_s: float,
        amplitude_mps: tuple[float, float],
        length_m: tuple[float, float],
        from_deg: float,
        spread_deg: float = 0.0,
        vertical_mps: tuple[float, float] = (0.0, 0.0),
        mean_wind: WindField | None = None,
        min_speed_mps: float = 1.0,
        max_rise_time_s: float = MAX_RISE_TIME_S,
    ) -> GustTrain:
        """``count`` gusts with onsets uniform in [start_s, end_s], amplitudes and lengths
        uniform in the given (low, high) ranges, directions uniform in from_deg +/- spread_deg,
        vertical parts uniform in ``vertical_mps``; reproducible by ``seed``."""
        if count < 0:
            raise ValueError(f"gust count must be >= 0, got {count!r}")
        if not end_s >= start_s:
            raise ValueError(f"gust window end_s ({end_s!r}) must be >= start_s ({start_s!r})")
        for name, (lo, hi) in (("amplitude_mps", amplitude_mps), ("length_m", length_m), ("vertical_mps", vertical_mps)):
            if not hi >= lo:
                raise ValueError(f"gust {name} range ({lo!r}, {hi!r}) must have low <= high")
        rng = np.random.default_rng(seed)
        onset = np.sort(rng.uniform(start_s, end_s, count))
        amp = rng.uniform(amplitude_mps[0], amplitude_mps[1], count)
        length = rng.uniform(length_m[0], length_m[1], count)
        dirs = (from_deg + rng.uniform(-spread_deg, spread_deg, count)) % 360.0
        vert = rng.uniform(vertical_mps[0], vertical_mps[1], count)
        gusts = [
            Gust(onset_s=float(o), amplitude_mps=float(a), length_m=float(d), from_deg=float(f), vertical_mps=float(w))
            for o, a, d, f, w in zip(onset, amp, length, dirs, vert, strict=True)
        ]
        return cls(gusts, mean_wind=mean_wind, min_speed_mps=min_speed_mps, max_rise_time_s=max_rise_time_s)

    def mean(self, up_m: float) -> Vec3:
        return (0.0, 0.0, 0.0)

    def sample(self, t_s: float, east_m: float, north_m: float, up_m: float, airspeed_mps: float) -> Vec3:
        me, mn, _ = self._mean_fn(up_m) if self._mean_fn is not None else ZERO
        return gusts_sample(self.memory, self.table, t_s, east_m, north_m, airspeed_mps, me, mn)

    def __repr__(self) -> str:
        return f"GustTrain({list(self.gusts)!r})"
