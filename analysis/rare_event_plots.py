"""The rare-event estimate's figure (matplotlib, headless Agg, PNG and SVG via :func:`analysis.batch_plots.save_figure`).

Input: per level, the minimum margins of its flights (m, + inside; arrays), each level's threshold, the
event's level and the estimate. Subset simulation shows its levels side by side, each level's threshold
the step toward the event; plain Monte Carlo is one level. Failed flights carry a large sentinel margin
and are left out of the points.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from analysis.batch_plots import PALETTE, plt, save_figure
from analysis.falsify_plots import PLOTTED_MARGIN_LIMIT_M


def plot_levels(
    values: Sequence[np.ndarray],
    thresholds: Sequence[float],
    below_m: float,
    probability: float,
    cov: float,
    interval: tuple[float, float] | None,
    out_base: Path,
    title: str,
    bound_threshold_m: float | None = None,
) -> list[Path]:
    """Each level's flights (margin against level, jittered), its threshold, and the event's level.
    ``bound_threshold_m``: the levels stopped above the event, and the estimate is P[margin <= it], an upper bound."""
    fig, ax = plt.subplots(figsize=(7.0, 4.4))
    jitter = np.random.default_rng(0)
    for i, g in enumerate(values):
        g = np.asarray(g, dtype=float)
        ok = g < PLOTTED_MARGIN_LIMIT_M
        hit = ok & (g <= below_m)
        x = i + jitter.uniform(-0.28, 0.28, len(g))
        ax.scatter(x[ok & ~hit], g[ok & ~hit], s=10, color=PALETTE[0], alpha=0.5, label="a flight" if i == 0 else None)
        ax.scatter(x[hit], g[hit], s=14, color="tab:red", alpha=0.8, label="in the event" if i == 0 else None)
    for i, b in enumerate(thresholds[: len(values)]):
        if b > below_m:
            label = "level threshold (its p0 quantile)" if i == 0 else "_nolegend_"
            ax.hlines(b, i - 0.4, i + 0.4, color=PALETTE[1], lw=2.0, label=label)
    ax.axhline(below_m, color="tab:red", lw=1.2, ls="--", label=f"event: margin <= {below_m:+g} m")
    ax.axhline(0.0, color="black", lw=0.8)
    ax.set_xticks(range(len(values)))
    ax.set_xticklabels([f"level {i}" for i in range(len(values))] if len(values) > 1 else ["random draws"])
    ax.set_ylabel("minimum margin (m, + inside)")
    err = f"95 % [{interval[0]:.2g}, {interval[1]:.2g}]" if interval is not None else f"CoV {cov:.2f}"
    if bound_threshold_m is None:
        result = f"estimate {probability:.3g} ({err})"
    else:
        result = f"at most P[min margin <= {bound_threshold_m:+.2f} m] = {probability:.3g} ({err}): the levels stopped there"
    ax.set_title(f"{title}\n{result}", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return save_figure(fig, Path(out_base))
