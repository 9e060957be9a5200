"""Property: the recovery planner's vectorized segment test gives the scalar loop's verdict, and the same routes.

:meth:`RecoveryPlanner._clear_one` tests the boundary edges in a segment's bounding box with
:func:`geofence.recovery_path._edges_block_np` once there are ``VECTOR_FROM_EDGES`` of them; with
``vector_from`` above every count it loops over them in Python (the reference). Random fences of a few
hundred edges (so the bounding-box prefilter is on), random segments -- ends on and next to keep-in
corners, inside keep-outs, outside the keep-in, zero-length, along an edge -- and clearances: the same
boolean must come out. Also, whole routes: :meth:`RecoveryPlanner.plan` from a planner that never
vectorizes gives the same points, bit for bit.
"""

import math
import random

from hypothesis import given, settings
from hypothesis import strategies as st

import geofence.recovery_path as rp
from geofence.fence import Fence, KeepOutCircle
from geofence.geodesy import LocalFrame

FRAME = LocalFrame(47.0, 8.0, 400.0)
NEVER = 10**9


def _fence(seed: int, n_vertices: int, n_squares: int, n_circles: int):
    rng = random.Random(seed)

    def ll(e: float, n: float) -> tuple[float, float]:
        lat, lon, _ = FRAME.to_geodetic(e, n, FRAME.h0_m)
        return lat, lon

    keep_in = []
    for i in range(n_vertices):
        a = 2.0 * math.pi * i / n_vertices
        r = 600.0 * (1.0 + 0.2 * math.sin(5.0 * a) + rng.uniform(-0.04, 0.04))
        keep_in.append(ll(r * math.cos(a), r * math.sin(a)))
    squares, circles = [], []
    for _ in range(n_squares):
        cx, cy, s, t = rng.uniform(-300, 300), rng.uniform(-300, 300), rng.uniform(5, 25), rng.uniform(0, math.pi / 2)
        squares.append(
            tuple(ll(cx + s * math.cos(t + k * math.pi / 2), cy + s * math.sin(t + k * math.pi / 2)) for k in range(4))
        )
    for _ in range(n_circles):
        circles.append(KeepOutCircle(*ll(rng.uniform(-300, 300), rng.uniform(-300, 300)), rng.uniform(5, 30)))
    f = Fence(keep_in=tuple(keep_in), ceiling_m=120.0, keep_out_polygons=tuple(squares), keep_out_circles=tuple(circles))
    return f.to_local(FRAME)


def _point(rng: random.Random, lf) -> tuple[float, float]:
    kind = rng.randrange(5)
    v = lf.keep_in.vertices
    if kind == 0:  # a keep-in corner, or right next to it
        p = v[rng.randrange(len(v))]
        eps = rng.choice([0.0, 1e-9, 1e-3, 0.5])
        return float(p[0]) + eps * rng.uniform(-1, 1), float(p[1]) + eps * rng.uniform(-1, 1)
    if kind == 1 and lf.keep_out_polygons:  # inside (or on a corner of) a keep-out
        k = lf.keep_out_polygons[rng.randrange(len(lf.keep_out_polygons))].vertices
        w = [rng.random() for _ in range(len(k))]
        return float(sum(wi * k[i, 0] for i, wi in enumerate(w)) / sum(w)), float(
            sum(wi * k[i, 1] for i, wi in enumerate(w)) / sum(w)
        )
    if kind == 2:  # on an edge of the keep-in
        i = rng.randrange(len(v))
        a, b, t = v[i - 1], v[i], rng.random()
        return float(a[0] + t * (b[0] - a[0])), float(a[1] + t * (b[1] - a[1]))
    return rng.uniform(-800, 800), rng.uniform(-800, 800)  # anywhere, also outside the keep-in


@settings(max_examples=15, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n_vertices=st.integers(270, 700),
    n_squares=st.integers(0, 20),
    n_circles=st.integers(0, 4),
)
def test_vectorized_segment_test_equals_the_loop(seed, n_vertices, n_squares, n_circles):
    lf = _fence(seed, n_vertices, n_squares, n_circles)
    planner = rp.RecoveryPlanner(lf, 5.0, lazy=True)
    assert len(planner._edges) > rp.BBOX_PREFILTER_EDGES
    rng = random.Random(seed + 1)
    for _ in range(150):
        p = _point(rng, lf)
        u = rng.random()
        if u < 0.05:
            q = p
        elif u < 0.5:  # short segments: most of them clear
            a, r = rng.uniform(0, 2 * math.pi), rng.uniform(1.0, 80.0)
            q = (p[0] + r * math.cos(a), p[1] + r * math.sin(a))
        else:
            q = _point(rng, lf)
        thr = rng.choice([1e-9, 0.01, rng.uniform(0.1, 10.0), rng.uniform(0.1, 60.0)])
        ref = planner._clear_one(p, q, thr, vector_from=NEVER)
        for vf in (0, 1, rp.VECTOR_FROM_EDGES):
            assert planner._clear_one(p, q, thr, vector_from=vf) is ref, (p, q, thr, vf)


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(270, 500), n_squares=st.integers(0, 15))
def test_routes_are_the_same_with_and_without_the_vectorized_test(seed, n_vertices, n_squares):
    lf = _fence(seed, n_vertices, n_squares, 1)
    fast = rp.RecoveryPlanner(lf, 6.0, lazy=True)
    old = rp.VECTOR_FROM_EDGES
    rp.VECTOR_FROM_EDGES = NEVER
    try:
        ref = rp.RecoveryPlanner(lf, 6.0, lazy=True)
        rng = random.Random(seed + 2)
        starts = [_point(rng, lf) for _ in range(6)]
        goal = lf.recovery_en
        ref_routes = [ref.plan(s, goal) for s in starts]
        ref_safe = [(p.east_m, p.north_m, p.clearance_m) for p in ref.safe_points()]
    finally:
        rp.VECTOR_FROM_EDGES = old
    assert [(p.east_m, p.north_m, p.clearance_m) for p in fast.safe_points()] == ref_safe
    for s, r in zip(starts, ref_routes):
        got = fast.plan(s, goal)
        if r is None:
            assert got is None
        else:
            assert got.points == r.points and got.reached_goal == r.reached_goal and got.first_leg_floor_m == r.first_leg_floor_m
