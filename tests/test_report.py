"""Batch results and report (analysis.report, analysis.batch_plots) on synthetic summaries."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from analysis.batch_plots import (
    comparison_stats,
    comparison_table,
    plot_breach_distribution,
    plot_platform_comparison,
    wind_levels,
)
from analysis.report import (
    IDENTITY_COLUMNS,
    collect_results,
    read_results_csv,
    result_columns,
    write_report,
    write_results_csv,
)

NAN = float("nan")


def summary(flight: str, aircraft: str, kind: str, wind: float, excursion: float, **kw) -> dict:
    s = {
        "scenario": flight.split("__")[0],
        "aircraft": aircraft,
        "platform_kind": kind,
        "pilot": "scripted",
        "seed": 7,
        "wind_speed_mps": wind,
        "wind_from_deg": 270.0,
        "geofence": True,
        "completed": True,
        "sim_time_s": 45.0,
        "wall_time_s": 0.4,
        "error": None,
        "max_excursion_m": excursion,
        "max_lateral_excursion_m": excursion,
        "max_vertical_excursion_m": -3.5,
        "min_margin_m": -excursion,
        "time_outside_s": max(0.0, excursion) * 0.5,
        "activations": 4,
        "breached_keep_out": False,
        "landed_outside_gap": False,
        "time_to_peak_excursion_s": 2.25,
        "time_to_handback_s": 3.5,
        "ground_speed_at_activation_mps": 12.0,
        "approach_angle_at_activation_deg": 10.0,
        "final_mode": "MONITOR",
        "mode_transitions": [
            {"t_s": 1.0, "from": "MONITOR", "to": "OVERRIDE", "reason": "lateral: x | y"},
            {"t_s": 4.5, "from": "OVERRIDE", "to": "RECOVERED", "reason": "recovered"},
        ],
        "flight": flight,
        "source": "scenarios/ci/x.yaml",
    }
    s.update(kw)
    return s


def make_batch(out: Path) -> list[dict]:
    flights = [
        summary("mc__w0", "F450", "multirotor", 0.0, -2.0),
        summary("mc__w4", "F450", "multirotor", 4.0, 1.25, breached_keep_out=True),
        summary("mc__w8", "F450", "multirotor", 8.0, 3.5, landed_outside_gap=True, activations=6),
        summary("fw__w0", "Tern", "fixed_wing", 0.0, -4.0, time_to_handback_s=NAN, time_to_peak_excursion_s=NAN),
        summary("fw__w8", "Tern", "fixed_wing", 8.0, 0.5),
        {
            "flight": "bad__cfg",
            "scenario": "bad__cfg",
            "completed": False,
            "error": "bad configuration: x.yaml: wind.speed_mps: must be >= 0, got -3",
        },
    ]
    for s in flights:
        folder = out / s["flight"]
        folder.mkdir(parents=True)
        (folder / "summary.json").write_text(json.dumps(s, indent=2))  # NaN is written as NaN, as the runner does
    # a failed flight with only the minimal keys, and no 'flight' key (the folder name stands in)
    (out / "crashed").mkdir()
    (out / "crashed" / "summary.json").write_text(
        json.dumps({"scenario": "crashed", "completed": False, "error": "FloatingPointError: overflow"})
    )
    # folders that are not finished flights are ignored
    (out / "in_progress").mkdir()
    (out / "in_progress" / "trajectory.csv").write_text("time_s\n")
    return flights


def same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b and type(a) is type(b)


def test_collect_results_flattens_and_tolerates_failures(tmp_path):
    make_batch(tmp_path)
    rows = collect_results(tmp_path)
    assert [r["flight"] for r in rows] == ["bad__cfg", "crashed", "fw__w0", "fw__w8", "mc__w0", "mc__w4", "mc__w8"]
    by = {r["flight"]: r for r in rows}
    assert "mode_transitions" not in by["mc__w0"] and by["mc__w0"]["n_transitions"] == 2
    assert by["crashed"]["completed"] is False and by["crashed"]["error"].startswith("FloatingPointError")
    assert math.isnan(by["fw__w0"]["time_to_handback_s"])


def test_results_csv_round_trip(tmp_path):
    make_batch(tmp_path)
    rows = collect_results(tmp_path)
    path = write_results_csv(rows, tmp_path / "results.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert tuple(header[: len(IDENTITY_COLUMNS)]) == IDENTITY_COLUMNS
    assert header == result_columns(rows)
    assert header.index("max_excursion_m") < header.index("wall_time_s")
    back = read_results_csv(path)
    assert len(back) == len(rows)
    for r, b in zip(rows, back):
        for k in header:
            assert same(r.get(k), b[k]), (r.get("flight"), k, r.get(k), b[k])
    # rewriting overwrites atomically and leaves no temporary file behind
    write_results_csv(back, path)
    assert read_results_csv(path) is not None
    assert sorted(p.name for p in tmp_path.glob(".*")) == []


def test_report_has_counts_table_figures_and_failures(tmp_path):
    make_batch(tmp_path)
    rows = collect_results(tmp_path)
    path = write_report(tmp_path, rows)
    text = path.read_text()
    assert path == tmp_path / "report.md"
    assert "**7 flights**: 5 completed, **2 failed**" in text
    assert "**3 breaches**" in text and "**1 out-of-gap landings**" in text and "1 keep-out breaches" in text
    assert comparison_table(rows).strip() in text
    assert "| F450 (multirotor) | predictive | 4 m/s | 1 | 0 | 1/1 |" in text
    assert "`bad__cfg`: bad configuration: x.yaml: wind.speed_mps: must be >= 0, got -3" in text
    assert "`crashed`: FloatingPointError: overflow" in text
    for stem in ("breach_distribution", "platform_comparison"):
        assert f"]({stem}.png)" in text
        for suffix in (".png", ".svg"):
            f = tmp_path / f"{stem}{suffix}"
            assert f.is_file() and f.stat().st_size > 1000


def test_comparison_stats_numbers(tmp_path):
    make_batch(tmp_path)
    rows = collect_results(tmp_path)
    stats = {(s["platform"], s["wind"]): s for s in comparison_stats(rows) if s["variant"] == "predictive"}
    mc8 = stats[("F450 (multirotor)", "8 m/s")]
    assert mc8["breaches"] == 1 and mc8["landed_outside_gap"] == 1 and mc8["mean_activations"] == 6.0
    fw0 = stats[("Tern (fixed_wing)", "0 m/s")]
    assert fw0["mean_peak_excursion_m"] == -4.0 and math.isnan(fw0["mean_time_to_handback_s"])
    assert "| Tern (fixed_wing) | predictive | 0 m/s | 1 | 0 | 0/1 |" in comparison_table(rows)


def test_many_wind_speeds_are_binned():
    rows = [
        {
            "aircraft": "F450",
            "platform_kind": "multirotor",
            "completed": True,
            "wind_speed_mps": w,
            "max_excursion_m": w - 5.0,
            "activations": 1,
            "time_to_handback_s": 2.0,
        }
        for w in (0, 1, 2.5, 4, 6, 9, 12)
    ]
    labels, level = wind_levels(rows)
    assert [lab.split()[0] for lab in labels] == ["calm", "moderate", "strong"]
    assert level(rows[0]).startswith("calm") and level(rows[-1]).startswith("strong")
    stats = comparison_stats(rows)
    assert [s["flights"] for s in stats] == [3, 2, 2]


@pytest.mark.parametrize("case", ["synthetic", "empty", "all_failed"])
def test_plots_are_written(tmp_path, case):
    if case == "synthetic":
        make_batch(tmp_path / "b")
        rows = collect_results(tmp_path / "b")
    elif case == "empty":
        rows = []
    else:
        rows = [{"flight": "a", "scenario": "a", "completed": False, "error": "boom"}]
    for fn, stem in ((plot_breach_distribution, "dist"), (plot_platform_comparison, "cmp")):
        written = fn(rows, tmp_path / "fig" / stem)
        assert [p.suffix for p in written] == [".png", ".svg"]
        assert all(p.is_file() and p.stat().st_size > 1000 for p in written)
    report = write_report(tmp_path / "r", rows).read_text()
    assert f"**{len(rows)} flights**" in report


def mixed_variant_batch(out: Path) -> None:
    """A campaign-like set: one case per wind, flown predictive (held), reactive (breached) and unprotected."""
    for wind in (0.0, 4.0):
        case = f"box-{int(wind):04d}"
        flights = [
            (f"{case}__predictive", summary(f"{case}__predictive", "F450RD", "multirotor", wind, -1.5), "predictive"),
            (f"{case}__reactive", summary(f"{case}__reactive", "F450RD", "multirotor", wind, 2.0), "reactive"),
            (f"{case}__unprotected", {"aircraft": "F450RD", "platform_kind": "multirotor", "completed": True,
                                      "wind_speed_mps": wind, "geofence": False}, None),
        ]  # fmt: skip
        for flight, s, trigger in flights:
            folder = out / flight
            folder.mkdir(parents=True)
            (folder / "summary.json").write_text(json.dumps(dict(s, flight=flight)))
            doc = {"name": flight, "aircraft": "F450RD"}
            if trigger is not None:
                doc["geofence"] = {"fence": {}, "trigger": trigger}
            (folder / "scenario.yaml").write_text(json.dumps(doc))  # (JSON is YAML)


def test_a_report_of_mixed_variants_counts_each_apart(tmp_path):
    """Issue 41: "F450RD 2/4 breaches" lumped a predictive fence that held with a reactive one that did not."""
    mixed_variant_batch(tmp_path)
    rows = collect_results(tmp_path)
    stats = {(s["variant"], s["wind"]): s for s in comparison_stats(rows)}
    assert {k: (s["breaches"], s["scored"], s["flights"]) for k, s in stats.items()} == {
        ("predictive", "0 m/s"): (0, 1, 1),
        ("predictive", "4 m/s"): (0, 1, 1),
        ("reactive", "0 m/s"): (1, 1, 1),
        ("reactive", "4 m/s"): (1, 1, 1),
        ("none", "0 m/s"): (0, 0, 1),
        ("none", "4 m/s"): (0, 0, 1),
    }
    text = write_report(tmp_path, rows).read_text()
    assert "| F450RD (multirotor) | predictive | 4 m/s | 1 | 0 | 0/1 |" in text
    assert "| F450RD (multirotor) | reactive | 4 m/s | 1 | 0 | 1/1 |" in text
    assert "| F450RD (multirotor) | no geofence | 4 m/s | 1 | 0 | 0/0 |" in text
    assert "- **predictive**: 2 flights (0 failed); 0/2 scored flights breached" in text
    assert "- **reactive**: 2 flights (0 failed); 2/2 scored flights breached" in text
    assert "- **no geofence**: 2 flights (0 failed); not scored (no fence flown)" in text


def test_an_unreadable_summary_is_said_and_counted_apart(tmp_path, capsys):
    make_batch(tmp_path)
    (tmp_path / "torn").mkdir()
    (tmp_path / "torn" / "summary.json").write_text('{"aircraft": "F450", "compl')
    rows = collect_results(tmp_path)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "torn/summary.json: unreadable" in err and "counted apart" in err
    table = comparison_table(rows)
    # the two failed flights of no known platform stay as they were, the unreadable one is not a third
    assert "| unknown | geofence unknown | unknown wind | 2 | 2 |" in table
    assert "(1 unreadable summary.json counted apart" in table
    assert sum(s["flights"] for s in comparison_stats(rows)) == len(rows) - 1
    text = write_report(tmp_path, rows).read_text()
    assert "**7 flights**" in text and "**1 unreadable `summary.json`** (counted apart" in text


def test_a_partial_batch_says_so_in_the_report_and_in_results_csv(tmp_path):
    make_batch(tmp_path)
    planned = ["bad__cfg", "crashed", "fw__w0", "fw__w8", "mc__w0", "mc__w4", "mc__w8", "never__flown"]
    (tmp_path / ".batch.json").write_text(json.dumps({"planned": planned, "finished": False}))
    rows = collect_results(tmp_path)
    text = write_report(tmp_path, rows).read_text()
    assert "**Partial batch: 7 of 8 planned flights have results**" in text
    back = read_results_csv(write_results_csv(rows, tmp_path / "results.csv"))
    assert {(r["batch_partial"], r["batch_flights"]) for r in back} == {(True, "7/8")}
    (tmp_path / ".batch.json").write_text(json.dumps({"planned": planned[:-1], "finished": True}))
    assert "Partial" not in write_report(tmp_path, rows).read_text()
    assert "batch_partial" not in read_results_csv(write_results_csv(rows, tmp_path / "results.csv"))[0]
