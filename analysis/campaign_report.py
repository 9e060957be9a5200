"""The efficacy campaign's report: breach counts, exact confidence bounds and figures.

Input: a batch folder's ``results.csv`` (:func:`analysis.report.read_results_csv`)
and the campaign's ``campaign.json`` manifest (written by
:mod:`scenarios.campaign.generator`); output: numbers, ``campaign_report.md`` and two
figures. Nothing here flies.

Flights are ``<case_id>__<variant>`` (variant ``predictive``, ``reactive`` or
``unprotected``). The runner scores only flights with a geofence, so the
unprotected twin is scored here (:func:`score_unprotected`): its recorded
``trajectory.csv`` against the fence of its case in the manifest, in the ENU
frame at the case's start point (the runner's frame), with
:func:`analysis.scoring.score_flight`.

Definitions (per flight; see :func:`flight_outcome`):

* **keep-in breach**: ``max_lateral_excursion_m > KEEP_IN_TOLERANCE_M`` (0.0 m):
  the vehicle was beyond a lateral boundary (a keep-in edge, or inside a
  keep-out zone, which the lateral margin includes) by any amount;
* **keep-out entry**: ``breached_keep_out``;
* **vertical breach**: ``max_vertical_excursion_m > VERTICAL_TOLERANCE_M``
  (0.0 m; above the ceiling, or below the floor outside every gap);
* **out-of-gap landing**: ``landed_outside_gap``;
* **breach**: any of the four. Failed flights (an error, or not completed)
  are counted apart and never as breaches or as clean flights.

Conditions (:func:`condition`, in this order): **beyond authority** (the case's mean wind plus one
turbulence sigma at the start height is more than the platform can fly back against, as the
generator judged it before any flight: ``beyond_authority`` in the manifest); **beyond max speed in
flight** (the flight met a wind whose mean over :data:`SUSTAINED_WIND_WINDOW_S` exceeded its
platform's max speed: ``peak_sustained_wind_mps`` of its summary, or :func:`peak_sustained_wind_mps` of its
trajectory for an older summary: for those
seconds the air moved faster than the vehicle can fly, so no override can hold it; judged on every
flight alike, breached or not, since the forecast-based class cannot see a tail of the turbulence);
**activated at start** (the case's predictive unit found its activation margin already at or below 0 at
its first step, ``first_activation_s`` 0 in its summary: the start state was inside the activation
boundary, where the override's guarantee has not begun; the generator prefers a start beyond it and
cannot always find one, e.g. a fixed-wing in a corridor or wedge narrower than its turn; judged from
the predictive flight for all three variants of the case); **GPS fault** (the position source lost or
out: dead reckoning drifts with the wind estimate's error); else **nominal** (the cases the containment
figure is for). Every breach is listed whatever
its condition; the headline rate is the nominal one.

For each breached flight the report also gives the strongest wind the vehicle met, averaged over
:data:`SUSTAINED_WIND_WINDOW_S` (``peak_sustained_wind_mps``), against
its platform's max speed: above 1, the air around it moved faster than it can fly.

Rates: breaches / flights with a one-sided exact (Clopper-Pearson) 95 % upper
bound, ``beta.ppf(0.95, k + 1, n - k)`` (0 of 1000 -> 0.00299), and breaches
per simulated flight hour with the Poisson 95 % upper bound
``chi2.ppf(0.95, 2k + 2) / 2 / hours``.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from analysis.batch_plots import num, save_figure, truthy
from analysis.bounds import clopper_pearson_upper, poisson_rate_upper
from analysis.containment import (
    VOLUMES,
    ClassRates,
    ContingencyInputs,
    add_class_rates,
    class_rate_lines,
    class_rates,
    class_rates_record,
    containment_lines,
    plot_containment,
)
from analysis.formats.replace import replace_text, replacing
from analysis.report import RESULTS_CSV, read_results_csv
from analysis.scoring import SCORED_COLUMNS, SUSTAINED_WIND_WINDOW_S, score_flight, sustained_wind_peak_mps
from geofence.geometry.fence import parse_fence
from geofence.geometry.geodesy import LocalFrame
from geofence.validation import ConfigError

MANIFEST = "campaign.json"
REPORT_MD = "campaign_report.md"
FLIGHTS_CSV = "campaign_flights.csv"
COUNTS_JSON = "containment_counts.json"
"""The containment section's counts (per class: flights, flight hours, exits of each volume), which
:func:`combine_containment` adds up over the shards of one campaign."""
CAMPAIGN_SETTINGS = ("generator", "seed", "max_duration_s", "platforms", "families", "faults", "downward_sensors")
"""The manifest's keys every shard of one campaign shares (the cases differ only in their numbers)."""
COMBINED_MD = "containment_combined.md"
"""One row per flight: its condition, status, breaches and whether its unprotected twin breached."""
KEEP_IN_TOLERANCE_M = 0.0
"""A keep-in breach is a lateral excursion strictly beyond this (m)."""
VERTICAL_TOLERANCE_M = 0.0
"""A vertical breach is a ceiling/floor excursion strictly beyond this (m)."""
VARIANTS = ("predictive", "reactive", "unprotected")
CONTAINMENT_FIGURE = ("campaign_containment", "Peak excursions against the contingency volume, per class")
FIGURES = {
    "campaign_excursion": "Peak excursion per family: predictive vs reactive (vs unprotected)",
    "campaign_breach_bounds": "Breach rate and its 95 % upper bound per platform",
}


# --------------------------------------------------------------------------- manifest and rows
def load_manifest(path: str | Path) -> dict:
    """``campaign.json`` as a mapping, with ``cases_by_id``."""
    m = json.loads(Path(path).read_text())
    m["cases_by_id"] = {c["case_id"]: c for c in m.get("cases", [])}
    return m


def split_flight(flight: str) -> tuple[str, str]:
    """``"box-0003__predictive"`` -> ``("box-0003", "predictive")``; no variant -> ``(flight, "")``."""
    case, sep, variant = str(flight).rpartition("__")
    return (case, variant) if sep else (str(flight), "")


def read_trajectory_columns(path: str | Path, names: Sequence[str] = SCORED_COLUMNS) -> dict[str, np.ndarray]:
    """The named columns of a ``trajectory.csv`` (those present) as float arrays."""
    path = Path(path)
    with open(path, newline="") as fh:
        header = next(csv.reader(fh))
    cols = [header.index(n) for n in names if n in header]
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols, ndmin=2)
    return {header[c]: data[:, i] for i, c in enumerate(cols)}


def peak_sustained_wind_mps(path: str | Path, window_s: float = SUSTAINED_WIND_WINDOW_S) -> float:
    """:func:`analysis.scoring.sustained_wind_peak_mps` of a ``trajectory.csv`` (m/s; NaN without its wind columns):
    for flights whose summary predates the key."""
    cols = read_trajectory_columns(path, ("time_s", "wind_east_mps", "wind_north_mps"))
    if len(cols) < 3:
        return math.nan
    return sustained_wind_peak_mps(cols["time_s"], cols["wind_east_mps"], cols["wind_north_mps"], window_s)


def case_fence(case: Mapping):
    """The :class:`~geofence.geometry.local_fence.LocalFence` of a manifest case, in the runner's frame (its start point)."""
    st = case["start"]
    frame = LocalFrame(float(st["lat_deg"]), float(st["lon_deg"]), float(st.get("ground_alt_m", 0.0)))
    return parse_fence(case["fence"], f"campaign case {case['case_id']}").to_local(frame)


def score_unprotected(batch_dir: str | Path, row: Mapping, case: Mapping) -> dict:
    """Scores of an unprotected twin from its ``trajectory.csv`` (``{}`` if it was not recorded)."""
    path = Path(batch_dir) / str(row.get("flight")) / "trajectory.csv"
    if not path.is_file():
        return {}
    traj = read_trajectory_columns(path)
    if len(traj.get("time_s", ())) == 0:
        return {}
    scores = score_flight(traj, case_fence(case))
    scores["activations"] = 0
    return scores


def campaign_rows(rows: Iterable[Mapping], manifest: Mapping, batch_dir: str | Path | None = None) -> list[dict]:
    """Rows joined with their case (``case_id``, ``variant``, ``family``, ``attack``, ``platform``, ...).

    With ``batch_dir``, unprotected twins without scores are scored from their trajectories.
    Rows of flights that are not in the manifest are left out.
    """
    cases = manifest.get("cases_by_id") or {c["case_id"]: c for c in manifest.get("cases", [])}
    out = []
    for r in rows:
        case_id, variant = split_flight(r.get("flight") or r.get("scenario") or "")
        case = cases.get(case_id)
        if case is None or variant not in VARIANTS:
            continue
        row = dict(r)
        row.update(
            case_id=case_id,
            variant=variant,
            family=case["family"],
            attack=case["attack"],
            platform=case["platform"],
            platform_kind=case.get("platform_kind", row.get("platform_kind")),
            case_pilot=case.get("pilot"),
            gps_fault=bool(case.get("gps_fault")),
            beyond_authority=case.get("beyond_authority") or "",
            platform_max_speed_mps=case.get("max_speed_mps"),
            ceiling_m=(case.get("fence") or {}).get("ceiling_m"),
            faults=",".join(sorted({str(f.get("kind")) for f in case.get("faults") or [] if isinstance(f, Mapping)})),
        )
        if variant == "unprotected" and batch_dir is not None and not math.isfinite(num(row.get("max_excursion_m"))):
            row.update(score_unprotected(batch_dir, row, case))
        if batch_dir is not None and not is_error(row) and row.get("peak_sustained_wind_mps") is None:
            # (a summary written before the key: its cell in a results.csv of newer flights is empty)
            traj = Path(batch_dir) / str(row.get("flight") or row.get("scenario")) / "trajectory.csv"
            if traj.is_file():
                row["peak_sustained_wind_mps"] = peak_sustained_wind_mps(traj)
        out.append(row)
    committed = {r["case_id"] for r in out if r["variant"] == "predictive" and activated_at_first_step(r)}
    for r in out:
        r["activated_at_start"] = r["case_id"] in committed
    return out


def activated_at_first_step(row: Mapping) -> bool:
    """The flight's unit activated at its first step (``first_activation_s`` is 0: the start state was inside the
    activation boundary); False when it never activated or the summary predates the field."""
    t = num(row.get("first_activation_s"))
    return math.isfinite(t) and t <= 0.0


# --------------------------------------------------------------------------- per-flight outcome
CONDITIONS = ("nominal", "GPS fault", "activated at start", "beyond authority", "beyond max speed in flight")


def met_wind_beyond_max_speed(row: Mapping) -> bool:
    """The flight met a wind above its platform's max speed for :data:`SUSTAINED_WIND_WINDOW_S`
    (``peak_sustained_wind_mps`` > ``platform_max_speed_mps``; False when either is unknown)."""
    w, vmax = num(row.get("peak_sustained_wind_mps")), num(row.get("platform_max_speed_mps"))
    return math.isfinite(w) and math.isfinite(vmax) and vmax > 0.0 and w > vmax


def condition(row: Mapping) -> str:
    """The flight's condition (module docstring): beyond authority (forecast), beyond max speed in
    flight, activated at start (its case's predictive flight), GPS fault, else nominal.

    A manifest written before the authority test counts its cases as within it; a row without a
    recorded wind (no trajectory) is judged by its case alone.
    """
    if row.get("beyond_authority"):
        return "beyond authority"
    if met_wind_beyond_max_speed(row):
        return "beyond max speed in flight"
    if truthy(row.get("activated_at_start")):
        return "activated at start"
    return "GPS fault" if truthy(row.get("gps_fault")) else "nominal"


def is_error(row: Mapping) -> bool:
    return bool(row.get("error"))


def is_failed(row: Mapping) -> bool:
    """An error, or a flight that did not complete (e.g. a mission left unfinished)."""
    return is_error(row) or not truthy(row.get("completed"))


@dataclass(frozen=True)
class FlightOutcome:
    keep_in_breach: bool
    keep_out_entry: bool
    vertical_breach: bool
    out_of_gap_landing: bool
    scored: bool

    @property
    def breach(self) -> bool:
        return self.keep_in_breach or self.keep_out_entry or self.vertical_breach or self.out_of_gap_landing


def flight_outcome(row: Mapping) -> FlightOutcome:
    """The per-flight breach flags (see the module docstring); unscored flights have none."""
    lat = num(row.get("max_lateral_excursion_m"))
    ver = num(row.get("max_vertical_excursion_m"))
    scored = math.isfinite(num(row.get("max_excursion_m")))
    return FlightOutcome(
        keep_in_breach=scored and lat > KEEP_IN_TOLERANCE_M,
        keep_out_entry=scored and truthy(row.get("breached_keep_out")),
        vertical_breach=scored and ver > VERTICAL_TOLERANCE_M,
        out_of_gap_landing=scored and truthy(row.get("landed_outside_gap")),
        scored=scored,
    )


def is_mission(row: Mapping) -> bool:
    return (row.get("case_pilot") or row.get("pilot")) == "mission"


def mission_stalled(row: Mapping) -> bool:
    """A mission that did not finish while the geofence had acted, without an error."""
    return is_mission(row) and not is_error(row) and not truthy(row.get("mission_finished")) and num(row.get("activations")) > 0


# --------------------------------------------------------------------------- group statistics
@dataclass(frozen=True)
class GroupStats:
    """Counts and bounds of one group of flights (e.g. one variant x platform x family)."""

    key: tuple[str, ...]
    flights: int
    errors: int
    incomplete: int
    scored: int
    keep_in_breaches: int
    keep_out_entries: int
    vertical_breaches: int
    out_of_gap_landings: int
    breaches: int
    hours: float
    missions: int
    nuisance_missions: int
    stalled_missions: int
    checked_missions: int = 0
    """Missions that passed the pre-flight check (``preflight.passed`` in the summary)."""
    checked_nuisance: int = 0
    """... of which the geofence overrode anyway (the check's promise broken)."""

    @property
    def breach_rate(self) -> float:
        return self.breaches / self.scored if self.scored else math.nan

    @property
    def breach_rate_upper(self) -> float:
        return clopper_pearson_upper(self.breaches, self.scored)

    @property
    def per_hour(self) -> float:
        return self.breaches / self.hours if self.hours > 0 else math.nan

    @property
    def per_hour_upper(self) -> float:
        return poisson_rate_upper(self.breaches, self.hours)


def group_stats(rows: Sequence[Mapping], key: tuple[str, ...] = ()) -> GroupStats:
    """Counts over ``rows``: a breach counts only on a scored flight that did not error."""
    ok = [r for r in rows if not is_error(r)]
    outcomes = [flight_outcome(r) for r in ok]
    scored = [o for o in outcomes if o.scored]
    missions = [r for r in ok if is_mission(r)]
    hours = sum(max(num(r.get("sim_time_s")), 0.0) for r in ok if math.isfinite(num(r.get("sim_time_s")))) / 3600.0
    return GroupStats(
        key=key,
        flights=len(rows),
        errors=len(rows) - len(ok),
        incomplete=sum(1 for r in ok if not truthy(r.get("completed"))),
        scored=len(scored),
        keep_in_breaches=sum(o.keep_in_breach for o in scored),
        keep_out_entries=sum(o.keep_out_entry for o in scored),
        vertical_breaches=sum(o.vertical_breach for o in scored),
        out_of_gap_landings=sum(o.out_of_gap_landing for o in scored),
        breaches=sum(o.breach for o in scored),
        hours=hours,
        missions=len(missions),
        nuisance_missions=sum(1 for r in missions if num(r.get("activations")) > 0),
        stalled_missions=sum(1 for r in missions if mission_stalled(r)),
        checked_missions=sum(1 for r in missions if truthy(r.get("preflight.passed"))),
        checked_nuisance=sum(1 for r in missions if truthy(r.get("preflight.passed")) and num(r.get("activations")) > 0),
    )


def grouped(rows: Sequence[Mapping], fields: Sequence[str]) -> list[GroupStats]:
    """:class:`GroupStats` per distinct value of ``fields`` (sorted by key)."""
    groups: dict[tuple, list] = {}
    for r in rows:
        groups.setdefault(tuple(str(r.get(f)) for f in fields), []).append(r)
    return [group_stats(v, k) for k, v in sorted(groups.items(), key=lambda kv: _variant_order(kv[0]))]


def _variant_order(key: tuple) -> tuple:
    return tuple((VARIANTS.index(k) if k in VARIANTS else len(VARIANTS), k) for k in key)


# --------------------------------------------------------------------------- excursions
@dataclass(frozen=True)
class ExcursionStats:
    n: int
    mean_m: float
    p95_m: float
    max_m: float


def excursion_stats(values: Iterable[float]) -> ExcursionStats:
    v = np.asarray([x for x in values if math.isfinite(x)], dtype=float)
    if not len(v):
        return ExcursionStats(0, math.nan, math.nan, math.nan)
    return ExcursionStats(len(v), float(v.mean()), float(np.percentile(v, 95)), float(v.max()))


def excursion_comparison(rows: Sequence[Mapping], by: str = "family") -> list[dict]:
    """Per ``by`` value (and ``all``): peak excursion stats per variant, and predictive/reactive ratios.

    Peak excursion is ``max_excursion_m`` (m beyond the fence, lateral or
    vertical; < 0: closest approach inside). The ratios compare the *depth
    beyond the fence* ``max(excursion, 0)``: mean and max over flights,
    predictive / reactive (NaN when the reactive depth is 0). ``paired_mean_m``
    is the mean over cases flown in both variants of predictive - reactive.
    """
    ok = [r for r in rows if not is_error(r)]
    keys = sorted({str(r.get(by)) for r in ok})
    out = []
    for k in [*keys, "all"]:
        sel = [r for r in ok if k == "all" or str(r.get(by)) == k]
        per = {v: [num(r.get("max_excursion_m")) for r in sel if r.get("variant") == v] for v in VARIANTS}
        stats = {v: excursion_stats(per[v]) for v in VARIANTS}
        depth = {v: np.clip(np.asarray([x for x in per[v] if math.isfinite(x)], dtype=float), 0.0, None) for v in VARIANTS}

        def ratio(f) -> float:
            p, q = depth["predictive"], depth["reactive"]
            if not len(p) or not len(q) or f(q) <= 0.0:
                return math.nan
            return float(f(p) / f(q))

        by_case: dict[str, dict[str, float]] = {}
        for r in sel:
            if r.get("variant") in ("predictive", "reactive"):
                by_case.setdefault(str(r.get("case_id")), {})[str(r.get("variant"))] = num(r.get("max_excursion_m"))
        diffs = [
            d["predictive"] - d["reactive"]
            for d in by_case.values()
            if len(d) == 2 and math.isfinite(d["predictive"]) and math.isfinite(d["reactive"])
        ]
        out.append(
            {
                by: k,
                "stats": stats,
                "mean_depth_ratio": ratio(np.mean),
                "max_depth_ratio": ratio(np.max),
                "paired_mean_m": float(np.mean(diffs)) if diffs else math.nan,
                "paired_n": len(diffs),
            }
        )
    return out


def twin_outcomes(rows: Sequence[Mapping]) -> dict[str, FlightOutcome]:
    """Per case id, the outcome of its unprotected twin (twins that erred are left out)."""
    return {str(r.get("case_id")): flight_outcome(r) for r in rows if r.get("variant") == "unprotected" and not is_error(r)}


def unprotected_vs_protected(rows: Sequence[Mapping]) -> dict[str, dict[str, int]]:
    """Per protected variant: cases where the twin breached and the variant did / did not, and the reverse."""
    twins = twin_outcomes(rows)
    out = {}
    for v in ("predictive", "reactive"):
        c = {"twin_breached": 0, "twin_breached_and_held": 0, "twin_breached_and_breached": 0, "twin_clean_but_breached": 0}
        for r in rows:
            tw = twins.get(str(r.get("case_id")))
            if r.get("variant") != v or tw is None or is_error(r):
                continue
            pr = flight_outcome(r)
            if not (tw.scored and pr.scored):
                continue
            if tw.breach:
                c["twin_breached"] += 1
                c["twin_breached_and_breached" if pr.breach else "twin_breached_and_held"] += 1
            elif pr.breach:
                c["twin_clean_but_breached"] += 1
        out[v] = c
    return out


FLIGHT_COLUMNS = (
    "flight", "case_id", "variant", "family", "attack", "platform", "condition", "status", "breach",
    "keep_in_breach", "keep_out_entry", "vertical_breach", "out_of_gap_landing", "max_excursion_m",
    "activations", "twin_breached", "peak_sustained_wind_mps",
)  # fmt: skip
"""The columns of :data:`FLIGHTS_CSV` (:func:`flight_summaries`)."""


def flight_status(row: Mapping) -> str:
    """``error``, ``mission stalled by the geofence`` (a mission left unfinished after the geofence acted, no
    error), ``incomplete`` (otherwise not completed) or ``completed``."""
    if is_error(row):
        return "error"
    if mission_stalled(row):
        return "mission stalled by the geofence"
    return "completed" if truthy(row.get("completed")) else "incomplete"


def flight_summaries(rows: Sequence[Mapping]) -> list[dict]:
    """Per flight (:data:`FLIGHT_COLUMNS`): its case, condition and status, its breach flags (empty when it was
    not scored) and, for a protected flight, whether its case's unprotected twin breached (empty for the twin
    itself, or when the twin erred or was not scored)."""
    twins = twin_outcomes(rows)
    out = []
    for r in rows:
        o = flight_outcome(r)
        twin = twins.get(str(r.get("case_id"))) if r.get("variant") != "unprotected" else None
        flags = (o.breach, o.keep_in_breach, o.keep_out_entry, o.vertical_breach, o.out_of_gap_landing)
        out.append(
            dict(
                zip(
                    FLIGHT_COLUMNS,
                    (
                        r.get("flight"),
                        r.get("case_id"),
                        r.get("variant"),
                        r.get("family"),
                        r.get("attack"),
                        r.get("platform"),
                        condition(r),
                        flight_status(r),
                        *(f if o.scored else "" for f in flags),
                        r.get("max_excursion_m", ""),
                        r.get("activations", ""),
                        twin.breach if twin is not None and twin.scored else "",
                        r.get("peak_sustained_wind_mps", ""),
                    ),  # fmt: skip
                )
            )
        )
    return out


def offending_flights(rows: Sequence[Mapping], variant: str = "predictive") -> list[Mapping]:
    """Flights of ``variant`` with a breach: keep-in, keep-out entry, vertical or an out-of-gap landing."""
    return [r for r in rows if r.get("variant") == variant and not is_error(r) and flight_outcome(r).breach]


def describe_flight(r: Mapping) -> str:
    o = flight_outcome(r)
    what = [
        w
        for w, f in (
            ("keep-in", o.keep_in_breach),
            ("keep-out", o.keep_out_entry),
            ("vertical", o.vertical_breach),
            ("out-of-gap landing", o.out_of_gap_landing),
        )
        if f
    ]
    return (
        f"{r.get('flight')}: {', '.join(what) or 'clean'}; lateral excursion {num(r.get('max_lateral_excursion_m')):+.2f} m, "
        f"vertical {num(r.get('max_vertical_excursion_m')):+.2f} m, {r.get('platform')} {r.get('family')}/{r.get('attack')}, "
        f"wind {num(r.get('wind_speed_mps')):.1f} m/s{', GPS fault' if truthy(r.get('gps_fault')) else ''}"
        f"{'; beyond authority (' + str(r.get('beyond_authority')) + ')' if r.get('beyond_authority') else ''}"
        f"{'; activated at start (inside the activation boundary)' if truthy(r.get('activated_at_start')) else ''}"
        f"{_sustained_wind_text(r)}, "
        f"activations {r.get('activations')}, final mode {r.get('final_mode')}"
    )


def _sustained_wind_text(r: Mapping) -> str:
    w, vmax = num(r.get("peak_sustained_wind_mps")), num(r.get("platform_max_speed_mps"))
    if not math.isfinite(w):
        return ""
    ratio = f", {w / vmax:.2f} x its max speed {vmax:.1f} m/s" if math.isfinite(vmax) and vmax > 0 else ""
    return f"; wind met {w:.1f} m/s over {SUSTAINED_WIND_WINDOW_S:g} s{ratio}"


# --------------------------------------------------------------------------- figures
def plot_excursions(rows: Sequence[Mapping], out_base: Path) -> list[Path]:
    """Strip plot of peak excursion per family and variant, on a symmetric-log axis (m)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if not is_error(r)]
    families = sorted({str(r.get("family")) for r in ok})
    colours = {"predictive": "tab:blue", "reactive": "tab:orange", "unprotected": "tab:grey"}
    offsets = {"predictive": -0.25, "reactive": 0.0, "unprotected": 0.25}
    fig, ax = plt.subplots(figsize=(max(7.0, 1.1 * len(families) + 3.0), 5.0))
    rng = np.random.default_rng(0)
    for v in VARIANTS:
        for i, f in enumerate(families):
            y = np.asarray([num(r.get("max_excursion_m")) for r in ok if r.get("family") == f and r.get("variant") == v])
            y = y[np.isfinite(y)]
            if not len(y):
                continue
            x = i + offsets[v] + rng.uniform(-0.07, 0.07, len(y))
            ax.scatter(
                x,
                y,
                s=16,
                color=colours[v],
                alpha=0.75,
                edgecolors="none",
                label=v if i == 0 or not any(h.get_label() == v for h in ax.collections) else None,
            )
            ax.hlines(np.median(y), i + offsets[v] - 0.1, i + offsets[v] + 0.1, color=colours[v], lw=2)
    ax.axhline(0.0, color="red", lw=1.0, ls="--")
    ax.text(1.0, 0.0, " fence", color="red", va="bottom", ha="right", transform=ax.get_yaxis_transform())
    ax.set_yscale("symlog", linthresh=1.0)
    ax.set_xticks(range(len(families)))
    ax.set_xticklabels(families, rotation=30, ha="right")
    ax.set_xlabel("case family")
    ax.set_ylabel("peak excursion beyond the fence (m, symlog; < 0 inside)")
    ax.set_title("Peak excursion per family and variant (bar: median)")
    handles, labels = ax.get_legend_handles_labels()
    uniq = dict(zip(labels, handles))
    ax.legend(uniq.values(), uniq.keys(), loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, out_base)


def plot_breach_bounds(rows: Sequence[Mapping], out_base: Path) -> list[Path]:
    """Per platform and variant: observed breach rate (dot) and its exact 95 % upper bound (bar)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    stats = {s.key: s for s in grouped(rows, ("platform", "variant"))}
    platforms = sorted({k[0] for k in stats})
    colours = {"predictive": "tab:blue", "reactive": "tab:orange", "unprotected": "tab:grey"}
    fig, ax = plt.subplots(figsize=(max(7.0, 1.3 * len(platforms) + 3.0), 4.8))
    width = 0.26
    for j, v in enumerate(VARIANTS):
        xs, ub, rate, labels = [], [], [], []
        for i, p in enumerate(platforms):
            s = stats.get((p, v))
            if s is None or not s.scored:
                continue
            xs.append(i + (j - 1) * width)
            ub.append(s.breach_rate_upper)
            rate.append(s.breach_rate)
            labels.append(f"{s.breaches}/{s.scored}")
        if not xs:
            continue
        ax.bar(xs, ub, width=width * 0.9, color=colours[v], alpha=0.35, label=f"{v}: 95 % upper bound")
        ax.scatter(xs, rate, color=colours[v], zorder=3, s=22, label=f"{v}: observed")
        for x, u, t in zip(xs, ub, labels):
            ax.text(x, u + 0.01, t, ha="center", va="bottom", fontsize=7)
    ax.set_xticks(range(len(platforms)))
    ax.set_xticklabels(platforms)
    ax.set_ylim(0.0, 1.12)
    ax.set_xlabel("platform")
    ax.set_ylabel("breach rate (fraction of scored flights)")
    ax.set_title("Breach rate per platform: observed and exact (Clopper-Pearson) 95 % upper bound")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, out_base)


# --------------------------------------------------------------------------- report
def _f(x: float, digits: int = 2) -> str:
    return "n/a" if not math.isfinite(x) else f"{x:.{digits}f}"


def _rate(s: GroupStats) -> str:
    return f"{s.breaches}/{s.scored} ({_f(s.breach_rate, 3)}, ≤ {_f(s.breach_rate_upper, 4)})"


def _stats_table(stats: Sequence[GroupStats], names: Sequence[str]) -> list[str]:
    lines = [
        "| " + " | ".join(names) + " | flights | errors | incomplete | keep-in | keep-out | vertical | out-of-gap "
        "| breaches/scored (rate, 95 % UB) | sim h | per h (95 % UB) |",
        "|" + "---|" * len(names) + "---:|---:|---:|---:|---:|---:|---:|---|---:|---|",
    ]
    for s in stats:
        lines.append(
            "| " + " | ".join(s.key) + f" | {s.flights} | {s.errors} | {s.incomplete} | {s.keep_in_breaches} "
            f"| {s.keep_out_entries} | {s.vertical_breaches} | {s.out_of_gap_landings} | {_rate(s)} "
            f"| {s.hours:.3f} | {_f(s.per_hour, 1)} ({_f(s.per_hour_upper, 1)}) |"
        )
    return lines


def _containment_section(rows: Sequence[Mapping], contingency: Mapping[str, ContingencyInputs]) -> list[str]:
    predictive = [r for r in rows if r.get("variant") == "predictive"]
    return [
        "## Containment (predictive)",
        "",
        "The operational volume is the fence; around it the contingency volume (lateral S_CV, vertical H_CV) and "
        "the ground risk buffer (1:1 rule) sized per platform by the SORA guidance's method "
        "(`analysis/containment.py`: S_CV = S_GNSS 3 m + S_pos 3 m + S_map 1 m + v0 t_R + v0²/(2 g tan φ), "
        "H_CV = 1 m + 0.707 v0 t_R + v0²/(2 g), v0 the top speed, t_R the reaction time, φ the bank or tilt limit). "
        "Exits of each volume per class, every class side by side: per flight with the exact 95 % bound, per "
        "simulated flight hour with the Poisson 95 % bound.",
        "",
        *containment_lines(predictive, contingency),
        "",
        f"![{CONTAINMENT_FIGURE[1]}]({CONTAINMENT_FIGURE[0]}.png)",
        "",
    ]


def campaign_report_lines(
    rows: Sequence[Mapping], manifest: Mapping | None = None, contingency: Mapping[str, ContingencyInputs] | None = None
) -> list[str]:
    """The markdown of the campaign report for joined rows (:func:`campaign_rows`); with ``contingency`` (each
    platform's figures) its containment section."""
    rows = list(rows)
    lines = ["# Geofence efficacy campaign", ""]
    if manifest is not None:
        lines.append(
            f"Campaign seed {manifest.get('seed')}: {manifest.get('n_cases')} cases "
            f"({manifest.get('skipped_cases', 0)} skipped: no platform fitted) x {len(VARIANTS)} variants; "
            f"{len(rows)} flights in the results."
        )
        lines.append("")
    lines += [
        "Definitions: a **keep-in breach** is a lateral excursion > "
        f"{KEEP_IN_TOLERANCE_M:g} m (beyond a keep-in edge or into a keep-out zone); a **vertical breach** an "
        f"excursion > {VERTICAL_TOLERANCE_M:g} m above the ceiling or below the floor outside every gap; a "
        "**breach** is any of keep-in, keep-out entry, vertical, or landing outside a gap. Rates are over scored "
        "flights without an error; the upper bounds are one-sided exact 95 % (Clopper-Pearson for the rate, "
        "Poisson for breaches per simulated flight hour). The unprotected twin is scored from its trajectory "
        "against its case's fence.",
        "",
    ]
    rows = [dict(r, condition=condition(r)) for r in rows]
    nominal = [r for r in rows if r["condition"] == "nominal"]
    lines += [
        "## Nominal conditions (the containment figure)",
        "",
        "Wind within each platform's authority (mean + one turbulence sigma at the start height below "
        "90 % of its max speed, judged before the flight; and in flight no "
        f"{SUSTAINED_WIND_WINDOW_S:g} s mean of the wind met above its max speed), a start outside the "
        "activation boundary (the predictive unit did not activate at its first step) and no GPS fault.",
        "",
    ]
    cases = (manifest or {}).get("cases") or []
    if cases and not any("beyond_authority" in c for c in cases):
        lines += [
            "**This manifest predates the authority test: every case without a GPS fault counts as nominal here.** "
            "Regenerate the campaign (same seed: the same cases) to class them.",
            "",
        ]
    lines += _stats_table(grouped(nominal, ("variant",)), ["variant"]) + [""]
    lines += [
        "## Per variant and condition",
        "",
        "GPS fault: the position source lost or out (dead reckoning drifts with the wind estimate's error). "
        "Beyond authority: a wind the platform cannot fly back against for long; the unit is to land, never "
        "over a forbidden area. Beyond max speed in flight: the flight met a wind whose "
        f"{SUSTAINED_WIND_WINDOW_S:g} s mean exceeded its platform's max speed (judged on every flight from its "
        "trajectory, breached or not). Activated at start: the case began inside the activation boundary (its "
        "predictive unit overrode at the first step), where the override's guarantee has not begun: the "
        "generator prefers a start beyond it and cannot always find one.",
        "",
    ]
    lines += _stats_table(grouped(rows, ("variant", "condition")), ["variant", "condition"]) + [""]
    if contingency:
        lines += _containment_section(rows, contingency)
    lines += ["## Per variant", ""] + _stats_table(grouped(rows, ("variant",)), ["variant"]) + [""]
    lines += (
        ["## Per variant and platform", ""] + _stats_table(grouped(rows, ("variant", "platform")), ["variant", "platform"]) + [""]
    )
    lines += ["## Per variant and family", ""] + _stats_table(grouped(rows, ("variant", "family")), ["variant", "family"]) + [""]
    lines += (
        ["## Per variant, platform and family", ""]
        + _stats_table(grouped(rows, ("variant", "platform", "family")), ["variant", "platform", "family"])
        + [""]
    )

    lines += [
        "## Peak excursion: predictive vs reactive",
        "",
        "Peak excursion `max_excursion_m` (m beyond the fence; < 0: closest approach inside). Ratios compare "
        "the depth beyond the fence, max(excursion, 0), predictive / reactive (n/a when the reactive fence "
        "was never crossed). Paired: mean over cases of predictive - reactive.",
        "",
        "| family | variant | n | mean (m) | p95 (m) | max (m) | depth ratio mean / max | paired mean (m), n |",
        "|---|---|---:|---:|---:|---:|---|---|",
    ]
    for c in excursion_comparison(rows):
        for v in VARIANTS:
            s = c["stats"][v]
            if not s.n:
                continue
            extra = (
                f"{_f(c['mean_depth_ratio'], 3)} / {_f(c['max_depth_ratio'], 3)} | {_f(c['paired_mean_m'])}, {c['paired_n']}"
                if v == "predictive"
                else " | "
            )
            lines.append(f"| {c['family']} | {v} | {s.n} | {_f(s.mean_m)} | {_f(s.p95_m)} | {_f(s.max_m)} | {extra} |")
    lines.append("")

    lines += [
        "## Unprotected twins",
        "",
        "Cases whose unprotected twin breached, and what the protected flight of the same case did.",
        "",
        "| variant | twin breached | ... and held | ... and breached too | twin clean but protected breached |",
        "|---|---:|---:|---:|---:|",
    ]
    for v, c in unprotected_vs_protected(rows).items():
        lines.append(
            f"| {v} | {c['twin_breached']} | {c['twin_breached_and_held']} | {c['twin_breached_and_breached']} "
            f"| {c['twin_clean_but_breached']} |"
        )
    lines.append("")

    lines += [
        "## Normal missions",
        "",
        "Missions keep every waypoint and leg 3 turn/stop rooms inside every boundary. A **nuisance override** "
        "is a mission flight with activations > 0; **stalled** a mission that did not finish with activations "
        "> 0 and no error; errors are counted apart. **Passed the check**: missions the pre-flight check "
        "(`geofence-testbed check`) passed; the check promises that these are never overridden.",
        "",
        "| variant | missions | nuisance overrides | stalled by the geofence | errors | passed the check | "
        "... and overridden anyway |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for v in VARIANTS:
        sel = [r for r in rows if r.get("variant") == v and is_mission(r)]
        if not sel:
            continue
        s = group_stats(sel)
        lines.append(
            f"| {v} | {s.missions} | {s.nuisance_missions} | {s.stalled_missions} | {s.errors} | "
            f"{s.checked_missions} | {s.checked_nuisance} |"
        )
    lines.append("")

    lines += ["## Offending flights", ""]
    for v in ("predictive", "reactive"):
        bad = offending_flights(rows, v)
        lines.append(f"**{v}** ({len(bad)}: keep-in breach, keep-out entry, vertical breach or out-of-gap landing):")
        lines.append("")
        lines += [f"- {describe_flight(r)}" for r in sorted(bad, key=lambda r: -num(r.get("max_excursion_m")))] or ["- none"]
        lines.append("")
    errs = [r for r in rows if is_error(r)]
    lines += [f"## Errors ({len(errs)})", ""]
    lines += [f"- `{r.get('flight')}`: {' '.join(str(r.get('error')).split())}" for r in errs] or ["None."]
    lines.append("")
    lines += ["## Figures", ""]
    for stem, caption in FIGURES.items():
        lines += [f"### {caption}", "", f"![{caption}]({stem}.png)", ""]
    return lines


def _not_this_campaign(batch_dir: Path, n_results: int, manifest: Mapping, manifest_path) -> str:
    """Why results that hold none of the campaign's flights are refused, in one line."""
    cases = manifest.get("cases") or []
    example = f"{cases[0]['case_id']}__{VARIANTS[0]}" if cases else "<case_id>__predictive"
    return (
        f"{batch_dir / RESULTS_CSV}: none of its {n_results} flights is one of the campaign's in {manifest_path} "
        f"(named <case_id>__<variant>, e.g. {example}): give the folder this campaign was flown into"
    )


def write_campaign_report(
    batch_dir: str | Path,
    manifest_path: str | Path,
    *,
    out_dir: str | Path | None = None,
    contingency: Mapping[str, ContingencyInputs] | None = None,
) -> Path:
    """Read ``<batch_dir>/results.csv`` and the manifest; write ``campaign_report.md``, its figures and
    ``campaign_flights.csv`` (one row per flight, :func:`flight_summaries`).

    Returns the report's path (in ``out_dir``, default ``batch_dir``). Results of which no flight is one of the
    campaign's (``<case_id>__<variant>``) are refused with a one-line :class:`ConfigError`, nothing written.
    """
    batch_dir = Path(batch_dir)
    out_dir = Path(out_dir) if out_dir is not None else batch_dir
    out_dir.mkdir(parents=True, exist_ok=True)
    manifest = load_manifest(manifest_path)
    results = read_results_csv(batch_dir / RESULTS_CSV)
    rows = campaign_rows(results, manifest, batch_dir)
    if not rows:
        raise ConfigError(_not_this_campaign(batch_dir, len(results), manifest, manifest_path))
    plot_excursions(rows, out_dir / "campaign_excursion")
    plot_breach_bounds(rows, out_dir / "campaign_breach_bounds")
    if contingency:
        predictive = [dict(r, condition=condition(r)) for r in rows if r.get("variant") == "predictive"]
        plot_containment(predictive, contingency, out_dir / CONTAINMENT_FIGURE[0])
        counts = {
            "campaign": {k: manifest.get(k) for k in CAMPAIGN_SETTINGS},
            "cases": [int(manifest.get("first_case") or 0), int(manifest.get("n_cases_requested") or 0)],
            "results_sha256": file_sha256(batch_dir / RESULTS_CSV),
            "variant": "predictive",
            "classes": class_rates_record(class_rates(predictive, contingency)),
        }
        replace_text(out_dir / COUNTS_JSON, json.dumps(counts, indent=1) + "\n")
    flights = out_dir / FLIGHTS_CSV
    with replacing(flights, newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=FLIGHT_COLUMNS)
        writer.writeheader()
        writer.writerows(flight_summaries(rows))
    return replace_text(out_dir / REPORT_MD, "\n".join(campaign_report_lines(rows, manifest, contingency)))


# --------------------------------------------------------------------------- shards of one campaign
def file_sha256(path: str | Path) -> str:
    """The sha256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


class Shard(NamedTuple):
    """One shard's containment counts (:data:`COUNTS_JSON` in its results folder)."""

    folder: Path
    campaign: dict
    first_case: int
    n_cases: int
    classes: list[ClassRates]


def read_shard(folder: str | Path) -> Shard:
    """A results folder's :data:`COUNTS_JSON`, checked: present, well-formed, and not stale (its ``results.csv``
    unchanged since the report was written); else a one-line :class:`ConfigError` naming the file."""
    folder = Path(folder)
    path = folder / COUNTS_JSON
    if not path.is_file():
        raise ConfigError(f"{path}: missing (run 'geofence-testbed campaign report {folder} --campaign CAMPAIGN' first)")
    try:
        doc = json.loads(path.read_text())
        classes = [
            ClassRates(str(c["name"]), int(c["flights"]), float(c["hours"]), _exits(c["exits"])) for c in doc["classes"]
        ]  # fmt: skip
        first, n = (int(x) for x in doc["cases"])
        campaign, digest = dict(doc["campaign"]), str(doc["results_sha256"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ConfigError(f"{path}: not a containment counts file ({type(exc).__name__}: {exc})") from None
    results = folder / RESULTS_CSV
    if not results.is_file() or file_sha256(results) != digest:
        raise ConfigError(f"{path}: stale ({results} changed since the report was written; run 'campaign report' again)")
    return Shard(folder, campaign, first, n, classes)


def _exits(by_volume: Mapping) -> tuple[int, int, int, int]:
    """A counts file's exits by volume, in :data:`analysis.containment.VOLUMES`' order."""
    fence, cv, grb, floor = (int(by_volume[v]) for v in VOLUMES)
    return fence, cv, grb, floor


def check_shards(shards: Sequence[Shard]) -> None:
    """The shards are of one campaign (the same :data:`CAMPAIGN_SETTINGS`) and no case is in two of them: else a
    one-line :class:`ConfigError` naming the field or the cases."""
    first = shards[0]
    for sh in shards[1:]:
        for key in CAMPAIGN_SETTINGS:
            if sh.campaign.get(key) != first.campaign.get(key):
                raise ConfigError(
                    f"{sh.folder / COUNTS_JSON}: campaign.{key} is {sh.campaign.get(key)!r}, "
                    f"{first.folder / COUNTS_JSON} has {first.campaign.get(key)!r}: not shards of one campaign"
                )  # fmt: skip
    spans = sorted(shards, key=lambda sh: sh.first_case)
    for a, b in zip(spans, spans[1:]):
        if b.first_case < a.first_case + a.n_cases:
            raise ConfigError(
                f"{b.folder / COUNTS_JSON}: cases {b.first_case}..{b.first_case + b.n_cases - 1} overlap "
                f"{a.folder / COUNTS_JSON}'s {a.first_case}..{a.first_case + a.n_cases - 1} (a flight counted twice)"
            )  # fmt: skip


def combine_containment(folders: Sequence[str | Path], out_path: str | Path) -> Path:
    """The containment section of several shards of one campaign, their counts added up (:func:`read_shard`,
    :func:`check_shards`, :func:`analysis.containment.add_class_rates`), written to ``out_path`` (markdown)."""
    if not folders:
        raise ConfigError("campaign combine: give at least one results folder")
    shards = [read_shard(f) for f in folders]  # (every file checked before anything is written)
    check_shards(shards)
    total = add_class_rates([sh.classes for sh in shards])
    flights, hours = sum(c.flights for c in total), sum(c.hours for c in total)
    c = shards[0].campaign
    lines = [
        "# Containment over the shards of one campaign (predictive)",
        "",
        f"Campaign seed {c.get('seed')} ({c.get('generator')}; longest flight {c.get('max_duration_s')} s"
        f"{'; one single failure per case' if c.get('faults') else ''}): {len(shards)} shards, "
        f"{sum(sh.n_cases for sh in shards)} cases requested, {flights} scored flights, {hours:.1f} simulated flight "
        "hours. Each shard's counts were read from its `containment_counts.json` (written by `campaign report`, "
        "checked against its `results.csv`); the flights of different shards are disjoint, so the counts add up "
        "and the bounds below are the whole campaign's.",
        "",
        "| shard | cases | flights | flight h |",
        "|---|---|---:|---:|",
        *(f"| {sh.folder} | {sh.first_case}..{sh.first_case + sh.n_cases - 1} | {sum(k.flights for k in sh.classes)} | "
          f"{sum(k.hours for k in sh.classes):.1f} |" for sh in sorted(shards, key=lambda sh: sh.first_case)),
        "",
        *class_rate_lines(total),
        "",
    ]  # fmt: skip
    return replace_text(Path(out_path), "\n".join(lines))
