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


MODE_STYLE = {  # geofence mode -> (label, colour)
    0: ("pilot in control", "tab:blue"),
    1: ("geofence override", "tab:red"),
    2: ("handed back", "tab:cyan"),
    3: ("landing in a floor gap", "tab:purple"),
    4: ("terminating", "black"),
}


def _draw_fence(ax, fence, envelope, wind_en) -> None:
    """Keep-in, keep-outs, floor gaps and the activation boundary on an ENU ground-track axis."""
    from analysis.boundary import activation_field

    def outline(poly, **kw):
        v = np.vstack([poly.vertices, poly.vertices[:1]])
        ax.plot(v[:, 0], v[:, 1], **kw)

    outline(fence.keep_in, color="black", lw=2, label="keep-in fence")
    for i, k in enumerate(fence.keep_out_polygons):
        ax.fill(k.vertices[:, 0], k.vertices[:, 1], color="tab:red", alpha=0.25, label="keep-out" if i == 0 else None)
    for i, (ce, cn, r) in enumerate(fence.keep_out_circles):
        ax.add_patch(plt.Circle((ce, cn), r, color="tab:red", alpha=0.25, label="keep-out" if i == 0 and not fence.keep_out_polygons else None))
    for i, g in enumerate(fence.floor_gaps):
        ax.fill(g.vertices[:, 0], g.vertices[:, 1], color="tab:green", alpha=0.25, label="floor gap" if i == 0 else None)
    if envelope is not None:
        E, N, field = activation_field(fence, envelope, wind_en)
        ax.contour(E, N, field, levels=[0.0], colors="tab:orange", linestyles="--", linewidths=1.5)
        ax.plot([], [], color="tab:orange", ls="--", label="activation boundary (head-on, cruise)")
    re, rn = fence.recovery_en
    ax.plot(re, rn, marker="*", color="tab:orange", ms=12, ls="none", label="recovery point")


def _margin_panel(ax, traj: dict[str, np.ndarray], fence) -> None:
    """Margin vs time: the true 3-D margin to the fence and the unit's activation margin, override shaded."""
    from analysis.scoring import margins

    t = traj["time_s"]
    m = margins(traj, fence)
    ax.plot(t, m["total"], color="black", lw=1.2, label="margin to the fence (truth)")
    if "activation_margin_m" in traj and np.isfinite(traj["activation_margin_m"]).any():
        act = np.where(np.isfinite(traj["activation_margin_m"]), traj["activation_margin_m"], np.nan)
        ax.plot(t, act, color="tab:orange", lw=1.0, ls="--", label="activation margin (unit's estimate)")
    ax.axhline(0.0, color="tab:red", lw=1.0)
    override = traj.get("geofence_mode", np.zeros_like(t)) == 1
    ax.fill_between(t, 0, 1, where=override, color="tab:red", alpha=0.15, transform=ax.get_xaxis_transform())
    finite = m["total"][np.isfinite(m["total"])]
    if finite.size:
        top = float(np.percentile(finite, 95))
        ax.set_ylim(min(float(finite.min()), 0.0) - 0.05 * max(top, 1.0), top * 1.1 + 0.5)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("margin (m)")
    ax.legend(loc="upper right", fontsize="small")
    ax.grid(alpha=0.3)


def plot_flight(
    traj: dict[str, np.ndarray], out_path: Path, title: str, wind_note: str = "", fence=None, envelope=None
) -> list[Path]:
    """Ground track (ENU m) beside altitude and speed vs time; with a fence, its boundaries and the modes.

    Without a fence the track is coloured by time; with one, by geofence mode
    (override segments in red), over the keep-in fence, keep-outs, floor gaps
    and the activation boundary. Writes ``out_path`` with suffix .png and .svg;
    returns the paths written.
    """
    t, e, n = traj["time_s"], traj["east_m"], traj["north_m"]
    wind_title = ""
    fig = plt.figure(figsize=(12, 7.4 if fence is not None else 6.4), constrained_layout=True)
    rows = 3 if fence is not None else 2
    grid = fig.add_gridspec(rows, 2, width_ratios=[1.25, 1])
    ax = fig.add_subplot(grid[:, 0])
    if fence is not None:
        wind_en = (float(np.nanmean(traj.get("wind_east_mps", [0.0]))), float(np.nanmean(traj.get("wind_north_mps", [0.0]))))
        _draw_fence(ax, fence, envelope, wind_en)
        mode = traj.get("geofence_mode", np.zeros_like(t)).astype(int)
        for m, (label, colour) in MODE_STYLE.items():
            sel = mode == m
            if sel.any():
                ax.scatter(e[sel], n[sel], s=3, color=colour, label=label, zorder=3)
        points = None
    else:
        points = ax.scatter(e, n, c=t, s=2, cmap="viridis")
    ax.plot(e[0], n[0], marker="^", color="tab:green", ms=9, ls="none", label="start")
    ax.plot(e[-1], n[-1], marker="s", color="tab:red", ms=8, ls="none", label="end")
    if "wind_east_mps" in traj and np.nanmax(np.hypot(traj["wind_east_mps"], traj["wind_north_mps"])) > 0.1:
        we, wn = np.nanmean(traj["wind_east_mps"]), np.nanmean(traj["wind_north_mps"])
        ax.annotate(
            "", xy=(0.92, 0.92), xytext=(0.92 - 0.08 * we / np.hypot(we, wn), 0.92 - 0.08 * wn / np.hypot(we, wn)),
            xycoords="axes fraction", arrowprops={"arrowstyle": "-|>", "color": "tab:blue", "lw": 2},
        )
        wind_title = f" (mean wind {np.hypot(we, wn):.1f} m/s, from {np.degrees(np.arctan2(-we, -wn)) % 360:.0f}°, arrow: toward)"
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title("ground track" + wind_title, fontsize="medium")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=3, fontsize="small", frameon=False)
    if points is not None:
        fig.colorbar(points, ax=ax, label="time (s)", shrink=0.8)

    ax_alt = fig.add_subplot(grid[0, 1])
    ax_alt.plot(t, traj["agl_m"], color="tab:purple")
    if fence is not None and fence.altitude_reference == "agl":
        ax_alt.axhline(fence.ceiling_m, color="black", lw=1.5, label="ceiling")
        if fence.floor_m is not None:
            ax_alt.axhline(fence.floor_m, color="tab:green", lw=1.5, ls="--", label="floor (gaps excepted)")
        override = traj.get("geofence_mode", np.zeros_like(t)) == 1
        ax_alt.fill_between(t, 0, 1, where=override, color="tab:red", alpha=0.15, transform=ax_alt.get_xaxis_transform(), label="override")
        ax_alt.legend(loc="lower right", fontsize="small")
    ax_alt.set_ylabel("height AGL (m)")
    ax_alt.grid(alpha=0.3)
    ax_alt.set_title("altitude and speed")
    ax_spd = fig.add_subplot(grid[1, 1], sharex=ax_alt)
    ax_spd.plot(t, traj["ground_speed_mps"], label="ground speed")
    ax_spd.plot(t, traj["airspeed_mps"], label="airspeed", alpha=0.8)
    ax_spd.set_ylabel("speed (m/s)")
    ax_spd.legend(loc="upper right")
    ax_spd.grid(alpha=0.3)
    if fence is not None:
        _margin_panel(fig.add_subplot(grid[2, 1], sharex=ax_alt), traj, fence)
    else:
        ax_spd.set_xlabel("time (s)")
    fig.suptitle(title + (f" — {wind_note}" if wind_note else ""))
    written = []
    for suffix in (".png", ".svg"):
        path = Path(out_path).with_suffix(suffix)
        fig.savefig(path, dpi=110)
        written.append(path)
    plt.close(fig)
    return written


def plot_result(result, folder: Path) -> list[Path]:
    """``flight.png``/``.svg`` of a flown :class:`~scenarios.runner.FlightResult` into ``folder``."""
    rec = result.recorder
    traj = {name: rec.column(name) for name in rec.columns}
    sc = result.scenario
    return plot_flight(
        traj, Path(folder) / "flight", f"{sc.name} ({sc.aircraft})", fence=result.extras.get("fence"), envelope=sc.profile.envelope
    )
