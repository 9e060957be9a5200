"""Figures of the seed-flight reproduction, in the style of the seed paper's figures.

From :class:`scenarios.app.seed_reproduction.SeedAnalysis` objects (recorded arrays,
unit transitions, the attempt schedule): headless Agg, PNG + SVG.

* :func:`plot_xy_tracks`: x–y track near the corner of the fence, pilot vs
  override segments, the fence lines and the average-overshoot line per axis;
  reactive beside predictive.
* :func:`plot_time_histories`: x, y and height against time, pilot vs override
  segments coloured, boundaries solid, the ramped PD set-point dashed.
* :func:`plot_single_attempts`: the fastest attempt on each axis, zoomed, reactive
  above predictive (the seed paper's single-breach figures).
* :func:`plot_overshoot_vs_velocity`: peak excursion against the velocity at
  activation per axis, with least-squares lines and Pearson r.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from analysis.batch_plots import save_figure  # noqa: E402
from geofence.unit.geofence_unit import Mode  # noqa: E402

PILOT_COLOUR = "tab:blue"
OVERRIDE_COLOUR = "tab:red"
SETPOINT_COLOUR = "black"
FENCE_COLOUR = "black"
MEAN_COLOUR = "tab:orange"
AXIS_COLOUR = {"x": "tab:purple", "y": "tab:green", "ceiling": "tab:brown"}


def _layout_rect(fig, rect: tuple[float, float, float, float]) -> None:
    """Keep the constrained layout inside ``rect`` (figure fraction), leaving room for a figure legend."""
    engine: Any = fig.get_layout_engine()
    engine.set(rect=rect)


def _save(fig, out_dir: Path, stem: str) -> list[Path]:
    return save_figure(fig, Path(out_dir) / stem, dpi=120)


def _split_by_mode(t, y, mode):
    """(pilot, override) copies of ``y`` with the other segments NaN; override segments overlap one sample to join."""
    over = mode == Mode.OVERRIDE
    joined = over | np.concatenate([[False], over[:-1]]) | np.concatenate([over[1:], [False]])
    return np.where(~over, y, np.nan), np.where(joined, y, np.nan)


def _title(an) -> str:
    trig = "reactive fence (acts on the line)" if an.trigger == "reactive" else "predictive fence (acts on the shifted boundary)"
    law = "published PD law + 3 s ramp" if an.law == "seed_pd" else "velocity recovery law"
    return f"{trig}\n{law}"


# --------------------------------------------------------------------------- x–y track
def _xy_axis(ax, an, lim) -> None:
    tr, b = an.traj, an.boundaries
    mode = tr["geofence_mode"]
    pe, oe = _split_by_mode(tr["time_s"], tr["east_m"], mode)
    ax.plot(pe, tr["north_m"], color=PILOT_COLOUR, lw=0.9, label="pilot in control")
    ax.plot(oe, tr["north_m"], color=OVERRIDE_COLOUR, lw=0.9, label="geofence override")
    (x0, x1), (y0, y1) = lim
    ax.fill_between([x0, b.west_m], y0, y1, color="0.85", zorder=0)
    ax.fill_between([b.west_m, x1], b.north_m, y1, color="0.85", zorder=0, label="outside the fence")
    ax.plot([b.west_m, b.west_m], [y0, b.north_m], color=FENCE_COLOUR, lw=2.2, label="fence")
    ax.plot([b.west_m, x1], [b.north_m, b.north_m], color=FENCE_COLOUR, lw=2.2)
    sx, sy = an.stats["x"], an.stats["y"]
    if math.isfinite(sx["mean_m"]):
        xm = b.west_m - sx["mean_m"]
        ax.axvline(xm, color=MEAN_COLOUR, ls="--", lw=1.6, label="average peak excursion per axis")
        ax.annotate(
            f"x: {sx['mean_m']:+.2f} ± {sx['sd_m']:.2f} m",
            (xm, y0 + 0.04 * (y1 - y0)),
            xytext=(4, 0),
            textcoords="offset points",
            fontsize="small",
            color=MEAN_COLOUR,
            rotation=90,
            va="bottom",
        )
    if math.isfinite(sy["mean_m"]):
        ym = b.north_m + sy["mean_m"]
        ax.axhline(ym, color=MEAN_COLOUR, ls="--", lw=1.6)
        ax.annotate(
            f"y: {sy['mean_m']:+.2f} ± {sy['sd_m']:.2f} m",
            (x1 - 0.02 * (x1 - x0), ym),
            xytext=(0, 4),
            textcoords="offset points",
            fontsize="small",
            color=MEAN_COLOUR,
            ha="right",
        )
    ax.plot(0.0, 0.0, marker="^", color="tab:green", ms=10, ls="none", label="launch / recovery point")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x = east of launch (m)")
    ax.set_ylabel("y = north of launch (m)")
    ax.grid(alpha=0.3)
    ax.set_title(f"{an.name}: {_title(an)}", fontsize="medium")


def plot_xy_tracks(analyses: Sequence, out_dir: Path, stem: str = "seed_xy_tracks") -> list[Path]:
    """x–y tracks of the runs side by side (same limits), fence lines and average-overshoot lines."""
    b = analyses[0].boundaries
    e = np.concatenate([a.traj["east_m"] for a in analyses])
    n = np.concatenate([a.traj["north_m"] for a in analyses])
    pad = 0.25
    x0, x1 = min(np.nanmin(e), b.west_m) - pad, max(np.nanmax(e), 0.5) + pad
    y0, y1 = min(np.nanmin(n), -0.5) - pad, max(np.nanmax(n), b.north_m) + pad
    span = max(x1 - x0, y1 - y0)
    lim = ((x0, x0 + span), (y0, y0 + span))
    fig, axes = plt.subplots(1, len(analyses), figsize=(6.2 * len(analyses), 6.9), constrained_layout=True, squeeze=False)
    for ax, an in zip(axes[0], analyses):
        _xy_axis(ax, an, lim)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize="small", frameon=False, bbox_to_anchor=(0.5, -0.0))
    _layout_rect(fig, (0, 0.07, 1, 0.93))
    fig.suptitle(f"Seed flight tests reproduced: x–y track, {len(analyses[0].rows)} breach attempts (west, north, up)")
    return _save(fig, out_dir, stem)


# --------------------------------------------------------------------------- time histories
_HIST = (
    ("x", "east_m", "east_m", "x (m)"),
    ("y", "north_m", "north_m", "y (m)"),
    ("ceiling", "agl_m", "height_m", "height AGL (m)"),
)


def _boundary(an, axis) -> float:
    b = an.boundaries
    return {"x": b.west_m, "y": b.north_m, "ceiling": b.ceiling_m}[axis]


def _history_axes(axes, an, window=None, legend=True) -> None:
    tr = an.traj
    t, mode = tr["time_s"], tr["geofence_mode"]
    sel = np.ones_like(t, bool) if window is None else (t >= window[0]) & (t <= window[1])
    for ax, (axis, col, sp_col, label) in zip(axes, _HIST):
        y = tr[col]
        py, oy = _split_by_mode(t[sel], y[sel], mode[sel])
        ax.plot(t[sel], py, color=PILOT_COLOUR, lw=1.0, label="pilot in control")
        ax.plot(t[sel], oy, color=OVERRIDE_COLOUR, lw=1.2, label="geofence override")
        if an.setpoints is not None:
            ax.plot(t[sel], an.setpoints[sp_col][sel], color=SETPOINT_COLOUR, ls="--", lw=1.0, label="ramped set-point (3 s)")
        ax.axhline(_boundary(an, axis), color=FENCE_COLOUR, lw=1.8, label="fence line / ceiling")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    if legend:
        axes[0].legend(loc="upper right", fontsize="x-small", ncol=2)


def plot_time_histories(an, out_dir: Path, stem: str | None = None) -> list[Path]:
    """x, y and height against time for one run: pilot vs override coloured, set-point ramp dashed, boundaries."""
    fig, axes = plt.subplots(3, 1, figsize=(13, 8.6), sharex=True, constrained_layout=True)
    _history_axes(axes, an, legend=False)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize="small", frameon=False)
    _layout_rect(fig, (0, 0.04, 1, 0.96))
    t = an.traj["time_s"]
    for r in an.rows:  # attempt starts, labelled by direction
        for ax in axes:
            ax.axvline(r["t_start_s"], color="0.6", lw=0.6, ls=":")
        axes[0].annotate(
            r["direction"][0].upper(),
            (r["t_start_s"], 1.0),
            xycoords=("data", "axes fraction"),
            fontsize="x-small",
            ha="left",
            va="bottom",
            color="0.35",
        )
    axes[-1].set_xlabel("time (s)   [dotted: attempt starts, W = west, N = north, U = up]")
    axes[-1].set_xlim(t[0], t[-1])
    fig.suptitle(f"{an.name}: per-axis time histories — {_title(an).replace(chr(10), ', ')}")
    return _save(fig, out_dir, stem or f"seed_time_histories_{an.name}")


def _fastest_attempt(an, axis):
    rows = [r for r in an.rows if r["axis"] == axis]
    return max(rows, key=lambda r: r["speed_cmd_mps"]) if rows else None


def plot_single_attempts(
    analyses: Sequence, out_dir: Path, stem: str = "seed_single_attempts", span_s: float = 9.0
) -> list[Path]:
    """The fastest attempt on each axis, zoomed (columns), one row per run: the axis's coordinate against time."""
    fig, axes = plt.subplots(len(analyses), 3, figsize=(14, 3.4 * len(analyses) + 0.6), constrained_layout=True, squeeze=False)
    for i, an in enumerate(analyses):
        t, mode = an.traj["time_s"], an.traj["geofence_mode"]
        for j, (axis, col, sp_col, label) in enumerate(_HIST):
            ax = axes[i][j]
            r = _fastest_attempt(an, axis)
            if r is None:
                ax.set_visible(False)
                continue
            t0 = r["t_start_s"] - 0.5
            later = [q["t_start_s"] for q in an.rows if q["t_start_s"] > r["t_start_s"]]
            t_end = min(t0 + span_s, min(later) if later else math.inf)
            sel = (t >= t0) & (t <= t_end)
            py, oy = _split_by_mode(t[sel], an.traj[col][sel], mode[sel])
            ax.plot(t[sel] - t0, py, color=PILOT_COLOUR, lw=1.4, label="pilot in control")
            ax.plot(t[sel] - t0, oy, color=OVERRIDE_COLOUR, lw=1.6, label="geofence override")
            if an.setpoints is not None:
                ax.plot(t[sel] - t0, an.setpoints[sp_col][sel], color=SETPOINT_COLOUR, ls="--", lw=1.2, label="ramped set-point")
            ax.axhline(_boundary(an, axis), color=FENCE_COLOUR, lw=1.8, label="fence line / ceiling")
            ax.set_title(
                f"{an.name} ({an.trigger}): {r['direction']} at {r['speed_cmd_mps']:.2f} m/s\npeak excursion {r['peak_m']:+.2f} m"
                + (f", v at activation {r['v_activation_mps']:.2f} m/s" if math.isfinite(r["v_activation_mps"]) else ""),
                fontsize="small",
            )
            ax.set_ylabel(label)
            ax.set_xlabel("time from attempt start (s)")
            ax.set_xlim(0.0, span_s)
            ax.grid(alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize="small", frameon=False)
    _layout_rect(fig, (0, 0.05, 1, 0.95))
    fig.suptitle("The fastest attempt on each axis: reactive (top) vs predictive (bottom)")
    return _save(fig, out_dir, stem)


# --------------------------------------------------------------------------- overshoot vs velocity
def plot_overshoot_vs_velocity(analyses: Sequence, out_dir: Path, stem: str = "seed_overshoot_vs_velocity") -> list[Path]:
    """Peak excursion per attempt against velocity toward the boundary at activation, per axis; one panel per run."""
    fig, axes = plt.subplots(
        1, len(analyses), figsize=(6.2 * len(analyses), 4.8), constrained_layout=True, sharey=True, squeeze=False
    )
    for ax, an in zip(axes[0], analyses):
        for axis in ("x", "y", "ceiling"):
            rows = [r for r in an.rows if r["axis"] == axis]
            v = np.array([r["v_activation_mps"] for r in rows], float)
            p = np.array([r["peak_m"] for r in rows], float)
            ok = np.isfinite(v) & np.isfinite(p)
            s = an.stats[axis]
            lab = f"{axis}: r = {s['r_overshoot_velocity']:+.2f}" if math.isfinite(s["r_overshoot_velocity"]) else f"{axis}"
            ax.scatter(v[ok], p[ok], color=AXIS_COLOUR[axis], s=28, label=lab, zorder=3)
            if ok.sum() >= 3 and np.std(v[ok]) > 0:
                k, c = np.polyfit(v[ok], p[ok], 1)
                vv = np.linspace(v[ok].min(), v[ok].max(), 2)
                ax.plot(vv, k * vv + c, color=AXIS_COLOUR[axis], lw=1.2, alpha=0.8)
        ax.axhline(0.0, color=FENCE_COLOUR, lw=1.5)
        ax.text(0.01, 0.0, " fence / ceiling", transform=ax.get_yaxis_transform(), va="bottom", fontsize="small")
        ax.set_xlabel("velocity toward the boundary at activation (m/s)")
        ax.set_title(f"{an.name}: {_title(an)}", fontsize="medium")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize="small")
    axes[0][0].set_ylabel("peak excursion beyond the boundary (m)\n(≤ 0: stayed inside)")
    fig.suptitle("Overshoot grows with the speed at activation behind a reactive fence")
    return _save(fig, out_dir, stem)


def plot_all(reactive, predictive, out_dir: Path) -> list[Path]:
    """Every figure of the reproduction into ``out_dir``; returns the paths written."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    paths += plot_xy_tracks([reactive, predictive], out_dir)
    paths += plot_time_histories(reactive, out_dir)
    paths += plot_time_histories(predictive, out_dir)
    paths += plot_single_attempts([reactive, predictive], out_dir)
    paths += plot_overshoot_vs_velocity([reactive, predictive], out_dir)
    return paths
