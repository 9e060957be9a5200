"""Batch results: collect per-flight summaries, write/read ``results.csv``, write ``report.md``.

A batch folder holds one sub-folder per flight with its ``summary.json``
(see :mod:`scenarios.flight.runner` and :mod:`scenarios.app.batch`). Here:

* :func:`collect_results` reads every ``<out>/*/summary.json`` into one flat
  row per flight (``mode_transitions`` becomes its count ``n_transitions``;
  nested mappings are flattened to ``parent.child``; a failed flight's short
  summary gives a row with the keys it has; ``geofence_variant``, the
  geofence flown, from the folder's ``scenario.yaml``); a summary that cannot
  be read is said on stderr (file and problem) and its row is marked
  ``unreadable_summary``: counted apart, never as a flight of some platform;
* :func:`batch_progress`: whether the batch that wrote the folder is partial
  (its ``.batch.json``, written by :mod:`scenarios.app.batch`: the flights it
  planned, and whether it ran to its end); ``results.csv`` and ``report.md``
  say so;
* :func:`write_results_csv` / :func:`read_results_csv`: ``results.csv`` with a
  stable column order (:data:`IDENTITY_COLUMNS`, then :data:`SCORE_COLUMNS`,
  then the other known summary keys, then any others sorted), written
  atomically; values read back typed (bool, int, float, str; empty -> None);
* :func:`write_report`: ``report.md`` with the counts, the platform comparison
  table and figures (:mod:`analysis.batch_plots`), and the failed flights.
"""

from __future__ import annotations

import csv
import json
import math
import re
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from analysis.batch_plots import (
    UNREADABLE,
    VARIANT_LABEL,
    VARIANTS,
    comparison_table,
    flights_of,
    is_failed,
    is_scored,
    num,
    platform_of,
    plot_breach_distribution,
    plot_platform_comparison,
    truthy,
    variant_of,
)
from analysis.formats.replace import replace_text, replacing
from analysis.scoring import SCORE_KEYS

SUMMARY = "summary.json"
RESULTS_CSV = "results.csv"
REPORT_MD = "report.md"
BATCH_STATE = ".batch.json"
"""Written by a batch into its output folder: ``{"planned": [flight ids], "finished": bool}``."""
FIGURES = {"breach_distribution": "Breach distribution", "platform_comparison": "Platform comparison"}

IDENTITY_COLUMNS = ("flight", "scenario", "aircraft", "platform_kind", "wind_speed_mps", "seed")
SCORE_COLUMNS = SCORE_KEYS + ("n_transitions", "final_mode")
OTHER_COLUMNS = (
    "completed",
    "error",
    "pilot",
    "wind_from_deg",
    "geofence",
    "mission_finished",
    "ended_by_geofence",
    "first_activation_s",
    "mission_progress",
    "waypoints_reached",
    "waypoints_total",
    "sim_time_s",
    "wall_time_s",
    "control_rate_hz",
    "jsbsim_frames",
    "jsbsim_frames_per_wall_s",
    "max_agl_m",
    "max_ground_speed_mps",
    "source",
)
STRING_COLUMNS = frozenset(
    {"flight", "scenario", "aircraft", "platform_kind", "final_mode", "error", "pilot", "mission_progress", "source"}
)
"""Columns always read back as text (a flight called ``007`` stays ``"007"``)."""


# --------------------------------------------------------------------------- collecting
def flatten_summary(summary: Mapping, flight: str | None = None) -> dict:
    """One flat row from one ``summary.json`` mapping (see the module docstring)."""
    row: dict = {}

    def put(prefix: str, value) -> None:
        if isinstance(value, Mapping):
            for k, v in value.items():
                put(f"{prefix}.{k}" if prefix else str(k), v)
        elif isinstance(value, (list, tuple)):
            row[prefix] = json.dumps(value)
        else:
            row[prefix] = value

    for key, value in summary.items():
        if key == "mode_transitions":
            row["n_transitions"] = len(value) if isinstance(value, (list, tuple)) else None
            continue
        put(str(key), value)
    if flight is not None and not row.get("flight"):
        row["flight"] = flight
    if not row.get("scenario") and row.get("flight"):
        row["scenario"] = row["flight"]
    row.setdefault("completed", False)
    return row


def collect_results(out_dir: str | Path, warn: bool = True) -> list[dict]:
    """Rows of every ``<out_dir>/*/summary.json``, sorted by flight folder name.

    A summary that cannot be read or parsed gives a failed row naming the
    problem, flagged :data:`UNREADABLE` (so a half-written batch still reports,
    and the row is counted apart); with ``warn`` each is said on stderr, one line.
    """
    rows = []
    for path in sorted(Path(out_dir).glob(f"*/{SUMMARY}")):
        if path.parent.name.startswith("."):  # a flight being written (or left by a killed process)
            continue
        flight = path.parent.name
        try:
            summary = json.loads(path.read_text())
            if not isinstance(summary, Mapping):
                raise ValueError(f"expected a JSON object, got {type(summary).__name__}")
        except (OSError, ValueError) as exc:
            problem = " ".join(str(exc).split())
            if warn:
                print(f"warning: {path}: unreadable ({problem}); counted apart, not as a flight", file=sys.stderr)
            summary = {"flight": flight, "scenario": flight, "completed": False, "error": f"unreadable {SUMMARY}: {problem}"}
            summary[UNREADABLE] = True
        row = flatten_summary(summary, flight)
        variant = _variant_from_scenario(path.parent / "scenario.yaml")
        if variant is not None:
            row["geofence_variant"] = variant
        rows.append(row)
    return rows


def _variant_from_scenario(path: Path) -> str | None:
    """The geofence a flight's ``scenario.yaml`` flies (``predictive``, ``reactive``, ``none``); None if unknown."""
    import yaml

    try:
        doc = yaml.safe_load(path.read_text())
    except (OSError, ValueError, yaml.YAMLError):
        return None
    if not isinstance(doc, Mapping):
        return None
    geofence = doc.get("geofence")
    if not isinstance(geofence, Mapping):
        return "none"
    trigger = str(geofence.get("trigger", "predictive"))
    return trigger if trigger in ("predictive", "reactive") else None


def batch_progress(out_dir: str | Path, rows: Sequence[Mapping]) -> tuple[int, int] | None:
    """``(flights with a result, flights planned)`` when the batch in ``out_dir`` is partial, else None.

    Partial: its :data:`BATCH_STATE` says it did not run to its end, or a planned flight has no result.
    """
    try:
        state = json.loads((Path(out_dir) / BATCH_STATE).read_text())
        planned = [str(f) for f in state["planned"]]
        finished = bool(state.get("finished"))
    except (OSError, ValueError, KeyError, TypeError):
        return None
    have = {str(r.get("flight")) for r in flights_of(rows)}
    written = sum(f in have for f in planned)
    if finished and written == len(planned):
        return None
    return written, len(planned)


# --------------------------------------------------------------------------- results.csv
def result_columns(rows: Sequence[Mapping]) -> list[str]:
    """The column order for ``rows``: identity, scores, other known keys, then the rest sorted."""
    present = set().union(*(r.keys() for r in rows)) if rows else set()
    cols = list(IDENTITY_COLUMNS) + list(SCORE_COLUMNS)
    cols += [c for c in OTHER_COLUMNS if c in present]
    known = set(cols)
    cols += sorted(c for c in present if c not in known)
    return cols


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf"))
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(v)
    return str(v)


def write_results_csv(rows: Sequence[Mapping], path: str | Path) -> Path:
    """Write ``rows`` to ``path`` (CSV, header + one line per flight), atomically; returns the path.

    Of a partial batch (:func:`batch_progress` of the folder), every row says so: ``batch_partial`` true
    and ``batch_flights`` ``written/planned``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = batch_progress(path.parent, rows)
    if partial is not None:
        rows = [dict(r, batch_partial=True, batch_flights=f"{partial[0]}/{partial[1]}") for r in rows]
    cols = result_columns(rows)
    with replacing(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in rows:
            w.writerow([_cell(r.get(c)) for c in cols])
    return path


_INT = re.compile(r"^[+-]?\d+$")


def _parse(col: str, text: str):
    if text == "":
        return None
    if col in STRING_COLUMNS:
        return text
    low = text.lower()
    if low in ("true", "false"):
        return low == "true"
    if _INT.match(text):
        return int(text)
    try:
        return float(text)
    except ValueError:
        return text


def read_results_csv(path: str | Path) -> list[dict]:
    """Rows of a ``results.csv`` with typed values (bool, int, float, str; empty cells -> None)."""
    with open(path, newline="") as fh:
        return [{k: _parse(k, v) for k, v in r.items()} for r in csv.DictReader(fh)]


# --------------------------------------------------------------------------- report.md
def _md(text) -> str:
    """Text safe inside a markdown table cell / list item (one line, pipes escaped)."""
    return " ".join(str(text).split()).replace("|", "\\|")


def batch_counts(rows: Sequence[Mapping]) -> dict[str, int]:
    """``flights``, ``completed``, ``failed``, ``scored``, ``breaches`` (peak excursion > 0),
    ``keep_out_breaches``, ``landed_outside_gap``."""
    ok = [r for r in rows if not is_failed(r)]
    scored = [r for r in ok if is_scored(r)]
    return {
        "flights": len(rows),
        "completed": len(ok),
        "failed": len(rows) - len(ok),
        "scored": len(scored),
        "breaches": sum(num(r.get("max_excursion_m")) > 0.0 for r in scored),
        "keep_out_breaches": sum(truthy(r.get("breached_keep_out")) for r in scored),
        "landed_outside_gap": sum(truthy(r.get("landed_outside_gap")) for r in scored),
    }


def variant_counts(rows: Sequence[Mapping]) -> dict[str, dict[str, int]]:
    """:func:`batch_counts` per geofence variant present (:func:`analysis.batch_plots.variant_of`), in order."""
    by: dict[str, list[Mapping]] = {}
    for r in rows:
        by.setdefault(variant_of(r), []).append(r)
    return {v: batch_counts(by[v]) for v in VARIANTS if v in by}


def _counts_lines(rows: Sequence[Mapping], unreadable: int) -> list[str]:
    """The headline counts, then one line per geofence variant (never lumped)."""
    c = batch_counts(rows)
    lines = [
        f"**{c['flights']} flights**: {c['completed']} completed, **{c['failed']} failed**; "
        f"{c['scored']} scored against a fence: **{c['breaches']} breaches** (peak excursion > 0 m), "
        f"{c['keep_out_breaches']} keep-out breaches, **{c['landed_outside_gap']} out-of-gap landings**.",
        "",
    ]
    if unreadable:
        lines += [f"**{unreadable} unreadable `{SUMMARY}`** (counted apart, not as flights; see Failed flights).", ""]
    lines += ["Per geofence flown:", ""]
    for v, vc in variant_counts(rows).items():
        scored = (
            f"{vc['breaches']}/{vc['scored']} scored flights breached, {vc['keep_out_breaches']} keep-out breaches, "
            f"{vc['landed_outside_gap']} out-of-gap landings"
            if vc["scored"]
            else "not scored (no fence flown)"
            if v == "none"
            else "none scored"
        )
        lines.append(f"- **{VARIANT_LABEL[v]}**: {vc['flights']} flights ({vc['failed']} failed); {scored}")
    return lines + [""]


def write_report(out_dir: str | Path, rows: Sequence[Mapping], title: str | None = None) -> Path:
    """Write ``<out_dir>/report.md`` and its figures (PNG + SVG beside it); returns the report's path.

    Counts, table and figures are per platform and geofence variant; rows of an unreadable ``summary.json``
    are counted apart; a partial batch (:func:`batch_progress`) is said at the top."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    all_rows = list(rows)
    rows = flights_of(all_rows)
    unreadable = len(all_rows) - len(rows)
    plot_breach_distribution(rows, out_dir / "breach_distribution")
    plot_platform_comparison(rows, out_dir / "platform_comparison")

    lines = [f"# {title or f'Batch report: {out_dir.name}'}", ""]
    partial = batch_progress(out_dir, all_rows)
    if partial is not None:
        lines += [
            f"**Partial batch: {partial[0]} of {partial[1]} planned flights have results** (the batch did not run to "
            "its end; run the same command again to fly the rest).",
            "",
        ]
    lines += _counts_lines(rows, unreadable)
    lines.append(f"Per-flight numbers: [`{RESULTS_CSV}`]({RESULTS_CSV}) (one row per flight).")
    lines.append("")
    lines += [
        "## Platform comparison",
        "",
        "One line per platform, geofence flown (predictive, reactive, none) and wind level. Breaches are counted over the scored flights (`breaches/scored`). Peak excursion: metres beyond "
        "the fence, lateral or vertical (< 0: the closest approach stayed inside by that much). Recovery "
        "time: OVERRIDE entry to hand-back (RECOVERED/MONITOR), mean per flight then over flights. Time "
        "to peak: first activation to the smallest margin after it.",
        "",
        comparison_table(rows).rstrip("\n"),
        "",
    ]
    lines += ["## Figures", ""]
    for stem, caption in FIGURES.items():
        lines.append(f"### {caption}")
        lines.append("")
        lines.append(f"![{caption}]({stem}.png)")
        lines.append("")
        lines.append(f"[{stem}.png]({stem}.png) · [{stem}.svg]({stem}.svg)")
        lines.append("")

    worst = sorted((r for r in rows if not is_failed(r) and is_scored(r)), key=lambda r: -num(r.get("max_excursion_m")))[:5]
    if worst:
        lines += [
            "## Largest peak excursions",
            "",
            "| flight | platform | geofence | wind (m/s) | peak excursion (m) | time outside (s) | activations |",
            "|---|---|---|---:|---:|---:|---:|",
        ]
        for r in worst:
            lines.append(
                f"| {_md(r.get('flight') or r.get('scenario'))} | {_md(platform_of(r))} | {VARIANT_LABEL[variant_of(r)]} "
                f"| {num(r.get('wind_speed_mps')):g} | {num(r.get('max_excursion_m')):.2f} "
                f"| {num(r.get('time_outside_s')):.2f} | {_md(r.get('activations'))} |"
            )
        lines.append("")

    failed = [r for r in all_rows if is_failed(r)]
    lines += [f"## Failed flights ({len(failed)})", ""]
    if failed:
        for r in failed:
            name = r.get("flight") or r.get("scenario") or "?"
            lines.append(f"- `{_md(name)}`: {_md(r.get('error') or 'did not complete (no error recorded)')}")
    else:
        lines.append("None.")
    lines.append("")

    path = out_dir / REPORT_MD
    return replace_text(path, "\n".join(lines))
