"""The fixed-wing platform: a JSBSim airplane flown by our FBW-B flight controller.

:class:`FixedWingPlatform` owns one :class:`~aircraft.jsbsim_model.JSBSimModel`
loaded with ``aircraft/systems/fixedwing_fc.xml`` appended. That system file is
the whole inner loop (bank hold + turn coordinator, climb-rate/altitude hold on
pitch attitude, airspeed hold on throttle), running in C++ every JSBSim frame.
This class only:

* writes the profile's envelope and gains into the controller's ``fc/*`` properties;
* starts the aircraft in the air, settled at cruise (see :meth:`FixedWingPlatform.reset`);
* latches the four normalized sticks into ``fc/stick-roll``, ``fc/stick-pitch``,
  ``fc/stick-yaw``, ``fc/stick-throttle`` (meaning: see :mod:`geofence.interface`).

Stick -> property contract (all in [-1, 1], clipped here):
  roll     -> fc/stick-roll      bank = roll * max_bank_rad (+ right)
  pitch    -> fc/stick-pitch     climb rate +1 -> max_climb_rate_mps, -1 -> -max_descent_rate_mps, 0 holds altitude
  yaw      -> fc/stick-yaw       rudder offset (+ nose right), 0 = coordinated
  throttle -> fc/stick-throttle  airspeed -1 -> min_speed_mps, 0 -> cruise_speed_mps, +1 -> max_speed_mps

Units: SI throughout, as the names say; JSBSim feet stay inside JSBSimModel and
the controller XML.
"""

from __future__ import annotations

import math
from pathlib import Path

from aircraft.jsbsim_model import FT_TO_M, M_TO_FT, OWN_SYSTEMS
from aircraft.profile import PlatformProfile
from aircraft.stick_platform import StickPlatform
from geofence.geometry.geodesy import LocalFrame, geodetic_to_ecef
from geofence.interface import PlatformKind, StickCommand
from geofence.physics.dynamics import G_MPS2, isa_density_ratio

FC_SYSTEM_FILE: Path = OWN_SYSTEMS / "fixedwing_fc.xml"

#: Seconds the controller flies straight and level inside :meth:`reset` before
#: the aircraft is placed back at the requested start point.
SETTLE_S: float = 5.0
#: A turbine (an engine with an N1, e.g. the pc7's PT6) started at idle spools up for ~15 s more: its settle
#: goes on while N1 still rises faster than :data:`SPOOLING_N1_PCT_S`, up to :data:`SETTLE_MAX_S` in all.
SETTLE_MAX_S: float = 40.0
SPOOLING_N1_PCT_S: float = 0.5
_N1 = "propulsion/engine/n1"


TERMINATION_SURFACES: dict[str, float] = {"aileron": 1.0, "elevator": -1.0, "rudder": 1.0}
"""The surface commands at flight termination: full aileron, full up elevator and full rudder (ArduPilot's
advanced failsafe termination positions), a spin. Neutral surfaces glide: a Tern terminated at 70 m and 25 m/s
came down 568 m on (measured); spinning, 39 m on after 8.3 s (its path bounded by the no-drag fall's 95 m,
:mod:`geofence.physics.termination`)."""


class FixedWingPlatform(StickPlatform):
    """A JSBSim fixed-wing aircraft with the generic FBW-B controller (Platform protocol)."""

    def __init__(self, profile: PlatformProfile):
        if profile.kind is not PlatformKind.FIXED_WING:
            raise ValueError(f"{profile.model}: profile kind is {profile.kind.value}, not fixed_wing")
        super().__init__(profile, FC_SYSTEM_FILE)
        m = self.model
        env = profile.envelope
        self._params = {
            "fc/max-bank-rad": env.max_bank_rad,
            "fc/max-pitch-rad": env.max_pitch_rad,
            "fc/max-climb-mps": env.max_climb_rate_mps,
            "fc/max-descent-mps": env.max_descent_rate_mps,
            "fc/cruise-speed-mps": env.cruise_speed_mps,
            "fc/min-speed-mps": env.min_speed_mps,
            "fc/max-speed-mps": env.max_speed_mps,
        }
        # Everything under gains: is written verbatim (controller gains, min pitch,
        # trim seeds such as fc/throttle-trim and fc/theta-trim-rad, fcs/pitch-trim-cmd-norm).
        self._params.update(profile.gains)
        self._engaged = m.node("fc/engaged")
        self._wind_mps = (0.0, 0.0, 0.0)
        self._reset_args: tuple | None = None
        self._fresh = False
        self._write_params()

    def _write_params(self) -> None:
        for prop, value in self._params.items():
            self.model.set(prop, value)

    # -- Platform protocol ---------------------------------------------------
    def reset(
        self,
        frame: LocalFrame,
        lat_deg: float,
        lon_deg: float,
        agl_m: float,
        heading_deg: float,
        airspeed_mps: float,
    ) -> None:
        """Air start at ``agl_m`` (> 0), heading ``heading_deg``, ``airspeed_mps`` (EAS; cruise if 0).

        JSBSim's trim cannot handle a small electric propeller (its engine
        steady-state search marches in 0.5 s steps, unstable for a 20 g prop),
        so instead the controller flies the aircraft straight and level for
        :data:`SETTLE_S` seconds from the profile's trim seeds (a turbine until it has spooled up, at most
        :data:`SETTLE_MAX_S`), and the settled
        aircraft is then put back at the requested position and altitude with
        the clock reset to 0. Integrators, propeller RPM and attitude stay
        settled. The altitude hold references the start altitude, the sticks
        are zeroed, the speed hold targets cruise (a different start airspeed
        relaxes toward cruise unless the throttle stick says otherwise).

        The start is steady flight in the wind set by :meth:`set_wind_enu`
        (nose on ``heading_deg``, crabbing in a crosswind). A wind first set
        after ``reset`` but before any :meth:`step` is treated the same way:
        the aircraft is re-settled in it, so that a scenario's initial wind
        is not a gust at t = 0.

        ``agl_m`` <= 0 parks the aircraft on the ground, motor off, controller
        disengaged (sticks are ignored until the next air start).
        """
        self._bind_sticks()  # (after a termination)
        self._reset_args = (frame, lat_deg, lon_deg, agl_m, heading_deg, airspeed_mps)
        self._fresh = True
        m = self.model
        env = self.envelope
        v0 = airspeed_mps if airspeed_mps > 0.0 else env.cruise_speed_mps
        self.command(StickCommand())
        self._write_params()
        theta0 = self._params.get("fc/theta-trim-rad", 0.0)
        m.set("fc/engaged", 0.0)
        m.set("fcs/mixture-cmd-norm", 1.0)
        m.set("fcs/aileron-cmd-norm", 0.0)
        m.set("fcs/rudder-cmd-norm", 0.0)
        m.set("fcs/elevator-cmd-norm", 0.0)
        if agl_m <= 0.0:
            m.set("fcs/throttle-cmd-norm", 0.0)
            m.reset(frame, lat_deg, lon_deg, 0.0, heading_deg, 0.0)
            m.set_wind_enu(*self._wind_mps)
            m.fdm.set_sim_time(0.0)
            return
        m.set("fcs/throttle-cmd-norm", self._params.get("fc/throttle-trim", 0.5))
        m.set("ic/alpha-deg", math.degrees(theta0))
        m.set("ic/gamma-deg", 0.0)
        # v0 is an equivalent airspeed (what the FC holds); JSBSim's initial condition is true airspeed
        v0_true = v0 / math.sqrt(isa_density_ratio(frame.h0_m + agl_m))
        m.reset(frame, lat_deg, lon_deg, agl_m, heading_deg, v0_true)
        m.set_wind_enu(*self._wind_mps)  # run_ic zeroes JSBSim's wind
        m.set("propulsion/set-running", -1)
        # The controller's altitude reference is the start altitude, its speed
        # reference cruise; while settling, hold the start airspeed instead.
        m.set("fc/cruise-speed-mps", v0)
        m.set("fc/engaged", 1.0)
        m.set("fc/h-ref-ft", m.get("position/h-sl-ft"))
        # Settle; a small heading hold (Python, every 0.1 s) cancels the yaw
        # that the propeller spin-up puts in during the first frames.
        set_roll_stick = self._stick_setters[0]
        chunk = max(1, int(round(0.1 / self.dt_s)))
        # bank ~ V * heading error / (g * 1.2 s): closes the heading error with a ~1.2 s time constant
        k_stick_per_deg = math.radians(1.0) * v0 / (G_MPS2 * 1.2 * max(env.max_bank_rad, 0.1))
        settle_chunks = int(round(SETTLE_S / (chunk * self.dt_s)))
        turbine, n1 = m.has(_N1), 0.0
        for i in range(int(round(SETTLE_MAX_S / (chunk * self.dt_s))) if turbine else settle_chunks):
            if turbine:
                now = m.get(_N1)
                rising, n1 = now - n1 > SPOOLING_N1_PCT_S * chunk * self.dt_s, now
                if i >= settle_chunks and not rising:
                    break
            err_deg = (heading_deg - math.degrees(m.get("attitude/psi-rad")) + 180.0) % 360.0 - 180.0
            set_roll_stick(max(-0.5, min(0.5, k_stick_per_deg * err_deg)))
            m.step(chunk)
        set_roll_stick(0.0)
        m.set("fc/cruise-speed-mps", env.cruise_speed_mps)
        self._place(frame, lat_deg, lon_deg, agl_m)
        m.set("fc/h-ref-ft", m.get("position/h-sl-ft"))
        m.fdm.set_sim_time(0.0)

    def _place(self, frame: LocalFrame, lat_deg: float, lon_deg: float, agl_m: float) -> None:
        """Move the flying aircraft to a geodetic position, keeping its velocity and attitude."""
        m = self.model
        h_m = frame.h0_m + agl_m
        x, y, z = geodetic_to_ecef(lat_deg, lon_deg, h_m)
        m.set("position/lat-gc-deg", math.degrees(math.atan2(z, math.hypot(x, y))))
        m.set("position/long-gc-deg", lon_deg)
        m.set("position/h-agl-ft", agl_m * M_TO_FT)

    def set_wind_enu(self, east_mps: float, north_mps: float, up_mps: float) -> None:
        """Air-mass velocity in m/s (ENU, toward). Right after :meth:`reset`, re-settles in it."""
        wind = (east_mps, north_mps, up_mps)
        changed = self._fresh and wind != self._wind_mps  # (in flight, not fresh: no comparison)
        self._wind_mps = wind
        self.model.set_wind_enu(east_mps, north_mps, up_mps)
        if changed and self._reset_args is not None:
            self.reset(*self._reset_args)

    def step(self, n_frames: int = 1) -> None:
        self._fresh = False
        self.model.step(n_frames)

    def cut_propulsion(self) -> None:
        """Loss of propulsion (a scenario's ``propulsion_loss`` fault), until the next :meth:`reset`: the
        controller's throttle output is held at 0 (its trim far below its clip at 0, so its speed hold cannot
        raise it: every engine kind), and each engine is stopped with its magnetos off (a piston engine stays
        dead; the propeller windmills). The controller keeps flying bank and climb on the elevator."""
        m = self.model
        m.set("fc/throttle-trim", -1.0e3)
        m.set("fcs/throttle-cmd-norm", 0.0)
        m.set("propulsion/magneto_cmd", 0.0)
        for i in range(m.fdm.get_propulsion().get_num_engines()):
            m.set(f"propulsion/engine[{i}]/set-running", 0.0)

    def terminate(self) -> None:
        """Flight termination (:meth:`aircraft.platform.Platform.terminate`): the engine stopped as in
        :meth:`cut_propulsion`, the controller disengaged (``fc/engaged`` 0: it no longer writes the actuator
        commands) and the surfaces set to :data:`TERMINATION_SURFACES` (a spin; neutral surfaces would glide
        far), so the aircraft falls; the sticks are ignored from now on."""
        self.cut_propulsion()
        m = self.model
        m.set("fc/engaged", 0.0)
        for surface in ("aileron", "elevator", "rudder"):
            m.set(f"fcs/{surface}-cmd-norm", TERMINATION_SURFACES[surface])
        self.ignore_sticks()

    # -- diagnostics -----------------------------------------------------------
    def fc(self, name: str) -> float:
        """Read a controller or JSBSim property (diagnostics, not for the per-step path)."""
        return self.model.get(name)


__all__ = ["FixedWingPlatform", "FC_SYSTEM_FILE", "SETTLE_S", "FT_TO_M"]
