"""The multicopter platform: JSBSim's F450 quadcopter flown by an AltHold-style flight controller.

:class:`MulticopterPlatform` owns one :class:`~aircraft.jsbsim_model.JSBSimModel`
of a multirotor model (the shipped ``F450``) with our flight controller
``aircraft/systems/multicopter_fc.xml`` appended. The flight controller (tilt
angle -> body rate -> X mixer; climb rate with hover feed-forward and altitude
hold -> collective) runs inside JSBSim's C++ FCS every frame; this module only
latches the four sticks into the controller's input properties, writes the
profile's limits and gains, places the vehicle, and delegates stepping, wind
and truth to the model.

Stick -> property contract (sticks clipped to [-1, 1], see :mod:`geofence.interface`):

* ``roll``     -> ``fc/stick-roll``:     bank  = roll  * max_bank_rad (+ right)
* ``pitch``    -> ``fc/stick-pitch``:    pitch = pitch * max_pitch_rad (+ nose up)
* ``yaw``      -> ``fc/stick-yaw``:      heading rate = yaw * max_yaw_rate_radps (+ nose right)
* ``throttle`` -> ``fc/stick-throttle``: climb rate, +1 -> max_climb_rate_mps,
  -1 -> max_descent_rate_mps, 0 holds altitude.

The envelope limits are written to ``fc/max-tilt-rad``, ``fc/max-yaw-rate-rps``,
``fc/max-climb-mps`` and ``fc/max-descent-mps``; the profile's ``gains:`` (any
``fc/*`` property) are written after them, so a profile may override anything.
"""

from __future__ import annotations

from pathlib import Path

from aircraft.profile import PlatformProfile
from aircraft.stick_platform import StickPlatform
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import StickCommand

FC_SYSTEM_XML = Path(__file__).parent / "systems" / "multicopter_fc.xml"

_ESC_PROPS = (
    "fcs/cmdFR_ext_nd",
    "fcs/cmdAL_ext_nd",
    "fcs/cmdFL_ext_nd",
    "fcs/cmdAR_ext_nd",
    "fcs/cmdEscFR_nd",
    "fcs/cmdEscAL_nd",
    "fcs/cmdEscFL_nd",
    "fcs/cmdEscAR_nd",
)
_THROTTLE_POS_PROPS = tuple(f"fcs/throttle-pos-norm[{i}]" for i in range(4))
_CUT_COLLECTIVE = -2.0
"""The collective input that cuts every ESC command (a controller output is at most 1)."""
_SPIN_UP_S = 0.5
"""Time run after the initial conditions: rotors spin up (air start) or the gear settles (ground start)."""


class MulticopterPlatform(StickPlatform):
    """A multirotor with an angle-mode + altitude-hold flight controller (see module docstring)."""

    def __init__(self, profile: PlatformProfile):
        super().__init__(profile, FC_SYSTEM_XML)
        m = self.model
        self._reset_node = m.node("fc/reset-cmd")
        self._integrators_held = False
        self._started = False
        self._wind_nodes = tuple(
            m.node(p) for p in ("atmosphere/wind-east-fps", "atmosphere/wind-north-fps", "atmosphere/wind-down-fps")
        )
        self._hover_throttle = 0.0
        self._write_parameters()

    def _write_parameters(self) -> None:
        env = self.envelope
        s = self.model.set
        # The FC uses one tilt limit for both axes (the table's max_bank/max_pitch).
        s("fc/max-tilt-rad", min(env.max_bank_rad, env.max_pitch_rad))
        s("fc/max-yaw-rate-rps", env.max_yaw_rate_radps)
        s("fc/max-climb-mps", env.max_climb_rate_mps)
        s("fc/max-descent-mps", env.max_descent_rate_mps)
        for prop, value in self.profile.gains.items():
            s(prop, value)
        # F450's own rate loop and collective stay out of the way: our FC drives the ESCs.
        s("fcs/ScasEngage", 0.0)
        s("fcs/throttle-cmd-norm", 0.0)
        self._hover_throttle = self.model.get("fc/hover-throttle")

    # -- Platform protocol -------------------------------------------------------
    def reset(
        self,
        frame: LocalFrame,
        lat_deg: float,
        lon_deg: float,
        agl_m: float,
        heading_deg: float = 0.0,
        airspeed_mps: float = 0.0,
    ) -> None:
        """Start on the ground (``agl_m`` <= 0, motors idle) or hovering at ``agl_m`` (level, at rest).

        ``airspeed_mps`` is ignored: a multirotor always starts at rest relative
        to the ground. The wind set by :meth:`set_wind_enu` is kept. Resets are
        deterministic: every JSBSim model state (rotor speeds, FC integrators and
        filters) is cleared first. Sim time restarts at 0.
        """
        self._bind_sticks()  # (after a termination)
        m = self.model
        # run_ic sets JSBSim's wind from its (calm) initial conditions: keep ours.
        wind_fps = [nd.get_double_value() for nd in self._wind_nodes]
        if self._started:
            # Clear every model's state (rotor speeds, FC filters and integrators) so
            # that a reset is independent of the previous run.
            m.clear_state()
        self._started = True
        self._write_parameters()
        self.command(StickCommand())
        on_ground = agl_m <= 0.0
        # Motors must already be at hover before the first frame of an air start
        # (otherwise the vehicle free-falls while the ESCs spin up).
        start_throttle = self.model.get("fc/idle-throttle") if on_ground else self._hover_throttle
        for p in (*_ESC_PROPS, *_THROTTLE_POS_PROPS):
            m.set(p, start_throttle)
        # A ground start places the CG at the gear height so the legs just touch.
        start_agl_m = self.model.get("fc/gear-height-m") if on_ground else agl_m
        # fc/reset-cmd holds every FC integrator at zero until the first frame of the run.
        self._reset_node.set_double_value(1.0)
        m.reset(frame, lat_deg, lon_deg, start_agl_m, heading_deg, 0.0)
        m.step(int(round(_SPIN_UP_S / self.dt_s)))
        if not on_ground:
            # The ESCs start from 0 rpm: fly the spin-up transient, then re-apply the
            # initial conditions (run_ic keeps the rotor speeds), so the air start
            # begins in a true hover at the requested height.
            m.reset(frame, lat_deg, lon_deg, start_agl_m, heading_deg, 0.0)
        m.fdm.set_sim_time(0.0)
        for nd, v in zip(self._wind_nodes, wind_fps):
            nd.set_double_value(v)
        self._integrators_held = True

    def set_wind_enu(self, east_mps: float, north_mps: float, up_mps: float) -> None:
        """Steady air-mass velocity in m/s (ENU, toward); kept across :meth:`reset`."""
        self.model.set_wind_enu(east_mps, north_mps, up_mps)

    def terminate(self) -> None:
        """Flight termination (:meth:`aircraft.platform.Platform.terminate`): the four ESC commands cut at the power
        stage, the model's own summation of ``fcs/throttle-cmd-norm`` and the controller's outputs before each ESC
        (the collective input held at -2: the sum stays below 0, which the ESC clips to 0, whatever the controller
        writes), so the motors spin down (ESC lag) and the vehicle falls; the sticks are ignored from now on."""
        self.model.set("fcs/throttle-cmd-norm", _CUT_COLLECTIVE)
        self.ignore_sticks()

    def step(self, n_frames: int = 1) -> None:
        """Advance ``n_frames`` frames of ``dt_s``."""
        if self._integrators_held and n_frames > 0:
            self.model.fdm.run()  # this frame zeroes the FC integrators
            self._reset_node.set_double_value(0.0)
            self._integrators_held = False
            n_frames -= 1
        self.model.step(n_frames)
