"""A pilot's law on arrays: the sticks a pilot flies at a step, from the truth's fields and the demands it latched,
for the compiled step of the closed loop (:mod:`scenarios.flight.step_kernel`).

One question: which sticks does the pilot send at this step? A pilot that has a compiled form of its law keeps
its demands in one record over float memory (:data:`LAW`), written when they change (a scripted pilot: when a segment
starts); :func:`law_sticks` answers from them. Its kinds:

* :data:`GIVEN`: no compiled law this step: the pilot's own sticks are passed in (a pilot without one, a
  multirotor's velocity loop, whose integrator lives in its navigator);
* :data:`HELD_STICKS`: the sticks in the array (a raw-sticks segment);
* :data:`FIXED_WING_COURSE`: :meth:`~scenarios.flight.pilots.nav_laws.FixedWingNavigator.sticks` the short way:
  a course, flown at an airspeed's throttle stick, holding a height or at a climb stick
  (:func:`~scenarios.flight.pilots.nav_laws.course_law_sticks`, the same function in Python).

The pilot's own ``command`` answers through its objects (the navigator, on the same functions), so a step flown
either way sends the same sticks (``tests/test_flight_step.py``, ``tests/test_pilot_law.py``).
"""

from __future__ import annotations

from math import hypot
from typing import Any, NamedTuple

import numpy as np

from geofence.interface import Envelope, VehicleState
from geofence.jit import jitable
from geofence.physics.control_laws import course_error_rad
from geofence.unit.passes import float_record
from scenarios.flight.pilots.nav_laws import course_law_sticks

# the kinds (the record's ``kind``)
GIVEN = 0.0
HELD_STICKS = 1.0
FIXED_WING_COURSE = 2.0

LAW = float_record(
    "kind",
    # HELD_STICKS: the sticks; FIXED_WING_COURSE: throttle, its throttle stick
    "roll", "pitch", "yaw", "throttle",
    # FIXED_WING_COURSE: the course (rad clockwise from north), the height to hold (m up; where climb_stick is
    # NaN) or the climb (pitch) stick, the navigator's gains (1/s), the envelope's bank limit (rad), climb and
    # descent rates (m/s)
    "course_rad", "hold_up_m", "climb_stick", "altitude_gain_per_s", "course_gain_per_s", "max_bank_rad",
    "max_climb_mps", "max_descent_mps",
)  # fmt: skip
"""A pilot's law, one record over float memory (the pattern of :data:`geofence.unit.passes.UNIT_STATE`): the
pilot writes it when its demands change, the compiled step reads it."""
LAW_SIZE = LAW.itemsize // 8


class _LawEnvelope(NamedTuple):
    """The :class:`Envelope` fields :func:`course_law_sticks` reads, for compiled code."""

    max_bank_rad: float
    max_climb_rate_mps: float
    max_descent_rate_mps: float


class _LawState(NamedTuple):
    """The :class:`VehicleState` fields :func:`course_error_rad` reads, for compiled code."""

    v_east_mps: float
    v_north_mps: float
    yaw_rad: float


def law_array() -> np.ndarray:
    """A pilot's law record's memory (:data:`LAW`), of kind :data:`GIVEN`."""
    return np.zeros(LAW_SIZE)


def law_record(A: np.ndarray) -> Any:
    """The record :data:`LAW` over a law array ``A`` (its fields read and written in place)."""
    return A.view(LAW)[0]


def hold_sticks(A: np.ndarray, roll: float, pitch: float, yaw: float, throttle: float) -> None:
    """Make ``A`` fly these sticks (:data:`HELD_STICKS`)."""
    a = law_record(A)
    a.kind, a.roll, a.pitch, a.yaw, a.throttle = HELD_STICKS, roll, pitch, yaw, throttle


def fly_course(
    A: np.ndarray, course_rad: float, hold_up_m: float, climb_stick: float | None, throttle_stick: float,
    altitude_gain_per_s: float, course_gain_per_s: float, env: Envelope,
) -> None:  # fmt: skip
    """Make ``A`` fly a course (:data:`FIXED_WING_COURSE`): at ``throttle_stick``, holding ``hold_up_m`` or, given,
    at ``climb_stick``; the navigator's gains and the envelope's limits."""
    a = law_record(A)
    a.kind, a.course_rad, a.hold_up_m = FIXED_WING_COURSE, course_rad, hold_up_m
    a.climb_stick = np.nan if climb_stick is None else climb_stick
    a.throttle, a.altitude_gain_per_s, a.course_gain_per_s = throttle_stick, altitude_gain_per_s, course_gain_per_s
    a.max_bank_rad, a.max_climb_mps, a.max_descent_mps = env.max_bank_rad, env.max_climb_rate_mps, env.max_descent_rate_mps


@jitable
def law_kind(A: np.ndarray) -> float:
    """The kind of the law in ``A`` (:data:`GIVEN`, :data:`HELD_STICKS`, :data:`FIXED_WING_COURSE`)."""
    return A.view(LAW)[0].kind


@jitable
def law_sticks(A: np.ndarray, ve: float, vn: float, yaw: float, up: float) -> tuple[float, float, float, float]:
    """``(roll, pitch, yaw, throttle)`` of the law in ``A`` at the truth's velocity (east, north), heading and
    height (m up); :data:`GIVEN` has none (zeros: the caller passes the pilot's)."""
    a = A.view(LAW)[0]
    kind = a.kind
    if kind == FIXED_WING_COURSE:
        # the laws read these fields by name, as they read an Envelope's and a VehicleState's
        env: Envelope = _LawEnvelope(a.max_bank_rad, a.max_climb_mps, a.max_descent_mps)  # type: ignore[assignment]
        state: VehicleState = _LawState(ve, vn, yaw)  # type: ignore[assignment]
        err = course_error_rad(state, a.course_rad)
        roll, pitch = course_law_sticks(
            hypot(ve, vn), err, up, a.hold_up_m, a.climb_stick, a.altitude_gain_per_s, a.course_gain_per_s, env
        )  # fmt: skip
        return roll, pitch, 0.0, a.throttle
    if kind == HELD_STICKS:
        return a.roll, a.pitch, a.yaw, a.throttle
    return 0.0, 0.0, 0.0, 0.0
