"""The seed-flight reproduction: per-attempt overshoot statistics, reactive vs predictive.

Flies (or reads back) ``scenarios/paper/indoor_quad.yaml`` (reactive fence,
published PD law with a 3 s set-point ramp) and
``scenarios/paper/indoor_quad_predictive.yaml`` (the same attempts behind our
predictive fence), splits each flight into the pilot's breach attempts and
reports, per axis,

* the **peak excursion** beyond the boundary the attempt aimed at, per attempt
  (x: the west line, ``west - east``; y: the north line, ``north - line``;
  ceiling: ``agl - ceiling``; > 0 metres beyond, <= 0 never crossed: the
  closest approach), its mean and sample standard deviation;
* the **velocity toward that boundary at activation** (the state the geofence
  saw at the step it took over, the first activation of the attempt);
* the **Pearson correlation** of peak excursion with that velocity (the seed
  observation: overshoot grows with the speed at activation).

Entry points: :func:`analyse_flight` (a :class:`~scenarios.flight.runner.FlightResult`),
:func:`analyse_folder` (a written ``trajectory.csv`` + ``summary.json``;
attempts from ``attempts.json`` if present, else rebuilt from the
``mission_item`` column and the pilot's seed), :func:`compare_reactive_predictive`
(markdown table), and ``python -m scenarios.app.seed_reproduction OUT_DIR [--no-fly]``
which flies both scenarios into ``OUT_DIR`` (or reads them), writes
``OUT_DIR/seed_reproduction.md`` and the figures of :mod:`analysis.paper_plots`.
Works on recorded arrays only; no JSBSim import unless it flies.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from geofence.unit.config import MultirotorLaw

REPO = Path(__file__).resolve().parents[2]
REACTIVE_SCENARIO = REPO / "scenarios" / "paper" / "indoor_quad.yaml"
PREDICTIVE_SCENARIO = REPO / "scenarios" / "paper" / "indoor_quad_predictive.yaml"

AXES = ("x", "y", "ceiling")
AXIS_LABEL = {"x": "x (west line)", "y": "y (north line)", "ceiling": "ceiling"}
DIRECTION_AXIS = {"west": "x", "north": "y", "up": "ceiling", "east": "x+", "south": "y-"}


@dataclass(frozen=True)
class Boundaries:
    """The three boundaries of the seed fence, local ENU m / height m in the fence's reference."""

    west_m: float = -0.75
    north_m: float = 0.75
    ceiling_m: float = 1.1


def boundaries_from_fence(fence) -> Boundaries:
    """West line (min east of the keep-in), north line (max north) and ceiling of a :class:`LocalFence`."""
    v = np.asarray(fence.keep_in.vertices, dtype=float)
    return Boundaries(float(v[:, 0].min()), float(v[:, 1].max()), float(fence.ceiling_m))


def excursions(traj: Mapping[str, np.ndarray], b: Boundaries) -> dict[str, np.ndarray]:
    """Signed distance beyond each boundary per row (m; > 0 outside)."""
    return {
        "x": b.west_m - np.asarray(traj["east_m"], float),
        "y": np.asarray(traj["north_m"], float) - b.north_m,
        "ceiling": np.asarray(traj["agl_m"], float) - b.ceiling_m,
    }


def closing_velocities(traj: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Velocity toward each boundary per row (m/s; > 0 closing)."""
    return {
        "x": -np.asarray(traj["v_east_mps"], float),
        "y": np.asarray(traj["v_north_mps"], float),
        "ceiling": np.asarray(traj["v_up_mps"], float),
    }


def normalise_transitions(transitions: Iterable[Any]) -> list[dict]:
    """Unit transitions (``Transition`` objects or their ``as_dict()``) as dicts with t_s, from, to, reason."""
    out = []
    for tr in transitions:
        out.append(tr.as_dict() if hasattr(tr, "as_dict") else dict(tr))
    return out


def activation_times(transitions: Iterable[Any]) -> np.ndarray:
    """Times (s) at which an override started (MONITOR/RECOVERED -> OVERRIDE; re-activations excluded)."""
    return np.array(
        [t["t_s"] for t in normalise_transitions(transitions) if t["to"] == "OVERRIDE" and t["from"] != "OVERRIDE"], float
    )


def attempts_from_items(traj: Mapping[str, np.ndarray], breach_config) -> list[dict]:
    """Rebuild the attempt schedule from the ``mission_item`` column (attempts done) and the pilot's seed.

    Window of attempt k: the rows with ``mission_item == k`` (attempt 0 includes
    the take-off). Direction and speed follow from the config as the pilot drew them.
    """
    from scenarios.flight.pilots.breach_attempts import draw_speeds

    items = np.asarray(traj["mission_item"], float)
    t = np.asarray(traj["time_s"], float)
    speeds = draw_speeds(breach_config)
    out = []
    for k in range(breach_config.attempts):
        sel = np.flatnonzero(items == k)
        if not len(sel):
            break
        d = breach_config.directions[k % len(breach_config.directions)]
        out.append({"attempt": k, "direction": d, "speed_mps": float(speeds[k]), "t_start_s": float(t[sel[0]])})
    return out


def attempt_rows(
    traj: Mapping[str, np.ndarray], transitions: Iterable[Any], attempts: Sequence[Mapping], b: Boundaries
) -> list[dict]:
    """One row per attempt: its axis, the peak excursion beyond that boundary, the activation and its closing speed.

    Attempt ``k`` spans ``[t_start_k, t_start_{k+1})`` (the last one: to the end
    of the record). ``peak_m`` is the farthest excursion on the attempt's axis (<= 0:
    never crossed); ``peak_other_m`` the farthest on the other two axes;
    ``v_activation_mps`` the velocity toward the attempt's boundary at the first
    activation in the window (NaN if the geofence never acted).
    """
    t = np.asarray(traj["time_s"], float)
    exc = excursions(traj, b)
    vel = closing_velocities(traj)
    act_t = activation_times(transitions)
    rows = []
    for k, a in enumerate(attempts):
        t0 = float(a["t_start_s"])
        t1 = float(attempts[k + 1]["t_start_s"]) if k + 1 < len(attempts) else math.inf
        sel = (t >= t0) & (t < t1)
        if not sel.any():
            continue
        axis = DIRECTION_AXIS.get(a["direction"], a["direction"])
        acts = act_t[(act_t >= t0) & (act_t < t1)]
        row = {
            "attempt": int(a.get("attempt", k)),
            "direction": a["direction"],
            "axis": axis,
            "speed_cmd_mps": float(a["speed_mps"]),
            "t_start_s": t0,
            "activations": int(len(acts)),
            "t_activation_s": float(acts[0]) if len(acts) else math.nan,
            "v_activation_mps": math.nan,
            "peak_m": math.nan,
            "peak_other_m": math.nan,
        }
        if axis in exc:
            row["peak_m"] = float(np.max(exc[axis][sel]))
            row["peak_other_m"] = float(max(np.max(exc[o][sel]) for o in AXES if o != axis))
            if len(acts):
                i = int(np.clip(np.searchsorted(t, acts[0] - 1e-6), 0, len(t) - 1))
                row["v_activation_mps"] = float(vel[axis][i])
        rows.append(row)
    return rows


def pearson_r(x: Sequence[float] | np.ndarray, y: Sequence[float] | np.ndarray) -> float:
    """Pearson correlation of the finite pairs (NaN with fewer than 3 or no spread)."""
    xa, ya = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(xa) & np.isfinite(ya)
    xa, ya = xa[ok], ya[ok]
    if len(xa) < 3 or np.std(xa) == 0 or np.std(ya) == 0:
        return math.nan
    return float(np.corrcoef(xa, ya)[0, 1])


def axis_statistics(rows: Sequence[Mapping]) -> dict[str, dict]:
    """Per axis: n attempts, crossed, mean / sd (ddof 1) / max of the peak excursion, mean v at activation, r, slope."""
    out = {}
    for axis in AXES:
        sel = [r for r in rows if r["axis"] == axis and math.isfinite(r["peak_m"])]
        peaks = np.array([r["peak_m"] for r in sel], float)
        v = np.array([r["v_activation_mps"] for r in sel], float)
        ok = np.isfinite(v)
        slope = float(np.polyfit(v[ok], peaks[ok], 1)[0]) if ok.sum() >= 3 and np.std(v[ok]) > 0 else math.nan
        out[axis] = {
            "n": int(len(peaks)),
            "crossed": int(np.sum(peaks > 0.0)),
            "mean_m": float(np.mean(peaks)) if len(peaks) else math.nan,
            "sd_m": float(np.std(peaks, ddof=1)) if len(peaks) > 1 else math.nan,
            "max_m": float(np.max(peaks)) if len(peaks) else math.nan,
            "mean_v_activation_mps": float(np.nanmean(v)) if ok.any() else math.nan,
            "r_overshoot_velocity": pearson_r(v, peaks),
            "slope_s": slope,
        }
    return out


@dataclass
class SeedAnalysis:
    name: str
    trigger: str
    law: str
    rows: list[dict]
    stats: dict[str, dict]
    traj: dict[str, np.ndarray]
    transitions: list[dict]
    boundaries: Boundaries
    attempts: list[dict]
    setpoints: dict[str, np.ndarray] | None = None
    """The ramped PD set-point per row (east/north/height, NaN outside an override), seed_pd only."""


def ramp_setpoints(
    traj: Mapping[str, np.ndarray], transitions: Iterable[Any], goal_enh: tuple[float, float, float], ramp_s: float
) -> dict[str, np.ndarray]:
    """Recompute the seed PD law's ramped set-point per row from the transitions, with the law's own code.

    Each activation (MONITOR/RECOVERED -> OVERRIDE) starts
    :meth:`geofence.recovery.guidance.SeedPDRecovery.start` from the recorded state of
    that step (re-activations keep the ramp, as the unit does); rows outside
    an override are NaN.
    """
    from geofence.interface import VehicleState
    from geofence.recovery.guidance import SeedPDGains, SeedPDRecovery, StraightRoute
    from geofence.unit.geofence_unit import Mode

    t = np.asarray(traj["time_s"], float)
    mode = np.asarray(traj["geofence_mode"], float)
    out = {k: np.full(len(t), np.nan) for k in ("east_m", "north_m", "height_m")}
    law = SeedPDRecovery(None, SeedPDGains(), ramp_s)  # type: ignore[arg-type]  # the setpoint needs no envelope
    starts = activation_times(transitions)
    for j, ta in enumerate(starts):
        i0 = int(np.clip(np.searchsorted(t, ta - 1e-6), 0, len(t) - 1))
        s = VehicleState(
            t_s=t[i0], east_m=float(traj["east_m"][i0]), north_m=float(traj["north_m"][i0]), agl_m=float(traj["agl_m"][i0])
        )
        law.start(s, StraightRoute(goal_enh[0], goal_enh[1]), goal_enh[2], s.agl_m, float(t[i0]))
        i = i0
        while i < len(t) and mode[i] == Mode.OVERRIDE:
            out["east_m"][i], out["north_m"][i], out["height_m"][i] = law.setpoint(float(t[i]))
            i += 1
    return out


def _analysis(name, scenario_geofence, traj, transitions, attempts, boundaries) -> SeedAnalysis:
    rows = attempt_rows(traj, transitions, attempts, boundaries)
    trans = normalise_transitions(transitions)
    an = SeedAnalysis(
        name=name,
        trigger=scenario_geofence.trigger if scenario_geofence else "none",
        law=scenario_geofence.multirotor_law if scenario_geofence else "none",
        rows=rows,
        stats=axis_statistics(rows),
        traj={k: np.asarray(v, float) for k, v in traj.items()},
        transitions=trans,
        boundaries=boundaries,
        attempts=list(attempts),
    )
    return an


def analyse_flight(result) -> SeedAnalysis:
    """Analyse a :class:`~scenarios.flight.runner.FlightResult` of a breach-attempts flight behind a geofence."""
    from scenarios.flight.recorder import COLUMNS

    traj = {c: result.recorder.column(c) for c in COLUMNS}
    fence = result.fence
    unit = result.unit
    pilot_log = getattr(result.pilot, "attempt_log", None)
    attempts = pilot_log if pilot_log else attempts_from_items(traj, result.scenario.pilot.breach)
    an = _analysis(result.scenario.name, result.scenario.geofence, traj, unit.transitions, attempts, boundaries_from_fence(fence))
    _add_setpoints(an, result.scenario, fence)
    return an


def _add_setpoints(an: SeedAnalysis, scenario, fence) -> None:
    gf = scenario.geofence
    if gf is not None and gf.multirotor_law is MultirotorLaw.SEED_PD:
        re, rn = fence.recovery_en
        an.setpoints = ramp_setpoints(an.traj, an.transitions, (re, rn, fence.recovery_height_m), gf.ramp_s)


def analyse_folder(folder: Path, scenario_path: Path) -> SeedAnalysis:
    """Analyse a written flight (``trajectory.csv`` + ``summary.json``, optional ``attempts.json``)."""
    from scenarios.definition.schema import load_scenario
    from scenarios.flight.recorder import read_trajectory_csv

    folder = Path(folder)
    scenario = load_scenario(scenario_path)
    traj = read_trajectory_csv(folder / "trajectory.csv")
    summary = json.loads((folder / "summary.json").read_text())
    assert scenario.geofence is not None, f"{scenario_path}: the seed reproduction needs a geofence block"
    fence = scenario.local_fence()
    log = folder / "attempts.json"
    attempts = json.loads(log.read_text()) if log.is_file() else attempts_from_items(traj, scenario.pilot.breach)
    an = _analysis(
        summary["scenario"], scenario.geofence, traj, summary.get("mode_transitions", []), attempts, boundaries_from_fence(fence)
    )
    _add_setpoints(an, scenario, fence)
    return an


# --------------------------------------------------------------------------- reports
def _f(x: float, fmt: str = "{:+.3f}") -> str:
    return "—" if x is None or not math.isfinite(x) else fmt.format(x)


def statistics_table(an: SeedAnalysis) -> str:
    lines = [
        "| axis | attempts | crossed | peak excursion mean ± sd (m) | max (m) | mean v at activation (m/s) | r(overshoot, v) | slope (m per m/s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for axis in AXES:
        s = an.stats[axis]
        lines.append(
            f"| {AXIS_LABEL[axis]} | {s['n']} | {s['crossed']} | {_f(s['mean_m'])} ± {_f(s['sd_m'], '{:.3f}')} | {_f(s['max_m'])} "
            f"| {_f(s['mean_v_activation_mps'], '{:.2f}')} | {_f(s['r_overshoot_velocity'], '{:+.2f}')} | {_f(s['slope_s'], '{:.2f}')} |"
        )
    return "\n".join(lines)


def attempts_table(an: SeedAnalysis) -> str:
    lines = [
        "| # | direction | commanded speed (m/s) | start (s) | activations | v at activation (m/s) | peak excursion (m) | other axes (m) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in an.rows:
        lines.append(
            f"| {r['attempt']} | {r['direction']} | {r['speed_cmd_mps']:.2f} | {r['t_start_s']:.1f} | {r['activations']} "
            f"| {_f(r['v_activation_mps'], '{:.2f}')} | {_f(r['peak_m'])} | {_f(r['peak_other_m'])} |"
        )
    return "\n".join(lines)


def compare_reactive_predictive(reactive: SeedAnalysis, predictive: SeedAnalysis) -> str:
    """Side-by-side markdown table of the per-axis statistics of the two runs."""
    lines = [
        f"| axis | {reactive.name}: mean ± sd (m) | max (m) | crossed | r(overshoot, v) "
        f"| {predictive.name}: mean ± sd (m) | max (m) | crossed | r(overshoot, v) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for axis in AXES:
        cells = []
        for an in (reactive, predictive):
            s = an.stats[axis]
            cells.append(
                f"{_f(s['mean_m'])} ± {_f(s['sd_m'], '{:.3f}')} | {_f(s['max_m'])} | {s['crossed']}/{s['n']} | {_f(s['r_overshoot_velocity'], '{:+.2f}')}"
            )
        lines.append(f"| {AXIS_LABEL[axis]} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def report_markdown(reactive: SeedAnalysis, predictive: SeedAnalysis, figures: Sequence[Path] = ()) -> str:
    b = reactive.boundaries
    parts = [
        "# Seed flight tests reproduced: reactive vs predictive geofence",
        "",
        f"Fence: west line x = {b.west_m:+.2f} m, north line y = {b.north_m:+.2f} m (from launch), ceiling {b.ceiling_m:.2f} m AGL; "
        f"{len(reactive.rows)} breach attempts (same seed and speeds in both runs). "
        "Peak excursion = farthest distance beyond the boundary the attempt aimed at (≤ 0: never crossed; "
        "the closest approach). v at activation = velocity toward that boundary when the geofence took over "
        "(first activation of the attempt). sd: sample standard deviation.",
        "",
        "## Side by side",
        "",
        compare_reactive_predictive(reactive, predictive),
        "",
    ]
    for an in (reactive, predictive):
        parts += [f"## {an.name} (trigger: {an.trigger}, law: {an.law})", "", statistics_table(an), "", attempts_table(an), ""]
    if figures:
        parts += ["## Figures", ""] + [f"![{Path(p).stem}]({Path(p).name})" for p in figures if Path(p).suffix == ".png"] + [""]
    return "\n".join(parts)


# --------------------------------------------------------------------------- flying + CLI
def fly_seed_scenario(path: Path, out_dir: Path | None = None):
    """Fly a seed scenario (keeping the pilot's attempt log); write it under ``out_dir`` if given. Returns the FlightResult."""
    import scenarios.flight.runner as runner
    from scenarios.definition.schema import load_scenario
    from scenarios.flight.runner import write_result

    result = runner.fly(load_scenario(path))
    if out_dir is not None:
        folder = write_result(result, Path(out_dir))
        (folder / "attempts.json").write_text(json.dumps(getattr(result.pilot, "attempt_log", []), indent=1) + "\n")
    return result


def run(
    out_dir: Path, fly_flights: bool = True, reactive_path: Path = REACTIVE_SCENARIO, predictive_path: Path = PREDICTIVE_SCENARIO
) -> Path:
    """Fly (or read) both seed scenarios, write ``seed_reproduction.md`` and the figures into ``out_dir``; returns the report path."""
    from analysis.paper_plots import plot_all

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    analyses = []
    for path in (reactive_path, predictive_path):
        if fly_flights:
            analyses.append(analyse_flight(fly_seed_scenario(path, out_dir)))
        else:
            from scenarios.definition.schema import load_scenario

            name = load_scenario(path).name
            if not (out_dir / name / "trajectory.csv").is_file():
                from geofence.validation import ConfigError

                raise ConfigError(
                    f"{out_dir}: --no-fly: no flight {name!r} to re-analyse here (no {name}/trajectory.csv); "
                    f"run without --no-fly to fly it first"
                )
            analyses.append(analyse_folder(out_dir / name, path))
    reactive, predictive = analyses
    figures = plot_all(reactive, predictive, out_dir)
    report = out_dir / "seed_reproduction.md"
    report.write_text(report_markdown(reactive, predictive, figures))
    stats = {an.name: an.stats for an in analyses}
    (out_dir / "seed_reproduction.json").write_text(json.dumps(stats, indent=2, default=lambda x: None) + "\n")
    return report


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m scenarios.app.seed_reproduction", description=__doc__.splitlines()[0])
    p.add_argument("out_dir", type=Path, help="where the flights, seed_reproduction.md and the figures go")
    p.add_argument("--no-fly", action="store_true", help="read the flights already written in OUT_DIR instead of flying them")
    args = p.parse_args(argv)
    report = run(args.out_dir, fly_flights=not args.no_fly)
    print(report.read_text().split("## indoor_quad")[0])
    print(f"wrote {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
