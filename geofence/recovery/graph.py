"""The planner's graph: its corner nodes, which pairs of them are tangent at both ends, filing the clear ones.

Owns the corner nodes round the grown obstacles (:func:`corner_nodes`), the tangency test of a node's normal
cone (:func:`_tangent_at`), a node's tangent candidates (:func:`_tangent_row`), every node's at once
(:func:`_tangent_pairs`), and the edge store's filing of a node's clear candidates (:func:`_file_row`,
:func:`_file_rows`). The edge store: node ``i``'s edges are ``store_j[row_start[i]:][:row_len[i]]`` (other
nodes) with lengths ``store_w``, ``row_start[i]`` -1 until filed, ``used[0]`` entries filled.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from geofence.jit import compiled, jitable
from geofence.recovery.segments import _fan_clear_grid

if TYPE_CHECKING:  # pragma: no cover
    from geofence.geometry.local_fence import LocalFence

NODE_INFLATION_M: float = 1e-6
"""Nodes sit on clearance circles of radius ``c + NODE_INFLATION_M``."""

CORNER_STEP_RAD: float = math.pi / 6.0
"""Largest turn covered by one circumscribed piece at a corner (30 deg)."""

CIRCLE_SIDES: int = 16
"""Sides of the polygon circumscribed round each grown keep-out circle."""


def corner_nodes(fence: "LocalFence", clearance_m: float) -> list[tuple[float, float, float, float, float, float]]:
    """The graph's corner nodes ``(east, north, n1e, n1n, n2e, n2n)``: each point and its normal cone (n1 -> n2),
    the vertices of the pieces circumscribed round the clearance arcs at the grown obstacles' corners and round
    the grown circles (see :mod:`geofence.recovery`)."""
    cp = clearance_m + NODE_INFLATION_M
    out: list[tuple[float, float, float, float, float, float]] = []

    def arc(vx: float, vy: float, a0: float, delta: float, radius: float, k: int = 0) -> None:
        # node j: corner of the tangent lines at angles a0 + j·delta/k and a0 + (j+1)·delta/k
        k = k or max(1, math.ceil(abs(delta) / CORNER_STEP_RAD - 1e-12))
        dist = radius / math.cos(abs(delta) / (2 * k))
        sg = 1.0 if delta >= 0.0 else -1.0
        for j in range(k):
            ang = a0 + (j + 0.5) * delta / k
            a1, a2 = a0 + j * delta / k, a0 + (j + 1) * delta / k
            # the two normals, ordered counter-clockwise (cone from n1 to n2)
            if sg < 0.0:
                a1, a2 = a2, a1
            out.append(
                (vx + dist * math.cos(ang), vy + dist * math.sin(ang), math.cos(a1), math.sin(a1), math.cos(a2), math.sin(a2))
            )

    def polygon(p, free_side: float) -> None:
        # free_side=+1: free space is the polygon's interior (keep-in); -1: its exterior (keep-out)
        v = p.vertices
        sgn = 1.0 if p.ccw else -1.0
        nv = len(v)
        for i in range(nv):
            px, py = float(v[i - 1, 0]), float(v[i - 1, 1])
            vx, vy = float(v[i, 0]), float(v[i, 1])
            qx, qy = float(v[(i + 1) % nv, 0]), float(v[(i + 1) % nv, 1])
            d1x, d1y, d2x, d2y = vx - px, vy - py, qx - vx, qy - vy
            l1, l2 = math.hypot(d1x, d1y), math.hypot(d2x, d2y)
            if l1 == 0.0 or l2 == 0.0:
                continue
            turn = sgn * (d1x * d2y - d1y * d2x)  # > 0: convex corner of the polygon
            if free_side > 0.0 and turn >= 0.0:
                continue  # convex keep-in corner: no obstacle corner to wrap round
            if free_side < 0.0 and turn <= 0.0:
                continue  # reflex keep-out corner
            # normals pointing into the free space (inward for keep-in, outward for keep-out)
            k = free_side * sgn
            n1x, n1y = -k * d1y / l1, k * d1x / l1
            n2x, n2y = -k * d2y / l2, k * d2x / l2
            delta = math.atan2(n1x * n2y - n1y * n2x, n1x * n2x + n1y * n2y)
            arc(vx, vy, math.atan2(n1y, n1x), delta, cp)

    polygon(fence.keep_in, 1.0)
    for p in fence.keep_out_polygons:
        polygon(p, -1.0)
    for x, y, r in fence.keep_out_circles:
        arc(x, y, -math.pi / CIRCLE_SIDES, 2.0 * math.pi, r + cp, CIRCLE_SIDES)
    return out


@jitable
def _tangent_at(c0: float, c1: float, c2: float, c3: float, corner: bool, dx: float, dy: float) -> bool:
    """Can a shortest path leave a node (its normal cone ``c0..c3``: n1 -> n2) along ``(dx, dy)``?

    A shortest path only bends at a corner node by wrapping round it: the line through the node along the
    direction must support the node's local (circumscribed) obstacle, i.e. a normal of the line lies in the
    node's normal cone. Non-corner nodes (safe points) accept every direction. Collinear cases (within 1e-9
    relative) count as tangent.
    """
    if not corner:
        return True
    px = -dy
    py = dx
    s1 = c0 * py - c1 * px
    s2 = px * c3 - py * c2
    # the tolerance's size lies within [lo, hi]; a cross product outside that band on both sides of zero gets its
    # verdict without the square root (the same verdict: the square root decides only within the band)
    ax = abs(px)
    ay = abs(py)
    lo = 0.5e-9 * (ax if ax > ay else ay)
    hi = 2e-9 * (ax + ay)
    a1 = abs(s1)
    a2 = abs(s2)
    if (a1 < lo or a1 > hi) and (a2 < lo or a2 > hi):
        small1 = a1 < lo
        small2 = a2 < lo
        return ((small1 or s1 > 0.0) and (small2 or s2 > 0.0)) or ((small1 or s1 < 0.0) and (small2 or s2 < 0.0))
    tol = -1e-9 * math.hypot(px, py)
    return (s1 >= tol and s2 >= tol) or (s1 <= -tol and s2 <= -tol)


@jitable
def _tangent_row(i: int, nodes: np.ndarray, cones: np.ndarray, is_corner: np.ndarray) -> np.ndarray:
    """The nodes ``j != i`` whose straight edge to node ``i`` is tangent at both ends (:func:`_tangent_at`
    leaving ``i`` along ``nodes[j] - nodes[i]`` and leaving ``j`` along its negation): the candidates of ``i``'s
    graph edges, ascending."""
    n = nodes.shape[0]
    out = np.empty(n, np.int64)
    m = 0
    xi = nodes[i, 0]
    yi = nodes[i, 1]
    for j in range(n):
        if j == i:
            continue
        dx = nodes[j, 0] - xi
        dy = nodes[j, 1] - yi
        if _tangent_at(cones[i, 0], cones[i, 1], cones[i, 2], cones[i, 3], is_corner[i], dx, dy) and _tangent_at(
            cones[j, 0], cones[j, 1], cones[j, 2], cones[j, 3], is_corner[j], -dx, -dy
        ):
            out[m] = j
            m += 1
    return out[:m]


@jitable
def _tangent_pairs(nodes: np.ndarray, cones: np.ndarray, is_corner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every node's :func:`_tangent_row` at once, ``(ptr, cols)``: node ``i``'s candidates are
    ``cols[ptr[i]:ptr[i + 1]]``, ascending, the same as its row. Each pair is tested once: the test is symmetric
    (row ``j`` tests the same two cones along the negated difference, and ``a - b`` is exactly ``-(b - a)``)."""
    n = nodes.shape[0]
    cap = 4 * n + 16
    pa = np.empty(cap, np.int64)
    pb = np.empty(cap, np.int64)
    m = 0
    for a in range(n):
        xa = nodes[a, 0]
        ya = nodes[a, 1]
        c0 = cones[a, 0]
        c1 = cones[a, 1]
        c2 = cones[a, 2]
        c3 = cones[a, 3]
        corner = is_corner[a]
        for b in range(a + 1, n):
            dx = nodes[b, 0] - xa
            dy = nodes[b, 1] - ya
            if _tangent_at(c0, c1, c2, c3, corner, dx, dy) and _tangent_at(
                cones[b, 0], cones[b, 1], cones[b, 2], cones[b, 3], is_corner[b], -dx, -dy
            ):
                if m == cap:
                    cap *= 2
                    qa = np.empty(cap, np.int64)
                    qb = np.empty(cap, np.int64)
                    qa[:m] = pa[:m]
                    qb[:m] = pb[:m]
                    pa = qa
                    pb = qb
                pa[m] = a
                pb[m] = b
                m += 1
    ptr = np.zeros(n + 1, np.int64)
    for k in range(m):
        ptr[pa[k] + 1] += 1
        ptr[pb[k] + 1] += 1
    for i in range(n):
        ptr[i + 1] += ptr[i]
    fill = ptr[:n].copy()
    cols = np.empty(2 * m, np.int64)
    for k in range(m):  # in the order found: a row gets its lower partners first, each side ascending
        a = pa[k]
        b = pb[k]
        cols[fill[a]] = b
        fill[a] += 1
        cols[fill[b]] = a
        fill[b] += 1
    return ptr, cols


@jitable
def _file_row(
    i: int, jj: np.ndarray, P: np.ndarray, node_thr: float, edges: np.ndarray, circles: np.ndarray, x0: float,
    y0: float, cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray, row_start: np.ndarray,
    row_len: np.ndarray, store_j: np.ndarray, store_w: np.ndarray, used: np.ndarray,
) -> bool:  # fmt: skip
    """File node ``i``'s graph edges among its tangent candidates ``jj`` (those whose segment is clear at
    ``node_thr``, :func:`geofence.recovery.segments._fan_clear_grid`) in the edge store; ``False``: the store is full."""
    ok = _fan_clear_grid(P[i, 0], P[i, 1], P[jj], node_thr, edges, circles, x0, y0, cell, nx, ny, start, items)
    jj = jj[ok]
    m = jj.shape[0]
    if used[0] + m > store_j.shape[0]:
        return False
    at = used[0]
    for k in range(m):
        store_j[at + k] = jj[k]
        store_w[at + k] = np.hypot(P[jj[k], 0] - P[i, 0], P[jj[k], 1] - P[i, 1])
    row_start[i] = at
    row_len[i] = m
    used[0] = at + m
    return True


@jitable
def _file_rows(
    ptr: np.ndarray, cols: np.ndarray, P: np.ndarray, node_thr: float, edges: np.ndarray, circles: np.ndarray,
    x0: float, y0: float, cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray,
    row_start: np.ndarray, row_len: np.ndarray, store_j: np.ndarray, store_w: np.ndarray, used: np.ndarray,
) -> bool:  # fmt: skip
    """:func:`_file_row` for every node not filed yet, its candidates from :func:`_tangent_pairs`; ``False``: the
    store is full (the rows filed so far stay)."""
    for i in range(P.shape[0]):
        if row_start[i] >= 0:
            continue
        if not _file_row(i, cols[ptr[i] : ptr[i + 1]], P, node_thr, edges, circles, x0, y0, cell, nx, ny, start,
                         items, row_start, row_len, store_j, store_w, used):  # fmt: skip
            return False
    return True


tangent_row = compiled(_tangent_row)
"""The compiled :func:`_tangent_row`."""

tangent_pairs = compiled(_tangent_pairs)
"""The compiled :func:`_tangent_pairs`."""

file_rows = compiled(_file_rows)
"""The compiled :func:`_file_rows`."""
