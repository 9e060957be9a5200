"""Activation boundaries: how far inside the fence the geofence must act ("shifted fence").

Pure functions on floats. The fence is shifted inward, edge by edge, by the
room the vehicle needs to turn back (fixed-wing) or stop (multirotor) plus an
estimate-uncertainty margin; vertically by the room to arrest a climb or a
descent. The geofence acts when the *activation margin* (distance to an edge
minus the room needed against that edge) reaches zero. This module assembles
the margins; the room formulas themselves (turn, trochoid excursion, reaction
travel, braking, arrest, their upper bounds and the head-on room) live in
:mod:`geofence.rooms`, whose docstring derives them; the per-state terms in
:func:`geofence.margins_kernel.lateral_terms`, shared with the compiled kernels.

Conventions: ENU metres and m/s; angles in rad. For an edge, ``n`` is the unit
normal pointing *towards the breach* (outward across a keep-in edge, into a
keep-out); a velocity or wind component along ``n`` is positive when it
carries the vehicle towards the breach ("closing", "tailwind").

Fixed-wing: the manoeuvre scored
--------------------------------
:func:`activation_margins` uses the maneuver the override flies: keep the
current state for the reaction time (the pilot's current turn goes on:
:func:`~geofence.rooms.reaction_arc_m`), then turn at the bank limit in
direction ``s`` until the air heading is the wind-corrected heading towards
the recovery point (a course reversal, ``Delta = pi``, within 1 m of it), then
fly straight. For each edge it takes the exact maximum of the trochoid
excursion ``x(theta)`` over that turn
(:func:`~geofence.rooms.trochoid_excursion_m`), or the reaction arc's farthest
point when that lies farther (banked away from an edge, the aircraft first
closes on it: :func:`~geofence.rooms.reaction_arc_gap_m`), and chooses the direction ``s``
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
The worst-case pilot (:func:`~geofence.rooms.multirotor_room_m`): until the
override acts (``t_react`` plus the control-step ``latency_s``) the vehicle may
keep accelerating toward the edge at the tilt limit (while below max
airspeed) plus the wind's push, then brakes at the braking deceleration net of
the push, weakened while a climb is being arrested
(:func:`~geofence.rooms.braking_room_m`). Both the pilot's acceleration and
the climb arrest were measured to matter in closed loop (an F450 at full tilt
and full climb overshot by 1.3 m without them, 0 with).

Turbulence and gusts: ``wind_extra_mps`` (k·σ of the turbulence plus a gust
allowance, chosen by the caller) is added to the wind component towards every
edge and to the wind speed, for the whole manoeuvre, on both platform kinds.

Vertical: the arrest distance (:func:`~geofence.rooms.vertical_arrest_distance_m`)
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

from . import jit as _jit
from .fence import AltitudeReference, FenceError
from .interface import Envelope, PlatformKind, VehicleState
from .lateral_kernel import (
    capped_lateral,
    circle_scored,
    edge_scored,
    fixed_wing_edge_terms,
    multirotor_edge_room_m,
    wind_toward_mps,
)
from .local_fence import FEATURE_KEEP_OUT_CIRCLE, LocalFence
from .margins_kernel import (
    EnvelopeTerms,
    envelope_terms,
    envelope_tuple,
    floor_with_gap_m,
    lateral_terms,
    room_bound,
    state_binding,
    vertical_arrests_m,
    vertical_time_to_breach_s,
)
from .margins_kernel import margins as margins_kernel
from .margins_kernel import monitor_margins as monitor_margins_kernel
from .rooms import (
    G_MPS2,
    fixed_wing_edge_room_m,
    gap_circle_turn_rad,
    trochoid_excursion_bound_m,
    vertical_arrest_distance_m,
    worst_case_lateral_shift_m,
)

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
    towards its nearest point where that is an edge's end: :func:`~geofence.lateral_kernel.edge_scored`),
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


def _edge_distances(edges: tuple, e: float, n: float, n_line: int = 0, free: bool = False) -> tuple[list, float]:
    """``([(d, ux, uy, feature, index, edge), ...], min d)``: each edge item's scored distance from (e, n) and
    the direction it is scored along (:func:`~geofence.lateral_kernel.edge_scored`; the first ``n_line`` are a
    convex keep-in's; ``free``: (e, n) is in the free space); ``min d``: the nearest point-segment distance."""
    out = []
    min_d = math.inf
    for k, (ax, ay, dx, dy, il2, nx, ny, feat, idx, j) in enumerate(edges):
        d, db, ux, uy = edge_scored(e - ax, n - ay, dx, dy, il2, nx, ny, k < n_line, free)
        out.append((db, ux, uy, feat, idx, j))
        if d < min_d:
            min_d = d
    return out, min_d


PRUNE_FROM_EDGES = 12
"""From this many threatened edges on, a fixed-wing's binding edge is found by :func:`_binding_edge_pruned`
(bounded excursions, nearest first); below it the plain scan is cheaper. Both give the same answer."""


def _binding_edge_no_turn(near: list) -> tuple[float, tuple | None]:
    """``(activation, (room, feature, index, edge, nx, ny, d, v_n))`` of the edge with the smallest
    ``d - room`` (the first in ``near``'s order on a tie): a multirotor's room is the per-edge ``base``."""
    worst = math.inf
    wk = None
    for d, nx, ny, feat, idx, j, v_n, _w_n, base, _psi0, _gap in near:
        act = d - base
        if act < worst:
            worst, wk = act, (base, feat, idx, j, nx, ny, d, v_n)
    return worst, wk


def _binding_edge_scan(
    near: list, radius: float, inv_omega: float, v_turn: float, s: float, delta: float
) -> tuple[float, tuple | None]:
    """The fixed-wing's :func:`_binding_edge_no_turn`: room = ``base`` + the larger of the trochoid excursion of
    the turn ``s``, ``delta`` and the reaction arc's ``gap`` (:func:`~geofence.rooms.reaction_arc_gap_m`)
    against each edge (the reference form: every edge scored)."""
    worst = math.inf
    wk = None
    for d, nx, ny, feat, idx, j, v_n, w_n, base, psi0, gap in near:
        room = fixed_wing_edge_room_m(base, gap, radius, inv_omega, v_turn, w_n, psi0, s, delta)
        act = d - room
        if act < worst:
            worst, wk = act, (room, feat, idx, j, nx, ny, d, v_n)
    return worst, wk


def _binding_edge_pruned(
    near: list, radius: float, inv_omega: float, v_turn: float, s: float, delta: float
) -> tuple[float, tuple | None]:
    """:func:`_binding_edge_scan`'s answer (the same edge, bit for bit) scoring only the edges that can bind.

    The excursion of the turn is at most ``R·(1 - s·sin psi0) + max(w_n, 0)·delta/omega`` (each term of
    ``x(theta)`` bounded over ``theta in [0, delta]``), so an edge's activation is at least
    ``d - base - that bound``. Edges are scored in order of that lower bound until it exceeds the worst
    activation found; a tie keeps the edge that comes first in ``near`` (as the scan does).
    """
    bounded = []
    for pos, item in enumerate(near):
        d, w_n, base, psi0, gap = item[0], item[7], item[8], item[9], item[10]
        ub = trochoid_excursion_bound_m(radius, inv_omega, w_n, math.sin(psi0), s, delta)
        gap_ub = gap * (1.0 + 1e-9) + 1e-9  # and the gap's: (d - base) - gap can round above d - (base + gap)
        bounded.append((d - base - (ub if ub > gap_ub else gap_ub), pos))
    bounded.sort()
    worst = math.inf
    wk = None
    wpos = -1
    for lb, pos in bounded:
        if lb > worst:
            break
        d, nx, ny, feat, idx, j, v_n, w_n, base, psi0, gap = near[pos]
        room = fixed_wing_edge_room_m(base, gap, radius, inv_omega, v_turn, w_n, psi0, s, delta)
        act = d - room
        if act < worst or (act == worst and pos < wpos):
            worst, wk, wpos = act, (room, feat, idx, j, nx, ny, d, v_n), pos
    return worst, wk


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
    prune_from_edges: int = PRUNE_FROM_EDGES,
    compiled: bool | None = None,
) -> ShiftResult:
    """Required shifts and activation margins for a state (see :class:`ShiftResult`).

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
    ``prune_from_edges`` (the Python branches): from this many threatened edges on, a fixed-wing's binding
    edge is found by the pruned search (the same answer; a huge value scores every edge, the reference).
    ``compiled``: the binding lateral element comes from the compiled search
    (:func:`geofence.lateral_kernel.lateral_binding`); ``False`` runs the plain-Python branches below, the
    reference it equals bit for bit; ``None`` (default): as :data:`geofence.jit.ACTIVE` says (compiled where
    numba is installed).

    Floor gaps: below the floor inside a gap, leaving the gap sideways is a
    breach, so the gap's edges are scored like keep-in edges (lateral room).
    The floor is safe while *either* the descent can be arrested above the
    floor *or* the vehicle stays inside the gap it is over, so the floor
    activation is the larger of the vertical arrest margin (gaps ignored) and
    the lateral activation margin against the gap's edges. A fixed-wing cannot
    hover: the override keeps it circling at the bank limit, the way it turns,
    until it has climbed back above the floor from the deepest point its
    descent reaches, and the circle drifts with the wind: its gap room is that
    whole circling turn (:func:`geofence.rooms.gap_circle_turn_rad`). That turn
    is one for the keep-in and the gap together: the keep-in's best turn, or
    the other one where its circle keeps the gap better and its lateral
    activation allows it (then the result's turn, lateral element and room are
    that turn's, and the override flies it). Scored in the keep-in's turn
    alone, a heading sweeping round flipped the circle out of the gap within a
    step (case history: docs/campaigns.md#breach-classes-found-and-fixed).
    Plain-Python scalar code for the per-step loop.
    """
    if compiled is None:
        compiled = _jit.ACTIVE
    if compiled and fence.grid() is None:  # a fence without an index: the whole answer is one compiled call
        return _margins_compiled(
            fence, e, n, h, ve, vn, vu, envelope, wind_e, wind_n, h_uncertainty_m, v_uncertainty_m, latency_s, bank_rad,
            wind_extra_mps, rollout_target_en, g,
        )  # fmt: skip
    hu = h_uncertainty_m
    fixed_wing = envelope.kind is PlatformKind.FIXED_WING
    env = _envelope_tuple(envelope)
    t_r = env.reaction_s + latency_s
    re, rn = fence.recovery_en if rollout_target_en is None else rollout_target_en
    de, dn = re - e, rn - n
    made: list = []  # the per-state terms (state, turn, brake, turns, bound), made in Python where needed

    def terms() -> tuple:
        """:func:`~geofence.margins_kernel.lateral_terms` of the state (made once)."""
        if not made:
            extra = wind_extra_mps if wind_extra_mps > 0.0 else 0.0
            made.append(
                lateral_terms(
                    env,
                    ve,
                    vn,
                    vu,
                    wind_e,
                    wind_n,
                    math.hypot(ve, vn),
                    math.hypot(ve - wind_e, vn - wind_n),
                    math.hypot(wind_e, wind_n) + extra,
                    extra,
                    hu,
                    latency_s,
                    bank_rad,
                    de,
                    dn,
                    math.hypot(de, dn),
                    g,
                )  # fmt: skip
            )
        return made[0]

    def directions() -> tuple[tuple[float, float], ...]:
        """The turns scored, ``(sign, angle)`` each (none for a multirotor)."""
        turns = terms()[3]
        return ((turns.s1, turns.delta1), (turns.s2, turns.delta2)) if fixed_wing else ((0.0, 0.0),)

    if compiled:  # the bound by one compiled call (the same number)
        V = _envelope_terms(envelope)
        state_args = (V, ve, vn, vu, wind_e, wind_n, hu, latency_s, bank_rad, wind_extra_mps, de, dn, g)
        bound = room_bound(*state_args)
    else:
        bound = terms()[4]

    def terms_of(items: list, min_d: float) -> list:
        """Per edge item ``(d, nx, ny, feat, idx, j)`` that can bind (``d - bound < min_d``), its
        direction-independent part ``(d, nx, ny, feat, idx, j, v_n, w_n, base room, psi0, gap)`` (``gap``: how much
        farther the reaction arc gets than its end, 0 for a multirotor; one call per list: the per-step loop)."""
        state, turn, brake, _turns, _bound = terms()
        out = []
        for d, nx, ny, feat, idx, j in items:
            if d - bound >= min_d:
                continue
            v_n = ve * nx + vn * ny
            w_n = wind_toward_mps(state, nx, ny)
            if fixed_wing:
                base, gap, psi0 = fixed_wing_edge_terms(state, turn, nx, ny, w_n)
            else:
                base = multirotor_edge_room_m(env, state, brake, v_n, w_n)
                psi0 = gap = 0.0
            out.append((d, nx, ny, feat, idx, j, v_n, w_n, base, psi0, gap))
        return out

    def worst_edge(dists: list, min_d: float, turns: tuple | None = None):
        """(activation, turn sign, (room, feature, index, edge, nx, ny, d, v_n), delta) of the binding edge, the
        best of ``turns`` (``(sign, angle)`` each; default :func:`directions`)."""
        near = terms_of(dists, min_d)
        turn = terms()[1]
        radius, inv_omega, v_turn = turn.radius, turn.inv_omega, turn.v_turn
        best = None
        for s, delta in directions() if turns is None else turns:
            if not fixed_wing:
                worst, wk = _binding_edge_no_turn(near)
            elif len(near) < prune_from_edges:
                worst, wk = _binding_edge_scan(near, radius, inv_omega, v_turn, s, delta)
            else:
                worst, wk = _binding_edge_pruned(near, radius, inv_omega, v_turn, s, delta)
            if best is None or worst > best[0]:
                best = (worst, s, wk, delta)
        return best

    # the binding lateral element: one compiled call (lateral_kernel), or the Python reference below (the
    # full scan or the index's walk), which it equals bit for bit
    grid = fence.grid()
    # in the free space an edge facing away is scored towards its nearest point (edge_scored): the binding is
    # found as from the free space, and found again from a breached point once the margin says so (rare; the
    # margin comes from the walk's nearest element, so knowing it first would cost a walk every step)
    if compiled:
        E, meta, all_ids, zeros = fence.element_table()
        if grid is not None and bound < math.inf:  # the index's walk
            walk = True
            ids, lbs, delta_c = grid.candidates(e, n, bound)
        else:  # every element
            walk = False
            ids, lbs, delta_c = all_ids, zeros, 0.0
        free = True
        while True:
            lat_act, s_best, i_bind, room, nx, ny, d_edge, v_n, turn_angle, min_d = state_binding(
                E, ids, lbs, walk, e, n, delta_c, fence.line_scored_edges(), free, *state_args, 0.0, 0.0
            )
            lat_margin = fence.lateral_margin_m(e, n, min_d)  # min_d: the exact nearest element, walked or scanned
            if lat_margin >= 0.0 or not free:
                break
            free = False  # breached: again, the edges facing away scored along their normals
        assert i_bind >= 0  # the nearest element is always a candidate
        feat, idx, j = meta[i_bind]
    else:
        if grid is not None and bound < math.inf:
            dists, min_d = grid.near(e, n, bound, True)
            lat_margin = fence.lateral_margin_m(e, n, min_d)  # the walk just made gives the nearest element
            if lat_margin < 0.0:
                dists, min_d = grid.near(e, n, bound, False)
        else:
            lat_margin = fence.lateral_margin_m(e, n)
            dists, min_d = _edge_distances(fence.danger_edges(), e, n, fence.line_scored_edges(), lat_margin >= 0.0)
            for i, (ce, cn, r) in enumerate(fence.keep_out_circles):
                d, ux, uy = circle_scored(e, n, ce, cn, r)
                dists.append((d, ux, uy, FEATURE_KEEP_OUT_CIRCLE, i, -1))
                if d < min_d:
                    min_d = d
        lat_act, s_best, (room, feat, idx, j, nx, ny, d_edge, v_n), turn_angle = worst_edge(dists, min_d)
    lat_act, ttb = capped_lateral(lat_act, lat_margin, d_edge, v_n)

    # vertical
    c_m = fence.ceiling_m - h
    c_s, f_dive = vertical_arrests_m(env, vu, t_r, v_uncertainty_m)
    if fence.floor_m is None:
        f_m, f_s, f_act = math.inf, 0.0, math.inf
    else:
        f_m = fence.floor_margin_m(e, n, h)
        f_act = h - fence.floor_m - f_dive - v_uncertainty_m
        if fence.floor_gaps:
            gi, gd = fence.best_gap(e, n)
            if gd > 0.0:  # over a gap: staying inside it (laterally) also keeps the floor
                gdists, gmin = _edge_distances(fence.gap_edges(gi), e, n, 0, True)  # (inside the gap: free of it)
                if not fixed_wing:
                    f_act = floor_with_gap_m(f_act, worst_edge(gdists, gmin)[0], gd)
                else:  # it circles, the way it turns, until it has climbed back from its deepest point
                    deepest = h - f_dive - v_uncertainty_m
                    circle = gap_circle_turn_rad(fence.floor_m - deepest, env.max_climb_mps, terms()[1].inv_omega)
                    floor_best = floor_with_gap_m(f_act, worst_edge(gdists, gmin, ((s_best, circle),))[0], gd)
                    # the turn is one for the keep-in and the gap together: where the other turn's circle keeps
                    # the gap better and its lateral activation allows it, it is the one scored (and flown); it
                    # can raise the floor's activation only below the gap's own room
                    if floor_best < gd:
                        (sa1, da1), (sa2, da2) = directions()
                        s_o, delta_o = (sa2, da2) if s_best == sa1 else (sa1, da1)
                        floor_o = floor_with_gap_m(f_act, worst_edge(gdists, gmin, ((s_o, circle),))[0], gd)
                        now = min(lat_act, floor_best, c_m - c_s)
                        if floor_o > floor_best and min(floor_o, c_m - c_s) > now:
                            # the binding lateral element for the other turn alone (the candidates just scored)
                            if compiled:
                                o_act, o_s, o_bind, o_room, o_nx, o_ny, o_d, o_vn, o_angle, _ = state_binding(
                                    E, ids, lbs, walk, e, n, delta_c, fence.line_scored_edges(), free, *state_args,
                                    s_o, delta_o,
                                )  # fmt: skip
                                o_feat, o_idx, o_j = meta[o_bind]
                            else:
                                o_act, o_s, o_terms, o_angle = worst_edge(dists, min_d, ((s_o, delta_o),))
                                o_room, o_feat, o_idx, o_j, o_nx, o_ny, o_d, o_vn = o_terms
                            o_lat, o_ttb = capped_lateral(o_act, lat_margin, o_d, o_vn)
                            if min(o_lat, floor_o, c_m - c_s) > now:
                                lat_act, ttb, s_best, room, feat, idx, j = o_lat, o_ttb, o_s, o_room, o_feat, o_idx, o_j
                                nx, ny, d_edge, v_n, turn_angle = o_nx, o_ny, o_d, o_vn, o_angle
                                floor_best = floor_o
                    f_act = floor_best
        f_s = f_m - f_act
    v_act = min(c_m - c_s, f_act)
    vttb = vertical_time_to_breach_s(c_m, f_m, vu, fence.floor_m is not None)
    # positional (a keyword call costs a microsecond per step); the fields in ShiftResult's order
    return ShiftResult(
        v_act if v_act < lat_act else lat_act,  # activation_margin_m: min(lat_act, v_act), exactly
        lat_margin,  # lateral_margin_m
        room,  # lateral_shift_m
        lat_act,  # lateral_activation_m
        feat,  # feature
        idx,  # feature_index
        j,  # edge
        nx,  # normal_e
        ny,  # normal_n
        d_edge,  # edge_distance_m
        v_n,  # closing_speed_mps
        ttb,  # time_to_breach_s
        int(s_best),  # turn_sign
        turn_angle,  # turn_angle_rad
        c_m,  # ceiling_margin_m
        c_s,  # ceiling_shift_m
        f_m,  # floor_margin_m
        f_s,  # floor_shift_m
        v_act,  # vertical_activation_m
        vttb,  # vertical_time_to_breach_s
    )


_ENVELOPE_TERMS: dict[int, tuple[Envelope, np.ndarray, EnvelopeTerms]] = {}
"""The margins' envelope terms (the compiled kernels' array and the named tuple) by envelope object (its identity
checked: the entry holds it); cleared from :data:`_ENVELOPE_TERMS_KEPT` entries on (a unit makes a new envelope
each time the air density it scales to moves, and a batch process flies many units)."""
_ENVELOPE_TERMS_KEPT = 64


def _margins_compiled(
    fence: LocalFence, e: float, n: float, h: float, ve: float, vn: float, vu: float, envelope: Envelope,
    wind_e: float, wind_n: float, hu: float, v_unc: float, latency_s: float, bank_rad: float, wind_extra_mps: float,
    rollout_target_en: tuple[float, float] | None, g: float,
) -> ShiftResult:  # fmt: skip
    """:func:`activation_margins` of a fence without an index by :func:`geofence.margins_kernel.margins`."""
    return CompiledMargins(fence, _envelope_terms(envelope)).margins(
        e, n, h, ve, vn, vu, wind_e, wind_n, hu, v_unc, latency_s, bank_rad, wind_extra_mps, rollout_target_en, g
    )


def _cached_terms(envelope: Envelope) -> tuple[Envelope, np.ndarray, EnvelopeTerms]:
    """``(envelope, envelope_terms, envelope_tuple)`` of ``envelope`` (:mod:`geofence.margins_kernel`), cached by
    identity."""
    cached = _ENVELOPE_TERMS.get(id(envelope))
    if cached is None or cached[0] is not envelope:
        if len(_ENVELOPE_TERMS) >= _ENVELOPE_TERMS_KEPT:
            _ENVELOPE_TERMS.clear()
        cached = _ENVELOPE_TERMS[id(envelope)] = (envelope, envelope_terms(envelope), envelope_tuple(envelope))
    return cached


def _envelope_terms(envelope: Envelope) -> np.ndarray:
    """:func:`geofence.margins_kernel.envelope_terms` of ``envelope``, cached by identity."""
    return _cached_terms(envelope)[1]


def _envelope_tuple(envelope: Envelope) -> EnvelopeTerms:
    """:func:`geofence.margins_kernel.envelope_tuple` of ``envelope``, cached by identity."""
    return _cached_terms(envelope)[2]


class CompiledMargins:
    """The compiled margins of one fence without an index and one envelope, their tables bound once.

    :meth:`margins` is :func:`activation_margins` and :meth:`monitor` is :func:`monitor_margins` (the same
    numbers: :func:`geofence.margins_kernel.margins` and :func:`~geofence.margins_kernel.monitor_margins`), with
    positional arguments and the fence's tables and the envelope's terms looked up at construction, not per call:
    the unit asks one of them every step (:class:`geofence.unit.GeofenceUnit` keeps one per envelope).
    ``envelope``: an :class:`Envelope`, or its :func:`~geofence.margins_kernel.envelope_terms` already made.
    """

    __slots__ = ("fence", "_tables", "_terms", "_meta", "_margins_kernel", "_monitor_kernel")

    def __init__(self, fence: LocalFence, envelope: Envelope | np.ndarray):
        self.fence = fence
        self._tables = fence.margin_tables()
        self._terms = envelope if isinstance(envelope, np.ndarray) else _envelope_terms(envelope)
        self._meta = fence.element_table()[1]
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
        kernel = self._margins_kernel
        r = kernel(
            F, L, self._terms, e, n, h, ve, vn, vu, wind_e, wind_n, hu, v_unc, latency_s, bank_rad, wind_extra_mps,
            has, te, tn, g, math.nan,
        )  # fmt: skip
        if kernel is margins_kernel:
            self._margins_kernel = _jit.entry_point(kernel)
        return self._result(e, n, r)

    def monitor(
        self, e: float, n: float, h: float, ve: float, vn: float, vu: float, ground_speed_mps: float, wind_e: float,
        wind_n: float, hu: float, v_unc: float, latency_s: float, skip_time_s: float, bank_rad: float,
        wind_extra_mps: float, rollout_target_en: tuple[float, float] | None, g: float = G_MPS2,
    ) -> ShiftResult | None:  # fmt: skip
        """:func:`monitor_margins`: ``None`` when the unit's skip shortcut holds, else :meth:`margins`."""
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
    """A monitoring unit's step in one compiled call (:func:`geofence.margins_kernel.monitor_margins`), for a
    fence without an index while :data:`geofence.jit.ACTIVE`: ``None`` when the unit's skip shortcut holds (no
    element, ceiling or floor within the largest room the state can need over ``skip_time_s``, see
    :meth:`geofence.unit.GeofenceUnit._far_from_everything`, the reference), else :func:`activation_margins`
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
