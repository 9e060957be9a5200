"""Property: inside a convex keep-in, the margin scores each edge at its line distance, so a turn that leaves the
fence through an edge far along it is seen.

The activation margin scores each edge as its distance from the vehicle less the manoeuvre's excursion along the
edge's normal. To leave through an edge's segment, the vehicle only has to reach the edge's *line*, which is
nearer than the segment when the perpendicular foot lies off it. A long turn drifting in strong wind left a finely
divided circle that way (campaign seed 27112026, circle-0169: a c172x 86 m out). Inside a convex keep-in, crossing
any edge's line is leaving it, so those edges are scored at their line distance
(:func:`geofence.geometry.elements.edge_scored`). ``tests/test_edge_scoring.py`` holds the same property on concave
keep-ins and keep-outs.

Checked here, on random convex keep-ins (ellipses divided into 3 to 400 edges: scanned and indexed), for a
fixed-wing in winds up to 0.6 of its airspeed: the manoeuvre the margin scores, flown numerically (the reaction
phase in the current turn, then the turn it chose at the bank limit, in the estimated wind), leaves the fence only
if the activation margin is negative; and the margins with the fence's index equal those without (within 1e-9 m),
for both platform kinds. The property found a second gap, now closed:
the reaction phase was scored where it ends, not at its farthest point.
"""

import math
import random

from hypothesis import given, settings
from hypothesis import strategies as st
from support import FRAME, FW, MC, G, latlon, model_path_leaves, random_fence, random_flight, same_margins

from geofence.geometry.fence import Fence
from geofence.margins.boundary_shift import activation_margins


def convex_fence(n_vertices: int, radius_m: float, aspect: float, turn_rad: float) -> Fence:
    """An ellipse (semi-axes ``radius_m`` and ``aspect * radius_m``, rotated by ``turn_rad``) as ``n_vertices`` edges."""
    pts = []
    c, s = math.cos(turn_rad), math.sin(turn_rad)
    for k in range(n_vertices):
        a = 2.0 * math.pi * k / n_vertices
        x, y = radius_m * math.cos(a), aspect * radius_m * math.sin(a)
        pts.append(latlon(c * x - s * y, s * x + c * y))
    return Fence(keep_in=tuple(pts), ceiling_m=500.0)


def leaving_turns(seed: int, n_vertices: int, aspect: float) -> int:
    """Checks the property below on one random convex keep-in and 12 states; returns how many of the scored
    manoeuvres left the fence."""
    rng = random.Random(seed)
    radius = rng.uniform(4.0, 25.0) * FW.cruise_speed_mps**2 / (G * math.tan(FW.max_bank_rad))  # 4 to 25 turn radii
    turn = rng.uniform(0.0, math.pi)
    local = convex_fence(n_vertices, radius, aspect, turn).to_local(FRAME)
    assert local.line_scored_edges() == n_vertices
    left = 0
    for _ in range(12):
        a, frac = rng.uniform(-math.pi, math.pi), rng.uniform(0.3, 0.97)
        x, y = frac * radius * math.cos(a), frac * radius * aspect * math.sin(a)
        e, n = math.cos(turn) * x - math.sin(turn) * y, math.sin(turn) * x + math.cos(turn) * y
        if local.lateral_margin_m(e, n) <= 0.0:
            continue
        ve, vn, we, wn, bank, latency = random_flight(rng, FW, 0.6)
        kw = dict(latency_s=latency, bank_rad=bank)
        r = activation_margins(local, e, n, 30.0, ve, vn, 0.0, FW, we, wn, **kw)
        out = model_path_leaves(local, e, n, ve, vn, we, wn, bank, latency, r)
        if out > 1e-3:  # the scored manoeuvre leaves the fence: the margin must say so
            left += 1
            assert r.lateral_activation_m < 0.0, (seed, e, n, out, r)
    return left


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n_vertices=st.sampled_from([3, 5, 8, 24, 60, 150, 309, 400]),
    aspect=st.floats(0.5, 1.0),
)
def test_a_turn_that_leaves_a_convex_keep_in_has_a_negative_margin(seed, n_vertices, aspect):
    leaving_turns(seed, n_vertices, aspect)


def test_the_property_meets_turns_that_leave_the_fence():
    """The states above include scored manoeuvres that leave the fence: the property is not met vacuously."""
    assert sum(leaving_turns(s, 309, 0.9) for s in range(8)) > 0


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n_vertices=st.sampled_from([30, 309, 1200]))
def test_convex_keep_ins_indexed_equal_the_full_scan_for_both_kinds(seed, n_vertices):
    """With the index and without, both platform kinds, near and far from the edges: every field within 1e-9 m
    (the index scores the line-scored edges as the full scan does)."""
    rng = random.Random(seed)
    fence = convex_fence(n_vertices, rng.uniform(300.0, 3000.0), rng.uniform(0.3, 1.0), rng.uniform(0.0, 3.0))
    indexed, scanned = fence.to_local(FRAME, index=True), fence.to_local(FRAME, index=False)
    assert indexed.grid() is not None and indexed.grid().line_edges == n_vertices
    for env in (MC, FW):
        for _ in range(20):
            a, frac = rng.uniform(-math.pi, math.pi), rng.uniform(0.0, 1.05)
            e, n = frac * 300.0 * math.cos(a), frac * 300.0 * math.sin(a)
            course, speed = rng.uniform(-math.pi, math.pi), rng.uniform(0.0, 1.2 * env.max_speed_mps)
            args = (e, n, 30.0, speed * math.cos(course), speed * math.sin(course), 0.0, env)
            kw = dict(latency_s=0.1, bank_rad=rng.uniform(-0.6, 0.6), wind_extra_mps=rng.uniform(0.0, 3.0))
            w = (rng.uniform(-12.0, 12.0), rng.uniform(-12.0, 12.0))
            got = activation_margins(indexed, *args, *w, **kw)
            assert same_margins(got, activation_margins(scanned, *args, *w, **kw)), (seed, e, n, env.kind)


def test_a_concave_keep_in_keeps_the_segment_distance():
    local = random_fence(7, 40, 0, 0).to_local(FRAME)
    assert local.line_scored_edges() == 0


def test_the_reaction_phase_is_scored_at_its_farthest_point():
    """A Tern 2.4 m from the edge of an 8-gon, heading 45 deg off the edge's normal, banked away from it: during its
    2.1 s reaction it first closes on the edge and then turns away. The margin scored where the reaction ends
    (1.6 m towards the edge), not the farthest it gets (3.5 m): the scored manoeuvre left the fence by 1.2 m
    with a margin of +0.8 m (the property above found it). The arc's farthest point is scored now
    (:func:`geofence.physics.rooms.reaction_arc_gap_m`): the margin is negative."""
    rng = random.Random(152)
    radius = rng.uniform(4.0, 25.0) * FW.cruise_speed_mps**2 / (G * math.tan(FW.max_bank_rad))
    local = convex_fence(8, radius, 0.625, rng.uniform(0.0, math.pi)).to_local(FRAME)
    e, n, ve, vn, we, wn = (
        192.3650689348986,
        -535.7328496936138,
        22.16391450917391,
        22.197762747364,
        6.301352190975233,
        6.400349622995843,
    )
    bank, latency = -0.47411565970200664, 0.22795384412501588
    r = activation_margins(local, e, n, 30.0, ve, vn, 0.0, FW, we, wn, latency_s=latency, bank_rad=bank)
    out = model_path_leaves(local, e, n, ve, vn, we, wn, bank, latency, r)
    assert out > 1e-3 and r.lateral_activation_m < 0.0, (out, r.lateral_activation_m)
