"""The activation ("shifted") boundary as a field on a grid, for plots.

The geofence acts at a boundary that depends on the state; for a picture we
draw the representative one: every keep-in edge moved inward by the room the
platform needs when it approaches that edge head-on at cruise speed in the
given steady wind (so the downwind edges move in further). The field is
``min_i(distance to edge i - shift_i)`` inside the keep-in polygon; its zero
contour is the activation boundary (exact for concave polygons too).
"""

from __future__ import annotations

import numpy as np

from geofence.boundary_shift import fixed_wing_room_m, multicopter_stopping_distance_m
from geofence.dynamics import drag_coefficients, wind_push_mps2
from geofence.fence import LocalFence
from geofence.interface import Envelope


def edge_shifts_m(fence: LocalFence, env: Envelope, wind_en: tuple[float, float]) -> np.ndarray:
    """Per keep-in edge: the room (m) needed for a head-on approach at cruise speed in the wind."""
    normals = fence.keep_in.outward_normals
    w_n = normals @ np.asarray(wind_en, dtype=float)
    wind_speed = float(np.hypot(*wind_en))
    v = env.cruise_speed_mps
    shifts = []
    for wn in w_n:
        if env.is_multirotor:
            push = wind_push_mps2(*drag_coefficients(env), wind_speed, float(wn))
            shifts.append(multicopter_stopping_distance_m(v, env.reaction_time_s, env.braking_decel_mps2, v, push))
        else:
            shifts.append(fixed_wing_room_m(v, env.max_bank_rad, 0.0, float(wn), env.reaction_time_s))
    return np.asarray(shifts)


def activation_field(fence: LocalFence, env: Envelope, wind_en: tuple[float, float], resolution: int = 220):
    """(E, N, field) grids over the keep-in bounding box; field < 0 outside the activation boundary."""
    k = fence.keep_in
    x0, y0, x1, y1 = k.bbox
    pad = 0.05 * max(x1 - x0, y1 - y0)
    e = np.linspace(x0 - pad, x1 + pad, resolution)
    n = np.linspace(y0 - pad, y1 + pad, resolution)
    E, N = np.meshgrid(e, n)
    pts = np.column_stack([E.ravel(), N.ravel()])
    shifts = edge_shifts_m(fence, env, wind_en)
    a = k.starts[None, :, :]
    d = (k.ends - k.starts)[None, :, :]
    p = pts[:, None, :]
    t = np.clip(((p - a) * d).sum(-1) / (d * d).sum(-1), 0.0, 1.0)
    dist = np.linalg.norm(p - (a + t[..., None] * d), axis=-1)
    field = (dist - shifts[None, :]).min(axis=1)
    inside = k.contains_array(pts)
    field = np.where(inside, field, -dist.min(axis=1))
    return E, N, field.reshape(E.shape)
