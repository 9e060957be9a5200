"""Planar polygon geometry: known answers and property tests against shapely."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from shapely.geometry import LinearRing, Point, Polygon

from geofence.geometry.polygon import (
    BOUNDARY_TOL_M,
    PolygonIndex,
    as_vertices,
    centroid,
    is_ccw,
    is_simple,
    oriented_ccw,
    point_in_polygon,
    point_location,
    polygon_covers_polygon,
    polygons_intersect,
    self_intersections,
    signed_area,
    signed_distance,
)

SQUARE = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]
L_SHAPE = [(0.0, 0.0), (20.0, 0.0), (20.0, 10.0), (10.0, 10.0), (10.0, 20.0), (0.0, 20.0)]


# ------------------------------------------------------------------ known answers
def test_area_and_orientation():
    assert signed_area(SQUARE) == pytest.approx(100.0)
    assert signed_area(SQUARE[::-1]) == pytest.approx(-100.0)
    assert is_ccw(SQUARE) and not is_ccw(SQUARE[::-1])
    assert signed_area(L_SHAPE) == pytest.approx(300.0)
    assert signed_area(oriented_ccw(SQUARE[::-1])) > 0
    # closing vertex dropped
    assert len(as_vertices(SQUARE + [SQUARE[0]])) == 4
    assert centroid(SQUARE) == pytest.approx((5.0, 5.0))
    # far from the origin the shoelace stays exact
    far = [(x + 1e6, y - 3e6) for x, y in SQUARE]
    assert signed_area(far) == pytest.approx(100.0, abs=1e-6)


def test_self_intersections_known_cases():
    assert self_intersections(SQUARE) == []
    assert is_simple(SQUARE) and is_simple(L_SHAPE)
    # bow-tie: the diagonals, edges 1 and 3, cross
    assert self_intersections([(0, 0), (10, 0), (0, 10), (10, 10)]) == [(1, 3)]
    # a vertex repeated non-consecutively: the polygon touches itself there
    fig8 = [(0, 0), (5, 5), (10, 0), (10, 10), (5, 5), (0, 10)]
    bad = self_intersections(fig8)
    assert bad and not is_simple(fig8)
    assert all(i != j for i, j in bad)
    # a vertex touching a non-adjacent edge (no shared vertex)
    touch = [(0, 0), (10, 0), (10, 10), (5, 0.0), (0, 10)]
    assert (0, 2) in self_intersections(touch) or (0, 3) in self_intersections(touch)
    # consecutive repeated vertex -> zero-length edge (i, i)
    assert (1, 1) in self_intersections([(0, 0), (10, 0), (10, 0), (10, 10)])
    # zero-width spike: adjacent collinear edges folding back
    assert (0, 1) in self_intersections([(0, 0), (2, 0), (1, 0), (1, 1)])
    # degenerate (collinear) triangle
    assert not is_simple([(0, 0), (1, 0), (2, 0)])


def test_point_location_conventions():
    assert point_location(5, 5, SQUARE) == 1
    assert point_location(15, 5, SQUARE) == -1
    # edges and vertices are on the boundary and count as inside (closed set)
    for p in [(10, 5), (0, 0), (10, 10), (5, 0), (0, 7.5)]:
        assert point_location(*p, SQUARE) == 0
        assert point_in_polygon(*p, SQUARE)
        assert PolygonIndex(SQUARE).contains(*p)
        assert PolygonIndex(SQUARE).signed_distance(*p) >= 0.0
    # just outside by more than the tolerance
    assert point_location(10 + 10 * BOUNDARY_TOL_M, 5, SQUARE) == -1
    # ray through a vertex (y equal to a vertex y) is handled
    assert point_location(5, 10, L_SHAPE) == 1
    assert point_location(15, 10, L_SHAPE) == 0
    assert point_location(15, 15, L_SHAPE) == -1
    assert point_location(-1, 10, L_SHAPE) == -1


def test_signed_distance_known():
    assert signed_distance(5, 5, SQUARE) == pytest.approx(5.0)
    assert signed_distance(5, 1, SQUARE) == pytest.approx(1.0)
    assert signed_distance(11, 11, SQUARE) == pytest.approx(-math.sqrt(2))
    assert signed_distance(-3, 5, SQUARE[::-1]) == pytest.approx(-3.0)
    # in the notch of the L: nearest is the edge (20, 10)-(10, 10), or the reflex vertex
    assert signed_distance(13, 13, L_SHAPE) == pytest.approx(-3.0)
    assert signed_distance(10.5, 10.5, L_SHAPE) == pytest.approx(-0.5)
    # beyond a convex corner the nearest boundary point is the vertex (20, 10)
    assert signed_distance(22, 12, L_SHAPE) == pytest.approx(-2.0 * math.sqrt(2))
    assert signed_distance(9, 9, L_SHAPE) == pytest.approx(math.sqrt(2))  # reflex vertex (10, 10)


def test_index_arrays_and_nearest():
    for verts in (SQUARE, SQUARE[::-1]):
        p = PolygonIndex(verts)
        assert np.allclose(np.linalg.norm(p.directions, axis=1), 1.0)
        assert np.allclose(p.lengths, 10.0)
        # inward normals point at the centre from each edge midpoint
        mid = 0.5 * (p.starts + p.ends)
        assert np.all(np.einsum("ij,ij->i", p.inward_normals, np.array([5.0, 5.0]) - mid) > 0)
        assert np.allclose(p.outward_normals, -p.inward_normals)
    p = PolygonIndex(SQUARE)
    d, edge, ox, oy = p.nearest(5.0, 1.0)  # near the south edge (edge 0)
    assert (d, edge) == (pytest.approx(1.0), 0)
    assert (ox, oy) == pytest.approx((0.0, -1.0))
    d, edge, ox, oy = p.nearest(12.0, 5.0)  # outside, east edge (edge 1)
    assert (d, edge) == (pytest.approx(-2.0), 1)
    assert (ox, oy) == pytest.approx((1.0, 0.0))
    d, edge, ox, oy = p.nearest(13.0, 14.0)  # outside, nearest the corner (10, 10)
    assert d == pytest.approx(-5.0)
    assert (ox, oy) == pytest.approx((0.6, 0.8))
    # reversed order: edge numbers follow the caller's order
    q = PolygonIndex(SQUARE[::-1])
    d, edge, ox, oy = q.nearest(5.0, 1.0)
    a, b = q.starts[edge], q.ends[edge]
    assert a[1] == 0.0 and b[1] == 0.0 and (ox, oy) == pytest.approx((0.0, -1.0))
    assert p.edge_distances(5.0, 1.0) == pytest.approx([1.0, 5.0, 9.0, 5.0])
    assert list(p.nearest_edge_array([(5.0, 1.0), (12.0, 5.0)])) == [0, 1]


def test_inradius():
    x, y, r = PolygonIndex(SQUARE).inradius(precision_m=1e-3)
    assert r == pytest.approx(5.0, abs=1e-3) and (x, y) == pytest.approx((5.0, 5.0), abs=0.05)
    x, y, r = PolygonIndex(L_SHAPE).inradius(precision_m=1e-3)
    # the circle touches x = 0, y = 0 and the reflex vertex (10, 10): c = sqrt(2)(10 - c)
    c = 10.0 * math.sqrt(2.0) / (1.0 + math.sqrt(2.0))
    assert r == pytest.approx(c, abs=1e-3)
    assert (x, y) == pytest.approx((c, c), abs=0.05)
    assert PolygonIndex(L_SHAPE).signed_distance(x, y) == pytest.approx(r)


# ------------------------------------------------------------------ property tests
@st.composite
def star_polygons(draw, min_n=3, max_n=16):
    """Random simple (star-shaped) polygons: sorted distinct angles, random radii, random orientation."""
    n = draw(st.integers(min_n, max_n))
    angles = sorted(set(draw(st.lists(st.floats(0.0, 2 * math.pi - 1e-3), min_size=n, max_size=n))))
    assume(len(angles) >= 3)
    assume(min(np.diff(angles + [angles[0] + 2 * math.pi])) > 1e-3)
    assume(max(np.diff(angles + [angles[0] + 2 * math.pi])) < math.pi - 1e-2)
    radii = draw(st.lists(st.floats(10.0, 1000.0), min_size=len(angles), max_size=len(angles)))
    cx, cy = draw(st.floats(-5e3, 5e3)), draw(st.floats(-5e3, 5e3))
    verts = [(cx + r * math.cos(a), cy + r * math.sin(a)) for a, r in zip(angles, radii)]
    if draw(st.booleans()):
        verts = verts[::-1]
    assume(Polygon(verts).is_valid)
    return verts


points = st.tuples(st.floats(-7e3, 7e3), st.floats(-7e3, 7e3))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(star_polygons(), st.lists(points, min_size=1, max_size=20), st.data())
def test_pip_and_signed_distance_agree_with_shapely(verts, pts, data):
    poly = Polygon(verts)
    idx = PolygonIndex(verts)
    # add points near the polygon so both sides get exercised
    x0, y0, x1, y1 = poly.bounds
    for _ in range(10):
        pts.append((data.draw(st.floats(x0 - 50, x1 + 50)), data.draw(st.floats(y0 - 50, y1 + 50))))
    for x, y in pts:
        p = Point(x, y)
        bd = poly.exterior.distance(p)
        d = idx.signed_distance(x, y)
        assert abs(abs(d) - bd) <= 1e-6
        if bd > 1e-7:  # away from exact-boundary ties (vertices are tested separately)
            assert (d > 0) == poly.contains(p)
            assert point_in_polygon(x, y, verts) == poly.contains(p)
    arr = idx.signed_distance_array(np.array(pts))
    assert np.allclose(arr, [idx.signed_distance(x, y) for x, y in pts], atol=1e-9)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(star_polygons())
def test_vertices_and_edge_points_are_on_boundary(verts):
    idx = PolygonIndex(verts)
    for x, y in verts:
        assert idx.location(x, y) == 0
        assert idx.contains(x, y)
    assert is_simple(verts) and self_intersections(verts) == []
    assert abs(signed_area(verts)) == pytest.approx(Polygon(verts).area, rel=1e-9)


coord = st.floats(-100, 100).map(lambda v: round(v, 6))  # micrometre resolution, as real fences


@settings(max_examples=400, deadline=None)
@given(st.lists(st.tuples(coord, coord), min_size=3, max_size=9))
def test_self_intersection_agrees_with_shapely_random_floats(verts):
    assume(all(verts[i] != verts[(i + 1) % len(verts)] for i in range(len(verts))))
    mine = not self_intersections(verts) and signed_area(verts) != 0.0
    assert mine == Polygon(verts).is_valid
    assert (not self_intersections(verts)) == LinearRing(verts).is_simple


@settings(max_examples=600, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 3), st.integers(0, 3)), min_size=3, max_size=8))
def test_self_intersection_agrees_with_shapely_degenerate_grid(verts):
    """Small integer grids make touching, collinear and repeated-vertex cases common."""
    verts = [(float(x), float(y)) for x, y in verts]
    assume(all(verts[i] != verts[(i + 1) % len(verts)] for i in range(len(verts))))
    mine = not self_intersections(verts) and signed_area(verts) != 0.0
    assert mine == Polygon(verts).is_valid


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(star_polygons(max_n=8), star_polygons(max_n=8))
def test_polygon_relations_agree_with_shapely(a, b):
    pa, pb = Polygon(a), Polygon(b)
    assume(pa.boundary.distance(pb.boundary) > 1e-6 or pa.boundary.intersects(pb.boundary))
    assert polygons_intersect(a, b) == pa.intersects(pb)
    if pa.boundary.distance(pb.boundary) > 1e-6:
        assert polygon_covers_polygon(a, b) == pa.covers(pb)


def _self_intersections_all_pairs(vertices):
    """Reference: every pair of edges tested (the check before the x-sweep)."""
    from geofence.geometry.polygon import as_vertices, orient2d, segments_intersect

    v = [tuple(map(float, p)) for p in as_vertices(vertices)]
    n = len(v)
    if n < 3:
        return []
    seg = [(v[i], v[(i + 1) % n]) for i in range(n)]
    out = [(i, i) for i in range(n) if seg[i][0] == seg[i][1]]
    zero = {i for i, _ in out}
    for i in range(n):
        for j in range(i + 1, n):
            if i in zero or j in zero:
                continue
            (a, b), (c, d) = seg[i], seg[j]
            if j == i + 1 or (i == 0 and j == n - 1):
                p, q, r = (a, b, d) if j == i + 1 else (c, d, b)
                if orient2d(p, q, r) == 0 and (q[0] - p[0]) * (r[0] - q[0]) + (q[1] - p[1]) * (r[1] - q[1]) < 0:
                    out.append((i, j))
                continue
            if segments_intersect(a, b, c, d):
                out.append((i, j))
    return out


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(-6, 6), st.integers(-6, 6)), min_size=3, max_size=14))
def test_self_intersections_sweep_equals_all_pairs(points):
    """The x-sweep visits every pair that can meet: same pairs, same order, as testing all pairs."""
    assert self_intersections(points) == _self_intersections_all_pairs(points)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-50, 50), st.floats(-50, 50)), min_size=65, max_size=120), st.floats(-60, 60), st.floats(-60, 60)
)
def test_point_location_agrees_with_a_per_edge_loop(points, x, y):
    """:func:`point_location` (the compiled query on the polygon's edge table) gives the answer of a per-edge loop
    written out here, its crossing test in the division form, for polygons of any size."""
    import geofence.geometry.polygon as P

    v = P.as_vertices(points)
    inside, best = False, math.inf
    n = len(v)
    for i in range(n):
        ax, ay, bx, by = float(v[i, 0]), float(v[i, 1]), float(v[(i + 1) % n, 0]), float(v[(i + 1) % n, 1])
        best = min(best, P.segment_dist2(x, y, ax, ay, bx, by))
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            inside = not inside
    expected = 0 if best <= P.BOUNDARY_TOL_M**2 else (1 if inside else -1)
    assert point_location(x, y, points) == expected
