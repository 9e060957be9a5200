"""Dead reckoning for the geofence unit when its position source is lost.

From the last valid estimate (position, ground velocity) the horizontal state
is propagated with what the unit still measures:

* multirotor: the AHRS attitude gives the horizontal thrust of a
  tilt-controlled vehicle, ``g·tan(tilt)`` in the tilt direction, and the
  platform's drag law (:mod:`geofence.physics.dynamics`) the air drag at the
  dead-reckoned airspeed ``v_ground - wind`` (last wind estimate):
  ``a = g·tan(tilt)·u_tilt - a_drag(|v_air|)·v_air/|v_air|``. Without the
  drag term a vehicle holding its position against a steady wind (tilted
  into it) would be dead-reckoned as accelerating upwind, and the guidance
  would let it drift downwind at the wind speed;
* fixed-wing: the airspeed along the AHRS heading plus the last wind estimate
  gives the ground velocity directly.

With ``measured_velocity`` set (the estimator carries a measured ground velocity through the loss: an
optical-flow sensor in range, :func:`geofence.estimation.estimator.update_flow`) a multirotor's velocity is the
estimate's, and only the position is integrated here: it drifts with the flow's noise and heading error instead of
the attitude's.

It starts from the estimate at the last fix's time of validity when the estimator gives it
(:class:`geofence.interface.FixState`), replaying the attitude seen since, else from the last
fresh estimate. Heights keep coming from the estimator's barometric channel. The error grows
with time (about ½·g·δθ·t², 8 m after 15 s for a 0.5° attitude error), which
is enough to fly a few hundred metres to a floor gap and land in it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import replace

from geofence.interface import Envelope, FixState, VehicleState
from geofence.physics.dynamics import G_MPS2, drag_accel_mps2, drag_coefficients


class DeadReckoning:
    def __init__(self, env: Envelope):
        self.env = env
        self._k1, self._k2 = drag_coefficients(env)
        self.active = False
        self.e = self.n = self.ve = self.vn = 0.0
        self.measured_velocity = False
        """The estimate's ground velocity is measured (optical flow): :meth:`step` takes it (set by the unit)."""

    def start(self, last_valid: VehicleState) -> None:
        """From an estimate (already extrapolated past its fix: the fallback when no fix state is known)."""
        self.active = True
        self.e, self.n = last_valid.east_m, last_valid.north_m
        self.ve, self.vn = last_valid.v_east_mps, last_valid.v_north_mps

    def start_at_fix(self, fix: FixState, since: Iterable[VehicleState], wind_en: tuple[float, float]) -> None:
        """From the state at the last fix's time of validity, replaying the estimates (attitudes) seen since.

        The estimator extrapolates past its newest fix with the acceleration it had then; in a hard manoeuvre
        that is seconds behind (a 40 deg brake of a multirotor reversed its velocity inside the 0.5 s an
        estimate stays fresh). Replaying the attitude from the fix's time starts the dead reckoning from
        what the vehicle did since, not from the extrapolation.
        """
        self.active = True
        self.e, self.n = fix.east_m, fix.north_m
        self.ve, self.vn = fix.v_east_mps, fix.v_north_mps
        t = fix.t_s
        for est in since:
            if est.t_s > t:
                self.step(est, est.t_s - t, wind_en)
                t = est.t_s

    def stop(self) -> None:
        self.active = False
        self.measured_velocity = False

    def step(self, est: VehicleState, dt_s: float, wind_en: tuple[float, float]) -> VehicleState:
        """The estimate with its horizontal position/velocity replaced by the dead-reckoned ones."""
        sy, cy = math.sin(est.yaw_rad), math.cos(est.yaw_rad)
        if self.env.is_multirotor and self.measured_velocity:
            self.ve, self.vn = est.v_east_mps, est.v_north_mps
        elif self.env.is_multirotor:
            a_fwd = -G_MPS2 * math.tan(est.pitch_rad)  # nose down accelerates forward
            a_right = G_MPS2 * math.tan(est.roll_rad)
            ae, an = a_fwd * sy + a_right * cy, a_fwd * cy - a_right * sy
            vae, van = self.ve - wind_en[0], self.vn - wind_en[1]
            va = math.hypot(vae, van)
            if va > 1e-6:
                d = drag_accel_mps2(self._k1, self._k2, va) / va
                ae -= d * vae
                an -= d * van
            self.ve += ae * dt_s
            self.vn += an * dt_s
        else:
            v_air = max(est.airspeed_mps, self.env.min_speed_mps)
            self.ve = v_air * sy + wind_en[0]
            self.vn = v_air * cy + wind_en[1]
        self.e += self.ve * dt_s
        self.n += self.vn * dt_s
        return replace(est, east_m=self.e, north_m=self.n, v_east_mps=self.ve, v_north_mps=self.vn)
