"""The one interface every simulated platform offers to the simulation loop.

A platform is an aircraft *with its own flight controller*: it takes normalized
outer-loop sticks (see :mod:`geofence.interface` for their meaning per kind),
steps the flight dynamics, reports truth, and declares its performance
envelope. The loop, the pilots and the geofence talk to it only through this
protocol.
"""

from __future__ import annotations

from typing import Protocol

from geofence.geometry.geodesy import LocalFrame
from geofence.interface import Envelope, StickCommand, VehicleState


class Platform(Protocol):
    name: str
    """The JSBSim model name."""
    envelope: Envelope
    """Declared performance limits (the geofence's only knowledge of the airframe)."""
    dt_s: float
    """Flight-dynamics frame time in s."""

    def reset(
        self,
        frame: LocalFrame,
        lat_deg: float,
        lon_deg: float,
        agl_m: float,
        heading_deg: float,
        airspeed_mps: float,
    ) -> None:
        """Start at a WGS-84 position, ``agl_m`` above the frame's ground height.

        ``agl_m`` = 0 starts on the ground (multirotor) ; a fixed-wing starts in
        the air at ``airspeed_mps`` (or its cruise speed when 0), trimmed.
        """

    def command(self, cmd: StickCommand) -> None:
        """Latch outer-loop sticks; they act from the next frame on."""

    def set_wind_enu(self, east_mps: float, north_mps: float, up_mps: float) -> None:
        """Air-mass velocity in m/s (ENU, direction the air moves toward)."""

    def step(self, n_frames: int = 1) -> None:
        """Advance ``n_frames`` frames of ``dt_s``."""

    def truth(self) -> VehicleState:
        """True state in SI units, ENU about the reset frame."""

    def terminate(self) -> None:
        """Flight termination, until the next :meth:`reset`: propulsion cut at the power stage, independent of the
        flight controller (a flight-termination system's own channel), and every later :meth:`command` ignored. A
        multirotor falls with its motors off; a fixed-wing's engine stops and its controller is disengaged, its
        surfaces set to spin it down (gliding would carry it far)."""
