"""Graph searches compiled in one call: the lazy A*, the shortest-route tree to a goal, and a route's first leg.

Owns the binary heap of node indices by key (:func:`_key_less` ... :func:`_key_push`), the boxes of nodes
released by a lower bound of their keys (:func:`_box_key_bound`), the A* over a lazy graph with a segment grid
(:func:`_lazy_astar`), Dijkstra from a goal over the whole graph (:func:`_goal_tree`) and the first leg of a
route by that tree (:func:`_tree_first_leg`), and the key-ordered chunks of first legs of the planner's own
search (:func:`by_key_in_chunks`).
"""

from __future__ import annotations

import heapq
import math
from math import hypot
from typing import Iterator

import numpy as np

from geofence.jit import compiled, jitable
from geofence.recovery.graph import _file_row, _tangent_row
from geofence.recovery.segments import _element_blocks, _segment_blocker_grid, _segment_box, _segment_clear_grid


@jitable
def _key_less(keys: np.ndarray, a: int, b: int) -> bool:
    """Is ``(keys[a], a)`` before ``(keys[b], b)``: ascending key, ties by index (a stable sort's order)."""
    return keys[a] < keys[b] or (keys[a] == keys[b] and a < b)


@jitable
def _key_sift_down(heap: np.ndarray, keys: np.ndarray, pos: int, size: int) -> None:
    """Restore the binary min-heap ``heap[:size]`` of indices (ordered by :func:`_key_less`) below ``pos``."""
    while True:
        child = 2 * pos + 1
        if child >= size:
            return
        if child + 1 < size and _key_less(keys, heap[child + 1], heap[child]):
            child += 1
        if not _key_less(keys, heap[child], heap[pos]):
            return
        heap[child], heap[pos] = heap[pos], heap[child]
        pos = child


@jitable
def _key_sift_up(heap: np.ndarray, keys: np.ndarray, pos: int) -> None:
    """Restore the binary min-heap of :func:`_key_sift_down` above ``pos`` (a new entry there)."""
    while pos > 0:
        parent = (pos - 1) // 2
        if not _key_less(keys, heap[pos], heap[parent]):
            return
        heap[parent], heap[pos] = heap[pos], heap[parent]
        pos = parent


@jitable
def _key_pop(heap: np.ndarray, keys: np.ndarray, size: int) -> int:
    """Take the top of the binary min-heap ``heap[:size]`` (of :func:`_key_sift_down`); the heap is then
    ``heap[:size - 1]``."""
    top = heap[0]
    heap[0] = heap[size - 1]
    _key_sift_down(heap, keys, 0, size - 1)
    return top


@jitable
def _key_push(heap: np.ndarray, keys: np.ndarray, size: int, i: int) -> None:
    """Put ``i`` in the binary min-heap ``heap[:size]``; the heap is then ``heap[:size + 1]``."""
    heap[size] = i
    _key_sift_up(heap, keys, size)


@jitable
def _box_distance(x: float, y: float, box: np.ndarray, c: int) -> float:
    """Distance from (x, y) to box ``c`` (``xmin, xmax, ymin, ymax``): at most any of its nodes' (to round-off)."""
    dx = box[c, 0] - x if box[c, 0] > x else (x - box[c, 1] if x > box[c, 1] else 0.0)
    dy = box[c, 2] - y if box[c, 2] > y else (y - box[c, 3] if y > box[c, 3] else 0.0)
    return math.sqrt(dx * dx + dy * dy)


@jitable
def _box_key_bound(sx: float, sy: float, gx: float, gy: float, box: np.ndarray, c: int) -> float:
    """A lower bound of a first leg's key (straight length from the start plus straight length to the goal) over
    the nodes in box ``c`` (``xmin, xmax, ymin, ymax``), below the computed key by more than its round-off."""
    return (_box_distance(sx, sy, box, c) + _box_distance(gx, gy, box, c)) * (1.0 - 1e-12) - 1e-9


@jitable
def _heapify_boxes(blb: np.ndarray) -> np.ndarray:
    """The boxes ``0 .. len(blb) - 1`` as a heap by their lower bounds ``blb`` (:func:`_key_less`)."""
    nb = blb.shape[0]
    boxes = np.arange(nb)
    for pos in range(nb // 2 - 1, -1, -1):
        _key_sift_down(boxes, blb, pos, nb)
    return boxes


@jitable
def _release_boxes(
    sx: float, sy: float, gx: float, gy: float, P: np.ndarray, box_start: np.ndarray, box_items: np.ndarray,
    blb: np.ndarray, boxes: np.ndarray, n_boxes: int, open_key: float, leg: np.ndarray, keys: np.ndarray,
    cand: np.ndarray, size: int,
) -> tuple[int, int]:  # fmt: skip
    """:func:`_lazy_astar`'s release of the boxes whose nodes can come next: while the smallest box bound (heap
    ``boxes[:n_boxes]`` by ``blb``) is at most the smallest key waiting (first leg in ``cand[:size]``, or the
    open node's ``open_key``), its nodes get their first leg ``leg`` and key ``keys`` and join ``cand``.
    Returns ``(size, n_boxes)`` after.

    Every node left out has a key above that bound, so the next first leg and the choice between it and the
    next open node are those of a heap of every node, ties included."""
    while n_boxes > 0:
        bound = keys[cand[0]] if size > 0 else np.inf
        if open_key < bound:
            bound = open_key
        if blb[boxes[0]] > bound:
            break
        c = _key_pop(boxes, blb, n_boxes)
        n_boxes -= 1
        for p in range(box_start[c], box_start[c + 1]):
            i = box_items[p]
            ex = P[i, 0] - sx  # (square roots, as the planner's own lazy search keys them)
            ey = P[i, 1] - sy
            fx = P[i, 0] - gx
            fy = P[i, 1] - gy
            leg[i] = math.sqrt(ex * ex + ey * ey)
            keys[i] = leg[i] + math.sqrt(fx * fx + fy * fy)
            _key_push(cand, keys, size, i)
            size += 1
    return size, n_boxes


@jitable
def _best_node(touched: np.ndarray, n_touched: int, dist: np.ndarray, goal_d: np.ndarray) -> int:
    """The node of the smallest ``dist + goal_d`` among ``touched[:n_touched]``, the lowest index on a tie
    (np.argmin's); -1 when none is finite."""
    best = -1
    best_total = np.inf
    for k in range(n_touched):
        i = touched[k]
        total = dist[i] + goal_d[i]
        if total < best_total or (total == best_total and i < best):
            best_total = total
            best = i
    return best


@jitable
def _touch(touched: np.ndarray, n_touched: int, dist: np.ndarray, i: int) -> int:
    """Node ``i`` about to be given a distance: listed in ``touched`` if it had none. Returns ``n_touched``."""
    if dist[i] == np.inf:
        touched[n_touched] = i
        n_touched += 1
    return n_touched


@jitable
def _relax_row(
    i: int, d: float, gx: float, gy: float, P: np.ndarray, row_start: np.ndarray, row_len: np.ndarray,
    store_j: np.ndarray, store_w: np.ndarray, dist: np.ndarray, pred: np.ndarray, touched: np.ndarray,
    n_touched: int, open_: list,
) -> int:  # fmt: skip
    """:func:`_lazy_astar`'s expansion of node ``i`` at distance ``d``: each node of its row reached shorter
    through it gets that distance, ``i`` as predecessor, and joins the open heap ``open_`` keyed by the distance
    plus its straight length to the goal. Returns ``n_touched``."""
    at = row_start[i]
    for k in range(at, at + row_len[i]):
        j = store_j[k]
        nd = d + store_w[k]
        if nd < dist[j]:
            n_touched = _touch(touched, n_touched, dist, j)
            dist[j] = nd
            pred[j] = i
            heapq.heappush(open_, (nd + hypot(P[j, 0] - gx, P[j, 1] - gy), nd, j))
    return n_touched


@jitable
def _lazy_astar(
    sx: float, sy: float, gx: float, gy: float, thr: float, node_thr: float, P: np.ndarray, cones: np.ndarray,
    is_corner: np.ndarray, goal_d: np.ndarray, edges: np.ndarray, circles: np.ndarray, x0: float, y0: float,
    cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray, row_start: np.ndarray, row_len: np.ndarray,
    store_j: np.ndarray, store_w: np.ndarray, used: np.ndarray, box: np.ndarray, box_start: np.ndarray,
    box_items: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, int, int]:  # fmt: skip
    """The A* search of a lazy graph with a segment grid, from a start (sx, sy) in the free space
    towards the goal (gx, gy), in one compiled call: ``(dist, pred, first legs found, best node)`` (``first
    legs found`` -1: the edge store is full, grow it and call again; ``best node``: :func:`_best_node`).

    First legs are taken in key order (a heap of node indices by :func:`_key_less`, the stable sort's order)
    and tested as their key comes up, the open nodes in a heap of ``(key, distance, node)``. ``goal_d``: each
    node's straight length to the goal, infinite where it does not see it. A node's graph edges
    (:func:`~geofence.recovery.graph._tangent_row`'s candidates, clear at ``node_thr``) are found on its first
    expansion and kept in ``row_start``/``row_len`` (-1: not yet) over ``store_j``/``store_w`` (``used[0]``
    entries filled), across calls. The nodes join the first legs' heap box by box (``box``: rows ``xmin, xmax,
    ymin, ymax``; box ``c`` holds ``box_items[box_start[c]:box_start[c + 1]]``; :func:`_release_boxes`)."""
    n = P.shape[0]
    dist, pred, leg, keys = np.full(n, np.inf), np.full(n, -1, np.int64), np.empty(n), np.empty(n)
    touched, cand = np.empty(n, np.int64), np.empty(n, np.int64)  # touched: given a finite distance
    n_boxes, size, n_touched, n_first, best_goal = box.shape[0], 0, 0, 0, np.inf
    blb = np.empty(n_boxes)
    for c in range(n_boxes):
        blb[c] = _box_key_bound(sx, sy, gx, gy, box, c)
    boxes = _heapify_boxes(blb)
    open_ = [(0.0, 0.0, 0)]
    open_.pop()
    while True:
        open_key = open_[0][0] if len(open_) > 0 else np.inf
        size, n_boxes = _release_boxes(sx, sy, gx, gy, P, box_start, box_items, blb, boxes, n_boxes, open_key, leg,
                                       keys, cand, size)  # fmt: skip
        if size > 0 and (len(open_) == 0 or keys[cand[0]] < open_key):  # the next untested first leg first
            i = _key_pop(cand, keys, size)
            size -= 1
            key, d = keys[i], leg[i]
            if key >= best_goal:
                break
            if d >= dist[i] or not _segment_clear_grid(sx, sy, P[i, 0], P[i, 1], thr, edges, circles, x0, y0, cell,
                                                       nx, ny, start, items):  # fmt: skip
                continue
            n_touched = _touch(touched, n_touched, dist, i)
            dist[i], pred[i] = d, -1
            n_first += 1
        elif len(open_) > 0:
            key, d, i = heapq.heappop(open_)
            if d > dist[i]:
                continue
        else:
            break
        if key >= best_goal:
            break  # no open node can shorten the best route found to the goal
        if goal_d[i] < np.inf:
            best_goal = min(best_goal, d + goal_d[i])
        if row_start[i] < 0 and not _file_row(i, _tangent_row(i, P, cones, is_corner), P, node_thr, edges, circles,
                                              x0, y0, cell, nx, ny, start, items, row_start, row_len, store_j,
                                              store_w, used):  # fmt: skip
            return dist, pred, -1, -1  # node i's graph edges, found on its first expansion: the store is full
        n_touched = _relax_row(i, d, gx, gy, P, row_start, row_len, store_j, store_w, dist, pred, touched, n_touched,
                               open_)  # fmt: skip
    return dist, pred, n_first, _best_node(touched, n_touched, dist, goal_d)


@jitable
def _goal_tree(
    goal_d: np.ndarray, row_start: np.ndarray, row_len: np.ndarray, store_j: np.ndarray, store_w: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(D, nxt)``: every node's shortest route length to the goal over the graph (every row filed) and the next
    node on it (-1: straight to the goal; ``D`` infinite: no route). Dijkstra from the goal over the reversed
    edges: node ``v`` reaches the goal through ``u`` when ``u`` is in ``v``'s row (the forward search's edges,
    each with the length filed in ``v``'s row), starting from ``goal_d`` (the straight lengths of the nodes that
    see the goal)."""
    n = goal_d.shape[0]
    # the reversed rows: who has u in its row, and at what length
    rptr = np.zeros(n + 1, np.int64)
    for v in range(n):
        for k in range(row_start[v], row_start[v] + row_len[v]):
            rptr[store_j[k] + 1] += 1
    for u in range(n):
        rptr[u + 1] += rptr[u]
    fill = rptr[:n].copy()
    rsrc = np.empty(rptr[n], np.int64)
    rw = np.empty(rptr[n])
    for v in range(n):
        for k in range(row_start[v], row_start[v] + row_len[v]):
            u = store_j[k]
            rsrc[fill[u]] = v
            rw[fill[u]] = store_w[k]
            fill[u] += 1
    D = goal_d.copy()
    nxt = np.full(n, -1, np.int64)
    open_ = [(0.0, 0)]
    open_.pop()
    for i in range(n):
        if D[i] < np.inf:
            heapq.heappush(open_, (D[i], i))
    while len(open_) > 0:
        d, u = heapq.heappop(open_)
        if d > D[u]:
            continue
        for k in range(rptr[u], rptr[u + 1]):
            v = rsrc[k]
            nd = d + rw[k]
            if nd < D[v]:
                D[v] = nd
                nxt[v] = u
                heapq.heappush(open_, (nd, v))
    return D, nxt


@jitable
def _release_tree_boxes(
    sx: float, sy: float, P: np.ndarray, D: np.ndarray, box_start: np.ndarray, box_items: np.ndarray,
    blb: np.ndarray, boxes: np.ndarray, n_boxes: int, keys: np.ndarray, cand: np.ndarray, size: int,
) -> tuple[int, int]:  # fmt: skip
    """:func:`_tree_first_leg`'s release of the boxes whose nodes can come next: while the smallest box bound is
    finite and at most the smallest key waiting, its nodes with a route (``D`` finite) get their key ``leg + D``
    and join ``cand``. Returns ``(size, n_boxes)`` after."""
    while n_boxes > 0:
        if blb[boxes[0]] == np.inf or (size > 0 and blb[boxes[0]] > keys[cand[0]]):
            break
        c = _key_pop(boxes, blb, n_boxes)
        n_boxes -= 1
        for p in range(box_start[c], box_start[c + 1]):
            i = box_items[p]
            if D[i] == np.inf:
                continue
            ex = P[i, 0] - sx
            ey = P[i, 1] - sy
            keys[i] = math.sqrt(ex * ex + ey * ey) + D[i]
            _key_push(cand, keys, size, i)
            size += 1
    return size, n_boxes


@jitable
def _remember(recent: np.ndarray, n_recent: int, next_recent: int, k: int) -> tuple[int, int]:
    """Element ``k`` blocked a leg: kept in the ring ``recent`` (the last few blockers). Returns ``(n_recent,
    next_recent)`` after."""
    recent[next_recent] = k
    return (n_recent + 1 if n_recent < recent.shape[0] else n_recent), (next_recent + 1) % recent.shape[0]


@jitable
def _leg_blocked_nearby(
    sx: float, sy: float, ex: float, ey: float, thr: float, edges: np.ndarray, circles: np.ndarray, x0: float,
    y0: float, cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray, recent: np.ndarray,
    n_recent: int, next_recent: int,
) -> tuple[bool, int, int]:  # fmt: skip
    """Whether the leg (sx, sy) -> (ex, ey) is blocked at ``thr`` by an element that blocked one of the last legs
    (nearby legs share them) or by one filed in the end's own grid cell (a leg to a node is often blocked
    there, and that element is remembered): ``(blocked, n_recent, next_recent)``. Not blocked here is not
    clear: the caller tests the whole grid next."""
    box_i = _segment_box(sx, sy, ex, ey, thr)
    for r in range(n_recent):
        if _element_blocks(sx, sy, ex, ey, thr, box_i, edges, circles, recent[r]):
            return True, n_recent, next_recent
    ci = min(max(int((ex - x0) // cell), 0), nx - 1)
    cj = min(max(int((ey - y0) // cell), 0), ny - 1)
    c = cj * nx + ci
    for p in range(start[c], start[c + 1]):
        if _element_blocks(sx, sy, ex, ey, thr, box_i, edges, circles, items[p]):
            n_recent, next_recent = _remember(recent, n_recent, next_recent, items[p])
            return True, n_recent, next_recent
    return False, n_recent, next_recent


@jitable
def _tree_first_leg(
    sx: float, sy: float, thr: float, P: np.ndarray, D: np.ndarray, edges: np.ndarray, circles: np.ndarray,
    x0: float, y0: float, cell: float, nx: int, ny: int, start: np.ndarray, items: np.ndarray, box: np.ndarray,
    box_start: np.ndarray, box_items: np.ndarray, box_d: np.ndarray,
) -> int:  # fmt: skip
    """The node a shortest route from (sx, sy) (in the free space) leaves for: the first node, by ``(leg + D,
    index)``, whose straight leg from the start is clear at ``thr``; -1: none (no route to the goal from here).

    ``D``: :func:`_goal_tree`'s lengths. The nodes come in :func:`_lazy_astar`'s boxes, each released into
    the heap once its lower bound (the start's distance to the box, less its round-off, plus ``box_d``: the
    smallest ``D`` in it) is at most the smallest key waiting: the same order as a heap of every node. A route
    through any later node is no shorter, so with exact ``D`` no other node's first leg is tested."""
    n = P.shape[0]
    n_boxes = box.shape[0]
    blb = np.empty(n_boxes)
    for c in range(n_boxes):
        blb[c] = (_box_distance(sx, sy, box, c) + box_d[c]) * (1.0 - 1e-12) - 1e-9
    boxes = _heapify_boxes(blb)
    keys = np.empty(n)
    cand = np.empty(n, np.int64)
    size = 0
    recent = np.empty(8, np.int64)
    n_recent = next_recent = 0
    while True:
        size, n_boxes = _release_tree_boxes(sx, sy, P, D, box_start, box_items, blb, boxes, n_boxes, keys, cand, size)
        if size == 0:
            return -1
        i = _key_pop(cand, keys, size)
        size -= 1
        blocked, n_recent, next_recent = _leg_blocked_nearby(
            sx, sy, P[i, 0], P[i, 1], thr, edges, circles, x0, y0, cell, nx, ny, start, items, recent, n_recent,
            next_recent,
        )  # fmt: skip
        if blocked:
            continue
        k = _segment_blocker_grid(sx, sy, P[i, 0], P[i, 1], thr, edges, circles, x0, y0, cell, nx, ny, start, items)
        if k < 0:
            return i
        n_recent, next_recent = _remember(recent, n_recent, next_recent, k)


lazy_astar = compiled(_lazy_astar)
"""The compiled :func:`_lazy_astar`."""

goal_tree = compiled(_goal_tree)
"""The compiled :func:`_goal_tree`."""

tree_first_leg = compiled(_tree_first_leg)
"""The compiled :func:`_tree_first_leg`."""


def by_key_in_chunks(keys: np.ndarray, leg: np.ndarray, first: int = 64) -> Iterator[tuple[list, list, list]]:
    """``(keys, legs, nodes)`` lists in ascending key order (ties by node index, as a stable sort), a chunk at a
    time (the first ``first`` smallest, then twice as many each time): a search that stops early sorts a few."""
    n = len(keys)
    rest = np.arange(n)
    k = first
    while len(rest):
        if len(rest) > k:
            kth = np.partition(keys[rest], k)[k]
            take = keys[rest] < kth
            if not take.any():  # (k + 1 or more tied at the smallest key)
                take = keys[rest] <= kth
            chunk, rest = rest[take], rest[~take]
        else:
            chunk, rest = rest, rest[:0]
        chunk = chunk[np.argsort(keys[chunk], kind="stable")]
        yield keys[chunk].tolist(), leg[chunk].tolist(), chunk.tolist()
        k *= 2
