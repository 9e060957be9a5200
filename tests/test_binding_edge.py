"""Property: the fixed-wing's pruned binding-edge search gives the full scan's answer, bit for bit.

:func:`geofence.boundary_shift._binding_edge_pruned` scores edges in order of a lower bound of their
activation and stops early; :func:`~geofence.boundary_shift._binding_edge_scan` scores every edge (the
reference). Random threatened-edge lists (distances, normals, winds, reaction rooms, headings), turns of
either direction and any angle up to a full circle, with duplicated edges so that ties occur: the same
activation and the same edge (room, feature, index, normal, distance, closing speed) must come out.
Also, whole margins: :func:`activation_margins` on large random fences equals itself with the pruning
threshold raised above every list length (the scan everywhere).
"""

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import geofence.boundary_shift as bs
from geofence.fence import Fence
from geofence.geodesy import LocalFrame
from geofence.interface import Envelope, PlatformKind

finite = dict(allow_nan=False, allow_infinity=False)


@st.composite
def near_lists(draw):
    n = draw(st.integers(1, 40))
    items = []
    for k in range(n):
        a = draw(st.floats(-math.pi, math.pi, **finite))
        item = (
            draw(st.floats(0.0, 400.0, **finite)),  # d
            math.cos(a),
            math.sin(a),
            "keep_in",
            0,
            k,
            draw(st.floats(-40.0, 40.0, **finite)),  # v_n
            draw(st.floats(-20.0, 20.0, **finite)),  # w_n
            draw(st.floats(0.0, 200.0, **finite)),  # base
            draw(st.floats(-math.pi, math.pi, exclude_max=True, **finite)),  # psi0
        )
        items.append(item)
        if draw(st.booleans()) and draw(st.booleans()):
            items.append(item[:5] + (k + 1000,) + item[6:])  # an exact tie
    return items


@settings(max_examples=400, deadline=None)
@given(
    near=near_lists(),
    v=st.floats(5.0, 60.0, **finite),
    bank=st.floats(0.1, 1.2, **finite),
    s=st.sampled_from([1.0, -1.0]),
    delta=st.floats(0.0, 2.0 * math.pi, **finite),
)
def test_pruned_equals_scan(near, v, bank, s, delta):
    radius, inv_omega = bs.turn_constants(v, bank)
    ref = bs._binding_edge_scan(near, radius, inv_omega, v, s, delta)
    got = bs._binding_edge_pruned(near, radius, inv_omega, v, s, delta)
    assert got == ref


FRAME = LocalFrame(47.0, 8.0, 400.0)
FW = Envelope(
    PlatformKind.FIXED_WING, 16.0, 24.0, 12.0, math.radians(40), math.radians(25), math.radians(28), 5.0, 3.0, 0.6, 5.0, 1.1
)


def _wavy_fence(n_vertices: int):
    """A wavy keep-in about 1.2 km across (finely sampled: many edges within a fixed-wing's reach) and one keep-out."""
    ll = lambda e, n: tuple(FRAME.to_geodetic(e, n, FRAME.h0_m)[:2])  # noqa: E731
    keep_in = []
    for i in range(n_vertices):
        a = 2.0 * math.pi * i / n_vertices
        r = 600.0 * (1.0 + 0.15 * math.sin(5.0 * a) + 0.04 * math.sin(41.0 * a))
        keep_in.append(ll(r * math.cos(a), r * math.sin(a)))
    square = tuple(ll(200.0 + x, y) for x, y in ((-15, -15), (15, -15), (15, 15), (-15, 15)))
    return Fence(keep_in=tuple(keep_in), ceiling_m=120.0, keep_out_polygons=(square,)).to_local(FRAME)


WAVY = _wavy_fence(1500)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    a=st.floats(0.0, 2.0 * math.pi, **finite),
    inset=st.floats(-5.0, 300.0, **finite),
    heading=st.floats(-math.pi, math.pi, **finite),
    speed=st.floats(10.0, 30.0, **finite),
    bank=st.floats(-0.5, 0.5, **finite),
    wind=st.tuples(st.floats(-8.0, 8.0, **finite), st.floats(-8.0, 8.0, **finite)),
)
def test_margins_with_pruning_equal_the_scan(monkeypatch_free, a, inset, heading, speed, bank, wind):
    r = 600.0 * (1.0 + 0.15 * math.sin(5.0 * a) + 0.04 * math.sin(41.0 * a)) - inset
    e, n = r * math.cos(a), r * math.sin(a)
    args = (WAVY, e, n, 40.0, speed * math.cos(heading), speed * math.sin(heading), 0.5, FW, wind[0], wind[1])
    kw = dict(h_uncertainty_m=3.0, v_uncertainty_m=1.0, latency_s=0.05, bank_rad=bank, wind_extra_mps=1.5)
    pruned = bs.activation_margins(*args, **kw)
    monkeypatch_free.setattr(bs, "PRUNE_FROM_EDGES", 10**9)
    try:
        scanned = bs.activation_margins(*args, **kw)
    finally:
        monkeypatch_free.undo()
    assert repr(pruned) == repr(scanned)  # every field, bit for bit (repr round-trips floats)


@pytest.fixture(scope="module")
def monkeypatch_free():
    """A monkeypatch usable with hypothesis (module scope: undone explicitly after each example)."""
    mp = pytest.MonkeyPatch()
    yield mp
    mp.undo()
