"""Properties of the compiled margins (:mod:`geofence.margins.kernel`) beyond the lateral rooms.

On random fences with keep-outs, a floor and floor gaps, at states above and below the floor, inside and outside
gaps, near the ceiling, climbing and descending, for both platform kinds, the fields of the :class:`ShiftResult`
agree with independent answers: the plain margins with the vectorised margins of the fence
(:meth:`LocalFence.lateral_margin_array`, :meth:`~LocalFence.floor_margin_array`), the ceiling's shift with the
arrest distance, the activation with the smaller of its lateral and vertical parts, the floor's with the larger
of the descent's arrest margin and (over a gap) the gap's room; and the lateral margin the kernel found is the
fence's remembered answer. A monitoring unit's step in one call (the skip shortcut, then the margins) answers as
its plain-Python shortcut does. One conformance test per compiled entry point (``.py_func``, 1e-9 relative).
"""

import math
import random

import pytest
from hypothesis import example, given, settings
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

from geofence.geometry.fence import Fence
from geofence.jit import COMPILED
from geofence.margins import boundary_shift
from geofence.margins.boundary_shift import activation_margins
from geofence.margins.kernel import envelope_terms, indexed_margins, margins, monitor_margins, room_bound
from geofence.physics.rooms import vertical_arrest_distance_m

TOL_M = 1e-9


def fence_with_gaps(seed: int, n_vertices: int, n_squares: int, n_circles: int, n_gaps: int) -> Fence:
    """A random fence (``random_fence``) with a floor at 20 m and up to ``n_gaps`` square gaps near the centre."""
    base = random_fence(seed, n_vertices, n_squares, n_circles)
    rng = random.Random(seed + 1)
    gaps = []
    for k in range(n_gaps):
        cx, cy, s = rng.uniform(-60, 60), rng.uniform(-60, 60), rng.uniform(10, 25)
        gaps.append(tuple(latlon(cx + x, cy + y) for x, y in ((-s, -s), (s, -s), (s, s), (-s, s))))
    return Fence(
        keep_in=base.keep_in,
        ceiling_m=base.ceiling_m,
        keep_out_polygons=base.keep_out_polygons,
        keep_out_circles=base.keep_out_circles,
        floor_m=20.0,
        floor_gaps=tuple(gaps),
    )


SMALL_FENCES = dict(
    seed=st.integers(0, 10_000),
    n_vertices=st.integers(4, 24),
    n_squares=st.integers(0, 3),
    n_circles=st.integers(0, 3),
    n_gaps=st.integers(0, 3),
)
"""Random fences a flight scans in full (no index): their shapes, keep-outs and floor gaps."""


def check_fields(local, r, e: float, n: float, h: float, vu: float, env, kw: dict) -> None:
    """The fields of ``r`` (the margins at (e, n, h)) against the fence's own and closed-form answers."""
    lat = float(local.lateral_margin_array([(e, n)])[0])
    assert local.lateral_margin_m(e, n) == r.lateral_margin_m  # remembered
    assert abs(r.lateral_margin_m - lat) <= TOL_M
    assert r.lateral_activation_m <= r.lateral_margin_m
    assert r.ceiling_margin_m == local.ceiling_m - h
    t_r = env.reaction_time_s + kw["latency_s"]
    climb = vertical_arrest_distance_m(vu, t_r, env.vertical_accel_mps2, env.max_climb_rate_mps)
    assert abs(r.ceiling_shift_m - (climb + kw["v_uncertainty_m"])) <= TOL_M
    assert r.activation_margin_m == min(r.lateral_activation_m, r.vertical_activation_m)
    ceiling_act = r.ceiling_margin_m - r.ceiling_shift_m
    if local.floor_m is None:
        assert r.floor_margin_m == math.inf and r.vertical_activation_m == ceiling_act
        return
    floor_m = float(local.floor_margin_array([(e, n)], [h])[0])
    assert abs(r.floor_margin_m - floor_m) <= TOL_M
    dive = vertical_arrest_distance_m(-vu, t_r, env.vertical_accel_mps2, env.max_descent_rate_mps)
    arrest = h - local.floor_m - dive - kw["v_uncertainty_m"]
    floor_act = r.floor_margin_m - r.floor_shift_m
    gap = float(local.gap_distance_array([(e, n)])[0]) if local.floor_gaps else -math.inf
    assert floor_act >= arrest - TOL_M  # the larger of the arrest margin and the gap's
    assert floor_act <= max(arrest, gap) + TOL_M  # the gap's no larger than how deep inside it the point is
    if gap <= 0.0:
        assert abs(floor_act - arrest) <= TOL_M
    assert abs(r.vertical_activation_m - min(ceiling_act, floor_act)) <= TOL_M


@settings(max_examples=25, deadline=None)
@given(**SMALL_FENCES, floor=st.booleans())
@example(seed=5004, n_vertices=15, n_squares=1, n_circles=1, n_gaps=2, floor=True)  # a tie at a keep-out's corner
def test_the_margins_agree_with_the_fences_own_answers(seed, n_vertices, n_squares, n_circles, n_gaps, floor):
    fence = (
        fence_with_gaps(seed, n_vertices, n_squares, n_circles, n_gaps)
        if floor
        else random_fence(seed, n_vertices, n_squares, n_circles)
    )
    local = fence.to_local(FRAME)
    assert local.grid() is None  # small: scanned element by element
    rng = random.Random(seed)
    points = probe_points(local, rng, 60)
    for g in local.floor_gaps:  # inside, on and around each gap
        (x0, y0, x1, y1) = g.bbox
        points += [(rng.uniform(x0 - 5, x1 + 5), rng.uniform(y0 - 5, y1 + 5)) for _ in range(20)]
    for e, n in points:
        for env in (MC, FW):
            args, kw = random_margin_call(rng, e, n, env, bank_rad=0.7, wrap_heading=True, rollout=True)
            h = rng.choice([30.0, 21.0, 19.0, 5.0, 118.0, 125.0, rng.uniform(0.0, 130.0)])
            args = (args[0], args[1], h, *args[3:])
            r = activation_margins(local, *args, **kw)
            check_fields(local, r, e, n, h, args[5], env, kw)


def test_over_a_gap_below_the_floor_the_gap_binds():
    """A multirotor and a fixed-wing below the floor inside a gap: the floor margin is the gap's (positive) and
    the vertical activation finite."""
    fence = fence_with_gaps(3, 16, 0, 0, 0)
    gap = tuple(latlon(x, y) for x, y in ((-30, -30), (30, -30), (30, 30), (-30, 30)))
    fence = Fence(keep_in=fence.keep_in, ceiling_m=fence.ceiling_m, floor_m=20.0, floor_gaps=(gap,))
    local = fence.to_local(FRAME)
    for env in (MC, FW):
        a = activation_margins(local, 10.0, 5.0, 12.0, 3.0, 1.0, -1.0, env, 2.0, -1.0)
        assert a.floor_margin_m > 0.0 and math.isfinite(a.vertical_activation_m)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n_gaps=st.integers(1, 4))
def test_the_gap_queries_equal_the_vectorised_distances(seed, n_gaps):
    """:meth:`LocalFence.best_gap` (compiled, :func:`geofence.geometry.scan.deepest_polygon`) and
    :meth:`~LocalFence.gap_distance_m` equal :meth:`~LocalFence.gap_distance_array` within 1e-9 m, inside, on and
    around overlapping gaps, and the gap it names is one that deep."""
    local = fence_with_gaps(seed, 12, 0, 0, n_gaps).to_local(FRAME)
    rng = random.Random(seed)
    points = [(rng.uniform(-90, 90), rng.uniform(-90, 90)) for _ in range(150)]
    points += [tuple(v) for g in local.floor_gaps for v in g.vertices]
    want = local.gap_distance_array(points)
    for (e, n), d in zip(points, want):
        gi, gd = local.best_gap(e, n)
        assert abs(gd - d) <= TOL_M and local.gap_distance_m(e, n) == gd, (e, n)
        assert abs(local.floor_gaps[gi].signed_distance(e, n) - d) <= TOL_M, (e, n)


def monitoring_outcomes(seed: int, n_vertices: int, n_squares: int, n_circles: int, n_gaps: int, floor: str) -> set:
    """Checks monitoring steps (:func:`geofence.margins.boundary_shift.monitor_margins`) against the full margins
    (:func:`~geofence.margins.boundary_shift.activation_margins`, the oracle) on one random fence (see the property
    below); returns the ``(platform kind, skipped)`` outcomes met."""
    if floor == "none":
        fence = random_fence(seed, n_vertices, n_squares, n_circles)
    else:
        fence = fence_with_gaps(seed, n_vertices, n_squares, n_circles, n_gaps)
        if floor == "wide gap":  # deeper than a multirotor's room: below the floor over it, still far
            gap = tuple(latlon(x, y) for x, y in ((-120, -120), (120, -120), (120, 120), (-120, 120)))
            fence = Fence(keep_in=fence.keep_in, ceiling_m=fence.ceiling_m, floor_m=20.0, floor_gaps=(gap,))
    rng = random.Random(seed)
    local = fence.to_local(FRAME)
    assert local.grid() is None
    outcomes = set()
    for env in (MC, FW):
        points = probe_points(local, rng, 25) + [(rng.uniform(-80, 80), rng.uniform(-80, 80)) for _ in range(25)]
        for e, n in points:
            speed, course = rng.uniform(0.0, 1.2 * env.max_speed_mps), rng.uniform(-math.pi, math.pi)
            ve, vn, vu = speed * math.sin(course), speed * math.cos(course), rng.uniform(-3.0, 3.0)
            h = rng.choice([60.0, 45.0, 30.0, 24.0, 21.0, 19.0, 5.0, 110.0, 118.0, rng.uniform(0.0, 125.0)])
            w, wd = rng.choice([rng.uniform(0.0, 9.0), 40.0]), rng.uniform(-math.pi, math.pi)
            kw = dict(
                h_uncertainty_m=rng.uniform(0.0, 9.0), v_uncertainty_m=rng.uniform(0.0, 6.0),
                latency_s=rng.uniform(0.025, 0.4), bank_rad=rng.uniform(-0.6, 0.6), wind_extra_mps=rng.uniform(0.0, 6.0),
                rollout_target_en=None if env is MC else (rng.uniform(-50, 50), rng.uniform(-50, 50)),
            )  # fmt: skip
            args = (local, e, n, h, ve, vn, vu)
            wind = (w * math.cos(wd), w * math.sin(wd))
            skip_time_s = 2.0 * env.reaction_time_s + kw["latency_s"]
            got = boundary_shift.monitor_margins(*args, speed, env, *wind, skip_time_s=skip_time_s, **kw)
            full = activation_margins(*args, env, *wind, **kw)
            if got is None:  # skipped: sound only if no activation could have been missed
                assert full.activation_margin_m > 0.0, (e, n, h, env.kind)
            else:
                assert same_margins(got, full), (e, n, h, env.kind)
            outcomes.add((env.kind, got is None))
    return outcomes


@settings(max_examples=20, deadline=None)
@given(**SMALL_FENCES, floor=st.sampled_from(["none", "gaps", "wide gap"]))
def test_a_monitoring_step_is_the_skip_shortcut_then_the_margins(seed, n_vertices, n_squares, n_circles, n_gaps, floor):
    """A monitoring step (:func:`geofence.margins.boundary_shift.monitor_margins`) skips only where the full margins
    (:func:`~geofence.margins.boundary_shift.activation_margins`) are positive (the shortcut never hides an activation),
    and otherwise answers them (every field within 1e-9 m); far from everything, near the edges, the ceiling,
    the floor and its gaps, in winds a multirotor cannot brake against (no bound: never skipped)."""
    outcomes = monitoring_outcomes(seed, n_vertices, n_squares, n_circles, n_gaps, floor)
    assert {o for o in outcomes if not o[1]} == {(MC.kind, False), (FW.kind, False)}  # the margins, both kinds


def test_the_monitoring_step_skips_where_the_reference_skips():
    """Both answers of the skip shortcut occur in the property above, for both kinds: over a wide floor gap below
    the floor (a multirotor) and in the middle of a wide fence, high and low."""
    seen = set()
    for seed in range(6):
        seen |= monitoring_outcomes(seed, 12, 0, 0, 1, ("none", "gaps", "wide gap")[seed % 3])
    assert {(MC.kind, True), (FW.kind, True), (MC.kind, False), (FW.kind, False)} <= seen


# ------------------------------------------------------------------ conformance: each compiled entry point is its source
needs_numba = pytest.mark.skipif(not COMPILED, reason="numba not installed, or NUMBA_DISABLE_JIT set (no compiled form)")


def _kernel_calls(seed: int, n_gaps: int):
    """``(margins arguments, monitor_margins arguments)`` at random states over a small fence with floor gaps."""
    local = fence_with_gaps(seed, 12, 2, 1, n_gaps).to_local(FRAME)
    F, L = local.margin_tables()
    rng = random.Random(seed)
    for e, n in probe_points(local, rng, 20):
        for env in (MC, FW):
            V = envelope_terms(env)
            args, kw = random_margin_call(rng, e, n, env, bank_rad=0.7, wrap_heading=True)
            _, _, _, ve, vn, vu, _, we, wn = args
            h = rng.uniform(-5.0, 150.0)
            hu, v_unc, lat_s, bank, extra = (
                kw[k] for k in ("h_uncertainty_m", "v_uncertainty_m", "latency_s", "bank_rad", "wind_extra_mps")
            )
            target = rng.choice([(False, 0.0, 0.0), (True, rng.uniform(-300, 300), rng.uniform(-300, 300))])
            yield (
                (F, L, V, e, n, h, ve, vn, vu, we, wn, hu, v_unc, lat_s, bank, extra, *target, 9.80665, math.nan),
                (F, L, V, e, n, h, math.hypot(ve, vn), ve, vn, vu, we, wn, extra, 2.0, hu, v_unc, lat_s, bank, *target, 9.80665),
            )  # fmt: skip


@needs_numba
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_gaps=st.integers(0, 3))
def test_margins_compiled_is_its_python_source(seed, n_gaps):
    for args, _ in _kernel_calls(seed, n_gaps):
        assert close_fields(margins(*args), margins.py_func(*args), 1e-9), args[3:6]


@needs_numba
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_gaps=st.integers(0, 3))
def test_monitor_margins_compiled_is_its_python_source(seed, n_gaps):
    for _, args in _kernel_calls(seed, n_gaps):
        far, fields = monitor_margins(*args)
        far_py, fields_py = monitor_margins.py_func(*args)
        assert far == far_py and close_fields(fields, fields_py, 1e-9), args[3:6]


@needs_numba
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.integers(60, 600), n_squares=st.integers(0, 8))
def test_room_bound_and_indexed_margins_compiled_are_their_python_source(seed, n_vertices, n_squares):
    """:func:`geofence.margins.kernel.room_bound` and :func:`~geofence.margins.kernel.indexed_margins` (an indexed
    fence's per-step calls), over an index cell's candidates and over every element."""
    local = random_fence(seed, n_vertices, n_squares, 2).to_local(FRAME, index=True)
    F, L = local.margin_tables()
    _E, _meta, all_ids, zeros = local.element_table()
    rng = random.Random(seed)
    for e, n in probe_points(local, rng, 20):
        for env in (MC, FW):
            args, kw = random_margin_call(rng, e, n, env, bank_rad=0.7, wrap_heading=True)
            _, _, _, ve, vn, vu, _, we, wn = args
            re, rn = local.recovery_en
            V = envelope_terms(env)
            hu, v_unc, lat_s, bank, extra = (
                kw[k] for k in ("h_uncertainty_m", "v_uncertainty_m", "latency_s", "bank_rad", "wind_extra_mps")
            )
            state = (V, ve, vn, vu, we, wn, hu, lat_s, bank, extra, re - e, rn - n, 9.80665)
            bound = room_bound(*state)
            assert close_fields((bound,), (room_bound.py_func(*state),), 1e-9)
            ids, lbs, delta = local.grid().candidates(e, n, bound) if bound < math.inf else (all_ids, zeros, 0.0)
            lat = local.lateral_margin_m(e, n)
            for walk in (bound < math.inf, False):
                cand = (ids, lbs, walk, delta) if walk else (all_ids, zeros, False, 0.0)
                call = (F, L, V, *cand, e, n, 30.0, ve, vn, vu, we, wn, hu, v_unc, lat_s, bank, extra)
                call += (False, 0.0, 0.0, 9.80665, lat)
                assert close_fields(indexed_margins(*call), indexed_margins.py_func(*call), 1e-9), (e, n, env.kind)
