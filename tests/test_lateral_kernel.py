"""Properties of the compiled lateral search: its ties and its scan.

Where lateral elements tie exactly, the first in element order binds (with the index and without). The full
scan of the lateral margin (:func:`geofence.geometry.scan.lateral_margin_scan`) equals the vectorised margins
within 1e-9 m. One conformance test per compiled entry point: the compiled code is its own source interpreted
(``.py_func``), within 1e-9 relative. (The recovery planner's segment tests and route follower are held to
shapely and a Dijkstra oracle in ``tests/test_recovery_clear_vector.py``.)
"""

import math
import random
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support import (
    FRAME,
    FW,
    MC,
    close_fields,
    latlon,
    probe_points,
    random_fence,
    random_margin_call,
    same_margins,
)

from geofence.geometry.fence import Fence, KeepOutCircle
from geofence.jit import COMPILED
from geofence.margins.boundary_shift import activation_margins

ROOT = Path(__file__).resolve().parents[1]

needs_numba = pytest.mark.skipif(not COMPILED, reason="numba not installed, or NUMBA_DISABLE_JIT set (the kernels run as Python)")


def _square(cx: float, cy: float, s: float) -> tuple:
    return tuple(latlon(cx + x, cy + y) for x, y in ((-s, -s), (s, -s), (s, s), (-s, s)))


@pytest.mark.parametrize("index", [False, True])
def test_exact_ties_go_to_the_first_element(index):
    """Two identical keep-outs (every edge of the second ties one of the first, exactly) and, indexed, two
    identical circles: the first element wins, with the index and without."""
    keep_outs = (_square(0.0, 120.0, 20.0), _square(0.0, 120.0, 20.0))
    fence = Fence(keep_in=_square(0.0, 0.0, 300.0), ceiling_m=120.0, keep_out_polygons=keep_outs)
    if index:
        fence = Fence(
            keep_in=tuple(latlon(300.0 * math.cos(a), 300.0 * math.sin(a)) for a in (2 * math.pi * k / 64 for k in range(64))),
            ceiling_m=120.0,
            keep_out_polygons=keep_outs,
            keep_out_circles=(KeepOutCircle(*latlon(0.0, -120.0), 20.0), KeepOutCircle(*latlon(0.0, -120.0), 20.0)),
        )
    local = fence.to_local(FRAME, index=index)
    other = fence.to_local(FRAME, index=not index)
    assert (local.grid() is not None) == index
    rng = random.Random(5)
    states = [(0.0, 0.0, 0.0, 0.0), (0.0, 60.0, 0.0, 0.0), (0.0, 60.0, 0.0, 10.0), (0.0, -60.0, 0.0, -10.0)]
    states += [(rng.uniform(-5, 5), 60.0 + rng.uniform(-5, 5), 0.0, rng.uniform(0, 20)) for _ in range(20)]
    tied = []
    for e, n, ve, vn in states:
        for env in (MC, FW):
            for wind in ((0.0, 0.0), (0.0, 4.0)):
                args = (e, n, 30.0, ve, vn, 0.0, env, *wind)
                a = activation_margins(local, *args)
                assert same_margins(a, activation_margins(other, *args)), (e, n, ve, vn, env.kind, wind)
                if a.feature == "keep_out_polygon":
                    tied.append(a)
    # the duplicate keep-out's edges tie exactly with the first's: the first keep-out binds
    assert tied and all(r.feature_index == 0 for r in tied)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(3, 300), n_squares=st.integers(0, 20), n_circles=st.integers(0, 6))
def test_the_lateral_scan_equals_the_vectorised_margins(seed, n_vertices, n_squares, n_circles):
    """The full scan of the lateral margin (keep-in, keep-out polygons, circles) equals
    :meth:`LocalFence.lateral_margin_array` (numpy over every polygon) within 1e-9 m at points next to vertices
    and edges, inside keep-outs and outside the keep-in."""
    local = random_fence(seed, n_vertices, n_squares, n_circles).to_local(FRAME, index=False)
    rng = random.Random(seed)
    points = probe_points(local, rng, 200)
    want = local.lateral_margin_array(points)
    got = [local.lateral_margin_scan_m(e, n) for e, n in points]
    assert np.allclose(got, want, rtol=0.0, atol=1e-9)
    assert {bool(m > 0.0) for m in got} == {True, False}  # inside and breached points both checked


# ------------------------------------------------------------------ conformance: each compiled entry point is its source


def _binding_arguments(local, env, rng: random.Random, e: float, n: float) -> tuple:
    """:func:`lateral_binding`'s arguments at (e, n) for a random state, by the public per-state terms."""
    from geofence.margins.kernel import envelope_terms, state_terms

    args, kw = random_margin_call(rng, e, n, env, bank_rad=0.7, wrap_heading=True)
    _, _, _, ve, vn, vu, _, we, wn = args
    re, rn = local.recovery_en
    T = state_terms(
        envelope_terms(env), ve, vn, vu, we, wn, kw["h_uncertainty_m"], kw["latency_s"], kw["bank_rad"],
        kw["wind_extra_mps"], re - e, rn - n, 9.80665,
    )  # fmt: skip
    E, _meta, ids, zeros = local.element_table()
    fixed_wing = T.env.fixed_wing != 0.0
    line = local.line_scored_edges()
    return (E, ids, zeros, False, e, n, T.bound, 0.0, line, True, fixed_wing, T.env, T.state, T.turn, T.brake, T.turns)


@needs_numba
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(4, 300), n_squares=st.integers(0, 10), n_circles=st.integers(0, 4))
def test_lateral_binding_compiled_is_its_python_source(seed, n_vertices, n_squares, n_circles):
    from geofence.margins.lateral import lateral_binding

    local = random_fence(seed, n_vertices, n_squares, n_circles).to_local(FRAME)
    rng = random.Random(seed)
    for e, n in probe_points(local, rng, 30):
        for env in (MC, FW):
            args = _binding_arguments(local, env, rng, e, n)
            assert close_fields(lateral_binding(*args), lateral_binding.py_func(*args), 1e-9), (e, n, env.kind)


@needs_numba
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(60, 600), n_circles=st.integers(0, 4))
def test_nearest_distance_compiled_is_its_python_source(seed, n_vertices, n_circles):
    from geofence.geometry.elements import nearest_distance

    local = random_fence(seed, n_vertices, 3, n_circles).to_local(FRAME, index=True)
    grid = local.grid()
    rng = random.Random(seed)
    for e, n in probe_points(local, rng, 30):
        ids, lbs, delta = grid.candidates(e, n, 0.0)
        args = (grid.table, ids, lbs, delta, e, n)
        assert close_fields((nearest_distance(*args),), (nearest_distance.py_func(*args),), 1e-9), (e, n)


@needs_numba
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(4, 300), n_squares=st.integers(0, 10), n_circles=st.integers(0, 4))
def test_the_lateral_margin_scans_compiled_are_their_python_source(seed, n_vertices, n_squares, n_circles):
    """:func:`geofence.geometry.scan.lateral_margin_scan` and :func:`~geofence.geometry.scan.deepest_polygon`."""
    from geofence.geometry.scan import deepest_polygon, lateral_margin_scan

    local = random_fence(seed, n_vertices, n_squares, n_circles).to_local(FRAME)
    tables = local.scan_tables()
    rng = random.Random(seed)
    for e, n in probe_points(local, rng, 30):
        scan = (e, n, *tables)
        assert close_fields((lateral_margin_scan(*scan),), (lateral_margin_scan.py_func(*scan),), 1e-9), (e, n)
        deep = (e, n, tables[1], tables[2])  # the keep-out polygons as the polygons to be deepest in
        assert close_fields(deepest_polygon(*deep), deepest_polygon.py_func(*deep), 1e-9), (e, n)
