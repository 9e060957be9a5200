"""Fast vectorized fence margins for long recorded arrays (numpy only), organised for throughput.

Each polygon's signed distance is :func:`geofence.geometry.polygon.signed_distances` (the one vectorised form of
the polygon's point query, which :meth:`~geofence.geometry.polygon.PolygonIndex.signed_distance_array` and the
``LocalFence.*_array`` methods run too) on chunks of the samples, and the chunks are shared between threads
(numpy releases the GIL inside its loops; chunks are large so that per-call overhead stays small).

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
from geofence.geometry.polygon import PolygonIndex, signed_distances

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
    _run_chunks(lambda s, e: signed_distances(poly.rows, x[s:e], y[s:e], out[s:e]), len(x), threads)
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
    keep_in = fence.keep_in.rows
    keep_outs = [(k.rows, x) for k, x in zip(fence.keep_out_polygons, _extents(fence.keep_out_polygon_extents))]
    circles = list(zip(fence.keep_out_circles, _extents(fence.keep_out_circle_extents)))
    gaps = [g.rows for g in fence.floor_gaps] if fence.floor_m is not None else []
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
        signed_distances(keep_in, xs, ys, lat)
        for k, extent in keep_outs:
            signed_distances(k, xs, ys, tmp)
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
                signed_distances(g, xs, ys, tmp)
                np.maximum(fl, tmp, out=fl)
        tot = total[s:e]
        np.minimum(lat, ceiling[s:e], out=tot)
        np.minimum(tot, fl, out=tot)

    _run_chunks(chunk, n, threads)
    return {"lateral": lateral, "keep_out": keep_out, "ceiling": ceiling, "floor": floor, "total": total}
