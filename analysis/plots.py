"""Figures of recorded flights (matplotlib, headless Agg backend, PNG and SVG).

Works on recorded arrays only (``trajectory.csv`` columns, see
:mod:`scenarios.flight.recorder`), so the same plots serve simulations and logs.

With a fence, :func:`plot_flight` draws what the geofence unit computed along
the flight:

* the ground track coloured by the unit's recorded activation margin
  (``activation_margin_m``; grey where the unit did not compute it), the
  activations (where it reached 0) and hand-backs marked, and, for a
  predictive unit (the one that uses it), the activation boundary for the
  speed and wind recorded at each activation (keep-in edges, keep-out polygons
  and circles, see :mod:`analysis.boundary`); a reactive unit acts on the fence
  line itself, so none is drawn;
* the keep-in fence, keep-outs, floor gaps, the recovery point (on top,
  labelled) and, for missions, the waypoints with their acceptance circles;
* the mean wind measured at the vehicle (arrow above the track, outside the
  data) beside the scenario's wind (at its reference height: the two differ
  with the height profile, turbulence and gusts);
* against time: height with ceiling and floor, speed, the lateral margin (to
  the keep-in edge and to the nearest keep-out, apart), the ceiling and floor
  margins (none drawn over a floor gap, where no floor applies), and the unit's
  activation margin, each with the
  geofence phases (:class:`geofence.unit.geofence_unit.Mode`) shaded and the GPS failure
  marked.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

from geofence.geometry.fence import AltitudeReference

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.artist import Artist  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.colors import TwoSlopeNorm  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from geofence.unit.geofence_unit import Mode  # noqa: E402

MODE_STYLE = {  # geofence mode -> (label, colour); MONITOR is not shaded on the time axes
    Mode.MONITOR: ("pilot in control", "tab:blue"),
    Mode.OVERRIDE: ("geofence override", "tab:red"),
    Mode.RECOVERED: ("handed back", "tab:cyan"),
    Mode.LAND_IN_GAP: ("landing in a floor gap", "tab:purple"),
    Mode.TERMINATE: ("terminating", "black"),
}
PHASE_ALPHA = 0.15
LEGEND_OUTSIDE: dict[str, Any] = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "fontsize": "small", "borderaxespad": 0.0}
MARGIN_CMAP = "RdYlGn"
NOT_COMPUTED_COLOUR = "0.72"
BOUNDARY_COLOURS = ("tab:orange", "darkorange", "gold", "peru")
MAX_BOUNDARIES = 3


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the True runs of a boolean array (stop exclusive)."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return list(zip(d[::2], d[1::2]))


def _modes(traj: dict[str, np.ndarray]) -> np.ndarray:
    t = traj["time_s"]
    m = np.asarray(traj.get("geofence_mode", np.zeros_like(t)), dtype=float)
    return np.where(np.isfinite(m), m, Mode.MONITOR).astype(int)


def _activation_margin(traj: dict[str, np.ndarray]) -> np.ndarray:
    """The recorded activation margin, NaN where the unit did not compute it.

    Non-finite values (not yet computed, minimum override) and the landing
    phases (LAND_IN_GAP, TERMINATE: the unit no longer computes margins, the
    column holds the last value) are NaN.
    """
    t = traj["time_s"]
    act = np.asarray(traj.get("activation_margin_m", np.full_like(t, np.nan)), dtype=float)
    m = _modes(traj)
    landing = (m == Mode.LAND_IN_GAP) | (m == Mode.TERMINATE)
    return np.where(np.isfinite(act) & ~landing, act, np.nan)


def _events(traj: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Indices of activations (MONITOR/RECOVERED -> OVERRIDE) and of hand-backs (OVERRIDE -> RECOVERED)."""
    m = _modes(traj)
    prev, cur = m[:-1], m[1:]
    act = np.flatnonzero(((prev == Mode.MONITOR) | (prev == Mode.RECOVERED)) & (cur == Mode.OVERRIDE)) + 1
    hand = np.flatnonzero((prev == Mode.OVERRIDE) & (cur == Mode.RECOVERED)) + 1
    if len(m) and m[0] == Mode.OVERRIDE:
        act = np.concatenate([[0], act])
    return act, hand


def _shade_phases(ax, traj, gps_fail_at_s: float | None, gps_outages: Sequence[tuple[float, float]] = ()) -> None:
    """Shade the non-MONITOR geofence phases and mark the GPS failure on a time axis."""
    t = traj["time_s"]
    m = _modes(traj)
    for mode, (_, colour) in MODE_STYLE.items():
        if mode is Mode.MONITOR:
            continue
        for a, b in _runs(m == mode):
            t1 = t[b] if b < len(t) else t[-1]
            ax.axvspan(t[a], t1, color=colour, alpha=PHASE_ALPHA if mode is not Mode.TERMINATE else 0.25, lw=0, zorder=0)
    if gps_fail_at_s is not None and np.isfinite(gps_fail_at_s):
        ax.axvline(gps_fail_at_s, color="black", ls=":", lw=1.6, zorder=5)
    for t0, t1 in gps_outages:
        ax.axvspan(t0, t1, facecolor="none", edgecolor="0.3", hatch="//", lw=0, zorder=0)


def _phase_handles(traj, gps_fail_at_s, gps_outages) -> list:
    m = _modes(traj)
    handles: list[Artist] = []
    for mode, (label, colour) in MODE_STYLE.items():
        if mode is not Mode.MONITOR and (m == mode).any():
            handles.append(Patch(color=colour, alpha=PHASE_ALPHA * 2, label=f"{mode.name}: {label}"))
    if gps_fail_at_s is not None and np.isfinite(gps_fail_at_s):
        handles.append(Line2D([], [], color="black", ls=":", lw=1.6, label=f"GPS lost (t = {gps_fail_at_s:g} s)"))
    if len(gps_outages):
        handles.append(Patch(facecolor="none", edgecolor="0.3", hatch="//", label="GPS outage"))
    return handles


def _ylim_from(ax, *series: np.ndarray, include: Sequence[float] = (), pad: float = 0.06) -> None:
    """Y-limits covering every finite value of the series (and ``include``), padded: nothing clips."""
    vals = [np.asarray(s, dtype=float)[np.isfinite(s)] for s in series]
    vals = [v for v in vals if v.size] + [np.asarray(include, dtype=float)]
    allv = np.concatenate(vals) if vals else np.array([])
    if not allv.size:
        return
    lo, hi = float(allv.min()), float(allv.max())
    span = max(hi - lo, 1.0)
    ax.set_ylim(lo - pad * span, hi + pad * span)


def _draw_fence(ax, fence) -> None:
    """Keep-in, keep-outs and floor gaps on an ENU ground-track axis."""

    def outline(poly, **kw):
        v = np.vstack([poly.vertices, poly.vertices[:1]])
        ax.plot(v[:, 0], v[:, 1], **kw)

    outline(fence.keep_in, color="black", lw=2, label="keep-in fence", zorder=2)
    n_ko = 0
    for k in fence.keep_out_polygons:
        ax.fill(
            k.vertices[:, 0], k.vertices[:, 1], color="tab:red", alpha=0.25, label="keep-out" if n_ko == 0 else None, zorder=1
        )
        n_ko += 1
    for ce, cn, r in fence.keep_out_circles:
        ax.add_patch(plt.Circle((ce, cn), r, color="tab:red", alpha=0.25, label="keep-out" if n_ko == 0 else None, zorder=1))
        n_ko += 1
    for i, g in enumerate(fence.floor_gaps):
        ax.fill(
            g.vertices[:, 0], g.vertices[:, 1], color="tab:green", alpha=0.25, label="floor gap" if i == 0 else None, zorder=1
        )


def _activation_boundaries(ax, traj, fence, envelope, act_idx: np.ndarray) -> None:
    """The activation boundary for the speed and wind recorded at (up to MAX_BOUNDARIES distinct) activations."""
    from analysis.boundary import activation_field

    if envelope is None or not len(act_idx):
        return
    speed_col = "ground_speed_mps" if envelope.is_multirotor else "airspeed_mps"
    we = traj.get("est_wind_east_mps", traj.get("wind_east_mps"))
    wn = traj.get("est_wind_north_mps", traj.get("wind_north_mps"))
    chosen, seen = [], set()
    for i in act_idx:
        v = float(traj[speed_col][i])
        w = (
            float(we[i]) if we is not None and np.isfinite(we[i]) else 0.0,
            float(wn[i]) if wn is not None and np.isfinite(wn[i]) else 0.0,
        )
        key = (round(v / 2.0), round(w[0] / 2.0), round(w[1] / 2.0))  # within 2 m/s: the same picture
        if key in seen:
            continue
        seen.add(key)
        chosen.append((i, v, w))
        if len(chosen) == MAX_BOUNDARIES:
            break
    n_act = len(act_idx)
    what = "airspeed" if not envelope.is_multirotor else "ground speed"
    for j, (i, v, w) in enumerate(chosen):
        E, N, field = activation_field(fence, envelope, w, speed_mps=v)
        colour = BOUNDARY_COLOURS[j % len(BOUNDARY_COLOURS)]
        ls = ("--", "-.", ":")[j % 3]
        ax.contour(E, N, field, levels=[0.0], colors=colour, linestyles=ls, linewidths=1.5, zorder=2)
        label = (
            f"activation boundary (head-on) at t = {traj['time_s'][i]:.1f} s\n({what} {v:.0f} m/s, "
            f"unit's wind estimate {np.hypot(*w):.0f} m/s)"
        )
        ax.plot([], [], color=colour, ls=ls, lw=1.5, label=label)
    if n_act > len(chosen):
        ax.plot([], [], ls="none", label=f"(+{n_act - len(chosen)} activations at a similar\nspeed and wind: same boundary)")


def _wind_title(ax, traj, scenario_wind) -> str:
    """The wind arrow (above the track's top right corner, off the data) and the title lines naming both winds."""
    cfg_text = _scenario_wind_text(scenario_wind)
    if "wind_east_mps" not in traj or not np.nanmax(np.hypot(traj["wind_east_mps"], traj["wind_north_mps"])) > 0.1:
        return f"\nscenario wind: {cfg_text}" if cfg_text else ""
    we, wn = np.nanmean(traj["wind_east_mps"]), np.nanmean(traj["wind_north_mps"])
    speed = float(np.hypot(we, wn))
    u = np.array([we, wn]) / speed
    centre = np.array([0.95, 1.07])  # axes fraction: right of the (left-aligned) title, above the frame
    ax.annotate(
        "",
        xy=tuple(centre + 0.035 * u),
        xytext=tuple(centre - 0.035 * u),
        xycoords="axes fraction",
        arrowprops={"arrowstyle": "-|>", "color": "tab:blue", "lw": 2},
        annotation_clip=False,
        zorder=10,
    )
    from_deg = np.degrees(np.arctan2(-we, -wn)) % 360
    title = f"\nwind measured at the vehicle (mean, arrow): {speed:.1f} m/s from {from_deg:.0f}°"
    return title + (f"\nscenario wind: {cfg_text}" if cfg_text else "")


def _scenario_wind_text(cfg) -> str:
    """The scenario's wind in words: speed, direction, the height it is given at, and what it adds."""
    if cfg is None:
        return ""
    text = f"{cfg.speed_mps:g} m/s from {cfg.from_deg:g}°"
    profile = cfg.profile
    if profile is not None and profile.law != "uniform":
        text += f" at {profile.reference_height_m:g} m AGL ({profile.law} law)"
    extras = []
    if cfg.turbulence is not None and cfg.turbulence.resolved_w20_mps > 0.0:
        extras.append("turbulence")
    if cfg.gusts or (cfg.random_gusts is not None and cfg.random_gusts.count):
        extras.append("gusts")
    return text + (f" + {', '.join(extras)}" if extras else "")


def _track_by_margin(ax, fig, traj) -> None:
    """Ground track as a line coloured by the unit's activation margin; grey where not computed."""
    e, n = traj["east_m"], traj["north_m"]
    act = _activation_margin(traj)
    pts = np.column_stack([e, n])
    segs = np.stack([pts[:-1], pts[1:]], axis=1)
    seg_val = act[1:]
    finite = np.isfinite(seg_val)
    ax.add_collection(LineCollection(segs[~finite], colors=NOT_COMPUTED_COLOUR, linewidths=1.6, zorder=3))
    if finite.any():
        vals = seg_val[finite]
        vmax = max(float(np.percentile(vals, 98)), 1.0)
        vmin = min(float(vals.min()), -0.05 * vmax)
        lc = LineCollection(
            segs[finite],
            array=np.clip(vals, vmin, vmax),
            cmap=MARGIN_CMAP,
            norm=TwoSlopeNorm(vmin=vmin, vcenter=0.0, vmax=vmax),
            linewidths=2.2,
            zorder=4,
        )
        ax.add_collection(lc)
        cb = fig.colorbar(lc, ax=ax, shrink=0.45, fraction=0.04, pad=0.01, location="right")
        cb.set_label("unit's activation margin (m); 0 = activates")
    ax.plot([], [], color=NOT_COMPUTED_COLOUR, lw=1.6, label="track where the unit computed no margin")


def _mode_track(ax, traj) -> None:
    e, n = traj["east_m"], traj["north_m"]
    mode = _modes(traj)
    for m, (label, colour) in MODE_STYLE.items():
        sel = mode == m
        if sel.any():
            ax.scatter(e[sel], n[sel], s=3, color=colour, label=label, zorder=3)


def plot_flight(
    traj: dict[str, np.ndarray], out_path: Path, title: str, wind_note: str = "", fence=None, envelope=None, **kw
) -> list[Path]:
    """:func:`flight_figure` written to ``out_path`` .png and .svg; returns the paths written."""
    fig = flight_figure(traj, title, wind_note, fence, envelope, **kw)
    written = []
    for suffix in (".png", ".svg"):
        path = Path(out_path).with_suffix(suffix)
        fig.savefig(path, dpi=100)
        written.append(path)
    plt.close(fig)
    return written


def flight_figure(
    traj: dict[str, np.ndarray],
    title: str,
    wind_note: str = "",
    fence=None,
    envelope=None,
    *,
    gps_fail_at_s: float | None = None,
    gps_outages: Sequence[tuple[float, float]] = (),
    waypoints_en: Sequence[tuple[float, float]] | None = None,
    acceptance_radius_m: float | None = None,
    trigger: str | None = None,
    scenario_wind=None,
):
    """The figure of a flight: ground track (ENU m) beside height, speed and margins vs time (open; the caller
    saves and closes it).

    Without a fence the track is coloured by time. With one (a
    :class:`~geofence.geometry.local_fence.LocalFence`; ``envelope`` the platform's
    :class:`~geofence.interface.Envelope`), see the module docstring.
    ``gps_fail_at_s`` (the scenario's ``sensors.gps_fail_at_s``) and
    ``gps_outages`` mark the GPS failure; ``waypoints_en`` (ENU m) and
    ``acceptance_radius_m`` draw a mission's waypoints; ``trigger`` (the unit's, ``"predictive"``
    by default) whether an activation boundary is drawn; ``scenario_wind`` (a
    :class:`~wind.config.WindConfig`) is named beside the measured mean wind.
    """
    t, e, n = traj["time_s"], traj["east_m"], traj["north_m"]
    has_fence = fence is not None
    n_time = 5 if has_fence else 2
    fig = plt.figure(figsize=(16, 12.5 if has_fence else 6.4), layout="constrained")
    grid = fig.add_gridspec(n_time, 2, width_ratios=[1.35, 1])
    ax = fig.add_subplot(grid[:, 0])
    act_idx, hand_idx = _events(traj) if has_fence else (np.array([], int), np.array([], int))
    if has_fence:
        _draw_fence(ax, fence)
        if "activation_margin_m" in traj:
            _track_by_margin(ax, fig, traj)
            over = _modes(traj) == Mode.OVERRIDE
            for a, b in _runs(over):
                ax.plot(e[a : b + 1], n[a : b + 1], color="tab:red", lw=6, alpha=0.25, solid_capstyle="round", zorder=2)
            if over.any():
                ax.plot([], [], color="tab:red", lw=6, alpha=0.25, label="geofence override (under the track)")
        else:
            _mode_track(ax, traj)
        if trigger != "reactive":  # a reactive unit acts on the fence line: it has no activation boundary
            _activation_boundaries(ax, traj, fence, envelope, act_idx)
        points = None
    else:
        points = ax.scatter(e, n, c=t, s=2, cmap="viridis")
    if waypoints_en is not None and len(waypoints_en):
        wp = np.asarray(waypoints_en, dtype=float)
        ax.plot(wp[:, 0], wp[:, 1], color="0.4", lw=0.8, ls=(0, (4, 3)), zorder=2)
        for k, (we_, wn_) in enumerate(wp):
            if acceptance_radius_m:
                ax.add_patch(plt.Circle((we_, wn_), acceptance_radius_m, fill=False, ec="0.3", lw=0.9, ls="--", zorder=2))
            ax.annotate(
                f"{k + 1}", (we_, wn_), xytext=(5, 5), textcoords="offset points", fontsize="small", color="0.2", zorder=6
            )
        ax.plot(
            wp[:, 0],
            wp[:, 1],
            marker="D",
            color="0.3",
            ms=5,
            ls="none",
            zorder=5,
            label="mission waypoints" + (f" (acceptance circle {acceptance_radius_m:g} m)" if acceptance_radius_m else ""),
        )
    # start and end above the recovery point (a flight often starts on it); the end hollow, under the start, so a
    # flight that lands where it took off shows both
    ax.plot(e[-1], n[-1], marker="s", mfc="none", mec="tab:red", mew=2, ms=12, ls="none", label="end", zorder=11)
    ax.plot(e[0], n[0], marker="^", color="tab:green", mec="black", ms=9, ls="none", label="start", zorder=12)
    if len(act_idx):
        ax.plot(
            e[act_idx],
            n[act_idx],
            marker="X",
            color="tab:red",
            mec="black",
            ms=9,
            ls="none",
            zorder=8,
            label=f"activation: margin reached 0 ({len(act_idx)})",
        )
    if len(hand_idx):
        ax.plot(
            e[hand_idx],
            n[hand_idx],
            marker="o",
            color="tab:cyan",
            mec="black",
            ms=6,
            ls="none",
            zorder=8,
            label=f"hand-back to the pilot ({len(hand_idx)})",
        )
    if has_fence:
        re, rn = fence.recovery_en
        ax.plot(re, rn, marker="*", color="gold", mec="black", mew=1.2, ms=18, ls="none", zorder=10, label="recovery point")
        ax.annotate(
            "recovery point",
            (re, rn),
            xytext=(10, -14),
            textcoords="offset points",
            fontsize="small",
            fontweight="bold",
            zorder=10,
            bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.5", "alpha": 0.85},
        )
    wind_title = _wind_title(ax, traj, scenario_wind)
    xs = [e[np.isfinite(e)]] + ([fence.keep_in.vertices[:, 0]] if has_fence else [])
    ys = [n[np.isfinite(n)]] + ([fence.keep_in.vertices[:, 1]] if has_fence else [])
    if waypoints_en is not None and len(waypoints_en):
        xs.append(np.asarray(waypoints_en, dtype=float)[:, 0])
        ys.append(np.asarray(waypoints_en, dtype=float)[:, 1])
    x0, x1 = float(np.min([a.min() for a in xs])), float(np.max([a.max() for a in xs]))
    y0, y1 = float(np.min([a.min() for a in ys])), float(np.max([a.max() for a in ys]))
    pad = 0.06 * max(x1 - x0, y1 - y0, 1.0)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title("ground track" + wind_title, fontsize="small", loc="left")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.07), ncol=2, fontsize="small", frameon=False)
    if points is not None:
        fig.colorbar(points, ax=ax, label="time (s)", shrink=0.8)

    time_axes = []
    ax_alt = fig.add_subplot(grid[0, 1])
    time_axes.append(ax_alt)
    ax_alt.plot(t, traj["agl_m"], color="tab:purple", label="height AGL")
    include = [0.0]
    if has_fence and fence.altitude_reference is AltitudeReference.AGL:
        ax_alt.axhline(fence.ceiling_m, color="black", lw=1.5, label="ceiling")
        include.append(fence.ceiling_m)
        if fence.floor_m is not None:
            ax_alt.axhline(fence.floor_m, color="tab:green", lw=1.5, ls="--", label="floor (gaps excepted)")
    _ylim_from(ax_alt, traj["agl_m"], include=include)
    ax_alt.set_ylabel("height AGL (m)")
    ax_alt.set_title("height, speed and margins (shaded: geofence phase)" if has_fence else "height and speed", fontsize="medium")
    ax_spd = fig.add_subplot(grid[1, 1], sharex=ax_alt)
    time_axes.append(ax_spd)
    ax_spd.plot(t, traj["ground_speed_mps"], label="ground speed")
    ax_spd.plot(t, traj["airspeed_mps"], label="airspeed", alpha=0.8)
    _ylim_from(ax_spd, traj["ground_speed_mps"], traj["airspeed_mps"], include=[0.0])
    ax_spd.set_ylabel("speed (m/s)")
    if has_fence:
        time_axes += _margin_panels(fig, grid, ax_alt, traj, fence)
    for tax in time_axes:
        if has_fence:
            _shade_phases(tax, traj, gps_fail_at_s, gps_outages)
        tax.grid(alpha=0.3)
        if tax.get_legend_handles_labels()[0]:
            tax.legend(**LEGEND_OUTSIDE)
        if tax is not time_axes[-1]:
            tax.tick_params(labelbottom=False)
    time_axes[-1].set_xlabel("time (s)")
    time_axes[-1].set_xlim(t[0], t[-1])
    if has_fence:
        handles = _phase_handles(traj, gps_fail_at_s, gps_outages)
        if handles:  # the phase key under the time axes, outside the data
            time_axes[-1].legend(handles=handles + time_axes[-1].get_legend_handles_labels()[0], **LEGEND_OUTSIDE)
    fig.suptitle(title + (f" — {wind_note}" if wind_note else ""))
    return fig


def _margin_panels(fig, grid, ax_alt, traj, fence) -> list:
    """Lateral margin, ceiling and floor margins, and the unit's activation margin vs time (m, + inside)."""
    from analysis.scoring import margins

    t = traj["time_s"]
    m = margins(traj, fence)
    ax_lat = fig.add_subplot(grid[2, 1], sharex=ax_alt)
    lat = fence.keep_in.signed_distance_array(np.column_stack([traj["east_m"], traj["north_m"]]))
    ax_lat.plot(t, lat, color="black", lw=1.2, label="to the keep-in edge (truth)")
    series = [lat]
    if fence.keep_out_polygons or fence.keep_out_circles:
        ko = np.where(np.isfinite(m["keep_out"]), m["keep_out"], np.nan)
        ax_lat.plot(t, ko, color="tab:red", lw=1.2, label="to the nearest keep-out (truth)")
        series.append(ko)
    ax_lat.axhline(0.0, color="tab:red", lw=1.0, ls="-")
    _ylim_from(ax_lat, *series, include=[0.0])
    ax_lat.set_ylabel("lateral margin (m)")

    ax_v = fig.add_subplot(grid[3, 1], sharex=ax_alt)
    ax_v.plot(t, m["ceiling"], color="tab:brown", lw=1.2, label="below the ceiling (truth)")
    series = [m["ceiling"]]
    if fence.floor_m is not None:
        over_gap = fence.in_floor_gap_array(np.column_stack([traj["east_m"], traj["north_m"]]))
        fl = np.where(np.isfinite(m["floor"]) & ~over_gap, m["floor"], np.nan)
        ax_v.plot(t, fl, color="tab:green", lw=1.2, label="above the floor (truth;\nno line: over a floor gap)")
        series.append(fl)
    ax_v.axhline(0.0, color="tab:red", lw=1.0)
    _ylim_from(ax_v, *series, include=[0.0])
    ax_v.set_ylabel("vertical margin (m)")

    ax_a = fig.add_subplot(grid[4, 1], sharex=ax_alt)
    act = _activation_margin(traj)
    ax_a.plot(
        t,
        act,
        color="tab:orange",
        lw=1.2,
        label="unit's activation margin\n(smaller of lateral, vertical;\nno line: not computed)",
    )
    ax_a.axhline(0.0, color="tab:red", lw=1.0)
    act_idx, _ = _events(traj)
    if len(act_idx):
        ax_a.plot(
            t[act_idx],
            np.zeros(len(act_idx)),
            marker="X",
            color="tab:red",
            mec="black",
            ms=7,
            ls="none",
            label="activation",
            zorder=6,
        )
    _ylim_from(ax_a, act, include=[0.0])
    ax_a.set_ylabel("activation\nmargin (m)")
    return [ax_lat, ax_v, ax_a]


def plot_result(result, folder: Path) -> list[Path]:
    """``flight.png``/``.svg`` of a flown :class:`~scenarios.flight.runner.FlightResult` into ``folder``."""
    rec = result.recorder
    traj = {name: rec.column(name) for name in rec.columns}
    sc = result.scenario
    return plot_flight(
        traj,
        Path(folder) / "flight",
        f"{sc.name} ({sc.aircraft})",
        fence=result.fence,
        envelope=sc.profile.envelope,
        **scenario_plot_kwargs(sc),
    )


def scenario_plot_kwargs(sc) -> dict:
    """The optional :func:`plot_flight` arguments a scenario provides: GPS failure, outages, waypoints,
    the unit's trigger and the scenario's wind.

    For callers that re-plot saved flights (``geofence-testbed plot``) from ``scenario.yaml``.
    """
    from geofence.geometry.geodesy import LocalFrame

    kw: dict = {"scenario_wind": getattr(sc, "wind", None)}
    geofence = getattr(sc, "geofence", None)
    if geofence is not None:
        kw["trigger"] = str(geofence.trigger)
    sensors = getattr(sc, "sensors", None)
    if sensors is not None:
        kw["gps_fail_at_s"] = sensors.gps_fail_at_s
        kw["gps_outages"] = tuple(sensors.gps_outages)
    mission = getattr(sc, "mission", None)
    if mission is not None:
        st = sc.start
        frame = LocalFrame(st.lat_deg, st.lon_deg, st.ground_alt_m)
        wps = [
            frame.to_enu(it.lat_deg, it.lon_deg, st.ground_alt_m)[:2]
            for it in mission.items
            if it.lat_deg is not None and it.lon_deg is not None
        ]
        if wps:
            kw["waypoints_en"] = wps
            kw["acceptance_radius_m"] = mission.acceptance_radius_m
    return kw
