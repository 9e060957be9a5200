"""The compliance monitor: does the vehicle follow the override's sticks?

During an override the unit commands an attitude (:mod:`geofence.interface`: a multirotor's roll and pitch
sticks are bank and pitch angles, ``stick · min(max_bank, max_pitch)``; a fixed-wing's roll stick is a bank
angle, ``stick · max_bank``; its pitch stick is a climb rate, not an attitude, and is not watched). A vehicle
that follows settles on the commanded attitude in about the envelope's ``reaction_time_s``; the monitor models
that as a first-order lag of the commanded angle (time constant ``reaction_time_s``) and compares it with the
estimated attitude.

The vehicle does not follow when it lags behind that model (its attitude farther from the command than the
model's, :func:`lag_behind_rad`) by more than :data:`NONCOMPLIANT_ANGLE_RAD` (or :data:`NONCOMPLIANT_FRACTION` of
the tilt limit, the larger) for ``grace_s`` on end, the watch starting ``reaction_time_s`` after the override
began. The test is one-sided because ``reaction_time_s`` is a conservative roll-in time: a following vehicle is
quicker than the model (a Tern banks 40° in about 0.7 s against the model's 1.1 s time constant) and may
overshoot the commanded bank by a few degrees (44-46° for 40°), which is not a miss; and where the vehicle is
ahead of the model, the model restarts from it (:func:`lag_step`). So a flight controller that
ignores the override from its start is flagged ``reaction_time_s + grace_s`` after it (rounded up to a step)
when the command is at least ``threshold / (1 - 1/e)`` away from its attitude (a full-stick turn or brake: 30-60°).
The threshold and the grace together: a following vehicle lags behind the model beyond the threshold only
briefly, where a rate-limited controller reverses a full command (an F450RD up to 33° for 0.225 s at most, a
fixed-wing never beyond 13°, on the overrides of the golden flights, the shipped geofence and airspace
scenarios and the CI campaign slice: 50 flights, none flagged; a flag would change the golden flights); a
vehicle ignoring a turn or a brake misses it by most of the commanded angle (30-60°) for as long as it ignores
it.

Pure math on the unit's commanded sticks and its state estimate; no files, no airframe names.
"""

from __future__ import annotations

import math

from geofence.interface import Envelope

NONCOMPLIANT_ANGLE_RAD = math.radians(15.0)
"""An attitude this far from the lagged command, held for the grace time, is not following (rad)."""
NONCOMPLIANT_FRACTION = 0.4
"""... or this fraction of the tilt (bank) limit, if larger: a 0.4 · 45° = 18° miss for a 45° limit."""

_TIME_EPS_S = 1e-9
"""Times compared to this (a step's time is a sum of floats)."""


class ComplianceMonitor:
    """Watches one override at a time: :meth:`start` as it begins, :meth:`update` at every override step."""

    def __init__(self, envelope: Envelope, grace_s: float) -> None:
        self.grace_s = grace_s
        self.set_envelope(envelope)
        self.start(0.0)

    def set_envelope(self, envelope: Envelope) -> None:
        """The envelope the commands are read with (the unit's, scaled to the air density)."""
        self.multirotor = envelope.is_multirotor
        self.tau_s = max(envelope.reaction_time_s, 1e-3)
        self.max_roll_rad = min(envelope.max_bank_rad, envelope.max_pitch_rad) if self.multirotor else envelope.max_bank_rad
        self.max_pitch_rad = self.max_roll_rad
        self.threshold_rad = max(NONCOMPLIANT_ANGLE_RAD, NONCOMPLIANT_FRACTION * self.max_roll_rad)

    def start(self, t_s: float, roll_rad: float = 0.0, pitch_rad: float = 0.0) -> None:
        """An override begins at ``t_s``; the lag model starts at the estimated attitude."""
        self.started_s = t_s
        self.expected_roll_rad, self.expected_pitch_rad = roll_rad, pitch_rad
        self.beyond_since_s = math.nan
        self.error_rad = 0.0
        self.noncompliant = False

    def update(self, t_s: float, dt_s: float, roll_stick: float, pitch_stick: float, roll_rad: float, pitch_rad: float) -> bool:
        """One override step: the commanded sticks (clipped as the controller clips them) and the estimated
        attitude; returns whether the vehicle is not following (its lag held for ``grace_s``)."""
        a = min(1.0, dt_s / self.tau_s)
        cmd = max(-1.0, min(1.0, roll_stick)) * self.max_roll_rad
        self.expected_roll_rad, err = lag_step(cmd, self.expected_roll_rad, roll_rad, a)
        if self.multirotor:
            cmd = max(-1.0, min(1.0, pitch_stick)) * self.max_pitch_rad
            self.expected_pitch_rad, lag = lag_step(cmd, self.expected_pitch_rad, pitch_rad, a)
            err = max(err, lag)
        self.error_rad = err
        if t_s - self.started_s < self.tau_s - _TIME_EPS_S or err <= self.threshold_rad:
            self.beyond_since_s = math.nan
            self.noncompliant = False
            return False
        if self.beyond_since_s != self.beyond_since_s:  # (NaN: the lag starts now)
            self.beyond_since_s = t_s
        self.noncompliant = t_s - self.beyond_since_s >= self.grace_s - _TIME_EPS_S
        return self.noncompliant


def lag_step(command_rad: float, expected_rad: float, estimated_rad: float, a: float) -> tuple[float, float]:
    """One step of the lag model (gain ``a`` = dt / tau): ``(its new attitude, how far the vehicle lags behind it)``.
    Where the vehicle is at least as near the command as the model, the model restarts from the vehicle's attitude:
    it is the slowest follower from where the vehicle got, so a vehicle that led the model into a turn does not
    seem to lag when the command reverses (a Tern 19° past the model at a full reversal, measured)."""
    expected = expected_rad + a * (command_rad - expected_rad)
    lag = lag_behind_rad(command_rad, expected, estimated_rad)
    return (estimated_rad if lag == 0.0 else expected), lag


def lag_behind_rad(command_rad: float, expected_rad: float, estimated_rad: float) -> float:
    """How much farther from the command the estimated attitude is than the lag model's (rad, >= 0): 0 for a
    vehicle at least as quick as the model (one settling faster, or overshooting a little, is following)."""
    return max(0.0, abs(command_rad - estimated_rad) - abs(command_rad - expected_rad))
