"""The geofence unit's steps on arrays: :meth:`geofence.unit.geofence_unit.GeofenceUnit.update` while it passes the pilot's
sticks through, and while a fixed-wing override flies, as functions a compiled per-step kernel calls.

One question each. :func:`monitor_pass`: given this step's estimate (the sensing chain's numbers), does a
predictive unit that monitors (``MONITOR`` or ``RECOVERED``) keep passing the sticks through, and with which
margins? The answer is :data:`PASS` (and the margins), :data:`PASS_HANDBACK` (pass, and ``RECOVERED``'s hold is
over: back to ``MONITOR``), :data:`NEED_TARGET` (near a boundary, a fixed-wing's roll-out target for this cell is
not packed: the unit finds it, and the step is asked again) or :data:`UNIT`: anything else (an activation, a
stale or lost position, an envelope to re-scale to the air density, a wind beyond authority), which the unit's
own :meth:`~geofence.unit.geofence_unit.GeofenceUnit.update` then answers from the same estimate.
:func:`override_pass`: which sticks does a fixed-wing override send at this step (:data:`OVERRIDE_STEP`; after
its minimum override period, with its margins: it is not outside and may not hand back yet), or must the unit
answer (:data:`UNIT`: a re-activation, a possible hand-back, a lost position, ...; :data:`NEED_TARGET` as above)? The unit packs what a step reads in one float
array (:meth:`~geofence.unit.geofence_unit.GeofenceUnit.pack_monitor`, :meth:`~geofence.unit.geofence_unit.GeofenceUnit.pack_override`,
layout below); :func:`record_pass` keeps what each step taken so changes, and the unit takes it in before it
answers a step again (:meth:`~geofence.unit.geofence_unit.GeofenceUnit.take_in_passes`). ``update`` is the reference: the
same tests in the same order on the same numbers (``tests/test_flight_step.py`` flies flights both ways and
compares their bytes).

It also owns the few constants both read: when an estimate is fresh, when the envelope is re-scaled, when a
vehicle on the ground is sitting, the hand-back hold and the roll-out target cache's cells; and the formula of
the vertical hand-back hysteresis at an override's goal (:func:`vertical_handback_m`).
"""

from __future__ import annotations

import math
from math import hypot

import numpy as np

from geofence.jit import compiled, jitable
from geofence.margins.kernel import (
    ACTIVATION_FIELD,
    CEILING_MARGIN_FIELD,
    CLOSING_FIELD,
    FLOOR_MARGIN_FIELD,
    LATERAL_ACTIVATION_FIELD,
    LATERAL_MARGIN_FIELD,
    NOT_NEEDED,
    VERTICAL_ACTIVATION_FIELD,
    far_from_everything,
    margins,
    monitor_margins,
)
from geofence.margins.kernel import MAX_CLIMB as TERM_MAX_CLIMB  # (the envelope terms' positions)
from geofence.margins.kernel import MAX_DESCENT as TERM_MAX_DESCENT
from geofence.margins.kernel import VERTICAL_ACCEL as TERM_VERTICAL_ACCEL
from geofence.physics.rooms import vertical_arrest_distance_m
from geofence.recovery.guidance import fixed_wing_step
from geofence.unit.config import allowance_in_use_mps

RECOVERED_HOLD_S = 1.0
"""After a hand-back the unit stays ``RECOVERED`` this long (s) before ``MONITOR``."""
ROLLOUT_CELL_M = 10.0
"""Cell size of the fixed-wing roll-out target cache (m)."""
FRESH_ESTIMATE_AGE_S = 0.5
"""Dead reckoning starts from the last estimate whose GNSS data was at most this old (not a long extrapolation)."""
SITTING_MAX_GROUND_SPEED_MPS = 2.0
"""On the ground and slower than this (m/s), a vehicle is sitting: it breaches nothing where it is, and the unit
leaves it be (a multirotor that landed, a fixed-wing that stopped). Faster, it is rolling -- a fixed-wing that
touched down at flying speed inside a floor gap rolls out of it below the floor -- and its margins count: the
override lifts it off and climbs back above the floor inside the gap."""
DENSITY_REFRESH_M = 100.0
"""The envelope is re-scaled to the air density when the altitude moved this much (while monitoring)."""

# the answers
PASS = 0
PASS_HANDBACK = 1
UNIT = 2
OVERRIDE_STEP = 3  # (override_pass) the override's sticks, by its compiled step
NEED_TARGET = 4
"""The margins need the roll-out target of the estimate's cell and it is not among those packed: the unit finds it
(:meth:`~geofence.unit.geofence_unit.GeofenceUnit.find_rollout_target`, a route search where it has none cached), and the caller
asks the same step again from the same estimate (nothing was kept or recorded)."""

# the unit's packed numbers (GeofenceUnit.pack_monitor), each a float
K_SIGMA = 0  # uncertainty_k_sigma
EXTRA = 1  # extra_margin_m
REACTION_S = 2  # the (density-scaled) envelope's reaction time
FORECAST_ALLOWANCE = 3  # the forecast's wind allowance, m/s
ESTIMATED_TURBULENCE = 4  # 1: turbulence_source estimate
FORECAST_SIGMA = 5  # turbulence_sigma_mps
TURBULENCE_K = 6  # turbulence_k_sigma
GUST = 7  # gust_mps
RETURN_ALLOWANCE = 8  # return_wind_limits
RETURN_LIMIT = 9
AGL = 10  # 1: the fence's heights are AGL
MULTIROTOR = 11  # 1: no roll-out target
DENSITY_ALT = 12  # the altitude the envelope was scaled at (NaN: never)
MODE = 13  # the unit's mode, as a number
MONITOR_MODE = 14  # MONITOR's number (any other mode packed is RECOVERED)
MODE_SINCE = 15  # when the mode began, s
HAS_TARGETS = 16  # 1: the roll-out targets cached round cell (CELL_E, CELL_N) follow from TARGETS0
CELL_E = 17
CELL_N = 18
TARGETS0 = 19  # (has, east, north) of each cell within TARGET_CELLS of that one, row by row from the south-west
TARGET_CELLS = 2
"""The cached roll-out targets packed reach this many cells round the estimate's (5 x 5 cells): a vehicle crossing
into a neighbouring cell still finds its target without the unit (at 30 m/s a 10 m cell lasts 13 steps)."""
_SIDE = 2 * TARGET_CELLS + 1
# what the passes leave for the unit to take in (GeofenceUnit.take_in_passes): written by record_pass
PASSES = TARGETS0 + 3 * _SIDE * _SIDE  # passes since the unit last took them in
RING_NEXT = PASSES + 1  # the estimates' ring's row the next pass writes
LAST_T = PASSES + 2  # the last pass's time, s
LATENCY = PASSES + 3
WIND_E = PASSES + 4  # the wind estimate
WIND_N = PASSES + 5
TURBULENCE_EST = PASSES + 6
SIGMA_V = PASSES + 7
SIGMA_H = PASSES + 8  # the last finite one (packed: the unit's)
FAR = PASSES + 9  # 1: the last pass's skip shortcut held
ACTIVATION = PASSES + 10  # the last pass's activation margin (inf: far)
HAS_MARGINS = PASSES + 11  # 1: a pass computed margins: the last such pass's position and fields follow
MARGINS_E = PASSES + 12
MARGINS_N = PASSES + 13
MARGINS0 = PASSES + 14  # 18 fields (geofence.margins.kernel._margins)
HORIZON_MOVED = MARGINS0 + 18  # 1: a pass brought a new fusion horizon, its FixState fields follow
HORIZON0 = HORIZON_MOVED + 1  # 5 fields
# a fixed-wing override's step (GeofenceUnit.pack_override; the recovery's state written back by override_pass)
PERIOD_START = HORIZON0 + 5  # the override period's start, s
MIN_OVERRIDE = PERIOD_START + 1  # min_override_s
THR = PERIOD_START + 2  # the route follower's chord threshold argument (NaN: found by the call)
CLEARANCE = PERIOD_START + 3
TURN_THROTTLE = PERIOD_START + 4  # the throttle stick while the first turn lasts
THROTTLE = PERIOD_START + 5  # and after it
PROGRESS = PERIOD_START + 6  # the route's progress, m
TURNING = PERIOD_START + 7  # 1: the first turn lasts
TURNED = PERIOD_START + 8  # how far it has turned, rad
LAST_YAW = PERIOD_START + 9
RECOVERY_MOVED = PERIOD_START + 10  # 1: override steps moved the recovery's state (the four above)
# after the minimum override period: the hand-back's numbers (GeofenceUnit._handback_ok)
HANDBACK_MARGIN = PERIOD_START + 11  # handback_margin_m
RECOVERY_E = PERIOD_START + 12  # the fence's recovery point
RECOVERY_N = PERIOD_START + 13
RECOVERY_RADIUS = PERIOD_START + 14  # recovery_radius_m
CLIMB_BACK = PERIOD_START + 15  # the height the override climbs back to before it may hand back (NaN: none)
VERTICAL_HYSTERESIS = PERIOD_START + 16  # the unit's vertical hand-back hysteresis, m
GOAL_H = PERIOD_START + 17  # the override's goal height where it is short of the band (NaN: in the band)
CEILING_M = PERIOD_START + 18
FLOOR_M = PERIOD_START + 19  # (NaN: no floor)
N_UNIT = FLOOR_M + 1
RING_COLUMNS = 16
"""A ring row: the estimate's 15 fields in :class:`~geofence.interface.VehicleState`'s order, then ``on_ground``."""


@jitable
def rollout_cell(e: float, n: float) -> tuple[int, int]:
    """The roll-out target cache's cell of (e, n) (:data:`ROLLOUT_CELL_M` squares)."""
    return math.floor(e / ROLLOUT_CELL_M), math.floor(n / ROLLOUT_CELL_M)  # (math.floor of a float is an int)


@jitable
def latency_s(dt_s: float, estimate_age_s: float) -> float:
    """The unit's reaction latency beyond its envelope's (s): the step, and the age of the position data behind the
    estimate (the vehicle may have accelerated that long unseen)."""
    return dt_s + (0.0 if 0.0 > estimate_age_s else estimate_age_s)  # (max(age, 0.0), the value Python picks)


@jitable
def return_assured(wind_e: float, wind_n: float, allowance_mps: float, limit_mps: float) -> bool:
    """The wind with its allowance is under the return limit (:func:`geofence.physics.dynamics.return_wind_limits`): the
    test of :func:`geofence.physics.dynamics.return_not_assured` against limits computed once per envelope."""
    return hypot(wind_e, wind_n) + allowance_mps < limit_mps


@jitable
def activates(activation_m: float, on_ground: bool, ground_speed_mps: float) -> bool:
    """A monitoring unit starts its override: the activation margin reached 0 and the vehicle is not sitting on the
    ground (:data:`SITTING_MAX_GROUND_SPEED_MPS`)."""
    return activation_m <= 0.0 and not (on_ground and ground_speed_mps < SITTING_MAX_GROUND_SPEED_MPS)


@jitable
def hold_over(recovered: bool, t_s: float, mode_since_s: float) -> bool:
    """``RECOVERED`` has held :data:`RECOVERED_HOLD_S`: back to ``MONITOR``."""
    return recovered and t_s - mode_since_s >= RECOVERED_HOLD_S


@jitable
def outside(lateral_margin_m: float, ceiling_margin_m: float, floor_margin_m: float) -> bool:
    """Past the fence (a plain margin below 0): an override still outside at the end of its period re-activates."""
    return lateral_margin_m < 0.0 or ceiling_margin_m < 0.0 or floor_margin_m < 0.0


@jitable
def hand_back(
    climb_back_m: float, h: float, vertical_ok: bool, lateral_m: float, closing_mps: float, handback_margin_m: float,
    recovery_distance_m: float, recovery_radius_m: float,
) -> tuple[bool, bool]:  # fmt: skip
    """``(climbed back, hand back)`` of an override after its minimum period. Below the floor in a gap it climbs back
    to ``climb_back_m`` (NaN: none) first: below it, neither; at or above it, the climb is done (``climbed back``:
    the unit clears it) and the rest is tested. Hand back: the vertical hysteresis met (``vertical_ok``) and either
    the lateral one (``lateral_m`` at least ``handback_margin_m``, not closing) or the recovery point reached."""
    climbed = climb_back_m == climb_back_m  # (not NaN)
    if climbed and h < climb_back_m:
        return False, False
    lateral_ok = lateral_m >= handback_margin_m and closing_mps <= 0.0
    return climbed, vertical_ok and (lateral_ok or recovery_distance_m <= recovery_radius_m)


@jitable
def target_slot(U: np.ndarray, e: float, n: float) -> int:
    """Where the roll-out target of the cell of (e, n) is packed in ``U`` (its ``has`` flag; then east, north), or
    -1 where that cell is not among those packed (:data:`TARGET_CELLS` round the cell packed at ``CELL_E, CELL_N``)."""
    if U[HAS_TARGETS] != 0.0:
        cell_e, cell_n = rollout_cell(e, n)
        de, dn = cell_e - U[CELL_E], cell_n - U[CELL_N]
        if abs(de) <= TARGET_CELLS and abs(dn) <= TARGET_CELLS:
            return TARGETS0 + 3 * (int(dn + TARGET_CELLS) * _SIDE + int(de + TARGET_CELLS))
    return -1


@jitable
def cached_target(U: np.ndarray, e: float, n: float) -> tuple[bool, float, float]:
    """``(found, east, north)``: the roll-out target cached for the cell of (e, n) among those packed in ``U``
    (:func:`target_slot`; not found: the unit finds it)."""
    k = target_slot(U, e, n)
    if k >= 0 and U[k] != 0.0:
        return True, U[k + 1], U[k + 2]
    return False, 0.0, 0.0


@jitable
def _pass(U: np.ndarray, recovered: bool, t_s: float) -> int:
    """A pass's answer: :data:`PASS_HANDBACK` once ``RECOVERED`` has held (:func:`hold_over`), else :data:`PASS`."""
    return PASS_HANDBACK if hold_over(recovered, t_s, U[MODE_SINCE]) else PASS


@compiled
def monitor_pass(
    U: np.ndarray, F: np.ndarray, L: np.ndarray, V: np.ndarray, t_s: float, dt_s: float, alt: float, e: float,
    n: float, agl: float, ve: float, vn: float, vu: float, roll: float, on_ground: bool, wind_e: float, wind_n: float,
    position_valid: bool, sigma_h_m: float, sigma_v_m: float, estimate_age_s: float, turbulence_sigma_mps: float,
    g: float,
) -> tuple[int, bool, tuple[float, float, float, float, int, float, float, float, float, float, int, float, float, float, float, float, float, float]]:  # fmt: skip
    """``(answer, far, margins)`` of a monitoring step (see the module): ``far`` when the skip shortcut held
    (margins not computed), else the margins' fields (:func:`geofence.margins.kernel.monitor_margins`). ``U``: the
    unit's packed numbers; ``F, L, V``: its compiled margins' tables and envelope terms; the rest are
    :meth:`~geofence.unit.geofence_unit.GeofenceUnit.update`'s arguments, the estimate's fields among them."""
    if not (position_valid and estimate_age_s <= FRESH_ESTIMATE_AGE_S):
        return UNIT, False, NOT_NEEDED
    recovered = U[MODE] != U[MONITOR_MODE]
    if not recovered and not abs(alt - U[DENSITY_ALT]) < DENSITY_REFRESH_M:  # (NaN: never scaled)
        return UNIT, False, NOT_NEEDED
    if not return_assured(wind_e, wind_n, U[RETURN_ALLOWANCE], U[RETURN_LIMIT]):
        return UNIT, False, NOT_NEEDED
    allowance = allowance_in_use_mps(
        U[ESTIMATED_TURBULENCE] != 0.0, turbulence_sigma_mps, U[FORECAST_SIGMA], U[TURBULENCE_K], U[GUST],
        U[FORECAST_ALLOWANCE],
    )  # fmt: skip
    latency = latency_s(dt_s, estimate_age_s)
    k_sigma, extra = U[K_SIGMA], U[EXTRA]
    hu, v_unc = k_sigma * sigma_h_m + extra, k_sigma * sigma_v_m + extra
    skip_time_s = 2.0 * U[REACTION_S] + latency
    ground_speed = hypot(ve, vn)
    h = agl if U[AGL] != 0.0 else alt
    has_target = False
    target_e = target_n = 0.0
    if U[MULTIROTOR] == 0.0:  # the roll-out target of the estimate's cell, if the unit has it cached
        has_target, target_e, target_n = cached_target(U, e, n)
        if not has_target:  # not needed far from everything; else the unit finds it (a route search)
            far_only = far_from_everything(
                F, L, V, e, n, h, ground_speed, ve, vn, vu, wind_e, wind_n, allowance, skip_time_s, hu, v_unc, g
            )[0]  # fmt: skip
            if not far_only:
                return NEED_TARGET, False, NOT_NEEDED
            return _pass(U, recovered, t_s), True, NOT_NEEDED
    far, r = monitor_margins(
        F, L, V, e, n, h, ground_speed, ve, vn, vu, wind_e, wind_n, allowance, skip_time_s, hu, v_unc, latency, roll,
        has_target, target_e, target_n, g,
    )  # fmt: skip
    if not far and activates(r[0], on_ground, ground_speed):
        return UNIT, False, r  # an activation: the unit starts its override
    return _pass(U, recovered, t_s), far, r


@jitable
def record_pass(
    U: np.ndarray, H: np.ndarray, t_s: float, est: tuple, on_ground: bool, dt_s: float, wind_e: float, wind_n: float,
    sigma_h_m: float, sigma_v_m: float, estimate_age_s: float, turbulence_sigma_mps: float, far: bool,
    activation_m: float, has_margins: bool, margins: tuple, new_horizon: bool, horizon: np.ndarray,
) -> None:  # fmt: skip
    """Keep what a step the unit did not answer itself changes in it (a pass :func:`monitor_pass` let through, or
    an override step :func:`override_pass` took), for it to take in later
    (:meth:`~geofence.unit.geofence_unit.GeofenceUnit.take_in_passes`): the estimate in the ring ``H`` (the unit's history of the
    last seconds), the inputs it keeps, whether the skip shortcut held (``far``), the activation margin (inf: far,
    NaN: not needed), the margins when the step computed them (``has_margins``), the fusion horizon when it moved
    (``horizon``: its fields)."""
    row = int(U[RING_NEXT])
    for k in range(15):
        H[row, k] = est[k]
    H[row, 15] = on_ground
    U[RING_NEXT] = row + 1 if row + 1 < H.shape[0] else 0
    U[PASSES] += 1.0
    U[LAST_T] = t_s
    U[LATENCY] = latency_s(dt_s, estimate_age_s)
    U[WIND_E], U[WIND_N], U[TURBULENCE_EST], U[SIGMA_V] = wind_e, wind_n, turbulence_sigma_mps, sigma_v_m
    if math.isfinite(sigma_h_m):
        U[SIGMA_H] = sigma_h_m
    U[FAR] = far
    U[ACTIVATION] = activation_m
    if has_margins:
        U[HAS_MARGINS], U[MARGINS_E], U[MARGINS_N] = 1.0, est[4], est[5]
        m = MARGINS0  # (one by one: two of the fields are ints)
        U[m], U[m + 1], U[m + 2], U[m + 3], U[m + 4], U[m + 5] = (
            margins[0],
            margins[1],
            margins[2],
            margins[3],
            margins[4],
            margins[5],
        )
        U[m + 6], U[m + 7], U[m + 8], U[m + 9], U[m + 10] = margins[6], margins[7], margins[8], margins[9], margins[10]
        U[m + 11], U[m + 12], U[m + 13], U[m + 14] = margins[11], margins[12], margins[13], margins[14]
        U[m + 15], U[m + 16], U[m + 17] = margins[15], margins[16], margins[17]
    if new_horizon:
        U[HORIZON_MOVED] = 1.0
        for k in range(5):
            U[HORIZON0 + k] = horizon[k]


@compiled
def override_pass(
    U: np.ndarray, F: np.ndarray, L: np.ndarray, V: np.ndarray, R: np.ndarray, P: np.ndarray, Q: np.ndarray,
    K: np.ndarray, t_s: float, dt_s: float, alt: float, e: float, n: float, agl: float, ve: float, vn: float,
    vu: float, roll: float, yaw: float, airspeed: float, wind_e: float, wind_n: float, position_valid: bool,
    sigma_h_m: float, sigma_v_m: float, estimate_age_s: float, turbulence_sigma_mps: float, g: float,
) -> tuple[int, float, float, float, float, bool, tuple[float, float, float, float, int, float, float, float, float, float, int, float, float, float, float, float, float, float]]:  # fmt: skip
    """``(answer, roll, pitch, throttle, activation margin, has margins, margins)`` of a fixed-wing override's
    step: :data:`OVERRIDE_STEP` and the sticks of :meth:`~geofence.recovery.guidance.FixedWingRecovery.sticks` (its compiled
    step :data:`~geofence.recovery.guidance.fixed_wing_step` on the arrays ``R, P, Q, K`` of
    :meth:`~geofence.recovery.guidance.FixedWingRecovery.compiled_step`; the recovery's state moves on in ``U``), or
    :data:`UNIT` (a stale or lost position, a wind beyond authority, a route the compiled step does not answer).
    Within the minimum override period the margins are not needed (activation NaN, ``has margins`` false); after
    it they are computed (``F, L, V``: the compiled margins' tables and envelope terms, the roll-out target from
    those packed in ``U``: :data:`NEED_TARGET` where it is not), and a step that re-activates (still outside) or
    may hand back is the unit's (:data:`UNIT`): :meth:`~geofence.unit.geofence_unit.GeofenceUnit.update`'s path for an override
    step, the same tests in its order."""
    if not (position_valid and estimate_age_s <= FRESH_ESTIMATE_AGE_S):
        return UNIT, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED
    if not return_assured(wind_e, wind_n, U[RETURN_ALLOWANCE], U[RETURN_LIMIT]):
        return UNIT, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED
    h = agl if U[AGL] != 0.0 else alt
    activation = math.nan  # (not needed, nor computed, until the minimum override has passed)
    has_margins = False
    r = NOT_NEEDED
    if not t_s - U[PERIOD_START] < U[MIN_OVERRIDE]:
        has_target, target_e, target_n = cached_target(U, e, n)
        if not has_target:
            return NEED_TARGET, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED
        k_sigma, extra = U[K_SIGMA], U[EXTRA]
        allowance = allowance_in_use_mps(
            U[ESTIMATED_TURBULENCE] != 0.0, turbulence_sigma_mps, U[FORECAST_SIGMA], U[TURBULENCE_K], U[GUST],
            U[FORECAST_ALLOWANCE],
        )  # fmt: skip
        latency = latency_s(dt_s, estimate_age_s)
        r = margins(
            F, L, V, e, n, h, ve, vn, vu, wind_e, wind_n, k_sigma * sigma_h_m + extra, k_sigma * sigma_v_m + extra,
            latency, roll, allowance, True, target_e, target_n, g, math.nan,
        )  # fmt: skip
        if outside(r[LATERAL_MARGIN_FIELD], r[CEILING_MARGIN_FIELD], r[FLOOR_MARGIN_FIELD]):
            return UNIT, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED  # still outside: the unit re-activates
        if not no_hand_back(U, V, r, e, n, h, latency, sigma_v_m):
            return UNIT, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED  # the unit's hand-back test
        activation, has_margins = r[ACTIVATION_FIELD], True
    turning = U[TURNING] != 0.0
    throttle = U[TURN_THROTTLE] if turning else U[THROTTLE]
    thr, c_roll, c_pitch, progress, turning, turned, last_yaw = fixed_wing_step(
        R, P, Q, K, U[PROGRESS], U[THR], U[CLEARANCE], e, n, ve, vn, yaw, airspeed, hypot(ve, vn), h, wind_e, wind_n,
        turning, U[TURNED], U[LAST_YAW],
    )  # fmt: skip
    if not thr > 0.0:
        return UNIT, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED
    U[PROGRESS], U[TURNING], U[TURNED], U[LAST_YAW] = progress, turning, turned, last_yaw
    U[RECOVERY_MOVED] = 1.0
    return OVERRIDE_STEP, c_roll, c_pitch, throttle, activation, has_margins, r


@jitable
def no_hand_back(
    U: np.ndarray, V: np.ndarray, r: tuple, e: float, n: float, h: float, latency: float, sigma_v_m: float
) -> bool:  # fmt: skip
    """Sure that a predictive override's :func:`hand_back` on these margins (the hysteresis of
    :func:`vertical_handback_m`) neither hands back nor clears its climb back (else the unit answers the step)."""
    hysteresis = vertical_handback_m(
        U[VERTICAL_HYSTERESIS], U[GOAL_H], U[CEILING_M], U[FLOOR_M], U[REACTION_S] + latency,
        V[TERM_VERTICAL_ACCEL], V[TERM_MAX_CLIMB], V[TERM_MAX_DESCENT], U[K_SIGMA] * sigma_v_m + U[EXTRA],
    )  # fmt: skip
    climbed, ok = hand_back(
        U[CLIMB_BACK], h, r[VERTICAL_ACTIVATION_FIELD] >= hysteresis, r[LATERAL_ACTIVATION_FIELD], r[CLOSING_FIELD],
        U[HANDBACK_MARGIN], hypot(U[RECOVERY_E] - e, U[RECOVERY_N] - n), U[RECOVERY_RADIUS],
    )  # fmt: skip
    return not climbed and not ok


@jitable
def vertical_handback_m(
    hysteresis_m: float, goal_h_m: float, ceiling_m: float, floor_m: float, reaction_s: float, accel_mps2: float,
    max_climb_mps: float, max_descent_mps: float, uncertainty_m: float,
) -> float:  # fmt: skip
    """The vertical hand-back hysteresis an override's goal height allows, m (see
    :meth:`geofence.unit.geofence_unit.GeofenceUnit._vertical_handback_at_goal_m`): ``hysteresis_m``, or where the goal
    ``goal_h_m`` is short of the band (NaN: it is not) half the vertical activation margin at rest there when that
    is less (``floor_m`` NaN: none; ``reaction_s``: with the latency; ``uncertainty_m``: ``k·σ_v + extra``)."""
    if not math.isfinite(goal_h_m):
        return hysteresis_m
    rest = ceiling_m - goal_h_m - vertical_arrest_distance_m(0.0, reaction_s, accel_mps2, max_climb_mps)
    if floor_m == floor_m:  # (not NaN)
        below = goal_h_m - floor_m - vertical_arrest_distance_m(0.0, reaction_s, accel_mps2, max_descent_mps)
        rest = below if below < rest else rest  # (min(rest, below))
    rest -= uncertainty_m
    if not rest > 0.0:
        return hysteresis_m
    half = 0.5 * rest
    return half if half < hysteresis_m else hysteresis_m  # (min(hysteresis_m, half))
