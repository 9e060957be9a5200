"""Property: on any fence, a manoeuvre the margin scores that leaves the allowed area has a negative margin.

The activation margin scores each element as a distance less the manoeuvre's excursion along one direction. It is
sound when the whole element lies at least that distance away along that direction. For an edge whose
perpendicular foot lies off the segment, the point-segment distance ``d`` is to the edge's end, and along the
edge's *normal* the segment can be nearer than ``d``: a turn drifting in wind then reaches it with less excursion
along the normal than ``d``, and a vehicle heading straight at the end closes on it at its full speed, not the
normal component. A U-shaped keep-in's inner corner was left by 4.6 m with a margin of +21 m that way, and a keep-out's
corner and a concave star's the same (this property found them). Such an edge is now scored along the direction to
its nearest end (:func:`geofence.geometry.elements.edge_scored`): every point of the segment lies at least ``d`` along
it. A convex keep-in keeps its exact rule, the line distance along the normal (``tests/test_line_scored_edges.py``).

Checked here, for a fixed-wing at sea level and at high sites (the envelope at the site's density) in winds up to
0.7 of its airspeed, on random concave star keep-ins, U-shaped keep-ins (an inner notch: two reflex corners) and
star keep-ins with keep-out squares and circles: the manoeuvre the margin scores, flown numerically, leaves the
allowed area only if the activation margin is negative. A multirotor heading straight at a corner needs the room of
its full speed, as against a wall. ``tests/test_binding_edge.py`` holds the binding search to the exhaustive
minimum over every element.
"""

import math
import random
from types import SimpleNamespace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support import FRAME, FW, MC, G, latlon, model_path_leaves, random_fence, random_flight

from geofence.geometry.elements import edge_scored
from geofence.geometry.fence import Fence, KeepOutCircle
from geofence.margins.boundary_shift import activation_margins
from geofence.physics.dynamics import envelope_at_density, isa_density_ratio


def turn_radius(env) -> float:
    return env.cruise_speed_mps**2 / (G * math.tan(env.max_bank_rad))


def star_keep_in(rng: random.Random, radius_m: float, n_vertices: int) -> Fence:
    """A concave star: ``2..5`` lobes of relative depth 0.2..0.45."""
    amp, lobes, phase = rng.uniform(0.2, 0.45), rng.choice([2, 3, 4, 5]), rng.uniform(0.0, 2.0 * math.pi)
    pts = []
    for i in range(n_vertices):
        a = 2.0 * math.pi * i / n_vertices
        r = radius_m * (1.0 + amp * math.sin(lobes * a + phase))
        pts.append(latlon(r * math.cos(a), r * math.sin(a)))
    return Fence(keep_in=tuple(pts), ceiling_m=500.0)


def u_keep_in(rng: random.Random, r_turn: float) -> Fence:
    """A U (arms ``3..8`` turn radii wide, ``8..25`` long, a notch of ``2..10`` between them), rotated."""
    w, length, gap = rng.uniform(3, 8) * r_turn, rng.uniform(8, 25) * r_turn, rng.uniform(2, 10) * r_turn
    corners = [(0, 0), (2 * w + gap, 0), (2 * w + gap, length), (w + gap, length), (w + gap, w), (w, w), (w, length), (0, length)]
    th = rng.uniform(0.0, 2.0 * math.pi)
    c, s = math.cos(th), math.sin(th)
    pts = [(x - w - 0.5 * gap, y - 0.5 * length) for x, y in corners]
    return Fence(keep_in=tuple(latlon(c * x - s * y, s * x + c * y) for x, y in pts), ceiling_m=500.0)


def leaving_turns(seed: int, kind: str) -> int:
    """Checks the property on one random fence of ``kind`` and 25 random states; returns how many of the scored
    manoeuvres left the allowed area."""
    rng = random.Random(seed)
    alt = rng.choice([0.0, rng.uniform(1000.0, 3500.0)])
    env = envelope_at_density(FW, isa_density_ratio(alt))
    r_turn = turn_radius(env)
    if kind == "star":
        fence = star_keep_in(rng, rng.uniform(4.0, 25.0) * r_turn, rng.choice([5, 7, 12, 40, 150]))
    elif kind == "u":
        fence = u_keep_in(rng, r_turn)
    else:
        fence = random_fence(seed, rng.choice([5, 7, 12, 40, 150]), rng.randint(1, 6), rng.randint(0, 3))
    local = fence.to_local(FRAME)
    v = local.keep_in.vertices
    left = 0
    for _ in range(25):
        e, n = rng.uniform(v[:, 0].min(), v[:, 0].max()), rng.uniform(v[:, 1].min(), v[:, 1].max())
        if local.lateral_margin_m(e, n) <= 0.0:
            continue
        ve, vn, we, wn, bank, latency = random_flight(rng, env, 0.7)
        r = activation_margins(local, e, n, 30.0, ve, vn, 0.0, env, we, wn, latency_s=latency, bank_rad=bank)
        out = model_path_leaves(local, e, n, ve, vn, we, wn, bank, latency, r, steps=600, env=env)
        if out > 1e-3:  # the scored manoeuvre leaves: the margin must say so
            left += 1
            assert r.lateral_activation_m < 0.0, (seed, kind, alt, e, n, out, r)
    return left


@settings(max_examples=120, deadline=None)
@given(seed=st.integers(0, 100_000), kind=st.sampled_from(["star", "u", "keep_outs"]))
def test_a_turn_that_leaves_any_fence_has_a_negative_margin(seed, kind):
    leaving_turns(seed, kind)


def test_the_property_meets_turns_that_leave_the_fence():
    """The states above include scored manoeuvres that leave, on every kind of fence: not met vacuously."""
    for kind in ("star", "u", "keep_outs"):
        assert sum(leaving_turns(s, kind) for s in range(6)) > 0, kind


U_NOTCH = (
    (-200.836, -126.225), (200.836, -126.225), (200.836, 126.225), (46.680, 126.225),
    (46.680, 27.932), (-46.680, 27.932), (-46.680, 126.225), (-200.836, 126.225),
)  # fmt: skip


def test_a_turn_round_a_reflex_corner_has_a_negative_margin():
    """A Tern in the base of a U, 98 m from the notch's inner corner and heading at it in a 7 m/s wind. The margin
    scored the notch's floor along its normal at the distance to the corner and chose a left turn of 86 deg: +21 m,
    while that turn, flown, cuts the corner 4.6 m into the notch (found by the property above). Scored towards the
    corner, the margin is negative, so every turn's is."""
    local = Fence(keep_in=tuple(latlon(x, y) for x, y in U_NOTCH), ceiling_m=500.0).to_local(FRAME)
    e, n, ve, vn, we, wn, bank, latency = (144.407, -57.186, -12.422, 25.560, -5.074, 4.785, 0.215, 0.150)
    left_turn = SimpleNamespace(turn_sign=1.0, turn_angle_rad=1.5006)
    assert model_path_leaves(local, e, n, ve, vn, we, wn, bank, latency, left_turn, steps=1000) > 4.0
    r = activation_margins(local, e, n, 30.0, ve, vn, 0.0, FW, we, wn, latency_s=latency, bank_rad=bank)
    assert r.lateral_activation_m < 0.0


@pytest.mark.parametrize("keep_out", ["square", "circle"])
def test_heading_straight_at_a_corner_needs_the_room_of_a_wall(keep_out):
    """Calm air, a multirotor 60 m from a keep-out, heading straight at it: at a square's corner along its diagonal
    (both edges' feet lie off them) the margin is the one heading straight at the middle of its side from as far,
    and the one at a small circle's nearest point: the full speed closes on the corner, not its component along
    either normal (with the normals, the margin was that of 0.7 of the speed)."""
    env = MC
    keep_in = tuple(latlon(2000.0 * math.cos(a), 2000.0 * math.sin(a)) for a in (2 * math.pi * k / 40 for k in range(40)))
    square = tuple(latlon(x, y) for x, y in ((-50.0, -50.0), (50.0, -50.0), (50.0, 50.0), (-50.0, 50.0)))
    local = Fence(keep_in=keep_in, ceiling_m=500.0, keep_out_polygons=(square,)).to_local(FRAME)
    (x0, y0), (x1, y1), (x2, y2) = local.keep_out_polygons[0].vertices[:3]  # the corner (x1, y1)
    ux, uy = x1 - 0.5 * (x0 + x2), y1 - 0.5 * (y0 + y2)  # out of the square along its diagonal
    norm = math.hypot(ux, uy)
    ux, uy = ux / norm, uy / norm
    speed, d = 0.9 * env.max_speed_mps, 60.0
    kw = dict(latency_s=0.1)
    at_corner = activation_margins(local, x1 + d * ux, y1 + d * uy, 30.0, -speed * ux, -speed * uy, 0.0, env, **kw)
    assert at_corner.edge_distance_m == pytest.approx(d, abs=1e-9)
    if keep_out == "square":  # the side (x1, y1) -> (x2, y2), from its middle, out of the square
        mx, my = 0.5 * (x1 + x2), 0.5 * (y1 + y2)
        cx, cy = local.keep_out_polygons[0].vertices.mean(axis=0)
        nx, ny = (mx - cx) / math.hypot(mx - cx, my - cy), (my - cy) / math.hypot(mx - cx, my - cy)
        other = activation_margins(local, mx + d * nx, my + d * ny, 30.0, -speed * nx, -speed * ny, 0.0, env, **kw)
    else:  # a circle of 1 m at the corner, from its nearest point as far
        circle = KeepOutCircle(*FRAME.to_geodetic(x1, y1, FRAME.h0_m)[:2], 1.0)
        local_c = Fence(keep_in=keep_in, ceiling_m=500.0, keep_out_circles=(circle,)).to_local(FRAME)
        ce, cn, _ = local_c.keep_out_circles[0]
        other = activation_margins(
            local_c, ce + (d + 1.0) * ux, cn + (d + 1.0) * uy, 30.0, -speed * ux, -speed * uy, 0.0, env, **kw
        )
    assert other.edge_distance_m == pytest.approx(d, abs=1e-6)
    assert at_corner.lateral_activation_m == pytest.approx(other.lateral_activation_m, abs=1e-6)


def test_edge_scored_by_hand():
    """The edge from (0, 0) to (10, 0), its breach-pointing normal (0, 1) (the point below it is inside)."""
    edge = (10.0, 0.0, 1.0 / 100.0, 0.0, 1.0)  # (dx, dy, 1/len², nx, ny)
    # the foot on the segment: the normal, the perpendicular distance
    assert edge_scored(5.0 - 0.0, -3.0 - 0.0, *edge, False, True) == (3.0, 3.0, 0.0, 1.0)
    # the foot off the segment, beyond its end (10, 0): the direction to that end, the distance to it
    d, db, ux, uy = edge_scored(13.0, -4.0, *edge, False, True)
    assert (d, db) == (5.0, 5.0) and (ux, uy) == pytest.approx((-0.6, 0.8))
    # a convex keep-in's edge: the line distance along the normal, where it is positive
    assert edge_scored(13.0, -4.0, *edge, True, True) == (5.0, 4.0, 0.0, 1.0)
    # ... and beyond its line (outside that convex keep-in): the direction to the end again
    d, db, ux, uy = edge_scored(13.0, 4.0, *edge, True, True)
    assert (d, db) == (5.0, 5.0) and (ux, uy) == pytest.approx((-0.6, -0.8))
    # the foot on the segment, the point on its breach side (the edge faces away: a building's far side):
    # from the free space, the direction to the foot (back towards the edge), not the normal away from it
    assert edge_scored(5.0, 3.0, *edge, False, True) == (3.0, 3.0, -0.0, -1.0)
    # ... from a breached point, the normal as before
    assert edge_scored(5.0, 3.0, *edge, False, False) == (3.0, 3.0, 0.0, 1.0)
