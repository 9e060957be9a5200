"""The plotted activation field: computed in chunks of points, the same as in one piece, for any fence size."""

import numpy as np
import pytest

import analysis.boundary as boundary
from aircraft.profile import load_profile
from geofence.config import parse_geofence
from geofence.geodesy import LocalFrame

FRAME = LocalFrame(47.0, 8.0, 400.0)
ENV = load_profile("F450RD").envelope


def ragged_fence(n: int):
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    r = 300.0 + 20.0 * np.sin(7.0 * a)
    keep_in = [list(FRAME.to_geodetic(float(x), float(y), 0.0)[:2]) for x, y in zip(r * np.cos(a), r * np.sin(a))]
    box = [(-60.0, -60.0), (-20.0, -60.0), (-20.0, -20.0), (-60.0, -20.0)]
    keep_out = [[list(FRAME.to_geodetic(x, y, 0.0)[:2]) for x, y in box]]
    return parse_geofence({"fence": {"keep_in": keep_in, "keep_out_polygons": keep_out, "ceiling_m": 60}}).fence.to_local(FRAME)


@pytest.mark.parametrize("chunk", [1, 37, 10_000])
def test_the_field_in_chunks_is_the_field_in_one_piece(monkeypatch, chunk):
    fence = ragged_fence(240)
    whole = boundary.activation_field(fence, ENV, (3.0, -2.0), resolution=40)[2]
    monkeypatch.setattr(boundary, "CHUNK_PAIRS", chunk)
    parts = boundary.activation_field(fence, ENV, (3.0, -2.0), resolution=40)[2]
    assert np.array_equal(whole, parts)
    assert (whole > 0).any() and (whole < 0).any()  # a boundary to draw


def test_an_airspace_sized_fence_never_holds_every_point_edge_pair_at_once(monkeypatch):
    """10,000 edges on the plot's grid would need 7 GB in one array; the chunks hold CHUNK_PAIRS pairs."""
    fence = ragged_fence(10_000)
    seen = []
    real = boundary._segment_distances

    def spy(poly, pts):
        seen.append(len(pts) * len(poly.starts))
        return real(poly, pts)

    monkeypatch.setattr(boundary, "_segment_distances", spy)
    boundary.activation_field(fence, ENV, (0.0, 0.0), resolution=30)
    assert max(seen) <= boundary.CHUNK_PAIRS
