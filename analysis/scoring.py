"""Breach scoring of one recorded flight against a fence (vectorized, numpy only).

Input: named trajectory columns (as in ``trajectory.csv``: ``time_s``,
``east_m``, ``north_m``, ``agl_m`` or ``alt_m``, optional ``geofence_mode``)
and a :class:`~geofence.fence.LocalFence` in the same ENU frame. Output: a
flat dict of scores, all in SI units:

* ``max_excursion_m``: the farthest the vehicle got beyond the fence, lateral
  or vertical (<= 0: never outside; then it is minus the closest approach);
* ``max_lateral_excursion_m``, ``max_vertical_excursion_m``: the same per axis;
* ``min_margin_m``: the smallest 3-D margin (+ inside);
* ``time_outside_s``: total time with a negative margin;
* ``activations``: entries into OVERRIDE (from the recorded mode column);
* ``breached_keep_out``: any sample inside a keep-out zone;
* ``landed_outside_gap``: the flight ended on the ground where landing is not
  allowed (outside the fence, or below the floor outside every gap).
"""

from __future__ import annotations

import numpy as np

from geofence.fence import LocalFence

OVERRIDE_MODE = 1


def margins(traj: dict[str, np.ndarray], fence: LocalFence) -> dict[str, np.ndarray]:
    """Per-sample lateral, ceiling, floor and 3-D margins (m, + inside)."""
    pts = np.column_stack([traj["east_m"], traj["north_m"]])
    h = np.asarray(traj["agl_m"] if fence.altitude_reference == "agl" else traj["alt_m"], dtype=float)
    lateral = fence.lateral_margin_array(pts)
    ceiling = fence.ceiling_m - h
    floor = fence.floor_margin_array(pts, h) if fence.floor_m is not None else np.full_like(h, np.inf)
    return {"lateral": lateral, "ceiling": ceiling, "floor": floor, "total": np.minimum(lateral, np.minimum(ceiling, floor))}


def keep_out_margin(traj: dict[str, np.ndarray], fence: LocalFence) -> np.ndarray:
    """Per-sample distance outside the nearest keep-out zone (m, negative inside one; +inf with none)."""
    pts = np.column_stack([traj["east_m"], traj["north_m"]])
    m = np.full(len(pts), np.inf)
    for k in fence.keep_out_polygons:
        m = np.minimum(m, -k.signed_distance_array(pts))
    for ce, cn, r in fence.keep_out_circles:
        m = np.minimum(m, np.hypot(pts[:, 0] - ce, pts[:, 1] - cn) - r)
    return m


def score_flight(traj: dict[str, np.ndarray], fence: LocalFence) -> dict[str, float | int | bool]:
    """Breach scores of one flight (see the module docstring)."""
    t = np.asarray(traj["time_s"], dtype=float)
    m = margins(traj, fence)
    total = m["total"]
    dt = np.diff(t, append=t[-1] if len(t) else 0.0)
    vertical = np.minimum(m["ceiling"], m["floor"])
    mode = np.asarray(traj.get("geofence_mode", np.zeros_like(t)), dtype=float)
    in_override = mode == OVERRIDE_MODE
    activations = int(np.count_nonzero(in_override[1:] & ~in_override[:-1]) + (1 if len(mode) and in_override[0] else 0))
    landed_outside = False
    if len(t) and "agl_m" in traj:
        last = -1
        on_ground = traj["agl_m"][last] < 0.5
        if on_ground:
            landed_outside = bool(m["lateral"][last] < 0.0 or m["floor"][last] < 0.0)
    return {
        "max_excursion_m": float(-total.min()) if len(t) else 0.0,
        "max_lateral_excursion_m": float(-m["lateral"].min()) if len(t) else 0.0,
        "max_vertical_excursion_m": float(-vertical.min()) if len(t) else 0.0,
        "min_margin_m": float(total.min()) if len(t) else 0.0,
        "time_outside_s": float(dt[total < 0.0].sum()),
        "activations": activations,
        "breached_keep_out": bool((keep_out_margin(traj, fence) < 0.0).any()),
        "landed_outside_gap": landed_outside,
    }
