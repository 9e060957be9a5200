"""The plotted activation field: computed in chunks of points, the same as in one piece, for any fence size."""

import tracemalloc

import numpy as np
import pytest

from aircraft.profile import load_profile
from analysis.boundary import activation_field
from geofence.geometry.geodesy import LocalFrame
from geofence.unit.config import parse_geofence

FRAME = LocalFrame(47.0, 8.0, 400.0)
ENV = load_profile("F450RD").envelope


def ragged_fence(n: int):
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    r = 300.0 + 20.0 * np.sin(7.0 * a)
    keep_in = [list(FRAME.to_geodetic(float(x), float(y), 0.0)[:2]) for x, y in zip(r * np.cos(a), r * np.sin(a))]
    box = [(-60.0, -60.0), (-20.0, -60.0), (-20.0, -20.0), (-60.0, -20.0)]
    keep_out = [[list(FRAME.to_geodetic(x, y, 0.0)[:2]) for x, y in box]]
    return parse_geofence({"fence": {"keep_in": keep_in, "keep_out_polygons": keep_out, "ceiling_m": 60}}).fence.to_local(FRAME)


@pytest.mark.parametrize("chunk_pairs", [1, 37, 10_000])
def test_the_field_in_chunks_is_the_field_in_one_piece(chunk_pairs):
    fence = ragged_fence(240)
    whole = activation_field(fence, ENV, (3.0, -2.0), resolution=40, chunk_pairs=10**9)[2]
    parts = activation_field(fence, ENV, (3.0, -2.0), resolution=40, chunk_pairs=chunk_pairs)[2]
    assert np.array_equal(whole, parts)
    assert (whole > 0).any() and (whole < 0).any()  # a boundary to draw


def test_an_airspace_sized_fence_is_drawn_in_bounded_memory():
    """10,000 edges on a 60 x 60 grid: one (points, edges, 2) array would be 576 MB; the chunks stay far below."""
    fence = ragged_fence(10_000)
    tracemalloc.start()
    try:
        field = activation_field(fence, ENV, (0.0, 0.0), resolution=60)[2]
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert np.isfinite(field).all()
    assert peak < 200e6
