"""The wind-field protocol and the trivial fields (calm, sum of components).

Conventions used by every field in this package:

* A wind *vector* is local ENU in m/s and gives the direction the air moves
  **toward** (east, north, up). It is what JSBSim's ``atmosphere/wind-*-fps``
  properties expect (after the fps conversion and down = -up).
* A wind *direction* in configuration is meteorological: where the wind blows
  **from**, in degrees clockwise from north (from 270 = westerly = air moving
  east). :func:`toward_unit` converts one to the other.
* ``up_m`` is the height above the local ground (AGL), not altitude ASL.

``sample`` is on the simulation's per-step path and must be cheap: the
stateful parts sample by compiled functions over their own memory (the same
functions :mod:`wind.field_kernel` sums in one compiled call). Stateful fields
(turbulence, gusts) require monotonically non-decreasing ``t_s``; calling twice
with the same ``t_s`` returns the same vector.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Protocol, runtime_checkable

from geofence.jit import jitable

Vec3 = tuple[float, float, float]

ZERO: Vec3 = (0.0, 0.0, 0.0)


@runtime_checkable
class WindField(Protocol):
    """A wind field sampled along the flight.

    ``sample`` returns the total wind (steady + turbulence + gusts) in ENU m/s
    at time ``t_s`` and position (``east_m``, ``north_m``, ``up_m`` AGL), for an
    aircraft flying at true airspeed ``airspeed_mps`` (stateful components use
    it to convert their spatial scales to time). ``mean`` returns only the
    steady part at height ``up_m``: what a wind estimator would converge to.
    """

    def sample(self, t_s: float, east_m: float, north_m: float, up_m: float, airspeed_mps: float) -> Vec3: ...

    def mean(self, up_m: float) -> Vec3: ...


def notify_first_activation(field: object, t_s: float) -> None:
    """Tell ``field`` (and, for a :class:`CompositeWind`, its components) that the geofence first activated at ``t_s``.

    Wind fields with events (a gust train's activation-timed gusts, the compiled sampler
    :class:`wind.field_kernel.WindArrays`) expose ``first_activation(t_s)``; the others ignore it. The simulated
    flight calls this once, the step the unit first overrides the pilot.
    """
    for part in getattr(field, "components", (field,)):
        hook = getattr(part, "first_activation", None)
        if hook is not None:
            hook(t_s)


def toward_unit(from_deg: float) -> tuple[float, float]:
    """(east, north) unit vector the air moves toward, for a wind from ``from_deg``."""
    r = math.radians(from_deg)
    e, n = -math.sin(r), -math.cos(r)
    # snap the rounding noise of sin/cos at the cardinal directions to exact zeros
    return (0.0 if abs(e) < 1e-15 else e, 0.0 if abs(n) < 1e-15 else n)


def from_deg_of(east_mps: float, north_mps: float) -> float:
    """Meteorological direction-from in [0, 360) deg of a horizontal wind vector (0 for calm)."""
    if east_mps == 0.0 and north_mps == 0.0:
        return 0.0
    return math.degrees(math.atan2(-east_mps, -north_mps)) % 360.0


class CalmWind:
    """No wind at all."""

    __slots__ = ()

    def sample(self, t_s: float, east_m: float, north_m: float, up_m: float, airspeed_mps: float) -> Vec3:
        return ZERO

    def mean(self, up_m: float) -> Vec3:
        return ZERO

    def reset(self) -> None:
        """Nothing to reset (present for symmetry with the stateful fields)."""

    def __repr__(self) -> str:
        return "CalmWind()"


class CompositeWind:
    """The sum of several wind fields (e.g. steady + Dryden turbulence + gusts)."""

    __slots__ = ("components", "_samplers", "_means")

    def __init__(self, components: Iterable[WindField]) -> None:
        self.components: tuple[WindField, ...] = tuple(components)
        for c in self.components:
            if not isinstance(c, WindField):
                raise TypeError(f"CompositeWind: {c!r} is not a WindField (needs sample() and mean())")
        self._samplers = tuple(c.sample for c in self.components)
        self._means = tuple(c.mean for c in self.components)

    def sample(self, t_s: float, east_m: float, north_m: float, up_m: float, airspeed_mps: float) -> Vec3:
        e = n = u = 0.0
        for f in self._samplers:
            de, dn, du = f(t_s, east_m, north_m, up_m, airspeed_mps)
            e += de
            n += dn
            u += du
        return (e, n, u)

    def mean(self, up_m: float) -> Vec3:
        e = n = u = 0.0
        for f in self._means:
            de, dn, du = f(up_m)
            e += de
            n += dn
            u += du
        return (e, n, u)

    def reset(self) -> None:
        """Reset every stateful component to its initial (seeded) state."""
        for c in self.components:
            r = getattr(c, "reset", None)
            if r is not None:
                r()

    def __repr__(self) -> str:
        return f"CompositeWind({list(self.components)!r})"


def effective_speed(airspeed_mps: float, mean_wind: WindField | None, up_m: float, floor_mps: float) -> float:
    """Speed at which the air mass moves past the aircraft, for spatial -> temporal scales.

    ``max(airspeed, |mean horizontal wind at up_m|, floor)``: a hovering vehicle
    in wind still sees frozen turbulence convected past it by the mean wind,
    and in calm air it sees it at the floor speed (never zero).
    """
    e, n, _ = mean_wind.mean(up_m) if mean_wind is not None else ZERO
    return convection_speed_mps(airspeed_mps, floor_mps, math.sqrt(e * e + n * n))


@jitable
def convection_speed_mps(airspeed_mps: float, floor_mps: float, mean_speed_mps: float) -> float:
    """``max(airspeed, mean wind speed, floor)``: the speed of frozen turbulence past the aircraft
    (:func:`effective_speed`, the Dryden filters' time scales)."""
    v = airspeed_mps if airspeed_mps > floor_mps else floor_mps
    return mean_speed_mps if mean_speed_mps > v else v
