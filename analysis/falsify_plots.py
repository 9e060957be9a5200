"""The falsifier's convergence figure (matplotlib, headless Agg, PNG and SVG via :func:`analysis.batch_plots.save_figure`).

Input: the flights in the order flown and their minimum margins (m, + inside; arrays). Failed flights carry
a large sentinel margin and are left out of the points (the best-so-far curve skips them too).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from analysis.batch_plots import PALETTE, plt, save_figure

PLOTTED_MARGIN_LIMIT_M = 1.0e3
"""Margins at or above this are failed flights' sentinels: not plotted."""


def plot_convergence(flights: np.ndarray, margins_m: np.ndarray, out_base: Path, title: str) -> list[Path]:
    """Each flight's minimum margin and the best (least) so far against the flights flown; the fence line at 0."""
    flights, margins_m = np.asarray(flights, dtype=float), np.asarray(margins_m, dtype=float)
    ok = margins_m < PLOTTED_MARGIN_LIMIT_M
    best = np.minimum.accumulate(np.where(ok, margins_m, np.inf)) if len(margins_m) else margins_m
    fig, ax = plt.subplots(figsize=(7.0, 4.2))
    ax.scatter(flights[ok], margins_m[ok], s=14, color=PALETTE[0], alpha=0.55, label="a flight's minimum margin")
    finite = np.isfinite(best)
    ax.step(flights[finite], best[finite], where="post", color=PALETTE[1], lw=2.0, label="best so far")
    ax.axhline(0.0, color="black", lw=1.2, ls="-")
    ax.text(0.01, 0.0, "fence line: below = breach", transform=ax.get_yaxis_transform(), ha="left", va="bottom", fontsize=8)
    breach = np.flatnonzero(ok & (margins_m < 0.0))
    if len(breach):
        first = flights[breach[0]]
        ax.axvline(first, color="tab:red", lw=1.0, ls="--", label=f"first breach: flight {first:.0f}")
    ax.set_xlabel("flights flown")
    ax.set_ylabel("minimum margin (m, + inside)")
    ax.set_title(f"falsify: {title}")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return save_figure(fig, Path(out_base))
