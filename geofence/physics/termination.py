"""Where a terminated vehicle comes down: the termination footprint, written once.

At flight termination the propulsion is cut and the vehicle falls (a multirotor with its motors off; a
fixed-wing with its engine stopped and its surfaces set for a spin, :meth:`aircraft.platform.Platform.terminate`).
Its path is bounded by two point-mass falls from the estimated height ``h`` with the estimated velocity:

* **no drag** (the farthest it can carry its ground velocity; the wind does not act): it lands at
  ``v_ground · t0`` with ``t0 = (v_up + sqrt(v_up² + 2 g h)) / g``;
* **the most drag** the vehicle may have, a quadratic drag relative to the air with the terminal speed
  ``v_t`` (``a = g - (g / v_t²) |v - w| (v - w)``): its velocity relaxes to the wind's, it falls longer
  and drifts downwind the most.

The touchdown point lies on the path between the two ends (:func:`footprint_points` samples it), within a
radius of the estimate's uncertainty: ``k·σ_h`` of the position, plus the wind estimate's error for the
longest fall time (the wind and the ground velocity come from the same estimator). Lift is not modelled:
a vehicle whose termination leaves it gliding is outside this bound (the fixed-wing's termination spins it,
measured 39 m forward from 70 m at 25 m/s against the no-drag 95 m).

Pure functions on floats (:func:`geofence.jit.jitable`), ENU metres and m/s; tested against an independent
integration (scipy ``solve_ivp``) in ``tests/test_flyaway.py``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from geofence.jit import jitable
from geofence.physics.dynamics import G_MPS2

FALL_STEP_S = 0.005
"""The drag fall's integration step (s): at 5 ms the touchdown point is within 1 cm of an adaptive RK45's for
falls up to 120 m (``tests/test_flyaway.py``)."""
FOOTPRINT_SAMPLES = 5
"""Points on the path between the footprint's two ends at which its margin is taken."""


class Footprint(NamedTuple):
    """A termination footprint, relative to nothing: absolute ENU points (m) and times (s)."""

    far_e_m: float
    """The no-drag end (east)."""
    far_n_m: float
    drag_e_m: float
    """The most-drag end (east)."""
    drag_n_m: float
    radius_m: float
    """The uncertainty radius round the path between the two ends."""
    fall_s: float
    """The longer of the two fall times."""


@jitable
def no_drag_fall_s(h_m: float, v_up_mps: float) -> float:
    """Time to fall ``h_m`` (m, >= 0) from a vertical speed ``v_up_mps`` (+ up) without drag (s)."""
    h = max(h_m, 0.0)
    return (v_up_mps + math.sqrt(v_up_mps * v_up_mps + 2.0 * G_MPS2 * h)) / G_MPS2


@jitable
def drag_fall(
    h_m: float, ve: float, vn: float, vu: float, wind_e: float, wind_n: float, terminal_speed_mps: float
) -> tuple[float, float, float]:
    """``(east, north, t)``: where (relative to the start) and when a point mass with quadratic drag of terminal
    speed ``terminal_speed_mps`` lands, falling ``h_m`` from velocity ``(ve, vn, vu)`` in a horizontal wind
    ``(wind_e, wind_n)`` (fixed-step midpoint integration, :data:`FALL_STEP_S`, the last step interpolated)."""
    if h_m <= 0.0:
        return 0.0, 0.0, 0.0
    c = G_MPS2 / (terminal_speed_mps * terminal_speed_mps)
    dt = FALL_STEP_S
    x = y = t = 0.0
    z = h_m
    while True:
        ae, an, au = _drag_accel(ve, vn, vu, wind_e, wind_n, c)
        me, mn, mu = ve + 0.5 * dt * ae, vn + 0.5 * dt * an, vu + 0.5 * dt * au
        ae, an, au = _drag_accel(me, mn, mu, wind_e, wind_n, c)
        z_next = z + dt * mu
        if z_next <= 0.0:
            f = z / (z - z_next)  # (the fraction of the step to the ground)
            return x + f * dt * me, y + f * dt * mn, t + f * dt
        x, y, z, t = x + dt * me, y + dt * mn, z_next, t + dt
        ve, vn, vu = ve + dt * ae, vn + dt * an, vu + dt * au


@jitable
def _drag_accel(ve: float, vn: float, vu: float, wind_e: float, wind_n: float, c: float) -> tuple[float, float, float]:
    """Gravity and quadratic drag against the air-relative velocity (m/s²)."""
    re, rn = ve - wind_e, vn - wind_n
    s = c * math.sqrt(re * re + rn * rn + vu * vu)
    return -s * re, -s * rn, -G_MPS2 - s * vu


@jitable
def termination_footprint(
    e_m: float, n_m: float, h_m: float, ve: float, vn: float, vu: float, wind_e: float, wind_n: float,
    terminal_speed_mps: float, position_uncertainty_m: float, wind_error_mps: float,
) -> Footprint:  # fmt: skip
    """The footprint of a termination now, from the estimate at ``(e_m, n_m)``, ``h_m`` above the ground, moving
    at ``(ve, vn, vu)`` in the estimated wind: its no-drag and most-drag ends (terminal speed
    ``terminal_speed_mps``) and its radius ``position_uncertainty_m + wind_error_mps · (the longer fall)``."""
    t0 = no_drag_fall_s(h_m, vu)
    de, dn, t1 = drag_fall(h_m, ve, vn, vu, wind_e, wind_n, terminal_speed_mps)
    fall = max(t0, t1)
    return Footprint(e_m + ve * t0, n_m + vn * t0, e_m + de, n_m + dn, position_uncertainty_m + wind_error_mps * fall, fall)


def footprint_points(fp: Footprint) -> list[tuple[float, float]]:
    """:data:`FOOTPRINT_SAMPLES` points on the path from the most-drag end to the no-drag end (both included)."""
    k = FOOTPRINT_SAMPLES - 1
    return [
        (fp.drag_e_m + (fp.far_e_m - fp.drag_e_m) * i / k, fp.drag_n_m + (fp.far_n_m - fp.drag_n_m) * i / k) for i in range(k + 1)
    ]
