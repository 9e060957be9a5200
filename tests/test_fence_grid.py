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

from aircraft.profile import load_profile
from geofence.boundary_shift import activation_margins
from geofence.fence import Fence, KeepOutCircle
from geofence.fence_grid import SMALL_FENCE_ELEMENTS, FenceGrid
from geofence.geodesy import LocalFrame
from geofence.local_fence import FEATURE_KEEP_OUT_CIRCLE, LocalFence

FRAME = LocalFrame(47.0, 8.0, 400.0)
FW = load_profile("Tern").envelope
MC = load_profile("F450RD").envelope


def latlon(e, n):
    lat, lon, _ = FRAME.to_geodetic(e, n, FRAME.h0_m)
    return (lat, lon)


def _inside(poly: list[tuple[float, float]], x: float, y: float) -> bool:
    """Even-odd test of a point against a polygon's vertices (for the generator only)."""
    inside = False
    for (ax, ay), (bx, by) in zip(poly, poly[1:] + poly[:1]):
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            inside = not inside
    return inside


def random_fence(seed: int, n_vertices: int, n_squares: int, n_circles: int, dense: bool = False) -> Fence:
    rng = random.Random(seed)
    r0 = rng.uniform(300.0, 900.0) if not dense else rng.uniform(350.0, 700.0)
    keep_in = []
    for i in range(n_vertices):
        a = 2.0 * math.pi * i / n_vertices
        if dense:
            r = r0 * (1.0 + 0.2 * math.sin(3 * a + seed) + 0.03 * math.sin(29 * a)) + rng.uniform(-1.5, 1.5)
            if rng.random() < 0.01:  # a notch: sharp corners
                r -= rng.uniform(5.0, 25.0)
        else:
            r = r0 * (1.0 + 0.25 * math.sin(3 * a + seed) + 0.04 * rng.uniform(-1.0, 1.0))
        keep_in.append((r * math.cos(a), r * math.sin(a)))
    squares, circles, placed = [], [], []
    for _ in range(200):
        if len(squares) >= n_squares and len(circles) >= n_circles:
            break
        a, r = rng.uniform(0, 2 * math.pi), rng.uniform(0.0, 0.55 * r0)
        cx, cy, s = r * math.cos(a), r * math.sin(a), rng.uniform(8.0, 30.0)
        if any(math.hypot(cx - px, cy - py) < s + ps + 10.0 for px, py, ps in placed):
            continue
        if not _inside(keep_in, cx, cy):  # a narrow keep-in (a triangle) may not reach 0.55 r0 everywhere
            continue
        placed.append((cx, cy, s))
        if len(squares) < n_squares:
            t = rng.uniform(0, math.pi)
            cut = rng.randint(1, 12) if dense else 1  # sides cut into short edges
            corners = [(cx + s * math.cos(t + k * math.pi / 2), cy + s * math.sin(t + k * math.pi / 2)) for k in range(4)]
            pts = []
            for k in range(4):
                (ax, ay), (bx, by) = corners[k], corners[(k + 1) % 4]
                pts += [(ax + (bx - ax) * q / cut, ay + (by - ay) * q / cut) for q in range(cut)]
            squares.append(tuple(latlon(x, y) for x, y in pts))
        else:
            circles.append(KeepOutCircle(*latlon(cx, cy), s))
    return Fence(
        keep_in=tuple(latlon(e, n) for e, n in keep_in),
        ceiling_m=120.0,
        keep_out_polygons=tuple(squares),
        keep_out_circles=tuple(circles),
    )


def probe_points(local, rng: random.Random, count: int):
    """Points near vertices and edges (both sides), inside keep-outs, far inside and outside."""
    pts = []
    ki = local.keep_in
    for _ in range(count):
        kind = rng.randrange(5)
        if kind == 0:
            v = ki.vertices[rng.randrange(ki.n)]
            pts.append((v[0] + rng.gauss(0, 3.0), v[1] + rng.gauss(0, 3.0)))
        elif kind == 1:
            i = rng.randrange(ki.n)
            a, b = ki.starts[i], ki.ends[i]
            t = rng.random()
            o = ki.outward_normals[i] * rng.uniform(-40.0, 40.0)
            pts.append((a[0] + t * (b[0] - a[0]) + o[0], a[1] + t * (b[1] - a[1]) + o[1]))
        elif kind == 2 and local.keep_out_polygons:
            k = local.keep_out_polygons[rng.randrange(len(local.keep_out_polygons))]
            c = k.vertices.mean(axis=0)
            pts.append((c[0] + rng.uniform(-25, 25), c[1] + rng.uniform(-25, 25)))
        elif kind == 3 and local.keep_out_circles:
            ce, cn, r = local.keep_out_circles[rng.randrange(len(local.keep_out_circles))]
            pts.append((ce + rng.uniform(-1.5 * r, 1.5 * r), cn + rng.uniform(-1.5 * r, 1.5 * r)))
        else:
            pts.append((rng.uniform(-1500, 1500), rng.uniform(-1500, 1500)))
    return pts


def random_margin_call(
    rng: random.Random, e: float, n: float, env, *, bank_rad: float, wrap_heading: bool = False, rollout: bool = False
) -> tuple[tuple, dict]:
    """Random arguments of :func:`activation_margins` at (e, n): speed up to 1.2 x max in any course (with
    ``wrap_heading``, 1 in 5 at the ±pi wrap), wind up to 9 m/s, uncertainty, latency, bank up to ``bank_rad``,
    wind allowance and (with ``rollout``) a roll-out target: none, anywhere, or the point itself."""
    speed = rng.uniform(0.0, env.max_speed_mps * 1.2)
    course = rng.uniform(-math.pi, math.pi)
    if wrap_heading and rng.random() < 0.2:
        course = math.pi * rng.choice([1.0, -1.0]) * (1.0 - 1e-12 * rng.random())
    w, wd = rng.uniform(0.0, 9.0), rng.uniform(-math.pi, math.pi)
    args = (e, n, 30.0, speed * math.cos(course), speed * math.sin(course), rng.uniform(-3, 3), env)
    args += (w * math.cos(wd), w * math.sin(wd))
    kw = dict(
        h_uncertainty_m=rng.uniform(0, 6),
        v_uncertainty_m=1.0,
        latency_s=rng.uniform(0, 0.3),
        bank_rad=rng.uniform(-bank_rad, bank_rad),
        wind_extra_mps=rng.uniform(0, 3),
    )
    if rollout:
        kw["rollout_target_en"] = rng.choice([None, (rng.uniform(-300, 300), rng.uniform(-300, 300)), (e, n)])
    return args, kw


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


def dense_fence(seed: int, n_vertices: int, n_squares: int, n_circles: int) -> Fence:
    """A keep-in of closely spaced jagged vertices with notches, keep-out squares cut into short edges."""
    return random_fence(seed, n_vertices, n_squares, n_circles, dense=True)


def dense_states(local, rng: random.Random, count: int):
    """Points next to keep-in vertices (inside and out), next to and inside keep-outs, near circles."""
    ki = local.keep_in
    for _ in range(count):
        kind = rng.randrange(4)
        if kind == 0 or not (local.keep_out_polygons or local.keep_out_circles):
            v = ki.vertices[rng.randrange(ki.n)]
            inward = -ki.outward_normals[rng.randrange(ki.n)]
            depth = rng.choice([rng.uniform(-3.0, 3.0), rng.uniform(0.0, 120.0)])
            yield v[0] + inward[0] * depth + rng.gauss(0, 1.0), v[1] + inward[1] * depth + rng.gauss(0, 1.0)
        elif kind in (1, 2) and local.keep_out_polygons:
            k = local.keep_out_polygons[rng.randrange(len(local.keep_out_polygons))]
            v = k.vertices[rng.randrange(k.n)] if kind == 1 else k.vertices.mean(axis=0)
            yield v[0] + rng.uniform(-12.0, 12.0), v[1] + rng.uniform(-12.0, 12.0)
        elif local.keep_out_circles:
            ce, cn, r = local.keep_out_circles[rng.randrange(len(local.keep_out_circles))]
            yield ce + rng.uniform(-1.5 * r, 1.5 * r), cn + rng.uniform(-1.5 * r, 1.5 * r)


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
