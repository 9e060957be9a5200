"""The activation ("shifted") boundary as a field on a grid, for plots.

The geofence acts at a boundary that depends on the state; for a picture we
draw it for one speed and one steady wind (by default the platform's cruise
speed; :mod:`analysis.plots` passes the speed and wind recorded at each
activation): every boundary is moved toward the allowed side by the room the
platform needs when it approaches that boundary head-on at that speed in that
wind (:func:`geofence.physics.rooms.head_on_room_m`, so the downwind edges move further):

* keep-in edges move inward;
* keep-out polygons grow outward (each edge by the room for a head-on
  approach from outside);
* keep-out circles grow outward, the room at each point for an approach
  straight at the centre (the wind component along that line varies around
  the circle, so the grown circle is not a circle in wind).

The field is ``min(distance to the boundary - room)`` over every boundary,
positive on the allowed side; its zero contour is the activation boundary
(exact for concave polygons too). The unit's own boundary also includes its
uncertainty margin and wind allowance, and the approach angle; this field is
the head-on one without them. Every keep-out is drawn full-height, as the
unit treats it (its own floor and ceiling, if any, play no part in the
activation boundary; only the scoring uses them).
"""

from __future__ import annotations

import numpy as np

from geofence.geometry.local_fence import LocalFence
from geofence.interface import Envelope
from geofence.physics.rooms import head_on_room_m


def _speed(env: Envelope, speed_mps: float | None) -> float:
    return env.cruise_speed_mps if speed_mps is None or not np.isfinite(speed_mps) else float(speed_mps)


def edge_shifts_m(fence: LocalFence, env: Envelope, wind_en: tuple[float, float], speed_mps: float | None = None) -> np.ndarray:
    """Per keep-in edge: the room (m) needed for a head-on approach at ``speed_mps`` (default cruise) in the wind."""
    normals = fence.keep_in.outward_normals
    w_n = normals @ np.asarray(wind_en, dtype=float)
    wind_speed = float(np.hypot(*wind_en))
    v = _speed(env, speed_mps)
    return np.asarray([head_on_room_m(env, v, float(wn), wind_speed) for wn in w_n])


CHUNK_PAIRS = 2_000_000
"""Point-edge pairs held at once (a few tens of MB of temporaries): an airspace fence of 10,000 edges on a
220 x 220 grid would otherwise need 7 GB for one array."""


def _segment_distances(poly, pts: np.ndarray) -> np.ndarray:
    """(points, edges) distances from each point to each edge of a polygon index."""
    a = poly.starts[None, :, :]
    d = (poly.ends - poly.starts)[None, :, :]
    p = pts[:, None, :]
    t = np.clip(((p - a) * d).sum(-1) / (d * d).sum(-1), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * d), axis=-1)


def _nearest(poly, pts: np.ndarray, shifts: np.ndarray, chunk_pairs: int) -> tuple[np.ndarray, np.ndarray]:
    """Per point: ``min over edges (distance - shift)`` and ``min over edges distance``, in chunks of points."""
    n_edges = max(len(poly.starts), 1)
    step = max(1, chunk_pairs // n_edges)
    shifted = np.empty(len(pts))
    nearest = np.empty(len(pts))
    for i in range(0, len(pts), step):
        dist = _segment_distances(poly, pts[i : i + step])
        shifted[i : i + step] = (dist - shifts[None, :]).min(axis=1)
        nearest[i : i + step] = dist.min(axis=1)
    return shifted, nearest


def activation_field(
    fence: LocalFence,
    env: Envelope,
    wind_en: tuple[float, float],
    resolution: int = 220,
    speed_mps: float | None = None,
    chunk_pairs: int = CHUNK_PAIRS,
):
    """(E, N, field) grids over the keep-in bounding box; field < 0 outside the activation boundary.

    Keep-in edges, keep-out polygons and keep-out circles, each with its own
    head-on room at ``speed_mps`` (airspeed for a fixed-wing, ground speed for a
    multirotor; default cruise) in the steady wind ``wind_en`` (m/s toward E, N).
    ``chunk_pairs``: point-edge pairs computed at once (memory; the field is the same for any value).
    """
    k = fence.keep_in
    x0, y0, x1, y1 = k.bbox
    pad = 0.05 * max(x1 - x0, y1 - y0)
    e = np.linspace(x0 - pad, x1 + pad, resolution)
    n = np.linspace(y0 - pad, y1 + pad, resolution)
    E, N = np.meshgrid(e, n)
    pts = np.column_stack([E.ravel(), N.ravel()])
    wind = np.asarray(wind_en, dtype=float)
    wind_speed = float(np.hypot(*wind))
    v = _speed(env, speed_mps)

    shifts = edge_shifts_m(fence, env, wind_en, v)
    shifted, nearest = _nearest(k, pts, shifts, chunk_pairs)
    field = np.where(k.contains_array(pts), shifted, -nearest)

    for poly in fence.keep_out_polygons:
        # approaching from outside: the aircraft moves along the inward normal, so the tailwind is -(n . w)
        sh = np.asarray([head_on_room_m(env, v, float(-wn), wind_speed) for wn in poly.outward_normals @ wind])
        f, nearest = _nearest(poly, pts, sh, chunk_pairs)
        field = np.minimum(field, np.where(poly.contains_array(pts), -nearest, f))

    if fence.keep_out_circles:
        # room as a function of the tailwind component, interpolated (it is smooth and monotone in it)
        w_grid = np.linspace(-wind_speed, wind_speed, 41) if wind_speed > 0 else np.zeros(1)
        r_grid = np.asarray([head_on_room_m(env, v, float(w), wind_speed) for w in w_grid])
        for ce, cn, r in fence.keep_out_circles:
            rel = np.asarray([ce, cn]) - pts
            dc = np.linalg.norm(rel, axis=1)
            toward = (rel @ wind) / np.maximum(dc, 1e-9)
            sh = np.interp(toward, w_grid, r_grid) if len(w_grid) > 1 else np.full(len(pts), r_grid[0])
            field = np.minimum(field, (dc - r) - np.where(dc > r, sh, 0.0))
    return E, N, field.reshape(E.shape)
