"""The runner's steps in one compiled call (:mod:`scenarios.flight.step_kernel`: a monitoring step, a fixed-wing
override's step): a flight flown that way records the bytes and transitions of the same flight through the separate
objects, whatever the unit does in it (activations and hand-backs, GPS faults and dead reckoning from the history the
compiled steps kept, floor gaps, high sites, calm air, AMSL fences, the forecast's turbulence alone); and the
compiled row is the recorder's."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence import jit
from geofence.config import TurbulenceSource
from geofence.guidance import FixedWingRecovery
from geofence.heights import AltitudeReference
from geofence.interface import StickCommand, VehicleState
from scenarios.definition.schema import load_scenario
from scenarios.flight import step_kernel
from scenarios.flight.recorder import COLUMNS, Recorder, write_row
from scenarios.flight.runner import fly

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
pytestmark = pytest.mark.skipif(not jit.COMPILED, reason="numba is not installed")


def _both_ways(sc):
    previous = step_kernel.use_flight_step(False)
    try:
        reference = fly(sc)
    finally:
        step_kernel.use_flight_step(previous)
    compiled = fly(sc)
    return reference, compiled


def _assert_same_flight(reference, compiled):
    assert compiled.compiled_steps >= 20  # the compiled call was taken (a GPS failure 1.2 s in leaves 32 steps)
    assert reference.compiled_steps == 0
    assert compiled.recorder.data.tobytes() == reference.recorder.data.tobytes()
    ru, cu = reference.unit, compiled.unit
    assert ru is not None and cu is not None
    assert [(t.t_s, t.to_mode, t.reason) for t in cu.transitions] == [(t.t_s, t.to_mode, t.reason) for t in ru.transitions]
    # the unit's state at the end is the same: what it took in from the compiled steps included
    assert cu.activations == ru.activations and cu.mode == ru.mode
    assert cu.estimate == ru.estimate
    assert list(cu._history) == list(ru._history)
    assert repr(cu.activation_margin_m) == repr(ru.activation_margin_m)  # (NaN within a minimum override)
    assert cu.last == ru.last
    assert (cu.wind_enu, cu._sigma_h_m, cu._sigma_v_m, cu._latency_s) == (
        ru.wind_enu,
        ru._sigma_h_m,
        ru._sigma_v_m,
        ru._latency_s,
    )
    assert cu._last_horizon == ru._last_horizon and cu._skipped_last == ru._skipped_last
    rr, cr = ru.recovery, cu.recovery  # the override's state, taken in from the compiled steps
    assert type(cr) is type(rr)
    if isinstance(cr, FixedWingRecovery) and isinstance(rr, FixedWingRecovery) and rr._path is not None:
        assert cr.step_state() == rr.step_state()


CASES = {
    # activations, overrides, hand-backs and their RECOVERED hold; gusts timed from the first activation
    "fixed-wing adversarial": (ROOT / "scenarios" / "geofence_fixedwing_adversarial_wind.yaml", 40.0),
    "multirotor adversarial": (ROOT / "scenarios" / "geofence_multicopter_adversarial_wind.yaml", 40.0),
    # the GPS fails at 40 s while the unit monitors: dead reckoning replays the history the compiled steps kept
    "fixed-wing GPS loss": (ROOT / "scenarios" / "geofence_gps_loss_fixedwing.yaml", 55.0),
    "multirotor GPS failure over a floor gap": (DATA / "campaign_floor_gaps_0161_gps_fail_braking.yaml", None),
    "fixed-wing GPS outages while orbiting": (DATA / "campaign_star_0588_gps_outage_orbit.yaml", None),
    # a fixed-wing override whose first turn does not fit: flown at the minimum speed's throttle
    "fixed-wing slow first turn": (DATA / "campaign_corridor_1922_slow_turn.yaml", 30.0),
    # fixed-wing overrides that climb back above the floor in a gap before they may hand back, and hand-backs
    "fixed-wing climbs back above the floor": (DATA / "campaign_floor_gaps_0030_climb_back.yaml", None),
    # raw-sticks segments (the pilot's law array holds them), a fixed-wing's and a multirotor's
    "fixed-wing raw sticks": (ROOT / "scenarios" / "campaign_ci" / "u_fence-0002__predictive.yaml", 40.0),
    "multirotor raw sticks": (ROOT / "scenarios" / "campaign_ci" / "u_fence-0011__predictive.yaml", 40.0),
    # a roll-out target a compiled step needs, found with that step's sigma_h (the route's clearances)
    "fixed-wing target at the step's sigma": (DATA / "campaign_corridor_0013_target_sigma.yaml", 15.0),
    # roll-out targets of many cells (route searches), a floor with gaps
    "floor gaps mission": (ROOT / "scenarios" / "campaign_ci" / "floor_gaps-0008__predictive.yaml", 60.0),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_flight_through_the_compiled_step_is_the_flight_through_the_objects(name):
    path, seconds = CASES[name]
    sc = load_scenario(path)
    if seconds is not None:
        sc = replace(sc, duration_s=seconds)
    _assert_same_flight(*_both_ways(sc))


def test_a_fixed_wing_override_is_stepped_by_the_compiled_call_too():
    """A fixed-wing override's steps are compiled calls too (its recovery's compiled step inside; after the minimum
    override period its margins and hand-back tests too): with the monitoring steps, nearly every step of a flight
    that overrides half the time, and the unit answers few itself (activations, hand-backs, new roll-out
    targets)."""
    sc = replace(load_scenario(ROOT / "scenarios" / "geofence_fixedwing_adversarial_wind.yaml"), duration_s=40.0)
    reference, compiled = _both_ways(sc)
    _assert_same_flight(reference, compiled)
    unit = compiled.unit
    assert unit is not None and unit.activations >= 2
    overriding = np.count_nonzero(compiled.recorder.column("geofence_mode") == 1)
    assert overriding > 0.3 * compiled.recorder.n
    assert compiled.compiled_steps > 0.9 * compiled.recorder.n  # (94.9 % on this flight)


def test_the_same_in_calm_air_with_the_forecast_turbulence_only():
    sc = load_scenario(ROOT / "scenarios" / "geofence_fixedwing_adversarial_wind.yaml")
    assert sc.geofence is not None
    g = replace(sc.geofence, turbulence_source=TurbulenceSource.FORECAST)
    _assert_same_flight(*_both_ways(replace(sc, wind=None, geofence=g, duration_s=30.0)))


def test_the_same_with_an_amsl_fence_at_a_high_site():
    """Heights above sea level (the estimate's altitude, not its AGL) at a 1,500 m site: the envelope is scaled to
    the thin air there (the first step, and again if the altitude moves 100 m)."""
    sc = load_scenario(ROOT / "scenarios" / "geofence_multicopter_adversarial_wind.yaml")
    assert sc.geofence is not None
    site = 1500.0
    f = sc.geofence.fence
    fence = replace(
        f,
        altitude_reference=AltitudeReference.AMSL,
        ceiling_m=f.ceiling_m + site,
        floor_m=None if f.floor_m is None else f.floor_m + site,
    )
    start = replace(sc.start, ground_alt_m=site)
    _assert_same_flight(*_both_ways(replace(sc, start=start, geofence=replace(sc.geofence, fence=fence), duration_s=30.0)))


def test_no_compiled_step_where_a_part_has_no_compiled_form():
    """A reactive unit, a truth state source, the hook switched off: every step through the objects."""
    reactive = load_scenario(ROOT / "scenarios" / "campaign_ci" / "floor_gaps-0008__reactive.yaml")
    assert fly(replace(reactive, duration_s=5.0)).compiled_steps == 0
    truth = load_scenario(ROOT / "scenarios" / "paper" / "indoor_quad_predictive.yaml")
    assert fly(replace(truth, duration_s=5.0)).compiled_steps == 0
    sc = replace(load_scenario(ROOT / "scenarios" / "geofence_fixedwing_adversarial_wind.yaml"), duration_s=5.0)
    previous = step_kernel.use_flight_step(False)
    try:
        assert fly(sc).compiled_steps == 0
    finally:
        step_kernel.use_flight_step(previous)
    assert fly(sc).compiled_steps > 0


finite = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.lists(finite, min_size=40, max_size=40), st.integers(0, 4), st.integers(0, 30), st.booleans())
def test_the_compiled_row_is_the_recorders_row(v, mode, item, with_estimate):
    """:func:`write_row` (what the compiled step records) writes what :meth:`Recorder.append` writes from the same
    values: the degrees, the ground speed (CPython's hypot) and every column in its place."""
    s = VehicleState(*v[:15])
    wind = (v[15], v[16], v[17])
    pilot = StickCommand(v[18], v[19], v[20], v[21])
    cmd = StickCommand(v[22], v[23], v[24], v[25])
    est = VehicleState(*v[25:40]) if with_estimate else None
    est_fields = (est.east_m, est.north_m, est.agl_m) if est is not None else (np.nan, np.nan, np.nan)
    rec = Recorder(4)
    rec.append(s, wind, pilot, cmd, mode, item, est, (v[5], v[6]), v[7])
    T, row = rec.next_row()
    jit.numba.njit(write_row)(
        T, row, s.t_s, s.lat_deg, s.lon_deg, s.alt_m, s.east_m, s.north_m, s.up_m, s.agl_m, s.v_east_mps,
        s.v_north_mps, s.v_up_mps, s.airspeed_mps, s.roll_rad, s.pitch_rad, s.yaw_rad, *wind, *pilot, *cmd,
        float(mode), float(item), *est_fields, v[5], v[6], v[7],
    )  # fmt: skip
    rec.commit_row()
    rows = rec.rows()
    assert rows.shape == (2, len(COLUMNS))
    assert rows[0].tobytes() == rows[1].tobytes()


def test_the_recorder_grows_past_its_first_table():
    rec = Recorder(2)
    s = VehicleState(t_s=1.0, v_east_mps=3.0, v_north_mps=4.0)
    for k in range(5):
        T, row = rec.next_row()
        assert row == k
        rec.append(s, (0.0, 0.0, 0.0), StickCommand(0.0, 0.0, 0.0, 0.5), StickCommand(0.0, 0.0, 0.0, 0.5), 0, k)
    assert rec.n == 5 and list(rec.column("mission_item")) == [0, 1, 2, 3, 4]
    assert list(rec.column("ground_speed_mps")) == [5.0] * 5
