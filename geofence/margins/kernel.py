"""The activation margins of a state against a fence, compiled whole: the one implementation.

:func:`geofence.margins.boundary_shift.activation_margins` is a façade over one call here: the per-state terms
(:func:`state_terms`: reaction time, turn constants, roll-out heading, the room bound), the binding lateral element
among the candidates (:func:`geofence.margins.lateral.lateral_binding`), the lateral margin's full scan
(:func:`geofence.geometry.scan.lateral_margin_scan`), the ceiling, the floor and the floor gap the vehicle is over.
:func:`margins` scans every element (a fence without a :class:`~geofence.geometry.fence_grid.FenceGrid`: the fences
autopilots store, and most users'); :func:`indexed_margins` searches an index cell's candidates
(:meth:`geofence.geometry.fence_grid.FenceGrid.candidates`, reach :func:`room_bound`): both are :func:`_margins_among`.
The room formulas are compiled from their one home in :mod:`geofence.physics.rooms` and :mod:`geofence.physics.dynamics`.
:func:`monitor_margins` is a monitoring unit's step (the skip shortcut :func:`far_from_everything`, then the
margins) in one call.

The fence's tables (:class:`MarginTables`, built once per fence, packed in one float and one int array: a
compiled call pays about 0.1 µs per array argument) and the envelope's terms (:func:`envelope_terms`) are arrays;
the kernels return the result's fields with the binding element's row id in place of its feature, index and edge.
"""

from __future__ import annotations

import math
from math import hypot
from typing import NamedTuple

import numpy as np

from geofence.geometry.elements import (
    CEILING,
    CIRCLES,
    ELEMENTS,
    FLOOR,
    GAP_EDGE_OFFSETS,
    GAP_EDGES,
    GAP_OFFSETS,
    GAP_POLYGONS,
    HAS_FLOOR,
    IDS,
    KEEP_IN,
    KEEP_OUT_OFFSETS,
    KEEP_OUTS,
    LINE_EDGES,
    RECOVERY_E,
    RECOVERY_N,
    ZEROS,
    fence_scalar,
    packed_column,
    packed_table,
    packed_vector,
)  # fmt: skip
from geofence.geometry.scan import deepest_polygon, lateral_margin_scan
from geofence.interface import Envelope, PlatformKind
from geofence.jit import compiled, jitable, numba
from geofence.margins.lateral import (
    EnvelopeTerms,
    FixedWingTurn,
    LateralState,
    MultirotorBrake,
    Turns,
    capped_lateral,
    lateral_binding,
)
from geofence.physics.dynamics import drag_coefficients
from geofence.physics.rooms import (
    climb_arrest_phase,
    climb_back_drift_m,
    fixed_wing_reaction_terms,
    fixed_wing_room_bound_m,
    gap_circle_turn_rad,
    multirotor_room_bound_m,
    rollout_turns,
    room_upper_bounds_terms,
    tilt_accel_mps2,
    vertical_arrest_distance_m,
)

__all__ = [
    "Binding",
    "Candidates",
    "EnvelopeTerms",
    "StateTerms",
    "envelope_of_terms",
    "envelope_terms",
    "envelope_tuple",
    "far_from_everything",
    "indexed_margins",
    "margins",
    "monitor_margins",
    "room_bound",
    "state_terms",
    "vertical_arrests_m",
    "vertical_time_to_breach_s",
]


ENVELOPE_TERM_COUNT = len(EnvelopeTerms._fields)
# the positions the unit's kernel reads a few of them at (geofence.unit.passes)
VERTICAL_ACCEL = EnvelopeTerms._fields.index("vertical_accel_mps2")
MAX_CLIMB = EnvelopeTerms._fields.index("max_climb_mps")
MAX_DESCENT = EnvelopeTerms._fields.index("max_descent_mps")


def envelope_tuple(env: Envelope) -> EnvelopeTerms:
    """The :class:`EnvelopeTerms` of ``env``."""
    k1, k2 = drag_coefficients(env)
    return EnvelopeTerms(
        fixed_wing=float(env.kind is PlatformKind.FIXED_WING), reaction_s=env.reaction_time_s,
        max_bank_rad=env.max_bank_rad, cruise_mps=env.cruise_speed_mps, min_speed_mps=env.min_speed_mps,
        max_speed_mps=env.max_speed_mps, braking_mps2=env.braking_decel_mps2,
        vertical_accel_mps2=env.vertical_accel_mps2, max_climb_mps=env.max_climb_rate_mps, k1=k1, k2=k2,
        max_descent_mps=env.max_descent_rate_mps,
    )  # fmt: skip


def envelope_terms(env: Envelope) -> np.ndarray:
    """The envelope's terms :func:`margins` reads, as the float array it takes (:class:`EnvelopeTerms`' order)."""
    return np.array(envelope_tuple(env), dtype=np.float64)


def envelope_of_terms(V: np.ndarray) -> EnvelopeTerms:
    """The :class:`EnvelopeTerms` of :func:`envelope_terms`' array (compiled: a fixed-size tuple of its floats)."""
    return EnvelopeTerms(*(float(x) for x in V))


if numba is not None:
    from numba.np.unsafe.ndarray import to_fixed_tuple

    @numba.extending.overload(envelope_of_terms)
    def _envelope_of_terms_compiled(V):  # noqa: ANN001, ANN202 - numba's typing hook
        def impl(V):  # noqa: ANN001, ANN202
            return EnvelopeTerms(*to_fixed_tuple(V, ENVELOPE_TERM_COUNT))

        return impl


class StateTerms(NamedTuple):
    """A state's terms for the binding search (:func:`geofence.margins.lateral.lateral_binding`): the envelope's,
    the state's own, a fixed-wing's turn and a multirotor's stop (the other kind's are zeros), the two turns a
    fixed-wing is scored with, and ``bound`` (m): no element farther than the nearest plus this can bind."""

    env: EnvelopeTerms
    state: LateralState
    turn: FixedWingTurn
    brake: MultirotorBrake
    turns: Turns
    bound: float


class Candidates(NamedTuple):
    """The lateral elements a state's binding element is searched among: the rows ``ids`` of the element table
    ``E``, walked in order of their bounds ``lbs`` (less ``delta_c``) when ``walk`` (an index cell's list,
    :meth:`geofence.geometry.fence_grid.FenceGrid.candidates`), else every one scored; the first ``n_line`` rows are a
    convex keep-in's edges (:func:`geofence.margins.lateral.lateral_binding`'s arguments)."""

    E: np.ndarray
    ids: np.ndarray
    lbs: np.ndarray
    walk: bool
    delta_c: float
    n_line: int


class Binding(NamedTuple):
    """The binding lateral element of a turn choice: its activation (capped at the lateral margin), turn sign,
    element id, room, the direction it is scored along, scored distance, closing speed, turn angle and time to
    breach (:class:`~geofence.margins.boundary_shift.ShiftResult`'s lateral fields)."""

    act: float
    s: float
    i: int
    room: float
    nx: float
    ny: float
    d: float
    v_n: float
    angle: float
    ttb: float


MarginFields = tuple[
    float, float, float, float, int, float, float, float, float, float, int, float, float, float, float, float, float, float
]
""":func:`_margins`' answer: :class:`~geofence.margins.boundary_shift.ShiftResult`'s fields, the binding element's row id in
place of its feature, index and edge."""


@jitable
def state_terms(
    V: np.ndarray, ve: float, vn: float, vu: float, wind_e: float, wind_n: float, hu: float, latency_s: float,
    bank_rad: float, wind_extra_mps: float, de: float, dn: float, g: float,
) -> StateTerms:  # fmt: skip
    """The :class:`StateTerms` of a state, the one home of their arithmetic; arguments as :func:`_margins`'
    (``V``: :func:`envelope_terms`; ``(de, dn)``: the roll-out target from the position, m).

    Fixed-wing: the reaction phase (the pilot's current turn goes on, and rolling out of the current bank costs
    up to another roll time, at cruise at least: :func:`~geofence.physics.rooms.fixed_wing_reaction_terms`), the turns
    to the wind-corrected roll-out heading (:func:`~geofence.physics.rooms.rollout_turns`); multirotor: the worst-case
    pilot (the tilt limit while below max airspeed) and the climb arrest (it lowers the collective, and with it
    the horizontal braking force).
    """
    env = envelope_of_terms(V)
    extra = wind_extra_mps if wind_extra_mps > 0.0 else 0.0
    speed = hypot(ve, vn)
    v_air = hypot(ve - wind_e, vn - wind_n)
    wspeed = hypot(wind_e, wind_n) + extra
    t_r = env.reaction_s + latency_s
    state = LateralState(ve, vn, wind_e, wind_n, extra, hu)
    if env.fixed_wing != 0.0:
        psi_abs, psi_react0, v_turn, radius, inv_omega, t_fw, omega_now, rot = fixed_wing_reaction_terms(
            v_air, ve - wind_e, vn - wind_n, ve, vn, speed, env.cruise_mps, env.min_speed_mps, env.max_bank_rad,
            env.reaction_s, t_r, bank_rad, g,
        )  # fmt: skip
        turn = FixedWingTurn(v_turn, psi_react0, rot, omega_now, t_fw, math.sin(psi_abs), math.cos(psi_abs), radius, inv_omega)
        turns = Turns(*rollout_turns(de, dn, hypot(de, dn), wind_e, wind_n, v_turn, psi_abs))
        bound = fixed_wing_room_bound_m(radius, inv_omega, speed, wspeed, t_fw) + hu
        return StateTerms(env, state, turn, MultirotorBrake(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), turns, bound)
    a_tilt = tilt_accel_mps2(env.max_bank_rad, g)
    arrest_t, arrest_loss = climb_arrest_phase(vu, env.vertical_accel_mps2, g)
    bound = multirotor_room_bound_m(speed, t_r, a_tilt, env.k1, env.k2, wspeed, env.braking_mps2, (arrest_t, arrest_loss), hu)
    a_pilot = a_tilt if v_air < env.max_speed_mps else 0.0
    brake = MultirotorBrake(wspeed, speed, a_pilot, t_r, arrest_t, arrest_loss)
    turn = FixedWingTurn(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    return StateTerms(env, state, turn, brake, Turns(0.0, 0.0, 0.0, 0.0), bound)


def _room_bound(
    V: np.ndarray, ve: float, vn: float, vu: float, wind_e: float, wind_n: float, hu: float, latency_s: float,
    bank_rad: float, wind_extra_mps: float, de: float, dn: float, g: float,
) -> float:  # fmt: skip
    """The ``bound`` of :func:`state_terms` (m): an indexed fence's candidates are the elements within it."""
    return state_terms(V, ve, vn, vu, wind_e, wind_n, hu, latency_s, bank_rad, wind_extra_mps, de, dn, g).bound


room_bound = compiled(_room_bound)
"""The compiled :func:`_room_bound`."""


@jitable
def _binding(C: Candidates, e: float, n: float, lat_margin: float, T: StateTerms, turns: Turns) -> Binding:
    """The :class:`Binding` among the candidates ``C`` for ``turns`` (:func:`geofence.margins.lateral.lateral_binding`,
    reach ``T.bound``; from the free space where ``lat_margin >= 0``), its activation capped by ``lat_margin``."""
    env = T.env
    act, s, i, room, nx, ny, d, v_n, angle, _ = lateral_binding(
        C.E, C.ids, C.lbs, C.walk, e, n, T.bound, C.delta_c, C.n_line, lat_margin >= 0.0, env.fixed_wing != 0.0, env,
        T.state, T.turn, T.brake, turns,
    )  # fmt: skip
    act, ttb = capped_lateral(act, lat_margin, d, v_n)
    return Binding(act, s, i, room, nx, ny, d, v_n, angle, ttb)


@jitable
def _gap_activation(G: np.ndarray, e: float, n: float, T: StateTerms, turns: Turns) -> float:
    """The activation against a floor gap's edge elements ``G`` (normals out of the gap) from a point inside it
    (free of it), every edge scored."""
    cnt = G.shape[0]
    env = T.env
    return lateral_binding(
        G, np.arange(cnt), np.zeros(cnt), False, e, n, T.bound, 0.0, 0, True, env.fixed_wing != 0.0, env, T.state,
        T.turn, T.brake, turns,
    )[0]  # fmt: skip


class OtherTurn(NamedTuple):
    """The other turn a fixed-wing over a floor gap may be scored with (:func:`_over_gap`): its direction
    (0: none) and angle, the floor's activation with its circle, and the activation it must beat (m)."""

    s: float
    delta: float
    floor_act: float
    now: float


NO_OTHER_TURN = OtherTurn(0.0, 0.0, 0.0, 0.0)


@jitable
def _over_gap(
    G: np.ndarray, e: float, n: float, gap_depth_m: float, floor_act: float, climb_m: float, ceiling_act: float,
    T: StateTerms, lat: Binding,
) -> tuple[float, OtherTurn]:  # fmt: skip
    """``(floor activation, other turn)`` over a gap ``gap_depth_m`` deep whose edge elements are ``G``: staying
    inside it (laterally) also keeps the floor (:func:`floor_with_gap_m`).

    A fixed-wing circles, the way it turns, until it has climbed back ``climb_m`` from its deepest point
    (:func:`geofence.physics.rooms.gap_circle_turn_rad`). The turn is one for the keep-in and the gap together: where the
    other turn's circle keeps the gap better, that turn is the one scored (and flown) if its lateral activation
    allows it (:func:`_margins_among` scores it); it can raise the floor's activation only below the gap's own
    room."""
    turns = T.turns
    if T.env.fixed_wing == 0.0:
        return floor_with_gap_m(floor_act, _gap_activation(G, e, n, T, turns), gap_depth_m), NO_OTHER_TURN
    circle = gap_circle_turn_rad(climb_m, T.env.max_climb_mps, T.turn.inv_omega)
    best = floor_with_gap_m(floor_act, _gap_activation(G, e, n, T, Turns(lat.s, circle, lat.s, circle)), gap_depth_m)
    if best >= gap_depth_m:
        return best, NO_OTHER_TURN
    s_o, delta_o = (turns.s2, turns.delta2) if lat.s == turns.s1 else (turns.s1, turns.delta1)
    other = floor_with_gap_m(floor_act, _gap_activation(G, e, n, T, Turns(s_o, circle, s_o, circle)), gap_depth_m)
    now = min(lat.act, best, ceiling_act)
    if other > best and min(other, ceiling_act) > now:
        return best, OtherTurn(s_o, delta_o, other, now)
    return best, NO_OTHER_TURN


@jitable
def _floor(
    F: np.ndarray, L: np.ndarray, e: float, n: float, h: float, dive_m: float, v_unc: float, ceiling_act: float,
    T: StateTerms, lat: Binding,
) -> tuple[float, float, OtherTurn]:  # fmt: skip
    """``(floor margin, floor activation, other turn)``: ``inf, inf`` without a floor; the gap-aware margin
    (:meth:`geofence.geometry.local_fence.LocalFence.floor_margin_m`) and, over the gap the point is deepest inside
    (:meth:`~geofence.geometry.local_fence.LocalFence.best_gap`), :func:`_over_gap`; else the descent's arrest margin
    (``dive_m``: how far it goes)."""
    if fence_scalar(F, L, HAS_FLOOR) == 0.0:
        return math.inf, math.inf, NO_OTHER_TURN
    floor = fence_scalar(F, L, FLOOR)
    f_m = h - floor
    f_act = h - floor - dive_m - v_unc
    gap_offsets = packed_vector(L, GAP_OFFSETS)
    if gap_offsets.shape[0] <= 1:
        return f_m, f_act, NO_OTHER_TURN
    gi, gd = deepest_polygon(e, n, packed_table(F, L, GAP_POLYGONS, 7), gap_offsets)
    if gd > f_m:
        f_m = gd
    if not gd > 0.0:
        return f_m, f_act, NO_OTHER_TURN
    edge_offsets = packed_vector(L, GAP_EDGE_OFFSETS)
    G = packed_table(F, L, GAP_EDGES, 7)[edge_offsets[gi] : edge_offsets[gi + 1]]
    f_act, other = _over_gap(G, e, n, gd, f_act, floor - (h - dive_m - v_unc), ceiling_act, T, lat)
    return f_m, f_act, other


@jitable
def _margins_among(
    F: np.ndarray, L: np.ndarray, V: np.ndarray, C: Candidates, e: float, n: float, h: float, ve: float, vn: float,
    vu: float, wind_e: float, wind_n: float, hu: float, v_unc: float, latency_s: float, bank_rad: float,
    wind_extra_mps: float, has_target: bool, target_e: float, target_n: float, g: float, lat_margin: float,
) -> MarginFields:  # fmt: skip
    """:func:`_margins` with the binding element searched among the candidates ``C``: the one algorithm."""
    re, rn = (target_e, target_n) if has_target else (fence_scalar(F, L, RECOVERY_E), fence_scalar(F, L, RECOVERY_N))
    T = state_terms(V, ve, vn, vu, wind_e, wind_n, hu, latency_s, bank_rad, wind_extra_mps, re - e, rn - n, g)
    if lat_margin != lat_margin:
        lat_margin = _lateral_margin(F, L, e, n)
    lat = _binding(C, e, n, lat_margin, T, T.turns)
    c_m = fence_scalar(F, L, CEILING) - h
    c_s, dive = vertical_arrests_m(T.env, vu, T.env.reaction_s + latency_s, v_unc)
    ceiling_act = c_m - c_s
    f_m, f_act, other = _floor(F, L, e, n, h, dive, v_unc, ceiling_act, T, lat)
    if other.s != 0.0:  # the other turn, where its lateral activation allows it
        o_lat = _binding(C, e, n, lat_margin, T, Turns(other.s, other.delta, other.s, other.delta))
        if min(o_lat.act, other.floor_act, ceiling_act) > other.now:
            lat = o_lat
            f_act = other.floor_act
    has_floor = fence_scalar(F, L, HAS_FLOOR) != 0.0
    f_s = f_m - f_act if has_floor else 0.0
    v_act = f_act if f_act < ceiling_act else ceiling_act
    vttb = vertical_time_to_breach_s(c_m, f_m, vu, has_floor)
    return (
        v_act if v_act < lat.act else lat.act, lat_margin, lat.room, lat.act, lat.i, lat.nx, lat.ny, lat.d, lat.v_n,
        lat.ttb, int(lat.s), lat.angle, c_m, c_s, f_m, f_s, v_act, vttb,
    )  # fmt: skip


@jitable
def _margins(
    F: np.ndarray, L: np.ndarray, V: np.ndarray, e: float, n: float, h: float, ve: float, vn: float, vu: float,
    wind_e: float, wind_n: float, hu: float, v_unc: float, latency_s: float, bank_rad: float, wind_extra_mps: float,
    has_target: bool, target_e: float, target_n: float, g: float, lat_margin: float,
) -> MarginFields:  # fmt: skip
    """:func:`~geofence.margins.boundary_shift.activation_margins` scanning every element: ``(activation, lateral margin,
    lateral shift, lateral activation, element id, nx, ny, edge distance, closing speed, time to breach, turn sign,
    turn angle, ceiling margin, ceiling shift, floor margin, floor shift, vertical activation, vertical time to
    breach)``; the arguments are its own (``h_uncertainty_m`` is ``hu``, ``v_uncertainty_m`` ``v_unc``;
    ``has_target``: a ``rollout_target_en`` is given). ``F, L``: a fence's packed :class:`MarginTables`.
    ``lat_margin``: the lateral margin at (e, n) when the caller has it, NaN: the full scan's
    (:func:`_lateral_margin`)."""
    C = Candidates(
        packed_table(F, L, ELEMENTS, 7),
        packed_vector(L, IDS),
        packed_column(F, L, ZEROS),
        False,
        0.0,
        int(fence_scalar(F, L, LINE_EDGES)),
    )
    return _margins_among(
        F, L, V, C, e, n, h, ve, vn, vu, wind_e, wind_n, hu, v_unc, latency_s, bank_rad, wind_extra_mps, has_target,
        target_e, target_n, g, lat_margin,
    )  # fmt: skip


def _indexed_margins(
    F: np.ndarray, L: np.ndarray, V: np.ndarray, ids: np.ndarray, lbs: np.ndarray, walk: bool, delta_c: float,
    e: float, n: float, h: float, ve: float, vn: float, vu: float, wind_e: float, wind_n: float, hu: float,
    v_unc: float, latency_s: float, bank_rad: float, wind_extra_mps: float, has_target: bool, target_e: float,
    target_n: float, g: float, lat_margin: float,
) -> MarginFields:  # fmt: skip
    """:func:`_margins` of an indexed fence, the binding element searched among an index cell's candidates
    (``ids, lbs, walk, delta_c``: :class:`Candidates`' fields, from :meth:`geofence.geometry.fence_grid.FenceGrid.candidates`)
    and ``lat_margin`` the index's lateral margin at (e, n)."""
    C = Candidates(packed_table(F, L, ELEMENTS, 7), ids, lbs, walk, delta_c, int(fence_scalar(F, L, LINE_EDGES)))
    return _margins_among(
        F, L, V, C, e, n, h, ve, vn, vu, wind_e, wind_n, hu, v_unc, latency_s, bank_rad, wind_extra_mps, has_target,
        target_e, target_n, g, lat_margin,
    )  # fmt: skip


@jitable
def vertical_arrests_m(env: EnvelopeTerms, vu: float, t_r: float, v_unc: float) -> tuple[float, float]:
    """``(ceiling shift, dive)`` (m): how far a climb at ``vu`` (m/s) goes before it is arrested, plus the
    vertical uncertainty ``v_unc``, and how far a descent does (:func:`geofence.physics.rooms.vertical_arrest_distance_m`
    over the reaction time ``t_r``, the pilot accelerating up to the climb or descent rate meanwhile)."""
    c_s = vertical_arrest_distance_m(vu, t_r, env.vertical_accel_mps2, env.max_climb_mps) + v_unc
    return c_s, vertical_arrest_distance_m(-vu, t_r, env.vertical_accel_mps2, env.max_descent_mps)


@jitable
def vertical_time_to_breach_s(ceiling_margin_m: float, floor_margin_m: float, vu: float, has_floor: bool) -> float:
    """Seconds until the ceiling (climbing) or the floor (descending, ``has_floor``) is reached at ``vu`` m/s: 0
    once either is breached, ``inf`` when level (within 1e-9 m/s) or descending without a floor."""
    if ceiling_margin_m <= 0.0 or floor_margin_m <= 0.0:
        return 0.0
    if vu > 1e-9:
        return ceiling_margin_m / vu
    if vu < -1e-9 and has_floor:
        return floor_margin_m / -vu
    return math.inf


@jitable
def floor_with_gap_m(floor_act: float, gap_act: float, gap_depth_m: float) -> float:
    """The floor's activation over a gap (m): the larger of the descent's arrest margin ``floor_act`` and the
    activation against the gap's edges ``gap_act``, that no larger than how deep inside the gap the point is."""
    g = gap_depth_m if gap_act > gap_depth_m else gap_act
    return g if g > floor_act else floor_act


@jitable
def _lateral_margin(F: np.ndarray, L: np.ndarray, e: float, n: float) -> float:
    """The lateral margin at (e, n): :func:`geofence.geometry.scan.lateral_margin_scan` on the packed tables."""
    return lateral_margin_scan(
        e,
        n,
        packed_table(F, L, KEEP_IN, 7),
        packed_table(F, L, KEEP_OUTS, 7),
        packed_vector(L, KEEP_OUT_OFFSETS),
        packed_table(F, L, CIRCLES, 3),
    )


@jitable
def far_from_everything(
    F: np.ndarray, L: np.ndarray, V: np.ndarray, e: float, n: float, h: float, ground_speed: float, ve: float,
    vn: float, vu: float, wind_e: float, wind_n: float, allowance: float, t_s: float, hu: float, v_unc: float, g: float,
) -> tuple[bool, float]:  # fmt: skip
    """:meth:`geofence.unit.geofence_unit.GeofenceUnit._far_from_everything` on the tables (its reference): no element, ceiling or
    floor within the largest room the state can need (:func:`geofence.physics.rooms.room_upper_bounds_terms` at the wind
    speed plus ``allowance`` over the time ``t_s``, plus the uncertainties ``hu`` and ``v_unc``), and the lateral margin at (e, n) when it was computed (else NaN)."""
    env = envelope_of_terms(V)
    fixed_wing = env.fixed_wing != 0.0
    w = hypot(wind_e, wind_n) + allowance
    room, vroom = room_upper_bounds_terms(
        fixed_wing, env.max_speed_mps, env.max_bank_rad, env.braking_mps2, env.vertical_accel_mps2,
        env.max_climb_mps, env.max_descent_mps, env.k1, env.k2, ground_speed, hypot(ve - wind_e, vn - wind_n), vu, w,
        t_s, g,
    )  # fmt: skip
    if room == math.inf:
        return False, math.nan
    room += hu
    vroom += v_unc
    if fence_scalar(F, L, CEILING) - h <= vroom:
        return False, math.nan
    lat = _lateral_margin(F, L, e, n)
    if not lat > room:
        return False, lat
    floor = fence_scalar(F, L, FLOOR)
    if fence_scalar(F, L, HAS_FLOOR) == 0.0 or h - floor > vroom:
        return True, lat
    if fixed_wing:  # it circles in a gap while it climbs back: the circle drifts (an upper bound)
        room += climb_back_drift_m(floor + vroom - h, env.max_climb_mps, w)
    return deepest_polygon(e, n, packed_table(F, L, GAP_POLYGONS, 7), packed_vector(L, GAP_OFFSETS))[1] > room, lat


# the positions of a few of _margins' fields (the others by ShiftResult's order, the element id unpacked)
ACTIVATION_FIELD, LATERAL_MARGIN_FIELD, LATERAL_ACTIVATION_FIELD, CLOSING_FIELD = 0, 1, 3, 8
CEILING_MARGIN_FIELD, FLOOR_MARGIN_FIELD, VERTICAL_ACTIVATION_FIELD = 12, 14, 16
NOT_NEEDED = (math.inf, math.inf, 0.0, math.inf, -1, 0.0, 0.0, math.inf, 0.0, math.inf, 0, 0.0, math.inf, 0.0, math.inf, 0.0, math.inf, math.inf)  # fmt: skip


def _monitor_margins(
    F: np.ndarray, L: np.ndarray, V: np.ndarray, e: float, n: float, h: float, ground_speed: float, ve: float,
    vn: float, vu: float, wind_e: float, wind_n: float, allowance: float, far_t_s: float, hu: float, v_unc: float,
    latency_s: float, bank_rad: float, has_target: bool, target_e: float, target_n: float, g: float,
) -> tuple[bool, tuple[float, float, float, float, int, float, float, float, float, float, int, float, float, float, float, float, float, float]]:  # fmt: skip
    """A monitoring step's question in one call: ``(far, fields)``: the unit's skip shortcut
    (:func:`far_from_everything`, with ``far_t_s`` its time), and unless it holds, :func:`_margins`' fields (with
    the lateral margin the shortcut computed)
    (``wind_extra_mps`` is ``allowance``); when far, the fields are placeholders (not computed)."""
    far, lat = far_from_everything(
        F, L, V, e, n, h, ground_speed, ve, vn, vu, wind_e, wind_n, allowance, far_t_s, hu, v_unc, g
    )  # fmt: skip
    if far:
        return True, NOT_NEEDED
    return False, _margins(
        F, L, V, e, n, h, ve, vn, vu, wind_e, wind_n, hu, v_unc, latency_s, bank_rad, allowance, has_target, target_e,
        target_n, g, lat,
    )  # fmt: skip


margins = compiled(_margins)
"""The compiled :func:`_margins` (the Python function itself without numba)."""

indexed_margins = compiled(_indexed_margins)
"""The compiled :func:`_indexed_margins` (the Python function itself without numba)."""

monitor_margins = compiled(_monitor_margins)
"""The compiled :func:`_monitor_margins` (the Python function itself without numba)."""
