"""The geofence unit's steps on arrays: :meth:`geofence.unit.geofence_unit.GeofenceUnit.update` while it passes the pilot's
sticks through, and while a fixed-wing override flies, as functions a compiled per-step kernel calls.

One question each. :func:`monitor_pass`: given this step's estimate (the sensing chain's numbers), does a
predictive unit that monitors (``MONITOR`` or ``RECOVERED``) keep passing the sticks through, and with which
margins? The answer is :data:`PASS` (and the margins), :data:`PASS_HANDBACK` (pass, and ``RECOVERED``'s hold is
over: back to ``MONITOR``), :data:`NEED_TARGET` (near a boundary, a fixed-wing's roll-out target for this cell is
not in the record's window on the unit's cache: the unit finds it, and the step is asked again) or :data:`UNIT`: anything else (an activation, a
stale or lost position, an envelope to re-scale to the air density, a wind beyond authority), which the unit's
own :meth:`~geofence.unit.geofence_unit.GeofenceUnit.update` then answers from the same estimate.
:func:`override_pass`: which sticks does a fixed-wing override send at this step (:data:`OVERRIDE_STEP`; after
its minimum override period, with its margins: it is not outside and may not hand back yet), or must the unit
answer (:data:`UNIT`: a re-activation, a possible hand-back, a lost position, ...; :data:`NEED_TARGET` as
above)?

The unit's per-step state is one record, :data:`UNIT_STATE` (named float64 fields over float memory, the pattern
of :mod:`geofence.estimation.estimator`), which the unit owns
(:attr:`~geofence.unit.geofence_unit.GeofenceUnit.memory`) and whose fields its attributes are: the passes read
it and :func:`record_pass` writes in it what each step taken so changes, as ``update`` would, so nothing is
packed or taken back. Only what lives in the unit's Python objects is handed over, by name: the estimates' ring,
the last margins and the fusion horizon (:meth:`~geofence.unit.geofence_unit.GeofenceUnit.take_in_ring`), a
fixed-wing recovery's step state (:meth:`~geofence.unit.geofence_unit.GeofenceUnit.override_arrays`).
``update`` is the reference: the same tests in the same order on the same numbers
(``tests/test_flight_step.py`` flies flights both ways and compares their bytes).

It also owns the few constants both read: when an estimate is fresh, when the envelope is re-scaled, when a
vehicle on the ground is sitting, the hand-back hold and the roll-out target cache's cells; the unit's modes
(:class:`Mode`); and the formula of the vertical hand-back hysteresis at an override's goal
(:func:`vertical_handback_m`).
"""

from __future__ import annotations

import math
from enum import IntEnum
from math import hypot
from typing import Any

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
"""The margins need the roll-out target of the estimate's cell and it is not in the record's window: the unit finds it
(:meth:`~geofence.unit.geofence_unit.GeofenceUnit.find_rollout_target`, a route search where it has none cached), and the caller
asks the same step again from the same estimate (nothing was kept or recorded)."""

TARGET_CELLS = 2
"""The record's window on the unit's roll-out target cache reaches this many cells round its centre cell (5 x 5
cells): a vehicle crossing into a neighbouring cell still finds its target without the unit (at 30 m/s a 10 m
cell lasts 13 steps)."""
TARGET_SIDE = 2 * TARGET_CELLS + 1
MARGIN_FIELDS = 18
"""The margins' fields (:func:`geofence.margins.kernel.margins`' tuple)."""


class Mode(IntEnum):
    """The unit's state machine (see :mod:`geofence.unit.geofence_unit`); the record keeps it as its number."""

    MONITOR = 0
    OVERRIDE = 1
    RECOVERED = 2
    LAND_IN_GAP = 3
    TERMINATE = 4


MONITOR_NUMBER = float(Mode.MONITOR)
"""``MONITOR`` as the record's ``mode`` holds it (a completed hand-back is recorded as ``MONITOR``)."""


def float_record(*fields: str | tuple[str, tuple[int, ...]]) -> np.dtype:
    """A record dtype of float64 fields (a ``(name, shape)`` pair: an array of floats), viewable over float memory."""
    spec = [(f, np.float64) if isinstance(f, str) else (f[0], np.float64, f[1]) for f in fields]
    return np.dtype((np.record, spec))


UNIT_STATE = float_record(
    # the configuration's and the fence's numbers (set once, as the unit is built)
    "k_sigma", "extra_margin_m", "forecast_allowance_mps", "estimated_turbulence", "forecast_sigma_mps",
    "turbulence_k_sigma", "gust_mps", "agl", "min_override_s", "handback_margin_m", "recovery_e_m", "recovery_n_m",
    "recovery_radius_m", "vertical_handback_m", "ceiling_m", "floor_m",  # (floor NaN: none)
    # the envelope's (set as it is scaled to the air density; density_alt_m NaN: never)
    "reaction_time_s", "return_allowance_mps", "return_limit_mps", "multirotor", "density_alt_m",
    # the unit's state, which update and the passes both read and write
    "mode", "mode_since_s", "latency_s", "turbulence_est_mps", "sigma_h_m", "sigma_v_m",
    "position_valid", "strong_wind_since_s", "skipped_last", "activation_margin_m",  # (strong wind NaN: none)
    "period_start_s", "climb_back_m", "goal_h_m", "goal_short_of_band",  # the override's (climb back NaN: none)
    # a window on the roll-out target cache: (has, east, north) of the cells round (cell_e, cell_n), south first
    "has_targets", "cell_e", "cell_n", ("targets", (TARGET_SIDE, TARGET_SIDE, 3)),
    # the hand-over to the unit's Python objects (GeofenceUnit.take_in_ring): the ring of estimates' bookkeeping,
    # the wind estimate (the list the unit shares with its guidance laws), the last margins computed (for the
    # fence's memo and ShiftResult) and the fusion horizon
    "ring_next", "ring_rows", "last_t_s", ("wind_en_mps", (2,)), "has_margins", "margins_e_m", "margins_n_m", ("margins", (MARGIN_FIELDS,)),
    "horizon_moved", ("horizon", (5,)),
    # the hand-over with a fixed-wing recovery's compiled step (GeofenceUnit.override_arrays)
    "thr", "clearance_m", "turn_throttle", "throttle", "progress_m", "turning", "turned_rad", "last_yaw_rad",
    "recovery_moved",
)  # fmt: skip
"""The unit's per-step state, one record over float memory (every field float64: a flag is 0 or 1, the mode its
number) that :class:`~geofence.unit.geofence_unit.GeofenceUnit` owns (:attr:`~geofence.unit.geofence_unit.GeofenceUnit.memory`):
its attributes that the passes read or write are this record's fields, so the compiled passes and ``update``
read and write the same storage."""

UNIT_SIZE = UNIT_STATE.itemsize // 8
"""Float64 slots of the unit's record."""


def field_slot(name: str) -> int:
    """The first float slot of a :data:`UNIT_STATE` field."""
    fields = UNIT_STATE.fields
    assert fields is not None
    return int(fields[name][1]) // 8


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
def window_cell(u: Any, e: float, n: float) -> tuple[bool, int, int]:
    """``(in the window, row, column)``: where the cell of (e, n) is in the record ``u``'s window on the roll-out
    target cache (:data:`TARGET_CELLS` round the cell ``cell_e, cell_n``; not in it where the window is empty)."""
    if u.has_targets != 0.0:
        cell_e, cell_n = rollout_cell(e, n)
        de, dn = cell_e - u.cell_e, cell_n - u.cell_n
        if abs(de) <= TARGET_CELLS and abs(dn) <= TARGET_CELLS:
            return True, int(dn + TARGET_CELLS), int(de + TARGET_CELLS)
    return False, 0, 0


@jitable
def cached_target(u: Any, e: float, n: float) -> tuple[bool, float, float]:
    """``(found, east, north)``: the roll-out target of the cell of (e, n) in the record ``u``'s window
    (:func:`window_cell`; not found: the unit finds it)."""
    inside, i, j = window_cell(u, e, n)
    if inside and u.targets[i, j, 0] != 0.0:
        return True, u.targets[i, j, 1], u.targets[i, j, 2]
    return False, 0.0, 0.0


@jitable
def goal_short_of_band_h_m(goal_h_m: float, short_of_band: bool) -> float:
    """The override's goal height where it is short of the band (an explicit recovery height, or the middle of a
    band too thin for the goal's room), else NaN: a goal in the band leaves the hysteresis and the settling room
    by construction."""
    return goal_h_m if math.isfinite(goal_h_m) and short_of_band else math.nan


@jitable
def _pass(u: Any, recovered: bool, t_s: float) -> int:
    """A pass's answer: :data:`PASS_HANDBACK` once ``RECOVERED`` has held (:func:`hold_over`), else :data:`PASS`."""
    return PASS_HANDBACK if hold_over(recovered, t_s, u.mode_since_s) else PASS


@jitable
def _allowance(u: Any, turbulence_sigma_mps: float) -> float:
    """The wind allowance in use (:func:`geofence.unit.config.allowance_in_use_mps`) on the record's numbers."""
    return allowance_in_use_mps(
        u.estimated_turbulence != 0.0, turbulence_sigma_mps, u.forecast_sigma_mps, u.turbulence_k_sigma, u.gust_mps,
        u.forecast_allowance_mps,
    )  # fmt: skip


@compiled
def monitor_pass(
    U: np.ndarray, F: np.ndarray, L: np.ndarray, V: np.ndarray, t_s: float, dt_s: float, alt: float, e: float,
    n: float, agl: float, ve: float, vn: float, vu: float, roll: float, on_ground: bool, wind_e: float, wind_n: float,
    position_valid: bool, sigma_h_m: float, sigma_v_m: float, estimate_age_s: float, turbulence_sigma_mps: float,
    g: float,
) -> tuple[int, bool, tuple[float, float, float, float, int, float, float, float, float, float, int, float, float, float, float, float, float, float]]:  # fmt: skip
    """``(answer, far, margins)`` of a monitoring step (see the module): ``far`` when the skip shortcut held
    (margins not computed), else the margins' fields (:func:`geofence.margins.kernel.monitor_margins`). ``U``: the
    unit's record's memory (:data:`UNIT_STATE`, read only); ``F, L, V``: its compiled margins' tables and envelope
    terms; the rest are :meth:`~geofence.unit.geofence_unit.GeofenceUnit.update`'s arguments, the estimate's fields
    among them."""
    u = U.view(UNIT_STATE)[0]
    if not (position_valid and estimate_age_s <= FRESH_ESTIMATE_AGE_S):
        return UNIT, False, NOT_NEEDED
    recovered = u.mode != MONITOR_NUMBER
    if not recovered and not abs(alt - u.density_alt_m) < DENSITY_REFRESH_M:  # (NaN: never scaled)
        return UNIT, False, NOT_NEEDED
    if not return_assured(wind_e, wind_n, u.return_allowance_mps, u.return_limit_mps):
        return UNIT, False, NOT_NEEDED
    allowance = _allowance(u, turbulence_sigma_mps)
    latency = latency_s(dt_s, estimate_age_s)
    k_sigma, extra = u.k_sigma, u.extra_margin_m
    hu, v_unc = k_sigma * sigma_h_m + extra, k_sigma * sigma_v_m + extra
    skip_time_s = 2.0 * u.reaction_time_s + latency
    ground_speed = hypot(ve, vn)
    h = agl if u.agl != 0.0 else alt
    has_target = False
    target_e = target_n = 0.0
    if u.multirotor == 0.0:  # the roll-out target of the estimate's cell, if the unit has it cached
        has_target, target_e, target_n = cached_target(u, e, n)
        if not has_target:  # not needed far from everything; else the unit finds it (a route search)
            far_only = far_from_everything(
                F, L, V, e, n, h, ground_speed, ve, vn, vu, wind_e, wind_n, allowance, skip_time_s, hu, v_unc, g
            )[0]  # fmt: skip
            if not far_only:
                return NEED_TARGET, False, NOT_NEEDED
            return _pass(u, recovered, t_s), True, NOT_NEEDED
    far, r = monitor_margins(
        F, L, V, e, n, h, ground_speed, ve, vn, vu, wind_e, wind_n, allowance, skip_time_s, hu, v_unc, latency, roll,
        has_target, target_e, target_n, g,
    )  # fmt: skip
    if not far and activates(r[0], on_ground, ground_speed):
        return UNIT, False, r  # an activation: the unit starts its override
    return _pass(u, recovered, t_s), far, r


@jitable
def record_pass(
    U: np.ndarray, H: np.ndarray, t_s: float, est: tuple, on_ground: bool, dt_s: float, wind_e: float, wind_n: float,
    sigma_h_m: float, sigma_v_m: float, estimate_age_s: float, turbulence_sigma_mps: float, far: bool,
    activation_m: float, has_margins: bool, margins: tuple, new_horizon: bool, horizon: np.ndarray,
) -> None:  # fmt: skip
    """What a step the unit did not answer itself changes in it (a pass :func:`monitor_pass` let through, or an
    override step :func:`override_pass` took), written in its record (``U``'s memory) as :meth:`update` would: the
    inputs it keeps, whether the skip shortcut held (``far``), the activation margin (inf: far, NaN: not needed);
    and for the hand-over to its Python objects (:meth:`~geofence.unit.geofence_unit.GeofenceUnit.take_in_ring`)
    the estimate in the ring ``H`` (the unit's history of the last seconds), the margins when the step computed
    them (``has_margins``), the fusion horizon when it moved (``horizon``: its fields)."""
    u = U.view(UNIT_STATE)[0]
    row = int(u.ring_next)
    for k in range(15):
        H[row, k] = est[k]
    H[row, 15] = on_ground
    u.ring_next = row + 1 if row + 1 < H.shape[0] else 0
    u.ring_rows += 1.0
    u.last_t_s = t_s
    u.latency_s = latency_s(dt_s, estimate_age_s)
    u.wind_en_mps[0], u.wind_en_mps[1] = wind_e, wind_n
    u.turbulence_est_mps, u.sigma_v_m = turbulence_sigma_mps, sigma_v_m
    if math.isfinite(sigma_h_m):
        u.sigma_h_m = sigma_h_m
    u.position_valid, u.strong_wind_since_s = 1.0, math.nan  # (a pass: a fresh position, the return assured)
    u.skipped_last = far
    u.activation_margin_m = activation_m
    if has_margins:
        u.has_margins, u.margins_e_m, u.margins_n_m = 1.0, est[4], est[5]
        _keep_margins(u.margins, margins)
    if new_horizon:
        u.horizon_moved = 1.0
        for k in range(5):
            u.horizon[k] = horizon[k]


@jitable
def _keep_margins(m: np.ndarray, r: tuple) -> None:
    """The margins' fields ``r`` into the record's ``margins`` (one by one: two of the fields are ints)."""
    m[0], m[1], m[2], m[3], m[4], m[5] = r[0], r[1], r[2], r[3], r[4], r[5]
    m[6], m[7], m[8], m[9], m[10], m[11] = r[6], r[7], r[8], r[9], r[10], r[11]
    m[12], m[13], m[14], m[15], m[16], m[17] = r[12], r[13], r[14], r[15], r[16], r[17]


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
    :meth:`~geofence.recovery.guidance.FixedWingRecovery.compiled_step`; the recovery's state moves on in the record
    ``U``), or :data:`UNIT` (a stale or lost position, a wind beyond authority, a route the compiled step does not
    answer). Within the minimum override period the margins are not needed (activation NaN, ``has margins``
    false); after it they are computed (``F, L, V``: the compiled margins' tables and envelope terms, the roll-out
    target from the record's window: :data:`NEED_TARGET` where it is not), and a step that re-activates (still
    outside) or may hand back is the unit's (:data:`UNIT`): :meth:`~geofence.unit.geofence_unit.GeofenceUnit.update`'s
    path for an override step, the same tests in its order."""
    u = U.view(UNIT_STATE)[0]
    if not (position_valid and estimate_age_s <= FRESH_ESTIMATE_AGE_S):
        return UNIT, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED
    if not return_assured(wind_e, wind_n, u.return_allowance_mps, u.return_limit_mps):
        return UNIT, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED
    h = agl if u.agl != 0.0 else alt
    activation = math.nan  # (not needed, nor computed, until the minimum override has passed)
    has_margins = False
    r = NOT_NEEDED
    if not t_s - u.period_start_s < u.min_override_s:
        has_target, target_e, target_n = cached_target(u, e, n)
        if not has_target:
            return NEED_TARGET, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED
        k_sigma, extra = u.k_sigma, u.extra_margin_m
        allowance = _allowance(u, turbulence_sigma_mps)
        latency = latency_s(dt_s, estimate_age_s)
        r = margins(
            F, L, V, e, n, h, ve, vn, vu, wind_e, wind_n, k_sigma * sigma_h_m + extra, k_sigma * sigma_v_m + extra,
            latency, roll, allowance, True, target_e, target_n, g, math.nan,
        )  # fmt: skip
        if outside(r[LATERAL_MARGIN_FIELD], r[CEILING_MARGIN_FIELD], r[FLOOR_MARGIN_FIELD]):
            return UNIT, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED  # still outside: the unit re-activates
        if not no_hand_back(u, V, r, e, n, h, latency, sigma_v_m):
            return UNIT, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED  # the unit's hand-back test
        activation, has_margins = r[ACTIVATION_FIELD], True
    turning = u.turning != 0.0
    throttle = u.turn_throttle if turning else u.throttle
    thr, c_roll, c_pitch, progress, turning, turned, last_yaw = fixed_wing_step(
        R, P, Q, K, u.progress_m, u.thr, u.clearance_m, e, n, ve, vn, yaw, airspeed, hypot(ve, vn), h, wind_e, wind_n,
        turning, u.turned_rad, u.last_yaw_rad,
    )  # fmt: skip
    if not thr > 0.0:
        return UNIT, 0.0, 0.0, 0.0, math.nan, False, NOT_NEEDED
    u.progress_m, u.turning, u.turned_rad, u.last_yaw_rad = progress, turning, turned, last_yaw
    u.recovery_moved = 1.0
    return OVERRIDE_STEP, c_roll, c_pitch, throttle, activation, has_margins, r


@jitable
def no_hand_back(
    u: Any, V: np.ndarray, r: tuple, e: float, n: float, h: float, latency: float, sigma_v_m: float
) -> bool:  # fmt: skip
    """Sure that a predictive override's :func:`hand_back` on these margins (the hysteresis of
    :func:`vertical_handback_m`; ``u``: the unit's record) neither hands back nor clears its climb back (else the
    unit answers the step)."""
    hysteresis = vertical_handback_m(
        u.vertical_handback_m, goal_short_of_band_h_m(u.goal_h_m, u.goal_short_of_band != 0.0), u.ceiling_m,
        u.floor_m, u.reaction_time_s + latency, V[TERM_VERTICAL_ACCEL], V[TERM_MAX_CLIMB], V[TERM_MAX_DESCENT],
        u.k_sigma * sigma_v_m + u.extra_margin_m,
    )  # fmt: skip
    climbed, ok = hand_back(
        u.climb_back_m, h, r[VERTICAL_ACTIVATION_FIELD] >= hysteresis, r[LATERAL_ACTIVATION_FIELD], r[CLOSING_FIELD],
        u.handback_margin_m, hypot(u.recovery_e_m - e, u.recovery_n_m - n), u.recovery_radius_m,
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
