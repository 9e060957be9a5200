"""Property: the fixed-wing's pruned binding-edge search gives the full scan's answer, bit for bit.

:func:`geofence.boundary_shift._binding_edge_pruned` scores edges in order of a lower bound of their
activation and stops early; :func:`~geofence.boundary_shift._binding_edge_scan` scores every edge (the
reference). Random threatened-edge lists (distances, normals, winds, reaction rooms, headings), turns of
either direction and any angle up to a full circle, with duplicated edges so that ties occur: the same
activation and the same edge (room, feature, index, normal, distance, closing speed) must come out.
Also, whole margins: :func:`activation_margins`'s Python branches (``compiled=False``) on a large wavy
fence equal themselves with ``prune_from_edges`` above every list length (the scan everywhere), and the
compiled search.
"""

import math

from hypothesis import given, settings
from hypothesis import strategies as st

import geofence.boundary_shift as bs
from geofence.fence import Fence
from geofence.geodesy import LocalFrame
from geofence.interface import Envelope, PlatformKind
from geofence.rooms import turn_constants


def fl(lo: float, hi: float, exclude_max: bool = False) -> st.SearchStrategy[float]:
    """Finite floats in [lo, hi] (or [lo, hi))."""
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False, exclude_max=exclude_max)


@st.composite
def near_lists(draw):
    n = draw(st.integers(1, 40))
    items = []
    for k in range(n):
        a = draw(fl(-math.pi, math.pi))
        item = (
            draw(fl(0.0, 400.0)),  # d
            math.cos(a),
            math.sin(a),
            "keep_in",
            0,
            k,
            draw(fl(-40.0, 40.0)),  # v_n
            draw(fl(-20.0, 20.0)),  # w_n
            draw(fl(0.0, 200.0)),  # base
            draw(fl(-math.pi, math.pi, exclude_max=True)),  # psi0
            draw(st.one_of(st.just(0.0), fl(0.0, 100.0))),  # gap: how much farther the reaction arc gets
        )
        items.append(item)
        if draw(st.booleans()) and draw(st.booleans()):
            items.append(item[:5] + (k + 1000,) + item[6:])  # an exact tie
    return items


@settings(max_examples=400, deadline=None)
@given(
    near=near_lists(),
    v=fl(5.0, 60.0),
    bank=fl(0.1, 1.2),
    s=st.sampled_from([1.0, -1.0]),
    delta=fl(0.0, 2.0 * math.pi),
)
def test_pruned_equals_scan(near, v, bank, s, delta):
    radius, inv_omega = turn_constants(v, bank)
    ref = bs._binding_edge_scan(near, radius, inv_omega, v, s, delta)
    got = bs._binding_edge_pruned(near, radius, inv_omega, v, s, delta)
    assert got == ref


FRAME = LocalFrame(47.0, 8.0, 400.0)
FW = Envelope(
    PlatformKind.FIXED_WING, 16.0, 24.0, 12.0, math.radians(40), math.radians(25), math.radians(28), 5.0, 3.0, 0.6, 5.0, 1.1
)


def _wavy_fence(n_vertices: int):
    """A wavy keep-in about 1.2 km across (finely sampled: many edges within a fixed-wing's reach) and one keep-out."""

    def ll(e: float, n: float) -> tuple[float, float]:
        lat, lon, _ = FRAME.to_geodetic(e, n, FRAME.h0_m)
        return lat, lon

    keep_in = []
    for i in range(n_vertices):
        a = 2.0 * math.pi * i / n_vertices
        r = 600.0 * (1.0 + 0.15 * math.sin(5.0 * a) + 0.04 * math.sin(41.0 * a))
        keep_in.append(ll(r * math.cos(a), r * math.sin(a)))
    square = tuple(ll(200.0 + x, y) for x, y in ((-15, -15), (15, -15), (15, 15), (-15, 15)))
    return Fence(keep_in=tuple(keep_in), ceiling_m=120.0, keep_out_polygons=(square,)).to_local(FRAME)


WAVY = _wavy_fence(1500)


@settings(max_examples=150, deadline=None)
@given(
    a=fl(0.0, 2.0 * math.pi),
    inset=fl(-5.0, 300.0),
    heading=fl(-math.pi, math.pi),
    speed=fl(10.0, 30.0),
    bank=fl(-0.5, 0.5),
    wind=st.tuples(fl(-8.0, 8.0), fl(-8.0, 8.0)),
)
def test_margins_with_pruning_equal_the_scan(a, inset, heading, speed, bank, wind):
    r = 600.0 * (1.0 + 0.15 * math.sin(5.0 * a) + 0.04 * math.sin(41.0 * a)) - inset
    e, n = r * math.cos(a), r * math.sin(a)
    args = (WAVY, e, n, 40.0, speed * math.cos(heading), speed * math.sin(heading), 0.5, FW, wind[0], wind[1])
    kw = dict(h_uncertainty_m=3.0, v_uncertainty_m=1.0, latency_s=0.05, bank_rad=bank, wind_extra_mps=1.5)
    pruned = bs.activation_margins(*args, **kw, compiled=False)
    scanned = bs.activation_margins(*args, **kw, prune_from_edges=10**9, compiled=False)
    assert repr(pruned) == repr(scanned)  # every field, bit for bit (repr round-trips floats)
    assert repr(bs.activation_margins(*args, **kw)) == repr(scanned)  # and the compiled search (where numba is)
