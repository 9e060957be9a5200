"""Figures and tables across a batch of flights (matplotlib, headless Agg backend, PNG and SVG).

Input: the flat per-flight rows of :func:`analysis.report.collect_results` (or
:func:`analysis.report.read_results_csv`): dicts with ``aircraft``,
``platform_kind``, ``wind_speed_mps`` and the scores of
:mod:`analysis.scoring`. Failed flights (``completed`` false, no scores) are
counted but not plotted.

* :func:`plot_breach_distribution`: how far the flights got beyond (or stayed
  inside) the fence, per platform: histogram and ECDF of the peak excursion,
  and ECDFs of the minimum lateral and vertical margins;
* :func:`plot_platform_comparison`: small multiples per platform and wind
  level (breaches, peak excursion mean and max, activations, recovery time);
* :func:`comparison_table`: the same numbers as a markdown table;
* :func:`comparison_stats`: the numbers themselves.

Platforms are aircraft models (``"F450 (multirotor)"``), and every count,
mean and curve is per platform *and variant* (:func:`variant_of`: the
geofence flown, ``predictive``, ``reactive`` or ``none``), never lumped: a
predictive fence with no breach beside its unprotected twin with two is not
"2/4 breaches". Wind levels are the
distinct ``wind_speed_mps`` values when there are at most
:data:`MAX_WIND_VALUES` of them, else calm / moderate / strong bins
(:data:`WIND_BINS`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

MAX_WIND_VALUES = 4
WIND_BINS = ((0.0, 3.0, "calm"), (3.0, 7.0, "moderate"), (7.0, math.inf, "strong"))
"""``(low, high, label)`` in m/s, low inclusive: used when there are many distinct wind speeds."""

UNREADABLE = "unreadable_summary"
"""A row's flag: its ``summary.json`` could not be read (:func:`analysis.report.collect_results`); such rows
are counted apart, never as a flight of some platform."""
VARIANTS = ("predictive", "reactive", "none", "unknown")
"""The geofence a flight flew (:func:`variant_of`), in the order they are listed."""
VARIANT_LABEL = {"predictive": "predictive", "reactive": "reactive", "none": "no geofence", "unknown": "geofence unknown"}
VARIANT_LINESTYLE = {"predictive": "-", "reactive": "--", "none": ":", "unknown": "-."}
VARIANT_HATCH = {"predictive": "", "reactive": "//", "none": "..", "unknown": "xx"}
PALETTE = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan")
FENCE_STYLE: dict[str, Any] = {"color": "black", "lw": 1.6, "ls": "-"}


# --------------------------------------------------------------------------- row helpers
def num(v) -> float:
    """A row value as a float (NaN for missing, None, empty or non-numeric)."""
    if v is None or isinstance(v, str) and not v.strip():
        return math.nan
    if isinstance(v, bool):
        return float(v)
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def truthy(v) -> bool:
    """A row flag as a bool (``True``/``"true"``/``1``)."""
    if isinstance(v, str):
        return v.strip().lower() in ("true", "1", "yes")
    return bool(v) if v is not None and not (isinstance(v, float) and math.isnan(v)) else False


def flights_of(rows: Iterable[Mapping]) -> list[Mapping]:
    """The rows that are flights (not an unreadable ``summary.json``, see :data:`UNREADABLE`)."""
    return [r for r in rows if not truthy(r.get(UNREADABLE))]


def is_failed(row: Mapping) -> bool:
    """A flight that did not complete or raised an error."""
    return not truthy(row.get("completed")) or bool(row.get("error"))


def is_scored(row: Mapping) -> bool:
    """A flight with fence scores (it flew with a geofence and produced a peak excursion)."""
    return math.isfinite(num(row.get("max_excursion_m")))


def platform_of(row: Mapping) -> str:
    """``"<aircraft> (<platform_kind>)"``, or whichever of the two is known."""
    a, k = row.get("aircraft") or "", row.get("platform_kind") or ""
    if a and k:
        return f"{a} ({k})"
    return str(a or k or "unknown")


def variant_of(row: Mapping) -> str:
    """The geofence a flight flew: ``predictive``, ``reactive``, ``none`` (no geofence) or ``unknown``.

    From ``geofence_variant`` (:func:`analysis.report.collect_results` reads it from the flight's
    ``scenario.yaml``), else a campaign flight's name (``<case>__predictive`` / ``__reactive`` /
    ``__unprotected``), else the ``geofence`` flag (a geofence without a known trigger is predictive, the
    default trigger).
    """
    v = row.get("geofence_variant")
    if v in VARIANTS:
        return str(v)
    _, sep, suffix = str(row.get("flight") or "").rpartition("__")
    if sep and suffix in ("predictive", "reactive"):
        return suffix
    if sep and suffix == "unprotected":
        return "none"
    flag = row.get("geofence")
    if flag is None or isinstance(flag, str) and not flag.strip():
        return "unknown"
    return "predictive" if truthy(flag) else "none"


def series_label(platform: str, variant: str) -> str:
    """``"F450RD (multirotor), predictive"``: one curve, bar or table line."""
    return f"{platform}, {VARIANT_LABEL.get(variant, variant)}"


def wind_levels(rows: Sequence[Mapping]) -> tuple[list[str], Callable[[Mapping], str]]:
    """The wind-level labels in order, and a function mapping a row to its label."""
    speeds = sorted({round(num(r.get("wind_speed_mps")), 3) for r in rows if math.isfinite(num(r.get("wind_speed_mps")))})
    has_unknown = any(not math.isfinite(num(r.get("wind_speed_mps"))) for r in rows)
    if len(speeds) <= MAX_WIND_VALUES:
        labels = [f"{s:g} m/s" for s in speeds]

        def level(r: Mapping) -> str:
            s = num(r.get("wind_speed_mps"))
            return f"{round(s, 3):g} m/s" if math.isfinite(s) else "unknown wind"
    else:

        def bin_label(lo: float, hi: float, lab: str) -> str:
            return f"{lab} ({lo:g}–{hi:g} m/s)" if math.isfinite(hi) else f"{lab} (≥ {lo:g} m/s)"

        labels = [bin_label(*b) for b in WIND_BINS if any(b[0] <= s < b[1] for s in speeds)]

        def level(r: Mapping) -> str:
            s = num(r.get("wind_speed_mps"))
            for b in WIND_BINS:
                if b[0] <= s < b[1]:
                    return bin_label(*b)
            return "unknown wind"

    if has_unknown:
        labels.append("unknown wind")
    return labels, level


def _platforms(rows: Iterable[Mapping]) -> list[str]:
    return sorted({platform_of(r) for r in rows})


def _series(rows: Iterable[Mapping]) -> list[tuple[str, str]]:
    """The (platform, variant) pairs present, platforms sorted, variants in :data:`VARIANTS` order."""
    pairs = {(platform_of(r), variant_of(r)) for r in rows}
    return sorted(pairs, key=lambda pv: (pv[0], VARIANTS.index(pv[1]) if pv[1] in VARIANTS else len(VARIANTS)))


def _colours(platforms: Sequence[str]) -> dict[str, str]:
    return {p: PALETTE[i % len(PALETTE)] for i, p in enumerate(platforms)}


# --------------------------------------------------------------------------- statistics
def comparison_stats(rows: Sequence[Mapping]) -> list[dict]:
    """One dict per (platform, variant, wind level) that has flights, in that order.

    Keys: ``platform``, ``variant`` (:func:`variant_of`), ``wind``, ``flights``, ``failed``, ``scored``,
    ``breaches`` (peak excursion > 0), ``keep_out_breaches``,
    ``landed_outside_gap``, ``mean_peak_excursion_m``, ``max_peak_excursion_m``,
    ``mean_activations``, ``mean_time_to_handback_s`` (mean over flights of
    the per-flight mean recovery time), ``mean_time_to_peak_excursion_s``.
    Means skip missing values; NaN when nothing is left. Unreadable summaries are left out (:func:`flights_of`).
    """
    rows = flights_of(rows)
    levels, level = wind_levels(rows)
    out = []
    for p, v in _series(rows):
        for w in levels:
            group = [r for r in rows if platform_of(r) == p and variant_of(r) == v and level(r) == w]
            if not group:
                continue
            ok = [r for r in group if not is_failed(r)]
            scored = [r for r in ok if is_scored(r)]
            exc = np.array([num(r.get("max_excursion_m")) for r in scored])
            out.append(
                {
                    "platform": p,
                    "variant": v,
                    "wind": w,
                    "flights": len(group),
                    "failed": len(group) - len(ok),
                    "scored": len(scored),
                    "breaches": int(np.count_nonzero(exc > 0.0)),
                    "keep_out_breaches": sum(truthy(r.get("breached_keep_out")) for r in scored),
                    "landed_outside_gap": sum(truthy(r.get("landed_outside_gap")) for r in scored),
                    "mean_peak_excursion_m": _mean(exc),
                    "max_peak_excursion_m": float(exc.max()) if len(exc) else math.nan,
                    "mean_activations": _mean([num(r.get("activations")) for r in scored]),
                    "mean_time_to_handback_s": _mean([num(r.get("time_to_handback_s")) for r in scored]),
                    "mean_time_to_peak_excursion_s": _mean([num(r.get("time_to_peak_excursion_s")) for r in scored]),
                }
            )
    return out


def _mean(values) -> float:
    a = np.asarray(list(values), dtype=float)
    a = a[np.isfinite(a)]
    return float(a.mean()) if len(a) else math.nan


def _fmt(v: float, digits: int = 2) -> str:
    return "–" if not math.isfinite(v) else f"{v:.{digits}f}"


def comparison_table(rows: Sequence[Mapping]) -> str:
    """The platform comparison as a markdown table (one line per platform, variant and wind level)."""
    head = (
        "| platform | geofence | wind | flights | failed | breaches | keep-out breaches | landed outside gap "
        "| mean peak excursion (m) | max peak excursion (m) | mean activations | mean recovery time (s) "
        "| mean time to peak (s) |"
    )
    sep = "|" + "|".join(["---", "---", "---"] + ["---:"] * 10) + "|"
    lines = [head, sep]
    for s in comparison_stats(rows):
        lines.append(
            f"| {s['platform']} | {VARIANT_LABEL.get(s['variant'], s['variant'])} | {s['wind']} | {s['flights']} | {s['failed']} | {s['breaches']}/{s['scored']} "
            f"| {s['keep_out_breaches']} | {s['landed_outside_gap']} | {_fmt(s['mean_peak_excursion_m'])} "
            f"| {_fmt(s['max_peak_excursion_m'])} | {_fmt(s['mean_activations'], 1)} "
            f"| {_fmt(s['mean_time_to_handback_s'])} | {_fmt(s['mean_time_to_peak_excursion_s'])} |"
        )
    if len(lines) == 2:
        lines.append("| (no flights) |" + " |" * 12)
    unreadable = len(rows) - len(flights_of(rows))
    if unreadable:
        lines += ["", f"({unreadable} unreadable summary.json counted apart: not in the table)"]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- figures
def save_figure(fig, out_base: Path, dpi: int = 110) -> list[Path]:
    """Write ``fig`` as ``out_base``.png and .svg (creating the folder), close it, return the paths."""
    out_base = Path(out_base)
    out_base.parent.mkdir(parents=True, exist_ok=True)
    written = []
    for suffix in (".png", ".svg"):
        path = out_base.with_suffix(suffix)
        fig.savefig(path, dpi=dpi)
        written.append(path)
    plt.close(fig)
    return written


def _no_data(ax, text: str = "no scored flights") -> None:
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", color="grey")


def _ecdf(ax, values: np.ndarray, **kw) -> None:
    v = np.sort(values)
    y = np.arange(1, len(v) + 1) / len(v)
    ax.step(np.concatenate([[v[0]], v]), np.concatenate([[0.0], y]), where="post", **kw)


def _counts_note(rows: Sequence[Mapping]) -> str:
    unreadable = len(rows) - len(flights_of(rows))
    rows = flights_of(rows)
    n = len(rows)
    failed = sum(is_failed(r) for r in rows)
    scored = sum(is_scored(r) and not is_failed(r) for r in rows)
    return f"{n} flights, {scored} scored, {failed} failed" + (f", {unreadable} unreadable apart" if unreadable else "")


def _series_style(series: Sequence[tuple[str, str]]) -> dict[tuple[str, str], dict[str, Any]]:
    """Colour per platform, line style and hatch per variant."""
    colour = _colours(sorted({p for p, _ in series}))
    return {
        (p, v): {"color": colour[p], "ls": VARIANT_LINESTYLE.get(v, "-"), "hatch": VARIANT_HATCH.get(v, "")} for p, v in series
    }


def plot_breach_distribution(rows: Sequence[Mapping], out_base: Path) -> list[Path]:
    """Distribution of breaches across a batch, per platform and variant; writes ``out_base`` .png and .svg.

    Top: histogram and ECDF of the peak 3-D excursion beyond the fence (m;
    > 0 is a breach; the minimum 3-D margin is its negative). Bottom: ECDFs of
    the minimum lateral and vertical margins (m, + inside). The fence line
    (0 m) is marked on every panel and the breach side shaded. One key under
    the panels (colour: platform; line style and hatch: the geofence flown), off the data.
    """
    from matplotlib.artist import Artist
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    rows = list(rows)
    good = [r for r in flights_of(rows) if is_scored(r) and not is_failed(r)]
    series = _series(good)
    style = _series_style(series)
    fig, axes = plt.subplots(2, 2, figsize=(12, 9), layout="constrained")
    (ax_hist, ax_ecdf), (ax_lat, ax_vert) = axes
    by = {pv: [r for r in good if (platform_of(r), variant_of(r)) == pv] for pv in series}

    exc_all = np.array([num(r["max_excursion_m"]) for r in good]) if good else np.array([])
    if len(exc_all):
        lo, hi = float(exc_all.min()), float(exc_all.max())
        lo, hi = min(lo, -0.5), max(hi, 0.5)
        width = (hi - lo) / float(np.clip(np.sqrt(len(exc_all)) * 2, 8, 40))
        bins = np.arange(math.floor(lo / width) - 1, math.ceil(hi / width) + 2) * width  # 0 is a bin edge
        data = [np.array([num(r["max_excursion_m"]) for r in by[pv]]) for pv in series]
        _, _, patches = ax_hist.hist(
            data, bins=bins, color=[style[pv]["color"] for pv in series], alpha=0.85, histtype="barstacked",
            edgecolor="white", linewidth=0.5,
        )  # fmt: skip
        for pv, bars in zip(series, patches if len(series) > 1 else [patches]):
            for bar in bars:
                bar.set_hatch(style[pv]["hatch"])
        for pv, d in zip(series, data):
            _ecdf(ax_ecdf, d, color=style[pv]["color"], ls=style[pv]["ls"], lw=2)
    else:
        _no_data(ax_hist)
        _no_data(ax_ecdf)

    def margin_panel(ax, key: str, axis: str) -> None:
        any_data = False
        for pv in series:
            d = np.array([-num(r.get(key)) for r in by[pv]])
            d = d[np.isfinite(d)]
            if len(d):
                _ecdf(ax, d, color=style[pv]["color"], ls=style[pv]["ls"], lw=2)
                any_data = True
        if not any_data:
            _no_data(ax)
        ax.set_xlabel(f"minimum {axis} margin (m, + inside the fence)")
        ax.set_ylabel("fraction of flights ≤ x")
        ax.set_title(f"closest {axis} approach (ECDF)", fontsize="medium")

    margin_panel(ax_lat, "max_lateral_excursion_m", "lateral")
    margin_panel(ax_vert, "max_vertical_excursion_m", "vertical")

    ax_hist.set_xlabel("peak excursion beyond the fence (m, > 0 = breach)")
    ax_hist.set_ylabel("flights")
    ax_hist.set_title("peak 3-D excursion (histogram, stacked by platform and geofence)", fontsize="medium")
    ax_ecdf.set_xlabel("peak excursion beyond the fence (m, > 0 = breach)")
    ax_ecdf.set_ylabel("fraction of flights ≤ x")
    ax_ecdf.set_title("peak 3-D excursion (ECDF)", fontsize="medium")
    for ax, breach_side in ((ax_hist, 1), (ax_ecdf, 1), (ax_lat, -1), (ax_vert, -1)):
        _mark_fence_side(ax, breach_side, ecdf=ax is not ax_hist)
    keys: list[Artist] = [
        Line2D([], [], color=style[pv]["color"], ls=style[pv]["ls"], lw=2, label=f"{series_label(*pv)} (n={len(by[pv])})")
        for pv in series
    ]
    keys += [Line2D([], [], **FENCE_STYLE, label="fence line"), Patch(color="tab:red", alpha=0.15, label="breach side")]
    fig.legend(handles=keys, loc="outside lower center", ncol=min(3, len(keys)), fontsize="small", frameon=False)
    fig.suptitle(f"Breach distribution across the batch, per platform and geofence ({_counts_note(rows)})")
    return save_figure(fig, out_base)


def _mark_fence_side(ax, breach_side: int, ecdf: bool) -> None:
    """The fence line at 0 and the breach side shaded (right for excursions, left for margins)."""
    ax.axvline(0.0, **FENCE_STYLE)
    x0, x1 = ax.get_xlim()
    if breach_side > 0:
        x1 = max(x1, 0.5)
        ax.axvspan(0.0, x1, color="tab:red", alpha=0.08)
    else:
        x0 = min(x0, -0.5)
        ax.axvspan(x0, 0.0, color="tab:red", alpha=0.08)
    ax.set_xlim(x0, x1)
    if ecdf:
        ax.set_ylim(0.0, 1.02)
    ax.grid(alpha=0.3)


def plot_platform_comparison(rows: Sequence[Mapping], out_base: Path) -> list[Path]:
    """Small multiples per platform, variant and wind level; writes ``out_base`` .png and .svg.

    Panels: breaches (count of the scored flights, labelled breaches/scored;
    "no breaches" written in the panel when there are none), activations per
    flight (mean), the peak lateral excursion and the peak vertical excursion
    in separate panels (every flight as a dot, the mean as a bar, the max as a
    triangle; m beyond the fence, fence line at 0; never mixed), and mean
    recovery time (OVERRIDE to hand-back, s). Wind level on x, one bar/column
    per platform and geofence variant (colour: platform; hatch: variant),
    each bar's number written upright above it (no two overlap), one key.
    """
    rows = list(rows)
    stats = [s for s in comparison_stats(rows) if s["scored"] > 0]
    flights = flights_of(rows)
    series = sorted({(s["platform"], s["variant"]) for s in stats}, key=lambda pv: (pv[0], VARIANTS.index(pv[1])))
    levels_all, level_of = wind_levels(flights)
    levels = [w for w in levels_all if any(s["wind"] == w for s in stats)]
    style = _series_style(series)
    fig, axes = plt.subplots(3, 2, figsize=(12, 12), layout="constrained")
    ax_b, ax_a, ax_lat, ax_vert, ax_r, ax_key = axes.ravel()
    ax_key.axis("off")
    panels = [ax_b, ax_a, ax_lat, ax_vert, ax_r]
    place = _BarPlace(len(levels), len(series))
    table = {(s["platform"], s["variant"], s["wind"]): s for s in stats}
    if not stats:
        for ax in panels:
            _no_data(ax, "no scored flights")
    else:
        _breach_panel(ax_b, series, levels, table, style, place, stats)
        good = [r for r in flights if is_scored(r) and not is_failed(r)]
        for ax, key, axis in ((ax_lat, "max_lateral_excursion_m", "lateral"), (ax_vert, "max_vertical_excursion_m", "vertical")):
            _excursion_panel(ax, good, key, axis, series, levels, level_of, style, place)
        _bars(ax_a, "mean_activations", "{:.1f}", series, levels, table, style, place)
        ax_a.set_ylabel("activations per flight (mean)")
        ax_a.set_title("geofence activations (entries into OVERRIDE)", fontsize="medium")
        _bars(ax_r, "mean_time_to_handback_s", "{:.1f} s", series, levels, table, style, place)
        ax_r.set_ylabel("recovery time (s)")
        ax_r.set_title("mean recovery time (OVERRIDE entry to hand-back)", fontsize="medium")
    for ax in panels:
        ax.set_xticks(place.x, levels)
        ax.set_xlabel("wind speed")
        ax.grid(alpha=0.3, axis="y")
        ax.set_axisbelow(True)
    if series:
        _comparison_key(ax_key, series, style)
    fig.suptitle(f"Platform comparison by geofence and wind level ({_counts_note(rows)})")
    return save_figure(fig, out_base)


class _BarPlace:
    """Where each series' bar sits in each wind level's group (x in level units)."""

    def __init__(self, n_levels: int, n_series: int):
        self.x = np.arange(n_levels)
        self.width = 0.8 / max(1, n_series)

    def offsets(self, i: int) -> np.ndarray:
        return self.x - 0.4 + self.width * (i + 0.5)


def _bars(ax, key: str, fmt: str, series, levels, table, style, place, label_total: bool = False) -> None:
    """One bar per series and wind level, its number upright above it."""
    for i, (p, v) in enumerate(series):
        vals = [table[(p, v, w)][key] if (p, v, w) in table else math.nan for w in levels]
        b = ax.bar(
            place.offsets(i), np.nan_to_num(vals, nan=0.0), place.width * 0.9, color=style[(p, v)]["color"], alpha=0.9,
            hatch=style[(p, v)]["hatch"], edgecolor="white",
        )  # fmt: skip
        for rect, val, w in zip(b, vals, levels):
            if (p, v, w) not in table:
                continue
            text = "–" if not math.isfinite(val) else fmt.format(val)
            if label_total:
                text += f"/{table[(p, v, w)]['scored']}"
            x = rect.get_x() + rect.get_width() / 2
            ax.annotate(
                text, (x, max(rect.get_height(), 0.0)), xytext=(0, 3), textcoords="offset points",
                ha="center", va="bottom", rotation=90, fontsize="x-small",
            )  # fmt: skip
    ax.set_ylim(0, max(ax.get_ylim()[1], 1e-9) * 1.35)  # room for the upright numbers


def _breach_panel(ax, series, levels, table, style, place, stats) -> None:
    _bars(ax, "breaches", "{:.0f}", series, levels, table, style, place, label_total=True)
    ax.set_ylim(0, max([s["breaches"] for s in stats] + [1]) * 1.4)
    if not any(s["breaches"] for s in stats):
        ax.text(
            0.5, 0.55, f"no breaches in {sum(s['scored'] for s in stats)} scored flights", transform=ax.transAxes,
            ha="center", va="center", color="tab:green", fontsize="large", fontweight="bold",
        )  # fmt: skip
    ax.set_ylabel("flights with a breach")
    ax.set_title("breaches (peak excursion > 0 m; labels: breaches/scored)", fontsize="medium")


def _excursion_panel(ax, good, key: str, axis: str, series, levels, level_of, style, place) -> None:
    """Every flight's peak excursion along one axis as a dot, the mean as a bar, the max as a triangle."""
    rng = np.random.default_rng(0)
    any_data = False
    for i, pv in enumerate(series):
        xs = place.offsets(i)
        colour = style[pv]["color"]
        for j, w in enumerate(levels):
            vals = np.array([num(r.get(key)) for r in good if (platform_of(r), variant_of(r)) == pv and level_of(r) == w])
            vals = vals[np.isfinite(vals)]
            if not len(vals):
                continue
            any_data = True
            jitter = rng.uniform(-0.28, 0.28, len(vals)) * place.width
            ax.scatter(xs[j] + jitter, vals, s=14, color=colour, alpha=0.55, edgecolors="none", zorder=3)
            ax.hlines(vals.mean(), xs[j] - 0.42 * place.width, xs[j] + 0.42 * place.width, color=colour, lw=3, zorder=4)
            ax.plot(xs[j], vals.max(), marker="v", ms=8, color=colour, markeredgecolor="black", ls="none", zorder=5)
    ax.axhline(0.0, **FENCE_STYLE)
    if not any_data:
        _no_data(ax, f"no {axis} excursions recorded")
    lo, hi = ax.get_ylim()
    hi = max(hi, 0.15 * (hi - lo), 0.5)
    lo, hi = lo - 0.04 * (hi - lo), hi + 0.10 * (hi - lo)
    ax.axhspan(0.0, hi, color="tab:red", alpha=0.08)
    ax.set_ylim(lo, hi)
    what = "edge or keep-out" if axis == "lateral" else "ceiling or floor"
    ax.set_ylabel(f"peak {axis} excursion (m)")
    ax.set_title(
        f"peak {axis} excursion beyond the {what}\n(< 0: closest approach, stayed inside by that much)", fontsize="medium"
    )


def _comparison_key(ax, series, style) -> None:
    """The one key: a patch per platform and geofence (bars left to right in each wind group), then the marks."""
    from matplotlib.artist import Artist
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    keys: list[Artist] = [
        Patch(facecolor=style[pv]["color"], hatch=style[pv]["hatch"], edgecolor="white", label=series_label(*pv)) for pv in series
    ]
    keys += [
        Line2D([], [], marker="o", ls="none", color="grey", alpha=0.6, label="one flight"),
        Line2D([], [], color="grey", lw=3, label="mean"),
        Line2D([], [], marker="v", ls="none", color="grey", markeredgecolor="black", ms=8, label="max"),
        Line2D([], [], **FENCE_STYLE, label="fence line"),
        Patch(color="tab:red", alpha=0.15, label="beyond the fence"),
    ]
    ax.legend(
        handles=keys, loc="center", ncol=1 if len(keys) <= 12 else 2, frameon=False, fontsize="small",
        title="key (bars left to right in each wind group)",
    )  # fmt: skip
