"""A flyaway terminated inside (issue 38): the termination footprint (geofence/physics/termination.py) against an
independent integration, the compliance monitor (geofence/unit/compliance.py), and in closed loop a flight
controller that ignores (or freezes on) the override, terminated by the unit's own channel
(Platform.terminate) and coming down inside the fence."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support import FRAME, FW, MC, edge_run_doc, fault_scenario_doc, fly_doc, latlon, point_mass_fall

from geofence.interface import StickCommand, VehicleState
from geofence.physics.control_laws import climb_rate_to_stick, stick_to_climb_rate
from geofence.physics.termination import drag_fall, footprint_points, no_drag_fall_s, termination_footprint
from geofence.unit.compliance import (
    NONCOMPLIANT_VERTICAL_MPS,
    VERTICAL_GRACE_FACTOR,
    VERTICAL_MODEL_ACCEL_FRACTION,
    ComplianceMonitor,
    watch,
    watch_step,
)
from geofence.unit.config import parse_geofence
from geofence.unit.geofence_unit import GeofenceUnit, Mode
from geofence.validation import ConfigError

# -- the footprint ----------------------------------------------------------------------------------------------

FALLS = [
    # h, (ve, vn, vu), (wind e, n), terminal speed
    (70.0, (25.0, 0.0, 0.0), (0.0, 0.0), 8.0),
    (30.0, (0.0, 10.0, -2.0), (3.0, -4.0), 8.0),
    (120.0, (-5.0, 7.0, 3.0), (8.0, 0.0), 20.0),
    (5.0, (15.0, 15.0, 0.0), (-6.0, 2.0), 12.0),
    (60.0, (0.0, 0.0, 0.0), (5.0, 5.0), 8.0),
]


@pytest.mark.parametrize(("h", "v", "w", "vt"), FALLS)
def test_the_drag_fall_lands_where_an_adaptive_integration_of_the_same_point_mass_does(h, v, w, vt):
    e, n, t = drag_fall(h, *v, *w, vt)
    oe, on, ot = point_mass_fall(h, v, w, vt)
    assert math.hypot(e - oe, n - on) < 0.01 and t == pytest.approx(ot, abs=2e-3)


@pytest.mark.parametrize(("h", "v", "w", "vt"), FALLS)
def test_the_no_drag_end_is_the_vacuum_fall_of_the_oracle(h, v, w, vt):
    fp = termination_footprint(100.0, -50.0, h, *v, *w, vt, 6.0, 1.0)
    oe, on, ot = point_mass_fall(h, v, w, None)
    assert fp.far_e_m == pytest.approx(100.0 + oe, abs=1e-3) and fp.far_n_m == pytest.approx(-50.0 + on, abs=1e-3)
    assert no_drag_fall_s(h, v[2]) == pytest.approx(ot, abs=1e-6)
    assert fp.radius_m == pytest.approx(6.0 + 1.0 * fp.fall_s) and fp.fall_s >= ot
    pts = footprint_points(fp)
    assert pts[0] == (fp.drag_e_m, fp.drag_n_m) and pts[-1] == pytest.approx((fp.far_e_m, fp.far_n_m))


def _reach_m(h: float, speed: float, vt: float) -> tuple[float, float]:
    fp = termination_footprint(0.0, 0.0, h, speed, 0.0, 0.0, 0.0, 0.0, vt, 0.0, 0.0)
    return math.hypot(fp.far_e_m, fp.far_n_m), math.hypot(fp.drag_e_m, fp.drag_n_m)


@settings(max_examples=60, deadline=None)
@given(
    h=st.floats(1.0, 120.0), dh=st.floats(1.0, 50.0), v=st.floats(0.5, 30.0), dv=st.floats(0.5, 10.0),
    vt=st.floats(4.0, 40.0),
)  # fmt: skip
def test_the_footprint_reaches_farther_with_speed_and_with_height(h, dh, v, dv, vt):
    far, drag = _reach_m(h, v, vt)
    far_fast, drag_fast = _reach_m(h, v + dv, vt)
    far_high, drag_high = _reach_m(h + dh, v, vt)
    assert far_fast > far and drag_fast > drag
    assert far_high > far and drag_high >= drag - 1e-9  # (with drag and no wind the carry saturates with height)
    assert drag <= far + 1e-9  # drag only shortens the carry (no wind)


@settings(max_examples=40, deadline=None)
@given(h=st.floats(0.5, 120.0), vu=st.floats(-10.0, 5.0), vt=st.floats(2.0, 40.0))
def test_at_rest_in_calm_air_the_footprint_is_straight_below(h, vu, vt):
    fp = termination_footprint(12.0, -7.0, h, 0.0, 0.0, vu, 0.0, 0.0, vt, 0.0, 0.0)
    assert (fp.far_e_m, fp.far_n_m, fp.drag_e_m, fp.drag_n_m) == pytest.approx((12.0, -7.0, 12.0, -7.0), abs=1e-9)


# -- the compliance monitor -------------------------------------------------------------------------------------

DT = 0.025


def _run_monitor(env, commands, follow_tau_s: float | None, grace_s: float = 0.5, overshoot: float = 1.0):
    """Fly a command sequence ((roll, pitch) sticks per step) through the monitor, the vehicle a first-order lag of
    time constant ``follow_tau_s`` under a rate limit (None: it ignores the command and stays level): the time
    of the first flag, or None."""
    mon = ComplianceMonitor(env, grace_s)
    mon.start(0.0)
    tilt = min(env.max_bank_rad, env.max_pitch_rad) if env.is_multirotor else env.max_bank_rad
    roll = pitch = 0.0
    rate = math.radians(180.0) * DT
    for k, (rs, ps) in enumerate(commands):
        t = k * DT
        if mon.update(t, DT, StickCommand(roll=rs, pitch=ps), VehicleState(roll_rad=roll, pitch_rad=pitch)):
            return t
        if follow_tau_s is not None:
            a = min(1.0, DT / follow_tau_s)
            roll += max(-rate, min(rate, a * (overshoot * rs * tilt - roll)))
            pitch += max(-rate, min(rate, a * (overshoot * ps * tilt - pitch)))
    return None


_sticks = st.lists(
    st.tuples(st.sampled_from([-1.0, -0.5, 0.0, 0.3, 1.0]), st.sampled_from([-1.0, 0.0, 0.6, 1.0]), st.integers(4, 60)),
    min_size=1, max_size=12,
)  # fmt: skip


def _expand(segments):
    return [(r, p) for r, p, n in segments for _ in range(n)]


@settings(max_examples=60, deadline=None)
@given(segments=_sticks, faster=st.floats(0.3, 1.0), overshoot=st.floats(1.0, 1.12), multirotor=st.booleans())
def test_a_vehicle_that_follows_the_override_is_never_flagged(segments, faster, overshoot, multirotor):
    env = MC if multirotor else FW
    assert _run_monitor(env, _expand(segments), faster * env.reaction_time_s, overshoot=overshoot) is None


@pytest.mark.parametrize("env", [FW, MC], ids=["fixed_wing", "multirotor"])
@pytest.mark.parametrize("stick", [1.0, -1.0, 0.6])
def test_a_vehicle_ignoring_the_override_is_flagged_after_the_reaction_time_and_the_grace(env, stick):
    """Flagged ``reaction_time_s + grace_s`` after the override began (a command of at least ``threshold / (1 -
    1/e)``), else once the lag model is the threshold away from the level attitude, plus the grace; within the
    lag's discretisation."""
    grace = 0.5
    flagged = _run_monitor(env, [(stick, stick)] * 400, None, grace)
    mon = ComplianceMonitor(env, grace)
    command = abs(stick) * mon.max_roll_rad
    tau = mon.tau_s
    beyond = max(tau, tau * math.log(command / (command - mon.threshold_rad)))
    assert flagged is not None and abs(flagged - (beyond + grace)) <= 3 * DT  # (the monitor's lag is Euler's)


def test_a_small_command_ignored_is_not_a_flyaway():
    """A command within the threshold of the attitude (a gentle correction) is not flagged, followed or not."""
    assert _run_monitor(FW, [(0.2, 0.0)] * 400, None) is None


_watch_steps = st.lists(
    st.tuples(
        st.floats(-1.2, 1.2), st.floats(-1.2, 1.2), st.floats(-1.2, 1.2), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0),
        st.floats(-8.0, 8.0), st.booleans(), st.sampled_from([0.0, 0.0, 0.0, 2.0]),
    ),
    min_size=1, max_size=80,
)  # fmt: skip


@settings(max_examples=40, deadline=None)
@given(steps=_watch_steps, multirotor=st.booleans(), commanding=st.booleans())
def test_the_compiled_watch_is_its_interpreted_source(steps, multirotor, commanding):
    """:data:`watch` (what the unit's Python steps call) and a compiled flight step inline :func:`watch_step`: the
    compiled function keeps the same record as its source interpreted, step by step (within 1e-9), through mode
    changes, take-offs and touchdowns."""
    env = MC if multirotor else FW
    a, b = ComplianceMonitor(env, 0.5), ComplianceMonitor(env, 0.5)
    since = 0.0
    for k, (cr, cp, ct, roll, pitch, v_up, on_ground, new_mode) in enumerate(steps):
        t = k * DT
        since = t if new_mode else since
        args = (t, DT, commanding, since, cr, cp, ct, on_ground, roll, pitch, v_up)
        assert bool(watch(a.memory, *args)) == bool(watch_step(b.memory, *args))
        assert np.allclose(a.memory, b.memory, rtol=1e-9, atol=1e-9, equal_nan=True)


@given(v_up=st.floats(-20.0, 20.0), multirotor=st.booleans())
def test_the_climb_rate_a_stick_commands_inverts_the_stick_for_a_climb_rate(v_up, multirotor):
    """:func:`stick_to_climb_rate` (what the monitor expects) inverts :func:`climb_rate_to_stick` (what the guidance
    sends) within the envelope's rates, and saturates at them beyond."""
    env = MC if multirotor else FW
    rate = stick_to_climb_rate(climb_rate_to_stick(v_up, env), env)
    assert rate == pytest.approx(min(max(v_up, -env.max_descent_rate_mps), env.max_climb_rate_mps), abs=1e-9)


def _run_vertical(env, sticks, v_up_of, grace_s: float = 0.5):
    """Fly a sequence of vertical sticks (a multirotor's throttle, a fixed-wing's pitch) through the monitor, the
    vehicle's vertical speed ``v_up_of(k, commanded climb rate)`` at step ``k``: the time of the first flag, or None."""
    mon = ComplianceMonitor(env, grace_s)
    mon.start(0.0, VehicleState(v_up_mps=v_up_of(0, 0.0)))
    for k, stick in enumerate(sticks):
        rate = stick * (env.max_climb_rate_mps if stick >= 0.0 else env.max_descent_rate_mps)
        cmd = StickCommand(throttle=stick) if env.is_multirotor else StickCommand(pitch=stick)
        if mon.update(k * DT, DT, cmd, VehicleState(v_up_mps=v_up_of(k, rate))):
            return k * DT
    return None


@pytest.mark.parametrize("env", [FW, MC], ids=["fixed_wing", "multirotor"])
def test_a_vehicle_climbing_on_through_a_commanded_descent_is_flagged(env):
    """Climbing at its full rate while told to descend: flagged once the vertical bound (down from that climb at
    half the envelope's vertical acceleration, ``reaction_time_s`` after the command) is the threshold below the
    climb, plus twice the grace."""
    climb = env.max_climb_rate_mps
    flagged = _run_vertical(env, [-1.0] * 800, lambda k, rate: climb)
    bound_down_s = (NONCOMPLIANT_VERTICAL_MPS + 1e-9) / (VERTICAL_MODEL_ACCEL_FRACTION * env.vertical_accel_mps2)
    expected = env.reaction_time_s + bound_down_s + VERTICAL_GRACE_FACTOR * 0.5
    assert flagged is not None and abs(flagged - expected) <= 2 * DT, (flagged, expected)


_vertical_sticks = st.lists(st.tuples(st.sampled_from([-1.0, -0.4, 0.0, 0.5, 1.0]), st.integers(4, 80)), min_size=1, max_size=10)


@settings(max_examples=60, deadline=None)
@given(segments=_vertical_sticks, faster=st.floats(0.3, 1.0), overshoot_mps=st.floats(0.0, 1.0),
       sag_mps=st.floats(0.0, 6.0), multirotor=st.booleans())  # fmt: skip
def test_a_vehicle_following_the_vertical_command_is_never_flagged(segments, faster, overshoot_mps, sag_mps, multirotor):
    """A vehicle whose vertical speed comes to the commanded rate at least as quickly as the model (a first-order
    lag), overshooting a climb by up to 1 m/s, or sinking below the command by any amount, is following."""
    env = MC if multirotor else FW
    sticks = [v for v, n in segments for _ in range(n)]
    state = {"vz": 0.0}
    tau = faster * max(env.reaction_time_s, 2 * DT)

    def v_up(k, rate):
        vz = state["vz"] + min(1.0, DT / tau) * (rate - state["vz"])
        state["vz"] = vz
        return vz + (overshoot_mps if rate > 0.0 else 0.0) - (sag_mps if k % 50 < 25 else 0.0)

    assert _run_vertical(env, sticks, v_up) is None


def test_the_new_settings_are_validated():
    fence = {"keep_in": [[0.0, 0.0], [0.0, 0.01], [0.01, 0.01], [0.01, 0.0]], "ceiling_m": 100}
    cfg = parse_geofence({"fence": fence, "compliance_grace_s": 0.8, "termination_terminal_speed_mps": 12})
    assert (cfg.compliance_grace_s, cfg.termination_terminal_speed_mps) == (0.8, 12.0)
    with pytest.raises(ConfigError, match=r"^geofence\.termination_terminal_speed_mps: "):
        parse_geofence({"fence": fence, "termination_terminal_speed_mps": 0})
    with pytest.raises(ConfigError, match=r"^geofence\.compliance_grace_s: "):
        parse_geofence({"fence": fence, "compliance_grace_s": -1})


# -- the termination channel -------------------------------------------------------------------------------------


def _terminated_fall(model: str, agl_m: float, sticks: StickCommand):
    """``model`` started at ``agl_m`` (a multirotor hovering, a fixed-wing at cruise heading north), terminated at
    once and commanded ``sticks`` all the way down: ``(its start and touchdown states, the fall time)``."""
    from aircraft.factory import build_platform
    from aircraft.profile import load_profile

    pl = build_platform(load_profile(model))
    pl.set_wind_enu(0.0, 0.0, 0.0)
    pl.reset(FRAME, FRAME.lat0_deg, FRAME.lon0_deg, agl_m, 0.0, 0.0)
    start = pl.truth()
    pl.terminate()
    s, t = start, 0.0
    while not s.on_ground and t < 60.0:
        pl.command(sticks)
        pl.step(1)
        t += pl.dt_s
        s = pl.truth()
    return start, s, t


@pytest.mark.closed_loop
def test_a_terminated_multirotor_falls_whatever_its_sticks_say():
    start, down, t = _terminated_fall("F450RD", 30.0, StickCommand(throttle=1.0, pitch=-1.0))
    assert down.on_ground and no_drag_fall_s(30.0, 0.0) <= t <= 1.5 * no_drag_fall_s(30.0, 0.0)
    assert math.hypot(down.east_m - start.east_m, down.north_m - start.north_m) < 1.0  # (a full forward stick, ignored)


@pytest.mark.closed_loop
def test_a_terminated_fixed_wing_comes_down_short_of_its_no_drag_carry():
    start, down, t = _terminated_fall("Tern", 60.0, StickCommand(roll=-1.0, pitch=1.0, throttle=1.0))
    carry = math.hypot(down.east_m - start.east_m, down.north_m - start.north_m)
    assert down.on_ground and t < 15.0 and carry < start.ground_speed_mps * no_drag_fall_s(60.0, start.v_up_mps)


# -- the unit's decision ------------------------------------------------------------------------------------------


def _ignored_override(start_north_m: float, speed_mps: float = 20.0, agl_m: float = 60.0):
    """A unit overriding a Tern that flies on north at ``speed_mps``, wings level, while the unit commands a full
    bank, in a keep-in square of half side 400 m: ``(the unit, the time it terminated or None, the footprint
    margins it saw)``."""
    square = [latlon(e, n) for e, n in ((-400.0, -400.0), (400.0, -400.0), (400.0, 400.0), (-400.0, 400.0))]
    cfg = parse_geofence({"fence": {"keep_in": [list(p) for p in square], "ceiling_m": 150}}, "test")
    unit = GeofenceUnit(cfg, cfg.fence.to_local(FRAME), FW)
    unit.mode = Mode.OVERRIDE
    margins = []
    for k in range(600):
        t = k * DT
        est = VehicleState(t_s=t, north_m=start_north_m + speed_mps * t, agl_m=agl_m, v_north_mps=speed_mps)
        if unit.compliance.noncompliant:
            margins.append(unit.termination_margin_m(est)[0])
        if unit.watch_compliance(t, DT, StickCommand(roll=1.0), est):
            return unit, t, margins
    return unit, None, margins


def test_a_flyaway_whose_footprint_is_inside_is_terminated_before_it_leaves_and_no_later():
    unit, t, margins = _ignored_override(150.0)
    assert t is not None and unit.mode is Mode.TERMINATE
    assert unit.noncompliant_at_s == pytest.approx(FW.reaction_time_s + unit.config.compliance_grace_s, abs=DT)
    assert t > unit.noncompliant_at_s + 1.0  # it waited while the footprint had room
    lead = 20.0 * 2 * DT
    assert 0.0 <= margins[-1] <= lead and all(m > lead for m in margins[:-1])
    assert "before it leaves" in unit.transitions[-1].reason and unit.termination["footprint_margin_m"] >= 0.0


def test_a_flyaway_whose_footprint_is_outside_already_is_terminated_at_once():
    unit, t, margins = _ignored_override(330.0)
    assert t == pytest.approx(unit.noncompliant_at_s) and not margins  # (terminated at the step it was flagged)
    assert unit.termination["footprint_margin_m"] < 0.0
    assert "already outside: at once" in unit.transitions[-1].reason


# -- the closed loop ----------------------------------------------------------------------------------------------


def _flyaway(aircraft: str, kind: str, **run):
    res = fly_doc(edge_run_doc(aircraft, [{"kind": kind, "at_first_activation": True}], **run), f"flyaway_{aircraft}")
    s = res.summary
    assert s["completed"] and s["final_mode"] == "TERMINATE", s["mode_transitions"]
    assert s["terminated_at_s"] is not None and "does not follow the override" in s["termination_reason"]
    c = res.recorder.column
    first = s["first_activation_s"]
    detected = s["termination"]["noncompliant_at_s"] - first
    dt_s = c("time_s")[1] - c("time_s")[0]
    assert detected <= res.unit.env.reaction_time_s + res.unit.config.compliance_grace_s + dt_s, detected
    assert s["touchdown_margin_m"] is not None and s["touchdown_margin_m"] >= 0.0, s  # down inside the fence
    assert s["touchdown_en_m"] is not None  # it came down (on the ground)
    return res


@pytest.mark.closed_loop
def test_a_multirotor_flyaway_is_terminated_and_falls_inside():
    res = _flyaway("F450RD", "fc_ignores_override", agl_m=20.0, edge_m=100.0, duration_s=40.0, pitch=0.4)
    assert res.summary["max_excursion_m"] <= 0.0


@pytest.mark.closed_loop
@pytest.mark.parametrize("delay_s", [1.5, 1.7])
def test_a_vehicle_that_stops_following_late_in_the_override_is_not_handed_back(delay_s):
    """The flight controller starts ignoring the override as it comes to a stop, just before its hand-back: the
    override is not handed back while the vehicle lags behind what it sent (a hand-back restarts the watch on the
    pilot's sticks, and the pilot flies it out: terminated at once with its footprint outside), so the watch flags it
    in the override and it is terminated before its footprint leaves."""
    faults = [{"kind": "fc_ignores_override", "at_first_activation": True, "delay_s": delay_s}]
    res = fly_doc(edge_run_doc("F450RD", faults, agl_m=20.0, edge_m=100.0, duration_s=40.0, pitch=0.4), "late_flyaway")
    s = res.summary
    onset = s["first_activation_s"] + delay_s
    after = [tr for tr in s["mode_transitions"] if tr["t_s"] >= onset]
    assert [tr["to"] for tr in after] == ["TERMINATE"] and after[0]["from"] == "OVERRIDE", s["mode_transitions"]
    assert "before it leaves" in s["termination_reason"] and s["termination"]["footprint_margin_m"] >= 0.0
    assert s["touchdown_margin_m"] is not None and s["touchdown_margin_m"] >= 0.0 and s["max_excursion_m"] <= 0.0


@pytest.mark.closed_loop
def test_a_fixed_wing_flyaway_is_terminated_and_spins_down_inside():
    res = _flyaway("Tern", "fc_ignores_override", agl_m=60.0, edge_m=300.0, duration_s=40.0)
    s, c = res.summary, res.recorder.column
    t = c("time_s")
    k = (t > s["first_activation_s"] + 0.5) & (t < s["terminated_at_s"])
    assert k.sum() > 20 and (abs(c("cmd_roll")[k]) > 0.5).all() and (abs(c("roll_deg")[k]) < 3.0).all()  # a flyaway
    assert s["max_excursion_m"] <= 0.0
    assert s["termination"]["footprint_margin_m"] < 0.0 and "already outside: at once" in s["termination_reason"]


@pytest.mark.closed_loop
def test_a_frozen_flight_controller_is_terminated_inside():
    res = _flyaway("F450RD", "fc_freezes", agl_m=20.0, edge_m=100.0, duration_s=40.0, pitch=0.4)
    assert res.summary["max_excursion_m"] <= 0.0


@pytest.mark.closed_loop
def test_a_fast_fixed_wing_flyaway_is_terminated_before_its_footprint_leaves():
    """A c172x at 100 m and 58 m/s: its footprint is still inside at detection, so the unit waits until it is
    about to leave (and no longer), then terminates."""
    res = _flyaway("c172x", "fc_ignores_override", agl_m=100.0, edge_m=800.0, duration_s=60.0)
    s = res.summary
    assert "before it leaves" in s["termination_reason"] and s["terminated_at_s"] > s["termination"]["noncompliant_at_s"]
    assert s["termination"]["footprint_margin_m"] >= 0.0 and s["max_excursion_m"] <= 0.0


@pytest.mark.closed_loop
@pytest.mark.parametrize("index", [222, 145])
def test_a_terminated_multirotor_ends_at_its_impact_without_diverging(index):
    """A motors-off fall strikes the ground at 20+ m/s: the flight ends there (completed, its touchdown recorded),
    not in the model's gear bouncing it back up and diverging: two cases of the first fault campaign (seed
    20261125, a Micro250 whose flight controller froze), which diverged before."""
    from scenarios.campaign.generator import DEFAULT_FAMILIES, DEFAULT_PLATFORMS, Variant, build_case, case_family

    case = build_case(index, 20261125, case_family(index, DEFAULT_FAMILIES), DEFAULT_PLATFORMS, 120.0, faults=True)
    assert case is not None and case.manifest["faults"][0]["kind"] == "fc_freezes"
    s = fly_doc(case.documents[Variant.PREDICTIVE], case.case_id).summary
    assert s["completed"] and s.get("incomplete_reason") is None, s.get("incomplete_reason")
    assert s["terminated_at_s"] is not None and s["touchdown_en_m"] is not None


@pytest.mark.closed_loop
@pytest.mark.parametrize("aircraft", ["F450RD", "Tern"])
def test_a_flyaway_up_through_the_ceiling_is_terminated_within_the_contingency_volume(aircraft):
    """A vehicle climbing at its full rate into the ceiling whose flight controller ignores the override (which
    commands a descent): the vertical watch flags the climb and the unit terminates it before it coasts through
    the ceiling, so it tops out within the contingency volume's height ``H_CV`` (before: no watch, it climbed on)."""
    from aircraft.profile import load_profile
    from analysis.containment import ContingencyInputs, contingency_volume

    env = load_profile(aircraft).envelope
    if env.is_multirotor:
        seg, start = {"duration_s": 40.0, "sticks": {"roll": 0.0, "pitch": 0.0, "yaw": 0.0, "throttle": 1.0}}, (0.0, 0.0)
    else:
        seg, start = {"duration_s": 40.0, "course_deg": 0, "speed": "cruise", "climb": "max"}, (0.0, -300.0)
    fault = [{"kind": "fc_ignores_override", "at_first_activation": True}]
    s = fly_doc(fault_scenario_doc(aircraft, fault, duration_s=40.0, agl_m=110.0, segments=[seg], start_en=start)).summary
    assert s["final_mode"] == "TERMINATE" and "through the ceiling" in s["termination_reason"], s["mode_transitions"]
    assert s["termination"]["axis"] == "vertical"
    limit = min(env.max_bank_rad, env.max_pitch_rad) if env.is_multirotor else env.max_bank_rad
    h_cv = contingency_volume(ContingencyInputs(env.kind, env.max_speed_mps, env.reaction_time_s, limit), 150.0).h_cv_m
    assert 0.0 < s["max_vertical_excursion_m"] <= h_cv, (s["max_vertical_excursion_m"], h_cv)
    assert s["touchdown_margin_m"] is not None and s["touchdown_margin_m"] > 0.0


def _noncompliant_unit(fence: dict, est: VehicleState):
    """A unit overriding a fixed-wing held at ``est`` that ignores a full bank command: ``(the unit, whether it
    terminated it)``."""
    cfg = parse_geofence({"fence": fence}, "test")
    unit = GeofenceUnit(cfg, cfg.fence.to_local(FRAME), FW)
    unit.mode = Mode.OVERRIDE
    for k in range(400):
        t = k * DT
        if unit.watch_compliance(t, DT, StickCommand(roll=1.0), dataclasses.replace(est, t_s=t)):
            return unit, True
    return unit, False


_SQUARE = [list(latlon(e, n)) for e, n in ((-400.0, -400.0), (400.0, -400.0), (400.0, 400.0), (-400.0, 400.0))]


def test_a_floor_alone_is_no_reason_to_terminate_but_a_gap_under_the_footprint_is():
    """Over a floor, away from its gaps, a vehicle that does not follow is not terminated while its footprint has
    lateral room (a fall through the floor is no better than its own descent); over a gap it is, at once."""
    gap = [list(latlon(e, n)) for e, n in ((-60.0, -60.0), (60.0, -60.0), (60.0, 60.0), (-60.0, 60.0))]
    fence = {"keep_in": _SQUARE, "ceiling_m": 150, "floor_m": 30, "floor_gaps": [gap]}
    hovering_away = VehicleState(east_m=-250.0, north_m=0.0, agl_m=40.0)
    unit, terminated = _noncompliant_unit(fence, hovering_away)
    assert unit.compliance.noncompliant and not terminated and unit.mode is Mode.OVERRIDE
    unit, terminated = _noncompliant_unit(fence, VehicleState(east_m=0.0, north_m=0.0, agl_m=40.0))
    assert terminated and "over a floor gap" in unit.transitions[-1].reason


def test_a_vehicle_missing_only_the_climb_is_terminated_only_near_the_ceiling():
    """A vehicle that follows the attitude but climbs on through a commanded descent is still steered sideways: it
    is not terminated for its footprint or over a gap, only once its coast once cut would reach the ceiling."""
    gap = [list(latlon(e, n)) for e, n in ((-60.0, -60.0), (60.0, -60.0), (60.0, 60.0), (-60.0, 60.0))]
    fence = {"keep_in": _SQUARE, "ceiling_m": 150, "floor_m": 30, "floor_gaps": [gap]}
    cfg = parse_geofence({"fence": fence}, "test")
    unit = GeofenceUnit(cfg, cfg.fence.to_local(FRAME), FW)
    unit.mode = Mode.OVERRIDE
    heights = []
    for k in range(2000):
        t = k * DT
        est = VehicleState(t_s=t, east_m=0.0, north_m=0.0, agl_m=60.0 + 4.0 * t, v_up_mps=4.0)  # (over the gap)
        if unit.watch_compliance(t, DT, StickCommand(pitch=-1.0), est):
            break
        heights.append(est.agl_m)
    assert unit.mode is Mode.TERMINATE and unit.termination["axis"] == "vertical"
    assert "through the ceiling" in unit.transitions[-1].reason
    assert unit.compliance.climb_missed and not unit.compliance.attitude_missed
    assert 140.0 < heights[-1] < 150.0  # (cut where its coast, 0.8 m, and the margins still fit under 150 m)


def test_the_landing_is_watched_too():
    """In a landing (LAND_IN_GAP) the unit commands as in an override: a vehicle banking away from the commanded
    wings-level descent, with its footprint at the edge, is terminated as not following the landing."""
    cfg = parse_geofence({"fence": {"keep_in": _SQUARE, "ceiling_m": 150}}, "test")
    unit = GeofenceUnit(cfg, cfg.fence.to_local(FRAME), FW)
    unit.mode = Mode.LAND_IN_GAP
    assert unit.commanding
    for k in range(400):
        t = k * DT
        est = VehicleState(t_s=t, north_m=380.0, agl_m=40.0, v_north_mps=15.0, roll_rad=math.radians(40.0))
        if unit.watch_compliance(t, DT, StickCommand(roll=-1.0, pitch=-1.0), est):
            break
    assert unit.mode is Mode.TERMINATE and "does not follow the landing" in unit.transitions[-1].reason
    unit.mode = Mode.MONITOR
    assert not unit.commanding


@pytest.mark.closed_loop
@pytest.mark.parametrize("aircraft, agl_m", [("F450RD", 40.0), ("Micro250", 60.0)])
def test_a_flight_controller_freezing_while_the_pilot_flies_is_terminated_inside(aircraft, agl_m):
    """The pilot flies forward, then brakes and backs off; the flight controller froze on the forward stick
    half a second before. Watched on the pilot's sticks the unit passes through, the freeze is flagged as soon as
    the pilot's command moves, and the vehicle is terminated before its footprint leaves the fence (before: found
    only at the override near the edge, with the footprint already outside; it came down 4.8 m and 14.4 m out)."""
    hold = {"roll": 0.0, "pitch": 0.0, "yaw": 0.0, "throttle": 0.0}
    segments = [{"duration_s": 3.0, "sticks": {**hold, "pitch": -0.7}}, {"duration_s": 37.0, "sticks": {**hold, "pitch": 0.7}}]
    doc = fault_scenario_doc(
        aircraft, [{"kind": "fc_freezes", "at_s": 2.5}], duration_s=40.0, half_m=150.0, agl_m=agl_m,
        segments=segments, start_en=(0.0, -100.0),
    )  # fmt: skip
    s = fly_doc(doc).summary
    assert s["final_mode"] == "TERMINATE" and "does not follow the pilot's sticks" in s["termination_reason"], s
    assert s["first_activation_s"] is None  # (no override was needed to find it)
    assert s["max_lateral_excursion_m"] < 0.0 and s["touchdown_margin_m"] > 0.0
