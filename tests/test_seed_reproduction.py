"""The seed-flight reproduction: breach-attempts pilot, set-point ramp, per-axis statistics, and closed loop.

Closed-loop tests fly the shipped ``scenarios/paper`` files shortened to a few
attempts (tens of simulated seconds each).
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence.interface import Envelope, PlatformKind, VehicleState
from geofence.recovery.guidance import SeedPDGains, SeedPDRecovery, StraightRoute
from scenarios.app.seed_reproduction import (
    PREDICTIVE_SCENARIO,
    REACTIVE_SCENARIO,
    Boundaries,
    analyse_flight,
    attempt_rows,
    attempts_from_items,
    axis_statistics,
    compare_reactive_predictive,
    pearson_r,
    ramp_setpoints,
)
from scenarios.definition.schema import BreachAttemptsConfig, SpeedDraw, load_scenario, parse_scenario
from scenarios.flight.pilots.breach_attempts import BreachAttemptsPilot, draw_speeds

ENV = Envelope(
    PlatformKind.MULTIROTOR, 13.0, 22.6, 0.0, math.radians(20), math.radians(20), math.radians(90), 1.0, 0.8, 3.5, 3.0, 0.25
)


# --------------------------------------------------------------------------- the ramp
@given(
    start=st.tuples(*[st.floats(-5, 5)] * 3),
    goal=st.tuples(*[st.floats(-5, 5)] * 3),
    ramp_s=st.floats(0.5, 6.0),
    t0=st.floats(0.0, 100.0),
    frac=st.floats(0.0, 1.0),
)
@settings(max_examples=60, deadline=None)
def test_seed_pd_setpoint_ramps_linearly_over_ramp_s(start, goal, ramp_s, t0, frac):
    law = SeedPDRecovery(ENV, SeedPDGains(), ramp_s)
    law.start(VehicleState(east_m=start[0], north_m=start[1]), StraightRoute(goal[0], goal[1]), goal[2], start[2], t0)
    sp = law.setpoint(t0 + frac * ramp_s)
    for k in range(3):
        assert sp[k] == pytest.approx(start[k] + frac * (goal[k] - start[k]), abs=1e-9)
    assert law.setpoint(t0 + ramp_s + 1.0) == pytest.approx(goal, abs=1e-12)  # held at the goal after the ramp
    assert law.setpoint(t0) == pytest.approx(start, abs=1e-12)


def test_ramp_setpoints_recomputed_from_transitions():
    t = np.arange(0.0, 10.0, 0.025)
    mode = np.where((t >= 2.0) & (t < 7.0), 1, 0)
    traj = {
        "time_s": t,
        "east_m": -0.75 - 0.1 * t,
        "north_m": np.zeros_like(t),
        "agl_m": np.full_like(t, 0.9),
        "geofence_mode": mode,
    }
    trans = [
        {"t_s": 2.0, "from": "MONITOR", "to": "OVERRIDE"},
        {"t_s": 4.0, "from": "OVERRIDE", "to": "OVERRIDE"},
        {"t_s": 7.0, "from": "OVERRIDE", "to": "RECOVERED"},
    ]
    sp = ramp_setpoints(traj, trans, (0.0, 0.0, 0.8), ramp_s=3.0)
    i2, i35, i5, i6 = (int(np.searchsorted(t, x - 1e-9)) for x in (2.0, 3.5, 5.0, 6.0))
    e_breach = -0.75 - 0.2
    assert np.isnan(sp["east_m"][:i2]).all() and np.isnan(sp["east_m"][int(np.searchsorted(t, 7.0 - 1e-9)) :]).all()
    assert sp["east_m"][i2] == pytest.approx(e_breach)
    assert sp["east_m"][i35] == pytest.approx(0.5 * e_breach)  # halfway through the 3 s ramp; the re-activation keeps it
    assert sp["height_m"][i35] == pytest.approx(0.85)
    assert sp["east_m"][i5] == pytest.approx(0.0) and sp["east_m"][i6] == pytest.approx(0.0)


# --------------------------------------------------------------------------- statistics
def _synthetic(peaks_by_attempt, directions, v_act):
    """A trajectory with attempts of 10 s; attempt k peaks at ``peaks[k]`` beyond its boundary at t = 10k + 5 s."""
    b = Boundaries(-0.75, 0.75, 1.1)
    t = np.arange(0.0, 10.0 * len(peaks_by_attempt), 0.05)
    e, n, h = np.zeros_like(t), np.zeros_like(t), np.full_like(t, 0.8)
    ve, vn, vu = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
    trans, attempts = [], []
    for k, (p, d) in enumerate(zip(peaks_by_attempt, directions)):
        sel = (t >= 10 * k) & (t < 10 * k + 10)
        bump = np.clip(1.0 - np.abs(t[sel] - (10 * k + 5)) / 3.0, 0.0, None)  # triangle, 1 at t = 10k + 5
        i_act = int(np.searchsorted(t, 10 * k + 4.0 - 1e-9))
        if d == "west":
            e[sel] = (b.west_m - p) * bump
            ve[i_act] = -v_act[k]
        elif d == "north":
            n[sel] = (b.north_m + p) * bump
            vn[i_act] = v_act[k]
        else:
            h[sel] = 0.8 + (b.ceiling_m + p - 0.8) * bump
            vu[i_act] = v_act[k]
        attempts.append({"attempt": k, "direction": d, "speed_mps": v_act[k], "t_start_s": 10.0 * k})
        trans += [
            {"t_s": float(t[i_act]), "from": "MONITOR", "to": "OVERRIDE"},
            {"t_s": float(t[i_act]) + 2.0, "from": "OVERRIDE", "to": "OVERRIDE"},
        ]
    traj = {"time_s": t, "east_m": e, "north_m": n, "agl_m": h, "v_east_mps": ve, "v_north_mps": vn, "v_up_mps": vu}
    return traj, trans, attempts, b


def test_axis_statistics_on_known_excursions():
    directions = ["west", "north", "up"] * 3
    peaks = [0.30, 0.10, 0.05, 0.50, -0.20, 0.15, 0.10, 0.40, 0.10]
    v_act = [0.5, 0.3, 0.4, 0.9, 0.1, 0.8, 0.2, 0.7, 0.6]
    traj, trans, attempts, b = _synthetic(peaks, directions, v_act)
    rows = attempt_rows(traj, trans, attempts, b)
    assert [r["axis"] for r in rows] == ["x", "y", "ceiling"] * 3
    assert [r["peak_m"] for r in rows] == pytest.approx(peaks, abs=1e-9)
    assert [r["v_activation_mps"] for r in rows] == pytest.approx(v_act)
    assert all(r["activations"] == 1 for r in rows)  # the re-activation is not a new activation
    stats = axis_statistics(rows)
    for axis, idx in (("x", [0, 3, 6]), ("y", [1, 4, 7]), ("ceiling", [2, 5, 8])):
        p = np.array(peaks)[idx]
        assert stats[axis]["mean_m"] == pytest.approx(p.mean(), abs=1e-9)
        assert stats[axis]["sd_m"] == pytest.approx(p.std(ddof=1), abs=1e-9)
        assert stats[axis]["crossed"] == int((p > 0).sum())
        assert stats[axis]["r_overshoot_velocity"] == pytest.approx(np.corrcoef(np.array(v_act)[idx], p)[0, 1], abs=1e-9)
    assert stats["y"]["crossed"] == 2  # the -0.20 attempt stayed inside


def test_pearson_r_edge_cases():
    assert pearson_r([1, 2, 3], [2, 4, 6]) == pytest.approx(1.0)
    assert pearson_r([1, 2, 3], [3, 2, 1]) == pytest.approx(-1.0)
    assert math.isnan(pearson_r([1, 2], [1, 2]))
    assert math.isnan(pearson_r([1, 1, 1], [1, 2, 3]))
    assert pearson_r([1, 2, np.nan, 3], [1, 2, 5, 3]) == pytest.approx(1.0)


# --------------------------------------------------------------------------- the pilot
def test_pilot_speeds_reproducible_by_seed():
    cfg = BreachAttemptsConfig(attempts=12, speed_mps=(0.2, 1.0), seed=3)
    a, b = draw_speeds(cfg), draw_speeds(BreachAttemptsConfig(attempts=12, speed_mps=(0.2, 1.0), seed=3))
    assert np.array_equal(a, b)
    assert not np.allclose(a, draw_speeds(BreachAttemptsConfig(attempts=12, speed_mps=(0.2, 1.0), seed=4)))
    assert a.min() >= 0.2 and a.max() <= 1.0 and a.max() - a.min() > 0.3
    p = BreachAttemptsPilot(cfg, ENV, VehicleState(), 0.025)
    assert [p.direction(k) for k in range(4)] == ["west", "north", "up", "west"]
    assert p.speed(2) == min(a[2], ENV.max_climb_rate_mps)
    assert p.items_total == 12 and p.items_reached == 0 and not p.finished


def test_per_round_speeds_match_across_the_directions_of_a_round():
    cfg = BreachAttemptsConfig(
        attempts=8, directions=("west", "north", "up"), speed_mps=(0.2, 1.0), seed=3, speed_draw=SpeedDraw.PER_ROUND
    )
    a = draw_speeds(cfg)
    assert len(a) == 8 and np.array_equal(a, draw_speeds(cfg))
    assert a[0] == a[1] == a[2] and a[3] == a[4] == a[5] and a[6] == a[7]
    assert len(set(a.tolist())) == 3 and a.min() >= 0.2 and a.max() <= 1.0
    # per attempt (the default) is what it was: one draw per attempt
    b = draw_speeds(BreachAttemptsConfig(attempts=8, speed_mps=(0.2, 1.0), seed=3))
    assert np.array_equal(b, np.random.default_rng(3).uniform(0.2, 1.0, 8))


# --------------------------------------------------------------------------- closed loop
def _short(path, attempts=4, directions=("west", "north")):
    raw = yaml.safe_load(path.read_text())
    raw = copy.deepcopy(raw)
    raw["pilot"].update(attempts=attempts, directions=list(directions), speed_mps=[0.25, 1.0], seed=7, speed_draw="per_attempt")
    raw["duration_s"] = 90
    return parse_scenario(raw, where=str(path), default_name=path.stem)


def _fly(scenario):
    import scenarios.flight.runner as runner

    result = runner.fly(scenario)
    return result, result.pilot


def test_shipped_seed_scenarios_load():
    r, p = load_scenario(REACTIVE_SCENARIO), load_scenario(PREDICTIVE_SCENARIO)
    assert r.geofence.trigger == "reactive" and r.geofence.multirotor_law == "seed_pd" and r.geofence.ramp_s == 3.0
    assert p.geofence.trigger == "predictive"
    assert r.pilot.breach == p.pilot.breach  # the same attempts
    assert r.geofence.fence.recovery_point[2] == 0.8 and r.geofence.fence.ceiling_m == 1.1


@pytest.mark.closed_loop
def test_reactive_overshoots_and_grows_with_speed_predictive_does_not():
    reactive, pilot = _fly(_short(REACTIVE_SCENARIO))
    assert pilot.finished and len(pilot.attempt_log) == 4
    an_r = analyse_flight(reactive)
    lateral = [r for r in an_r.rows if r["axis"] in ("x", "y")]
    assert len(lateral) == 4
    assert all(r["peak_m"] > 0.05 for r in lateral)  # the reactive fence is crossed every time
    v = np.array([r["v_activation_mps"] for r in lateral])
    p = np.array([r["peak_m"] for r in lateral])
    assert v.max() - v.min() > 0.2  # the drawn speeds are spread
    assert p[np.argmax(v)] > p[np.argmin(v)] + 0.1  # overshoot grows with the speed at activation
    assert pearson_r(v, p) > 0.8

    predictive, pilot_p = _fly(_short(PREDICTIVE_SCENARIO))
    assert [a["speed_mps"] for a in pilot_p.attempt_log] == [a["speed_mps"] for a in pilot.attempt_log]
    an_p = analyse_flight(predictive)
    assert len(an_p.rows) == 4
    assert max(r["peak_m"] for r in an_p.rows) <= 0.05
    assert all(r["activations"] >= 1 for r in an_p.rows)  # it acted (early), it was not just never approached
    table = compare_reactive_predictive(an_r, an_p)
    assert "indoor_quad" in table and "indoor_quad_predictive" in table and table.count("\n") == 4


@pytest.mark.closed_loop
def test_ceiling_attempt_breaches_reactive_fence_and_ramp_recorded():
    result, pilot = _fly(_short(REACTIVE_SCENARIO, attempts=2, directions=("up",)))
    an = analyse_flight(result)
    assert [r["axis"] for r in an.rows] == ["ceiling", "ceiling"]
    assert all(r["peak_m"] > 0.0 for r in an.rows)
    assert an.setpoints is not None
    override = an.traj["geofence_mode"] == 1
    assert override.any() and np.isfinite(an.setpoints["height_m"][override]).all()
    # the ramp ends at the recovery height
    assert np.nanmin(an.setpoints["height_m"]) == pytest.approx(0.8, abs=1e-9)


@pytest.mark.closed_loop
def test_predictive_quad_is_handed_back_at_its_recovery_height_under_the_ceiling():
    # 0.8 m set-point under a 1.1 m ceiling: at rest there a climb through the reaction time needs 0.23 m of
    # the 0.3 m, less than the 0.11 m hysteresis leaves; the hand-back is judged at the goal's own margin
    result, pilot = _fly(_short(PREDICTIVE_SCENARIO, attempts=2, directions=("up",)))
    transitions = result.summary["mode_transitions"]
    overrides = [i for i, tr in enumerate(transitions) if tr["to"] == "OVERRIDE"]
    assert overrides and transitions[overrides[0]]["reason"].startswith("vertical")
    assert all(any(tr["to"] == "RECOVERED" for tr in transitions[i + 1 :]) for i in overrides)
    assert pilot.finished and result.summary["final_mode"] in ("MONITOR", "RECOVERED")
    assert result.summary["max_vertical_excursion_m"] < 0.0


@pytest.mark.closed_loop
def test_flight_reproducible_and_schedule_rebuilt_from_items():
    sc = _short(REACTIVE_SCENARIO, attempts=3)
    r1, p1 = _fly(sc)
    r2, p2 = _fly(sc)
    assert p1.attempt_log == p2.attempt_log
    assert np.array_equal(r1.recorder.column("east_m"), r2.recorder.column("east_m"))
    traj = {c: r1.recorder.column(c) for c in ("time_s", "mission_item")}
    rebuilt = attempts_from_items(traj, sc.pilot.breach)
    assert [a["direction"] for a in rebuilt] == [a["direction"] for a in p1.attempt_log]
    assert [a["speed_mps"] for a in rebuilt] == pytest.approx([a["speed_mps"] for a in p1.attempt_log], abs=1e-4)
    assert [a["t_start_s"] for a in rebuilt[1:]] == pytest.approx([a["t_start_s"] for a in p1.attempt_log[1:]], abs=1e-6)
