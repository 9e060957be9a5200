"""Steady (mean) wind with an optional height profile.

The configured ``speed_mps`` is the horizontal wind speed at the profile's
reference height (10 m unless told otherwise); with no profile it applies at
every height. Profiles give a non-negative factor of height above ground:

* :class:`UniformProfile`: 1 everywhere.
* :class:`PowerLawProfile`: ``(z / z_ref) ** exponent`` for z > 0, and 0 at and
  below the ground (z <= 0). Exponent ~1/7 (0.14) over open terrain.
* :class:`LogLawProfile`: ``ln(z / z0) / ln(z_ref / z0)`` for z > z0, and 0 at
  and below the roughness length z0 (the log law is negative there, which is
  not physical). z0 ~ 0.03 m open grass, 0.1-0.25 m crops/hedges, ~1 m towns.

Neither profile ever returns a negative number or NaN, for any height
(including negative heights from ground contact). The steady wind is
horizontal: its up component is 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from wind.field import Vec3, toward_unit


@dataclass(frozen=True, slots=True)
class UniformProfile:
    """The same wind speed at every height."""

    def factor(self, up_m: float) -> float:
        return 1.0


@dataclass(frozen=True, slots=True)
class PowerLawProfile:
    """Power-law profile ``(z / reference_height_m) ** exponent``, 0 at and below the ground."""

    exponent: float = 0.14
    reference_height_m: float = 10.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.exponent) and 0.0 < self.exponent <= 1.0):
            raise ValueError(f"power-law exponent must be in (0, 1], got {self.exponent!r}")
        if not (math.isfinite(self.reference_height_m) and self.reference_height_m > 0.0):
            raise ValueError(f"reference_height_m must be > 0, got {self.reference_height_m!r}")

    def factor(self, up_m: float) -> float:
        if not up_m > 0.0:  # also catches NaN
            return 0.0
        return (up_m / self.reference_height_m) ** self.exponent


@dataclass(frozen=True, slots=True)
class LogLawProfile:
    """Logarithmic profile ``ln(z / z0) / ln(z_ref / z0)``, 0 at and below the roughness length z0."""

    roughness_length_m: float = 0.03
    reference_height_m: float = 10.0

    def __post_init__(self) -> None:
        z0, zr = self.roughness_length_m, self.reference_height_m
        if not (math.isfinite(z0) and z0 > 0.0):
            raise ValueError(f"roughness_length_m must be > 0, got {z0!r}")
        if not (math.isfinite(zr) and zr > z0):
            raise ValueError(f"reference_height_m must be > roughness_length_m ({z0!r}), got {zr!r}")

    def factor(self, up_m: float) -> float:
        z0 = self.roughness_length_m
        if not up_m > z0:  # also catches NaN
            return 0.0
        return math.log(up_m / z0) / math.log(self.reference_height_m / z0)


WindProfile = UniformProfile | PowerLawProfile | LogLawProfile


class SteadyWind:
    """Steady horizontal wind of ``speed_mps`` (at the profile's reference height) from ``from_deg``."""

    __slots__ = ("speed_mps", "from_deg", "profile", "_e", "_n", "_uniform", "_level", "_last_up", "_last_mean")

    def __init__(self, speed_mps: float, from_deg: float, profile: WindProfile | None = None) -> None:
        if not (math.isfinite(speed_mps) and speed_mps >= 0.0):
            raise ValueError(f"steady wind speed_mps must be >= 0, got {speed_mps!r}")
        if not math.isfinite(from_deg):
            raise ValueError(f"steady wind from_deg must be finite, got {from_deg!r}")
        self.speed_mps = float(speed_mps)
        self.from_deg = float(from_deg)
        self.profile: WindProfile = profile if profile is not None else UniformProfile()
        ue, un = toward_unit(from_deg)
        self._e = self.speed_mps * ue
        self._n = self.speed_mps * un
        self._uniform = isinstance(self.profile, UniformProfile)
        self._level: Vec3 = (self._e, self._n, 0.0)
        """The wind at every height of a uniform profile."""
        # The last height asked for and its wind: within one step the turbulence and the gusts ask
        # for the mean wind at the height the steady part was just sampled at.
        self._last_up = math.nan
        self._last_mean: Vec3 = self._level

    @property
    def reference_enu_mps(self) -> tuple[float, float]:
        """The wind (east, north) at the profile's reference height (factor 1), m/s toward."""
        return (self._e, self._n)

    def speed_at(self, up_m: float) -> float:
        """Horizontal wind speed in m/s at height ``up_m`` AGL."""
        return self.speed_mps * self.profile.factor(up_m)

    def mean(self, up_m: float) -> Vec3:
        if self._uniform:
            return self._level
        if up_m == self._last_up:  # (never true for a NaN height)
            return self._last_mean
        k = self.profile.factor(up_m)
        out = (self._e * k, self._n * k, 0.0)
        self._last_up = up_m
        self._last_mean = out
        return out

    def sample(self, t_s: float, east_m: float, north_m: float, up_m: float, airspeed_mps: float) -> Vec3:
        return self.mean(up_m)

    def __repr__(self) -> str:
        return f"SteadyWind(speed_mps={self.speed_mps!r}, from_deg={self.from_deg!r}, profile={self.profile!r})"
