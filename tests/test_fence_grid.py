"""Property: the fence index changes no answer.

On random fences (noisy star-shaped keep-ins of 40-600 vertices, keep-out squares and circles) and
random states (next to vertices and edges, inside keep-outs, outside the keep-in, far inside), the
indexed :meth:`LocalFence.lateral_margin_m` and :func:`activation_margins` equal the full scan
(``index=False``) bit for bit, for a multirotor and a fixed-wing in wind. The same on random dense ragged
fences (keep-ins of 1,500-4,000 vertices a metre or two apart with jagged noise and notches, keep-out squares
whose sides are cut into short edges, circles) and states next to vertices, inside keep-outs and around them:
the index's walk with the pruned search equals the reference (``prune_from_edges`` huge) and the full scan
(these are the Python branches, ``compiled=False``; ``tests/test_lateral_kernel.py`` holds the compiled search
to them).
"""

import math
import random

from hypothesis import given, settings
from hypothesis import strategies as st
from support import FRAME, FW, MC, dense_fence, dense_states, latlon, probe_points, random_fence, random_margin_call

from geofence.boundary_shift import activation_margins
from geofence.fence import Fence, KeepOutCircle
from geofence.fence_grid import SMALL_FENCE_ELEMENTS, FenceGrid
from geofence.local_fence import FEATURE_KEEP_OUT_CIRCLE, LocalFence


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
        for env in (MC, FW):
            args, kw = random_margin_call(rng, e, n, env, bank_rad=0.5)
            for compiled in (True, False):  # the compiled search and the Python walk (the reference)
                a = activation_margins(indexed, *args, **kw, compiled=compiled)
                b = activation_margins(scan, *args, **kw, compiled=compiled)
                assert tuple(a) == tuple(b), (e, n, env.kind, compiled)


def test_small_fences_are_scanned_and_large_ones_indexed():
    assert random_fence(1, 4, 0, 0).to_local(FRAME).grid() is None
    assert random_fence(1, SMALL_FENCE_ELEMENTS, 0, 0).to_local(FRAME).grid() is not None


def test_a_cell_is_rebuilt_for_a_larger_reach():
    local = random_fence(7, 300, 10, 3).to_local(FRAME, index=True)
    scan = random_fence(7, 300, 10, 3).to_local(FRAME, index=False)
    grid = local.grid()
    e, n = 0.7 * local.keep_in.vertices[0]
    near_small, d0 = grid.near(e, n, 5.0)
    near_big, d1 = grid.near(e, n, 2000.0)  # more than the cell was built for
    assert d0 == d1 == min(scan.lateral_margin_m(e, n), d0)
    assert len(near_big) > len(near_small)
    assert len(near_big) == local.grid().n_elements  # 2 km covers the whole fence


def test_the_binding_edge_beyond_the_nearest_one_is_kept():
    """Flying fast at an edge while close to another: the farther edge binds, and the index keeps it."""
    sq = [(-200.0, -200.0), (200.0, -200.0), (200.0, 200.0), (-200.0, 200.0)]
    fence = Fence(keep_in=tuple(latlon(e, n) for e, n in sq), ceiling_m=120.0)
    indexed, scan = fence.to_local(FRAME, index=True), fence.to_local(FRAME, index=False)
    for env, e, n, speed in ((MC, 185.0, -192.0, 12.0), (FW, 120.0, -190.0, 22.0)):
        args = (e, n, 30.0, speed, 0.0, 0.0, env, 0.0, 0.0)
        a, b = activation_margins(indexed, *args), activation_margins(scan, *args)
        assert a.edge == 1 and a.edge_distance_m > 14.0  # the east edge, not the nearer south one
        assert tuple(a) == tuple(b)


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


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(48, 400), prefix=st.integers(1, 40))
def test_candidates_past_the_tuple_prefix_give_the_same_answers(seed, n_vertices, prefix):
    """A cell keeps only its first candidates as tuples; the walk continues over the rest vectorised."""
    local = random_fence(seed, n_vertices, 8, 3).to_local(FRAME, index=True)
    full = local.grid()
    short = FenceGrid(
        local.danger_edges(),
        local.keep_out_circles,
        FEATURE_KEEP_OUT_CIRCLE,
        local.keep_in,
        local.keep_out_polygons,
        prefix_items=prefix,
    )
    rng = random.Random(seed)
    for e, n in probe_points(local, rng, 100):
        assert short.nearest_distance(e, n) == full.nearest_distance(e, n)
        reach = rng.uniform(0.0, 300.0)
        a_items, a_min = short.near(e, n, reach)
        b_items, b_min = full.near(e, n, reach)
        assert a_min == b_min
        # the walk may visit different supersets; what can bind (d - reach < d_min) must be identical
        assert [x for x in a_items if x[0] - reach < a_min] == [x for x in b_items if x[0] - reach < b_min]


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
            a = activation_margins(indexed, *args, **kw, compiled=False)
            ref = activation_margins(indexed, *args, **kw, prune_from_edges=10**9, compiled=False)
            full = activation_margins(scan, *args, **kw, compiled=False)
            assert tuple(a) == tuple(ref) == tuple(full), (e, n, env.kind)


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
    """A cell built from its block's elements (:meth:`FenceGrid._block_ids`, the blocks of a large fence) keeps
    the same candidates, bounds, containment and keep-out boxes as the pass over every element: at points near
    vertices, inside keep-outs, far inside and outside, for reaches from none to beyond a block."""
    local = random_fence(seed, n_vertices, n_squares, n_circles, dense=True).to_local(FRAME, index=True)
    args = (local.danger_edges(), local.keep_out_circles, FEATURE_KEEP_OUT_CIRCLE, local.keep_in, local.keep_out_polygons)
    line = local.line_scored_edges()
    blocks = FenceGrid(*args, line_edges=line, block_min_elements=0)
    full = FenceGrid(*args, line_edges=line, block_min_elements=10**9)
    rng = random.Random(seed + 3)
    for e, n in probe_points(local, rng, 120):
        a, b = blocks._cell(e, n, reach_m), full._cell(e, n, reach_m)
        assert a.ids.tolist() == b.ids.tolist() and a.lbs.tolist() == b.lbs.tolist(), (e, n)
        assert (a.built_for, a.cx, a.cy, a.u, a.ki_state, a.ko) == (b.built_for, b.cx, b.cy, b.u, b.ki_state, b.ko)
    assert blocks._blocks and not full._blocks
