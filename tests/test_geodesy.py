"""WGS-84 local frame: round trips, agreement with GeographicLib geodesics, orientation."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence.geometry.geodesy import (
    LocalFrame,
    ecef_to_geodetic,
    enu_of,
    geodesic_destination,
    geodesic_distance_m,
    geodetic_to_ecef,
)

lats = st.floats(-80.0, 80.0)
lons = st.floats(-179.0, 179.0)


@given(lats, lons, st.floats(-100.0, 5000.0))
def test_ecef_round_trip_is_sub_millimetre(lat, lon, h):
    la, lo, hh = ecef_to_geodetic(*geodetic_to_ecef(lat, lon, h))
    assert abs(la - lat) < 1e-9 and abs(lo - lon) < 1e-9 and abs(hh - h) < 1e-3


@given(lats, lons, st.floats(-2000, 2000), st.floats(-2000, 2000), st.floats(-50, 500))
def test_enu_round_trip(lat0, lon0, e, n, u):
    frame = LocalFrame(lat0, lon0, 100.0)
    lat, lon, h = frame.to_geodetic(e, n, u)
    e2, n2, u2 = frame.to_enu(lat, lon, h)
    assert math.isclose(e2, e, abs_tol=1e-4) and math.isclose(n2, n, abs_tol=1e-4) and math.isclose(u2, u, abs_tol=1e-4)


def test_axes_point_east_north_up():
    frame = LocalFrame(-35.36, 149.16, 584.0)
    lat, lon = geodesic_destination(-35.36, 149.16, 90.0, 100.0)
    e, n, _ = frame.to_enu(lat, lon, 584.0)
    assert 99.9 < e < 100.1 and abs(n) < 0.1
    lat, lon = geodesic_destination(-35.36, 149.16, 0.0, 100.0)
    e, n, _ = frame.to_enu(lat, lon, 584.0)
    assert 99.9 < n < 100.1 and abs(e) < 1e-6
    assert frame.to_enu(-35.36, 149.16, 600.0)[2] == pytest.approx(16.0, abs=1e-6)


@settings(max_examples=50)
@given(lats, lons, st.floats(0.0, 360.0), st.floats(10.0, 5000.0))
def test_planar_distance_matches_geodesic_within_projection_error(lat0, lon0, azi, dist):
    """Within 5 km of the origin the tangent-plane distance errs by < 2e-6 relative (plus curvature drop)."""
    frame = LocalFrame(lat0, lon0, 0.0)
    lat, lon = geodesic_destination(lat0, lon0, azi, dist)
    e, n, _ = frame.to_enu(lat, lon, 0.0)
    assert abs(math.hypot(e, n) - geodesic_distance_m(lat0, lon0, lat, lon)) < 2e-6 * dist + 1e-6


def test_vectorized_matches_scalar():
    frame = LocalFrame(47.4, 8.5, 400.0)
    lat = np.array([47.40, 47.41, 47.39])
    lon = np.array([8.50, 8.52, 8.49])
    h = np.array([400.0, 420.0, 390.0])
    arr = frame.to_enu_array(lat, lon, h)
    for i in range(3):
        assert np.allclose(arr[i], frame.to_enu(lat[i], lon[i], h[i]), atol=1e-6)


def test_invalid_origin_is_rejected():
    with pytest.raises(ValueError, match="lat/lon"):
        LocalFrame(123.0, 8.0)


@settings(max_examples=200, deadline=None)
@given(
    lat0=st.floats(-89.0, 89.0),
    lon0=st.floats(-180.0, 180.0),
    h0=st.floats(-400.0, 5000.0),
    dlat=st.floats(-0.05, 0.05),
    dlon=st.floats(-0.05, 0.05),
    h=st.floats(-400.0, 9000.0),
)
def test_compiled_to_enu_is_the_interpreted_one(lat0, lon0, h0, dlat, dlon, h):
    """``LocalFrame.to_enu`` (``geodesy.enu_of`` compiled, the truth read-out's every step) gives the numbers of
    the same function interpreted on the frame's table, to 1 µm, as Python floats."""
    frame = LocalFrame(lat0, lon0, h0)
    lat, lon = lat0 + dlat, lon0 + dlon
    got = frame.to_enu(lat, lon, h)
    ref = enu_of(tuple(frame.enu_table), lat, lon, h)
    assert got == pytest.approx(ref, abs=1e-6)
    assert all(type(x) is float for x in got)  # no numpy scalars leak into summaries
