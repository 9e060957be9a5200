"""Fast vectorized fence margins for long recorded arrays (numpy only).

Same numbers as :meth:`geofence.geometry.polygon.PolygonIndex.signed_distance_array`
and the ``LocalFence.*_array`` methods (the same formulas, operation for
operation, so the results are bit-identical), but organised for throughput:
the samples are cut into chunks, each polygon edge is one pass of in-place
ufuncs over a chunk (no ``(M, N)`` temporaries, a dozen preallocated buffers
per chunk), and the chunks are shared between threads (numpy releases the GIL
inside its loops; chunks are large so that per-call overhead stays small).

Keep-outs with their own floor or ceiling (``LocalFence.keep_out_*_extents``,
:class:`~geofence.geometry.fence.VerticalExtent`) count here only inside their volume
(:meth:`~geofence.geometry.fence.VerticalExtent.volume_margin_array`): this is the
scoring's view of the airspace. The ``LocalFence`` margins are the unit's,
which treats every keep-out as full-height, so the two agree exactly when
every keep-out is full-height.

Used by :mod:`analysis.scoring`; ``bench/scoring.py`` measures it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from geofence.geometry.fence import VerticalExtent
from geofence.geometry.polygon import BOUNDARY_TOL_M, PolygonIndex

CHUNK = 65536
"""Samples per chunk (measured on 2 cores: 32-64 k is best on one thread, >= 64 k with two)."""

_POOL: ThreadPoolExecutor | None = None
_POOL_SIZE = 0
_POOL_PID = 0
PARALLEL_MIN_SAMPLES = 2 * CHUNK
"""Below this many samples everything runs on the calling thread."""


def default_threads() -> int:
    """Worker threads: ``GEOFENCE_SCORING_THREADS`` or the number of usable cores (at most 8)."""
    env = os.environ.get("GEOFENCE_SCORING_THREADS")
    if env:
        return max(1, int(env))
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        n = os.cpu_count() or 1
    return max(1, min(8, n))


def _pool(threads: int) -> ThreadPoolExecutor:
    """The shared worker pool; a new one after a fork (a forked child has none of the parent's threads)."""
    global _POOL, _POOL_SIZE, _POOL_PID
    if _POOL is None or _POOL_SIZE != threads or _POOL_PID != os.getpid():
        if _POOL is not None and _POOL_PID == os.getpid():
            _POOL.shutdown(wait=False)
        _POOL = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="scoring")
        _POOL_SIZE, _POOL_PID = threads, os.getpid()
    return _POOL


class _Edges:
    """Per-edge constants of one polygon as plain floats (what the per-edge passes need)."""

    __slots__ = ("rows",)

    def __init__(self, poly: PolygonIndex) -> None:
        a, b = poly.starts, poly.ends
        d = b - a
        l2 = np.einsum("ij,ij->i", d, d)
        il2 = np.where(l2 > 0.0, 1.0 / np.where(l2 > 0.0, l2, 1.0), 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            dxdy = np.where(d[:, 1] != 0.0, d[:, 0] / d[:, 1], 0.0)
        self.rows = tuple(
            (
                float(a[i, 0]),
                float(a[i, 1]),
                float(b[i, 1]),
                float(d[i, 0]),
                float(d[i, 1]),
                float(il2[i]),
                float(dxdy[i]),
                float(min(a[i, 1], b[i, 1])),
                float(max(a[i, 1], b[i, 1])),
            )
            for i in range(len(a))
        )


_EDGE_CACHE: dict[int, tuple[PolygonIndex, _Edges]] = {}


def _edges(poly: PolygonIndex) -> _Edges:
    hit = _EDGE_CACHE.get(id(poly))
    if hit is None or hit[0] is not poly:
        if len(_EDGE_CACHE) > 256:
            _EDGE_CACHE.clear()
        hit = (poly, _Edges(poly))
        _EDGE_CACHE[id(poly)] = hit
    return hit[1]


def _signed_distance_chunk(edges: _Edges, x: np.ndarray, y: np.ndarray, out: np.ndarray) -> None:
    """Signed distance of one chunk into ``out`` (+ inside, on the boundary counts as inside)."""
    m = len(x)
    best = out
    best.fill(np.inf)
    inside = np.zeros(m, dtype=bool)
    px = np.empty(m)
    py = np.empty(m)
    t = np.empty(m)
    tmp = np.empty(m)
    s1 = np.empty(m, dtype=bool)
    s2 = np.empty(m, dtype=bool)
    for ax, ay, by, dx, dy, il2, dxdy, ylo, yhi in edges.rows:
        np.subtract(x, ax, out=px)
        np.subtract(y, ay, out=py)
        # crossing number (ray towards +x): the edge straddles y and the crossing lies right of x
        if dy != 0.0:
            np.less(y, yhi, out=s1)  # y < max(ay, by)
            np.greater_equal(y, ylo, out=s2)  # y >= min(ay, by)
            np.logical_and(s1, s2, out=s1)
            np.multiply(py, dxdy, out=tmp)
            np.less(px, tmp, out=s2)
            np.logical_and(s1, s2, out=s1)
            np.logical_xor(inside, s1, out=inside)
        # squared distance to the segment
        np.multiply(px, dx, out=t)
        np.multiply(py, dy, out=tmp)
        np.add(t, tmp, out=t)
        np.multiply(t, il2, out=t)
        np.maximum(t, 0.0, out=t)
        np.minimum(t, 1.0, out=t)
        np.multiply(t, dx, out=tmp)
        np.subtract(px, tmp, out=px)
        np.multiply(t, dy, out=tmp)
        np.subtract(py, tmp, out=py)
        np.multiply(px, px, out=px)
        np.multiply(py, py, out=py)
        np.add(px, py, out=px)
        np.minimum(best, px, out=best)
    np.sqrt(best, out=best)
    # outside (and not within the boundary tolerance): negative
    np.less_equal(best, BOUNDARY_TOL_M, out=s1)
    np.logical_or(inside, s1, out=inside)
    np.negative(best, out=best, where=~inside)


def _run_chunks(fn, n: int, threads: int | None) -> None:
    """Call ``fn(start, stop)`` over ``[0, n)`` in chunks, on worker threads for large ``n``."""
    spans = [(s, min(n, s + CHUNK)) for s in range(0, n, CHUNK)]
    threads = default_threads() if threads is None else max(1, int(threads))
    if threads == 1 or n < PARALLEL_MIN_SAMPLES:
        for s, e in spans:
            fn(s, e)
        return
    # one contiguous block of chunks per task keeps the per-task overhead small
    per = max(1, -(-len(spans) // (threads * 4)))
    blocks = [spans[i : i + per] for i in range(0, len(spans), per)]

    def work(block):
        for s, e in block:
            fn(s, e)

    for f in [_pool(threads).submit(work, b) for b in blocks]:
        f.result()


def signed_distance(poly: PolygonIndex, x, y, threads: int | None = None) -> np.ndarray:
    """Signed distance (m, + inside) of every (x[i], y[i]) to ``poly``; = ``poly.signed_distance_array``."""
    x = np.ascontiguousarray(x, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    out = np.empty(len(x))
    edges = _edges(poly)
    _run_chunks(lambda s, e: _signed_distance_chunk(edges, x[s:e], y[s:e], out[s:e]), len(x), threads)
    return out


def _extents(extents: Sequence[VerticalExtent]) -> list[VerticalExtent | None]:
    """Each keep-out's extent, ``None`` for a full-height one (nothing to apply)."""
    return [None if x.full_height else x for x in extents]


def fence_margins(fence, x, y, h, threads: int | None = None) -> dict[str, np.ndarray]:
    """Per-sample margins of a :class:`~geofence.geometry.local_fence.LocalFence` (m, + safe), in one chunked pass.

    ``x, y``: east, north (m); ``h``: height in the fence's altitude reference.
    Returns ``lateral`` (keep-in and keep-outs), ``keep_out`` (distance outside
    the nearest keep-out's volume, ``+inf`` with none), ``ceiling``, ``floor``
    (gap-aware, ``+inf`` with no floor) and ``total`` (the 3-D margin).
    A keep-out with a vertical extent enters ``keep_out`` (and so ``lateral``
    and ``total``) as ``max(distance outside its footprint, h - its ceiling,
    its floor - h)``: negative only inside its volume. With full-height
    keep-outs only, identical to ``fence.lateral_margin_array`` /
    ``floor_margin_array`` / ``margin_array``.
    """
    x = np.ascontiguousarray(x, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    h = np.ascontiguousarray(h, dtype=float)
    n = len(x)
    keep_in = _edges(fence.keep_in)
    keep_outs = [(_edges(k), x) for k, x in zip(fence.keep_out_polygons, _extents(fence.keep_out_polygon_extents))]
    circles = list(zip(fence.keep_out_circles, _extents(fence.keep_out_circle_extents)))
    gaps = [_edges(g) for g in fence.floor_gaps] if fence.floor_m is not None else []
    ceiling_m, floor_m = float(fence.ceiling_m), fence.floor_m
    lateral = np.empty(n)
    keep_out = np.full(n, np.inf)
    ceiling = np.empty(n)
    floor = np.full(n, np.inf)
    total = np.empty(n)

    def chunk(s: int, e: int) -> None:
        xs, ys, hs = x[s:e], y[s:e], h[s:e]
        lat, ko, fl = lateral[s:e], keep_out[s:e], floor[s:e]
        tmp = np.empty(e - s)
        _signed_distance_chunk(keep_in, xs, ys, lat)
        for k, extent in keep_outs:
            _signed_distance_chunk(k, xs, ys, tmp)
            np.negative(tmp, out=tmp)
            if extent is not None:
                extent.volume_margin_array(tmp, hs, out=tmp)
            np.minimum(ko, tmp, out=ko)
        for (ce, cn, r), extent in circles:
            np.hypot(xs - ce, ys - cn, out=tmp)
            np.subtract(tmp, r, out=tmp)
            if extent is not None:
                extent.volume_margin_array(tmp, hs, out=tmp)
            np.minimum(ko, tmp, out=ko)
        if keep_outs or circles:
            np.minimum(lat, ko, out=lat)
        np.subtract(ceiling_m, hs, out=ceiling[s:e])
        if floor_m is not None:
            np.subtract(hs, floor_m, out=fl)
            for g in gaps:
                _signed_distance_chunk(g, xs, ys, tmp)
                np.maximum(fl, tmp, out=fl)
        tot = total[s:e]
        np.minimum(lat, ceiling[s:e], out=tot)
        np.minimum(tot, fl, out=tot)

    _run_chunks(chunk, n, threads)
    return {"lateral": lateral, "keep_out": keep_out, "ceiling": ceiling, "floor": floor, "total": total}
