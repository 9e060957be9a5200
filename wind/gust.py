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
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np

from wind.field import ZERO, Vec3, WindField, toward_unit

MAX_RISE_TIME_S = 5.0
"""Default upper bound on a convected gust's rise time (s): its speed floor is ``length_m / MAX_RISE_TIME_S``."""

MAX_VELOCITY_DT_S = 1.0
"""Longer steps (s): the positions are too far apart to difference into a velocity (the airspeed stands in)."""


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
        """Shape factor in [0, 1] at penetration distance ``x_m`` past the onset."""
        d = self.length_m
        if x_m <= 0.0:
            return 0.0
        if x_m < d:
            return 0.5 * (1.0 - math.cos(math.pi * x_m / d))
        x_m -= d + self.hold_m
        if x_m <= 0.0:
            return 1.0
        if x_m < d:
            return 0.5 * (1.0 + math.cos(math.pi * x_m / d))
        return 0.0

    def passed(self, x_m: float) -> bool:
        """Whether the gust has gone by at penetration distance ``x_m``: :meth:`shape` is 0 there and beyond.

        The same test as :meth:`shape`'s last branch (never true for rise-and-hold); ``x - (d + hold)`` grows
        with x, so once true it stays true for every larger distance.
        """
        return x_m - (self.length_m + self.hold_m) >= self.length_m

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


class GustTrain:
    """A schedule of discrete gusts, a :class:`~wind.field.WindField` (zero mean).

    ``mean_wind`` (the air mass that convects the gusts), ``min_speed_mps``
    and ``max_rise_time_s`` set the penetration speed of the gusts that have no
    fixed ``penetration_speed_mps`` (see the module docstring). Overlapping
    gusts add.
    """

    __slots__ = (
        "gusts",
        "mean_wind",
        "min_speed_mps",
        "max_rise_time_s",
        "_mean_fn",
        "_t",
        "_out",
        "_x",
        "_dirs",
        "_floor",
        "_pos",
        "_timed",
        "after_first_activation",
        "_armed",
        "_passed",
        "_first_live",
    )

    def __init__(
        self,
        gusts: Iterable[Gust],
        mean_wind: WindField | None = None,
        min_speed_mps: float = 1.0,
        max_rise_time_s: float = MAX_RISE_TIME_S,
        after_first_activation: Iterable[Gust] = (),
    ) -> None:
        self._timed: tuple[Gust, ...] = tuple(sorted(gusts, key=lambda g: g.onset_s))
        self.after_first_activation: tuple[Gust, ...] = tuple(after_first_activation)
        """Gusts whose ``onset_s`` counts from the geofence's first activation (see :meth:`first_activation`)."""
        self.gusts: tuple[Gust, ...] = self._timed
        if not (math.isfinite(min_speed_mps) and min_speed_mps > 0.0):
            raise ValueError(f"gust min_speed_mps must be > 0, got {min_speed_mps!r}")
        if math.isnan(max_rise_time_s) or not max_rise_time_s > 0.0:
            raise ValueError(f"gust max_rise_time_s must be > 0 (inf: no length floor), got {max_rise_time_s!r}")
        self.mean_wind = mean_wind
        self.min_speed_mps = float(min_speed_mps)
        self.max_rise_time_s = float(max_rise_time_s)
        self._mean_fn = mean_wind.mean if mean_wind is not None else None
        self.reset()

    def _schedule(self, gusts: tuple[Gust, ...], x: list[float]) -> None:
        """Set the gusts in effect (sorted by onset) and their distances travelled so far."""
        self.gusts = gusts
        self._x = x
        self._dirs = tuple(toward_unit(g.from_deg) for g in gusts)
        self._floor = tuple(max(self.min_speed_mps, g.length_m / self.max_rise_time_s) for g in gusts)
        # The gusts that have gone by (Gust.passed), and the first that has not: sample skips the first ones, and
        # returns zero at once while the first live gust has not begun (or when all have gone by).
        self._passed = [False] * len(gusts)
        self._first_live = 0

    def reset(self) -> None:
        """Back to the start: no distance travelled into any gust; the activation-timed gusts unarmed again."""
        self._t: float | None = None
        self._pos: tuple[float, float] | None = None
        self._out: Vec3 = ZERO
        self._armed = False
        self._schedule(self._timed, [0.0] * len(self._timed))

    def first_activation(self, t_s: float) -> None:
        """The geofence overrode the pilot for the first time at ``t_s``: schedule the activation-timed gusts.

        Each starts ``onset_s`` after ``t_s``. Later calls do nothing (the first activation happens once).
        """
        if self._armed or not self.after_first_activation:
            self._armed = True
            return
        self._armed = True
        pairs = list(zip(self.gusts, self._x)) + [(replace(g, onset_s=t_s + g.onset_s), 0.0) for g in self.after_first_activation]
        pairs.sort(key=lambda p: p[0].onset_s)
        self._schedule(tuple(g for g, _ in pairs), [x for _, x in pairs])

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
        last = self._t
        if t_s == last:
            return self._out
        if last is not None and not t_s > last:
            raise ValueError(f"GustTrain.sample: time went backwards ({t_s!r} s after {last!r} s); call reset()")
        self._t = t_s
        pos = self._pos
        self._pos = (east_m, north_m)
        gusts = self.gusts
        n_gusts = len(gusts)
        live = self._first_live
        if live == n_gusts or t_s <= gusts[live].onset_s:
            self._out = ZERO
            return ZERO

        # speed of the vehicle relative to the mean air mass that carries the frozen gusts
        me = mn = 0.0
        if self._mean_fn is not None:
            me, mn, _ = self._mean_fn(up_m)
        dt = t_s - last if last is not None else 0.0
        if pos is not None and 0.0 < dt <= MAX_VELOCITY_DT_S:
            re = (east_m - pos[0]) / dt - me
            rn = (north_m - pos[1]) / dt - mn
            v = math.sqrt(re * re + rn * rn)
        else:  # no previous position: the airspeed stands in
            w = math.sqrt(me * me + mn * mn)
            v = airspeed_mps if airspeed_mps > w else w
        e = n = u = 0.0
        xs = self._x
        floors = self._floor
        dirs = self._dirs
        passed = self._passed
        for i in range(live, n_gusts):
            g = gusts[i]
            if t_s <= g.onset_s:
                break  # sorted by onset
            if passed[i]:
                continue  # gone by: no more wind from it
            if g.penetration_speed_mps is not None:
                x = g.penetration_speed_mps * (t_s - g.onset_s)
            else:
                t0 = g.onset_s if last is None or last < g.onset_s else last
                f = floors[i]
                x = xs[i] + (v if v > f else f) * (t_s - t0)
                xs[i] = x
            k = g.shape(x)
            if k != 0.0:
                de, dn = dirs[i]
                a = g.amplitude_mps * k
                e += a * de
                n += a * dn
                u += g.vertical_mps * k
            elif g.passed(x):
                passed[i] = True
                while live < n_gusts and passed[live]:
                    live += 1
                self._first_live = live
        self._out = (e, n, u)
        return self._out

    def __repr__(self) -> str:
        return f"GustTrain({list(self.gusts)!r})"
