"""What every simulated platform shares: a JSBSim model whose flight controller reads four sticks.

:class:`StickPlatform` loads the profile's model with its flight-controller
system file appended, latches :class:`~geofence.interface.StickCommand` s into
the controller's ``fc/stick-roll``, ``fc/stick-pitch``, ``fc/stick-yaw`` and
``fc/stick-throttle`` properties (clipped to [-1, 1]) and reports truth. The
subclasses add what differs: how the controller is parameterised and how a
start is placed (:mod:`aircraft.multicopter`, :mod:`aircraft.fixedwing`).
"""

from __future__ import annotations

from pathlib import Path

from aircraft.jsbsim_model import JSBSimModel
from aircraft.profile import PlatformProfile
from geofence.interface import StickCommand, VehicleState

STICK_PROPERTIES = ("fc/stick-roll", "fc/stick-pitch", "fc/stick-yaw", "fc/stick-throttle")


class StickPlatform:
    def __init__(self, profile: PlatformProfile, fc_system: Path):
        self.profile = profile
        self.name = profile.model
        self.envelope = profile.envelope
        self.dt_s = 1.0 / profile.frame_rate_hz
        self.model = JSBSimModel(profile.model, dt_s=self.dt_s, extra_systems=[fc_system])
        self._stick_setters = tuple(self.model.node(p).set_double_value for p in STICK_PROPERTIES)

    def command(self, cmd: StickCommand) -> None:
        """Latch the sticks (clipped to [-1, 1]); they act from the next frame on."""
        r, p, y, t = self._stick_setters
        r(_clip1(cmd.roll))
        p(_clip1(cmd.pitch))
        y(_clip1(cmd.yaw))
        t(_clip1(cmd.throttle))

    def truth(self) -> VehicleState:
        """True state (SI, ENU about the reset frame)."""
        return self.model.truth()


def _clip1(x: float) -> float:
    return -1.0 if x < -1.0 else (1.0 if x > 1.0 else float(x))
