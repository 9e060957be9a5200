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

Pure math on the sticks the unit sent and its state estimate; no files, no airframe names. The watch's state is one
record over float memory (:data:`WATCH_STATE`, the pattern of :data:`geofence.unit.passes.UNIT_STATE`) and its step
one function, :func:`watch_step`: the unit's Python step calls it compiled (:data:`watch`), and a compiled flight
step inlines the same source (:mod:`scenarios.flight.step_kernel`). :class:`ComplianceMonitor` is its façade.
"""

from __future__ import annotations

import math

import numpy as np

from geofence.interface import Envelope, StickCommand, VehicleState
from geofence.jit import compiled, jitable
from geofence.physics.control_laws import climb_rate_of_stick, clip
from geofence.unit.passes import float_record

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

WATCH_STATE = float_record(
    # the envelope's numbers the commands are read with (set_envelope) and the grace (set once)
    "multirotor", "tau_s", "max_tilt_rad", "threshold_rad", "vertical_accel_mps2", "max_climb_mps",
    "max_descent_mps", "grace_s",
    # the stretch watched: the unit's mode's start (NaN: none, or on the ground) and the watch's own start
    "watched_since_s", "started_s",
    # the models and the lag timers (NaN: within the threshold), the last step's misses and flags
    "expected_roll_rad", "expected_pitch_rad", "expected_v_up_mps", "descent_told_s", "beyond_since_s",
    "climbing_since_s", "error_rad", "vertical_error_mps", "attitude_missed", "climb_missed",
)  # fmt: skip
"""The compliance watch's state, one record over float memory (a flag 0 or 1) that :class:`ComplianceMonitor` owns
(:attr:`ComplianceMonitor.memory`) and a compiled flight step passes to :func:`watch_step`."""
WATCH_SIZE = WATCH_STATE.itemsize // 8
"""Float64 slots of the watch's record."""


class ComplianceMonitor:
    """The watch of one unit (a façade over its record, :data:`WATCH_STATE`): :meth:`watch` at every step (it starts
    a new stretch with each of the unit's modes), or by hand :meth:`start` as a stretch begins and :meth:`update`
    at every step of it."""

    def __init__(self, envelope: Envelope, grace_s: float) -> None:
        self.memory = np.zeros(WATCH_SIZE)
        """The record's float memory (:data:`WATCH_STATE`), which a compiled flight step reads and writes in place."""
        self._w = self.memory.view(WATCH_STATE)[0]
        self._w.grace_s = grace_s
        self.set_envelope(envelope)
        self.start(0.0)

    def set_envelope(self, envelope: Envelope) -> None:
        """The envelope the commands are read with (the unit's, scaled to the air density, from when it is)."""
        w = self._w
        multirotor = envelope.is_multirotor
        tilt = min(envelope.max_bank_rad, envelope.max_pitch_rad) if multirotor else envelope.max_bank_rad
        w.multirotor, w.tau_s, w.max_tilt_rad = multirotor, max(envelope.reaction_time_s, 1e-3), tilt
        w.threshold_rad = max(NONCOMPLIANT_ANGLE_RAD, NONCOMPLIANT_FRACTION * tilt)
        w.vertical_accel_mps2 = envelope.vertical_accel_mps2
        w.max_climb_mps, w.max_descent_mps = envelope.max_climb_rate_mps, envelope.max_descent_rate_mps

    def start(self, t_s: float, est: VehicleState | None = None) -> None:
        """A stretch begins at ``t_s``; the models start at the estimated attitude and vertical speed."""
        s = VehicleState() if est is None else est
        watch_start(self.memory, t_s, s.roll_rad, s.pitch_rad, s.v_up_mps)
        self._w.watched_since_s = t_s  # (update goes on with this stretch)

    def update(self, t_s: float, dt_s: float, cmd: StickCommand, est: VehicleState) -> bool:
        """One step of the stretch :meth:`start` began: the sticks the unit sent (clipped as the controller clips
        them) and the estimate; returns whether the vehicle is not following (a lag beyond its threshold held for
        its grace)."""
        return self.watch(t_s, dt_s, True, float(self._w.watched_since_s), cmd, est)

    def watch(
        self, t_s: float, dt_s: float, commanding: bool, mode_since_s: float, cmd: StickCommand, est: VehicleState
    ) -> bool:  # fmt: skip
        """One step of the unit's watch (:func:`watch_step`, compiled): ``commanding`` the unit's sticks or the
        pilot's, in the unit's mode since ``mode_since_s``; whether the vehicle is not following."""
        return bool(
            watch(
                self.memory, t_s, dt_s, commanding, mode_since_s, cmd.roll, cmd.pitch, cmd.throttle, est.on_ground,
                est.roll_rad, est.pitch_rad, est.v_up_mps,
            )
        )  # fmt: skip

    @property
    def multirotor(self) -> bool:
        return bool(self._w.multirotor)

    @property
    def tau_s(self) -> float:
        """The attitude model's time constant (s): the envelope's reaction time."""
        return float(self._w.tau_s)

    @property
    def max_roll_rad(self) -> float:
        """The attitude a full stick commands (rad): a multirotor's tilt limit (bank and pitch), a fixed-wing's bank."""
        return float(self._w.max_tilt_rad)

    @property
    def threshold_rad(self) -> float:
        """The attitude miss that is not following, held for the grace (rad)."""
        return float(self._w.threshold_rad)

    @property
    def grace_s(self) -> float:
        return float(self._w.grace_s)

    @property
    def error_rad(self) -> float:
        """The last step's attitude lag behind the model (rad)."""
        return float(self._w.error_rad)

    @property
    def vertical_error_mps(self) -> float:
        """The last step's climb above the vertical bound (m/s)."""
        return float(self._w.vertical_error_mps)

    @property
    def attitude_missed(self) -> bool:
        return bool(self._w.attitude_missed)

    @property
    def climb_missed(self) -> bool:
        return bool(self._w.climb_missed)

    @property
    def noncompliant(self) -> bool:
        """Whether the last step found the vehicle not following (either watch)."""
        return self.attitude_missed or self.climb_missed

    @property
    def lagging(self) -> bool:
        """Whether the vehicle lags behind a model now (a lag timer runs, or the last step flagged it): it is not
        doing what it was told, so where it goes says nothing about the air it flies in."""
        w = self._w
        return self.noncompliant or not (math.isnan(w.beyond_since_s) and math.isnan(w.climbing_since_s))

    @property
    def axis(self) -> str:
        """Which watch flagged the vehicle: ``attitude`` (also when both did) or ``vertical``."""
        return "vertical" if self.climb_missed and not self.attitude_missed else "attitude"

    @property
    def missed_since_s(self) -> float:
        """When the lag that flagged the vehicle began (s; NaN while it follows)."""
        w = self._w
        return float(w.climbing_since_s if self.axis == "vertical" else w.beyond_since_s)


@jitable
def watch_step(
    W: np.ndarray, t_s: float, dt_s: float, commanding: bool, mode_since_s: float, c_roll: float, c_pitch: float,
    c_throttle: float, on_ground: bool, roll_rad: float, pitch_rad: float, v_up_mps: float,
) -> bool:  # fmt: skip
    """A step of the watch on record ``W``'s memory: the sticks sent (``c_*``; the unit's while ``commanding``, else
    the pilot's it passed on) against the estimate's attitude and vertical speed, in the unit's mode since
    ``mode_since_s`` (a new value starts a new stretch: the models from the estimate). On the ground under the
    pilot's sticks (before a take-off) nothing is watched; watched again from the lift-off. Returns whether the
    vehicle is not following."""
    w = W.view(WATCH_STATE)[0]
    if on_ground and not commanding:
        w.watched_since_s = math.nan
        return False
    if w.watched_since_s != mode_since_s:  # a new stretch of one mode (or a lift-off; NaN: none yet)
        w.watched_since_s = mode_since_s
        watch_start(W, t_s, roll_rad, pitch_rad, v_up_mps)
    attitude = _attitude_beyond(w, dt_s, c_roll, c_pitch, roll_rad, pitch_rad)
    vertical = _vertical_beyond(w, t_s, dt_s, c_pitch if w.multirotor == 0.0 else c_throttle, v_up_mps)
    if t_s - w.started_s < w.tau_s - _TIME_EPS_S:
        attitude = vertical = False
    w.beyond_since_s = _since(w.beyond_since_s, attitude, t_s)
    w.climbing_since_s = _since(w.climbing_since_s, vertical, t_s)
    w.attitude_missed = t_s - w.beyond_since_s >= w.grace_s - _TIME_EPS_S  # (False while NaN)
    w.climb_missed = t_s - w.climbing_since_s >= VERTICAL_GRACE_FACTOR * w.grace_s - _TIME_EPS_S
    return w.attitude_missed != 0.0 or w.climb_missed != 0.0


watch = compiled(watch_step)
"""The compiled :func:`watch_step` (the unit's Python steps call it)."""


@jitable
def watch_start(W: np.ndarray, t_s: float, roll_rad: float, pitch_rad: float, v_up_mps: float) -> None:
    """A stretch begins at ``t_s``: the models start at the estimated attitude and vertical speed, the timers clear."""
    w = W.view(WATCH_STATE)[0]
    w.started_s = t_s
    w.expected_roll_rad, w.expected_pitch_rad, w.expected_v_up_mps = roll_rad, pitch_rad, v_up_mps
    w.descent_told_s = w.beyond_since_s = w.climbing_since_s = math.nan
    w.error_rad = w.vertical_error_mps = 0.0
    w.attitude_missed = w.climb_missed = 0.0


@jitable
def _attitude_beyond(w, dt_s: float, c_roll: float, c_pitch: float, roll_rad: float, pitch_rad: float) -> bool:
    """The attitude models' step (the roll's; a multirotor's pitch too): whether the lag is beyond the threshold."""
    a = min(1.0, dt_s / w.tau_s)
    tilt = w.max_tilt_rad
    w.expected_roll_rad, err = lag_step(clip(c_roll, -1.0, 1.0) * tilt, w.expected_roll_rad, roll_rad, a)
    if w.multirotor != 0.0:
        w.expected_pitch_rad, lag = lag_step(clip(c_pitch, -1.0, 1.0) * tilt, w.expected_pitch_rad, pitch_rad, a)
        err = max(err, lag)
    w.error_rad = err
    return err > w.threshold_rad


@jitable
def _vertical_beyond(w, t_s: float, dt_s: float, climb_stick: float, v_up_mps: float) -> bool:
    """The vertical bound's step (``climb_stick``: a multirotor's throttle, a fixed-wing's pitch): whether the climb
    is beyond the threshold above it."""
    target = max(-VERTICAL_TARGET_MPS, climb_rate_of_stick(climb_stick, w.max_climb_mps, w.max_descent_mps))
    bound = w.expected_v_up_mps
    if target >= bound:  # (a climb may come as quickly as the vehicle likes)
        bound, w.descent_told_s = target, math.nan
    else:  # the slowest follower comes down from its climb once it has reacted to being told to
        if w.descent_told_s != w.descent_told_s:  # (NaN: told now)
            w.descent_told_s = t_s
        if t_s - w.descent_told_s >= w.tau_s - _TIME_EPS_S:
            bound -= VERTICAL_MODEL_ACCEL_FRACTION * w.vertical_accel_mps2 * dt_s
        bound = max(target, min(bound, v_up_mps))
    w.expected_v_up_mps = bound
    lag = max(0.0, v_up_mps - bound)
    w.vertical_error_mps = lag
    return lag > NONCOMPLIANT_VERTICAL_MPS


@jitable
def _since(since_s: float, beyond: bool, t_s: float) -> float:
    """A lag timer's start: NaN while within the threshold, else when it went beyond (``t_s`` if just now)."""
    if not beyond:
        return math.nan
    return t_s if since_s != since_s else since_s


@jitable
def lag_step(command_rad: float, expected_rad: float, estimated_rad: float, a: float) -> tuple[float, float]:
    """One step of the lag model (gain ``a`` = dt / tau): ``(its new attitude, how far the vehicle lags behind it)``.
    Where the vehicle is at least as near the command as the model, the model restarts from the vehicle's attitude:
    it is the slowest follower from where the vehicle got, so a vehicle that led the model into a turn does not
    seem to lag when the command reverses (a Tern 19° past the model at a full reversal, measured)."""
    expected = expected_rad + a * (command_rad - expected_rad)
    lag = lag_behind(command_rad, expected, estimated_rad)
    return (estimated_rad if lag == 0.0 else expected), lag


@jitable
def lag_behind(command: float, expected: float, estimated: float) -> float:
    """How much farther from the command the estimate is than the model's (>= 0; rad or m/s as they are): 0 for
    a vehicle at least as quick as the model (one settling faster, or overshooting a little, is following)."""
    return max(0.0, abs(command - estimated) - abs(command - expected))
