"""The compliance monitor: does the vehicle follow the unit's sticks?

The unit knows what a vehicle following the sticks it sends does, its own while it commands (an override, a
landing in a gap) or the pilot's it passes through (:mod:`geofence.interface`): a multirotor's roll and pitch sticks are bank and pitch angles,
``stick · min(max_bank, max_pitch)``, its throttle a climb rate; a fixed-wing's roll stick is a bank angle,
``stick · max_bank``, its pitch stick a climb rate. The monitor watches both axes against the slowest follower:

* **attitude**: a first-order lag of the commanded angle (time constant ``reaction_time_s``);
* **vertical**: an upper bound on the vertical speed. Told to climb, any climb up to the commanded rate follows;
  told to hold or descend, a following vehicle's climb comes down to the commanded rate (no lower than a descent at
  :data:`VERTICAL_TARGET_MPS`) at :data:`VERTICAL_MODEL_ACCEL_FRACTION` of the envelope's ``vertical_accel_mps2``,
  ``reaction_time_s`` after it was told. Upward only: a vehicle sinking more than commanded (a multirotor sagging while it
  brakes at its tilt limit, a fixed-wing spiralling down at its limit) is following; the flyaway this watch
  exists for climbs on through the ceiling.

The vehicle does not follow when it lags behind the attitude model (farther from the command than the model,
:func:`lag_behind`) or climbs above the vertical bound by more than its threshold (attitude :data:`NONCOMPLIANT_ANGLE_RAD` or
:data:`NONCOMPLIANT_FRACTION` of the tilt limit, the larger, for ``grace_s`` on end; vertical
:data:`NONCOMPLIANT_VERTICAL_MPS` for :data:`VERTICAL_GRACE_FACTOR` times that), the watch starting ``reaction_time_s`` into each stretch of one mode. The tests are one-sided
because the models are conservative: a following vehicle is quicker than the model (a Tern banks 40° in about
0.7 s against the model's 1.1 s time constant) and may overshoot the commanded bank by a few degrees (44-46° for
40°), which is not a miss; and where the vehicle is ahead of a model, the model restarts from it
(:func:`lag_step`; the vertical bound from a vehicle below it). So a flight controller that ignores a full-stick turn or brake is flagged
``reaction_time_s + grace_s`` after it (rounded up to a step) when the command is at least
``threshold / (1 - 1/e)`` from its attitude (30-60°), and one that climbs on through a commanded descent (a
flyaway up through the ceiling) once its climb is :data:`NONCOMPLIANT_VERTICAL_MPS` above the bound,
plus the grace. The thresholds and the grace together: a following vehicle lags behind the models beyond them
only briefly (the measured figures are in ``docs/geofence_design.md``); a vehicle ignoring the unit misses the
command by most of it for as long as it ignores it.

Pure math on the sticks the unit sent and its state estimate; no files, no airframe names.
"""

from __future__ import annotations

import math

from geofence.interface import Envelope, StickCommand, VehicleState
from geofence.physics.control_laws import clip, stick_to_climb_rate

NONCOMPLIANT_ANGLE_RAD = math.radians(15.0)
"""An attitude this far from the lagged command, held for the grace time, is not following (rad)."""
NONCOMPLIANT_FRACTION = 0.4
"""... or this fraction of the tilt (bank) limit, if larger: a 0.4 · 45° = 18° miss for a 45° limit."""
VERTICAL_TARGET_MPS = 1.0
"""The vertical bound's target in a commanded descent: the commanded rate, but no lower than this descent (m/s)."""
VERTICAL_MODEL_ACCEL_FRACTION = 0.5
"""The vertical bound comes down at this fraction of the envelope's ``vertical_accel_mps2``."""
NONCOMPLIANT_VERTICAL_MPS = 2.5
"""A climb this far above the vertical bound, held for :data:`VERTICAL_GRACE_FACTOR` times the grace, is not
following (m/s): a vehicle still climbing at 1.5 m/s once the bound is a descent at 1 m/s."""
VERTICAL_GRACE_FACTOR = 2.0
"""The vertical lag's grace in grace times: a multirotor braking hard balloons up for a few tenths of a second."""

_TIME_EPS_S = 1e-9
"""Times compared to this (a step's time is a sum of floats)."""


class ComplianceMonitor:
    """Watches one stretch of one mode at a time: :meth:`start` as it begins, :meth:`update` at every
    step of it."""

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
        self.env = envelope

    def start(self, t_s: float, est: VehicleState | None = None) -> None:
        """A stretch begins at ``t_s``; the models start at the estimated attitude and vertical speed."""
        self.started_s = t_s
        self.expected_roll_rad = 0.0 if est is None else est.roll_rad
        self.expected_pitch_rad = 0.0 if est is None else est.pitch_rad
        self.expected_v_up_mps = 0.0 if est is None else est.v_up_mps
        self.descent_told_s = math.nan
        self.beyond_since_s = self.climbing_since_s = math.nan
        self.error_rad = 0.0
        self.vertical_error_mps = 0.0
        self.attitude_missed = self.climb_missed = False

    @property
    def noncompliant(self) -> bool:
        """Whether the last step found the vehicle not following (either watch)."""
        return self.attitude_missed or self.climb_missed

    def update(self, t_s: float, dt_s: float, cmd: StickCommand, est: VehicleState) -> bool:
        """One step: the sticks the unit sent (clipped as the controller clips them) and the estimate; returns
        whether the vehicle is not following (a lag beyond its threshold held for its grace)."""
        attitude, vertical = self._attitude_beyond(dt_s, cmd, est), self._vertical_beyond(t_s, dt_s, cmd, est)
        if t_s - self.started_s < self.tau_s - _TIME_EPS_S:
            attitude = vertical = False
        self.beyond_since_s = _since(self.beyond_since_s, attitude, t_s)
        self.climbing_since_s = _since(self.climbing_since_s, vertical, t_s)
        self.attitude_missed = t_s - self.beyond_since_s >= self.grace_s - _TIME_EPS_S  # (False while NaN)
        self.climb_missed = t_s - self.climbing_since_s >= VERTICAL_GRACE_FACTOR * self.grace_s - _TIME_EPS_S
        return self.attitude_missed or self.climb_missed

    @property
    def axis(self) -> str:
        """Which watch flagged the vehicle: ``attitude`` (also when both did) or ``vertical``."""
        return "vertical" if self.climb_missed and not self.attitude_missed else "attitude"

    @property
    def missed_since_s(self) -> float:
        """When the lag that flagged the vehicle began (s; NaN while it follows)."""
        return self.climbing_since_s if self.axis == "vertical" else self.beyond_since_s

    def _attitude_beyond(self, dt_s: float, cmd: StickCommand, est: VehicleState) -> bool:
        a = min(1.0, dt_s / self.tau_s)
        self.expected_roll_rad, err = lag_step(
            clip(cmd.roll, -1.0, 1.0) * self.max_roll_rad, self.expected_roll_rad, est.roll_rad, a
        )
        if self.multirotor:
            target = clip(cmd.pitch, -1.0, 1.0) * self.max_pitch_rad
            self.expected_pitch_rad, lag = lag_step(target, self.expected_pitch_rad, est.pitch_rad, a)
            err = max(err, lag)
        self.error_rad = err
        return err > self.threshold_rad

    def _vertical_beyond(self, t_s: float, dt_s: float, cmd: StickCommand, est: VehicleState) -> bool:
        target = max(-VERTICAL_TARGET_MPS, stick_to_climb_rate(cmd.throttle if self.multirotor else cmd.pitch, self.env))
        bound = self.expected_v_up_mps
        if target >= bound:  # (a climb may come as quickly as the vehicle likes)
            bound, self.descent_told_s = target, math.nan
        else:  # the slowest follower comes down from its climb once it has reacted to being told to
            if self.descent_told_s != self.descent_told_s:  # (NaN: told now)
                self.descent_told_s = t_s
            if t_s - self.descent_told_s >= self.tau_s - _TIME_EPS_S:
                bound -= VERTICAL_MODEL_ACCEL_FRACTION * self.env.vertical_accel_mps2 * dt_s
            bound = max(target, min(bound, est.v_up_mps))
        self.expected_v_up_mps = bound
        self.vertical_error_mps = lag = max(0.0, est.v_up_mps - bound)
        return lag > NONCOMPLIANT_VERTICAL_MPS


def _since(since_s: float, beyond: bool, t_s: float) -> float:
    """A lag timer's start: NaN while within the threshold, else when it went beyond (``t_s`` if just now)."""
    if not beyond:
        return math.nan
    return t_s if since_s != since_s else since_s


def lag_step(command_rad: float, expected_rad: float, estimated_rad: float, a: float) -> tuple[float, float]:
    """One step of the lag model (gain ``a`` = dt / tau): ``(its new attitude, how far the vehicle lags behind it)``.
    Where the vehicle is at least as near the command as the model, the model restarts from the vehicle's attitude:
    it is the slowest follower from where the vehicle got, so a vehicle that led the model into a turn does not
    seem to lag when the command reverses (a Tern 19° past the model at a full reversal, measured)."""
    expected = expected_rad + a * (command_rad - expected_rad)
    lag = lag_behind(command_rad, expected, estimated_rad)
    return (estimated_rad if lag == 0.0 else expected), lag


def lag_behind(command: float, expected: float, estimated: float) -> float:
    """How much farther from the command the estimate is than the model's (>= 0; rad or m/s as they are): 0 for
    a vehicle at least as quick as the model (one settling faster, or overshooting a little, is following)."""
    return max(0.0, abs(command - estimated) - abs(command - expected))
