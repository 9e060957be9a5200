"""A scenario's ``faults:`` (scenarios/definition/faults.py): parsed into typed faults, bad input one line and exit 2,
and each kind really injected: in the unit's sensors (aircraft/sensors.py) and in the closed loop (the runner)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support import FRAME, fault_scenario_doc, fly_doc

from aircraft.sensors import SensorConfig, SensorSuite
from geofence.interface import PlatformKind, VehicleState
from geofence.physics.dynamics import isa_density_ratio
from geofence.validation import ConfigError
from scenarios.app.cli import main
from scenarios.definition.faults import Fault, FaultKind, parse_faults, sensor_fault_rows
from scenarios.definition.schema import parse_scenario

# -- parsing ------------------------------------------------------------------


def test_every_kind_parses_into_its_typed_fault():
    raw = [
        {"kind": "gnss_loss", "at_s": 5, "duration_s": 3},
        {"kind": "gnss_degraded", "at_s": 1, "rate_hz": 1, "latency_s": 0.5, "bias_m": 4},
        {"kind": "gnss_walkoff", "at_first_activation": True, "delay_s": 2, "drift_mps": 0.5, "direction_deg": 90},
        {"kind": "baro_drift", "at_s": 0, "drift_rate_mps": 0.1},
        {"kind": "pitot_blocked", "at_s": 2},
        {"kind": "compass_error", "at_s": 2, "error_deg": -30},
        {"kind": "fc_ignores_override", "at_first_activation": True},
        {"kind": "fc_freezes", "at_s": 9},
        {"kind": "propulsion_loss", "at_s": 9.5},
    ]
    faults = parse_faults(raw, "x.yaml: faults", PlatformKind.FIXED_WING, 10.0, True)
    assert [f.kind for f in faults] == list(FaultKind)
    loss, degraded, walkoff, baro, _, compass, ignores, _, _ = faults
    assert (loss.at_s, loss.duration_s) == (5.0, 3.0) and loss.active(7.9, None) and not loss.active(8.0, None)
    assert (degraded.rate_hz, degraded.latency_s, degraded.bias_m) == (1.0, 0.5, 4.0)
    assert walkoff.at_first_activation and walkoff.delay_s == 2.0 and walkoff.direction_rad == pytest.approx(math.pi / 2)
    assert walkoff.onset_s(None) is None and walkoff.onset_s(4.0) == 6.0
    assert (baro.drift_m, baro.drift_rate_mps) == (0.0, 0.1)
    assert compass.error_rad == pytest.approx(math.radians(-30.0))
    assert ignores.onset_s(3.0) == 3.0 and ignores.duration_s == math.inf
    assert sensor_fault_rows(faults).shape[0] == 6  # the flight controller's and the engine's are the runner's


@pytest.mark.parametrize(
    ("item", "says"),
    [
        ({"kind": "pitot_blocked", "at_s": 1}, "faults[0].kind: pitot_blocked applies to a fixed-wing only"),
        ({"kind": "propulsion_loss", "at_s": 1}, "faults[0].kind: propulsion_loss applies to a fixed-wing only"),
        ({"kind": "gnss_loss", "at_s": 30}, "faults[0].at_s: 30 s is not before the flight's end"),
        ({"kind": "gnss_loss"}, "faults[0]: give exactly one start"),
        ({"kind": "gnss_loss", "at_s": 1, "at_first_activation": True}, "faults[0]: give exactly one start"),
        ({"kind": "gnss_loss", "at_s": 1, "delay_s": 2}, "faults[0].delay_s: only with at_first_activation"),
        ({"kind": "gnss_walkoff", "at_s": 1, "drift_mps": 0.5}, "faults[0].direction_deg: missing"),
        ({"kind": "gnss_degraded", "at_s": 1}, "faults[0]: gnss_degraded needs at least one of"),
        ({"kind": "baro_drift", "at_s": 1, "drift_m": "5 m"}, "faults[0].drift_m: expected a number"),
        ({"kind": "compass_error", "at_s": 1, "error_deg": 200}, "faults[0].error_deg: must be <= 180"),
        ({"kind": "gnss_loss", "at_s": 1, "drift_mps": 1}, "faults[0].drift_mps: unknown key"),
        ({"kind": "gps_loss", "at_s": 1}, "faults[0].kind: 'gps_loss' is not one of"),
        ({"at_s": 1}, "faults[0].kind: missing"),
    ],
)
def test_bad_faults_are_one_line_naming_file_and_field(item, says):
    doc = fault_scenario_doc("F450RD", [item], duration_s=30.0)
    with pytest.raises(ConfigError) as err:
        parse_scenario(doc, "case.yaml")
    message = str(err.value)
    assert message.startswith("case.yaml: faults[0]") and says in message and "\n" not in message, message


def test_a_start_at_the_first_activation_needs_a_geofence():
    doc = fault_scenario_doc("F450RD", [{"kind": "gnss_loss", "at_first_activation": True}])
    del doc["geofence"]
    with pytest.raises(ConfigError, match=r"faults\[0\]\.at_first_activation: the scenario has no geofence"):
        parse_scenario(doc, "case.yaml")


_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-1000, 1000), st.floats(allow_nan=True), st.text(max_size=5),
    st.lists(st.integers(), max_size=2), st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
)  # fmt: skip
_KEYS = st.sampled_from(
    ["kind", "at_s", "at_first_activation", "delay_s", "duration_s", "rate_hz", "latency_s", "bias_m", "drift_mps",
     "direction_deg", "drift_m", "drift_rate_mps", "error_deg", "typo"]
)  # fmt: skip


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(_VALUES, st.lists(st.one_of(_VALUES, st.dictionaries(_KEYS, _VALUES, max_size=5)), max_size=3)))
def test_any_faults_block_parses_or_fails_in_one_line(raw):
    try:
        faults = parse_faults(raw, "h.yaml: faults", PlatformKind.MULTIROTOR, 20.0, True)
    except ConfigError as exc:
        assert str(exc).startswith("h.yaml: faults") and "\n" not in str(exc), str(exc)
    else:
        assert all(isinstance(f, Fault) for f in faults)


@pytest.mark.parametrize(
    "item", [{"kind": "propulsion_loss", "at_s": 1}, {"kind": "gnss_loss", "at_s": 99}, {"kind": "gnss_loss", "at_s": -1}]
)
def test_validate_exits_2_with_one_line_on_a_bad_fault(tmp_path, capsys, item):
    path = tmp_path / "bad_fault.yaml"
    path.write_text(yaml.safe_dump(fault_scenario_doc("F450RD", [item], duration_s=20.0)))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {path}: faults[0]"), err


# -- the sensors: each sensor fault changes what they give ----------------------------------------------


def _truth(t_s: float) -> VehicleState:
    """A stationary vehicle at the frame's origin, 50 m up, heading north, in a wind: its airspeed 15 m/s, rising
    0.25 m/s every second."""
    lat, lon, alt = FRAME.to_geodetic(0.0, 0.0, 50.0)
    return VehicleState(t_s, lat, lon, alt, up_m=50.0, agl_m=50.0, airspeed_mps=15.0 + 0.25 * t_s)


def _sampled(faults: list | None, seconds: float = 20.0, cfg: SensorConfig | None = None) -> list:
    """Every step's ``(t, fix or None, air, attitude)`` of a suite (seed 7) at 40 Hz with these ``faults:``."""
    rows = sensor_fault_rows(parse_faults(faults, "s.yaml: faults", PlatformKind.FIXED_WING, 1e3, True))
    suite = SensorSuite(cfg or SensorConfig(), seed=7, faults=rows)
    out = []
    for k in range(int(seconds * 40) + 1):
        t = k / 40.0
        out.append((t, *suite.sample(_truth(t))))
    return out


def test_the_old_gps_keys_are_gnss_loss_faults_to_the_last_bit():
    old = _sampled(None, cfg=SensorConfig(gps_fail_at_s=12.0, gps_outages=((3.0, 5.5),)))
    new = _sampled([{"kind": "gnss_loss", "at_s": 3, "duration_s": 2.5}, {"kind": "gnss_loss", "at_s": 12}])
    assert repr(old) == repr(new)
    assert not any(fix.valid for t, fix, _, _ in new if fix is not None and (3.0 <= fix.t_s < 5.5 or fix.t_s >= 12.0))


def test_a_walk_off_moves_the_fixes_at_its_drift_velocity():
    base, off = _sampled(None), _sampled([{"kind": "gnss_walkoff", "at_s": 5, "drift_mps": 0.5, "direction_deg": 90}])
    for (_, a, _, _), (_, b, _, _) in zip(base, off):
        if a is None:
            continue
        east_m = FRAME.to_enu(b.lat_deg, b.lon_deg, b.alt_m)[0] - FRAME.to_enu(a.lat_deg, a.lon_deg, a.alt_m)[0]
        assert east_m == pytest.approx(0.5 * max(0.0, a.t_s - 5.0), abs=0.02)
        assert b.v_east_mps - a.v_east_mps == pytest.approx(0.5 if a.t_s >= 5.0 else 0.0, abs=1e-9)


def test_baro_pitot_and_compass_faults_change_their_readings_from_their_onset():
    base = _sampled(None)
    faulty = _sampled(
        [
            {"kind": "baro_drift", "at_s": 4, "drift_m": 5, "drift_rate_mps": 0.1},
            {"kind": "compass_error", "at_s": 6, "error_deg": 20},
            {"kind": "pitot_blocked", "at_s": 8, "duration_s": 4},
        ]  # fmt: skip
    )
    for (t, _, air0, att0), (_, _, air1, att1) in zip(base, faulty):
        assert air1.baro_alt_m - air0.baro_alt_m == pytest.approx(5.0 + 0.1 * (t - 4.0) if t >= 4.0 else 0.0, abs=1e-9)
        yaw_err = (att1.yaw_rad - att0.yaw_rad + math.pi) % (2 * math.pi) - math.pi
        assert yaw_err == pytest.approx(math.radians(20.0) if t >= 6.0 else 0.0, abs=1e-9)
        frozen_mps = -0.25 * (t - 8.0) * math.sqrt(isa_density_ratio(FRAME.h0_m + 50.0)) if 8.0 <= t < 12.0 else 0.0
        assert air1.airspeed_mps - air0.airspeed_mps == pytest.approx(frozen_mps, abs=1e-9)


def test_a_degraded_receiver_reports_at_its_rate_after_its_latency():
    fixes = [(t, fix) for t, fix, _, _ in _sampled([{"kind": "gnss_degraded", "at_s": 10, "rate_hz": 1, "latency_s": 0.5}])]
    late = [(t, fix.t_s) for t, fix in fixes if fix is not None and fix.t_s >= 10.0]
    validity = [tv for _, tv in late]
    assert np.diff(validity) == pytest.approx(np.ones(len(validity) - 1), abs=0.03)
    assert all(0.5 <= t - tv < 0.5 + 0.03 for t, tv in late)
    early = [fix.t_s for t, fix in fixes if fix is not None and 2.0 <= fix.t_s < 9.0]
    assert np.diff(early) == pytest.approx(np.full(len(early) - 1, 0.2), abs=0.03)


# -- the closed loop ------------------------------------------------------------------------------------


def _at(res, t_s: float) -> int:
    return int(np.searchsorted(res.recorder.column("time_s"), t_s))


@pytest.mark.closed_loop
def test_gnss_loss_fault_flies_as_the_old_key_and_the_unit_loses_its_position_at_onset():
    doc = fault_scenario_doc("F450RD", [{"kind": "gnss_loss", "at_s": 3}], duration_s=8.0)
    res = fly_doc(doc, "gnss_loss")
    old = fault_scenario_doc("F450RD", None, duration_s=8.0)
    old["sensors"] = {"gps_fail_at_s": 3}
    assert np.array_equal(res.recorder.rows(), fly_doc(old, "gps_fail_at_s").recorder.rows(), equal_nan=True)
    lost = [tr.t_s for tr in res.unit.transitions if "position source lost" in tr.reason]
    assert lost and 3.0 <= lost[0] <= 4.5, res.summary["mode_transitions"]
    assert res.summary["faults"] == [{"kind": "gnss_loss", "onset_s": 3.0}]


@pytest.mark.closed_loop
def test_a_walk_off_of_half_a_metre_a_second_drags_the_estimate_with_it():
    fault = {"kind": "gnss_walkoff", "at_s": 2, "drift_mps": 0.5, "direction_deg": 90}
    res = fly_doc(fault_scenario_doc("F450RD", [fault], duration_s=16.0), "walkoff")
    c = res.recorder.column
    err = c("est_east_m") - c("east_m")
    k = slice(_at(res, 6.0), _at(res, 16.0))
    slope = np.polyfit(c("time_s")[k], err[k], 1)[0]
    assert slope == pytest.approx(0.5, abs=0.15), f"the estimate walks off at {slope:.2f} m/s"


@pytest.mark.closed_loop
def test_a_baro_drift_of_5_m_puts_the_height_estimate_5_m_high():
    res = fly_doc(fault_scenario_doc("F450RD", [{"kind": "baro_drift", "at_s": 4, "drift_m": 5}], duration_s=12.0), "baro")
    c = res.recorder.column
    err = c("est_agl_m") - c("agl_m")
    before, after = err[_at(res, 1.0) : _at(res, 4.0)].mean(), err[_at(res, 8.0) :].mean()
    assert after - before == pytest.approx(5.0, abs=1.0)


def _tern_at_an_edge(faults: list | None, compliance_grace_s: float | None = None):
    """A Tern flying north at an edge 300 m ahead: the unit overrides (turns) at about 14 s. A long
    ``compliance_grace_s`` keeps the unit from terminating a vehicle that ignores it (the fault alone, as injected)."""
    doc = fault_scenario_doc("Tern", faults, duration_s=22.0, half_m=200.0, start_en=(0.0, -100.0))
    if compliance_grace_s is not None:
        doc["geofence"]["compliance_grace_s"] = compliance_grace_s
    return fly_doc(doc, "tern_edge")


@pytest.mark.closed_loop
def test_a_flight_controller_ignoring_the_override_flies_the_pilots_sticks():
    res = _tern_at_an_edge([{"kind": "fc_ignores_override", "at_first_activation": True}], compliance_grace_s=10.0)
    first = res.summary["first_activation_s"]
    assert first is not None and res.summary["faults"] == [{"kind": "fc_ignores_override", "onset_s": first}]
    c = res.recorder.column
    k = slice(_at(res, first + 1.0), _at(res, first + 4.0))
    assert np.all(np.abs(c("cmd_roll")[k]) > 0.5) and np.all(c("pilot_roll")[k] == 0.0)  # the unit turns, the pilot not
    assert np.all(np.abs(c("roll_deg")[k]) < 3.0)  # the platform flies the pilot's wings-level
    assert res.summary["max_excursion_m"] > 20.0  # out across the edge
    nominal = _tern_at_an_edge(None)
    assert np.abs(nominal.recorder.column("roll_deg")[k]).max() > 30.0 and nominal.summary["max_excursion_m"] <= 0.0


@pytest.mark.closed_loop
def test_a_frozen_flight_controller_holds_the_last_sticks_it_got():
    res = _tern_at_an_edge([{"kind": "fc_freezes", "at_first_activation": True, "delay_s": 1.0}])
    onset = res.summary["faults"][0]["onset_s"]
    assert onset == pytest.approx(res.summary["first_activation_s"] + 1.0)
    c = res.recorder.column
    k = slice(_at(res, onset + 3.0), _at(res, onset + 7.0))
    assert np.all(c("cmd_roll")[k] == 0.0)  # the unit rolled out and handed back ...
    assert np.all(c("roll_deg")[k] > 30.0)  # ... the platform keeps the full right bank it was given


@pytest.mark.closed_loop
def test_propulsion_loss_on_a_fixed_wing_bleeds_its_airspeed_and_height():
    lost = fly_doc(fault_scenario_doc("Tern", [{"kind": "propulsion_loss", "at_s": 2}], duration_s=12.0), "engine")
    nominal = fly_doc(fault_scenario_doc("Tern", None, duration_s=12.0), "engine_ok")
    a, b = lost.recorder.column, nominal.recorder.column
    assert lost.summary["faults"] == [{"kind": "propulsion_loss", "onset_s": 2.0}]
    assert a("airspeed_mps")[_at(lost, 1.9)] == pytest.approx(b("airspeed_mps")[_at(nominal, 1.9)], abs=1e-6)
    assert a("airspeed_mps")[_at(lost, 8.0)] < b("airspeed_mps")[_at(nominal, 8.0)] - 4.0
    assert a("agl_m")[-1] < b("agl_m")[-1] - 4.0
    assert np.all(a("cmd_throttle") == 0.0)  # the sticks asked for cruise all along


def test_the_compiled_sensors_step_conforms_with_every_sensor_fault():
    """The fault branches of the one entry point: compiled and interpreted (``py_func``) agree to 1e-9 along a
    climbing turn with every sensor fault, one of them timed from an activation (the loss, shorter, tested apart)."""
    from aircraft.sensors import FIX0, OUTAGES0, sensors_step

    if not hasattr(sensors_step, "py_func"):
        pytest.skip("numba is not compiling here: the interpreted run is the only one")
    raw = [
        {"kind": "gnss_degraded", "at_s": 5, "duration_s": 20, "rate_hz": 1, "latency_s": 0.6, "bias_m": 4},
        {"kind": "gnss_walkoff", "at_first_activation": True, "delay_s": 1, "drift_mps": 2, "direction_deg": 30},
        {"kind": "baro_drift", "at_s": 3, "drift_m": -2, "drift_rate_mps": 0.2},
        {"kind": "pitot_blocked", "at_s": 12, "duration_s": 5},
        {"kind": "compass_error", "at_s": 15, "error_deg": 12},
        {"kind": "gnss_loss", "at_s": 33, "duration_s": 2},
    ]
    rows = sensor_fault_rows(parse_faults(raw, "c.yaml: faults", PlatformKind.FIXED_WING, 60.0, True))
    a, b = (SensorSuite(SensorConfig(), seed=3, faults=rows) for _ in range(2))
    for k in range(int(40.0 * 40)):
        t = k / 40.0
        if k == 400:  # the unit's first activation, at 10 s
            a.trigger_faults(t)
            b.trigger_faults(t)
        lat, lon, h = FRAME.to_geodetic(50.0 * math.sin(0.2 * t), 50.0 * math.cos(0.2 * t), 30.0 + t)
        fields = (t, lat, lon, h, 10.0 * math.cos(0.2 * t), -10.0 * math.sin(0.2 * t), 1.0, 20.0 + 0.1 * t, 0.3, 0.05, 0.2 * t)
        got = sensors_step(a.memory, a.pools, a.idx, *fields)
        ref = sensors_step.py_func(b.memory, b.pools, b.idx, *fields)
        assert got == pytest.approx(ref, abs=1e-9, nan_ok=True), k
        assert a.memory[FIX0:OUTAGES0] == pytest.approx(b.memory[FIX0:OUTAGES0], abs=1e-9, nan_ok=True)
        assert got[-1] == a.refill() | False and ref[-1] == b.refill() | False
    assert np.array_equal(a.faults, b.faults, equal_nan=True)
    assert a.faults[1, 1] == 11.0  # the walk-off's onset, from the activation


@pytest.mark.closed_loop
def test_a_sensor_fault_timed_from_the_first_activation_starts_then():
    res = _tern_at_an_edge([{"kind": "gnss_loss", "at_first_activation": True, "delay_s": 1.0}])
    first = res.summary["first_activation_s"]
    assert first is not None and res.summary["faults"] == [{"kind": "gnss_loss", "onset_s": round(first + 1.0, 3)}]
    lost = [tr.t_s for tr in res.unit.transitions if "position source lost" in tr.reason]
    assert lost and first + 1.0 <= lost[0] <= first + 2.5, res.summary["mode_transitions"]
