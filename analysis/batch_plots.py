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

Platforms are aircraft models (``"F450 (multirotor)"``). Wind levels are the
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


def _colours(platforms: Sequence[str]) -> dict[str, str]:
    return {p: PALETTE[i % len(PALETTE)] for i, p in enumerate(platforms)}


# --------------------------------------------------------------------------- statistics
def comparison_stats(rows: Sequence[Mapping]) -> list[dict]:
    """One dict per (platform, wind level) that has flights, platforms then wind levels in order.

    Keys: ``platform``, ``wind``, ``flights``, ``failed``, ``scored``,
    ``breaches`` (peak excursion > 0), ``keep_out_breaches``,
    ``landed_outside_gap``, ``mean_peak_excursion_m``, ``max_peak_excursion_m``,
    ``mean_activations``, ``mean_time_to_handback_s`` (mean over flights of
    the per-flight mean recovery time), ``mean_time_to_peak_excursion_s``.
    Means skip missing values; NaN when nothing is left.
    """
    levels, level = wind_levels(rows)
    out = []
    for p in _platforms(rows):
        for w in levels:
            group = [r for r in rows if platform_of(r) == p and level(r) == w]
            if not group:
                continue
            ok = [r for r in group if not is_failed(r)]
            scored = [r for r in ok if is_scored(r)]
            exc = np.array([num(r.get("max_excursion_m")) for r in scored])
            out.append(
                {
                    "platform": p,
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
    """The platform comparison as a markdown table (one line per platform and wind level)."""
    head = (
        "| platform | wind | flights | failed | breaches | keep-out breaches | landed outside gap "
        "| mean peak excursion (m) | max peak excursion (m) | mean activations | mean recovery time (s) "
        "| mean time to peak (s) |"
    )
    sep = "|" + "|".join(["---", "---"] + ["---:"] * 10) + "|"
    lines = [head, sep]
    for s in comparison_stats(rows):
        lines.append(
            f"| {s['platform']} | {s['wind']} | {s['flights']} | {s['failed']} | {s['breaches']}/{s['scored']} "
            f"| {s['keep_out_breaches']} | {s['landed_outside_gap']} | {_fmt(s['mean_peak_excursion_m'])} "
            f"| {_fmt(s['max_peak_excursion_m'])} | {_fmt(s['mean_activations'], 1)} "
            f"| {_fmt(s['mean_time_to_handback_s'])} | {_fmt(s['mean_time_to_peak_excursion_s'])} |"
        )
    if len(lines) == 2:
        lines.append("| (no flights) |" + " |" * 11)
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
    n = len(rows)
    failed = sum(is_failed(r) for r in rows)
    scored = sum(is_scored(r) and not is_failed(r) for r in rows)
    return f"{n} flights, {scored} scored, {failed} failed"


def plot_breach_distribution(rows: Sequence[Mapping], out_base: Path) -> list[Path]:
    """Distribution of breaches across a batch, per platform; writes ``out_base`` .png and .svg.

    Top: histogram and ECDF of the peak 3-D excursion beyond the fence (m;
    > 0 is a breach; the minimum 3-D margin is its negative). Bottom: ECDFs of
    the minimum lateral and vertical margins (m, + inside). The fence line
    (0 m) is marked on every panel and the breach side shaded.
    """
    rows = list(rows)
    good = [r for r in rows if is_scored(r) and not is_failed(r)]
    platforms = _platforms(good)
    colour = _colours(platforms)
    fig, axes = plt.subplots(2, 2, figsize=(12, 8), constrained_layout=True)
    (ax_hist, ax_ecdf), (ax_lat, ax_vert) = axes
    by = {p: [r for r in good if platform_of(r) == p] for p in platforms}

    exc_all = np.array([num(r["max_excursion_m"]) for r in good]) if good else np.array([])
    if len(exc_all):
        lo, hi = float(exc_all.min()), float(exc_all.max())
        lo, hi = min(lo, -0.5), max(hi, 0.5)
        width = (hi - lo) / float(np.clip(np.sqrt(len(exc_all)) * 2, 8, 40))
        bins = np.arange(math.floor(lo / width) - 1, math.ceil(hi / width) + 2) * width  # 0 is a bin edge
        data = [np.array([num(r["max_excursion_m"]) for r in by[p]]) for p in platforms]
        ax_hist.hist(
            data,
            bins=bins,
            color=[colour[p] for p in platforms],
            label=platforms,
            alpha=0.85,
            histtype="barstacked",
            edgecolor="white",
            linewidth=0.5,
        )
        for p, d in zip(platforms, data):
            _ecdf(ax_ecdf, d, color=colour[p], lw=2, label=f"{p} (n={len(d)})")
    else:
        _no_data(ax_hist)
        _no_data(ax_ecdf)

    def margin_panel(ax, key: str, axis: str) -> None:
        any_data = False
        for p in platforms:
            d = np.array([-num(r.get(key)) for r in by[p]])
            d = d[np.isfinite(d)]
            if len(d):
                _ecdf(ax, d, color=colour[p], lw=2, label=f"{p} (n={len(d)})")
                any_data = True
        if not any_data:
            _no_data(ax)
        ax.set_xlabel(f"minimum {axis} margin (m, + inside the fence)")
        ax.set_ylabel("fraction of flights ≤ x")
        ax.set_title(f"closest {axis} approach", fontsize="medium")

    margin_panel(ax_lat, "max_lateral_excursion_m", "lateral")
    margin_panel(ax_vert, "max_vertical_excursion_m", "vertical")

    ax_hist.set_xlabel("peak excursion beyond the fence (m, > 0 = breach)")
    ax_hist.set_ylabel("flights")
    ax_hist.set_title("peak 3-D excursion (histogram, stacked by platform)", fontsize="medium")
    ax_ecdf.set_xlabel("peak excursion beyond the fence (m, > 0 = breach)")
    ax_ecdf.set_ylabel("fraction of flights ≤ x")
    ax_ecdf.set_title("peak 3-D excursion (ECDF)", fontsize="medium")
    for ax, breach_side in ((ax_hist, 1), (ax_ecdf, 1), (ax_lat, -1), (ax_vert, -1)):
        ax.axvline(0.0, **FENCE_STYLE, label="fence line")
        x0, x1 = ax.get_xlim()
        if breach_side > 0:
            x1 = max(x1, 0.5)
            ax.axvspan(0.0, x1, color="tab:red", alpha=0.08, label="breach")
            ax.set_xlim(x0, x1)
        else:
            x0 = min(x0, -0.5)
            ax.axvspan(x0, 0.0, color="tab:red", alpha=0.08, label="breach")
            ax.set_xlim(x0, x1)
        if ax is not ax_hist:
            ax.set_ylim(0.0, 1.02)
        ax.grid(alpha=0.3)
        handles, labels = ax.get_legend_handles_labels()
        if handles:
            ax.legend(loc="best" if ax is ax_hist else "lower right", fontsize="small", framealpha=0.9)
    fig.suptitle(f"Breach distribution across the batch ({_counts_note(rows)})")
    return save_figure(fig, out_base)


def plot_platform_comparison(rows: Sequence[Mapping], out_base: Path) -> list[Path]:
    """Small multiples per platform and wind level; writes ``out_base`` .png and .svg.

    Panels: breaches (count of the scored flights, labelled breaches/scored;
    "no breaches" written in the panel when there are none), activations per
    flight (mean), the peak lateral excursion and the peak vertical excursion
    in separate panels (every flight as a dot, the mean as a bar, the max as a
    triangle; m beyond the fence, fence line at 0; never mixed), and mean
    recovery time (OVERRIDE to hand-back, s). Wind level on x, one
    bar/column per platform, every bar labelled with its platform, one key.
    """
    from matplotlib.artist import Artist
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    rows = list(rows)
    stats = [s for s in comparison_stats(rows) if s["scored"] > 0]
    platforms = sorted({s["platform"] for s in stats})
    levels_all, level_of = wind_levels(rows)
    levels = [w for w in levels_all if any(s["wind"] == w for s in stats)]
    colour = _colours(platforms)
    fig, axes = plt.subplots(3, 2, figsize=(12, 11.5), layout="constrained")
    ax_b, ax_a, ax_lat, ax_vert, ax_r, ax_key = axes.ravel()
    ax_key.axis("off")
    axes = np.array([ax_b, ax_a, ax_lat, ax_vert, ax_r])
    x = np.arange(len(levels))
    width = 0.8 / max(1, len(platforms))
    table = {(s["platform"], s["wind"]): s for s in stats}

    def offsets(i: int) -> np.ndarray:
        return x - 0.4 + width * (i + 0.5)

    def excursion_panel(ax, good, key: str, axis: str) -> None:
        """Every flight's peak excursion along one axis as a dot, the mean as a bar, the max as a triangle."""
        rng = np.random.default_rng(0)
        any_data = False
        for i, p in enumerate(platforms):
            xs = offsets(i)
            for j, w in enumerate(levels):
                vals = np.array([num(r.get(key)) for r in good if platform_of(r) == p and level_of(r) == w])
                vals = vals[np.isfinite(vals)]
                if not len(vals):
                    continue
                any_data = True
                jitter = rng.uniform(-0.28, 0.28, len(vals)) * width
                ax.scatter(xs[j] + jitter, vals, s=14, color=colour[p], alpha=0.55, edgecolors="none", zorder=3)
                ax.hlines(vals.mean(), xs[j] - 0.42 * width, xs[j] + 0.42 * width, color=colour[p], lw=3, zorder=4)
                ax.plot(xs[j], vals.max(), marker="v", ms=9, color=colour[p], markeredgecolor="black", ls="none", zorder=5)
                ax.annotate(
                    p.split(" (")[0],
                    (xs[j], vals.max()),
                    xytext=(0, 7),
                    textcoords="offset points",
                    ha="center",
                    va="bottom",
                    fontsize="x-small",
                    color=colour[p],
                )
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

    def bars(ax, key: str, fmt: str, label_total: bool = False) -> None:
        for i, p in enumerate(platforms):
            vals = [table[(p, w)][key] if (p, w) in table else math.nan for w in levels]
            b = ax.bar(offsets(i), np.nan_to_num(vals, nan=0.0), width * 0.9, color=colour[p], alpha=0.9)
            for rect, v, w in zip(b, vals, levels):
                if (p, w) not in table:
                    continue
                text = "–" if not math.isfinite(v) else fmt.format(v)
                if label_total:
                    text += f"/{table[(p, w)]['scored']}"
                text = f"{p.split(' (')[0]}\n{text}"
                ax.annotate(
                    text,
                    (rect.get_x() + rect.get_width() / 2, max(rect.get_height(), 0.0)),
                    xytext=(0, 2),
                    textcoords="offset points",
                    ha="center",
                    va="bottom",
                    fontsize="small",
                )
        ax.set_ylim(0, max(ax.get_ylim()[1], 1e-9) * 1.18)

    if not stats:
        for ax in axes.ravel():
            _no_data(ax, "no scored flights")
    else:
        bars(ax_b, "breaches", "{:.0f}", label_total=True)
        ax_b.set_ylim(0, max([s["breaches"] for s in stats] + [1]) * 1.25)
        if not any(s["breaches"] for s in stats):
            ax_b.text(
                0.5,
                0.55,
                f"no breaches in {sum(s['scored'] for s in stats)} scored flights",
                transform=ax_b.transAxes,
                ha="center",
                va="center",
                color="tab:green",
                fontsize="large",
                fontweight="bold",
            )
        ax_b.set_ylabel("flights with a breach")
        ax_b.set_title("breaches (peak excursion > 0 m; labels: breaches/scored)", fontsize="medium")

        good = [r for r in rows if is_scored(r) and not is_failed(r)]
        for ax, key, axis in ((ax_lat, "max_lateral_excursion_m", "lateral"), (ax_vert, "max_vertical_excursion_m", "vertical")):
            excursion_panel(ax, good, key, axis)
        bars(ax_a, "mean_activations", "{:.1f}")
        ax_a.set_ylabel("activations per flight (mean)")
        ax_a.set_title("geofence activations (entries into OVERRIDE)", fontsize="medium")
        bars(ax_r, "mean_time_to_handback_s", "{:.1f} s")
        ax_r.set_ylabel("recovery time (s)")
        ax_r.set_title("mean recovery time (OVERRIDE entry to hand-back)", fontsize="medium")

    for ax in axes.ravel():
        ax.set_xticks(x, levels)
        ax.set_xlabel("wind speed")
        ax.grid(alpha=0.3, axis="y")
        ax.set_axisbelow(True)
    if platforms:
        keys: list[Artist] = [Patch(color=colour[p], label=p) for p in platforms]
        keys += [
            Line2D([], [], marker="o", ls="none", color="grey", alpha=0.6, label="one flight"),
            Line2D([], [], color="grey", lw=3, label="mean"),
            Line2D([], [], marker="v", ls="none", color="grey", markeredgecolor="black", ms=8, label="max"),
            Line2D([], [], **FENCE_STYLE, label="fence line"),
            Patch(color="tab:red", alpha=0.15, label="beyond the fence"),
        ]
        ax_key.legend(handles=keys, loc="center", ncol=2, frameon=False, fontsize="small", title="key")
    fig.suptitle(f"Platform comparison by wind level ({_counts_note(rows)})")
    return save_figure(fig, out_base)
