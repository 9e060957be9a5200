"""The closed loop's step (:mod:`scenarios.flight.step_kernel`) and the unit's decisions it takes
(:func:`geofence.unit.passes.monitor_pass`, :func:`~geofence.unit.passes.override_pass`): the same flight twice
records the same bytes; the compiled steps are their interpreted source (``py_func``, at 1e-9 relative); and the
decisions match oracles: sticks pass through unchanged while the unit monitors, and an activation comes at the
step where the public :func:`geofence.margins.boundary_shift.activation_margins` first reaches 0."""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence import jit
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import Envelope, PlatformKind, StickCommand, VehicleState
from geofence.margins.boundary_shift import activation_margins
from geofence.unit.config import parse_geofence
from geofence.unit.geofence_unit import GeofenceUnit, Mode
from geofence.unit.passes import OVERRIDE_STEP, PASS, monitor_pass, override_pass
from scenarios.definition.schema import load_scenario
from scenarios.flight.recorder import COLUMNS, Recorder, write_row
from scenarios.flight.runner import fly

ROOT = Path(__file__).resolve().parents[1]
FRAME = LocalFrame(47.0, 8.0, 400.0)
MC = Envelope(
    PlatformKind.MULTIROTOR, 8.0, 15.0, 0.0, math.radians(30), math.radians(30), math.radians(90), 3.0, 2.0, 5.6, 4.5, 0.25
)
TERN = Envelope(
    PlatformKind.FIXED_WING, 16.0, 24.0, 12.0, math.radians(40), math.radians(25), math.radians(28), 5.0, 3.0, 0.6, 5.0, 1.1
)
PILOT = StickCommand(roll=0.3, pitch=-0.8, yaw=0.0, throttle=0.2)
DT = 0.025
G = 9.80665
REL = 1e-9
"""The tolerance of a compiled step against its interpreted source (relative, and absolute below 1)."""


def _unit(env: Envelope, half_m: float = 300.0, **kw) -> GeofenceUnit:
    corners = [(-half_m, -half_m), (half_m, -half_m), (half_m, half_m), (-half_m, half_m)]
    fence = {"keep_in": [list(FRAME.to_geodetic(e, n, 0.0)[:2]) for e, n in corners], "ceiling_m": 120.0}
    cfg = parse_geofence({"fence": fence, **kw}, "test")
    return GeofenceUnit(cfg, cfg.fence.to_local(FRAME), env)


def _state(t: float, e: float, ve: float, n: float = 0.0, vn: float = 0.0, agl: float = 40.0, yaw: float = 0.0):
    return VehicleState(
        t_s=t, east_m=e, north_m=n, up_m=agl, agl_m=agl, alt_m=400.0 + agl, v_east_mps=ve, v_north_mps=vn,
        airspeed_mps=math.hypot(ve, vn), yaw_rad=yaw,
    )  # fmt: skip


def _close(a, b) -> bool:
    """Every field within :data:`REL` (NaN equal to NaN, infinities equal)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return bool(np.allclose(a, b, rtol=REL, atol=REL, equal_nan=True))


def _flat(answer) -> list[float]:
    out: list[float] = []
    for x in answer:
        out.extend(_flat(x) if isinstance(x, tuple) else [float(x)])
    return out


# -- the flight step ---------------------------------------------------------------------------------------------------
def test_the_same_flight_twice_records_the_same_bytes_and_the_step_takes_most_of_it():
    """Determinism, and the step's reach: a fixed-wing flight that overrides a third of the time is nearly all compiled
    calls (monitoring and override steps), the unit answering only the rest (activations, hand-backs, new targets)."""
    sc = replace(load_scenario(ROOT / "scenarios" / "geofence_fixedwing_adversarial_wind.yaml"), duration_s=40.0)
    a, b = fly(sc), fly(sc)
    assert a.recorder.n == b.recorder.n > 1000
    assert a.recorder.rows().tobytes() == b.recorder.rows().tobytes()
    assert a.unit is not None and b.unit is not None
    assert [tr.as_dict() for tr in a.unit.transitions] == [tr.as_dict() for tr in b.unit.transitions]
    assert a.unit.activations >= 2
    assert np.count_nonzero(a.recorder.column("geofence_mode") == Mode.OVERRIDE) > 0.3 * a.recorder.n
    assert a.compiled_steps > 0.9 * a.recorder.n


@pytest.mark.parametrize("name", ["geofence_fixedwing_adversarial_wind.yaml", "geofence_multicopter_adversarial_wind.yaml"])
def test_the_sticks_pass_through_unchanged_while_the_unit_monitors(name):
    """Oracle: in every recorded row whose mode is MONITOR or RECOVERED the sent sticks are the pilot's, exactly; in
    an override they are not all the pilot's."""
    rec = fly(replace(load_scenario(ROOT / "scenarios" / name), duration_s=30.0)).recorder
    mode = rec.column("geofence_mode")
    passing = (mode == Mode.MONITOR) | (mode == Mode.RECOVERED)
    assert passing.any() and (~passing).any()
    for axis in ("roll", "pitch", "yaw", "throttle"):
        assert np.array_equal(rec.column(f"cmd_{axis}")[passing], rec.column(f"pilot_{axis}")[passing])
    overridden = mode == Mode.OVERRIDE
    assert not np.array_equal(rec.column("cmd_roll")[overridden], rec.column("pilot_roll")[overridden])


def test_a_flight_without_an_array_form_flies_without_the_step():
    """A reactive unit and a truth state source: every step the unit's own; a predictive one: compiled calls."""
    reactive = load_scenario(ROOT / "scenarios" / "campaign_ci" / "floor_gaps-0008__reactive.yaml")
    assert fly(replace(reactive, duration_s=5.0)).compiled_steps == 0
    truth = load_scenario(ROOT / "scenarios" / "paper" / "indoor_quad_predictive.yaml")
    assert fly(replace(truth, duration_s=5.0)).compiled_steps == 0
    sc = replace(load_scenario(ROOT / "scenarios" / "geofence_fixedwing_adversarial_wind.yaml"), duration_s=5.0)
    assert fly(sc).compiled_steps > 0


# -- the unit's decisions against the public margins ---------------------------------------------------------------
@pytest.mark.parametrize("speed", [4.0, 8.0, 14.0])
def test_an_activation_comes_at_the_step_the_public_margin_first_reaches_zero(speed):
    """A multirotor flown straight at the east edge (synthetic estimates, no wind, exact sigmas 0): the unit's first
    activation is within one step of the first step where :func:`activation_margins` (with the unit's uncertainty
    margin, latency, allowance and density-scaled envelope) is at most 0."""
    u = _unit(MC)
    cfg = u.config
    t, e = 0.0, 150.0
    oracle_t = None
    for _ in range(4000):
        s = _state(t, e, speed)
        u.update(t, s, PILOT, DT, wind_en=(0.0, 0.0))
        r = activation_margins(
            u.fence, e, 0.0, s.agl_m, speed, 0.0, 0.0, u.env, 0.0, 0.0, h_uncertainty_m=cfg.extra_margin_m,
            v_uncertainty_m=cfg.extra_margin_m, latency_s=DT, wind_extra_mps=u.wind_allowance_mps,
        )  # fmt: skip
        if oracle_t is None and r.activation_margin_m <= 0.0:
            oracle_t = t
        if u.first_activation_s is not None or (oracle_t is not None and t > oracle_t + 2 * DT):
            break
        t, e = t + DT, e + speed * DT
    assert oracle_t is not None and u.first_activation_s is not None
    assert abs(u.first_activation_s - oracle_t) <= DT + 1e-9
    assert u.mode is Mode.OVERRIDE


@settings(max_examples=150, deadline=None)
@given(
    e=st.floats(-280.0, 280.0), n=st.floats(-280.0, 280.0), speed=st.floats(0.0, 14.0),
    course=st.floats(-math.pi, math.pi), agl=st.floats(5.0, 110.0),
)  # fmt: skip
def test_a_unit_whose_public_margin_is_positive_passes_the_sticks_through(e, n, speed, course, agl):
    """Oracle: where :func:`activation_margins` is positive the unit keeps monitoring and returns the pilot's sticks
    unchanged (far from everything or not)."""
    u = _unit(MC)
    cfg = u.config
    ve, vn = speed * math.cos(course), speed * math.sin(course)
    s = _state(0.0, e, ve, n, vn, agl)
    cmd = u.update(0.0, s, PILOT, DT, wind_en=(0.0, 0.0))
    r = activation_margins(
        u.fence, e, n, agl, ve, vn, 0.0, u.env, 0.0, 0.0, h_uncertainty_m=cfg.extra_margin_m,
        v_uncertainty_m=cfg.extra_margin_m, latency_s=DT, wind_extra_mps=u.wind_allowance_mps,
    )  # fmt: skip
    if r.activation_margin_m > 0.0:
        assert cmd == PILOT and u.mode is Mode.MONITOR and u.activations == 0
    else:
        assert u.mode is Mode.OVERRIDE and u.activations == 1


# -- compiled against interpreted ------------------------------------------------------------------------------
needs_numba = pytest.mark.skipif(not jit.COMPILED, reason="numba is not installed (both are the same function)")


@needs_numba
@settings(max_examples=60, deadline=None)
@given(
    e=st.floats(-320.0, 320.0), n=st.floats(-320.0, 320.0), speed=st.floats(0.0, 15.0),
    course=st.floats(-math.pi, math.pi), agl=st.floats(1.0, 125.0), sigma_h=st.floats(0.0, 5.0),
    wind=st.floats(0.0, 6.0), on_ground=st.booleans(),
)  # fmt: skip
def test_monitor_pass_compiled_is_its_interpreted_source(e, n, speed, course, agl, sigma_h, wind, on_ground):
    u = _unit(MC)
    ve, vn = speed * math.cos(course), speed * math.sin(course)
    u.update(0.0, _state(0.0, 0.0, 0.0), PILOT, DT, wind_en=(0.0, 0.0))  # (scaled to the site's density)
    U = u.memory  # (the unit's record)
    F, L, V = u.margins_tables()
    args = (DT, DT, 400.0 + agl, e, n, agl, ve, vn, 0.0, 0.0, on_ground, wind, -wind, True, sigma_h, 0.5 * sigma_h)
    args += (0.1, 0.5, G)
    got = monitor_pass(U.copy(), F, L, V, *args)
    want = monitor_pass.py_func(U.copy(), F, L, V, *args)
    assert got[0] == want[0] and got[1] == want[1]
    assert _close(_flat(got), _flat(want))


def _fixed_wing_in_override() -> GeofenceUnit:
    """A Tern flown at the east edge until its override starts, then past its minimum override period."""
    u = _unit(TERN, 400.0)
    t, e = 0.0, 200.0
    while u.mode is not Mode.OVERRIDE:
        u.update(t, _state(t, e, 20.0, yaw=math.pi / 2), PILOT, DT, wind_en=(0.0, 0.0))
        t, e = t + DT, e + 20.0 * DT
        assert t < 60.0
    return u


@needs_numba
@settings(max_examples=40, deadline=None)
@given(
    de=st.floats(-60.0, 60.0), dn=st.floats(-60.0, 60.0), speed=st.floats(12.0, 24.0),
    course=st.floats(-math.pi, math.pi), agl=st.floats(10.0, 110.0), later_s=st.floats(0.0, 8.0),
)  # fmt: skip
def test_override_pass_compiled_is_its_interpreted_source(de, dn, speed, course, agl, later_s):
    u = UNIT_IN_OVERRIDE
    if not u.override_ready():
        pytest.skip("the Tern's recovery has no compiled step here")
    F, L, V, R, P, Q, K = u.override_arrays()
    est = u.estimate
    assert est is not None
    e, n = est.east_m + de, est.north_m + dn
    u.find_rollout_target(e, n, 0.0)  # (the cell's target in the record: a route search where none is cached)
    ve, vn = speed * math.cos(course), speed * math.sin(course)
    t = est.t_s + later_s
    args = (t, DT, 400.0 + agl, e, n, agl, ve, vn, 0.0, 0.1, math.pi / 2 - course, speed, 1.0, 0.0, True, 0.0, 0.0)
    args += (0.0, 0.5, G)
    Ug, Uw = u.memory.copy(), u.memory.copy()
    got = override_pass(Ug, F, L, V, R, P, Q, K, *args)
    want = override_pass.py_func(Uw, F, L, V, R, P, Q, K, *args)
    assert got[0] == want[0]
    assert _close(_flat(got), _flat(want)) and _close(Ug, Uw)


UNIT_IN_OVERRIDE = _fixed_wing_in_override()


def test_the_override_unit_overrides():
    u = UNIT_IN_OVERRIDE
    assert u.mode is Mode.OVERRIDE and u.activations == 1 and "lateral" in u.transitions[-1].reason
    assert OVERRIDE_STEP != PASS


# -- the recorder's row -----------------------------------------------------------------------------------------------
finite = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.lists(finite, min_size=40, max_size=40), st.integers(0, 4), st.integers(0, 30), st.booleans())
def test_a_row_holds_each_value_in_its_column(v, mode, item, with_estimate):
    """Oracle: both writers (:meth:`Recorder.append`, :func:`write_row` of the compiled step) put each value in its
    named column, the angles in degrees and the ground speed the velocity's norm (1e-12 relative)."""
    s = VehicleState(*v[:15])
    wind = (v[15], v[16], v[17])
    pilot = StickCommand(v[18], v[19], v[20], v[21])
    cmd = StickCommand(v[22], v[23], v[24], v[25])
    est = VehicleState(*v[25:40]) if with_estimate else None
    est_fields = (est.east_m, est.north_m, est.agl_m) if est is not None else (np.nan, np.nan, np.nan)
    rec = Recorder(4)
    rec.append(s, wind, pilot, cmd, mode, item, est, (v[5], v[6]), v[7])
    T, row = rec.next_row()
    write_row(
        T, row, s.t_s, s.lat_deg, s.lon_deg, s.alt_m, s.east_m, s.north_m, s.up_m, s.agl_m, s.v_east_mps,
        s.v_north_mps, s.v_up_mps, s.airspeed_mps, s.roll_rad, s.pitch_rad, s.yaw_rad, *wind, *pilot, *cmd,
        float(mode), float(item), *est_fields, v[5], v[6], v[7],
    )  # fmt: skip
    rec.commit_row()
    deg = 180.0 / math.pi
    want = {
        "time_s": s.t_s, "lat_deg": s.lat_deg, "lon_deg": s.lon_deg, "alt_m": s.alt_m, "east_m": s.east_m,
        "north_m": s.north_m, "up_m": s.up_m, "agl_m": s.agl_m, "v_east_mps": s.v_east_mps,
        "v_north_mps": s.v_north_mps, "v_up_mps": s.v_up_mps, "ground_speed_mps": math.hypot(s.v_east_mps, s.v_north_mps),
        "airspeed_mps": s.airspeed_mps, "roll_deg": s.roll_rad * deg, "pitch_deg": s.pitch_rad * deg,
        "yaw_deg": s.yaw_rad * deg, "wind_east_mps": wind[0], "wind_north_mps": wind[1], "wind_up_mps": wind[2],
        "pilot_roll": pilot.roll, "pilot_pitch": pilot.pitch, "pilot_yaw": pilot.yaw, "pilot_throttle": pilot.throttle,
        "cmd_roll": cmd.roll, "cmd_pitch": cmd.pitch, "cmd_yaw": cmd.yaw, "cmd_throttle": cmd.throttle,
        "geofence_mode": mode, "mission_item": item, "est_east_m": est_fields[0], "est_north_m": est_fields[1],
        "est_agl_m": est_fields[2], "est_wind_east_mps": v[5], "est_wind_north_mps": v[6], "activation_margin_m": v[7],
    }  # fmt: skip
    assert set(want) == set(COLUMNS)
    rows = rec.rows()
    for name, value in want.items():
        k = COLUMNS.index(name)
        assert np.allclose(rows[:, k], value, rtol=1e-12, atol=0.0, equal_nan=True), name


def test_the_recorder_grows_past_its_first_table():
    rec = Recorder(2)
    s = VehicleState(t_s=1.0, v_east_mps=3.0, v_north_mps=4.0)
    for k in range(5):
        T, row = rec.next_row()
        assert row == k
        rec.append(s, (0.0, 0.0, 0.0), StickCommand(0.0, 0.0, 0.0, 0.5), StickCommand(0.0, 0.0, 0.0, 0.5), 0, k)
    assert rec.n == 5 and list(rec.column("mission_item")) == [0, 1, 2, 3, 4]
    assert list(rec.column("ground_speed_mps")) == [5.0] * 5
