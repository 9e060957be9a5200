"""The geofence unit: monitor the flight, override when a breach is imminent, hand back, or land in a gap.

State machine (every transition is logged with time and reason)::

    MONITOR ──activation margin <= 0──▶ OVERRIDE ──hand-back criteria──▶ RECOVERED ──1 s──▶ MONITOR
       ▲                                  │  ▲ still outside after min_override_s: re-activate │
       └──────────────────────────────────┘  └───────────────────────────────────────────────┘
    any ──position lost / return impossible / > max_reactivations──▶ LAND_IN_GAP ──▶ TERMINATE
                                                                         (fixed-wing, low over the gap)

With the position source lost, the unit navigates to the gap by dead
reckoning from its last valid estimate (:mod:`geofence.estimation.dead_reckoning`).

* MONITOR and RECOVERED pass the pilot's sticks through unchanged.
* Return is impossible when the estimated mean wind plus one sigma of the forecast
  turbulence reaches 90 % of the platform's max speed
  (:func:`geofence.physics.dynamics.return_not_assured`): at an activation, or held for 3 s
  at any time, the unit goes straight to LAND_IN_GAP (the most reachable floor gap,
  downwind preferred). A multirotor flies there at the lowest safe height and aims
  upwind in the gap.
* A multirotor's return is also impossible when its override, following (the compliance watch
  finds no lag), loses ground at its tilt limit
  (:class:`~geofence.physics.control_laws.LosingGround`): the wind measured beyond its authority
  seconds before the 20 s wind estimate gets there. With no floor it then lands at once, descending on
  the way (every second in the air drifts it), and where that landing would still touch down outside,
  it is terminated as it reaches the fence (:meth:`GeofenceUnit._authority_termination`).
* A vehicle on the ground slower than :data:`~geofence.unit.passes.SITTING_MAX_GROUND_SPEED_MPS` is sitting and never
  triggers; a faster one is rolling (a fixed-wing that touched down at flying speed) and triggers as in
  the air.
* Either a lateral or a vertical trigger starts the whole 3-D override
  (lateral goal: the recovery point; vertical goal: a safe height band).
* The activation margin is the estimated margin to the fence minus the room
  the platform needs to turn back or stop in the current wind
  (:mod:`geofence.margins.boundary_shift`), minus k·σ of the estimate; with
  ``trigger: reactive`` it is the plain margin (act on the line).
* The envelope is scaled to the air density at the site
  (:func:`geofence.physics.dynamics.envelope_at_density`, ISA density from the
  estimated altitude): a high site or a hot day means faster true airspeeds,
  wider turns and weaker climbs.
* Hand-back: after at least ``min_override_s``, inside the fence, and either
  ``handback_margin_m`` inside the activation boundary while not closing on
  the threatened edge, or within ``recovery_radius_m`` of the recovery point.

The unit sees only a state estimate, the platform :class:`Envelope`, a wind
estimate, and the pilot's :class:`StickCommand`. Heights ``h`` are in the
fence's altitude reference (AGL or AMSL).

The unit's per-step state is one record it owns (:data:`geofence.unit.passes.UNIT_STATE`), which its compiled
passes read and write in place (see :class:`GeofenceUnit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from geofence.estimation.dead_reckoning import DeadReckoning
from geofence.estimation.history import EstimateHistory, state_of_row
from geofence.estimation.wind_estimator import WIND_ESTIMATE_ERROR_MPS
from geofence.geometry.fence import AltitudeReference
from geofence.geometry.local_fence import LocalFence
from geofence.interface import Envelope, FixState, StickCommand, VehicleState
from geofence.margins.boundary_shift import CompiledMargins, ShiftResult, activation_margins
from geofence.physics.control_laws import climb_rate_to_stick, clip
from geofence.physics.dynamics import G_MPS2, envelope_at_density, isa_density_ratio, return_not_assured, return_wind_limits
from geofence.physics.rooms import (
    climb_back_drift_m,
    envelope_turn_radius_m,
    room_upper_bounds_fast_m,
    vertical_arrest_distance_m,
)
from geofence.physics.termination import Footprint, footprint_points, termination_footprint
from geofence.recovery import Point, RecoveryPlanner
from geofence.recovery.guidance import (
    FixedWingRecovery,
    LandingGuidance,
    MultirotorVelocityRecovery,
    Route,
    SeedPDRecovery,
    StraightRoute,
)
from geofence.unit.compliance import ComplianceMonitor
from geofence.unit.config import GeofenceConfig, MultirotorLaw, Trigger, TurbulenceSource, allowance_in_use_mps
from geofence.unit.passes import (  # (their home: the monitoring step's kernel reads them too)
    DENSITY_REFRESH_M,
    FRESH_ESTIMATE_AGE_S,
    TARGET_CELLS,
    TARGET_SIDE,
    UNIT_SIZE,
    UNIT_STATE,
    Mode,
    activates,
    field_slot,
    goal_short_of_band_h_m,
    hand_back,
    hold_over,
    latency_s,
    outside,
    return_assured,
    rollout_cell,
    vertical_handback_m,
    window_cell,
)

WIND_BEYOND_AUTHORITY_PERSIST_S = 3.0
TERMINATE_BELOW_AGL_M = 8.0
LANDING_EDGE_MARGIN_M = 2.0
"""A multirotor descends to land only this far (m) inside, beyond its estimate's uncertainty margin ``k·σ_h``."""
ROUTE_CLEARANCE_MULTIROTOR_M = 3.0
"""Lateral clearance (beyond k·σ_h) a multirotor's recovery route keeps from every boundary."""
VERTICAL_CLEARANCE_M = 2.0
"""Below the floor inside a gap, the override climbs this far above the floor before it moves sideways."""
DEAD_RECKONING_TRANSIT_AGL_M = 10.0
"""A multirotor without a position source flies to its landing point no higher than this (m AGL): inside a downward
rangefinder's and optical flow's range (12 m, and quality 0.2 below about 16 m: ``aircraft/sensors.py``), where
the flow measures the velocity it would otherwise dead-reckon from a wind estimate that may have shifted since the
last fix (case history: docs/campaigns.md, the fault campaign with the seed's downward sensors)."""
DEAD_RECKONING_LANDING_MARGIN_M = 25.0
"""With the position source lost, a multirotor lands in place only this far inside (else at the nearest point that
is), or farther when its descent takes long (:meth:`GeofenceUnit.dead_reckoning_room_m`)."""
REPLAY_WINDOW_S = 2.0
"""How far back the unit keeps its estimates (attitudes) for the dead reckoning to replay from the last fix."""
SLOW_TURN_SHORTFALL = 0.1
"""A fixed-wing's override flies its first turn at the minimum speed when the turn's scored room exceeds the room
there is by more than this fraction of it (:meth:`GeofenceUnit._turn_does_not_fit`): a margin that crossed 0
between two steps lacks a few per cent at most (down to -3.3 m of 79.7 m measured), a start inside the boundary
13-56 % (seeds 26112701, 26112702)."""
SLOW_TURN_MAX_WIND_FRACTION = 0.5
"""... and only in a wind (with its allowance) under this fraction of the minimum speed: slower, the vehicle must
still make way against it to face its route."""


# the modes as module constants for the per-step code (a global is read in a tenth of an enum class attribute's time)
_MONITOR, _OVERRIDE, _RECOVERED, _LAND_IN_GAP, _TERMINATE = (
    Mode.MONITOR, Mode.OVERRIDE, Mode.RECOVERED, Mode.LAND_IN_GAP, Mode.TERMINATE,
)  # fmt: skip
_FOLLOWED = {Mode.OVERRIDE: "the override", Mode.LAND_IN_GAP: "the landing"}
"""What the vehicle does not follow, per mode, in a termination's reason (else :data:`_PILOT_STICKS`, passed on)."""
_PILOT_STICKS = "the pilot's sticks"


def footprint_record(margin_m: float, fp: Footprint) -> dict[str, Any]:
    """A termination footprint and its lateral margin as the termination record keeps them (m, s; rounded)."""
    return {
        "footprint_margin_m": round(margin_m, 2), "footprint_far_en_m": [round(fp.far_e_m, 2), round(fp.far_n_m, 2)],
        "footprint_drag_en_m": [round(fp.drag_e_m, 2), round(fp.drag_n_m, 2)], "footprint_radius_m": round(fp.radius_m, 2),
        "fall_s": round(fp.fall_s, 2),
    }  # fmt: skip


class _Field:
    """An attribute of :class:`GeofenceUnit` that is a field of its record (:data:`~geofence.unit.passes.UNIT_STATE`):
    read and written in the record's memory, which the compiled passes read and write too."""

    __slots__ = ("slot",)

    def __init__(self, name: str) -> None:
        self.slot = field_slot(name)

    def __get__(self, unit: Any, owner: Any = None) -> float:
        return unit.memory.item(self.slot)

    def __set__(self, unit: Any, value: float) -> None:
        unit.memory[self.slot] = value


class _Flag(_Field):
    """A flag of the record (0 or 1) as a bool."""

    def __get__(self, unit: Any, owner: Any = None) -> bool:
        return unit.memory.item(self.slot) != 0.0

    def __set__(self, unit: Any, value: bool) -> None:  # type: ignore[override]
        unit.memory[self.slot] = value


_MODE_SLOT = field_slot("mode")


@dataclass(frozen=True)
class Transition:
    t_s: float
    from_mode: Mode
    to_mode: Mode
    reason: str

    def as_dict(self) -> dict:
        return {"t_s": round(self.t_s, 3), "from": self.from_mode.name, "to": self.to_mode.name, "reason": self.reason}


class GeofenceUnit:
    """The platform-independent geofence: ``update(...)`` once per outer-loop step.

    Its per-step state is one record, :data:`~geofence.unit.passes.UNIT_STATE`, in :attr:`memory`: the attributes
    below that are :class:`_Field` s are that record's fields, which the compiled passes
    (:mod:`geofence.unit.passes`) read and write too; nothing is copied between the two. The record's constants
    (the configuration's, the fence's and the envelope's numbers) are written where they are derived, once per
    unit or per envelope (:meth:`_configure_record`, :meth:`_build_laws`); :attr:`mode` is written through its
    setter (the passes only read it). What lives in Python
    objects (the history of estimates, the wind list its guidance laws share, the fence's memo, a fixed-wing
    recovery's state) is handed over by
    :meth:`take_in_ring` and :meth:`override_arrays`."""

    activation_margin_m = _Field("activation_margin_m")
    """The last step's activation margin, m (inf: far from everything, not computed in detail; NaN: not needed)."""
    _density_alt_m = _Field("density_alt_m")  # (NaN: never scaled)
    _mode_since_s = _Field("mode_since_s")
    _latency_s = _Field("latency_s")
    _turbulence_est_mps = _Field("turbulence_est_mps")
    _sigma_h_m = _Field("sigma_h_m")  # (the last finite one)
    _sigma_v_m = _Field("sigma_v_m")
    _position_valid = _Flag("position_valid")
    _strong_wind_since_s = _Field("strong_wind_since_s")  # (NaN: the return is assured)
    _skipped_last = _Flag("skipped_last")  # the last monitoring step's skip shortcut held
    _override_period_start_s = _Field("period_start_s")
    _climb_back_to_m = _Field("climb_back_m")  # the override's climb-back height, below the floor in a gap (NaN: none)
    _goal_h_m = _Field("goal_h_m")  # the override's goal height (set as it starts)
    _goal_short_of_band = _Flag("goal_short_of_band")  # an explicit goal or the band's middle (no room by construction)

    def __init__(self, config: GeofenceConfig, fence: LocalFence, envelope: Envelope):
        self.memory = np.zeros(UNIT_SIZE)
        """The unit's record's float memory (:data:`~geofence.unit.passes.UNIT_STATE`), which a compiled step passes to
        the passes."""
        self._record = self.memory.view(UNIT_STATE)[0]
        self._targets: np.ndarray = self._record.targets  # (a view: the window on the roll-out target cache)
        self.config = config
        self.fence = fence
        self.base_envelope = envelope
        """The profile's envelope (sea-level-ish); :attr:`env` is it scaled to the air density at the site."""
        self.env = envelope
        self._density_alt_m = math.nan
        self.mode = Mode.MONITOR
        self.transitions: list[Transition] = []
        self.activations = 0
        self.first_activation_s: float | None = None
        """When the activation margin first reached 0 (s, the time of :meth:`update`), or None: 0 at the first
        step is a start inside the activation boundary, where the override's guarantee has not begun."""
        self.reactivations = 0
        self._last: ShiftResult | None = None
        self._last_fields: tuple[CompiledMargins, list[float]] | None = None  # (fields not made a ShiftResult yet)
        self.activation_margin_m = math.inf
        self.wind_enu = [config.wind_prior_enu[0], config.wind_prior_enu[1]]  # (shared with the guidance laws)
        self._planners: dict[float, RecoveryPlanner] = {}
        self._rollout_cache: dict[tuple[int, int], tuple[float, float]] = {}
        self._clearances: tuple[float, ...] = ()
        self._clearances_for: tuple = ()  # (sigma_h, envelope) the clearances were computed for
        self._compiled: CompiledMargins | None = None  # the compiled margins of a fence without an index
        self._predictive = config.trigger is Trigger.PREDICTIVE
        self._configure_record(config, fence)
        self.compliance = ComplianceMonitor(envelope, config.compliance_grace_s)
        """Watches whether the vehicle follows what the unit sends (:meth:`watch_compliance`)."""
        self._build_laws(envelope)
        self._strong_wind_since_s = math.nan
        self._position_valid = True
        self._last_valid: VehicleState | None = None
        self._last_horizon: FixState | None = None
        self._history = EstimateHistory()
        self.estimate: VehicleState | None = None
        """The state the unit acted on last (its estimate, or its dead reckoning)."""
        self._climb_back_to_m = math.nan
        self._goal_h_m = math.nan
        self.noncompliant_at_s: float | None = None
        """When the compliance monitor first found the vehicle not following (s), or None."""
        self.termination: dict[str, Any] | None = None
        """Why and where the unit terminated the vehicle (one that did not follow, :meth:`watch_compliance`; one a
        wind beyond its authority carried out of its landing, :meth:`_authority_termination`), or None."""
        self._authority_wind_en: tuple[float, float] | None = None
        """The wind (m/s, toward) a multirotor's own ground velocity showed beyond its authority, at least
        (:class:`~geofence.physics.control_laws.LosingGround`), or None."""

    def _configure_record(self, config: GeofenceConfig, fence: LocalFence) -> None:
        """The record's constants from the configuration and the fence (set once; the few that :meth:`update` reads
        are kept as attributes too, written here only)."""
        u = self._record
        u.k_sigma, u.extra_margin_m, u.gust_mps = config.uncertainty_k_sigma, config.extra_margin_m, config.gust_mps
        self._agl = fence.altitude_reference is AltitudeReference.AGL
        self._estimated_turbulence = config.turbulence_source is TurbulenceSource.ESTIMATE
        self._forecast_allowance_mps = config.wind_allowance_mps(config.turbulence_sigma_mps)
        u.agl, u.estimated_turbulence = self._agl, self._estimated_turbulence
        u.forecast_allowance_mps = self._forecast_allowance_mps
        u.forecast_sigma_mps, u.turbulence_k_sigma = config.turbulence_sigma_mps, config.turbulence_k_sigma
        u.min_override_s, u.handback_margin_m = config.min_override_s, config.handback_margin_m
        u.recovery_e_m, u.recovery_n_m = fence.recovery_en
        u.recovery_radius_m, u.ceiling_m = config.recovery_radius_m, fence.ceiling_m
        u.floor_m = math.nan if fence.floor_m is None else fence.floor_m
        lo = (
            fence.floor_m
            if fence.floor_m is not None
            else (0.0 if fence.altitude_reference is AltitudeReference.AGL else -math.inf)
        )
        self._height_limits = (lo, fence.ceiling_m)
        # the vertical hand-back hysteresis, at most a tenth of the vertical band (an indoor fence is 1 m high)
        self._vertical_handback_m = u.vertical_handback_m = min(config.vertical_handback_m, 0.1 * (fence.ceiling_m - lo))

    @property
    def mode(self) -> Mode:
        """The state machine's mode (the record keeps its number, written by this setter only)."""
        return self._mode

    @mode.setter
    def mode(self, mode: Mode) -> None:
        self._mode = mode
        self.memory[_MODE_SLOT] = mode

    # -- helpers -------------------------------------------------------------
    def _build_laws(self, env: Envelope) -> None:
        """The guidance laws and dead reckoning for envelope ``env``."""
        self.env = env
        self.compliance.set_envelope(env)  # (the sticks read with the envelope in use)
        self._multirotor = env.is_multirotor
        u = self._record
        u.multirotor, u.reaction_time_s = self._multirotor, env.reaction_time_s
        if self.fence.grid() is None:
            self._compiled = CompiledMargins(self.fence, env)
        config = self.config
        self.recovery: SeedPDRecovery | MultirotorVelocityRecovery | FixedWingRecovery
        if env.is_multirotor:
            if config.multirotor_law is MultirotorLaw.SEED_PD:
                self.recovery = SeedPDRecovery(env, config.seed_pd, config.ramp_s)
            else:
                self.recovery = MultirotorVelocityRecovery(env, config.recovery_speed_mps, self.wind_enu)
        else:
            self.recovery = FixedWingRecovery(env, self.wind_enu)
        turn_r = envelope_turn_radius_m(env)
        self.landing = LandingGuidance(env, spiral_radius_m=max(1.2 * turn_r, 10.0), wind_enu=self.wind_enu)
        self.dead_reckoning = DeadReckoning(env)
        self._return_wind_limits = u.return_allowance_mps, u.return_limit_mps = return_wind_limits(
            config.turbulence_sigma_mps, env
        )

    def _scale_to_density(self, alt_m: float) -> None:
        """Scale the envelope to the ISA density at ``alt_m`` (AMSL); :meth:`update` asks it while monitoring, when
        the altitude moved :data:`DENSITY_REFRESH_M` or more since the last time."""
        self._density_alt_m = alt_m
        self._build_laws(envelope_at_density(self.base_envelope, isa_density_ratio(alt_m)))
        self._clear_rollout_targets()  # the route clearances follow the (true-airspeed) turn radius

    def _clear_rollout_targets(self) -> None:
        """Forget the roll-out targets found (the cache, and the record's window on it)."""
        self._rollout_cache.clear()
        self._record.has_targets = 0.0

    def _switch(self, t_s: float, to: Mode, reason: str) -> None:
        self.transitions.append(Transition(t_s, self.mode, to, reason))
        self.mode = to
        self._mode_since_s = t_s

    def height(self, s: VehicleState) -> float:
        """The height of ``s`` in the fence's altitude reference (m)."""
        return s.agl_m if self._agl else s.alt_m

    @property
    def wind_allowance_mps(self) -> float:
        """Turbulence and gust allowance added to the wind in every margin: ``k·σ + gust`` (σ: the forecast's,
        or with ``turbulence_source: estimate`` the larger of it and the unit's own estimate)."""
        cfg = self.config
        return allowance_in_use_mps(
            self._estimated_turbulence, self._turbulence_est_mps, cfg.turbulence_sigma_mps, cfg.turbulence_k_sigma,
            cfg.gust_mps, self._forecast_allowance_mps,
        )  # fmt: skip

    def _far_from_everything(self, s: VehicleState, h: float, sigma_h_m: float, sigma_v_m: float, dt_s: float) -> bool:
        """Cheap pre-check: no edge, ceiling or floor is within the largest room this state could need.

        An upper bound of the lateral room that :func:`activation_margins`
        can return for this state and of the vertical arrest distance
        (:func:`geofence.physics.rooms.room_upper_bounds_m`, in its fast form: the larger of max speed and
        the current speed, the strongest turn or braking, the wind with its
        allowance, two roll times); when the plain margins exceed both, the full
        per-edge computation cannot trigger and is skipped.
        """
        env = self.env
        k = self.config.uncertainty_k_sigma
        extra = self.config.extra_margin_m
        we, wn = self.wind_enu
        w = math.hypot(we, wn) + self.wind_allowance_mps
        t = 2.0 * env.reaction_time_s + self._latency_s
        room, vroom = room_upper_bounds_fast_m(
            env, s.ground_speed_mps, math.hypot(s.v_east_mps - we, s.v_north_mps - wn), s.v_up_mps, w, t
        )
        if room == math.inf:
            return False
        room += k * sigma_h_m + extra
        vroom += k * sigma_v_m + extra
        fence = self.fence
        if fence.ceiling_m - h <= vroom or not fence.lateral_margin_exceeds(s.east_m, s.north_m, room):
            return False
        if fence.floor_m is None or h - fence.floor_m > vroom:
            return True
        if not env.is_multirotor:  # it circles in a gap while it climbs back: the circle drifts (an upper bound)
            room += climb_back_drift_m(fence.floor_m + vroom - h, env.max_climb_rate_mps, w)
        return fence.best_gap(s.east_m, s.north_m)[1] > room

    def _margins(
        self, s: VehicleState, h: float, sigma_h_m: float, sigma_v_m: float, dt_s: float, rollout_target: Point | None = None
    ) -> ShiftResult:
        """:func:`activation_margins` of the unit's state; a fixed-wing's turn is scored towards ``rollout_target``
        (default: where the override's turn rolls out, :meth:`_rollout_target`)."""
        k = self.config.uncertainty_k_sigma
        extra = self.config.extra_margin_m
        target = None if self._multirotor else (rollout_target or self._rollout_target(s.east_m, s.north_m))
        if self._compiled is not None:  # activation_margins' compiled call, its tables bound
            wind = self.wind_enu
            return self._compiled.margins(
                s.east_m, s.north_m, h, s.v_east_mps, s.v_north_mps, s.v_up_mps, wind[0], wind[1],
                k * sigma_h_m + extra, k * sigma_v_m + extra, self._latency_s, s.roll_rad, self.wind_allowance_mps,
                target,
            )  # fmt: skip
        return activation_margins(
            self.fence, s.east_m, s.north_m, h, s.v_east_mps, s.v_north_mps, s.v_up_mps, self.env,
            self.wind_enu[0], self.wind_enu[1],
            h_uncertainty_m=k * sigma_h_m + extra, v_uncertainty_m=k * sigma_v_m + extra, latency_s=self._latency_s,
            bank_rad=s.roll_rad,
            wind_extra_mps=self.wind_allowance_mps,
            rollout_target_en=target,
        )  # fmt: skip

    def _monitor_margins(self, s: VehicleState, h: float, sigma_h_m: float, sigma_v_m: float, dt_s: float) -> ShiftResult | None:
        """A predictive unit's monitoring step: ``None`` when :meth:`_far_from_everything` holds, else :meth:`_margins`.

        For a fence without an index one compiled call answers both
        (:meth:`geofence.margins.boundary_shift.CompiledMargins.monitor`, the same numbers), unless a fixed-wing's roll-out
        target is not cached for its cell yet (finding it is a route search, made only when the margins are
        needed: the reference's order). After a step the shortcut answered, the next asks it alone first
        (far from everything it usually holds again, and alone it is the cheaper call): the same answers.
        """
        compiled = self._compiled
        if not self._skipped_last and compiled is not None:
            e, n = s.east_m, s.north_m
            target = None if self._multirotor else self._rollout_cache.get(rollout_cell(e, n))
            if target is not None or self._multirotor:
                k = self.config.uncertainty_k_sigma
                extra = self.config.extra_margin_m
                latency = self._latency_s
                wind = self.wind_enu
                found = compiled.monitor(
                    e, n, h, s.v_east_mps, s.v_north_mps, s.v_up_mps, s.ground_speed_mps, wind[0], wind[1],
                    k * sigma_h_m + extra, k * sigma_v_m + extra, latency, 2.0 * self.env.reaction_time_s + latency,
                    s.roll_rad, self.wind_allowance_mps, target,
                )  # fmt: skip
                self._skipped_last = found is None
                return found
        # far from everything at the last step (or no compiled call): the shortcut alone is the cheaper guess
        self._skipped_last = self._far_from_everything(s, h, sigma_h_m, sigma_v_m, dt_s)
        return None if self._skipped_last else self._margins(s, h, sigma_h_m, sigma_v_m, dt_s)

    def _reactive_activation(self, r: ShiftResult) -> float:
        """``trigger: reactive``'s activation margin: the plain margin (act on the line); a predictive unit's is
        ``r.activation_margin_m``."""
        return min(r.lateral_margin_m, r.ceiling_margin_m, r.floor_margin_m) - self.config.extra_margin_m

    def _trigger_reason(self, r: ShiftResult) -> str:
        if self.config.trigger is Trigger.REACTIVE:
            which = min(
                ("lateral", r.lateral_margin_m), ("ceiling", r.ceiling_margin_m), ("floor", r.floor_margin_m), key=lambda x: x[1]
            )
            return f"{which[0]} margin {which[1]:.2f} m reached the fence line (reactive)"
        if r.lateral_activation_m <= r.vertical_activation_m:
            return (
                f"lateral: {r.feature} edge {r.edge} at {r.edge_distance_m:.1f} m, needs {r.lateral_shift_m:.1f} m "
                f"(closing {r.closing_speed_mps:.1f} m/s, breach in {r.time_to_breach_s:.1f} s)"
            )
        return f"vertical: ceiling margin {r.ceiling_margin_m:.1f} m, floor margin {r.floor_margin_m:.1f} m, activation {r.vertical_activation_m:.1f} m"

    def _goal_height(self, h: float) -> float:
        return self._goal(h)[0]

    def _goal(self, h: float) -> tuple[float, bool]:
        """Height the override flies to: the nearest one where hand-back is possible.

        The vertical activation margin at rest must exceed the hand-back
        hysteresis with room to arrest the altitude hold's own overshoot, so
        the goal is ``h`` clipped to ``[floor + u + hyst + arrest, ceiling - u
        - hyst - arrest]`` (``u``: the vertical uncertainty margin), or the
        middle of the band when that is empty. An explicit recovery height wins.
        ``(goal, in_band)``: in_band False for an explicit height or the middle of an empty band (the goal then
        has no room for the hand-back by construction, :meth:`_vertical_handback_at_goal_m`).
        """
        rp = self.fence.fence.recovery_point
        if rp is not None and len(rp) == 3 and self.fence.recovery_height_m is not None:  # an explicit set-point height
            return self.fence.recovery_height_m, False
        lo, hi = self._height_limits
        env = self.env
        u = self.config.uncertainty_k_sigma * self._sigma_v_m + self.config.extra_margin_m + self._vertical_handback_m
        # the altitude hold approaches the goal at about 1 m/s per m: allow one arrest from 1 m/s
        settle = (
            vertical_arrest_distance_m(
                1.0, env.reaction_time_s, max(env.vertical_accel_mps2, 0.1), max(env.max_climb_rate_mps, env.max_descent_rate_mps)
            )
            + 0.5
        )
        band_lo, band_hi = lo + u + settle, hi - u - settle
        if band_lo <= band_hi:
            return clip(h, band_lo, band_hi), True
        return (0.5 * (lo + hi) if math.isfinite(lo) else hi - 5.0), False

    def _return_impossible(self) -> str | None:
        """Why return is impossible (or cannot be assured), or None (:func:`geofence.physics.dynamics.return_not_assured`).

        The turbulence is the forecast's σ only, never the unit's own estimate: that also
        holds the estimate's noise, and landing because of it was measured to cause more breaches than
        it prevents.
        """
        cfg = self.config
        return return_not_assured(math.hypot(*self.wind_enu), cfg.turbulence_sigma_mps, self.env)

    def _override_losing_ground(self) -> bool:
        """A multirotor's override losing ground at its tilt limit
        (:class:`~geofence.physics.control_laws.LosingGround`) while it follows the override (the compliance watch
        finds no lag): return is impossible, measured (the wind estimate lags a rising wind by its time constant).
        The wind it shows is kept (:attr:`_authority_wind_en`)."""
        recovery = self.recovery
        if not isinstance(recovery, MultirotorVelocityRecovery) or not recovery.velocity.losing.lost:
            return False
        if self.compliance.lagging:  # a vehicle not following the override: the watch's to judge, not the wind
            return False
        self._authority_wind_en = recovery.velocity.losing.implied_wind_enu(self.env.max_speed_mps)
        return True

    def _losing_ground_reason(self) -> str:
        """The transition's reason for :meth:`_override_losing_ground`."""
        assert isinstance(self.recovery, MultirotorVelocityRecovery) and self._authority_wind_en is not None
        lost = self.recovery.velocity.losing
        return (
            f"return impossible: losing ground at the tilt limit ({lost.away_mps:.1f} m/s away for {lost.seconds:.1f} s):"
            f" a wind of {math.hypot(*self._authority_wind_en):.1f} m/s or more, beyond max speed {self.env.max_speed_mps:.1f} m/s"
        )

    def _landing_losing_ground(self) -> tuple[float, float] | None:
        """The wind beyond its authority a multirotor measured losing ground, in its override or in this landing
        (:class:`~geofence.physics.control_laws.LosingGround`, while it follows), or None."""
        velocity = self.landing.velocity
        if velocity is not None and velocity.losing.lost and not self.compliance.lagging:
            self._authority_wind_en = velocity.losing.implied_wind_enu(self.env.max_speed_mps)
        return self._authority_wind_en

    def _authority_termination(self, t_s: float, s: VehicleState, dt_s: float, wind_en: tuple[float, float]) -> bool:
        """A multirotor a wind beyond its authority carries out of its landing (no floor): terminated as it reaches
        the fence. The landing touches down where its ground velocity carries it for
        :meth:`LandingGuidance.time_to_touchdown_s`; while that is inside, or the vehicle is more than it moves in
        two steps and the latency from the fence (the wind may ease: a landing predicted outside often is not),
        it lands on. At the fence, drifting on takes it out for the whole descent and a fall only for the fall's
        drift: it is terminated, unless the fall's footprint (:meth:`termination_margin_m`, in the wind measured,
        ``wind_en``, where that is stronger than the estimate) would come down farther out than the landing.
        Returns whether it switched to ``TERMINATE``."""
        fence, cfg = self.fence, self.config
        u = cfg.uncertainty_k_sigma * self._sigma_h_m + cfg.extra_margin_m
        if fence.lateral_margin_m(s.east_m, s.north_m) - u > s.ground_speed_mps * (2.0 * dt_s + self._latency_s):
            return False
        t_down = self.landing.time_to_touchdown_s(s.agl_m, s.ground_speed_mps)
        landing_m = fence.lateral_margin_m(s.east_m + s.v_east_mps * t_down, s.north_m + s.v_north_mps * t_down) - u
        if landing_m >= 0.0:
            return False
        wind = wind_en if math.hypot(*wind_en) > math.hypot(*self.wind_enu) else (self.wind_enu[0], self.wind_enu[1])
        margin, fp = self.termination_margin_m(s, wind)
        if margin <= landing_m:
            return False
        self.termination = {
            "cause": "wind beyond authority", "wind_en_mps": [round(wind[0], 2), round(wind[1], 2)],
            "landing_margin_m": round(landing_m, 2), **footprint_record(margin, fp),
        }  # fmt: skip
        self._switch(
            t_s, Mode.TERMINATE,
            f"a wind beyond authority carries the landing {-landing_m:.1f} m outside: flight termination at the fence,"
            f" footprint margin {margin:.1f} m",
        )  # fmt: skip
        return True

    def _landing_point(self, s: VehicleState) -> tuple[float, float]:
        """Where to land: the most reachable floor gap (wind-aware), or here / the recovery point with no floor."""
        fence = self.fence
        if fence.floor_m is None or not fence.floor_gaps:
            if self.env.is_multirotor:
                # without a position source, dead reckoning drifts: land only where there is room for it
                need = self._landing_edge_margin_m() if self._position_valid else self.dead_reckoning_room_m(s.agl_m)
                if fence.lateral_margin_m(s.east_m, s.north_m) > need:
                    return s.east_m, s.north_m
                found = self._point_with_room(s, need)
                return found[1] if found is not None else fence.recovery_en
            # a fixed-wing spirals down: the nearest point (by route) where its spiral fits inside
            r = self.landing.spiral_radius_m
            if fence.lateral_margin_m(s.east_m, s.north_m) >= r + self.route_clearances()[0]:
                return s.east_m, s.north_m
            found = self._point_with_room(s, r)
            return found[1] if found is not None else fence.recovery_en
        we, wn = self.wind_enu
        v = max(self.env.max_speed_mps, 1.0)
        best, best_time = fence.recovery_en, math.inf
        for gap in fence.floor_gaps:
            ge, gn, r_in = gap.inradius()
            d = math.hypot(ge - s.east_m, gn - s.north_m)
            tail = (we * (ge - s.east_m) + wn * (gn - s.north_m)) / d if d > 1e-6 else 0.0
            t = d / max(v + tail, 0.1 * v)
            if t < best_time:
                best, best_time = self._upwind_in_gap(ge, gn, r_in), t
        return best

    def _upwind_in_gap(self, ge: float, gn: float, r_in_m: float) -> tuple[float, float]:
        """Where in a gap (inscribed circle centre ``ge, gn``, radius ``r_in_m``) a multirotor aims its landing.

        Upwind of the centre, by up to the inscribed radius less the landing edge margin
        (:meth:`_landing_edge_margin_m`) and 1 m, in proportion to the wind up to half the max speed: a
        vehicle that cannot stop in the wind drifts downwind while it descends, and then has the whole gap
        to drift across instead of half of it. A fixed-wing spirals over the centre.
        """
        if not self.env.is_multirotor:
            return ge, gn
        we, wn = self.wind_enu
        w = math.hypot(we, wn)
        if w < 1e-6:
            return ge, gn
        offset = max(r_in_m - self._landing_edge_margin_m() - 1.0, 0.0) * min(1.0, w / (0.5 * max(self.env.max_speed_mps, 1.0)))
        return ge - offset * we / w, gn - offset * wn / w

    # -- routes inside the fence ------------------------------------------------
    def route_planners(self) -> dict[float, RecoveryPlanner]:
        """The recovery-route planners built so far, by lateral clearance (m; a new dict)."""
        return dict(self._planners)

    def route_planner(self, clearance_m: float) -> RecoveryPlanner:
        """The recovery-route planner of a lateral clearance (m, one of :meth:`route_clearances`), built on first use
        and kept."""
        p = self._planners.get(clearance_m)
        if p is None:
            p = self._planners[clearance_m] = RecoveryPlanner(self.fence, clearance_m)
        return p

    def prepare_routes(self) -> None:
        """Build the recovery-route planner of the current clearance now, before flight: its graph (every edge,
        up to :data:`~geofence.recovery_path.FULL_GRAPH_MAX_NODES` nodes) and the recovery point's shortest-route
        tree, with which a route search there tests a few first legs instead of searching
        (:meth:`RecoveryPlanner.prepare`). Otherwise the searches build the graph as they go, mid-flight (about
        half a second for the nodes of a 10,000-vertex fence with 500 keep-outs, then some 25 µs for each node a
        search first expands). Routes as short either way."""
        self.route_planner(self.route_clearances()[0]).prepare(goals=(self.fence.recovery_en,))

    def route_clearances(self, sigma_h_m: float | None = None) -> tuple[float, ...]:
        """Lateral clearances to try, largest first (m, rounded up to whole metres so planners can be reused).

        A fixed-wing wants its turn radius, a multirotor a few metres; both add
        the position uncertainty margin ``k·σ_h`` (``sigma_h_m``, default the unit's), since the route is flown on
        the estimate, and half of the halved clearance is tried before giving up.
        """
        env = self.env
        sigma = self._sigma_h_m if sigma_h_m is None else sigma_h_m
        key = (sigma, env)
        if key != self._clearances_for:
            hu = self.config.uncertainty_k_sigma * sigma + self.config.extra_margin_m
            if env.is_multirotor:
                c = ROUTE_CLEARANCE_MULTIROTOR_M + hu
            else:
                c = envelope_turn_radius_m(env) + hu
            self._clearances = tuple(float(math.ceil(x)) for x in (c, 0.5 * c, 0.25 * c))
            self._clearances_for = key
        return self._clearances

    def _route(self, start_en: tuple[float, float], goal_en: tuple[float, float], sigma_h_m: float | None = None) -> Route:
        """A route from ``start_en`` (the estimate's position) to ``goal_en`` inside the allowed area
        (:mod:`geofence.recovery_path`), with the clearances of :meth:`route_clearances` (``sigma_h_m``).

        The largest clearance that reaches the goal wins; failing all, the
        partial route that ends nearest it; with no admissible first leg at
        all, the straight line (the only thing left to fly).
        """
        partial = None
        for c in self.route_clearances(sigma_h_m):
            path = self.route_planner(c).plan(start_en, goal_en)
            if path is None:
                continue
            if path.reached_goal and len(path.points) >= 2:
                return path
            if partial is None and len(path.points) >= 2:
                partial = path
        return partial if partial is not None else StraightRoute(*goal_en)

    def _recovery_goal(self, s: VehicleState) -> tuple[Route, tuple[float, float]]:
        """The route and the goal of an override: the recovery point, or (fixed-wing) the nearest point
        on the way where its recovery orbit fits."""
        goal = self.fence.recovery_en
        if isinstance(self.recovery, FixedWingRecovery):
            orbit_r = self.recovery.orbit_radius_m
            if self.fence.lateral_margin_m(*goal) < orbit_r + self.route_clearances()[0]:
                found = self._point_with_room(s, orbit_r)
                if found is not None:
                    return found
        return self._route((s.east_m, s.north_m), goal), goal

    def dead_reckoning_room_m(self, agl_m: float) -> float:
        """How far inside a multirotor without a position source must be to descend from ``agl_m`` (m).

        It drifts at the error of the wind it dead-reckons on for as long as the descent takes: the
        mean wind's error (:data:`geofence.estimation.wind_estimator.WIND_ESTIMATE_ERROR_MPS`) plus the turbulence of those seconds,
        which no estimate knows (near the ground its time scale is tens of seconds, so it does not
        average out over a descent): the margins' wind allowance ``k·σ + gust``. At least
        :data:`DEAD_RECKONING_LANDING_MARGIN_M`.
        """
        rate = WIND_ESTIMATE_ERROR_MPS + self.wind_allowance_mps
        return max(DEAD_RECKONING_LANDING_MARGIN_M, rate * self.landing.time_to_touchdown_s(agl_m))

    def _point_with_room(self, s: VehicleState, radius_m: float) -> tuple[Route, tuple[float, float]] | None:
        """The route to, and the nearest point (by route) where a circle of ``radius_m`` keeps the largest route
        clearance from every boundary; None if no reachable point has that room."""
        found = self.route_planner(self.route_clearances()[0]).safe_point_with_radius((s.east_m, s.north_m), radius_m)
        return None if found is None else (found[1], found[0].en)

    def _rollout_target(self, e: float, n: float, sigma_h_m: float | None = None) -> tuple[float, float]:
        """Where a fixed-wing's recovery turn rolls out towards from (e, n): the point its guidance rolls out on,
        :attr:`FixedWingRecovery.lookahead_m` along its route (:meth:`RecoveryPath.rollout_point`).

        The margin scores the turn the override flies. Not the route's first point: a vehicle passing a
        vertex of its route a few metres away saw the direction to it, and with it the scored turn, swing
        round within a step, so that a fixed-wing in a corridor narrower than its turn turned away from the
        corridor towards a vertex behind it (case history: docs/campaigns.md#breach-classes-found-and-fixed). Cached per
        cell of :data:`geofence.unit.passes.ROLLOUT_CELL_M`; found with
        the route clearances of ``sigma_h_m`` (default the unit's, :meth:`route_clearances`).
        """
        key = rollout_cell(e, n)
        t = self._rollout_cache.get(key)
        if t is None:
            recovery = self.recovery
            assert isinstance(recovery, FixedWingRecovery)
            route = self._route((e, n), self.fence.recovery_en, sigma_h_m)
            t = route.rollout_point(e, n, recovery.lookahead_m)
            if len(self._rollout_cache) > 20000:
                self._clear_rollout_targets()
            self._rollout_cache[key] = t
            inside, i, j = window_cell(self._record, e, n)
            if inside:  # (the window shows the cache)
                self._targets[i, j] = 1.0, t[0], t[1]
        return t

    def _below_floor_in_gap(self, s: VehicleState, h: float) -> bool:
        fence = self.fence
        return fence.floor_m is not None and h < fence.floor_m and fence.best_gap(s.east_m, s.north_m)[1] > 0.0

    def _start_landing(self, t_s: float, s: VehicleState, h: float, reason: str) -> None:
        pe, pn = self._landing_point(s)
        route = self._route((s.east_m, s.north_m), (pe, pn))
        turn_sign, turn_limit = 0, math.inf
        recovery = self.recovery
        if isinstance(recovery, FixedWingRecovery) and not s.on_ground:
            left = recovery.turn_left_rad() if self.mode is _OVERRIDE else None
            if left is not None:
                # Still in its override's turn: it goes on with that turn, for what is left of the angle its
                # margin scored when the override began, and spirals that way. Scored afresh now, the turn is
                # counted after the current bank's reaction arc: a few degrees the other way, which the
                # guidance flies at once: a fixed-wing whose GPS went out in an override's turn so reversed it
                # and flew the long way round to its route, out of the fence
                # (case history: docs/campaigns.md#breach-classes-found-and-fixed).
                turn_sign, turn_limit = recovery.turn_sign, left
            else:
                # Otherwise the first turn is scored as the override's is, towards where the landing's own
                # guidance rolls out: a turn's length along its route to the landing point (over the point,
                # where the guidance orbits it: the override's roll-out target), and flown for the angle scored.
                spiral = self.landing.spiral_radius_m
                target = None
                if route.remaining_m(s.east_m, s.north_m) > 2.0 * spiral:
                    target = route.rollout_point(s.east_m, s.north_m, spiral)
                scored = self._margins(s, h, self._sigma_h_m, self._sigma_v_m, 0.0, target)
                turn_sign, turn_limit = scored.turn_sign, scored.turn_angle_rad
        # over a floor, a multirotor flies to its gap at the lowest height that is safe everywhere: it has
        # that much less to descend once over the gap, and drifts that much less in a wind it cannot beat
        # (a fixed-wing keeps its height until its spiral)
        low = self.env.is_multirotor and self.fence.floor_m is not None
        cruise_h = self._goal_height(-math.inf if low else h)
        self.landing.start(pe, pn, cruise_h, route, turn_sign, turn_limit)
        self._switch(t_s, Mode.LAND_IN_GAP, reason + f"; landing at ({pe:.0f}, {pn:.0f}) m ENU")

    def _turn_does_not_fit(self, r: ShiftResult) -> bool:
        """A predictive fixed-wing's first turn lacks more than :data:`SLOW_TURN_SHORTFALL` of its scored room (a start inside
        the activation boundary, not a boundary crossed between two steps), the edge binds rather than the
        ceiling or floor, no floor is below, and the wind with its allowance is under
        :data:`SLOW_TURN_MAX_WIND_FRACTION` of the minimum speed: the override then flies that turn at the
        minimum speed (:meth:`FixedWingRecovery.start`).

        A fixed-wing started inside the activation boundary (at its maximum speed in a corridor narrower than
        its turn, or in an acute wedge without a forecast) leaves turning at cruise and stays inside turning
        at the minimum speed (case history: docs/campaigns.md#breach-classes-found-and-fixed).
        """
        if self._multirotor or not self._predictive or self.fence.floor_m is not None:
            return False  # (a reactive unit acts on the line by design: every turn of its lacks room)
        if r.lateral_activation_m > r.vertical_activation_m or r.lateral_activation_m >= -SLOW_TURN_SHORTFALL * r.lateral_shift_m:
            return False
        wind = math.hypot(self.wind_enu[0], self.wind_enu[1]) + self.wind_allowance_mps
        return wind < SLOW_TURN_MAX_WIND_FRACTION * self.env.min_speed_mps

    def _start_override(self, t_s: float, s: VehicleState, h: float, r: ShiftResult, reason: str) -> None:
        route, _ = self._recovery_goal(s)
        floor = self.fence.floor_m
        hold = floor + VERTICAL_CLEARANCE_M if floor is not None and self._below_floor_in_gap(s, h) else None
        goal_h, in_band = self._goal(max(h, hold) if hold is not None else h)
        self.recovery.start(s, route, goal_h, h, t_s, r.turn_sign, r.turn_angle_rad, hold, self._turn_does_not_fit(r))
        self._goal_h_m = goal_h
        self._goal_short_of_band = not in_band
        self._climb_back_to_m = math.nan if hold is None else hold
        self._override_period_start_s = t_s
        self._switch(t_s, Mode.OVERRIDE, reason)

    # -- the per-step entry points --------------------------------------------
    def _take_estimate(
        self,
        t_s: float,
        est: VehicleState,
        dt_s: float,
        wind_en: tuple[float, float] | None,
        position_valid: bool,
        sigma_h_m: float,
        sigma_v_m: float,
        turbulence_sigma_mps: float | None,
        estimate_age_s: float,
        horizon: FixState | None,
    ) -> VehicleState:
        """A step's inputs taken in (:meth:`update`'s arguments): the state the unit acts on, its estimate or, with the
        position lost, its dead reckoning (run in the shadow while fixes are only missing)."""
        self._latency_s = latency_s(dt_s, estimate_age_s)
        if wind_en is not None:
            self.wind_enu[0], self.wind_enu[1] = wind_en
        if turbulence_sigma_mps is not None:
            self._turbulence_est_mps = turbulence_sigma_mps
        self._position_valid = position_valid
        history = self._history
        if position_valid and estimate_age_s <= FRESH_ESTIMATE_AGE_S:
            self._last_valid = est
            self._last_horizon = horizon
            if self.dead_reckoning.active:
                self.dead_reckoning.stop()
        elif self._last_valid is not None:
            # fixes are missing: dead reckoning runs from the last fix (in the shadow while the estimator
            # still extrapolates, in charge once it declares the position lost)
            wind = (self.wind_enu[0], self.wind_enu[1])
            if not self.dead_reckoning.active:
                fix = self._last_horizon
                if fix is not None and history.first_t_s() <= fix.t_s:
                    self.dead_reckoning.start_at_fix(fix, history, wind)
                else:
                    self.dead_reckoning.start(self._last_valid)
            reckoned = self.dead_reckoning.step(est, dt_s, wind)
            if not position_valid:
                est = reckoned
        # the attitudes of the last REPLAY_WINDOW_S (the dead reckoning replays them from the last fix)
        history.append(est)
        history.trim(t_s - REPLAY_WINDOW_S)
        self.estimate = est
        self._sigma_v_m = sigma_v_m
        if math.isfinite(sigma_h_m):
            self._sigma_h_m = sigma_h_m
        return est

    # -- the monitoring step on arrays (geofence.unit.passes) ----------------------------------------------------------
    @property
    def monitors_compiled(self) -> bool:
        """A predictive unit whose margins have their array form (a fence without an index): its monitoring steps
        can be taken by :func:`geofence.unit.passes.monitor_pass` (see :meth:`monitor_ready`)."""
        return self._predictive and self._compiled is not None

    def monitor_ready(self) -> bool:
        """Whether :func:`geofence.unit.passes.monitor_pass` can take the next step: a predictive unit monitoring
        (``MONITOR`` or ``RECOVERED``), its margins compiled (a fence without an index), not dead-reckoning.
        Asked again after every step :meth:`update` takes."""
        mode = self.mode
        return (mode is _MONITOR or mode is _RECOVERED) and self.monitors_compiled and not self.dead_reckoning.active

    def margins_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The compiled margins' tables and envelope terms ``(F, L, V)`` the passes read (with :attr:`memory`); valid
        until the next :meth:`update` (which may re-scale the envelope)."""
        compiled = self._compiled
        assert compiled is not None
        F, L = compiled._tables
        return F, L, compiled._terms

    def find_rollout_target(self, e: float, n: float, sigma_h_m: float) -> None:
        """Find the roll-out target of the cell of (e, n) where none is cached (a route search, as :meth:`update`
        would for margins there, with the step's ``sigma_h_m``, or where it is not finite the last finite one) and
        show it in the record's window (centred on that cell where it was not in it): a compiled step that answered
        :data:`~geofence.unit.passes.NEED_TARGET` is asked again."""
        self._rollout_target(e, n, sigma_h_m if math.isfinite(sigma_h_m) else self._sigma_h_m)
        if not window_cell(self._record, e, n)[0]:
            self._window_round(e, n)

    def _window_round(self, e: float, n: float) -> None:
        """The record's window on the roll-out target cache, centred on the cell of (e, n)
        (:data:`geofence.unit.passes.TARGET_CELLS` each way)."""
        ce, cn = rollout_cell(e, n)
        u, cache, targets = self._record, self._rollout_cache, self._targets
        u.has_targets, u.cell_e, u.cell_n = 1.0, ce, cn
        for i in range(TARGET_SIDE):
            for j in range(TARGET_SIDE):
                target = cache.get((ce + j - TARGET_CELLS, cn + i - TARGET_CELLS))
                targets[i, j] = (0.0, 0.0, 0.0) if target is None else (1.0, target[0], target[1])

    def override_ready(self) -> bool:
        """Whether :func:`geofence.unit.passes.override_pass` can take the next step: a fixed-wing override (of a unit
        that :attr:`monitors_compiled`) whose recovery has its compiled step (:meth:`FixedWingRecovery.compiled_step`),
        not dead-reckoning. Asked again after every step :meth:`update` takes."""
        recovery = self.recovery
        return (
            self.mode is _OVERRIDE
            and self.monitors_compiled
            and isinstance(recovery, FixedWingRecovery)
            and not self.dead_reckoning.active
            and recovery.compiled_step() is not None
        )

    def override_arrays(self) -> tuple[np.ndarray, ...]:
        """The arrays an override step reads besides :attr:`memory` (see :meth:`override_ready`): the compiled margins'
        tables and envelope terms and the recovery's compiled step's arrays ``(F, L, V, R, P, Q, K)``, valid until the
        next :meth:`update`. The hand-over to the record of what the recovery (a Python object) keeps: its route
        follower's chord arguments and its step's state (taken back by :meth:`take_in_ring`)."""
        recovery = self.recovery
        assert isinstance(recovery, FixedWingRecovery)
        arrays = recovery.compiled_step()
        assert arrays is not None
        R, P, Q, K, thr, clearance = arrays
        u = self._record
        u.thr, u.clearance_m = thr, clearance
        progress, turning, turned, last_yaw, turn_throttle, throttle = recovery.step_state()
        u.progress_m, u.turning, u.turned_rad, u.last_yaw_rad = progress, float(turning), turned, last_yaw
        u.turn_throttle, u.throttle, u.recovery_moved = turn_throttle, throttle, 0.0
        return (*self.margins_tables(), R, P, Q, K)

    def history_rows(self, dt_s: float) -> int:
        """Rows a ring of estimates needs to hold the unit's history (:data:`REPLAY_WINDOW_S`) at steps of ``dt_s``."""
        return math.ceil(REPLAY_WINDOW_S / dt_s) + 4

    def take_in_ring(self, H: np.ndarray, horizon: FixState | None) -> bool:
        """The hand-over of the steps compiled calls took since the last time (the passes of
        :func:`geofence.unit.passes.monitor_pass`, the override steps of :func:`geofence.unit.passes.override_pass`)
        to what lives in Python objects, as :meth:`update` would have kept them: their estimates (the ring ``H``,
        :meth:`history_rows` long) into the history and :attr:`estimate`, the wind estimate into the list the
        guidance laws share (:attr:`wind_enu`), the fusion horizon (``horizon``: the one
        before them, the sensing chain's), the last margins they computed (the fence's memo, :attr:`last`), and a
        fixed-wing recovery's step state. Everything else they changed is in the record already. Returns whether
        they moved the fusion horizon."""
        u = self._record
        passes = int(u.ring_rows)
        if passes == 0:
            return False
        rows = min(passes, len(H))
        end = int(u.ring_next)
        start = end - rows
        # oldest to newest, a copy (the ring is written on)
        block = H[start:end].copy() if start >= 0 else np.concatenate((H[start:], H[:end]))
        self._history.extend_rows(block)  # (states again only when dead reckoning replays them)
        self._history.trim(float(u.last_t_s) - REPLAY_WINDOW_S)
        self.estimate = self._last_valid = state_of_row(block[-1].tolist())
        self.wind_enu[0], self.wind_enu[1] = u.wind_en_mps.tolist()
        moved = u.horizon_moved != 0.0
        self._last_horizon = FixState(*u.horizon.tolist()) if moved else horizon
        if u.has_margins != 0.0:
            compiled = self._compiled
            assert compiled is not None  # (the compiled step runs only where it is)
            fields = u.margins.tolist()
            self.fence.remember_margin(float(u.margins_e_m), float(u.margins_n_m), fields[1])
            self._last = None
            self._last_fields = (compiled, fields)
        if u.recovery_moved != 0.0:
            recovery = self.recovery
            assert isinstance(recovery, FixedWingRecovery)
            recovery.set_step_state(float(u.progress_m), u.turning != 0.0, float(u.turned_rad), float(u.last_yaw_rad))
        u.ring_rows = u.has_margins = u.horizon_moved = u.recovery_moved = 0.0
        return bool(moved)

    @property
    def commanding(self) -> bool:
        """Whether the unit, not the pilot, commands the vehicle now (an override, a landing in a gap)."""
        return self.mode is _OVERRIDE or self.mode is _LAND_IN_GAP

    @property
    def watching(self) -> bool:
        """Whether the compliance watch (:meth:`watch_compliance`) runs now: in every mode but ``TERMINATE``, on the
        unit's sticks while it commands and on the pilot's it passes through otherwise (a flight controller that
        freezes while the pilot flies is found as soon as the pilot's command moves)."""
        return self.mode is not _TERMINATE

    def watch_compliance(self, t_s: float, dt_s: float, cmd: StickCommand, est: VehicleState) -> bool:
        """A step's compliance watch (the runner calls it while :attr:`watching`, with the sticks the unit sent and
        its newest estimate): the :class:`~geofence.unit.compliance.ComplianceMonitor` on them, a new stretch with
        each mode (on the ground under the pilot's sticks, before a take-off, nothing is watched). A vehicle not
        following is terminated where that contains it (:meth:`not_following`). Returns whether it switched to
        ``TERMINATE`` (the runner then cuts the propulsion)."""
        if not self.compliance.watch(t_s, dt_s, self.commanding, self._mode_since_s, cmd, est):
            return False
        return self.not_following(t_s, dt_s, est)

    def not_following(self, t_s: float, dt_s: float, est: VehicleState) -> bool:
        """The watch found the vehicle not following at this step (:meth:`watch_compliance`, or a compiled flight
        step's watch on the same record): terminated now where :meth:`termination_call` says so (the finding and
        the footprint kept in :attr:`termination`). Returns whether it switched to ``TERMINATE``."""
        monitor = self.compliance
        if self.noncompliant_at_s is None:
            self.noncompliant_at_s = t_s
        margin, fp = self.termination_margin_m(est)
        where = self.termination_call(est, dt_s, margin, fp, monitor.attitude_missed)
        if where is None:
            return False
        miss = f"attitude {math.degrees(monitor.error_rad):.0f} deg" if monitor.axis == "attitude" else (
            f"vertical speed {monitor.vertical_error_mps:.1f} m/s")  # fmt: skip
        self.termination = {
            "cause": "not following",
            "noncompliant_at_s": round(self.noncompliant_at_s, 3), "mode_since_s": round(self._mode_since_s, 3),
            "axis": monitor.axis, "attitude_miss_deg": round(math.degrees(monitor.error_rad), 1),
            "vertical_miss_mps": round(monitor.vertical_error_mps, 2), **footprint_record(margin, fp),
        }  # fmt: skip
        self._switch(
            t_s, Mode.TERMINATE,
            f"the vehicle does not follow {_FOLLOWED.get(self.mode, _PILOT_STICKS)} ({miss} off since "
            f"{monitor.missed_since_s:.2f} s): flight termination, footprint margin "
            f"{margin:.1f} m ({where})",
        )  # fmt: skip
        return True

    def termination_call(
        self, est: VehicleState, dt_s: float, margin_m: float, fp: Footprint, steers: bool
    ) -> str | None:  # fmt: skip
        """Whether to terminate a vehicle that does not follow, and why (None: not yet). One that misses the climb
        alone (``steers`` False: it follows the attitude, so the unit still steers it sideways) is terminated only
        when the height it coasts up to once cut (``v_up² / 2g``, with the vertical uncertainty) is within what it
        climbs in the next two steps and the latency of the ceiling. One that misses the attitude also when the
        footprint's lateral margin (``margin_m``) is down to what it moves in that time (at once if it is outside
        already), or where the whole footprint lies in a floor gap. A floor alone is no reason: a fall through it
        lands no better than the vehicle's own descent."""
        lead_s = 2.0 * dt_s + self._latency_s
        if steers and margin_m < 0.0:
            return "already outside: at once"
        if steers and margin_m <= est.ground_speed_mps * lead_s:
            return "before it leaves"
        climb = max(est.v_up_mps, 0.0)
        cfg = self.config
        apex_m = (
            self.height(est) + climb * climb / (2.0 * G_MPS2) + cfg.uncertainty_k_sigma * self._sigma_v_m + cfg.extra_margin_m
        )
        if self.fence.ceiling_m - apex_m <= climb * lead_s:
            return "before it climbs through the ceiling"
        if steers and self.fence.floor_m is not None and self.footprint_gap_margin_m(fp) >= 0.0:
            return "over a floor gap"
        return None

    def termination_footprint(self, est: VehicleState, wind_en: tuple[float, float] | None = None) -> Footprint:
        """Where the vehicle comes down if terminated now (:func:`geofence.physics.termination.termination_footprint`
        from the estimate, in the wind estimate or ``wind_en``, the position's uncertainty margin ``k·σ_h + extra``)."""
        cfg = self.config
        we, wn = self.wind_enu if wind_en is None else wind_en
        return termination_footprint(
            est.east_m, est.north_m, est.agl_m, est.v_east_mps, est.v_north_mps, est.v_up_mps, we, wn,
            cfg.termination_terminal_speed_mps, cfg.uncertainty_k_sigma * self._sigma_h_m + cfg.extra_margin_m,
            WIND_ESTIMATE_ERROR_MPS,
        )  # fmt: skip

    def termination_margin_m(self, est: VehicleState, wind_en: tuple[float, float] | None = None) -> tuple[float, Footprint]:
        """The termination footprint's lateral margin (m; + inside): the least over its path
        (:func:`~geofence.physics.termination.footprint_points`) of the lateral margin (keep-in and keep-outs), less
        its radius; and the footprint (in the wind estimate or ``wind_en``)."""
        fp = self.termination_footprint(est, wind_en)
        fence = self.fence
        return min(fence.lateral_margin_m(e, n) for e, n in footprint_points(fp)) - fp.radius_m, fp

    def footprint_gap_margin_m(self, fp: Footprint) -> float:
        """How far the footprint lies inside a floor gap (m; + inside; ``-inf`` with no gaps)."""
        fence = self.fence
        return min(fence.gap_distance_m(e, n) for e, n in footprint_points(fp)) - fp.radius_m

    def newest_estimate(self, ring: np.ndarray) -> VehicleState | None:
        """The newest estimate the unit has: the ring's newest row where compiled steps have written it since the
        last hand-over (:meth:`take_in_ring`), else :attr:`estimate`."""
        u = self._record
        if u.ring_rows == 0.0:
            return self.estimate
        return state_of_row(ring[int(u.ring_next) - 1].tolist())

    def complete_hand_back(self, t_s: float) -> None:
        """``RECOVERED`` held long enough: back to ``MONITOR``."""
        self._switch(t_s, Mode.MONITOR, "hand-back complete")

    @property
    def last(self) -> ShiftResult | None:
        """The margins of the last step that computed them (None before any)."""
        if self._last_fields is not None:
            compiled, fields = self._last_fields
            self._last = compiled.shift_result(fields)
            self._last_fields = None
        return self._last

    @last.setter
    def last(self, r: ShiftResult | None) -> None:
        self._last = r
        self._last_fields = None

    def update(
        self,
        t_s: float,
        est: VehicleState,
        pilot: StickCommand,
        dt_s: float,
        wind_en: tuple[float, float] | None = None,
        position_valid: bool = True,
        sigma_h_m: float = 0.0,
        sigma_v_m: float = 0.0,
        turbulence_sigma_mps: float | None = None,
        estimate_age_s: float = 0.0,
        horizon: FixState | None = None,
    ) -> StickCommand:
        """One step: returns the sticks to send to the flight controller (the pilot's, or the override's).

        ``turbulence_sigma_mps``: the wind estimator's current estimate of the
        turbulence intensity (m/s, 1-sigma), if it has one. ``estimate_age_s``:
        the age of the position data behind the estimate (a GNSS fix's latency
        plus the time since it): the vehicle may have accelerated for that long
        unseen, so it adds to the reaction time in every margin. ``horizon``: the estimate at its newest
        fix's time of validity, if the estimator gives it: dead reckoning then starts there.
        """
        est = self._take_estimate(
            t_s, est, dt_s, wind_en, position_valid, sigma_h_m, sigma_v_m, turbulence_sigma_mps, estimate_age_s, horizon
        )  # fmt: skip
        h = est.agl_m if self._agl else est.alt_m  # self.height(est)
        mode = self.mode
        if (
            mode is _MONITOR and position_valid and not abs(est.alt_m - self._density_alt_m) < DENSITY_REFRESH_M
        ):  # never scaled (NaN), or the altitude moved (not "<": a NaN altitude rescales)
            self._scale_to_density(est.alt_m)
        if mode is _LAND_IN_GAP or mode is _TERMINATE:
            return self._land(t_s, est, h, dt_s)
        if not position_valid:
            self._start_landing(t_s, est, h, "position source lost")
            return self._land(t_s, est, h, dt_s)
        we, wn = self.wind_enu
        allowance, limit = self._return_wind_limits
        # return_not_assured's test against its limits (computed once per envelope); its message only when it fails
        impossible = None if return_assured(we, wn, allowance, limit) else self._return_impossible()
        if impossible is None:
            self._strong_wind_since_s = math.nan
        else:
            since = self._strong_wind_since_s
            if since != since:  # (NaN: it starts now)
                self._strong_wind_since_s = since = t_s
            if t_s - since >= WIND_BEYOND_AUTHORITY_PERSIST_S:
                self._start_landing(t_s, est, h, impossible)
                return self._land(t_s, est, h, dt_s)

        if mode is _OVERRIDE and self._override_losing_ground():
            self._start_landing(t_s, est, h, self._losing_ground_reason())
            return self._land(t_s, est, h, dt_s)

        monitoring = mode is _MONITOR or mode is _RECOVERED
        if monitoring and self._predictive:
            found = self._monitor_margins(est, h, sigma_h_m, sigma_v_m, dt_s)
            if found is None:  # far from everything
                self.activation_margin_m = math.inf  # larger than any room: not computed in detail
                if hold_over(mode is _RECOVERED, t_s, self._mode_since_s):
                    self.complete_hand_back(t_s)
                return pilot
            r = found
        elif mode is _OVERRIDE and t_s - self._override_period_start_s < self.config.min_override_s:
            self.activation_margin_m = math.nan  # not needed (nor computed) until the minimum override has passed
            return self.recovery.sticks(est, h, t_s, dt_s)
        else:
            r = self._margins(est, h, sigma_h_m, sigma_v_m, dt_s)
        self.last = r
        act = r.activation_margin_m if self._predictive else self._reactive_activation(r)
        self.activation_margin_m = act

        if monitoring:
            if activates(act, est.on_ground, est.ground_speed_mps):
                self.activations += 1
                if self.first_activation_s is None:
                    self.first_activation_s = t_s
                if impossible:
                    self._start_landing(t_s, est, h, impossible)
                    return self._land(t_s, est, h, dt_s)
                self._start_override(t_s, est, h, r, self._trigger_reason(r))
            else:
                if hold_over(mode is _RECOVERED, t_s, self._mode_since_s):
                    self.complete_hand_back(t_s)
                return pilot

        # OVERRIDE
        if t_s - self._override_period_start_s >= self.config.min_override_s:
            if outside(r.lateral_margin_m, r.ceiling_margin_m, r.floor_margin_m):
                self.reactivations += 1
                if self.reactivations > self.config.max_reactivations:
                    self._start_landing(
                        t_s, est, h, f"still outside after {self.reactivations} override periods: recovery failed"
                    )
                    return self._land(t_s, est, h, dt_s)
                self._override_period_start_s = t_s
                self.transitions.append(
                    Transition(t_s, Mode.OVERRIDE, Mode.OVERRIDE, "still outside at the end of the override period: re-activated")
                )
            elif self._handback_ok(est, r, act) and not self.compliance.lagging:
                # (not while the vehicle lags behind what the override sent: a frozen flight controller keeps the
                # override's turn, and a hand-back would restart the compliance watch on the pilot's sticks)
                self.reactivations = 0
                self._switch(
                    t_s, Mode.RECOVERED, f"recovered: activation margin {act:.1f} m, closing {r.closing_speed_mps:.1f} m/s"
                )
                return pilot
        return self.recovery.sticks(est, h, t_s, dt_s)

    def _handback_ok(self, s: VehicleState, r: ShiftResult, act: float) -> bool:
        """:func:`geofence.unit.passes.hand_back` on these margins (its climb back cleared once done): a predictive
        unit's hysteresis is the activation margins' (:meth:`_vertical_handback_at_goal_m`), a reactive one's the
        plain margins'."""
        cfg = self.config
        if self._predictive:
            vertical_ok = r.vertical_activation_m >= self._vertical_handback_at_goal_m()
            lateral = r.lateral_activation_m
        else:
            vertical_ok = min(r.ceiling_margin_m, r.floor_margin_m) > 0.0
            lateral = r.lateral_margin_m - cfg.extra_margin_m
        re, rn = self.fence.recovery_en
        climbed, ok = hand_back(
            self._climb_back_to_m, self.height(s), vertical_ok, lateral, r.closing_speed_mps,
            cfg.handback_margin_m, math.hypot(re - s.east_m, rn - s.north_m), cfg.recovery_radius_m,
        )  # fmt: skip
        if climbed:
            self._climb_back_to_m = math.nan
        return ok

    def _vertical_handback_at_goal_m(self) -> float:
        """The vertical hand-back hysteresis the override's goal height allows, m.

        The configured one (at most a tenth of the band), or, where the goal is
        an explicit recovery height or the middle of a band too thin for
        :meth:`_goal_height`'s room, half the vertical
        activation margin the vehicle has at rest at the goal height when that
        is less: at rest the pilot may still climb or dive at once
        (:func:`~geofence.physics.rooms.vertical_arrest_distance_m` from 0 m/s), and an
        explicit recovery height 0.3 m under an indoor ceiling leaves 0.09 m
        of margin there (the indoor seed quad, 0.11 m of hysteresis: it was
        never handed back). Half of it keeps the hysteresis against the altitude
        hold's settling and never re-activates a vehicle resting at its goal.
        """
        env, fence, cfg = self.env, self.fence, self.config
        return vertical_handback_m(
            self._vertical_handback_m, self._goal_short_of_band_h_m(), fence.ceiling_m,
            math.nan if fence.floor_m is None else fence.floor_m, env.reaction_time_s + self._latency_s,
            env.vertical_accel_mps2, env.max_climb_rate_mps, env.max_descent_rate_mps,
            cfg.uncertainty_k_sigma * self._sigma_v_m + cfg.extra_margin_m,
        )  # fmt: skip

    def _goal_short_of_band_h_m(self) -> float:
        """The override's goal height where it is short of the band (an explicit recovery height, or the middle of a
        band too thin for :meth:`_goal_height`'s room), else NaN: a goal in the band leaves the hysteresis and the
        settling room by construction."""
        return goal_short_of_band_h_m(self._goal_h_m, self._goal_short_of_band)

    def _landing_edge_margin_m(self) -> float:
        """How far inside the keep-in, or inside a floor gap, a multirotor's estimate must be to descend there (m):
        :data:`LANDING_EDGE_MARGIN_M` beyond the estimate's uncertainty margin ``k·σ_h + extra`` (the one every
        activation margin adds). Without it a multirotor aimed a few metres inside a gap's upwind edge, its
        estimate off by less than k·σ_h, touched down outside the gap
        (case history: docs/campaigns.md#breach-classes-found-and-fixed)."""
        return LANDING_EDGE_MARGIN_M + self.config.uncertainty_k_sigma * self._sigma_h_m + self.config.extra_margin_m

    def _safe_to_descend(self, s: VehicleState) -> bool:
        """Over ground where landing is allowed, with room to spare (:meth:`_landing_edge_margin_m` inside the
        keep-in, and inside a gap below a floor)."""
        fence = self.fence
        need = self._landing_edge_margin_m()
        if fence.lateral_margin_m(s.east_m, s.north_m) < need:
            return False
        return fence.floor_m is None or fence.gap_distance_m(s.east_m, s.north_m) >= need

    def _finish_below_floor(self, s: VehicleState, h: float) -> bool:
        """Below the floor in a gap, drifting toward its edge: is touching down the quicker way out?

        Below the floor the vehicle may only be over a gap. When it drifts toward the gap's edge (a wind
        it cannot beat), climbing back above the floor and touching down both end the exposure; it keeps
        descending while it may still be inside the gap (its estimate within ``k·σ_h`` of it) and
        touchdown comes no later than the climb would clear the floor.
        """
        fence = self.fence
        if fence.floor_m is None or h >= fence.floor_m:
            return False
        # inside the gap as far as the estimate can tell (within k·σ of it): climbing back is a sure floor breach
        if fence.gap_distance_m(s.east_m, s.north_m) <= -self.config.uncertainty_k_sigma * self._sigma_h_m:
            return False
        climb_s = (fence.floor_m - h) / max(self.env.max_climb_rate_mps, 0.1)
        return self.landing.time_to_touchdown_s(s.agl_m, s.ground_speed_mps) <= climb_s

    def _land(self, t_s: float, s: VehicleState, h: float, dt_s: float) -> StickCommand:
        if self.env.is_multirotor:
            if s.on_ground:
                return StickCommand(throttle=-1.0)
            # a fresh estimate with the position lost: its velocity is measured (optical flow), the dead reckoning
            # takes it from the next step; a height known to a rangefinder's accuracy: the touchdown is flared on it
            self.dead_reckoning.measured_velocity = not self._position_valid and self._latency_s - dt_s <= FRESH_ESTIMATE_AGE_S
            flare = self.landing.flares(self._sigma_v_m)
            if not self._position_valid and not self.dead_reckoning.active:  # never had a position: level, descend
                return StickCommand(throttle=climb_rate_to_stick(-min(1.0, self.env.max_descent_rate_mps), self.env))
            if not self._position_valid and self.fence.floor_m is None:
                # dead reckoning: away from the edges first, then down at the full rate (it drifts every second);
                # on the way no higher than a downward sensor's range, where a flow measures what it drifts at
                low = h - s.agl_m + DEAD_RECKONING_TRANSIT_AGL_M
                if self.landing.cruise_h > low:
                    self.landing.cruise_h = low
                room = self.fence.lateral_margin_m(s.east_m, s.north_m) >= self.dead_reckoning_room_m(s.agl_m)
                return self.landing.sticks(s, h, dt_s, descend=room or self.landing.over_point(s), hurry=True, flare=flare)
            beyond = self._landing_losing_ground() if self.fence.floor_m is None else None
            if beyond is not None:  # drifting out whatever it steers: down at once (every second in the air drifts it)
                if self.mode is Mode.LAND_IN_GAP and self._authority_termination(t_s, s, dt_s, beyond):
                    return StickCommand(throttle=-1.0)
                return self.landing.sticks(s, h, dt_s, descend=True, hurry=True, flare=flare, brakes=False)
            descend = self._safe_to_descend(s) or self.landing.over_point(s) or self._finish_below_floor(s, h)
            return self.landing.sticks(s, h, dt_s, descend=descend, flare=flare)
        if self.mode is Mode.LAND_IN_GAP and self.landing.over_point(s) and s.agl_m < TERMINATE_BELOW_AGL_M:
            self._switch(t_s, Mode.TERMINATE, f"flight termination over the landing gap at {s.agl_m:.1f} m AGL")
        if self.mode is Mode.TERMINATE:
            return StickCommand(roll=1.0, pitch=-1.0, yaw=0.0, throttle=-1.0)  # motor to minimum, spiral down
        return self.landing.sticks(s, h, dt_s)
