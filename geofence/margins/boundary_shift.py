"""Activation boundaries: how far inside the fence the geofence must act ("shifted fence").

The fence is shifted inward, edge by edge, by the
room the vehicle needs to turn back (fixed-wing) or stop (multirotor) plus an
estimate-uncertainty margin; vertically by the room to arrest a climb or a
descent. The geofence acts when the *activation margin* (distance to an edge
minus the room needed against that edge) reaches zero. This module is the
façade: :func:`activation_margins` (and :class:`CompiledMargins`, its tables
bound once) is one call of the compiled margins, :mod:`geofence.margins.kernel`,
the one implementation, for a fence with an index or without; the room formulas
themselves (turn, trochoid excursion, reaction travel, braking, arrest, their
upper bounds and the head-on room) live in :mod:`geofence.physics.rooms`, whose
docstring derives them.

Conventions: ENU metres and m/s; angles in rad. For an edge, ``n`` is the unit
normal pointing *towards the breach* (outward across a keep-in edge, into a
keep-out); a velocity or wind component along ``n`` is positive when it
carries the vehicle towards the breach ("closing", "tailwind").

Fixed-wing: the manoeuvre scored
--------------------------------
:func:`activation_margins` uses the maneuver the override flies: keep the
current state for the reaction time (the pilot's current turn goes on:
:func:`~geofence.physics.rooms.reaction_arc_m`), then turn at the bank limit in
direction ``s`` until the air heading is the wind-corrected heading towards
the recovery point (a course reversal, ``Delta = pi``, within 1 m of it), then
fly straight. For each edge it takes the exact maximum of the trochoid
excursion ``x(theta)`` over that turn
(:func:`~geofence.physics.rooms.trochoid_excursion_m`), or the reaction arc's farthest
point when that lies farther (banked away from an edge, the aircraft first
closes on it: :func:`~geofence.physics.rooms.reaction_arc_gap_m`), and chooses the direction ``s``
with the larger worst-edge activation margin (both directions are scored
against *all* edges, so convex corners and narrow corridors are handled).
Assumed: constant airspeed -- the larger of the current one and cruise, since
the override flies at cruise and a slow aircraft's turn widens as it speeds up
(scored at the current airspeed instead, a slow aircraft leaves the fence)
(case history: docs/campaigns.md#acute-0013-a-slow-aircrafts-turn-widens-as-it-speeds-up-to-cruise)
-- and wind, instant roll-in (fold roll-in into
``reaction_time_s``), and a straight leg from roll-out to the recovery point
inside the fence (true when the fence is star-shaped about it, e.g. convex).
Consequences: the margin steps down when the vehicle overflies the recovery
point (it then needs a reversal instead of no turn), and at the recovery point
heading straight at an edge a reversal needs ``2R`` sideways -- if that
exceeds the room, the activation margin is negative at the recovery point
itself, which is what :func:`check_shift_feasible` reports for the whole fence.

Multirotor: the manoeuvre scored
--------------------------------
The worst-case pilot (:func:`~geofence.physics.rooms.multirotor_room_m`): until the
override acts (``t_react`` plus the control-step ``latency_s``) the vehicle may
keep accelerating toward the edge at the tilt limit (while below max
airspeed) plus the wind's push, then brakes at the braking deceleration net of
the push, weakened while a climb is being arrested
(:func:`~geofence.physics.rooms.braking_room_m`). Both the pilot's acceleration and
the climb arrest were measured to matter in closed loop (an F450 at full tilt
and full climb overshot by 1.3 m without them, 0 with).

Turbulence and gusts: ``wind_extra_mps`` (k·σ of the turbulence plus a gust
allowance, chosen by the caller) is added to the wind component towards every
edge and to the wind speed, for the whole manoeuvre, on both platform kinds.

Vertical: the arrest distance (:func:`~geofence.physics.rooms.vertical_arrest_distance_m`)
for a climb towards the ceiling and a descent towards the floor.

Uncertainty
-----------
``k·sigma``: horizontally ``k·sqrt(lambda_max)`` of the 2x2 horizontal
position covariance (conservative in every direction), vertically
``k·sqrt(P_uu)``; or a fixed configured margin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, Sequence

import numpy as np

from geofence import jit as _jit
from geofence.geometry.fence import AltitudeReference, FenceError
from geofence.geometry.local_fence import LocalFence
from geofence.interface import Envelope, PlatformKind, VehicleState
from geofence.margins.kernel import envelope_terms, indexed_margins, room_bound
from geofence.margins.kernel import margins as margins_kernel
from geofence.margins.kernel import monitor_margins as monitor_margins_kernel
from geofence.physics.rooms import G_MPS2, vertical_arrest_distance_m, worst_case_lateral_shift_m

__all__ = [
    "CompiledMargins",
    "ShiftFeasibility",
    "ShiftResult",
    "activation_margins",
    "activation_margins_for_state",
    "check_shift_feasible",
    "uncertainty_margin_m",
]


# --------------------------------------------------------------------------- uncertainty
def uncertainty_margin_m(cov: Sequence[Sequence[float]] | None, k_sigma: float = 3.0) -> tuple[float, float]:
    """``(horizontal, vertical)`` margins ``k·sigma`` from a 2x2 (E, N) or 3x3 (E, N, U) position covariance.

    Horizontal: ``k·sqrt`` of the largest eigenvalue of the E/N block;
    vertical: ``k·sqrt(P_uu)`` (0 for a 2x2 covariance). ``None`` -> (0, 0).
    """
    if cov is None:
        return 0.0, 0.0
    a, b, d = float(cov[0][0]), 0.5 * (float(cov[0][1]) + float(cov[1][0])), float(cov[1][1])
    lam = 0.5 * (a + d) + math.sqrt(0.25 * (a - d) ** 2 + b * b)
    vert = 0.0
    if len(cov) >= 3:
        vert = k_sigma * math.sqrt(max(float(cov[2][2]), 0.0))
    return k_sigma * math.sqrt(max(lam, 0.0)), vert


# --------------------------------------------------------------------------- activation margins
class ShiftResult(NamedTuple):
    """Activation margins for one state (m; + = no action needed).

    ``activation_margin_m = min(lateral_activation_m, vertical_activation_m)``.
    Lateral: ``lateral_margin_m`` is the plain margin at the position; the
    threatened constraint is the edge (or circle) with the smallest
    ``distance - room``: its ``feature`` / ``feature_index`` / ``edge`` (-1 for
    a circle), the unit direction it is scored along ``normal_e/normal_n`` (its breach-pointing normal, or
    towards its nearest point where that is an edge's end: :func:`~geofence.geometry.elements.edge_scored`),
    the distance it is scored at ``edge_distance_m``, required ``lateral_shift_m`` (room incl. reaction and
    uncertainty) and ``lateral_activation_m = edge_distance_m -
    lateral_shift_m`` (capped at ``lateral_margin_m`` once breached).
    ``closing_speed_mps`` is the ground speed along that direction,
    ``time_to_breach_s = edge_distance_m / closing_speed`` (``inf`` when not
    closing, 0 when breached). ``turn_sign``: the turn direction scored best
    (+1 left, -1 right; 0 for a multirotor) and ``turn_angle_rad`` the turn
    it scored (the guidance must not turn further). Vertical: margins to ceiling and
    (gap-aware) floor, their shifts, ``vertical_activation_m`` and
    ``vertical_time_to_breach_s``.
    """

    activation_margin_m: float
    lateral_margin_m: float
    lateral_shift_m: float
    lateral_activation_m: float
    feature: str
    feature_index: int
    edge: int
    normal_e: float
    normal_n: float
    edge_distance_m: float
    closing_speed_mps: float
    time_to_breach_s: float
    turn_sign: int
    turn_angle_rad: float
    ceiling_margin_m: float
    ceiling_shift_m: float
    floor_margin_m: float
    floor_shift_m: float
    vertical_activation_m: float
    vertical_time_to_breach_s: float


def activation_margins(
    fence: LocalFence,
    e: float,
    n: float,
    h: float,
    ve: float,
    vn: float,
    vu: float,
    envelope: Envelope,
    wind_e: float = 0.0,
    wind_n: float = 0.0,
    *,
    h_uncertainty_m: float = 0.0,
    v_uncertainty_m: float = 0.0,
    latency_s: float = 0.0,
    bank_rad: float = 0.0,
    wind_extra_mps: float = 0.0,
    rollout_target_en: tuple[float, float] | None = None,
    g: float = G_MPS2,
) -> ShiftResult:
    """Required shifts and activation margins for a state (see :class:`ShiftResult`), one compiled call
    (:mod:`geofence.margins.kernel`; :meth:`CompiledMargins.margins` with the tables bound once).

    ``(e, n)`` ENU position and ``h`` height in the fence's altitude reference
    (m); ``(ve, vn, vu)`` ground velocity (m/s); ``(wind_e, wind_n)`` the steady
    wind estimate (m/s, the direction the air moves towards);
    ``h_uncertainty_m`` / ``v_uncertainty_m`` the horizontal / vertical
    uncertainty margins (e.g. from :func:`uncertainty_margin_m`) added to every
    lateral / vertical shift. ``wind_extra_mps`` is the turbulence and gust
    allowance: every edge is scored as if the wind blew that much harder
    towards it for the whole manoeuvre (``w_n + extra``, ``|W| + extra``).
    ``rollout_target_en``: where the fixed-wing's recovery turn rolls out
    towards (the first point of its planned route; default the recovery point).

    Floor gaps: below the floor inside a gap, leaving the gap sideways is a
    breach, so the gap's edges are scored like keep-in edges (lateral room).
    The floor is safe while *either* the descent can be arrested above the
    floor *or* the vehicle stays inside the gap it is over, so the floor
    activation is the larger of the vertical arrest margin (gaps ignored) and
    the lateral activation margin against the gap's edges. A fixed-wing cannot
    hover: the override keeps it circling at the bank limit, the way it turns,
    until it has climbed back above the floor from the deepest point its
    descent reaches, and the circle drifts with the wind: its gap room is that
    whole circling turn (:func:`geofence.physics.rooms.gap_circle_turn_rad`). That turn
    is one for the keep-in and the gap together: the keep-in's best turn, or
    the other one where its circle keeps the gap better and its lateral
    activation allows it (then the result's turn, lateral element and room are
    that turn's, and the override flies it). Scored in the keep-in's turn
    alone, a heading sweeping round flipped the circle out of the gap within a
    step.
    """
    return CompiledMargins(fence, _envelope_terms(envelope)).margins(
        e, n, h, ve, vn, vu, wind_e, wind_n, h_uncertainty_m, v_uncertainty_m, latency_s, bank_rad, wind_extra_mps,
        rollout_target_en, g,
    )  # fmt: skip


_ENVELOPE_TERMS: dict[int, tuple[Envelope, np.ndarray]] = {}
"""The margins' envelope terms (the compiled kernels' array) by envelope object (its identity checked: the entry
holds it); cleared from :data:`_ENVELOPE_TERMS_KEPT` entries on (a unit makes a new envelope each time the air
density it scales to moves, and a batch process flies many units)."""
_ENVELOPE_TERMS_KEPT = 64


def _envelope_terms(envelope: Envelope) -> np.ndarray:
    """:func:`geofence.margins.kernel.envelope_terms` of ``envelope``, cached by identity."""
    cached = _ENVELOPE_TERMS.get(id(envelope))
    if cached is None or cached[0] is not envelope:
        if len(_ENVELOPE_TERMS) >= _ENVELOPE_TERMS_KEPT:
            _ENVELOPE_TERMS.clear()
        cached = _ENVELOPE_TERMS[id(envelope)] = (envelope, envelope_terms(envelope))
    return cached[1]


class CompiledMargins:
    """The compiled margins of one fence and one envelope, their tables bound once.

    :meth:`margins` is :func:`activation_margins` and :meth:`monitor` is :func:`monitor_margins` (the same
    numbers: :func:`geofence.margins.kernel.margins`, :func:`~geofence.margins.kernel.indexed_margins` for a fence
    with an index, and :func:`~geofence.margins.kernel.monitor_margins`), with positional arguments and the fence's
    tables and the envelope's terms looked up at construction, not per call: the unit asks one of them every step
    (:class:`geofence.unit.geofence_unit.GeofenceUnit` keeps one per envelope for a fence without an index).
    ``envelope``: an :class:`Envelope`, or its :func:`~geofence.margins.kernel.envelope_terms` already made.
    """

    __slots__ = ("fence", "_tables", "_terms", "_meta", "_grid", "_margins_kernel", "_monitor_kernel")

    def __init__(self, fence: LocalFence, envelope: Envelope | np.ndarray):
        self.fence = fence
        self._tables = fence.margin_tables()
        self._terms = envelope if isinstance(envelope, np.ndarray) else _envelope_terms(envelope)
        self._meta = fence.element_table()[1]
        self._grid = fence.grid()
        # the kernels, through numba's dispatcher at their first call, then by their entry points (geofence.jit:
        # the tables are this object's own, built once)
        self._margins_kernel = margins_kernel
        self._monitor_kernel = monitor_margins_kernel

    def margins(
        self, e: float, n: float, h: float, ve: float, vn: float, vu: float, wind_e: float, wind_n: float, hu: float,
        v_unc: float, latency_s: float, bank_rad: float, wind_extra_mps: float,
        rollout_target_en: tuple[float, float] | None, g: float = G_MPS2,
    ) -> ShiftResult:  # fmt: skip
        """:func:`activation_margins` (``hu``, ``v_unc``: its ``h_uncertainty_m``, ``v_uncertainty_m``)."""
        F, L = self._tables
        has, te, tn = (False, 0.0, 0.0) if rollout_target_en is None else (True, *rollout_target_en)
        if self._grid is not None:
            state = (ve, vn, vu, wind_e, wind_n, hu, v_unc, latency_s, bank_rad, wind_extra_mps, has, te, tn, g)
            return self._result(e, n, self._indexed(e, n, h, state))
        kernel = self._margins_kernel
        r = kernel(
            F, L, self._terms, e, n, h, ve, vn, vu, wind_e, wind_n, hu, v_unc, latency_s, bank_rad, wind_extra_mps,
            has, te, tn, g, math.nan,
        )  # fmt: skip
        if kernel is margins_kernel:
            self._margins_kernel = _jit.entry_point(kernel)
        return self._result(e, n, r)

    def _indexed(self, e: float, n: float, h: float, state: tuple) -> tuple:
        """:func:`geofence.margins.kernel.indexed_margins` over the index's candidates within the state's room bound
        (every element where it is unbounded) and its lateral margin."""
        assert self._grid is not None
        fence = self.fence
        ve, vn, vu, wind_e, wind_n, hu, v_unc, latency_s, bank_rad, extra, has, te, tn, g = state
        re, rn = (te, tn) if has else fence.recovery_en
        bound = room_bound(self._terms, ve, vn, vu, wind_e, wind_n, hu, latency_s, bank_rad, extra, re - e, rn - n, g)
        if bound < math.inf:
            ids, lbs, delta_c = self._grid.candidates(e, n, bound)
            walk = True
        else:
            _, _, ids, lbs = fence.element_table()
            walk, delta_c = False, 0.0
        F, L = self._tables
        lat_margin = fence.lateral_margin_m(e, n)
        return indexed_margins(
            F, L, self._terms, ids, lbs, walk, delta_c, e, n, h, ve, vn, vu, wind_e, wind_n, hu, v_unc, latency_s,
            bank_rad, extra, has, te, tn, g, lat_margin,
        )  # fmt: skip

    def monitor(
        self, e: float, n: float, h: float, ve: float, vn: float, vu: float, ground_speed_mps: float, wind_e: float,
        wind_n: float, hu: float, v_unc: float, latency_s: float, skip_time_s: float, bank_rad: float,
        wind_extra_mps: float, rollout_target_en: tuple[float, float] | None, g: float = G_MPS2,
    ) -> ShiftResult | None:  # fmt: skip
        """:func:`monitor_margins`: ``None`` when the unit's skip shortcut holds, else :meth:`margins` (every
        element scanned, index or none: the unit asks it of a fence without an index)."""
        F, L = self._tables
        has, te, tn = (False, 0.0, 0.0) if rollout_target_en is None else (True, *rollout_target_en)
        kernel = self._monitor_kernel
        far, r = kernel(
            F, L, self._terms, e, n, h, ground_speed_mps, ve, vn, vu, wind_e, wind_n, wind_extra_mps, skip_time_s,
            hu, v_unc, latency_s, bank_rad, has, te, tn, g,
        )  # fmt: skip
        if kernel is monitor_margins_kernel:
            self._monitor_kernel = _jit.entry_point(kernel)
        return None if far else self._result(e, n, r)

    def _result(self, e: float, n: float, r: tuple) -> ShiftResult:
        """The :class:`ShiftResult` of a margins kernel's fields at (e, n) (the fence remembers its lateral margin;
        ``tuple.__new__``: a named tuple's generated constructor costs twice as much)."""
        self.fence.remember_margin(e, n, r[1])
        return tuple.__new__(ShiftResult, r[:4] + self._meta[r[4]] + r[5:])

    def shift_result(self, fields: Sequence[float]) -> ShiftResult:
        """The :class:`ShiftResult` of a margins kernel's fields stored as floats (the element id and the turn sign
        back to ints)."""
        r = tuple(fields)
        return tuple.__new__(ShiftResult, r[:4] + self._meta[int(r[4])] + r[5:10] + (int(r[10]),) + r[11:])


def monitor_margins(
    fence: LocalFence, e: float, n: float, h: float, ve: float, vn: float, vu: float, ground_speed_mps: float,
    envelope: Envelope, wind_e: float, wind_n: float, *, h_uncertainty_m: float, v_uncertainty_m: float,
    latency_s: float, skip_time_s: float, bank_rad: float, wind_extra_mps: float,
    rollout_target_en: tuple[float, float] | None, g: float = G_MPS2,
) -> ShiftResult | None:  # fmt: skip
    """A monitoring unit's step in one compiled call (:func:`geofence.margins.kernel.monitor_margins`; every
    element scanned: for a fence without an index): ``None`` when the unit's skip shortcut holds (no
    element, ceiling or floor within the largest room the state can need over ``skip_time_s``, see
    :meth:`geofence.unit.geofence_unit.GeofenceUnit._far_from_everything`), else :func:`activation_margins`
    (the other arguments are its own; ``ground_speed_mps``: the state's). :meth:`CompiledMargins.monitor` with
    its tables bound once."""
    return CompiledMargins(fence, envelope).monitor(
        e, n, h, ve, vn, vu, ground_speed_mps, wind_e, wind_n, h_uncertainty_m, v_uncertainty_m, latency_s,
        skip_time_s, bank_rad, wind_extra_mps, rollout_target_en, g,
    )  # fmt: skip


def activation_margins_for_state(
    fence: LocalFence, state: VehicleState, envelope: Envelope, wind_e: float = 0.0, wind_n: float = 0.0, **kw
) -> ShiftResult:
    """:func:`activation_margins` for a :class:`VehicleState` (height: ``agl_m`` or ``alt_m`` per the fence)."""
    h = state.agl_m if fence.altitude_reference is AltitudeReference.AGL else state.alt_m
    return activation_margins(
        fence, state.east_m, state.north_m, h, state.v_east_mps, state.v_north_mps, state.v_up_mps, envelope, wind_e, wind_n, **kw
    )


# --------------------------------------------------------------------------- feasibility
@dataclass(frozen=True, slots=True)
class ShiftFeasibility:
    """Worst-case shifts for a platform and wind, and the room the fence offers (m)."""

    lateral_shift_m: float
    inradius_m: float
    ceiling_shift_m: float
    floor_shift_m: float
    vertical_room_m: float


def check_shift_feasible(
    fence: LocalFence,
    envelope: Envelope,
    wind_speed_mps: float,
    *,
    h_uncertainty_m: float = 0.0,
    v_uncertainty_m: float = 0.0,
    g: float = G_MPS2,
) -> ShiftFeasibility:
    """Raise :class:`FenceError` if the shifted (activation) boundary vanishes for this platform and wind.

    Lateral: the worst-case shift (:func:`worst_case_lateral_shift_m`) must be
    below the inradius of the allowed area (else no point is safe for every
    heading). Vertical: with a floor, ceiling - floor must exceed the climb
    plus descent arrest distances at the envelope's rates; with an AGL fence
    and no floor, the ceiling must exceed the climb arrest distance.
    """
    kind = envelope.kind.value
    w = abs(wind_speed_mps)
    shift = worst_case_lateral_shift_m(envelope, w, h_uncertainty_m, g)
    r = fence.inradius()[2]
    if not shift < r:
        why = (
            "the wind is at least the airspeed"
            if envelope.kind is PlatformKind.FIXED_WING
            else "the wind push is at least the braking deceleration"
        )
        detail = f"{shift:.1f} m" if math.isfinite(shift) else f"infinite ({why})"
        raise FenceError(
            f"shifted fence vanishes: worst-case lateral shift {detail} for {kind} at "
            f"{envelope.max_speed_mps:g} m/s in {w:g} m/s wind >= inradius {r:.1f} m of the allowed area"
        )
    t_r, az = envelope.reaction_time_s, envelope.vertical_accel_mps2
    cs = vertical_arrest_distance_m(abs(envelope.max_climb_rate_mps), t_r, az, abs(envelope.max_climb_rate_mps)) + v_uncertainty_m
    fs = (
        vertical_arrest_distance_m(abs(envelope.max_descent_rate_mps), t_r, az, abs(envelope.max_descent_rate_mps))
        + v_uncertainty_m
    )
    if fence.floor_m is not None:
        room = fence.ceiling_m - fence.floor_m
        need = cs + fs
    elif fence.altitude_reference is AltitudeReference.AGL:
        room, need, fs = fence.ceiling_m, cs, 0.0
    else:
        room, need, fs = math.inf, cs, 0.0
    if not need < room:
        raise FenceError(
            f"shifted fence vanishes vertically: climb + descent arrest {need:.1f} m for {kind} "
            f">= {room:.1f} m between floor and ceiling"
        )
    return ShiftFeasibility(shift, r, cs, fs, room)
