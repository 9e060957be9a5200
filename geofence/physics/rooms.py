"""Per-edge rooms: how far a vehicle travels towards a boundary before it has turned back or stopped.

This module is the one home of the geofence's turn/brake physics, and every
room formula is written here once: the coordinated-turn radius and rate, the
fixed-wing turn excursion (the trochoid) and its reaction travel, the
multirotor's reaction travel under the worst-case pilot and its braking
distance (weakened while a climb is arrested), the vertical arrest distance,
the head-on room that the analysis figures draw and the feasibility check
maximises, the room against one edge (:func:`fixed_wing_edge_room_m`), and the
upper bounds of the room that the binding searches' pruning, the margin's edge
culling and the unit's skip shortcut rely on. The compiled kernels call these
same functions (:func:`geofence.jit.jitable`): to change a formula, edit it here. Where the per-step loop needs a fast form
(precomputed turn constants, one call per edge), it stands next to its
reference form and ``tests/test_rooms.py`` checks that the two agree to 1e-9
relative. :mod:`geofence.margins.boundary_shift` assembles these rooms into activation
margins; gravity and the drag law come from :mod:`geofence.physics.dynamics`. Pure
functions on floats (plus :class:`~geofence.interface.Envelope` for the
envelope-level rooms).

Conventions: ENU metres and m/s; angles in rad. For an edge, ``n`` is the unit
normal pointing *towards the breach* (outward across a keep-in edge, into a
keep-out); a velocity or wind component along ``n`` is positive when it
carries the vehicle towards the breach ("closing", "tailwind").
``g = G_MPS2 = 9.80665 m/s²``.

Fixed-wing: coordinated turn and the trochoid
---------------------------------------------
Coordinated turn at airspeed ``V`` and bank ``phi``: radius
``R = V²/(g·tan phi)``, rate ``omega = g·tan phi / V``, course reversal in
``t = pi/omega``. Let ``psi`` be the air-relative heading measured
counter-clockwise from ``n`` (``psi0 = 0``: flying straight at the edge) and
``w = W·n`` the wind component towards the edge. Turning in direction ``s``
(+1 left/counter-clockwise, -1 right) by angle ``theta = omega·t``, the
ground track is the trochoid

    p(t) = s·R·(sin(psi0 + s·theta) - sin psi0, -(cos(psi0 + s·theta) - cos psi0))  (normal, tangent)
           + W·t,

so the excursion along the normal is

    x(theta) = s·R·[sin(psi0 + s·theta) - sin psi0] + w·theta/omega.

``dx/dtheta = (V·cos psi + w)/omega`` vanishes at ``cos psi = -w/V``; the
vehicle stops closing on the edge at ``psi* = arccos(-w/V)`` (in [0, pi]).
Turning the better way (away from the normal, ``a = |psi0| <= psi*``) the room
needed **along the normal** is

    x_max = R·(sin psi* - sin a) + w·(psi* - a)/omega.                      (1)

Known cases of (1): a head-on calm-air approach (``a = 0, w = 0``) needs
``x_max = R`` -- the track's extreme point is one radius ahead of the turn
entry, while the *lateral* displacement after the 180 deg reversal is ``2R``
(that is along the edge, not towards it). A parallel calm-air approach
(``a = pi/2``) needs 0. Head-on with wind ``u = w/V`` gives
``R·(sqrt(1-u²) + u·arccos(-u))``, whose derivative in ``u`` is
``arccos(-u) > 0``: the room grows monotonically with tailwind, from 0 at a
headwind equal to the airspeed to ``pi·R`` as the tailwind approaches the
airspeed; a tailwind ``w >= V`` can never be turned against (infinite room).
For a turn of exactly ``Delta`` (the margin's roll-out at the recovery
heading) the maximum of ``x(theta)`` over ``[0, Delta]`` is taken at the end
points and the interior maxima ``psi = s·psi* (mod 2 pi)``
(:func:`trochoid_excursion_m`). Before the turn, the reaction travel is the
displacement along ``n`` of the pilot's current turn (straight when level)
plus the wind drift (:func:`reaction_arc_m`).

Multirotor: reaction under the worst-case pilot, then braking
--------------------------------------------------------------
Stopping straight along the velocity: ``d = v·t_react + v²/(2·a_eff)``; its
projection on an edge normal is ``v_n·t_react + v_n·v/(2·a_eff)`` (``v_n`` =
ground velocity along ``n``; head-on this is the closed form exactly;
:func:`multicopter_stopping_distance_m`). The margin adds the worst-case
pilot (:func:`multirotor_room_m`): until the override acts (time ``t``) the
vehicle may keep accelerating toward the edge at the tilt limit
``g·tan(tilt_max)`` plus the wind's push, ``a_p``, so
``d = v_n·t + a_p·t²/2 + braking`` from ``v_n1 = v_n + a_p·t``,
``v1 = v + a_p·t``; and while a climb is being arrested (``v_up/a_z``
seconds) the collective cut lowers the braking deceleration to
``a_eff·(1 - a_z/g)`` (:func:`braking_room_m`). Wind: the platform's drag law
(:mod:`geofence.physics.dynamics`) gives the push ``a_w`` of the wind at zero ground
speed, taken as pushing towards the edge throughout: ``a_eff = a_brake - a_w``
(conservative); ``a_eff <= 0`` (cannot hold against the wind) gives infinite
room.

Vertical
--------
Arrest distance for a climb towards the ceiling (``v_z = v_up``) and a
descent towards the floor (``v_z = -v_up``): through the reaction time the
pilot keeps accelerating that way at ``a_z`` up to the platform's climb or
descent rate, then the override arrests it at ``a_z``; ``d = v_z·t_react +
v_z²/(2·a_z)`` once at that rate (:func:`vertical_arrest_distance_m`).
"""

from __future__ import annotations

import math

from geofence.interface import Envelope, PlatformKind
from geofence.jit import jitable
from geofence.physics.control_laws import wrap_pi
from geofence.physics.dynamics import G_MPS2, drag_coefficients, wind_push_mps2

__all__ = [
    "G_MPS2",
    "TWO_PI",
    "braking_room_m",
    "climb_arrest_phase",
    "course_reversal_time_s",
    "envelope_turn_radius_m",
    "fixed_wing_room_bound_m",
    "gap_circle_turn_rad",
    "fixed_wing_room_from_velocity_m",
    "fixed_wing_edge_room_m",
    "fixed_wing_reaction_terms",
    "fixed_wing_room_m",
    "head_on_room_m",
    "multicopter_stopping_distance_m",
    "multirotor_room_bound_m",
    "multirotor_room_m",
    "reaction_arc_bound_m",
    "reaction_arc_gap_m",
    "reaction_arc_m",
    "reaction_arc_sines_m",
    "reaction_arc_terms_m",
    "room_upper_bounds_fast_m",
    "room_upper_bounds_m",
    "room_upper_bounds_terms",
    "rollout_turns",
    "tilt_accel_mps2",
    "trochoid_excursion_m",
    "turn_constants",
    "trochoid_excursion_bound_m",
    "turn_excursion_m",
    "turn_radius_m",
    "turn_rate_radps",
    "vertical_arrest_distance_m",
    "worst_case_lateral_shift_m",
]

TWO_PI = 2.0 * math.pi


# --------------------------------------------------------------------------- fixed-wing: the turn
def turn_radius_m(airspeed_mps: float, bank_rad: float, g: float = G_MPS2) -> float:
    """Coordinated-turn radius ``R = V²/(g·tan phi)`` in m (``V`` m/s, ``phi`` rad)."""
    return airspeed_mps * airspeed_mps / (g * math.tan(bank_rad))


@jitable
def turn_rate_radps(airspeed_mps: float, bank_rad: float, g: float = G_MPS2) -> float:
    """Coordinated-turn rate ``omega = g·tan phi / V`` in rad/s (+ in the bank's direction)."""
    return g * math.tan(bank_rad) / airspeed_mps


MIN_BANK_RAD = 0.05
"""Smallest bank :func:`envelope_turn_radius_m` uses (a profile with no bank limit still has a finite turn)."""


def envelope_turn_radius_m(env: Envelope, speed_mps: float | None = None, g: float = G_MPS2) -> float:
    """The platform's turn radius at its bank limit (at least ``MIN_BANK_RAD``), ``V²/(g·tan phi)`` in m.

    ``speed_mps``: the airspeed (m/s), default cruise. Used for route
    clearances, the landing spiral and the pre-flight check's turns.
    """
    v = env.cruise_speed_mps if speed_mps is None else speed_mps
    return turn_radius_m(v, max(env.max_bank_rad, MIN_BANK_RAD), g)


def course_reversal_time_s(airspeed_mps: float, bank_rad: float, g: float = G_MPS2) -> float:
    """Time for a 180 deg course reversal, ``pi/omega``, in s."""
    return math.pi / turn_rate_radps(airspeed_mps, bank_rad, g)


@jitable
def turn_constants(airspeed_mps: float, bank_rad: float, g: float = G_MPS2) -> tuple[float, float]:
    """Fast form of ``(turn_radius_m, 1/turn_rate_radps)``: ``(R = V²/(g·tan phi) m, 1/omega = V/(g·tan phi) s)``.

    One tangent for both (the per-step loop needs them together).
    """
    tanb = g * math.tan(bank_rad)
    return airspeed_mps * airspeed_mps / tanb, airspeed_mps / tanb


@jitable
def trochoid_excursion_m(
    radius: float, inv_omega: float, v: float, w: float, psi0: float, s: float, delta: float | None
) -> float:
    """Largest excursion along the normal, ``max x(theta)`` over ``theta in [0, delta]``, of the trochoid, m (>= 0).

    ``x(theta) = s·R·[sin(psi0 + s·theta) - sin psi0] + w·theta/omega`` (module
    docstring) with ``R`` = ``radius`` (m), ``1/omega`` = ``inv_omega`` (s),
    airspeed ``v`` and wind towards the edge ``w`` (m/s), start heading
    ``psi0`` from the normal (rad, in ``[-pi, pi)``), turn direction ``s``
    (+1.0 left, -1.0 right). ``delta=None``: turn until no longer closing (the
    trochoid apex, closed form (1)); 0 if not closing at the start, ``inf`` if
    ``w >= v``. This is the per-edge fast form (turn constants precomputed) of
    :func:`turn_excursion_m`.
    """
    if delta is None:
        if v * math.cos(psi0) + w <= 0.0:
            return 0.0
        if w >= v:
            return math.inf
        ps = math.acos(-w / v)
        theta = (ps - s * psi0) % TWO_PI
        return max(0.0, s * radius * (math.sin(psi0 + s * theta) - math.sin(psi0)) + w * theta * inv_omega)
    best = s * radius * (math.sin(psi0 + s * delta) - math.sin(psi0)) + w * delta * inv_omega
    if -v < w < v:
        ps = math.acos(-w / v)
        theta = (ps - s * psi0) % TWO_PI
        while theta <= delta:
            x = s * radius * (math.sin(psi0 + s * theta) - math.sin(psi0)) + w * theta * inv_omega
            if x > best:
                best = x
            theta += TWO_PI
    return best if best > 0.0 else 0.0


@jitable
def trochoid_excursion_bound_m(radius: float, inv_omega: float, w: float, sin_psi0: float, s: float, delta: float) -> float:
    """Upper bound of :func:`trochoid_excursion_m` over a turn of ``delta`` (rad) in direction ``s``, m.

    ``R·(1 - s·sin psi0) + max(w, 0)·delta/omega`` (each term of ``x(theta)`` bounded over ``theta in [0,
    delta]``) plus a slack of ``1e-6·(1 + R + drift)`` that covers the excursion's round-off and that of
    ``sin_psi0`` (``sin psi0`` however the caller finds it). The binding-edge searches score edges in order of
    ``d - base - this``.
    """
    drift = w * delta * inv_omega if w > 0.0 else 0.0
    ub = radius * (1.0 - s * sin_psi0) + drift
    return ub + 1e-6 * (1.0 + radius + drift)


@jitable
def fixed_wing_edge_room_m(
    base_m: float, gap_m: float, radius: float, inv_omega: float, v: float, w: float, psi0: float, s: float, delta: float
) -> float:
    """The room against one edge of the fixed-wing manoeuvre the margins score, m: ``base_m`` (the reaction
    travel to where the turn starts, plus any margin the caller folds in) and the larger of the turn's excursion
    (:func:`trochoid_excursion_m` of ``s``, ``delta``) and ``gap_m``, how much farther the reaction arc itself
    gets (:func:`reaction_arc_gap_m`)."""
    ex = trochoid_excursion_m(radius, inv_omega, v, w, psi0, s, delta)
    return base_m + (ex if ex >= gap_m else gap_m)


def turn_excursion_m(
    airspeed_mps: float,
    bank_rad: float,
    psi0_rad: float,
    wind_normal_mps: float = 0.0,
    turn_sign: int = 0,
    turn_angle_rad: float | None = None,
    g: float = G_MPS2,
) -> float:
    """Room along an edge normal used by a max-bank turn (no reaction distance): ``max x(theta)``, in m.

    ``psi0_rad``: air-relative heading counter-clockwise from the edge's
    breach-pointing normal (0 = head-on). ``wind_normal_mps``: wind component
    towards the edge (+ tailwind). ``turn_sign``: +1 left, -1 right, 0 = the
    better of the two. ``turn_angle_rad``: turn exactly this much (max of the
    excursion over the turn); ``None`` = turn until no longer closing on the
    edge, giving closed form (1) of the module docstring. ``inf`` if the
    tailwind is >= the airspeed while closing.
    """
    v = airspeed_mps
    r = turn_radius_m(v, bank_rad, g)
    inv_omega = 1.0 / turn_rate_radps(v, bank_rad, g)
    psi0 = wrap_pi(psi0_rad)
    if turn_sign:
        return trochoid_excursion_m(r, inv_omega, v, wind_normal_mps, psi0, 1.0 if turn_sign > 0 else -1.0, turn_angle_rad)
    return min(
        trochoid_excursion_m(r, inv_omega, v, wind_normal_mps, psi0, 1.0, turn_angle_rad),
        trochoid_excursion_m(r, inv_omega, v, wind_normal_mps, psi0, -1.0, turn_angle_rad),
    )


@jitable
def reaction_arc_m(v_air: float, psi0: float, rot: float, omega: float, t: float, nx: float, ny: float, w_n: float) -> float:
    """Reaction travel along the normal ``(nx, ny)`` while the current turn goes on for ``t`` s, m (>= 0).

    ``(V/omega)·[sin(psi0 - theta_n) - sin(psi0 - rot - theta_n)] + w_n·t``
    (straight, ``V·t·cos(psi0 - theta_n) + w_n·t``, when ``|rot| < 1e-6``),
    with ``theta_n`` the normal's ENU angle. Air heading ``psi0`` (rad, ENU,
    counter-clockwise from east) rotates by ``-rot`` (rad; ``omega`` rad/s, + =
    clockwise); airspeed ``v_air`` and wind along the normal ``w_n`` in m/s.
    """
    return _reaction_arc_end_m(v_air, psi0, rot, omega, t, math.atan2(ny, nx), w_n)


@jitable
def _reaction_arc_end_m(v_air: float, psi0: float, rot: float, omega: float, t: float, theta: float, w_n: float) -> float:
    """:func:`reaction_arc_m` for the normal at ENU angle ``theta``."""
    if abs(rot) < 1e-6:
        along = v_air * t * math.cos(psi0 - theta)
    else:
        along = (v_air / omega) * (math.sin(psi0 - theta) - math.sin(psi0 - rot - theta))
    d = along + w_n * t
    return d if d > 0.0 else 0.0


@jitable
def reaction_arc_sines_m(
    arc: float, sp: float, cp: float, sq: float, cq: float, straight: bool, t: float, nx: float, ny: float, w_n: float
) -> float:
    """:func:`reaction_arc_m` without a transcendental function per normal, to round-off, m (>= 0): the fast form
    the compiled binding search bounds elements with (about 1e-15 of ``arc`` from the reference form).

    ``arc``: ``V·t`` when ``straight`` (``|rot| < 1e-6``), else ``V/omega``; ``(sp, cp)`` the sine and cosine of
    the air heading ``psi0`` at the start, ``(sq, cq)`` of ``psi0 - rot`` at the end; for a unit normal at
    angle ``theta``, ``sin(psi - theta) = sin psi·nx - cos psi·ny``.
    """
    if straight:
        along = arc * (cp * nx + sp * ny)
    else:
        along = arc * ((sp * nx - cp * ny) - (sq * nx - cq * ny))
    d = along + w_n * t
    return d if d > 0.0 else 0.0


@jitable
def reaction_arc_bound_m(v_air: float, w_n: float, t: float) -> float:
    """Upper bound of the reaction arc's farthest travel along a normal (:func:`reaction_arc_terms_m`'s end plus
    gap), m: ``(V + max(w_n, 0))·t``, with a relative slack of 1e-9 and 1e-9 m for round-off."""
    return (v_air + (w_n if w_n > 0.0 else 0.0)) * t * (1.0 + 1e-9) + 1e-9


@jitable
def reaction_arc_terms_m(
    v_air: float, psi0: float, rot: float, omega: float, t: float, nx: float, ny: float, w_n: float
) -> tuple[float, float]:
    """``(reaction_arc_m, reaction_arc_gap_m)`` of the same arguments, the normal's angle and the arc's end found
    once (the margins ask both of each element they score exactly)."""
    theta = math.atan2(ny, nx)
    end = _reaction_arc_end_m(v_air, psi0, rot, omega, t, theta, w_n)
    if abs(rot) < 1e-6:
        return end, 0.0
    a = psi0 - theta
    arc = v_air / omega
    c = -w_n * t / (arc * rot)
    if not -1.0 < c < 1.0:
        return end, 0.0
    best = end
    root = math.acos(c)
    for sgn in (1.0, -1.0):
        for k in range(-2, 3):
            u = (a - sgn * root - TWO_PI * k) / rot
            if 0.0 < u < 1.0:
                x = arc * (math.sin(a) - math.sin(a - rot * u)) + w_n * t * u
                if x > best:
                    best = x
    return end, best - end


@jitable
def fixed_wing_reaction_terms(
    v_air: float, vae: float, van: float, ve: float, vn: float, speed: float, cruise_mps: float, min_speed_mps: float,
    max_bank_rad: float, reaction_s: float, t_r: float, bank_rad: float, g: float,
) -> tuple[float, float, float, float, float, float, float, float]:  # fmt: skip
    """The per-state terms of the fixed-wing manoeuvre a margin scores: ``(psi, psi_react0, v_turn, R, 1/omega,
    t_fw, omega_now, rot)``.

    The air heading ``psi_react0`` (rad, ENU; of the air velocity ``(vae, van)`` of magnitude ``v_air``, else of
    the ground velocity); the turn speed ``v_turn`` (the override flies at cruise, so at least that) and its turn
    constants at the bank limit; the reaction time ``t_fw`` (``t_r`` plus rolling out of the current bank, up to
    another ``reaction_s``); the current turn's rate ``omega_now`` (+ = clockwise) and rotation ``rot`` over it
    (within ±pi); ``psi`` the heading where the recovery turn starts. The caller computes ``v_air``."""
    if v_air > 0.0:
        psi = math.atan2(van, vae)
    elif speed > 0.0:
        psi = math.atan2(vn, ve)
    else:
        psi = 0.0
    v_turn = max(v_air, cruise_mps, min_speed_mps, 1e-3)
    radius, inv_omega = turn_constants(v_turn, max_bank_rad, g)
    bank_now = max(-max_bank_rad, min(max_bank_rad, bank_rad))
    t_fw = t_r + reaction_s * (abs(bank_now) / max_bank_rad if max_bank_rad > 0 else 0.0)
    omega_now = turn_rate_radps(v_turn, bank_now, g)
    rot = max(-math.pi, min(math.pi, omega_now * t_fw))
    return psi - rot, psi, v_turn, radius, inv_omega, t_fw, omega_now, rot


@jitable
def rollout_turns(
    de: float, dn: float, dd: float, wind_e: float, wind_n: float, v_turn: float, psi: float
) -> tuple[float, float, float, float]:
    """``(1, delta_left, -1, delta_right)``: the turns from air heading ``psi`` to the wind-corrected heading
    whose track leads to the roll-out target ``(de, dn)`` away (``dd`` its length, the caller's ``hypot``); a
    course reversal either way within 1 m of it, where the direction is undefined."""
    if not dd > 1.0:
        return 1.0, math.pi, -1.0, math.pi
    psi_d = math.atan2(dn, de)
    psi_f = psi_d
    wc = (de * wind_n - dn * wind_e) / dd
    if abs(wc) < v_turn:
        cand = psi_d - math.asin(wc / v_turn)
        if v_turn * math.cos(cand - psi_d) + (de * wind_e + dn * wind_n) / dd > 0.0:
            psi_f = cand
    return 1.0, (psi_f - psi) % TWO_PI, -1.0, (psi - psi_f) % TWO_PI


@jitable
def reaction_arc_gap_m(v_air: float, psi0: float, rot: float, omega: float, t: float, nx: float, ny: float, w_n: float) -> float:
    """How much farther along the normal the reaction arc gets than where it ends, m (>= 0).

    The arc of :func:`reaction_arc_m`, as ``u`` runs from 0 to 1: the heading turned by ``-rot·u``, the time
    ``t·u``. An aircraft heading towards an edge while banked away from it first closes on the edge and then
    turns away: its farthest point lies inside the arc, where ``d/du = 0``, i.e. ``cos(a - rot·u) =
    -w_n·t / ((V/omega)·rot)`` with ``a = psi0 - theta_n``. Returns that farthest travel (at least 0) less
    :func:`reaction_arc_m`; 0 when the arc is straight or the end is the farthest.
    """
    return reaction_arc_terms_m(v_air, psi0, rot, omega, t, nx, ny, w_n)[1]


def fixed_wing_room_m(
    airspeed_mps: float, bank_rad: float, psi0_rad: float, wind_normal_mps: float, reaction_time_s: float, g: float = G_MPS2
) -> float:
    """Room along the normal to turn back from an edge: reaction distance + closed form (1), in m.

    Reaction distance: the ground-velocity component towards the edge,
    ``max(V·cos psi0 + w, 0)`` (m/s), times the reaction time (s). Head-on in
    calm air this is ``V·t_react + V²/(g·tan phi)``.
    """
    closing = airspeed_mps * math.cos(psi0_rad) + wind_normal_mps
    react = closing * reaction_time_s if closing > 0.0 else 0.0
    return react + turn_excursion_m(airspeed_mps, bank_rad, psi0_rad, wind_normal_mps, 0, None, g)


def fixed_wing_room_from_velocity_m(
    v_ground_normal: float,
    v_ground_tangent: float,
    wind_normal: float,
    wind_tangent: float,
    bank_rad: float,
    reaction_time_s: float,
    g: float = G_MPS2,
) -> float:
    """:func:`fixed_wing_room_m` (m) from ground velocity and wind (m/s) split along (normal, tangent) of the edge."""
    van, vat = v_ground_normal - wind_normal, v_ground_tangent - wind_tangent
    v = math.hypot(van, vat)
    if v == 0.0:
        return 0.0
    return fixed_wing_room_m(v, bank_rad, math.atan2(vat, van), wind_normal, reaction_time_s, g)


@jitable
def multirotor_room_bound_m(
    speed_mps: float, t_s: float, a_tilt: float, k1: float, k2: float, wind_speed_mps: float, a_brake: float,
    climb_arrest: tuple[float, float], hu: float,
) -> float:  # fmt: skip
    """Upper bound of a multirotor's room against any edge, plus ``hu``, m: :func:`multirotor_room_m` head-on at
    the ground speed, with the largest pilot acceleration and wind push (:func:`~geofence.physics.dynamics.wind_push_mps2`
    at ``|W|``, its drag law ``k1, k2``) and the weakest braking; a relative slack covers round-off (the room
    grows with each, so no edge farther than the nearest plus this bound can bind)."""
    push_max = wind_push_mps2(k1, k2, wind_speed_mps, wind_speed_mps)
    a_p_max = a_tilt + push_max
    room_max = multirotor_room_m(speed_mps, speed_mps, t_s, max(a_p_max, 0.0), a_brake - push_max, climb_arrest)
    return (room_max + hu) * (1.0 + 1e-9) + 1e-6


@jitable
def fixed_wing_room_bound_m(radius: float, inv_omega: float, speed_mps: float, wind_speed_mps: float, t_s: float) -> float:
    """Upper bound of reaction travel + excursion against any edge: ``2R + |W|·2pi/omega + (v + |W|)·t``, in m.

    Any turn of up to 2 pi moves the vehicle at most ``2R`` along a normal
    plus the wind drift ``|W|·2pi/omega``; the reaction phase (``t`` s) at
    most ``(v + |W|)·t``, for ``v`` (m/s) at least the speed flown then.
    ``radius``, ``inv_omega`` from :func:`turn_constants`.
    """
    return 2.0 * radius + wind_speed_mps * TWO_PI * inv_omega + (speed_mps + wind_speed_mps) * t_s


# --------------------------------------------------------------------------- multirotor: reaction and braking
@jitable
def tilt_accel_mps2(tilt_rad: float, g: float = G_MPS2) -> float:
    """Horizontal acceleration at tilt ``theta`` (rad): ``g·tan(theta)``, m/s²."""
    return g * math.tan(tilt_rad)


@jitable
def climb_arrest_phase(v_up_mps: float, vertical_accel_mps2: float, g: float = G_MPS2) -> tuple[float, float]:
    """``(t_arrest s, loss)`` of arresting a climb: ``(v_up/a_z, a_z/g)``; ``(0, 0)`` when not climbing.

    For the first ``t_arrest`` seconds the collective is cut, so the braking
    deceleration is only ``a·(1 - loss)`` (see :func:`braking_room_m`).
    """
    if v_up_mps > 0.0 and vertical_accel_mps2 > 0.0:
        return v_up_mps / vertical_accel_mps2, vertical_accel_mps2 / g
    return 0.0, 0.0


@jitable
def braking_room_m(v_n: float, v: float, a: float, climb_arrest: tuple[float, float]) -> float:
    """Braking distance along the normal from ground speed ``v`` (normal part ``v_n``, m/s) at ``a`` m/s², in m.

    Without a climb arrest: ``v_n·v/(2a)``. ``climb_arrest = (t_arrest_s,
    loss)`` (:func:`climb_arrest_phase`): for the first ``t_arrest_s`` the
    deceleration is only ``a1 = a·(1 - loss)`` (thrust, and so its horizontal
    part, drops by the vertical deceleration over g), so
    ``(v_n/v)·(v·t1 - a1·t1²/2 + v2²/(2a))`` with ``t1 = min(t_arrest, v/a1)``,
    ``v2 = v - a1·t1``. ``inf`` when ``a <= 0``.
    """
    if a <= 0.0:
        return math.inf
    t1, loss = climb_arrest
    a1 = a * (1.0 - loss)
    if t1 > 0.0 and a1 > 0.0:
        t1 = min(t1, v / a1)
        d1 = v * t1 - 0.5 * a1 * t1 * t1
        v2 = v - a1 * t1
        return (v_n / v) * (d1 + v2 * v2 / (2.0 * a)) if v > 0.0 else 0.0
    return v_n * v / (2.0 * a)


@jitable
def multirotor_room_m(
    v_n: float, speed_mps: float, t_s: float, a_pilot_mps2: float, a_brake_mps2: float, climb_arrest: tuple[float, float]
) -> float:
    """Room along the normal for a worst-case pilot, then braking: ``v_n·t + a_p·t²/2 + braking``, in m.

    The pilot accelerates towards the edge at ``a_p`` (m/s², tilt limit plus
    wind push) for ``t`` s from closing speed ``v_n`` and ground speed ``v``
    (m/s), then the vehicle brakes at ``a_brake`` (already net of the wind
    push) from ``v_n1 = v_n + a_p·t``, ``v1 = max(v + a_p·t, v_n1)``
    (:func:`braking_room_m`). 0 when ``v_n1 <= 0``. The per-edge fast form;
    with ``a_p = 0`` and no climb arrest it is
    :func:`multicopter_stopping_distance_m`.
    """
    v_n1 = v_n + a_pilot_mps2 * t_s
    if v_n1 <= 0.0:
        return v_n * t_s if v_n > 0.0 else 0.0
    base = (v_n * t_s if v_n > 0.0 else 0.0) + 0.5 * a_pilot_mps2 * t_s * t_s
    v1 = speed_mps + a_pilot_mps2 * t_s
    return base + braking_room_m(v_n1, v1 if v1 > v_n1 else v_n1, a_brake_mps2, climb_arrest)


def multicopter_stopping_distance_m(
    v_normal_mps: float,
    reaction_time_s: float,
    braking_decel_mps2: float,
    speed_mps: float | None = None,
    wind_push_mps2: float = 0.0,
) -> float:
    """Room along an edge normal to stop: ``v_n·t_react + v_n·v/(2·(a_brake - a_w))``, in m: the reaction travel
    plus :func:`braking_room_m` without a climb arrest.

    ``speed_mps`` (default ``|v_n|``) is the full ground speed (the vehicle
    brakes along its velocity); ``wind_push_mps2`` from
    :func:`geofence.physics.dynamics.wind_push_mps2`.
    0 when not closing; ``inf`` when the wind push is >= the braking deceleration.
    """
    if v_normal_mps <= 0.0:
        return 0.0
    v = abs(v_normal_mps) if speed_mps is None else max(speed_mps, v_normal_mps)
    return v_normal_mps * reaction_time_s + braking_room_m(v_normal_mps, v, braking_decel_mps2 - wind_push_mps2, (0.0, 0.0))


# --------------------------------------------------------------------------- vertical
@jitable
def vertical_arrest_distance_m(v_toward_mps: float, reaction_time_s: float, accel_mps2: float, v_max_toward_mps: float) -> float:
    """How far towards the ceiling (a climb) or the floor (a descent) the vehicle gets before it is arrested, m (>= 0).

    ``v`` m/s towards the limit (negative: away), ``t_react`` s, ``a_z`` m/s² (``inf`` when ``a_z <= 0``),
    ``v_max`` m/s: the platform's largest vertical speed that way. Through the reaction time the pilot keeps
    accelerating towards the limit at ``a_z``, up to ``v_max`` (as the lateral margins let it keep
    accelerating towards the edge); then the override arrests it at ``a_z``. Already at ``v_max`` or beyond
    (or with ``v_max`` 0: no acceleration) that is ``v·t_react + v²/(2·a_z)``. Holding the speed through the reaction
    instead let a pilot who dived again right after a hand-back take a vehicle below the floor: at rest
    next to the floor that distance is 0, where the dive needs about ``a_z·t_react²``
    (case history: docs/campaigns.md#breach-classes-found-and-fixed).
    """
    if accel_mps2 <= 0.0:
        return math.inf if v_toward_mps > 0.0 or v_max_toward_mps > 0.0 else 0.0
    v0 = v_toward_mps
    t_acc = 0.0
    if v0 < v_max_toward_mps:  # the pilot accelerates towards the limit until v_max or the override
        t_acc = (v_max_toward_mps - v0) / accel_mps2
        if t_acc > reaction_time_s:
            t_acc = reaction_time_s
    v_end = v0 + accel_mps2 * t_acc
    if v_end <= 0.0:  # still moving away when the override acts
        return 0.0
    d = v0 * t_acc + 0.5 * accel_mps2 * t_acc * t_acc + v_end * (reaction_time_s - t_acc) + v_end * v_end / (2.0 * accel_mps2)
    return d if d > 0.0 else 0.0


@jitable
def climb_back_drift_m(depth_below_floor_m: float, climb_rate_mps: float, wind_speed_mps: float) -> float:
    """How far a fixed-wing circling inside a floor gap drifts while it climbs back above the floor (m).

    It cannot hover: it stays over the gap by circling, and the circle moves with the air, for
    ``depth / climb rate`` seconds. 0 when it is not below the floor. (A multirotor holds its position
    while it climbs: no drift.)
    """
    if depth_below_floor_m <= 0.0:
        return 0.0
    return wind_speed_mps * depth_below_floor_m / max(climb_rate_mps, 0.1)


@jitable
def gap_circle_turn_rad(depth_below_floor_m: float, climb_rate_mps: float, inv_omega: float) -> float:
    """The turn (rad) a fixed-wing below the floor inside a floor gap flies while it climbs back above the floor.

    It cannot hover: the override keeps it circling at the bank limit, the way it turned, for
    ``depth / climb rate`` seconds (``inv_omega``: the turn's ``1/omega``, s), and the circle drifts with the
    wind meanwhile. Scored as one turn of this angle (:func:`trochoid_excursion_m`, the drift included),
    every point of the circle, not only the turn to its roll-out heading. 0 when it is not below the floor.
    """
    if depth_below_floor_m <= 0.0:
        return 0.0
    return depth_below_floor_m / max(climb_rate_mps, 0.1) / inv_omega


# --------------------------------------------------------------------------- envelope-level rooms
def head_on_room_m(env: Envelope, speed_mps: float, wind_toward_mps: float, wind_speed_mps: float, g: float = G_MPS2) -> float:
    """Room (m) to stop or turn back in a head-on approach at ``speed_mps`` (what the analysis figures draw).

    ``speed_mps``: airspeed for a fixed-wing (:func:`fixed_wing_room_m` at
    ``psi0 = 0``), ground speed for a multirotor
    (:func:`multicopter_stopping_distance_m` with the wind's push);
    ``wind_toward_mps``: the wind component toward the boundary (+ tailwind);
    ``wind_speed_mps``: the wind speed ``|W|`` (m/s).
    """
    w = float(wind_toward_mps)
    if env.kind is PlatformKind.FIXED_WING:
        return fixed_wing_room_m(speed_mps, env.max_bank_rad, 0.0, w, env.reaction_time_s, g)
    push = wind_push_mps2(*drag_coefficients(env), wind_speed_mps, w)
    return multicopter_stopping_distance_m(speed_mps, env.reaction_time_s, env.braking_decel_mps2, speed_mps, push)


def worst_case_lateral_shift_m(
    envelope: Envelope, wind_speed_mps: float, h_uncertainty_m: float = 0.0, g: float = G_MPS2
) -> float:
    """Largest lateral shift (m) over speeds and approach angles: :func:`head_on_room_m` with the wind as a tailwind.

    Fixed-wing: the largest over min, cruise and max speed (those above the
    wind; ``inf`` if none); multirotor: at max speed. ``wind_speed_mps`` is the
    design wind (mean plus any turbulence and gust allowance); plus
    ``h_uncertainty_m``.
    """
    w = abs(wind_speed_mps)
    if envelope.kind is PlatformKind.FIXED_WING:
        speeds = [v for v in (envelope.min_speed_mps, envelope.cruise_speed_mps, envelope.max_speed_mps) if v > w]
        if not speeds:
            return math.inf
        return max(head_on_room_m(envelope, v, w, w, g) for v in speeds) + h_uncertainty_m
    return head_on_room_m(envelope, envelope.max_speed_mps, w, w, g) + h_uncertainty_m


def room_upper_bounds_m(
    env: Envelope,
    ground_speed_mps: float,
    airspeed_mps: float,
    v_up_mps: float,
    wind_speed_mps: float,
    t_s: float,
    g: float = G_MPS2,
) -> tuple[float, float]:
    """``(lateral, vertical)`` upper bounds (m) of the room any edge, the ceiling or the floor can need (skip shortcut).

    Over every heading, for a reaction time of at most ``t_s`` s, with the wind
    speed ``|W|`` (m/s, including any allowance) towards every edge:

    * multirotor: :func:`multirotor_room_m` head-on at
      ``v = max(v_max, ground speed)`` with the pilot at the tilt limit plus the
      push ``a_w`` of ``|W|``, braking at ``(a_brake - a_w)·max(1 - a_z/g, 0.05)``
      throughout (the weakest, a climb arrest's); ``inf`` if that is <= 0;
    * fixed-wing: :func:`fixed_wing_room_bound_m` at
      ``v = max(v_max, airspeed)`` (the turn speed is at most that);
    * vertical: :func:`vertical_arrest_distance_m` from the largest of the
      climb rate, the descent rate and ``|v_up|``.

    The arithmetic is :func:`room_upper_bounds_terms`' (on the envelope's numbers: the compiled kernels call it).
    """
    k1, k2 = drag_coefficients(env)
    return room_upper_bounds_terms(
        env.kind is PlatformKind.FIXED_WING, env.max_speed_mps, env.max_bank_rad, env.braking_decel_mps2,
        env.vertical_accel_mps2, env.max_climb_rate_mps, env.max_descent_rate_mps, k1, k2,
        ground_speed_mps, airspeed_mps, v_up_mps, wind_speed_mps, t_s, g,
    )  # fmt: skip


room_upper_bounds_fast_m = room_upper_bounds_m
"""The unit's name for :func:`room_upper_bounds_m` (once a hand-inlined copy of it; now the same function)."""


@jitable
def room_upper_bounds_terms(
    fixed_wing: bool,
    max_speed_mps: float,
    max_bank_rad: float,
    braking_decel_mps2: float,
    vertical_accel_mps2: float,
    max_climb_rate_mps: float,
    max_descent_rate_mps: float,
    k1: float,
    k2: float,
    ground_speed_mps: float,
    airspeed_mps: float,
    v_up_mps: float,
    wind_speed_mps: float,
    t_s: float,
    g: float,
) -> tuple[float, float]:
    """:func:`room_upper_bounds_m` on the envelope's numbers (``k1, k2``: its drag law's
    :func:`~geofence.physics.dynamics.drag_coefficients`), composed of the room formulas' bounds."""
    w = wind_speed_mps
    if fixed_wing:
        v = max_speed_mps if max_speed_mps > airspeed_mps else airspeed_mps
        radius, inv_omega = turn_constants(v, max_bank_rad, g)
        lateral = fixed_wing_room_bound_m(radius, inv_omega, v, w, t_s)
    else:
        v = max_speed_mps if max_speed_mps > ground_speed_mps else ground_speed_mps
        push = wind_push_mps2(k1, k2, w, w)
        a = (braking_decel_mps2 - push) * max(1.0 - vertical_accel_mps2 / g, 0.05)
        a_p = tilt_accel_mps2(max_bank_rad, g) + push
        lateral = multirotor_room_m(v, v, t_s, a_p, a, (0.0, 0.0)) if a > 0.0 else math.inf
    vz = max(max_climb_rate_mps, max_descent_rate_mps, abs(v_up_mps))
    return lateral, vertical_arrest_distance_m(vz, t_s, vertical_accel_mps2, vz)
