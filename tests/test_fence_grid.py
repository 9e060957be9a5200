"""Property: the fence index changes no answer.

On random fences (noisy star-shaped keep-ins of 40-600 vertices, keep-out squares and circles) and
random states (next to vertices and edges, inside keep-outs, outside the keep-in, far inside), the
indexed :meth:`LocalFence.lateral_margin_m` equals the full scan (``index=False``) exactly, and a cell's
candidates hold every element that can bind (brute force over every element). On random dense ragged fences
(keep-ins of 1,500-4,000 vertices a metre or two apart with jagged noise and notches, keep-out squares whose
sides are cut into short edges, circles) and states next to vertices, inside keep-outs and around them,
:func:`activation_margins` with the index equals the full scan's (``tests/test_margin_brute_force.py`` holds the
same on the sparse fences).
"""

import math
import random

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from support import (
    FRAME,
    FW,
    MC,
    dense_fence,
    dense_states,
    latlon,
    probe_points,
    random_fence,
    random_margin_call,
    same_margins,
)

from geofence.geometry.fence import Fence, KeepOutCircle
from geofence.geometry.fence_grid import SMALL_FENCE_ELEMENTS, FenceGrid
from geofence.geometry.local_fence import LocalFence
from geofence.margins.boundary_shift import activation_margins


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(40, 600), n_squares=st.integers(0, 25), n_circles=st.integers(0, 8))
def test_index_equals_full_scan(seed, n_vertices, n_squares, n_circles):
    fence = random_fence(seed, n_vertices, n_squares, n_circles)
    indexed = fence.to_local(FRAME, index=True)
    scan = fence.to_local(FRAME, index=False)
    assert indexed.grid() is not None and scan.grid() is None
    rng = random.Random(seed)
    for e, n in probe_points(indexed, rng, 150):
        assert indexed.lateral_margin_m(e, n) == scan.lateral_margin_m(e, n), (e, n)


def element_distances(local, e: float, n: float) -> tuple[np.ndarray, np.ndarray]:
    """``(d, scored d)`` of every lateral element from (e, n), by numpy: the point-segment distance of each edge
    (a line-scored edge scored at its line distance where the foot lies off it and that is positive), a circle's
    ``hypot - radius``."""
    E = local.element_table()[0]
    edge = E[:, 4] >= 0.0
    px, py = e - E[:, 0], n - E[:, 1]
    t = (px * E[:, 2] + py * E[:, 3]) * E[:, 4]
    tc = np.clip(t, 0.0, 1.0)
    d = np.where(edge, np.hypot(px - tc * E[:, 2], py - tc * E[:, 3]), np.hypot(px, py) - E[:, 2])
    line_d = -(px * E[:, 5] + py * E[:, 6])
    line = (np.arange(len(E)) < local.line_scored_edges()) & ((t < 0.0) | (t > 1.0)) & (line_d > 0.0)
    return d, np.where(line, line_d, d)


def convex_fence(seed: int, n_vertices: int) -> Fence:
    """An ellipse divided into ``n_vertices`` edges (a convex keep-in: its edges are line-scored)."""
    rng = random.Random(seed)
    r, aspect = rng.uniform(300.0, 2000.0), rng.uniform(0.3, 1.0)
    pts = [(r * math.cos(a), aspect * r * math.sin(a)) for a in (2 * math.pi * k / n_vertices for k in range(n_vertices))]
    return Fence(keep_in=tuple(latlon(x, y) for x, y in pts), ceiling_m=120.0)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(48, 600), n_circles=st.integers(0, 6), convex=st.booleans())
def test_a_cell_holds_every_element_that_can_bind(seed, n_vertices, n_circles, convex):
    """The walk over a cell's candidates (sorted by their bounds, stopped once the bound less the reach exceeds
    the nearest distance) reaches every element whose scored distance less the reach is below the nearest
    distance, by the brute force over every element, on star-shaped fences with keep-outs and on convex ones
    (whose edges far along a side are scored at their line distance, far below their distance); and the
    compiled nearest distance is the brute force's."""
    fence = convex_fence(seed, n_vertices) if convex else random_fence(seed, n_vertices, 10, n_circles)
    local = fence.to_local(FRAME, index=True)
    assert (local.line_scored_edges() > 0) == convex or not convex
    grid = local.grid()
    rng = random.Random(seed)
    for e, n in probe_points(local, rng, 150):
        d, scored = element_distances(local, e, n)
        d_min = float(d.min())
        assert abs(grid.nearest_distance(e, n) - d_min) <= 1e-9 * (1.0 + abs(d_min)), (e, n)
        reach = rng.choice([0.0, rng.uniform(0.0, 300.0), rng.uniform(300.0, 1500.0)])
        ids, lbs, delta = grid.candidates(e, n, reach)
        walked = set(ids[lbs - delta - reach <= d_min + 1e-9].tolist())
        assert set(np.flatnonzero(scored - reach < d_min).tolist()) <= walked, (e, n, reach)


def test_small_fences_are_scanned_and_large_ones_indexed():
    assert random_fence(1, 4, 0, 0).to_local(FRAME).grid() is None
    assert random_fence(1, SMALL_FENCE_ELEMENTS, 0, 0).to_local(FRAME).grid() is not None


def test_a_cell_is_rebuilt_for_a_larger_reach():
    local = random_fence(7, 300, 10, 3).to_local(FRAME, index=True)
    grid = local.grid()
    e, n = 0.7 * local.keep_in.vertices[0]
    small = grid.candidates(e, n, 5.0)[0]
    big = grid.candidates(e, n, 2000.0)[0]  # more than the cell was built for
    assert len(big) > len(small)
    assert len(big) == grid.n_elements  # 2 km covers the whole fence


def test_the_binding_edge_beyond_the_nearest_one_is_kept():
    """Flying fast at an edge while close to another: the farther edge binds, and the index keeps it."""
    sq = [(-200.0, -200.0), (200.0, -200.0), (200.0, 200.0), (-200.0, 200.0)]
    fence = Fence(keep_in=tuple(latlon(e, n) for e, n in sq), ceiling_m=120.0)
    indexed, scan = fence.to_local(FRAME, index=True), fence.to_local(FRAME, index=False)
    for env, e, n, speed in ((MC, 185.0, -192.0, 12.0), (FW, 120.0, -190.0, 22.0)):
        args = (e, n, 30.0, speed, 0.0, 0.0, env, 0.0, 0.0)
        a, b = activation_margins(indexed, *args), activation_margins(scan, *args)
        assert a.edge == 1 and a.edge_distance_m > 14.0  # the east edge, not the nearer south one
        assert same_margins(a, b)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(48, 400), n_squares=st.integers(0, 20))
def test_lower_bound_and_exceeds_agree_with_the_margin(seed, n_vertices, n_squares):
    fence = random_fence(seed, n_vertices, n_squares, 2)
    local, scan = fence.to_local(FRAME, index=True), fence.to_local(FRAME, index=False)
    rng = random.Random(seed)
    for e, n in probe_points(local, rng, 120):
        m = scan.lateral_margin_m(e, n)
        lb = local.grid().margin_lower_bound(e, n)
        assert lb is None or lb <= m + 1e-9
        for x in (m - 1.0, m - 1e-6, m + 1e-6, m + 5.0, 0.0):
            assert local.lateral_margin_exceeds(e, n, x) == (m > x)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(4, 300), index=st.booleans(), step_m=st.floats(0.01, 30.0))
def test_exceeds_from_the_last_margin_agrees_along_a_walk(seed, n_vertices, index, step_m):
    """Along a walk of small steps the answer often comes from the previous step's margin (1-Lipschitz
    bound); it must be the margin's own answer at every step, at thresholds on both sides of it."""
    fence = random_fence(seed, n_vertices, 4, 2)
    local, scan = fence.to_local(FRAME, index=index), fence.to_local(FRAME, index=False)
    rng = random.Random(seed)
    e, n = next(iter(probe_points(local, rng, 1)))
    for _ in range(60):
        e, n = e + rng.uniform(-step_m, step_m), n + rng.uniform(-step_m, step_m)
        m = scan.lateral_margin_m(e, n)
        x = m + rng.choice((-2.0, -1e-5, 1e-5, 2.0, 2.0 * step_m))
        assert local.lateral_margin_exceeds(e, n, x) == (m > x)
        if rng.random() < 0.7:  # the unit's margins then ask for the margin itself (the next step's bound)
            assert local.lateral_margin_m(e, n) == m


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n_vertices=st.integers(1500, 4000),
    n_squares=st.integers(0, 12),
    n_circles=st.integers(0, 4),
)
def test_dense_fences_indexed_equal_the_reference(seed, n_vertices, n_squares, n_circles):
    fence = dense_fence(seed, n_vertices, n_squares, n_circles)
    indexed = LocalFence(fence, FRAME, index=True)
    scan = fence.to_local(FRAME, index=False)
    rng = random.Random(seed)
    for e, n in dense_states(indexed, rng, 60):
        for env in (FW, MC):
            args, kw = random_margin_call(rng, e, n, env, bank_rad=0.7, wrap_heading=True, rollout=True)
            a = activation_margins(indexed, *args, **kw)
            full = activation_margins(scan, *args, **kw)
            assert same_margins(a, full), (e, n, env.kind)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_squares=st.integers(1, 60), n_circles=st.integers(0, 10))
def test_margins_inside_overlapping_keep_outs_equal_the_full_scan(seed, n_squares, n_circles):
    """A dense city: keep-out squares and circles that overlap one another; points inside one or several of
    them, on their edges, just outside: the index answers inside keep-outs itself (the deepest negated
    depth) and must give the full scan's number."""
    rng = random.Random(seed)
    keep_in = tuple(latlon(400.0 * math.cos(a), 400.0 * math.sin(a)) for a in (2 * math.pi * k / 60 for k in range(60)))
    centres = [(rng.uniform(-150, 150), rng.uniform(-150, 150)) for _ in range(n_squares + n_circles)]
    squares = []
    for cx, cy in centres[:n_squares]:
        s, t = rng.uniform(5.0, 40.0), rng.uniform(0.0, math.pi)
        squares.append(
            tuple(latlon(cx + s * math.cos(t + k * math.pi / 2), cy + s * math.sin(t + k * math.pi / 2)) for k in range(4))
        )
    circles = tuple(KeepOutCircle(*latlon(cx, cy), rng.uniform(3.0, 30.0)) for cx, cy in centres[n_squares:])
    fence = Fence(keep_in=keep_in, ceiling_m=120.0, keep_out_polygons=tuple(squares), keep_out_circles=circles)
    indexed, scan = fence.to_local(FRAME, index=True), fence.to_local(FRAME, index=False)
    inside = 0
    for _ in range(300):
        if rng.random() < 0.5 and indexed.keep_out_polygons:
            k = indexed.keep_out_polygons[rng.randrange(len(indexed.keep_out_polygons))]
            v = k.vertices[rng.randrange(k.n)] if rng.random() < 0.5 else k.vertices.mean(axis=0)
            e, n = v[0] + rng.uniform(-20.0, 20.0), v[1] + rng.uniform(-20.0, 20.0)
        else:
            e, n = rng.uniform(-200, 200), rng.uniform(-200, 200)
        m = scan.lateral_margin_m(e, n)
        assert indexed.lateral_margin_m(e, n) == m, (e, n)
        inside += m < 0.0
    assert inside > 0


@settings(max_examples=10, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n_vertices=st.integers(300, 2500),
    n_squares=st.integers(0, 30),
    n_circles=st.integers(0, 8),
    reach_m=st.sampled_from([0.0, 30.0, 170.0, 600.0]),
)
def test_cells_built_from_their_block_are_the_cells_of_the_full_pass(seed, n_vertices, n_squares, n_circles, reach_m):
    """A cell built from its block's elements (:meth:`FenceGrid.blocks_built`, the blocks of a large fence) keeps
    the same candidates, bounds, containment and keep-out boxes as the pass over every element: at points near
    vertices, inside keep-outs, far inside and outside, for reaches from none to beyond a block."""
    local = random_fence(seed, n_vertices, n_squares, n_circles, dense=True).to_local(FRAME, index=True)
    args = (local.danger_edges(), local.keep_out_circles, local.keep_in, local.keep_out_polygons)
    line = local.line_scored_edges()
    blocks = FenceGrid(*args, line_edges=line, block_min_elements=0)
    full = FenceGrid(*args, line_edges=line, block_min_elements=10**9)
    rng = random.Random(seed + 3)
    for e, n in probe_points(local, rng, 120):
        a, b = blocks.cell_at(e, n, reach_m), full.cell_at(e, n, reach_m)
        assert a.ids.tolist() == b.ids.tolist() and a.lbs.tolist() == b.lbs.tolist(), (e, n)
        assert (a.built_for, a.cx, a.cy, a.u, a.ki_state, a.ko) == (b.built_for, b.cx, b.cy, b.u, b.ki_state, b.ko)
    assert blocks.blocks_built > 0 and full.blocks_built == 0
