"""Figures and reports that say what was flown (issue 41, the output half): synthetic flights, nothing flies."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest

from aircraft.profile import load_profile
from analysis.plots import flight_figure
from geofence.geometry.fence import parse_fence
from geofence.geometry.geodesy import LocalFrame
from geofence.unit.geofence_unit import Mode

FRAME = LocalFrame(47.4, 8.5, 0.0)


def square_fence(half_m: float, **kw):
    """A square keep-in of +-half_m about the frame's origin (local metres)."""
    corners = ((-half_m, -half_m), (half_m, -half_m), (half_m, half_m), (-half_m, half_m))
    m = {"keep_in": [list(FRAME.to_geodetic(x, y, 0.0)[:2]) for x, y in corners], "ceiling_m": 120.0}
    m.update(kw)
    return parse_fence(m, "test").to_local(FRAME)


def flight_east(n: int = 400, dt_s: float = 0.1, speed_mps: float = 10.0) -> dict[str, np.ndarray]:
    """A flight east at ``speed_mps`` in a 5 m/s westerly, overridden once (activation at 30 % of the flight)."""
    t = np.arange(n) * dt_s
    mode = np.full(n, int(Mode.MONITOR))
    mode[int(0.3 * n) : int(0.5 * n)] = int(Mode.OVERRIDE)
    mode[int(0.5 * n) :] = int(Mode.RECOVERED)
    return {
        "time_s": t,
        "east_m": speed_mps * t - 150.0,
        "north_m": np.zeros(n),
        "agl_m": np.full(n, 40.0),
        "ground_speed_mps": np.full(n, speed_mps),
        "airspeed_mps": np.full(n, speed_mps - 5.0),
        "wind_east_mps": np.full(n, 5.0),
        "wind_north_mps": np.zeros(n),
        "geofence_mode": mode.astype(float),
        "activation_margin_m": np.linspace(30.0, -5.0, n),
    }


def track_labels(fig) -> list[str]:
    """Every label on the ground-track axes (the first), artists and legend entries."""
    ax = fig.axes[0]
    labels = [a.get_label() for a in ax.get_children()]
    legend = ax.get_legend()
    if legend is not None:
        labels += [t.get_text() for t in legend.get_texts()]
    return labels


@pytest.mark.parametrize("trigger, drawn", [("reactive", False), ("predictive", True), (None, True)])
def test_the_activation_boundary_is_drawn_only_for_the_unit_that_uses_it(trigger, drawn):
    """A reactive unit acts on the fence line: its figure drew a predictive boundary 100+ m inside it."""
    fig = flight_figure(
        flight_east(), "test", fence=square_fence(300.0), envelope=load_profile("F450RD").envelope, trigger=trigger
    )
    try:
        boundary = [label for label in track_labels(fig) if "activation boundary" in str(label)]
        contours = [c for c in fig.axes[0].get_children() if type(c).__name__ in ("QuadContourSet", "ContourSet")]
        assert bool(boundary) is drawn, boundary
        assert bool(contours) is drawn
    finally:
        plt.close(fig)


def panel(fig, ylabel: str):
    return next(ax for ax in fig.axes if ax.get_ylabel() == ylabel)


def line(ax, starts: str):
    return next(ln for ln in ax.get_lines() if str(ln.get_label()).startswith(starts))


def test_no_floor_margin_is_drawn_over_a_floor_gap_as_the_legend_says():
    gap = [list(FRAME.to_geodetic(x, y, 0.0)[:2]) for x, y in ((-20, -20), (20, -20), (20, 20), (-20, 20))]
    fence = square_fence(300.0, floor_m=10.0, floor_gaps=[gap])
    traj = flight_east()
    fig = flight_figure(traj, "test", fence=fence, envelope=load_profile("F450RD").envelope)
    try:
        floor = line(panel(fig, "vertical margin (m)"), "above the floor")
        over_gap = np.abs(traj["east_m"]) < 20.0
        assert "no line: over a floor gap" in floor.get_label()
        assert np.isnan(floor.get_ydata()[over_gap]).all()
        assert np.isfinite(floor.get_ydata()[np.abs(traj["east_m"]) > 21.0]).all()
    finally:
        plt.close(fig)


def test_the_keep_in_margin_is_drawn_apart_from_a_nearer_keep_out():
    """The keep-in line was min(keep-in, keep-out): near a keep-out it hid under the keep-out's line."""
    box = [list(FRAME.to_geodetic(x, y, 0.0)[:2]) for x, y in ((-160, 10), (-140, 10), (-140, 30), (-160, 30))]
    fence = square_fence(300.0, keep_out_polygons=[{"polygon": box}])
    traj = flight_east()
    fig = flight_figure(traj, "test", fence=fence, envelope=load_profile("F450RD").envelope)
    try:
        keep_in = line(panel(fig, "lateral margin (m)"), "to the keep-in edge").get_ydata()
        expected = 300.0 - np.abs(traj["east_m"])  # the nearest keep-in edge is east or west
        assert np.allclose(keep_in, expected, atol=0.5)
    finally:
        plt.close(fig)


# --------------------------------------------------------------------------- the shipped examples
ROOT = Path(__file__).parents[1]
AIRSPACE_EXAMPLES = sorted((ROOT / "scenarios" / "airspace").glob("*.yaml"))
"""The airspace examples (the examples of scenarios/ itself fly in tests/test_closed_loop.py)."""


@pytest.mark.slow
@pytest.mark.parametrize("path", AIRSPACE_EXAMPLES, ids=[p.name for p in AIRSPACE_EXAMPLES])
def test_every_airspace_example_runs_to_completion(path):
    """Issue 41: the four airspace examples ran out of duration_s ("NOT completed", exit 1)."""
    from scenarios.definition.schema import load_scenario
    from scenarios.flight.runner import fly

    summary = fly(load_scenario(path)).summary
    assert summary["completed"], f"{path.name}: {summary.get('mission_progress')} at {summary.get('sim_time_s')} s"
    if path.parent.name == "airspace" and "large_fence" in path.name:
        assert summary["activations"] >= 1  # the avenues end inside the activation room: the unit turns it back


def test_compare_says_an_unreadable_summary_on_stderr_and_counts_it_apart(tmp_path):
    """Issue 41: a corrupt summary.json was counted as a failed "unknown" flight without a word."""
    (tmp_path / "good").mkdir()
    good = {"flight": "good", "aircraft": "F450RD", "platform_kind": "multirotor", "completed": True, "geofence": True,
            "wind_speed_mps": 4.0, "max_excursion_m": -2.0, "activations": 1}  # fmt: skip
    (tmp_path / "good" / "summary.json").write_text(json.dumps(good))
    (tmp_path / "torn").mkdir()
    (tmp_path / "torn" / "summary.json").write_text('{"flight": "torn", "aircr')
    res = subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "compare", str(tmp_path)], capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 0, res.stderr
    assert res.stderr.count("\n") == 1 and "torn/summary.json: unreadable (" in res.stderr, res.stderr
    assert "| unknown |" not in res.stdout and "(1 unreadable summary.json counted apart" in res.stdout
    assert "| F450RD (multirotor) | predictive | 4 m/s | 1 | 0 | 0/1 |" in res.stdout
