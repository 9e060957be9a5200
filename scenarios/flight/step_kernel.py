"""A step of the closed loop in one compiled call: the pilot's law, the wind field, the unit's sensing chain, its
monitoring step (or a fixed-wing override's step) and the recorder's row.

While the geofence unit monitors (it passes the pilot's sticks through, most of a flight), the runner's step is
one call of :func:`flight_step` instead of five calls and the Python between them: it flies the pilot's law where
it has a compiled form (:func:`scenarios.flight.pilots.law_kernel.law_sticks`; else the pilot's sticks are passed
in), samples the wind (:func:`wind.field_kernel.wind_sample`), runs the unit's sensors, estimator and wind
estimator (:func:`scenarios.flight.sensing.sense_step`), asks the unit's monitoring step
(:func:`geofence.unit.passes.monitor_pass`) and, on a pass, writes the step's row
(:func:`scenarios.flight.recorder.write_row`). While a fixed-wing override flies,
:func:`override_flight_step` does the same with the override's step (:func:`geofence.unit.passes.override_pass`).
Where a fixed-wing's roll-out target for the estimate's cell is not in the unit's record
(:data:`~geofence.unit.passes.NEED_TARGET`), the unit finds it and the rest of the same step is asked again
(:func:`flight_step_again`, :func:`override_flight_step_again`: from the estimate the first call left, the sensing
chain not stepped twice). Anything else (an activation, a hand-back, a position lost, ...) is answered by the
unit's own :meth:`~geofence.unit.geofence_unit.GeofenceUnit.update` from the same estimate, and the runner records that row
itself (:func:`unit_step`, the step the runner takes where no compiled call can: the same call). Compiled where
numba is, the same functions interpreted where it is not.

:class:`FlightStep` holds the arrays (the unit's own record among them, read and written in place), asks
:meth:`~geofence.unit.geofence_unit.GeofenceUnit.monitor_ready` and
:meth:`~geofence.unit.geofence_unit.GeofenceUnit.override_ready` after every step the unit took itself, and hands
the steps taken for it over to the unit's Python objects (:meth:`~geofence.unit.geofence_unit.GeofenceUnit.take_in_ring`:
their estimates' ring) before it answers one again.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

import numpy as np

from geofence import jit
from geofence.interface import FixState, StickCommand, VehicleState
from geofence.jit import jitable
from geofence.physics.dynamics import G_MPS2
from geofence.unit.compliance import watch_step
from geofence.unit.geofence_unit import GeofenceUnit
from geofence.unit.passes import (
    MONITOR_NUMBER,
    NEED_TARGET,
    OVERRIDE_STEP,
    PASS,
    PASS_HANDBACK,
    RING_COLUMNS,
    UNIT,
    UNIT_STATE,
    float_record,
    monitor_pass,
    override_pass,
    record_pass,
)
from scenarios.flight.pilots.law_kernel import GIVEN, law_array, law_kind, law_sticks
from scenarios.flight.recorder import Recorder, write_row
from scenarios.flight.sensing import HORIZON_IN_P, GeofenceSensing, Sensed, sense_step
from wind.field_kernel import WindArrays, wind_sample

WIND_LOW, SENSE_LOW, WATCHED, NOT_FOLLOWING = 1, 2, 4, 8
"""The flags a step returns: the wind field's noise pool runs low, the sensors' pools run low, the step's compliance
watch ran (:func:`geofence.unit.compliance.watch_step`, on the sticks sent), and it found the vehicle not following
(the unit then decides on a termination: :meth:`~geofence.unit.geofence_unit.GeofenceUnit.not_following`)."""
_H0, _H1 = HORIZON_IN_P.start, HORIZON_IN_P.stop
_new_tuple = tuple.__new__
_NO_STICKS = (0.0, 0.0, 0.0, 0.0)


class Truth(NamedTuple):
    """The truth's fields a step reads and records, in the order the entry points take them."""

    t_s: float
    lat_deg: float
    lon_deg: float
    alt_m: float
    east_m: float
    north_m: float
    up_m: float
    agl_m: float
    v_east_mps: float
    v_north_mps: float
    v_up_mps: float
    airspeed_mps: float
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    on_ground: bool


class SensedStep(NamedTuple):
    """The sensing chain's outputs at a step (:func:`scenarios.flight.sensing.sense_step`'s, as the unit takes them)."""

    est: tuple
    """The estimate's 15 fields (:class:`~geofence.interface.VehicleState`'s order, ``on_ground`` apart)."""
    wind_e_mps: float
    wind_n_mps: float
    position_valid: bool
    sigma_h_m: float
    sigma_v_m: float
    new_horizon: bool
    data_age_s: float
    turbulence_sigma_mps: float


STEP_OUT = float_record(("est", (15,)), *SensedStep._fields[1:])
"""What a step the unit answers itself needs (:data:`~geofence.unit.passes.UNIT`, or after
:data:`~geofence.unit.passes.NEED_TARGET`), a record over the float array ``Out``: :class:`SensedStep`'s fields in
order (a flag 0 or 1)."""


def _flight_step(
    FZ: np.ndarray, wind_pool: np.ndarray, GX: np.ndarray, P: np.ndarray, pools: np.ndarray, idx: np.ndarray,
    F: np.ndarray, L: np.ndarray, V: np.ndarray, U: np.ndarray, H: np.ndarray, W: np.ndarray, T: np.ndarray,
    Out: np.ndarray, A: np.ndarray, row: float, dt_s: float, t: float, lat: float, lon: float, alt: float, e: float,
    n: float, up: float, agl: float, ve: float, vn: float, vu: float, airspeed: float, roll: float, pitch: float,
    yaw: float, on_ground: bool, p_roll: float, p_pitch: float, p_yaw: float, p_throttle: float, item: float,
) -> tuple[int, float, float, float, int, float, float, float, float]:  # fmt: skip
    """One monitoring step from the truth's fields and the pilot's: ``(the unit's answer, the wind sampled (east,
    north, up), flags, the pilot's sticks (roll, pitch, yaw, throttle))`` (:func:`geofence.unit.passes.monitor_pass`'s
    answer; the flags: :data:`WIND_LOW`, :data:`SENSE_LOW`, :data:`WATCHED`, :data:`NOT_FOLLOWING`). The pilot's
    sticks are its law's (:func:`scenarios.flight.pilots.law_kernel.law_sticks` on its law array ``A``), or where
    that has none this step, those passed in (``p_roll`` ...). On a pass the unit's record ``U`` and ring ``H`` keep
    it (:func:`geofence.unit.passes.record_pass`), row ``row`` of ``T`` records it and the compliance watch's record
    ``W`` (:attr:`GeofenceUnit.compliance`) watches the sticks passed on; else ``Out`` holds the step's
    estimate and what the unit's own step needs (:data:`STEP_OUT`), for the unit (:data:`UNIT`) or for
    :func:`_flight_step_again` once the roll-out target is found (:data:`NEED_TARGET`). The arrays: the wind
    field's (:meth:`WindArrays.arrays`), the sensing chain's (:meth:`GeofenceSensing.kernel_arrays`), the unit's
    margins tables and envelope terms (:meth:`GeofenceUnit.margins_tables`) and record (:attr:`GeofenceUnit.memory`)."""
    truth = Truth(t, lat, lon, alt, e, n, up, agl, ve, vn, vu, airspeed, roll, pitch, yaw, on_ground)
    pilot = _pilot_sticks(A, truth, (p_roll, p_pitch, p_yaw, p_throttle))
    wind, flags, sensed = _wind_and_sensing(FZ, wind_pool, GX, P, pools, idx, dt_s, truth)
    answer, watched = _monitor_rest((F, L, V), (U, H, W), T, Out, P[_H0:_H1], row, dt_s, item, truth, wind, sensed, pilot)
    return answer, wind[0], wind[1], wind[2], flags + watched, pilot[0], pilot[1], pilot[2], pilot[3]


@jitable
def _pilot_sticks(A: np.ndarray, truth: Truth, given: tuple) -> tuple[float, float, float, float]:
    """The pilot's sticks: its law's (:func:`scenarios.flight.pilots.law_kernel.law_sticks` on ``A``), or where that
    has none, those ``given``."""
    if law_kind(A) != GIVEN:
        return law_sticks(A, truth.v_east_mps, truth.v_north_mps, truth.yaw_rad, truth.up_m)
    return given


@jitable
def _monitor_rest(
    tables: tuple, memory: tuple, T: np.ndarray, Out: np.ndarray, horizon: np.ndarray, row: float, dt_s: float,
    item: float, truth: Truth, wind: tuple, sensed: SensedStep, pilot: tuple,
) -> tuple[int, int]:  # fmt: skip
    """A monitoring step after the wind and the sensing chain: ``(the unit's answer, the watch's flags)``, its pass
    kept, recorded and watched (or ``Out`` filled for the unit). ``tables``: the margins' ``(F, L, V)``;
    ``memory``: the unit's record, ring and watch ``(U, H, W)``; ``horizon``: the sensing chain's fusion horizon
    fields; ``wind``: the wind sampled (east, north, up); ``pilot``: the pilot's sticks."""
    F, L, V = tables
    U, H, W = memory
    s, est = sensed, sensed.est
    answer, far, r = monitor_pass(
        U, F, L, V, truth.t_s, dt_s, est[3], est[4], est[5], est[7], est[8], est[9], est[10], est[11],
        truth.on_ground, s.wind_e_mps, s.wind_n_mps, s.position_valid, s.sigma_h_m, s.sigma_v_m, s.data_age_s,
        s.turbulence_sigma_mps, G_MPS2,
    )  # fmt: skip
    if answer == UNIT or answer == NEED_TARGET:
        _for_the_unit(Out, sensed)
        return answer, 0
    _keep(U, H, horizon, dt_s, truth, sensed, far, r[0], not far, r)
    u = U.view(UNIT_STATE)[0]
    mode = u.mode if answer == PASS else MONITOR_NUMBER  # (a completed hand-back: MONITOR)
    _write(T, row, item, truth, wind, pilot, pilot, mode, sensed, r[0])
    since = u.mode_since_s if answer == PASS else truth.t_s  # (the hand-back's MONITOR starts now)
    return answer, _watch(W, dt_s, truth, sensed, False, since, pilot)


@jitable
def _watch(
    W: np.ndarray, dt_s: float, truth: Truth, sensed: SensedStep, commanding: bool, mode_since_s: float, cmd: tuple
) -> int:  # fmt: skip
    """The step's compliance watch (:func:`geofence.unit.compliance.watch_step` on the watch's record ``W``) on the
    sticks sent ``cmd`` (the unit's while ``commanding``, else the pilot's) and the step's estimate: its flags
    (:data:`WATCHED`, and :data:`NOT_FOLLOWING`)."""
    est = sensed.est
    missed = watch_step(
        W, truth.t_s, dt_s, commanding, mode_since_s, cmd[0], cmd[1], cmd[3], truth.on_ground, est[11], est[12],
        est[10],
    )  # fmt: skip
    return WATCHED + (NOT_FOLLOWING if missed else 0)


@jitable
def _keep(
    U: np.ndarray, H: np.ndarray, horizon: np.ndarray, dt_s: float, truth: Truth, sensed: SensedStep, far: bool,
    activation: float, has_margins: bool, r: tuple,
) -> None:  # fmt: skip
    """A step taken for the unit, kept in its record and ring (:func:`geofence.unit.passes.record_pass`)."""
    s = sensed
    record_pass(
        U, H, truth.t_s, s.est, truth.on_ground, dt_s, s.wind_e_mps, s.wind_n_mps, s.sigma_h_m, s.sigma_v_m,
        s.data_age_s, s.turbulence_sigma_mps, far, activation, has_margins, r, s.new_horizon, horizon,
    )  # fmt: skip


@jitable
def _write(
    T: np.ndarray, row: float, item: float, truth: Truth, wind: tuple, pilot: tuple, cmd: tuple, mode: float,
    sensed: SensedStep, activation: float,
) -> None:  # fmt: skip
    """Row ``row`` of ``T`` (:func:`scenarios.flight.recorder.write_row`): the truth, the wind sampled, the pilot's
    and the sent sticks (``cmd``), the mode, the mission item, the estimate and the activation margin."""
    x, est = truth, sensed.est
    write_row(
        T, int(row), x.t_s, x.lat_deg, x.lon_deg, x.alt_m, x.east_m, x.north_m, x.up_m, x.agl_m, x.v_east_mps,
        x.v_north_mps, x.v_up_mps, x.airspeed_mps, x.roll_rad, x.pitch_rad, x.yaw_rad, wind[0], wind[1], wind[2],
        pilot[0], pilot[1], pilot[2], pilot[3], cmd[0], cmd[1], cmd[2], cmd[3], mode, item, est[4], est[5], est[7],
        sensed.wind_e_mps, sensed.wind_n_mps, activation,
    )  # fmt: skip


@jitable
def _wind_and_sensing(
    FZ: np.ndarray, wind_pool: np.ndarray, GX: np.ndarray, P: np.ndarray, pools: np.ndarray, idx: np.ndarray,
    dt_s: float, truth: Truth,
) -> tuple:  # fmt: skip
    """Every step's start: the wind sampled at the truth, and the unit's sensing chain: ``((wind east, north, up),
    flags, the chain's outputs)``."""
    x = truth
    w_e, w_n, w_u, w_low = wind_sample(FZ, wind_pool, GX, x.t_s, x.east_m, x.north_m, x.agl_m, x.airspeed_mps)
    est, we, wn, valid, sigma_h, sigma_v, new_horizon, age, turbulence, s_low = sense_step(
        P, pools, idx, dt_s, x.t_s, x.lat_deg, x.lon_deg, x.alt_m, x.v_east_mps, x.v_north_mps, x.v_up_mps,
        x.airspeed_mps, x.roll_rad, x.pitch_rad, x.yaw_rad,
    )  # fmt: skip
    flags = (WIND_LOW if w_low else 0) + (SENSE_LOW if s_low else 0)
    return (w_e, w_n, w_u), flags, SensedStep(est, we, wn, valid, sigma_h, sigma_v, new_horizon, age, turbulence)


@jitable
def _for_the_unit(Out: np.ndarray, sensed: SensedStep) -> None:
    """What a step the unit answers itself needs, into ``Out`` (:data:`STEP_OUT`)."""
    s, o = sensed, Out.view(STEP_OUT)[0]
    for k in range(15):
        o.est[k] = s.est[k]
    o.wind_e_mps, o.wind_n_mps, o.position_valid = s.wind_e_mps, s.wind_n_mps, s.position_valid
    o.sigma_h_m, o.sigma_v_m = s.sigma_h_m, s.sigma_v_m
    o.new_horizon, o.data_age_s, o.turbulence_sigma_mps = s.new_horizon, s.data_age_s, s.turbulence_sigma_mps


@jitable
def _unit_inputs_in(Out: np.ndarray) -> SensedStep:
    """What :func:`_for_the_unit` wrote into ``Out``."""
    o = Out.view(STEP_OUT)[0]
    e = o.est
    est = (e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7], e[8], e[9], e[10], e[11], e[12], e[13], e[14])
    return SensedStep(
        est, o.wind_e_mps, o.wind_n_mps, o.position_valid != 0.0, o.sigma_h_m, o.sigma_v_m, o.new_horizon != 0.0,
        o.data_age_s, o.turbulence_sigma_mps,
    )  # fmt: skip


def _flight_step_again(
    P: np.ndarray, F: np.ndarray, L: np.ndarray, V: np.ndarray, U: np.ndarray, H: np.ndarray, W: np.ndarray,
    T: np.ndarray, Out: np.ndarray, row: float, dt_s: float, t: float, lat: float, lon: float, alt: float, e: float,
    n: float, up: float, agl: float, ve: float, vn: float, vu: float, airspeed: float, roll: float, pitch: float,
    yaw: float, on_ground: bool, w_e: float, w_n: float, w_u: float, p_roll: float, p_pitch: float, p_yaw: float,
    p_throttle: float, item: float,
) -> tuple[int, int, float, float, float, float]:  # fmt: skip
    """The same monitoring step asked again after :data:`~geofence.unit.passes.NEED_TARGET` (the unit found the
    roll-out target and shows it in its record ``U``): from the estimate in ``Out`` and the wind and the pilot's
    sticks the first call gave, ``(its answer, the watch's flags, the pilot's sticks)`` (the rest as
    :func:`_flight_step`'s)."""
    truth = Truth(t, lat, lon, alt, e, n, up, agl, ve, vn, vu, airspeed, roll, pitch, yaw, on_ground)
    pilot = (p_roll, p_pitch, p_yaw, p_throttle)
    answer, watched = _monitor_rest(
        (F, L, V), (U, H, W), T, Out, P[_H0:_H1], row, dt_s, item, truth, (w_e, w_n, w_u), _unit_inputs_in(Out),
        pilot,
    )  # fmt: skip
    return answer, watched, p_roll, p_pitch, p_yaw, p_throttle


def _override_flight_step(
    FZ: np.ndarray, wind_pool: np.ndarray, GX: np.ndarray, P: np.ndarray, pools: np.ndarray, idx: np.ndarray,
    F: np.ndarray, L: np.ndarray, V: np.ndarray, R: np.ndarray, PR: np.ndarray, QR: np.ndarray, K: np.ndarray,
    U: np.ndarray, H: np.ndarray, W: np.ndarray, T: np.ndarray, Out: np.ndarray, A: np.ndarray, row: float,
    dt_s: float, t: float, lat: float, lon: float, alt: float, e: float, n: float, up: float, agl: float, ve: float,
    vn: float, vu: float, airspeed: float, roll: float, pitch: float, yaw: float, on_ground: bool, p_roll: float,
    p_pitch: float, p_yaw: float, p_throttle: float, item: float,
) -> tuple[int, float, float, float, int, float, float, float, float]:  # fmt: skip
    """:func:`_flight_step` for a fixed-wing override's step (:func:`geofence.unit.passes.override_pass`, on the
    unit's margins tables ``F, L, V`` and its recovery's arrays ``R, PR, QR, K``): the same tuple, its sticks the
    override's on :data:`~geofence.unit.passes.OVERRIDE_STEP` (its row recorded then), else the pilot's."""
    truth = Truth(t, lat, lon, alt, e, n, up, agl, ve, vn, vu, airspeed, roll, pitch, yaw, on_ground)
    pilot = _pilot_sticks(A, truth, (p_roll, p_pitch, p_yaw, p_throttle))
    wind, flags, sensed = _wind_and_sensing(FZ, wind_pool, GX, P, pools, idx, dt_s, truth)
    answer, watched, sticks = _override_rest(
        (F, L, V, R, PR, QR, K), (U, H, W), T, Out, P[_H0:_H1], row, dt_s, item, truth, wind, sensed, pilot
    )  # fmt: skip
    return answer, wind[0], wind[1], wind[2], flags + watched, sticks[0], sticks[1], sticks[2], sticks[3]


@jitable
def _override_rest(
    arrays: tuple, memory: tuple, T: np.ndarray, Out: np.ndarray, horizon: np.ndarray, row: float, dt_s: float,
    item: float, truth: Truth, wind: tuple, sensed: SensedStep, pilot: tuple,
) -> tuple[int, int, tuple[float, float, float, float]]:  # fmt: skip
    """An override step after the wind and the sensing chain: ``(answer, the watch's flags, the sticks to send)``,
    its step kept, recorded and watched (or ``Out`` filled for the unit). ``arrays``: the margins' ``(F, L, V)`` and
    the recovery's ``(R, PR, QR, K)``; the rest as :func:`_monitor_rest`'s."""
    F, L, V, R, PR, QR, K = arrays
    U, H, W = memory
    s, est = sensed, sensed.est
    answer, c_roll, c_pitch, c_throttle, activation, has_margins, r = override_pass(
        U, F, L, V, R, PR, QR, K, truth.t_s, dt_s, est[3], est[4], est[5], est[7], est[8], est[9], est[10], est[11],
        est[13], est[14], s.wind_e_mps, s.wind_n_mps, s.position_valid, s.sigma_h_m, s.sigma_v_m, s.data_age_s,
        s.turbulence_sigma_mps, G_MPS2,
    )  # fmt: skip
    if answer == UNIT or answer == NEED_TARGET:
        _for_the_unit(Out, sensed)
        return answer, 0, (pilot[0], pilot[1], pilot[2], pilot[3])
    u = U.view(UNIT_STATE)[0]
    _keep(U, H, horizon, dt_s, truth, sensed, u.skipped_last != 0.0, activation, has_margins, r)
    cmd = (c_roll, c_pitch, 0.0, c_throttle)
    _write(T, row, item, truth, wind, pilot, cmd, u.mode, sensed, activation)
    return answer, _watch(W, dt_s, truth, sensed, True, u.mode_since_s, cmd), cmd


def _override_flight_step_again(
    P: np.ndarray, F: np.ndarray, L: np.ndarray, V: np.ndarray, R: np.ndarray, PR: np.ndarray, QR: np.ndarray,
    K: np.ndarray, U: np.ndarray, H: np.ndarray, W: np.ndarray, T: np.ndarray, Out: np.ndarray, row: float,
    dt_s: float, t: float, lat: float, lon: float, alt: float, e: float, n: float, up: float, agl: float, ve: float,
    vn: float, vu: float, airspeed: float, roll: float, pitch: float, yaw: float, on_ground: bool, w_e: float,
    w_n: float, w_u: float, p_roll: float, p_pitch: float, p_yaw: float, p_throttle: float, item: float,
) -> tuple[int, int, float, float, float, float]:  # fmt: skip
    """:func:`_flight_step_again` for a fixed-wing override's step: ``(answer, the watch's flags, the sticks to
    send)``."""
    truth = Truth(t, lat, lon, alt, e, n, up, agl, ve, vn, vu, airspeed, roll, pitch, yaw, on_ground)
    answer, watched, sticks = _override_rest(
        (F, L, V, R, PR, QR, K), (U, H, W), T, Out, P[_H0:_H1], row, dt_s, item, truth, (w_e, w_n, w_u),
        _unit_inputs_in(Out), (p_roll, p_pitch, p_yaw, p_throttle),
    )  # fmt: skip
    return answer, watched, sticks[0], sticks[1], sticks[2], sticks[3]


flight_step: Callable[..., tuple[int, float, float, float, int, float, float, float, float]] = jit.compiled(_flight_step)
"""The compiled :func:`_flight_step`."""
override_flight_step: Callable[..., tuple[int, float, float, float, int, float, float, float, float]] = jit.compiled(
    _override_flight_step
)
"""The compiled :func:`_override_flight_step`."""
flight_step_again: Callable[..., tuple[int, int, float, float, float, float]] = jit.compiled(_flight_step_again)
"""The compiled :func:`_flight_step_again`."""
override_flight_step_again: Callable[..., tuple[int, int, float, float, float, float]] = jit.compiled(_override_flight_step_again)
"""The compiled :func:`_override_flight_step_again`."""
_AGAIN = {flight_step: flight_step_again, override_flight_step: override_flight_step_again}
"""Each step's kernel asked again after NEED_TARGET."""


class FlightStep:
    """The runner's steps in one compiled call each (see the module), for one flight.

    Built by :meth:`build` where every part has its compiled form; :attr:`ready` says whether the unit's next step
    can be taken this way (:meth:`GeofenceUnit.monitor_ready`: a monitoring step; :meth:`GeofenceUnit.override_ready`:
    a fixed-wing override's), and :meth:`step` takes it. The steps taken so are handed over to the unit's Python
    objects (:meth:`GeofenceUnit.take_in_ring`) when it next answers one itself, at a hand-back, and at
    :meth:`finish`.
    """

    def __init__(
        self, unit: GeofenceUnit, sensing: GeofenceSensing, wind: WindArrays, recorder: Recorder, dt_s: float,
        pilot_law: np.ndarray | None = None,
    ) -> None:  # fmt: skip
        self.unit = unit
        self.sensing = sensing
        self.wind = wind
        self.recorder = recorder
        self.dt_s = dt_s
        self._U = unit.memory  # (the unit's record: the passes read and write it in place)
        self._H = np.zeros((unit.history_rows(dt_s), RING_COLUMNS))
        self._W = unit.compliance.memory  # (the compliance watch's record, read and written in place)
        self._O = np.zeros(STEP_OUT.itemsize // 8)
        self._A = law_array() if pilot_law is None else pilot_law  # (kind GIVEN: the pilot's sticks passed in)
        self._dispatcher: Callable[..., tuple[int, float, float, float, int, float, float, float, float]] = flight_step
        self._kernel = self._dispatcher  # the mode's kernel, by its entry point after its first call
        self._entry_points: dict[Callable, Callable] = {}
        self._sense_args = sensing.kernel_arrays()
        self._wind_args = wind.arrays()
        self._tables: tuple[np.ndarray, ...] = ()
        self._lead: tuple[np.ndarray, ...] = ()  # the kernel's leading arrays, bound once (see _bind)
        self._first_call = True  # the kernel's entry point is not known yet
        self.ready = False
        self.watched = 0
        """The last step's compliance watch by the compiled call: its flags (:data:`WATCHED`, :data:`NOT_FOLLOWING`),
        0 where the call did not watch it (the unit answered the step: the runner watches it)."""
        self.steps = 0
        """Steps a compiled call answered so far (not counting those it left to the unit)."""
        self.refresh()

    @classmethod
    def build(
        cls,
        unit: GeofenceUnit | None,
        sensing: GeofenceSensing | None,
        wind: WindArrays | None,
        calm: bool,
        recorder: Recorder,
        dt_s: float,
        pilot_law: np.ndarray | None = None,
    ) -> FlightStep | None:
        """A :class:`FlightStep` for this flight, or None where a part has no array form: no unit or not one that
        :attr:`~GeofenceUnit.monitors_compiled`, the sensing
        chain not compiled (a truth source), the wind field not as arrays (``wind``: the runner's, None when the
        field has no array form or is ``calm``). ``pilot_law``: the pilot's law array where it has one
        (:mod:`scenarios.flight.pilots.law_kernel`; :meth:`step` then takes no sticks where its kind is not
        ``GIVEN``)."""
        if unit is None or not unit.monitors_compiled:
            return None
        if sensing is None or not sensing.compiled:
            return None
        if wind is None:
            if not calm:
                return None
            wind = WindArrays(None, None, None)  # calm: zeros
        return cls(unit, sensing, wind, recorder, dt_s, pilot_law)

    def refresh(self) -> None:
        """Ask the unit again whether a compiled call can take its next step, and which arrays it reads (after every step
        it took itself, and every step the runner took without this call: the wind field may have refilled its
        noise pool)."""
        unit = self.unit
        if unit.monitor_ready():
            self._dispatcher = flight_step
            self._tables = unit.margins_tables()
        elif unit.override_ready():
            self._dispatcher = override_flight_step
            self._tables = unit.override_arrays()
        else:
            self.ready = False
            return
        self.ready = True
        self._kernel = self._entry_points.get(self._dispatcher, self._dispatcher)
        self._first_call = self._dispatcher not in self._entry_points
        self._wind_args = self.wind.arrays()
        self._bind()

    def wind_changed(self) -> None:
        """The wind field's arrays were replaced (its gust table, at the first activation)."""
        self._wind_args = self.wind.arrays()
        self._bind()

    def _bind(self) -> None:
        """The kernel's leading arguments in one tuple: the wind field's, the sensing chain's, the mode's tables and
        the unit's record, ring and compliance watch (after any of them is replaced)."""
        self._lead = (*self._wind_args, *self._sense_args, *self._tables, self._U, self._H, self._W)

    def finish(self) -> None:
        """The steps taken so far handed over to the unit (at the end of the flight; the sensing chain's horizon too)."""
        self._take_in(False)

    def newest_estimate(self) -> VehicleState | None:
        """The unit's newest estimate (:meth:`GeofenceUnit.newest_estimate` on this flight's ring)."""
        return self.unit.newest_estimate(self._H)

    def _take_in(self, new_horizon: bool) -> FixState | None:
        """The steps taken so far handed over to the unit (:meth:`GeofenceUnit.take_in_ring`); the sensing chain keeps
        its newest fusion horizon (``new_horizon``: it moved at this step). Returns that horizon."""
        sensing = self.sensing
        moved = self.unit.take_in_ring(self._H, sensing.horizon)
        return sensing.stepped(new_horizon or moved, False)

    def _again(
        self, t_s: float, s: VehicleState, row: int, T: np.ndarray, w: tuple[float, float, float],
        pilot: tuple[float, float, float, float], item: int,
    ) -> tuple[int, int, float, float, float, float]:  # fmt: skip
        """After :data:`~geofence.unit.passes.NEED_TARGET`: the unit finds the roll-out target at the step's estimate
        (in ``Out``), and the mode's kernel is asked the same step again (``pilot``: the sticks the first call
        gave): ``(answer, the watch's flags, the sticks to send)``."""
        out = self._sensed_out()
        self.unit.find_rollout_target(out.est[4], out.est[5], out.sigma_h_m)
        dispatcher = _AGAIN[self._dispatcher]
        kernel = self._entry_points.get(dispatcher, dispatcher)
        args = (
            self._sense_args[0], *self._tables, self._U, self._H, self._W, T, self._O, float(row), self.dt_s, t_s, s.lat_deg,
            s.lon_deg, s.alt_m, s.east_m, s.north_m, s.up_m, s.agl_m, s.v_east_mps, s.v_north_mps, s.v_up_mps,
            s.airspeed_mps, s.roll_rad, s.pitch_rad, s.yaw_rad, s.on_ground, *w, *pilot, float(item),
        )  # fmt: skip
        result = kernel(*args)
        if kernel is dispatcher:
            self._entry_points[dispatcher] = jit.entry_point(dispatcher)
        return result

    def step(
        self, truth: VehicleState, t_s: float, pilot: StickCommand | None, item: int
    ) -> tuple[tuple[float, float, float], StickCommand]:
        """One step from the truth (its ``t_s``: ``t``) and the pilot's sticks (None: its law array flies them):
        ``(the wind sampled, the sticks to send)``; the step's row is recorded either way."""
        s = truth
        recorder = self.recorder
        T, row = recorder.next_row()
        kernel = self._kernel
        p = _NO_STICKS if pilot is None else pilot
        answer, w_e, w_n, w_u, flags, roll, pitch, yaw, throttle = kernel(
            *self._lead, T, self._O, self._A, float(row), self.dt_s, t_s, s.lat_deg, s.lon_deg, s.alt_m, s.east_m,
            s.north_m, s.up_m, s.agl_m, s.v_east_mps, s.v_north_mps, s.v_up_mps, s.airspeed_mps, s.roll_rad,
            s.pitch_rad, s.yaw_rad, s.on_ground, p[0], p[1], p[2], p[3], float(item),
        )  # fmt: skip
        if self._first_call:  # after its first call, by its entry point (geofence.jit: the arrays are ours)
            self._kernel = self._entry_points[kernel] = jit.entry_point(kernel)
            self._first_call = False
        self.watched = flags & (WATCHED | NOT_FOLLOWING)
        if flags & (WIND_LOW | SENSE_LOW):
            if flags & WIND_LOW:
                self.wind.refill()
                self.wind_changed()
            if flags & SENSE_LOW:
                self.sensing.stepped(False, True)
        w = (w_e, w_n, w_u)
        if answer == NEED_TARGET:  # the unit finds the roll-out target, and the same step is asked again
            answer, self.watched, roll, pitch, yaw, throttle = self._again(
                t_s, s, row, T, w, (roll, pitch, yaw, throttle), item
            )  # fmt: skip
        if answer == OVERRIDE_STEP:
            self.steps += 1
            recorder.commit_row()
            return w, _new_tuple(StickCommand, (roll, pitch, yaw, throttle))
        if pilot is None:  # the pilot's sticks, by its law
            pilot = _new_tuple(StickCommand, (roll, pitch, yaw, throttle))
        if answer == PASS:
            self.steps += 1
            recorder.commit_row()
            return w, pilot
        unit = self.unit
        if answer == PASS_HANDBACK:
            self.steps += 1
            recorder.commit_row()
            self._take_in(False)
            unit.complete_hand_back(t_s)
            self.refresh()
            return w, pilot
        # the unit answers this step itself, from the same estimate
        o = self._sensed_out()
        horizon = self._take_in(o.new_horizon != 0.0)
        est = VehicleState(*o.est)
        est.on_ground = s.on_ground  # touchdown switch / the flight controller's land detector
        sensed = _new_tuple(
            Sensed,
            (est, (o.wind_e_mps, o.wind_n_mps), o.position_valid != 0.0, o.sigma_h_m, o.sigma_v_m, horizon, o.data_age_s,
             o.turbulence_sigma_mps),
        )  # fmt: skip
        return w, self.by_unit(truth, t_s, w, pilot, item, sensed)

    def _sensed_out(self) -> SensedStep:
        """What the kernel left in ``Out`` for the unit (:data:`STEP_OUT`), as Python floats (the flags 0 or 1)."""
        v: list[Any] = self._O.tolist()
        return _new_tuple(SensedStep, (tuple(v[:15]), *v[15:]))

    def by_unit(
        self, truth: VehicleState, t_s: float, w: tuple[float, float, float], pilot: StickCommand, item: int,
        sensed: Sensed,
    ) -> StickCommand:  # fmt: skip
        """A step the unit answers itself (:func:`unit_step`), then asked again whether the next can be a compiled
        call."""
        cmd = unit_step(self.unit, self.recorder, truth, t_s, w, pilot, item, sensed, self.dt_s)
        self.refresh()
        return cmd


def unit_step(
    unit: GeofenceUnit, recorder: Recorder, truth: VehicleState, t_s: float, w: tuple[float, float, float],
    pilot: StickCommand, item: int, sensed: Sensed, dt_s: float,
) -> StickCommand:  # fmt: skip
    """A step the unit answers itself (:meth:`GeofenceUnit.update` on the sensing chain's outputs ``sensed``), its row
    recorded: the sticks to send."""
    est, wind_en, valid, sigma_h, sigma_v, horizon, age, turbulence = sensed
    cmd = unit.update(
        t_s, est, pilot, dt_s, wind_en=wind_en, position_valid=valid, sigma_h_m=sigma_h, sigma_v_m=sigma_v,
        estimate_age_s=age, turbulence_sigma_mps=turbulence, horizon=horizon,
    )  # fmt: skip
    recorder.append(truth, w, pilot, cmd, unit.mode, item, unit.estimate, wind_en, unit.activation_margin_m)
    return cmd
