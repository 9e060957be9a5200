"""Breach scoring of recorded flights against a fence (vectorized, numpy only).

Input: named trajectory columns (as in ``trajectory.csv``: ``time_s``,
``east_m``, ``north_m``, ``agl_m`` or ``alt_m``, optional ``geofence_mode``,
``v_east_mps``, ``v_north_mps``, ``ground_speed_mps``) and a
:class:`~geofence.geometry.local_fence.LocalFence` in the same ENU frame. Output: a flat dict
of scores, all in SI units:

* ``max_excursion_m``: the farthest the vehicle got beyond the fence, lateral
  or vertical (<= 0: never outside; then it is minus the closest approach);
* ``max_lateral_excursion_m``, ``max_vertical_excursion_m``: the same per axis;
* ``max_ceiling_excursion_m``: the vertical one above the ceiling alone (below a floor outside its gaps left out);
* ``min_margin_m``: the smallest 3-D margin (+ inside);
* ``time_outside_s``: total time with a negative margin (each sample counts
  for the interval to the next sample; the last sample counts 0 s);
* ``activations``: entries into OVERRIDE (from the recorded mode column);
* ``breached_keep_out``: any sample inside a keep-out zone's volume: inside it
  laterally *and* between its own floor and ceiling when it has them
  (:class:`~geofence.geometry.fence.VerticalExtent`; passing over a building's roof or
  under an airspace shelf is no entry). The same volumetric keep-out margin
  enters the lateral and 3-D margins below, so such a pass is no excursion
  either. (The geofence unit itself treats every keep-out as full-height.)
* ``landed_outside_gap``: the flight ended on the ground (``agl_m`` < 0.5 m)
  where landing is not allowed (outside the fence, or below the floor outside
  every gap);
* ``time_to_peak_excursion_s``: from the first activation (first OVERRIDE
  sample) to the sample of smallest 3-D margin at or after it;
* ``time_to_handback_s``: mean over activations of the time from entering
  OVERRIDE to the next sample in RECOVERED or MONITOR (activations that end in
  LAND_IN_GAP, TERMINATE or the end of the record are left out);
* ``ground_speed_at_activation_mps``: ground speed at the first activation;
* ``approach_angle_at_activation_deg``: angle between the ground velocity and
  the outward normal of the nearest keep-in edge at the first activation
  (0 = flying straight out, 90 = along the edge, 180 = straight in);
* ``touchdown_vertical_mps``, ``touchdown_horizontal_mps``: the largest descent rate and ground speed in the
  :data:`TOUCHDOWN_WINDOW_S` before the final touchdown (:func:`touchdown_index`: the first sample within
  :data:`TOUCHDOWN_GEAR_TRAVEL_M` of the resting height after the vehicle was last above it by
  :data:`ON_GROUND_AGL_M`); NaN when the flight does not end on the ground (``agl_m`` < :data:`ON_GROUND_AGL_M`).

The last four are NaN when there was no activation (and
``time_to_handback_s`` when no activation was handed back; the angle when the
vehicle was not moving). Velocities come from ``v_east_mps``/``v_north_mps``
when recorded, else from central differences of the position.

:func:`score_flight` scores one flight; :func:`score_many` scores many in one
vectorized pass (the margins dominate; they come from
:mod:`analysis.fast_margins`, chunked and threaded).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from analysis.fast_margins import fence_margins
from geofence.geometry.fence import AltitudeReference
from geofence.geometry.local_fence import LocalFence

MONITOR_MODE = 0
OVERRIDE_MODE = 1
RECOVERED_MODE = 2
ON_GROUND_AGL_M = 0.5
TOUCHDOWN_WINDOW_S = 0.3
"""The fraction of a second before the touchdown whose speeds are the touchdown speeds (s)."""
TOUCHDOWN_GEAR_TRAVEL_M = 0.2
"""A sample this close above the flight's resting height (its last ``agl_m``) has its gear on the ground (m): a
landing gear compresses by up to about this much between its first contact and rest (an F450's legs in JSBSim:
first contact at 0.29 m, at rest 0.15 m; after the contact the motors are cut and the body settles onto them)."""

SCORE_KEYS = (
    "max_excursion_m",
    "max_lateral_excursion_m",
    "max_vertical_excursion_m",
    "max_ceiling_excursion_m",
    "min_margin_m",
    "time_outside_s",
    "activations",
    "breached_keep_out",
    "landed_outside_gap",
    "time_to_peak_excursion_s",
    "time_to_handback_s",
    "ground_speed_at_activation_mps",
    "approach_angle_at_activation_deg",
    "touchdown_vertical_mps",
    "touchdown_horizontal_mps",
)
"""Every key :func:`score_flight` returns, in this order."""

Trajectory = Mapping[str, np.ndarray]


def _height(traj: Trajectory, fence: LocalFence) -> np.ndarray:
    return np.asarray(traj["agl_m"] if fence.altitude_reference is AltitudeReference.AGL else traj["alt_m"], dtype=float)


def margins(traj: dict[str, np.ndarray], fence: LocalFence) -> dict[str, np.ndarray]:
    """Per-sample lateral, ceiling, floor and 3-D (``total``) margins, and ``keep_out`` (m, + inside)."""
    m = fence_margins(fence, traj["east_m"], traj["north_m"], _height(traj, fence))
    return {"lateral": m["lateral"], "ceiling": m["ceiling"], "floor": m["floor"], "total": m["total"], "keep_out": m["keep_out"]}


def keep_out_margin(traj: dict[str, np.ndarray], fence: LocalFence) -> np.ndarray:
    """Per-sample distance outside the nearest keep-out zone's volume (m, negative inside one; +inf with none).

    The height column (``agl_m`` or ``alt_m``, per the fence) is needed only when a keep-out has a floor or
    ceiling of its own; with full-height keep-outs only, the distance is lateral.
    """
    x = np.asarray(traj["east_m"], dtype=float)
    h = _height(traj, fence) if fence.has_keep_out_extents else np.zeros_like(x)
    return fence_margins(fence, x, traj["north_m"], h)["keep_out"]


SCORED_COLUMNS = (
    "time_s",
    "east_m",
    "north_m",
    "agl_m",
    "alt_m",
    "v_east_mps",
    "v_north_mps",
    "ground_speed_mps",
    "geofence_mode",
    "v_up_mps",
)
"""The trajectory columns :func:`score_flight` reads (a recorder or a trajectory.csv provides them)."""


def score_flight(traj: dict[str, np.ndarray], fence: LocalFence) -> dict[str, float | int | bool]:
    """Breach scores of one flight (see the module docstring)."""
    return score_many([traj], fence)[0]


def score_many(
    trajs: Sequence[Trajectory], fences: LocalFence | Sequence[LocalFence], threads: int | None = None
) -> list[dict[str, float | int | bool]]:
    """Scores of many flights: one dict per trajectory, in order (see the module docstring).

    ``fences`` is one :class:`LocalFence` for all flights or one per flight.
    Flights sharing a fence object are concatenated and scored in one
    vectorized pass (:func:`score_concatenated`). ``threads``: worker threads
    for the margins (default: the usable cores).
    """
    trajs = list(trajs)
    if isinstance(fences, LocalFence) or not isinstance(fences, Sequence):
        fences = [fences] * len(trajs)
    if len(fences) != len(trajs):
        raise ValueError(f"score_many: {len(trajs)} trajectories but {len(fences)} fences")
    out: list[dict | None] = [None] * len(trajs)
    groups: dict[int, list[int]] = {}
    for i, f in enumerate(fences):
        groups.setdefault(id(f), []).append(i)
    for idx in groups.values():
        fence = fences[idx[0]]
        scored = [i for i in idx if len(trajs[i]["time_s"])]
        for i in idx:
            if not len(trajs[i]["time_s"]):
                out[i] = _empty_scores()
        if not scored:
            continue
        cat = {
            k: np.concatenate(
                [
                    np.asarray(trajs[i][k], dtype=float) if k in trajs[i] else np.full(len(trajs[i]["time_s"]), np.nan)
                    for i in scored
                ]
            )
            for k in _COLUMNS
            if any(k in trajs[i] for i in scored)
        }
        lengths = np.array([len(trajs[i]["time_s"]) for i in scored])
        for i, sc in zip(scored, score_concatenated(cat, lengths, fence, threads=threads)):
            out[i] = sc
    return out  # type: ignore[return-value]


_COLUMNS = (
    "time_s", "east_m", "north_m", "agl_m", "alt_m", "geofence_mode", "v_east_mps", "v_north_mps", "ground_speed_mps",
    "v_up_mps",
)  # fmt: skip


def _empty_scores() -> dict:
    nan = float("nan")
    return {
        "max_excursion_m": 0.0,
        "max_lateral_excursion_m": 0.0,
        "max_vertical_excursion_m": 0.0,
        "max_ceiling_excursion_m": 0.0,
        "min_margin_m": 0.0,
        "time_outside_s": 0.0,
        "activations": 0,
        "breached_keep_out": False,
        "landed_outside_gap": False,
        "time_to_peak_excursion_s": nan,
        "time_to_handback_s": nan,
        "ground_speed_at_activation_mps": nan,
        "approach_angle_at_activation_deg": nan,
        "touchdown_vertical_mps": nan,
        "touchdown_horizontal_mps": nan,
    }


def _first_per_segment(idx: np.ndarray, starts: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """For sorted sample indices ``idx``: their segment, and the first index per segment (-1 if none)."""
    seg = np.searchsorted(starts, idx, side="right") - 1
    first = np.full(k, -1, dtype=np.intp)
    if len(idx):
        u, pos = np.unique(seg, return_index=True)
        first[u] = idx[pos]
    return seg, first


def score_concatenated(
    traj: Trajectory, lengths, fence: LocalFence, threads: int | None = None
) -> list[dict[str, float | int | bool]]:
    """Scores of flights stored back to back in one set of columns (the vectorized core).

    ``traj``: columns holding every flight's samples one flight after the
    other; ``lengths``: samples per flight (all > 0, summing to the column
    length). Returns one score dict per flight.
    """
    lengths = np.asarray(lengths, dtype=np.intp)
    k = len(lengths)
    if k == 0:
        return []
    if np.any(lengths <= 0):
        raise ValueError("score_concatenated: every flight needs at least one sample")
    ends = np.cumsum(lengths)
    starts = ends - lengths
    last = ends - 1
    t = np.asarray(traj["time_s"], dtype=float)
    n = len(t)
    if int(ends[-1]) != n:
        raise ValueError(f"score_concatenated: lengths sum to {int(ends[-1])}, columns hold {n} samples")
    x = np.asarray(traj["east_m"], dtype=float)
    y = np.asarray(traj["north_m"], dtype=float)
    m = fence_margins(fence, x, y, _height(traj, fence), threads=threads)
    total, lateral = m["total"], m["lateral"]

    min_total = np.minimum.reduceat(total, starts)
    min_lateral = np.minimum.reduceat(lateral, starts)
    min_ceiling = np.minimum.reduceat(m["ceiling"], starts)
    min_vertical = np.minimum(min_ceiling, np.minimum.reduceat(m["floor"], starts))
    min_keep_out = np.minimum.reduceat(m["keep_out"], starts)
    dt = np.empty(n)
    np.subtract(t[1:], t[:-1], out=dt[:-1])
    dt[last] = 0.0
    time_outside = np.add.reduceat(np.where(total < 0.0, dt, 0.0), starts)

    landed = np.zeros(k, dtype=bool)
    if "agl_m" in traj:
        agl_last = np.asarray(traj["agl_m"], dtype=float)[last]
        landed = (agl_last < ON_GROUND_AGL_M) & ((lateral[last] < 0.0) | (m["floor"][last] < 0.0))

    # ---- geofence modes: activations, hand-backs
    if "geofence_mode" in traj:
        mode = np.asarray(traj["geofence_mode"], dtype=float)
    else:
        mode = np.zeros(n)
    ov = mode == OVERRIDE_MODE
    entry = ov.copy()
    entry[1:] &= ~ov[:-1]
    entry[starts] = ov[starts]
    entry_idx = np.flatnonzero(entry)
    entry_seg, first = _first_per_segment(entry_idx, starts, k)
    activations = np.bincount(entry_seg, minlength=k)

    # next non-OVERRIDE sample after each entry, if in the same flight and RECOVERED/MONITOR
    not_ov = np.flatnonzero(~ov)
    nxt = np.full(len(entry_idx), n, dtype=np.intp)
    if len(not_ov):
        j = np.searchsorted(not_ov, entry_idx)
        nxt = np.where(j < len(not_ov), not_ov[np.minimum(j, len(not_ov) - 1)], n)
    ok = nxt < ends[entry_seg]
    nxt_safe = np.where(ok, nxt, 0)
    ok &= (mode[nxt_safe] == RECOVERED_MODE) | (mode[nxt_safe] == MONITOR_MODE)
    hb_sum = np.bincount(entry_seg[ok], weights=t[nxt_safe[ok]] - t[entry_idx[ok]], minlength=k)
    hb_cnt = np.bincount(entry_seg[ok], minlength=k)
    with np.errstate(invalid="ignore", divide="ignore"):
        handback = np.where(hb_cnt > 0, hb_sum / np.maximum(hb_cnt, 1), np.nan)

    # ---- peak excursion after the first activation
    has = first >= 0
    to_peak = np.full(k, np.nan)
    if has.any():
        seg_id = np.repeat(np.arange(k), lengths)
        gate = np.where(has, first, ends)[seg_id]  # samples before the first activation (or all) are masked
        masked = np.where(np.arange(n) >= gate, total, np.inf)
        seg_min = np.minimum.reduceat(masked, starts)
        hit = np.flatnonzero((masked == seg_min[seg_id]) & np.isfinite(masked))
        _, peak = _first_per_segment(hit, starts, k)
        sel = has & (peak >= 0)
        to_peak[sel] = t[peak[sel]] - t[first[sel]]

    # ---- state at the first activation
    speed = np.full(k, np.nan)
    angle = np.full(k, np.nan)
    if has.any():
        fi = first[has]
        ve, vn = _velocity_at(traj, fi, starts[has], ends[has], t, x, y)
        gs = np.hypot(ve, vn)
        if "ground_speed_mps" in traj:
            rec = np.asarray(traj["ground_speed_mps"], dtype=float)[fi]
            gs = np.where(np.isfinite(rec), rec, gs)
        speed[has] = gs
        edge = fence.keep_in.nearest_edge_array(np.column_stack([x[fi], y[fi]]))
        normal = fence.keep_in.outward_normals[edge]
        v = np.hypot(ve, vn)
        with np.errstate(invalid="ignore", divide="ignore"):
            c = (ve * normal[:, 0] + vn * normal[:, 1]) / v
        angle[has] = np.where(v > 1e-9, np.degrees(np.arccos(np.clip(c, -1.0, 1.0))), np.nan)

    touchdown = _touchdowns(traj, starts, ends, t, x, y)
    out = []
    for i in range(k):
        out.append(
            {
                "max_excursion_m": float(-min_total[i]),
                "max_lateral_excursion_m": float(-min_lateral[i]),
                "max_vertical_excursion_m": float(-min_vertical[i]),
                "max_ceiling_excursion_m": float(-min_ceiling[i]),
                "min_margin_m": float(min_total[i]),
                "time_outside_s": float(time_outside[i]),
                "activations": int(activations[i]),
                "breached_keep_out": bool(min_keep_out[i] < 0.0),
                "landed_outside_gap": bool(landed[i]),
                "time_to_peak_excursion_s": float(to_peak[i]),
                "time_to_handback_s": float(handback[i]),
                "ground_speed_at_activation_mps": float(speed[i]),
                "approach_angle_at_activation_deg": float(angle[i]),
                "touchdown_vertical_mps": touchdown[i][0],
                "touchdown_horizontal_mps": touchdown[i][1],
            }
        )
    return out


def touchdown_index(agl: np.ndarray) -> int:
    """The sample of a flight's final touchdown: the first within :data:`TOUCHDOWN_GEAR_TRAVEL_M` of its
    resting height (the last sample's) after it was last :data:`ON_GROUND_AGL_M` above it; -1 when the flight
    does not end on the ground."""
    if not len(agl) or not agl[-1] < ON_GROUND_AGL_M:
        return -1
    rest = agl[-1]
    above = np.flatnonzero(agl > rest + ON_GROUND_AGL_M)
    after = int(above[-1]) + 1 if len(above) else 0
    near = np.flatnonzero(agl[after:] <= rest + TOUCHDOWN_GEAR_TRAVEL_M)
    return after + int(near[0]) if len(near) else -1


def _touchdowns(
    traj: Trajectory, starts: np.ndarray, ends: np.ndarray, t: np.ndarray, x: np.ndarray, y: np.ndarray
) -> list[tuple[float, float]]:
    """Per flight, ``(vertical, horizontal)`` touchdown speed (m/s): the largest descent rate and ground speed
    in the :data:`TOUCHDOWN_WINDOW_S` up to the touchdown (:func:`touchdown_index`); NaN where it has none.
    Velocities recorded, else differences of the positions."""
    nan = float("nan")
    if "agl_m" not in traj:
        return [(nan, nan)] * len(starts)
    agl = np.asarray(traj["agl_m"], dtype=float)
    vup = np.asarray(traj["v_up_mps"], dtype=float) if "v_up_mps" in traj else np.full(len(t), np.nan)
    out = []
    for a, b in zip(starts, ends):
        j = touchdown_index(agl[a:b])
        if j < 0:
            out.append((nan, nan))
            continue
        j += int(a)
        lo = int(np.searchsorted(t[a:b], t[j] - TOUCHDOWN_WINDOW_S)) + int(a)
        idx = np.arange(lo, j + 1)
        ve, vn = _velocity_at(traj, idx, np.full(len(idx), a), np.full(len(idx), b), t, x, y)
        down = -vup[idx]
        if not np.isfinite(down).all():
            span = np.maximum(t[np.minimum(idx + 1, b - 1)] - t[np.maximum(idx - 1, a)], 1e-9)
            down = -(agl[np.minimum(idx + 1, b - 1)] - agl[np.maximum(idx - 1, a)]) / span
        out.append((float(np.max(down)), float(np.max(np.hypot(ve, vn)))))
    return out


def _velocity_at(
    traj: Trajectory, idx: np.ndarray, lo: np.ndarray, hi: np.ndarray, t: np.ndarray, x: np.ndarray, y: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Ground velocity (east, north) at samples ``idx``: recorded, else central differences within [lo, hi)."""
    ve = np.full(len(idx), np.nan)
    vn = np.full(len(idx), np.nan)
    if "v_east_mps" in traj and "v_north_mps" in traj:
        ve = np.asarray(traj["v_east_mps"], dtype=float)[idx]
        vn = np.asarray(traj["v_north_mps"], dtype=float)[idx]
    missing = ~(np.isfinite(ve) & np.isfinite(vn))
    if missing.any():
        i = idx[missing]
        a = np.maximum(i - 1, lo[missing])
        b = np.minimum(i + 1, hi[missing] - 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            span = t[b] - t[a]
            ve[missing] = np.where(span > 0, (x[b] - x[a]) / span, np.nan)
            vn[missing] = np.where(span > 0, (y[b] - y[a]) / span, np.nan)
    return ve, vn


SUSTAINED_WIND_WINDOW_S = 10.0
"""The averaging window of the strongest wind a flight met (s): about the time a multirotor needs to
stop and turn back, and a fixed-wing to reverse its course."""


def sustained_wind_peak_mps(
    t_s: np.ndarray, wind_e_mps: np.ndarray, wind_n_mps: np.ndarray, window_s: float = SUSTAINED_WIND_WINDOW_S
) -> float:  # fmt: skip
    """The largest horizontal wind speed at the vehicle averaged over ``window_s`` (a moving mean of the wind
    sampled at each step, ``wind_east_mps``/``wind_north_mps``, by time), m/s; NaN with fewer than two samples. Each
    sample counts for the interval since the one before; a flight shorter than the window is its whole mean."""
    t, we, wn = (np.asarray(x, dtype=float) for x in (t_s, wind_e_mps, wind_n_mps))
    if len(t) < 2:
        return float("nan")
    dt = np.diff(t, prepend=t[0])
    ce, cn, ct = (np.concatenate(([0.0], np.cumsum(x * dt))) for x in (we, wn, np.ones_like(t)))
    j = np.arange(1, len(t) + 1)
    i = np.searchsorted(t, t - window_s, side="left")  # the window (t - window_s, t]
    span = ct[j] - ct[i]
    ok = span >= min(window_s, float(t[-1] - t[0])) - 1e-9
    if not ok.any():
        return float("nan")
    return float(np.max(np.hypot((ce[j] - ce[i])[ok], (cn[j] - cn[i])[ok]) / span[ok]))
