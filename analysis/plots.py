"""Figures of recorded flights (matplotlib, headless Agg backend, PNG and SVG).

Works on recorded arrays only (``trajectory.csv`` columns, see
:mod:`scenarios.recorder`), so the same plots serve simulations and logs.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot_flight(traj: dict[str, np.ndarray], out_path: Path, title: str, wind_note: str = "") -> list[Path]:
    """Ground track (ENU m, coloured by time) beside altitude and ground speed vs time.

    Writes ``out_path`` with suffix .png and .svg; returns the paths written.
    """
    t, e, n = traj["time_s"], traj["east_m"], traj["north_m"]
    fig = plt.figure(figsize=(11, 5.2), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, width_ratios=[1.25, 1])
    ax = fig.add_subplot(grid[:, 0])
    points = ax.scatter(e, n, c=t, s=2, cmap="viridis")
    ax.plot(e[0], n[0], marker="^", color="tab:green", ms=9, ls="none", label="start")
    ax.plot(e[-1], n[-1], marker="s", color="tab:red", ms=8, ls="none", label="end")
    if "wind_east_mps" in traj and np.nanmax(np.hypot(traj["wind_east_mps"], traj["wind_north_mps"])) > 0.1:
        we, wn = np.nanmean(traj["wind_east_mps"]), np.nanmean(traj["wind_north_mps"])
        ax.annotate(
            "", xy=(0.92, 0.92), xytext=(0.92 - 0.08 * we / np.hypot(we, wn), 0.92 - 0.08 * wn / np.hypot(we, wn)),
            xycoords="axes fraction", arrowprops={"arrowstyle": "-|>", "color": "tab:blue", "lw": 2},
        )
        ax.text(0.92, 0.97, f"mean wind {np.hypot(we, wn):.1f} m/s, blowing toward", transform=ax.transAxes, ha="right", va="top", color="tab:blue")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title("ground track")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    fig.colorbar(points, ax=ax, label="time (s)", shrink=0.8)

    ax_alt = fig.add_subplot(grid[0, 1])
    ax_alt.plot(t, traj["agl_m"], color="tab:purple")
    ax_alt.set_ylabel("height AGL (m)")
    ax_alt.grid(alpha=0.3)
    ax_alt.set_title("altitude and speed")
    ax_spd = fig.add_subplot(grid[1, 1], sharex=ax_alt)
    ax_spd.plot(t, traj["ground_speed_mps"], label="ground speed")
    ax_spd.plot(t, traj["airspeed_mps"], label="airspeed", alpha=0.8)
    ax_spd.set_xlabel("time (s)")
    ax_spd.set_ylabel("speed (m/s)")
    ax_spd.legend(loc="upper right")
    ax_spd.grid(alpha=0.3)
    fig.suptitle(title + (f" — {wind_note}" if wind_note else ""))
    written = []
    for suffix in (".png", ".svg"):
        path = Path(out_path).with_suffix(suffix)
        fig.savefig(path, dpi=110)
        written.append(path)
    plt.close(fig)
    return written
