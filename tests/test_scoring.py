"""Breach scoring (analysis.scoring, analysis.fast_margins) on hand-made trajectories with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from analysis.fast_margins import fence_margins, signed_distance
from analysis.scoring import SCORE_KEYS, margins, score_flight, score_many
from geofence.geometry.fence import Fence, KeepOutCircle

LAT0, LON0 = -35.3626, 149.1652


def ll(e: float, n: float) -> tuple[float, float]:
    return LAT0 + n / 111_320.0, LON0 + e / (111_320.0 * math.cos(math.radians(LAT0)))


BOX = [ll(-150, -100), ll(150, -100), ll(150, 100), ll(-150, 100)]


def box_fence(**kw):
    return Fence(keep_in=BOX, ceiling_m=50.0, **kw).to_local()


def track(e, n, agl, dt: float = 0.1, **extra) -> dict[str, np.ndarray]:
    e = np.asarray(e, dtype=float)
    t = np.arange(len(e)) * dt
    out = {
        "time_s": t,
        "east_m": e,
        "north_m": np.broadcast_to(np.asarray(n, dtype=float), e.shape).copy(),
        "agl_m": np.broadcast_to(np.asarray(agl, dtype=float), e.shape).copy(),
    }
    out["alt_m"] = out["agl_m"] + 584.0
    out.update({k: np.asarray(v, dtype=float) for k, v in extra.items()})
    return out


def edge_frame(fence, edge: int = 1):
    """Midpoint, outward normal and unit direction of a keep-in edge, in ENU."""
    k = fence.keep_in
    mid = 0.5 * (k.starts[edge] + k.ends[edge])
    return mid, k.outward_normals[edge], k.directions[edge]


# --------------------------------------------------------------------------- known answers
def test_straight_line_crossing_an_edge_by_three_metres():
    f = box_fence()
    mid, out, _ = edge_frame(f)
    s = -10.0 + 0.5 * np.arange(27)  # -10 m ... +3.0 m along the outward normal; 0 exactly at k = 20
    p = mid[None, :] + s[:, None] * out[None, :]
    sc = score_flight(track(p[:, 0], p[:, 1], 20.0, dt=0.1), f)
    assert sc["max_excursion_m"] == pytest.approx(3.0, abs=1e-9)
    assert sc["max_lateral_excursion_m"] == pytest.approx(3.0, abs=1e-9)
    assert sc["max_vertical_excursion_m"] == pytest.approx(-30.0, abs=1e-9)
    assert sc["min_margin_m"] == pytest.approx(-3.0, abs=1e-9)
    # samples 21..26 are outside; each counts until the next sample, the last counts 0: 5 x 0.1 s
    assert sc["time_outside_s"] == pytest.approx(0.5, abs=1e-9)
    assert not sc["breached_keep_out"] and not sc["landed_outside_gap"]
    assert sc["activations"] == 0 and math.isnan(sc["time_to_peak_excursion_s"])


def test_vertical_breach_of_the_ceiling_by_two_metres():
    f = box_fence()
    agl = np.concatenate([np.linspace(20.0, 52.0, 33), np.linspace(52.0, 20.0, 33)[1:]])
    sc = score_flight(track(np.zeros_like(agl), 0.0, agl, dt=0.5), f)
    assert sc["max_vertical_excursion_m"] == pytest.approx(2.0, abs=1e-9)
    assert sc["max_excursion_m"] == pytest.approx(2.0, abs=1e-9)
    assert sc["max_lateral_excursion_m"] == pytest.approx(-f.keep_in.signed_distance(0.0, 0.0), abs=1e-12)
    # above 50 m at agl 51, 52, 51 (one sample each): 3 x 0.5 s
    assert sc["time_outside_s"] == pytest.approx(1.5, abs=1e-9)


def test_keep_out_circle_through_and_past():
    f = box_fence(keep_out_circles=[KeepOutCircle(*ll(40.0, 0.0), 10.0)])
    ce, cn, r = f.keep_out_circles[0]
    e = ce + np.linspace(-100.0, 100.0, 401)  # passes exactly over the centre
    through = score_flight(track(e, cn, 20.0), f)
    assert through["breached_keep_out"]
    assert through["max_lateral_excursion_m"] == pytest.approx(r, abs=1e-6)  # crosses the centre
    past = score_flight(track(e, cn + r + 1.0, 20.0), f)
    assert not past["breached_keep_out"]
    assert past["max_lateral_excursion_m"] == pytest.approx(-1.0, abs=1e-6)


def test_landing_inside_vs_outside_a_floor_gap():
    gap = [ll(-20, -20), ll(20, -20), ll(20, 20), ll(-20, 20)]
    f = box_fence(floor_m=8.0, floor_gaps=[gap])
    agl = np.concatenate([np.full(20, 20.0), np.linspace(20.0, 0.0, 21)])
    inside = score_flight(track(np.zeros(41), 0.0, agl), f)
    assert not inside["landed_outside_gap"]
    assert inside["max_excursion_m"] <= 0.0
    outside = score_flight(track(np.full(41, 60.0), 0.0, agl), f)
    assert outside["landed_outside_gap"]
    assert outside["max_vertical_excursion_m"] == pytest.approx(8.0, abs=1e-9)  # 8 m below the floor, no gap
    assert outside["max_ceiling_excursion_m"] == pytest.approx(20.0 - box_fence().ceiling_m, abs=1e-9)  # (below it)
    airborne = score_flight(track(np.full(41, 60.0), 0.0, np.full(41, 20.0)), f)
    assert not airborne["landed_outside_gap"]


def _activation_flight(with_velocity: bool = True):
    """201 samples at 10 Hz towards keep-in edge 1, out to +2 m at t = 5.0 s, then back.

    Modes: OVERRIDE 2.0-3.9 s then RECOVERED (hand-back 2.0 s), OVERRIDE 10.0-12.9 s then
    MONITOR (3.0 s), OVERRIDE 15.0-15.9 s then LAND_IN_GAP (not a hand-back).
    """
    f = box_fence()
    mid, out, along = edge_frame(f)
    t = np.arange(201) * 0.1
    s = 2.0 - np.abs(t - 5.0) * 1.5  # signed offset beyond the edge; peak +2.0 m at t = 5.0
    speed, angle = 5.0, math.radians(60.0)
    v = speed * (math.cos(angle) * out + math.sin(angle) * along)
    pos = mid[None, :] + s[:, None] * out[None, :] + (t[:, None] - 2.0) * (math.sin(angle) * speed) * along[None, :]
    mode = np.zeros(201)
    mode[20:40] = 1
    mode[40:50] = 2
    mode[100:130] = 1
    mode[150:160] = 1
    mode[160:] = 3
    extra = {"geofence_mode": mode}
    if with_velocity:
        extra.update(v_east_mps=np.full(201, v[0]), v_north_mps=np.full(201, v[1]), ground_speed_mps=np.full(201, speed))
    else:
        # positions that move with v around the first activation (samples 19..21)
        pos[19:22] = pos[20][None, :] + (t[19:22, None] - 2.0) * v[None, :]
    return f, track(pos[:, 0], pos[:, 1], 20.0, dt=0.1, **extra)


def test_activation_timing_fields():
    f, tr = _activation_flight()
    sc = score_flight(tr, f)
    assert sc["activations"] == 3
    assert sc["max_excursion_m"] == pytest.approx(2.0, abs=1e-9)
    assert sc["time_to_peak_excursion_s"] == pytest.approx(3.0, abs=1e-9)
    assert sc["time_to_handback_s"] == pytest.approx(2.5, abs=1e-9)
    assert sc["ground_speed_at_activation_mps"] == pytest.approx(5.0, abs=1e-12)
    assert sc["approach_angle_at_activation_deg"] == pytest.approx(60.0, abs=1e-9)


def test_activation_velocity_from_positions_when_not_recorded():
    f, tr = _activation_flight(with_velocity=False)
    sc = score_flight(tr, f)
    assert sc["ground_speed_at_activation_mps"] == pytest.approx(5.0, abs=1e-6)
    assert sc["approach_angle_at_activation_deg"] == pytest.approx(60.0, abs=1e-6)


def test_no_activation_gives_nan_and_override_at_start_counts():
    f = box_fence()
    tr = track(np.zeros(10), 0.0, 20.0, geofence_mode=np.zeros(10))
    sc = score_flight(tr, f)
    for k in (
        "time_to_peak_excursion_s",
        "time_to_handback_s",
        "ground_speed_at_activation_mps",
        "approach_angle_at_activation_deg",
    ):
        assert math.isnan(sc[k])
    tr["geofence_mode"] = np.array([1, 1, 0, 0, 1, 1, 1, 1, 1, 1], dtype=float)
    sc = score_flight(tr, f)
    assert sc["activations"] == 2
    assert sc["time_to_handback_s"] == pytest.approx(0.2, abs=1e-12)  # the second never hands back


def test_keys_and_empty_flight():
    f = box_fence()
    sc = score_flight(track(np.zeros(0), 0.0, 20.0), f)
    assert tuple(sc) == SCORE_KEYS
    assert sc["max_excursion_m"] == 0.0 and sc["activations"] == 0


def test_score_many_matches_score_flight_and_handles_several_fences():
    f, tr = _activation_flight()
    g = box_fence(keep_out_circles=[KeepOutCircle(*ll(0.0, 0.0), 5.0)])
    mid, out, _ = edge_frame(f)
    line = track(mid[0] + out[0] * np.linspace(-5, 1, 50), mid[1] + out[1] * np.linspace(-5, 1, 50), 20.0)
    trajs = [tr, line, track(np.zeros(0), 0.0, 20.0), line, tr]
    fences = [f, f, f, g, g]
    many = score_many(trajs, fences)
    for traj, fence, got in zip(trajs, fences, many):
        want = score_flight(traj, fence)
        for k in SCORE_KEYS:
            assert (math.isnan(got[k]) and math.isnan(want[k])) or got[k] == pytest.approx(want[k], abs=1e-9), k
    with pytest.raises(ValueError):
        score_many(trajs, [f, g])


# --------------------------------------------------------------------------- properties
IRREGULAR = Fence(
    keep_in=[ll(-200, -150), ll(50, -180), ll(220, -40), ll(120, 30), ll(200, 160), ll(-60, 120), ll(-10, 10)],
    ceiling_m=60.0,
    floor_m=5.0,
    floor_gaps=[[ll(-40, -60), ll(0, -60), ll(0, -20), ll(-40, -20)]],
    keep_out_polygons=[[ll(60, -60), ll(100, -60), ll(80, -20)]],
    keep_out_circles=[KeepOutCircle(*ll(-100, -50), 15.0)],
).to_local()

coords = st.floats(-320.0, 320.0, allow_nan=False)
heights = st.floats(-5.0, 80.0, allow_nan=False)
tracks = st.lists(st.tuples(coords, coords, heights), min_size=1, max_size=60)


def _from_points(points) -> dict[str, np.ndarray]:
    a = np.array(points, dtype=float)
    return track(a[:, 0], a[:, 1], a[:, 2])


@settings(max_examples=60, deadline=None)
@given(tracks)
def test_excursion_is_minus_min_margin_and_fast_margins_match_reference(points):
    tr = _from_points(points)
    sc = score_flight(tr, IRREGULAR)
    assert sc["max_excursion_m"] == -sc["min_margin_m"]
    assert sc["max_excursion_m"] == max(sc["max_lateral_excursion_m"], sc["max_vertical_excursion_m"])
    pts = np.column_stack([tr["east_m"], tr["north_m"]])
    ref = IRREGULAR.margin_array(pts, tr["agl_m"])
    m = margins(tr, IRREGULAR)
    np.testing.assert_allclose(m["total"], ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(m["lateral"], IRREGULAR.lateral_margin_array(pts), rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        signed_distance(IRREGULAR.keep_in, pts[:, 0], pts[:, 1]), IRREGULAR.keep_in.signed_distance_array(pts), rtol=0, atol=1e-9
    )


@settings(max_examples=60, deadline=None)
@given(tracks, st.floats(0.0, 1.0))
def test_shifting_a_track_inward_never_increases_the_excursion(points, s):
    """Contracting a track towards the centre of a convex fence (by s) cannot push it further out."""
    f = box_fence()
    c = f.keep_in.vertices.mean(axis=0)
    sd_c = float(f.keep_in.signed_distance_array(c[None, :])[0])
    tr = _from_points(points)
    tr["agl_m"] = np.full_like(tr["agl_m"], 20.0)
    moved = dict(tr, east_m=c[0] + s * (tr["east_m"] - c[0]), north_m=c[1] + s * (tr["north_m"] - c[1]))
    before, after = score_flight(tr, f), score_flight(moved, f)
    bound = max(before["max_lateral_excursion_m"], -sd_c)
    assert after["max_lateral_excursion_m"] <= bound + 1e-9
    assert after["max_excursion_m"] <= max(before["max_excursion_m"], -sd_c) + 1e-9
    assert after["time_outside_s"] <= before["time_outside_s"] + 1e-9


@settings(max_examples=80, deadline=None)
@given(st.lists(st.sampled_from([0, 1, 2, 3]), min_size=1, max_size=80))
def test_activation_count_and_handback_match_a_plain_loop(modes):
    f = box_fence()
    n = len(modes)
    tr = track(np.zeros(n), 0.0, 20.0, dt=0.25, geofence_mode=np.array(modes, dtype=float))
    sc = score_flight(tr, f)
    entries = [i for i in range(n) if modes[i] == 1 and (i == 0 or modes[i - 1] != 1)]
    assert sc["activations"] == len(entries)
    durations = []
    for i in entries:
        j = i
        while j < n and modes[j] == 1:
            j += 1
        if j < n and modes[j] in (0, 2):
            durations.append((j - i) * 0.25)
    if durations:
        assert sc["time_to_handback_s"] == pytest.approx(sum(durations) / len(durations), abs=1e-9)
    else:
        assert math.isnan(sc["time_to_handback_s"])


def test_fence_margins_threaded_equals_single_thread():
    rng = np.random.default_rng(3)
    n = 300_000
    x, y, h = rng.uniform(-300, 300, n), rng.uniform(-300, 300, n), rng.uniform(-5, 80, n)
    one = fence_margins(IRREGULAR, x, y, h, threads=1)
    two = fence_margins(IRREGULAR, x, y, h, threads=2)
    for k in one:
        np.testing.assert_array_equal(one[k], two[k])
