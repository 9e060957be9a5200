"""The point-mass dynamics the unit assumes for a platform: the one home of the drag law and of gravity.

``G_MPS2 = 9.80665 m/s²`` (standard gravity) is defined here and imported by
every other module that needs g (the room formulas in :mod:`geofence.physics.rooms`,
the wind estimator, the control laws, dead reckoning).

A multirotor's horizontal air drag per unit mass at airspeed ``v`` (m/s) is

    a_drag(v) = k1·v + k2·v²        (m/s²)

with ``k1 = Envelope.drag_linear_per_s`` (rotor drag: blade flapping and
induced drag, roughly linear in airspeed; about 0.3-0.6 s⁻¹ for 0.5-2 kg
quads, Faessler et al. 2018) and ``k2 = Envelope.drag_quadratic_per_m`` (the
airframe's parasitic drag). In steady flight the horizontal thrust balances
it: ``g·tan(tilt) = a_drag(v_air)``. An envelope with both coefficients 0 has
no identified drag law; the purely quadratic law that balances the tilt limit
at ``max_speed_mps`` is used then (``k2 = g·tan(tilt_max)/v_max²``), which is
what the unit assumed before the drag law was part of the envelope.

Everything in the unit that needs the drag (the wind push in the activation
margin, the wind estimator's tilt-to-airspeed inversion, the skip shortcut)
calls these functions.

It is also the home of the one rule on the platform's authority over the wind
(:func:`return_not_assured`), shared by the unit in flight and the pre-flight check.
"""

from __future__ import annotations

import math
from dataclasses import replace

from geofence.interface import Envelope
from geofence.jit import jitable

G_MPS2: float = 9.80665
"""Standard gravity, m/s²."""

RETURN_IMPOSSIBLE_WIND_FRACTION = 0.9
"""Return cannot be assured once the sustained wind reaches this fraction of the platform's max speed."""
SUSTAINED_TURBULENCE_SIGMAS = 1.0
"""How many turbulence sigmas the sustained wind of a return allows for (see :func:`return_not_assured`)."""


def return_wind_limits(turbulence_sigma_mps: float, env: Envelope) -> tuple[float, float]:
    """``(allowance, limit)`` of :func:`return_not_assured` (m/s): return is assured while the mean wind plus
    ``allowance`` (the sustained turbulence) stays below ``limit`` (a fraction of the max speed). The unit
    computes them once per envelope and tests every step's wind against them."""
    return SUSTAINED_TURBULENCE_SIGMAS * max(turbulence_sigma_mps, 0.0), RETURN_IMPOSSIBLE_WIND_FRACTION * env.max_speed_mps


def return_not_assured(mean_wind_mps: float, turbulence_sigma_mps: float, env: Envelope) -> str | None:
    """Why the platform cannot be sure to fly back against the wind, or None.

    The wind it must fly against for as long as a return takes is the mean wind plus one turbulence
    sigma (:data:`SUSTAINED_TURBULENCE_SIGMAS`): Dryden turbulence near the ground stays above its
    mean for tens of seconds (its time scale ``L_u / V`` is about 15 s at 20 m in 8 m/s), and averaged
    over a return of about that length its spread is still most of a sigma -- less than the ``k·σ``
    peak that the room of a margin allows for over the few seconds of a turn or a stop. Return cannot
    be assured when that sustained wind reaches :data:`RETURN_IMPOSSIBLE_WIND_FRACTION` of the max
    speed. A discrete gust is not part of it: it passes in seconds, and the room of every margin
    allows for it.
    """
    allowance, limit = return_wind_limits(turbulence_sigma_mps, env)
    if mean_wind_mps + allowance < limit:
        return None
    what = f"wind {mean_wind_mps:.1f} m/s"
    if allowance > 0.0:
        what += f" + sustained turbulence {allowance:.1f} m/s"
    return f"return impossible: {what} >= {RETURN_IMPOSSIBLE_WIND_FRACTION:.0%} of max speed {env.max_speed_mps:.1f} m/s"


def drag_coefficients(env: Envelope) -> tuple[float, float]:
    """``(k1 per s, k2 per m)`` of the horizontal drag law (see the module docstring)."""
    k1, k2 = env.drag_linear_per_s, env.drag_quadratic_per_m
    if k1 > 0.0 or k2 > 0.0:
        return k1, k2
    if env.max_speed_mps > 0.0 and env.max_bank_rad > 0.0:
        return 0.0, G_MPS2 * math.tan(env.max_bank_rad) / env.max_speed_mps**2
    return 0.0, 0.0


def drag_accel_mps2(k1: float, k2: float, v_air_mps: float) -> float:
    """Drag deceleration per unit mass ``k1·v + k2·v²`` at airspeed ``v >= 0``, m/s²."""
    return (k1 + k2 * v_air_mps) * v_air_mps


@jitable
def airspeed_for_drag_mps(k1: float, k2: float, accel_mps2: float) -> float:
    """The airspeed whose drag is ``accel_mps2`` (inverse of :func:`drag_accel_mps2`); ``inf`` with no drag."""
    if accel_mps2 <= 0.0:
        return 0.0
    if k2 > 0.0:
        return 2.0 * accel_mps2 / (k1 + math.sqrt(k1 * k1 + 4.0 * k2 * accel_mps2))
    return accel_mps2 / k1 if k1 > 0.0 else math.inf


@jitable
def wind_push_mps2(k1: float, k2: float, wind_speed_mps: float, wind_normal_mps: float) -> float:
    """Drag acceleration the wind exerts towards an edge on a vehicle at rest over the ground, m/s².

    At zero ground speed the airspeed is ``|W|`` and the drag ``a_drag(|W|)``
    points along the wind; its component along the edge normal is
    ``(k1 + k2·|W|)·w_n``; 0 when the wind blows away from the edge.
    """
    if wind_normal_mps <= 0.0:
        return 0.0
    return (k1 + k2 * wind_speed_mps) * wind_normal_mps


def still_air_top_speed_mps(env: Envelope) -> float:
    """Top airspeed at the tilt limit implied by the drag law, m/s."""
    k1, k2 = drag_coefficients(env)
    return airspeed_for_drag_mps(k1, k2, G_MPS2 * math.tan(env.max_bank_rad))


@jitable
def isa_density_ratio(alt_m: float) -> float:
    """ISA troposphere density ratio ``σ = ρ/ρ0 = (1 - 2.25577e-5·h)^4.2559`` at ``h`` m AMSL (valid below 11 km)."""
    h = min(max(alt_m, -500.0), 11000.0)
    return (1.0 - 2.25577e-5 * h) ** 4.2559


def envelope_at_density(env: Envelope, density_ratio: float) -> Envelope:
    """The envelope a platform really has at air-density ratio ``σ`` (a high site, a hot day).

    Profiles are measured near sea level to 700 m and state the fixed-wing
    speeds as equivalent airspeed (EAS), which is what the flight controller
    holds. At density ratio ``σ`` the same EAS is a true airspeed ``EAS/√σ``,
    so every fixed-wing speed (and with it the turn radius ``V²/(g·tan φ)``)
    grows by ``1/√σ``. The excess thrust or power that climbs and arrests a
    descent shrinks roughly with the density (propeller thrust at a given rpm
    ``∝ ρ``), so ``max_climb_rate_mps`` and ``vertical_accel_mps2`` scale by
    ``σ``; a multirotor's quadratic (parasitic) drag scales with ``ρ`` too. Bank
    and tilt limits, braking and reaction time are kept. ``σ >= 1`` returns the
    envelope unchanged (no credit is taken for dense air).
    """
    s = min(density_ratio, 1.0)
    if s >= 1.0:
        return env
    env = replace(env, max_climb_rate_mps=env.max_climb_rate_mps * s, vertical_accel_mps2=env.vertical_accel_mps2 * s)
    if env.is_multirotor:
        return replace(env, drag_quadratic_per_m=env.drag_quadratic_per_m * s)
    f = 1.0 / math.sqrt(s)
    return replace(
        env, cruise_speed_mps=env.cruise_speed_mps * f, max_speed_mps=env.max_speed_mps * f, min_speed_mps=env.min_speed_mps * f
    )
