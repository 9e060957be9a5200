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

The laws are written once, :func:`profile_factor` and :func:`steady_mean` (over a profile's
:attr:`~PowerLawProfile.coefficients`), called by the objects here and by the compiled sampler
:mod:`wind.field_kernel`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from geofence.jit import jitable
from wind.field import Vec3, toward_unit

UNIFORM, POWER_LAW, LOG_LAW = 0.0, 1.0, 2.0
"""The profile laws, as :func:`profile_factor` takes them (floats: they live in the compiled sampler's arrays)."""


@jitable
def profile_factor(law: float, a: float, b: float, up_m: float) -> float:
    """The height factor of a profile ``(law, a, b)`` at ``up_m`` AGL: 1 (:data:`UNIFORM`), ``(z / b) ** a`` for
    z > 0 (:data:`POWER_LAW`: ``a`` the exponent, ``b`` the reference height), ``ln(z / a) / ln(b / a)`` for
    z > a (:data:`LOG_LAW`: ``a`` the roughness length); 0 at and below the ground, or z0, and for a NaN."""
    if law == UNIFORM:
        return 1.0
    if law == POWER_LAW:
        if not up_m > 0.0:  # also catches NaN
            return 0.0
        return (up_m / b) ** a
    if not up_m > a:  # also catches NaN
        return 0.0
    return math.log(up_m / a) / math.log(b / a)


@jitable
def steady_mean(east_mps: float, north_mps: float, law: float, a: float, b: float, up_m: float) -> tuple[float, float]:
    """The steady wind (east, north) at ``up_m``: the wind at the reference height scaled by
    :func:`profile_factor` (a uniform profile's wind as it is)."""
    if law == UNIFORM:
        return east_mps, north_mps
    k = profile_factor(law, a, b, up_m)
    return east_mps * k, north_mps * k


class _Profile:
    """A height profile: :meth:`factor` by :func:`profile_factor` over the subclass's ``coefficients``."""

    __slots__ = ()

    @property
    def coefficients(self) -> tuple[float, float, float]:
        """``(law, a, b)`` for :func:`profile_factor`."""
        raise NotImplementedError

    def factor(self, up_m: float) -> float:
        """The wind speed's factor at ``up_m`` AGL (1 at the reference height)."""
        return profile_factor(*self.coefficients, up_m)


@dataclass(frozen=True, slots=True)
class UniformProfile(_Profile):
    """The same wind speed at every height."""

    @property
    def coefficients(self) -> tuple[float, float, float]:
        """``(law, a, b)`` for :func:`profile_factor`."""
        return (UNIFORM, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class PowerLawProfile(_Profile):
    """Power-law profile ``(z / reference_height_m) ** exponent``, 0 at and below the ground."""

    exponent: float = 0.14
    reference_height_m: float = 10.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.exponent) and 0.0 < self.exponent <= 1.0):
            raise ValueError(f"power-law exponent must be in (0, 1], got {self.exponent!r}")
        if not (math.isfinite(self.reference_height_m) and self.reference_height_m > 0.0):
            raise ValueError(f"reference_height_m must be > 0, got {self.reference_height_m!r}")

    @property
    def coefficients(self) -> tuple[float, float, float]:
        """``(law, a, b)`` for :func:`profile_factor`."""
        return (POWER_LAW, self.exponent, self.reference_height_m)


@dataclass(frozen=True, slots=True)
class LogLawProfile(_Profile):
    """Logarithmic profile ``ln(z / z0) / ln(z_ref / z0)``, 0 at and below the roughness length z0."""

    roughness_length_m: float = 0.03
    reference_height_m: float = 10.0

    def __post_init__(self) -> None:
        z0, zr = self.roughness_length_m, self.reference_height_m
        if not (math.isfinite(z0) and z0 > 0.0):
            raise ValueError(f"roughness_length_m must be > 0, got {z0!r}")
        if not (math.isfinite(zr) and zr > z0):
            raise ValueError(f"reference_height_m must be > roughness_length_m ({z0!r}), got {zr!r}")

    @property
    def coefficients(self) -> tuple[float, float, float]:
        """``(law, a, b)`` for :func:`profile_factor`."""
        return (LOG_LAW, self.roughness_length_m, self.reference_height_m)


WindProfile = UniformProfile | PowerLawProfile | LogLawProfile


class SteadyWind:
    """Steady horizontal wind of ``speed_mps`` (at the profile's reference height) from ``from_deg``."""

    __slots__ = ("speed_mps", "from_deg", "profile", "_e", "_n", "_law", "_last_up", "_last_mean")

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
        self._law = self.profile.coefficients
        # The last height asked for and its wind: within one step the turbulence and the gusts ask
        # for the mean wind at the height the steady part was just sampled at.
        self._last_up = math.nan
        self._last_mean: Vec3 = (self._e, self._n, 0.0)

    @property
    def reference_enu_mps(self) -> tuple[float, float]:
        """The wind (east, north) at the profile's reference height (factor 1), m/s toward."""
        return (self._e, self._n)

    def speed_at(self, up_m: float) -> float:
        """Horizontal wind speed in m/s at height ``up_m`` AGL."""
        return self.speed_mps * self.profile.factor(up_m)

    def mean(self, up_m: float) -> Vec3:
        if up_m == self._last_up:  # (never true for a NaN height)
            return self._last_mean
        e, n = steady_mean(self._e, self._n, *self._law, up_m)
        out = (e, n, 0.0)
        self._last_up = up_m
        self._last_mean = out
        return out

    def sample(self, t_s: float, east_m: float, north_m: float, up_m: float, airspeed_mps: float) -> Vec3:
        return self.mean(up_m)

    def __repr__(self) -> str:
        return f"SteadyWind(speed_mps={self.speed_mps!r}, from_deg={self.from_deg!r}, profile={self.profile!r})"
