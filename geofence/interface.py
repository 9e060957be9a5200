"""The geofence unit's interface: what it reads and what it emits.

This module owns the three small value types that cross the boundary between
the geofence, the pilot/autopilot and the aircraft's flight controller:

* :class:`StickCommand`: normalized outer-loop sticks, the way an RC pilot or an
  autopilot feeds a commercial flight controller.
* :class:`VehicleState`: a state (truth or estimate) in the local ENU frame.
* :class:`Envelope`: the platform's declared performance limits.

Nothing here knows which airframe it describes, and nothing imports JSBSim.

Stick semantics (each stick in [-1, 1]):

========  ==========================================  ==========================================
stick     multirotor (angle mode + altitude hold)     fixed-wing (FBW-B style: bank + climb rate)
========  ==========================================  ==========================================
roll      bank = roll * max_bank_rad (+ right)        bank = roll * max_bank_rad (+ right)
pitch     pitch = pitch * max_pitch_rad (+ nose up,   climb rate: +1 -> max_climb_rate_mps,
          i.e. +pitch decelerates / flies backwards)  -1 -> max_descent_rate_mps, 0 holds altitude
yaw       yaw rate = yaw * max_yaw_rate_radps         rudder offset (+ nose right) on top of the
          (+ nose right)                              turn coordinator; 0 = coordinated
throttle  climb rate: +1 -> max_climb_rate_mps,       airspeed: -1 -> min_speed_mps,
          -1 -> max_descent_rate_mps, 0 holds alt     0 -> cruise_speed_mps, +1 -> max_speed_mps
========  ==========================================  ==========================================

All sticks at 0 therefore mean "level, hold altitude" on every platform
(hover for a multirotor, straight and level at cruise for a fixed-wing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import NamedTuple


class PlatformKind(str, Enum):
    """How the platform turns back: by braking (multirotor) or by turning (fixed-wing)."""

    MULTIROTOR = "multirotor"
    FIXED_WING = "fixed_wing"


class StickCommand(NamedTuple):
    """Normalized outer-loop sticks, each in [-1, 1] (see the module docstring).

    An immutable named tuple: the pilot, the unit and the guidance laws build several per step, and a tuple
    is built in a third of the time of a frozen dataclass.
    """

    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0
    throttle: float = 0.0

    def clipped(self) -> "StickCommand":
        """The same command with every stick clipped to [-1, 1]."""
        return StickCommand(_clip1(self.roll), _clip1(self.pitch), _clip1(self.yaw), _clip1(self.throttle))


def _clip1(x: float) -> float:
    return -1.0 if x < -1.0 else (1.0 if x > 1.0 else x)


@dataclass(frozen=True, slots=True)
class Envelope:
    """A platform's declared performance envelope (SI units).

    ``max_bank_rad`` is the bank limit of a fixed-wing aircraft or the tilt limit
    of a multirotor. ``min_speed_mps`` is 0 for a multirotor (it can hover).
    ``braking_decel_mps2`` is the horizontal deceleration the platform can hold
    when stopping; ``vertical_accel_mps2`` is the acceleration available to
    arrest a climb or descent; ``reaction_time_s`` is the latency from a command
    to the start of the response.

    Horizontal air drag per unit mass (multirotor), as a function of the
    airspeed ``v``: ``a = drag_linear_per_s·v + drag_quadratic_per_m·v²``. The
    linear part is rotor drag (blade flapping / induced drag), the quadratic
    part the airframe's parasitic drag. Both 0 (the default) means "not
    identified": :func:`geofence.physics.dynamics.drag_coefficients` then takes a
    purely quadratic law that balances the tilt limit at ``max_speed_mps``.
    Unused for a fixed-wing (it flies at an airspeed, not against a drag).
    """

    kind: PlatformKind
    cruise_speed_mps: float
    max_speed_mps: float
    min_speed_mps: float
    max_bank_rad: float
    max_pitch_rad: float
    max_yaw_rate_radps: float
    max_climb_rate_mps: float
    max_descent_rate_mps: float
    braking_decel_mps2: float
    vertical_accel_mps2: float
    reaction_time_s: float
    drag_linear_per_s: float = 0.0
    drag_quadratic_per_m: float = 0.0

    @property
    def is_multirotor(self) -> bool:
        return self.kind is PlatformKind.MULTIROTOR


@dataclass(slots=True)
class VehicleState:
    """A vehicle state, truth or estimate.

    Position is geodetic (WGS-84 lat/lon in deg, altitude above mean sea level
    in m) and also local ENU in m about the scenario origin; ``agl_m`` is the
    height above the local ground. Velocities are ground-relative ENU in m/s.
    Attitude is in rad (yaw is the true heading, clockwise from north).
    ``airspeed_mps`` is the true airspeed.
    """

    t_s: float = 0.0
    lat_deg: float = 0.0
    lon_deg: float = 0.0
    alt_m: float = 0.0
    east_m: float = 0.0
    north_m: float = 0.0
    up_m: float = 0.0
    agl_m: float = 0.0
    v_east_mps: float = 0.0
    v_north_mps: float = 0.0
    v_up_mps: float = 0.0
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = 0.0
    airspeed_mps: float = 0.0
    on_ground: bool = False

    @property
    def ground_speed_mps(self) -> float:
        return math.hypot(self.v_east_mps, self.v_north_mps)


class FixState(NamedTuple):
    """The horizontal estimate at its newest GNSS data's time of validity (the fusion horizon), not extrapolated.

    A position estimator fuses each fix at the fix's own time and extrapolates from there to the present;
    when fixes stop, dead reckoning starts best from this state, replaying the attitude since ``t_s``.
    """

    t_s: float
    east_m: float
    north_m: float
    v_east_mps: float
    v_north_mps: float
