"""Sticks over MAVLink: :class:`~geofence.interface.StickCommand` <-> RC_CHANNELS_OVERRIDE / MANUAL_CONTROL.

A companion overrides a pilot the way the flight controller lets it:

* **ArduPilot**: RC_CHANNELS_OVERRIDE from the ground-station system id (``SYSID_MYGCS``, 255 by default). With
  the default ``RCMAP_*`` chan1 = roll, chan2 = pitch, chan3 = throttle, chan4 = yaw; each stick maps linearly to
  ``PWM = 1500 + 500 * stick`` us, rounded to an integer (the project's throttle stick is centred, in [-1, 1], so
  it is 1000..2000 us like the others). On chan1..8 a value of 0 releases the channel to the RC receiver and
  UINT16_MAX leaves it as it is. An overridden channel times out ``RC_OVERRIDE_TIME`` (3 s) after the last
  message that set it.
* **PX4**: MANUAL_CONTROL to the vehicle's system: ``x = pitch*1000``, ``y = roll*1000``,
  ``z = (throttle+1)*500`` (0..1000), ``r = yaw*1000``. It is honoured until ``COM_RC_LOSS_T`` (0.5 s) passes
  without one; there is no explicit release (the companion stops sending).

The stick values are exactly :class:`StickCommand`'s (its signs and meanings, see :mod:`geofence.interface`); the
mappings are linear both ways. :class:`OverrideInput` is the vehicle's side: which overrides it has received
and which it honours at a given time.
"""

from __future__ import annotations

import math
from enum import Enum
from typing import Any

from pymavlink import mavutil

from geofence.interface import StickCommand

mav: Any = mavutil.mavlink

RC_OVERRIDE_TIME_S = 3.0
"""ArduPilot ``RC_OVERRIDE_TIME``: an overridden channel reverts to RC this long after its last override."""
COM_RC_LOSS_T_S = 0.5
"""PX4 ``COM_RC_LOSS_T``: MANUAL_CONTROL is no longer used this long after the last one."""
SYSID_MYGCS = 255
"""ArduPilot ``SYSID_MYGCS``: the only system whose RC_CHANNELS_OVERRIDE it accepts."""

PWM_CENTRE_US = 1500
PWM_HALF_RANGE_US = 500
CHANNEL_RELEASE = 0
"""chan1..8 value that hands a channel back to the RC receiver."""
CHANNEL_IGNORE = 65535
"""chan1..8 value (UINT16_MAX) that leaves a channel as it is."""
MANUAL_CONTROL_FULL_SCALE = 1000
"""MANUAL_CONTROL's x, y, r at a full stick; z spans 0..1000."""

STICK_CHANNELS = ("roll", "pitch", "throttle", "yaw")
"""The StickCommand field on chan1..chan4 (ArduPilot's default RCMAP_ROLL/PITCH/THROTTLE/YAW = 1/2/3/4)."""


class Autopilot(str, Enum):
    """Which flight controller's conventions the link follows."""

    ARDUPILOT = "ardupilot"
    PX4 = "px4"


def _clip1(x: float) -> float:
    return -1.0 if x < -1.0 else (1.0 if x > 1.0 else x)


def stick_to_pwm(stick: float) -> int:
    """A stick in [-1, 1] (clipped) as an RC pulse width, us (1000..2000)."""
    return int(round(PWM_CENTRE_US + PWM_HALF_RANGE_US * _clip1(stick)))


def pwm_to_stick(pwm_us: int) -> float:
    """An RC pulse width, us, as a stick in [-1, 1] (clipped)."""
    return _clip1((pwm_us - PWM_CENTRE_US) / PWM_HALF_RANGE_US)


def rc_override(cmd: StickCommand, target_system: int, target_component: int = 1) -> Any:
    """RC_CHANNELS_OVERRIDE setting chan1..4 to ``cmd``; chan5..8 left as they are (UINT16_MAX)."""
    pwm = [stick_to_pwm(getattr(cmd, name)) for name in STICK_CHANNELS]
    return mav.MAVLink_rc_channels_override_message(target_system, target_component, *pwm, *([CHANNEL_IGNORE] * 4))


def rc_release(target_system: int, target_component: int = 1) -> Any:
    """RC_CHANNELS_OVERRIDE releasing every channel chan1..8 to RC (0), as a companion does on hand-back."""
    return mav.MAVLink_rc_channels_override_message(target_system, target_component, *([CHANNEL_RELEASE] * 8))


def manual_control(cmd: StickCommand, target_system: int) -> Any:
    """MANUAL_CONTROL carrying ``cmd`` (clipped) to ``target_system``."""
    c = cmd.clipped()
    k = MANUAL_CONTROL_FULL_SCALE
    z = int(round((c.throttle + 1.0) * k / 2.0))
    return mav.MAVLink_manual_control_message(
        target_system, int(round(c.pitch * k)), int(round(c.roll * k)), z, int(round(c.yaw * k)), 0
    )


def manual_control_sticks(msg: Any) -> StickCommand:
    """The sticks a MANUAL_CONTROL message carries (clipped to [-1, 1])."""
    k = MANUAL_CONTROL_FULL_SCALE
    return StickCommand(
        roll=_clip1(msg.y / k), pitch=_clip1(msg.x / k), yaw=_clip1(msg.r / k), throttle=_clip1(2.0 * msg.z / k - 1.0)
    )


def rc_override_channels(msg: Any) -> tuple[float | None | bool, ...]:
    """chan1..4 of an RC_CHANNELS_OVERRIDE in :data:`STICK_CHANNELS` order: a stick value, ``None`` (released) or
    ``False`` (left as it is)."""
    out: list[float | None | bool] = []
    for i in range(len(STICK_CHANNELS)):
        raw = getattr(msg, f"chan{i + 1}_raw")
        out.append(False if raw == CHANNEL_IGNORE else None if raw == CHANNEL_RELEASE else pwm_to_stick(raw))
    return tuple(out)


class OverrideInput:
    """The vehicle's record of the overrides received, and the sticks it flies with at a time.

    ArduPilot mode: each of chan1..4 is held from the message that set it until it is released or
    ``rc_override_time_s`` passes (negative: never times out; 0: overrides disabled), accepted only from
    ``gcs_system``. PX4 mode: the newest MANUAL_CONTROL addressed to ``own_system`` sets all four sticks until
    ``manual_timeout_s`` passes. Times are the vehicle's (simulated) clock, s.
    """

    def __init__(
        self, autopilot: Autopilot, *, own_system: int = 1, gcs_system: int = SYSID_MYGCS,
        rc_override_time_s: float = RC_OVERRIDE_TIME_S, manual_timeout_s: float = COM_RC_LOSS_T_S,
    ) -> None:  # fmt: skip
        self.autopilot = autopilot
        self.own_system = own_system
        self.gcs_system = gcs_system
        self.rc_override_time_s = rc_override_time_s
        self.manual_timeout_s = manual_timeout_s
        self.values: list[float | None] = [None] * len(STICK_CHANNELS)
        self.stamps_s: list[float] = [-math.inf] * len(STICK_CHANNELS)
        self.accepted = 0
        """Override messages taken in (released channels included)."""
        self.rejected = 0
        """Override messages refused (wrong sender, wrong target, the other autopilot's message, disabled)."""

    def receive(self, msg: Any, t_s: float) -> bool:
        """Take in an RC_CHANNELS_OVERRIDE or MANUAL_CONTROL received at ``t_s``; True when it was accepted."""
        kind = msg.get_type()
        if kind == "RC_CHANNELS_OVERRIDE" and self.autopilot is Autopilot.ARDUPILOT:
            ok = msg.get_srcSystem() == self.gcs_system and msg.target_system == self.own_system
            if ok and self.rc_override_time_s != 0.0:
                for i, v in enumerate(rc_override_channels(msg)):
                    if v is not False:
                        self.values[i] = v if isinstance(v, float) else None
                        self.stamps_s[i] = t_s
                self.accepted += 1
                return True
        elif kind == "MANUAL_CONTROL" and self.autopilot is Autopilot.PX4 and msg.target == self.own_system:
            sticks = manual_control_sticks(msg)
            self.values = [getattr(sticks, name) for name in STICK_CHANNELS]
            self.stamps_s = [t_s] * len(STICK_CHANNELS)
            self.accepted += 1
            return True
        if kind in ("RC_CHANNELS_OVERRIDE", "MANUAL_CONTROL"):
            self.rejected += 1
        return False

    def _live(self, i: int, t_s: float) -> bool:
        if self.values[i] is None:
            return False
        timeout = self.rc_override_time_s if self.autopilot is Autopilot.ARDUPILOT else self.manual_timeout_s
        return timeout < 0.0 or t_s - self.stamps_s[i] < timeout

    def sticks(self, pilot: StickCommand, t_s: float) -> tuple[StickCommand, bool]:
        """The sticks flown at ``t_s``: each honoured override channel in place of the pilot's; and whether any was."""
        values = {name: getattr(pilot, name) for name in STICK_CHANNELS}
        honoured = False
        for i, name in enumerate(STICK_CHANNELS):
            if self._live(i, t_s):
                values[name] = self.values[i]
                honoured = True
        return (StickCommand(**values) if honoured else pilot), honoured
