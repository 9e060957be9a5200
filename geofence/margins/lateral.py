"""The binding lateral element of one state, compiled: the per-step hot path of the activation margin.

One question: given the fence's lateral elements (keep-in and keep-out edges,
keep-out circles) as one float table, a candidate list and the state's room
terms (named tuples: :class:`LateralState`, :class:`FixedWingTurn`,
:class:`MultirotorBrake`, :class:`Turns`, the envelope's
:class:`EnvelopeTerms`), which element has the
smallest activation ``d - room``, and what is the nearest element's distance?
The room against one element is :func:`fixed_wing_edge_terms` with
:func:`geofence.physics.rooms.fixed_wing_edge_room_m`, or :func:`multirotor_edge_room_m`.
:func:`geofence.margins.kernel.margins` (and so
:func:`geofence.margins.boundary_shift.activation_margins`) asks it every step; the
fixed-wing's search scores exactly only the elements a cheap lower bound cannot
rule out (:func:`_fixed_wing_binding`), and ``tests/test_binding_edge.py`` holds
it to the exhaustive minimum.

Compiled or interpreted, the same source: the room formulas are compiled from
their one home in :mod:`geofence.physics.rooms` and :mod:`geofence.physics.dynamics`
(:func:`geofence.jit.jitable`); the compiled run agrees with the interpreted one
to rounding (``tests/test_lateral_kernel.py``: 1e-9 relative).

Element table ``E`` (one row per element, in :meth:`LocalFence.danger_edges`
order then the circles): ``(ax, ay, dx, dy, 1/len², nx, ny)`` for an edge,
``(east, north, radius, 0, -1, 0, 0)`` for a circle (``1/len² < 0`` marks it).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from geofence.geometry.elements import walk_candidates
from geofence.jit import compiled, jitable
from geofence.physics.dynamics import wind_push_mps2
from geofence.physics.rooms import (
    fixed_wing_edge_room_m,
    multirotor_room_m,
    reaction_arc_bound_m,
    reaction_arc_sines_m,
    reaction_arc_terms_m,
    trochoid_excursion_bound_m,
)


class EnvelopeTerms(NamedTuple):
    """The envelope's numbers the margins read (SI units; ``fixed_wing`` 1.0 or 0.0; ``k1, k2`` its drag law's
    :func:`~geofence.physics.dynamics.drag_coefficients`). The kernels take them as a float array in this order
    (:func:`geofence.margins.kernel.envelope_terms`: an array argument costs less to pass) and read them by name
    (:func:`geofence.margins.kernel.envelope_of_terms`). Defined here, below the kernel that packs them, because
    every lateral room reads them."""

    fixed_wing: float
    reaction_s: float
    max_bank_rad: float
    cruise_mps: float
    min_speed_mps: float
    max_speed_mps: float
    braking_mps2: float
    vertical_accel_mps2: float
    max_climb_mps: float
    k1: float
    k2: float
    max_descent_mps: float


__all__ = [
    "EnvelopeTerms",
    "FixedWingTurn",
    "LateralState",
    "MultirotorBrake",
    "Turns",
    "capped_lateral",
    "lateral_binding",
]

FIXED_WING_SCRATCH_ROWS = 8
"""The scratch rows :func:`_fixed_wing_binding` takes (its per-element terms)."""


class LateralState(NamedTuple):
    """The state's terms every element is scored with: ground velocity and wind (m/s, ENU), the wind
    allowance added towards every element ``extra`` (m/s) and the horizontal uncertainty ``hu`` (m)."""

    ve: float
    vn: float
    wind_e: float
    wind_n: float
    extra: float
    hu: float


class FixedWingTurn(NamedTuple):
    """A fixed-wing's manoeuvre terms (:func:`geofence.physics.rooms.fixed_wing_reaction_terms`): the turn speed (m/s),
    the air heading at the reaction's start (rad, ENU), the reaction's rotation (rad) and rate (rad/s, + =
    clockwise), the reaction time (s), ``sin``/``cos`` of the heading where the turn starts, and the turn
    constants ``R`` (m), ``1/omega`` (s). Zeros for a multirotor."""

    v_turn: float
    psi_react0: float
    rot: float
    omega_now: float
    t_fw: float
    sa: float
    ca: float
    radius: float
    inv_omega: float


class MultirotorBrake(NamedTuple):
    """A multirotor's stop terms: the wind speed with its allowance (m/s), the ground speed (m/s), the pilot's
    tilt acceleration (m/s², 0 at max airspeed), the reaction time (s) and the climb arrest
    (:func:`geofence.physics.rooms.climb_arrest_phase`: s, fraction). Zeros for a fixed-wing."""

    wspeed: float
    speed: float
    a_pilot: float
    t_r: float
    arrest_t: float
    arrest_loss: float


class Turns(NamedTuple):
    """The two turns a fixed-wing is scored with: direction (+1 left, -1 right) and angle (rad) each."""

    s1: float
    delta1: float
    s2: float
    delta2: float


@jitable
def wind_toward_mps(state: LateralState, nx: float, ny: float) -> float:
    """The wind towards an element along the unit direction ``(nx, ny)`` it is scored along, with the
    allowance (m/s)."""
    return state.wind_e * nx + state.wind_n * ny + state.extra


@jitable
def fixed_wing_edge_terms(
    state: LateralState, turn: FixedWingTurn, nx: float, ny: float, w_n: float
) -> tuple[float, float, float]:
    """``(base, gap, psi0)`` of one element for a fixed-wing, whatever the turn: the reaction travel plus the
    uncertainty (m), how much farther the reaction arc gets (m; :func:`geofence.physics.rooms.reaction_arc_terms_m`),
    and the air heading where the turn starts relative to the direction ``(nx, ny)`` (rad)."""
    end, gap = reaction_arc_terms_m(turn.v_turn, turn.psi_react0, turn.rot, turn.omega_now, turn.t_fw, nx, ny, w_n)
    sa = turn.sa
    ca = turn.ca
    return end + state.hu, gap, math.atan2(nx * sa - ny * ca, nx * ca + ny * sa)


@jitable
def multirotor_edge_room_m(env: EnvelopeTerms, state: LateralState, brake: MultirotorBrake, v_n: float, w_n: float) -> float:
    """A multirotor's room against one element, plus the uncertainty, m: the worst-case pilot accelerates
    towards it at the tilt limit (while below max airspeed) helped by the wind's push until the override acts,
    then it brakes against that push (:func:`geofence.physics.rooms.multirotor_room_m`); ``v_n``, ``w_n``: the ground
    velocity and the wind towards it (m/s)."""
    push = wind_push_mps2(env.k1, env.k2, brake.wspeed, w_n)
    a_p = brake.a_pilot + push
    arrest = (brake.arrest_t, brake.arrest_loss)
    return multirotor_room_m(v_n, brake.speed, brake.t_r, a_p, env.braking_mps2 - push, arrest) + state.hu


@jitable
def _multirotor_binding(
    f_d: np.ndarray,
    f_nx: np.ndarray,
    f_ny: np.ndarray,
    f_id: np.ndarray,
    keep: np.ndarray,
    env: EnvelopeTerms,
    state: LateralState,
    brake: MultirotorBrake,
) -> tuple[float, float, int, float, float, float]:
    """``(activation, 0, position in keep, room, 0, v_n)``: the smallest ``d - base`` over ``keep`` (the lowest
    element id ``f_id`` on a tie, the first in element order)."""
    ve = state.ve
    vn = state.vn
    worst = math.inf
    wq = -1
    wroom = 0.0
    wvn = 0.0
    for q in range(keep.shape[0]):
        k = keep[q]
        nx = f_nx[k]
        ny = f_ny[k]
        v_n = ve * nx + vn * ny
        base = multirotor_edge_room_m(env, state, brake, v_n, wind_toward_mps(state, nx, ny))
        act = f_d[k] - base
        if act < worst or (wq >= 0 and act == worst and f_id[k] < f_id[keep[wq]]):
            worst = act
            wq = q
            wroom = base
            wvn = v_n
    return worst, 0.0, wq, wroom, 0.0, wvn


# the rows of _fixed_wing_binding's scratch: the exact terms made (non-zero), base, gap (how much farther the
# reaction arc gets than its end), psi0, the wind towards the element, d - (upper bound of base), sin psi0 (to
# round-off) and a turn's lower bound of the activation (indexed, not viewed: a view costs a reference count)
DONE, BASE, GAP, PSI, WIND, LB_BASE, SIN_PSI, LB_TURN = range(FIXED_WING_SCRATCH_ROWS)


@jitable
def _reaction_bounds(
    f_d: np.ndarray, f_nx: np.ndarray, f_ny: np.ndarray, keep: np.ndarray, state: LateralState, turn: FixedWingTurn,
    W: np.ndarray,
) -> None:  # fmt: skip
    """Fill each kept element's rows ``WIND``, ``LB_BASE`` and ``SIN_PSI`` of the scratch ``W`` for
    :func:`_fixed_wing_binding`, without transcendental functions per element: for a unit normal ``n`` at angle
    ``theta``, ``sin(psi - theta) = sin psi·nx - cos psi·ny`` gives the reaction arc
    (:func:`geofence.physics.rooms.reaction_arc_sines_m`) and ``sin psi0 = nx·sin a - ny·cos a``. Their round-off (about
    1e-15 of the arc's scale) is covered by a slack of 1e-9 of it; a normal that is not unit (a zero-length edge)
    gets no bound."""
    v_turn, psi_react0, rot, omega_now, t_fw, sa, ca, _radius, _inv_omega = turn
    hu = state.hu
    straight = abs(rot) < 1e-6
    sp = math.sin(psi_react0)
    cp = math.cos(psi_react0)
    sq = math.sin(psi_react0 - rot)
    cq = math.cos(psi_react0 - rot)
    arc = v_turn * t_fw if straight else v_turn / omega_now
    for q in range(keep.shape[0]):
        k = keep[q]
        nx = f_nx[k]
        ny = f_ny[k]
        w_n = wind_toward_mps(state, nx, ny)
        W[WIND, q] = w_n
        W[DONE, q] = 0.0
        if abs(nx * nx + ny * ny - 1.0) > 1e-9:  # no bound: scored exactly
            W[LB_BASE, q] = -math.inf
            W[SIN_PSI, q] = 0.0
            continue
        ub = reaction_arc_sines_m(arc, sp, cp, sq, cq, straight, t_fw, nx, ny, w_n)
        W[LB_BASE, q] = f_d[k] - ub - hu - 1e-9 * (1.0 + abs(arc) + abs(w_n) * t_fw + abs(hu))
        W[SIN_PSI, q] = nx * sa - ny * ca


@jitable
def _fixed_wing_binding(
    f_d: np.ndarray,
    f_nx: np.ndarray,
    f_ny: np.ndarray,
    f_id: np.ndarray,
    keep: np.ndarray,
    state: LateralState,
    turn: FixedWingTurn,
    turns: Turns,
    W: np.ndarray,
) -> tuple[float, float, int, float, float, float]:
    """``(activation, turn sign, position in keep, room, turn angle, v_n)`` of a fixed-wing's binding element
    over ``keep``: per turn ``(s1, delta1)``, ``(s2, delta2)`` the smallest ``d - base - excursion`` (the lowest
    element id on a tie, the first in element order), the turn with the larger one, the first winning a tie.

    Each element's exact terms (:func:`fixed_wing_edge_terms`: ``reaction_arc_m`` and its gap in one call, the
    heading ``psi0`` by ``atan2``) are computed only for the elements whose activation can be the smallest: a
    cheap lower bound comes first (:func:`_reaction_bounds`, less the turn's excursion bound
    :func:`geofence.physics.rooms.trochoid_excursion_bound_m` or the reaction arc's); after the element with the smallest
    bound, every element whose bound is at most the smallest activation found so far is scored exactly. A bound
    is at most its activation, so every element that can tie the smallest is scored exactly. ``W``: scratch, at
    least :data:`FIXED_WING_SCRATCH_ROWS` rows of ``keep``'s length (its rows: :data:`DONE` ...).
    """
    nk = keep.shape[0]
    if nk == 0:
        return math.inf, 0.0, -1, 0.0, 0.0, 0.0
    _reaction_bounds(f_d, f_nx, f_ny, keep, state, turn, W)
    b_act = math.inf
    b_s = 0.0
    b_q = -1
    b_room = 0.0
    b_delta = 0.0
    for di in range(2):
        s = turns.s1 if di == 0 else turns.s2
        delta = turns.delta1 if di == 0 else turns.delta2
        seed = -1
        for q in range(nk):
            w_n = W[WIND, q]
            ub = trochoid_excursion_bound_m(turn.radius, turn.inv_omega, w_n, W[SIN_PSI, q], s, delta)
            gap_ub = reaction_arc_bound_m(turn.v_turn, w_n, turn.t_fw)
            W[LB_TURN, q] = W[LB_BASE, q] - (ub if ub > gap_ub else gap_ub)
            if seed < 0 or W[LB_TURN, q] < W[LB_TURN, seed]:
                seed = q
        worst = math.inf
        wq = -1
        wroom = 0.0
        for r in range(-1, nk):
            q = seed if r < 0 else r
            if r >= 0 and (q == seed or W[LB_TURN, q] > worst):
                continue
            k = keep[q]
            if W[DONE, q] == 0.0:
                W[BASE, q], W[GAP, q], W[PSI, q] = fixed_wing_edge_terms(state, turn, f_nx[k], f_ny[k], W[WIND, q])
                W[DONE, q] = 1.0
            room = fixed_wing_edge_room_m(
                W[BASE, q], W[GAP, q], turn.radius, turn.inv_omega, turn.v_turn, W[WIND, q], W[PSI, q], s, delta
            )
            act = f_d[k] - room
            if act < worst or (wq >= 0 and act == worst and f_id[k] < f_id[keep[wq]]):
                worst = act
                wq = q
                wroom = room
        if b_q < 0 or worst > b_act:
            b_act = worst
            b_s = s
            b_q = wq
            b_room = wroom
            b_delta = delta
    k = keep[b_q]
    return b_act, b_s, b_q, b_room, b_delta, state.ve * f_nx[k] + state.vn * f_ny[k]


@jitable
def capped_lateral(lat_act: float, lat_margin: float, d_edge: float, v_n: float) -> tuple[float, float]:
    """``(lateral activation, time to breach)`` of a binding element: its activation no larger than the
    lateral margin, and 0 s once breached, else its distance over the closing speed (inf when not closing)."""
    if lat_margin < lat_act:
        lat_act = lat_margin
    if lat_margin <= 0.0:
        return lat_act, 0.0
    return lat_act, (d_edge / v_n if v_n > 1e-9 else math.inf)


def _lateral_binding(
    E: np.ndarray,
    ids: np.ndarray,
    lbs: np.ndarray,
    walk: bool,
    e: float,
    n: float,
    reach: float,
    delta_c: float,
    n_line: int,
    free: bool,
    fixed_wing: bool,
    env: EnvelopeTerms,
    state: LateralState,
    turn: FixedWingTurn,
    brake: MultirotorBrake,
    turns: Turns,
) -> tuple[float, float, int, float, float, float, float, float, float, float]:
    """``(activation, turn sign, element id, room, nx, ny, d, v_n, turn angle, d_min)`` of the binding element.

    Candidates: the rows ``ids`` of ``E``. ``walk``: they are sorted by ``lbs``, lower bounds of their
    distance plus ``delta_c`` (an index cell's list, :meth:`FenceGrid.candidates`; the walk's stop rule:
    :func:`walk_candidates`); else every
    candidate is scored (the full scan; ``ids`` in element order). Kept: ``d - reach < d_min``. Scored by
    :func:`_fixed_wing_binding` (``turn``, scored for each of ``turns``) or :func:`_multirotor_binding`
    (``brake``); a tie goes to the lowest element id (the first in element order). Element id -1:
    no candidate. ``env``: the envelope's terms; ``state``, ``turn``, ``brake``: the per-state terms
    (:func:`geofence.margins.kernel.state_terms`; the other platform kind's are zeros). ``n_line``: the first ``n_line`` elements are a convex keep-in's edges; ``free``: the point
    is in the free space (:func:`edge_scored`). Each edge is
    scored by :func:`edge_scored` (``d``, ``nx, ny``: its scored distance and direction; ``d_min`` stays the
    nearest point-segment distance).

    Its per-element arrays are rows of two scratch arrays allocated once per call (an allocation costs about as
    much as scoring an element).
    """
    m = ids.shape[0]
    I = np.empty((2, m), np.int64)  # noqa: E741
    W = np.empty((3 + FIXED_WING_SCRATCH_ROWS, m))
    f_id = I[0]
    f_d = W[0]
    f_nx = W[1]
    f_ny = W[2]
    cnt, min_d = walk_candidates(E, ids, lbs, walk, e, n, reach, delta_c, n_line, free, f_id, f_d, f_nx, f_ny)
    # the elements that can bind, in element order
    keep = I[1]
    nk = 0
    for k in range(cnt):
        if f_d[k] - reach < min_d:
            keep[nk] = k
            nk += 1
    keep = keep[:nk]
    if fixed_wing:
        b_act, b_s, b_q, b_room, b_delta, t_vn = _fixed_wing_binding(f_d, f_nx, f_ny, f_id, keep, state, turn, turns, W[3:])
    else:
        b_act, b_s, b_q, b_room, b_delta, t_vn = _multirotor_binding(f_d, f_nx, f_ny, f_id, keep, env, state, brake)
    if b_q < 0:
        return math.inf, 0.0, -1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, min_d
    k = keep[b_q]
    return b_act, b_s, f_id[k], b_room, f_nx[k], f_ny[k], f_d[k], t_vn, b_delta, min_d


lateral_binding = compiled(_lateral_binding)
"""The compiled :func:`_lateral_binding` (the Python function itself without numba)."""
