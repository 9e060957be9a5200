"""WGS-84 geodesy: a local East-North-Up frame and geodesic helpers.

The local frame is the exact geodetic -> ECEF -> ENU rotation about an origin
(the same transformation as GeographicLib's ``LocalCartesian``, which the
Python ``geographiclib`` package does not ship). The ellipsoid constants come
from ``geographiclib.Constants``. Geodesic distance and azimuth use
``geographiclib.geodesic.Geodesic.WGS84``.

Scalar methods use ``math`` (they run on the simulation's per-step path);
``*_array`` methods are vectorized with numpy for recorded trajectories.
Latitudes/longitudes are in degrees, heights and ENU coordinates in metres.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from geographiclib.constants import Constants
from geographiclib.geodesic import Geodesic

from geofence import jit as _jit
from geofence.jit import compiled, jitable

WGS84_A_M: float = Constants.WGS84_a
WGS84_F: float = Constants.WGS84_f
_E2 = WGS84_F * (2.0 - WGS84_F)
_B = WGS84_A_M * (1.0 - WGS84_F)
_EP2 = _E2 / (1.0 - _E2)


@jitable
def radii_of_curvature_m(lat_rad: float) -> tuple[float, float]:
    """``(N, M)``: the WGS-84 prime-vertical and meridian radii of curvature (m) at geodetic latitude ``lat_rad``;
    a metre north is ``1 / (M + h)`` rad of latitude, a metre east ``1 / ((N + h) cos lat)`` of longitude."""
    s = math.sin(lat_rad)
    w = 1.0 - _E2 * s * s
    n_rad = WGS84_A_M / math.sqrt(w)
    return n_rad, n_rad * (1.0 - _E2) / w


@jitable
def geodetic_to_ecef(lat_deg: float, lon_deg: float, h_m: float) -> tuple[float, float, float]:
    """WGS-84 geodetic coordinates to Earth-centred Earth-fixed x, y, z in m."""
    lat = math.radians(lat_deg)
    lon = math.radians(lon_deg)
    s, c = math.sin(lat), math.cos(lat)
    n = WGS84_A_M / math.sqrt(1.0 - _E2 * s * s)
    return ((n + h_m) * c * math.cos(lon), (n + h_m) * c * math.sin(lon), (n * (1.0 - _E2) + h_m) * s)


def ecef_to_geodetic(x: float, y: float, z: float) -> tuple[float, float, float]:
    """ECEF x, y, z in m to WGS-84 lat/lon in deg and ellipsoidal height in m.

    Bowring's method with two refinement iterations: sub-millimetre for any
    height a small UAS can reach.
    """
    p = math.hypot(x, y)
    lon = math.atan2(y, x)
    lat = math.atan2(z, p * (1.0 - _E2))
    for _ in range(3):
        s = math.sin(lat)
        n = WGS84_A_M / math.sqrt(1.0 - _E2 * s * s)
        h = p / math.cos(lat) - n if abs(lat) < math.radians(89.0) else z / s - n * (1.0 - _E2)
        lat = math.atan2(z, p * (1.0 - _E2 * n / (n + h)))
    s = math.sin(lat)
    n = WGS84_A_M / math.sqrt(1.0 - _E2 * s * s)
    h = p / math.cos(lat) - n if abs(lat) < math.radians(89.0) else z / s - n * (1.0 - _E2)
    return math.degrees(lat), math.degrees(lon), h


@jitable
def enu_of(T: np.ndarray | tuple, lat_deg: float, lon_deg: float, h_m: float) -> tuple[float, float, float]:
    """:meth:`LocalFrame.to_enu` with the frame as its table ``T`` (:attr:`LocalFrame.enu_table`: the origin in
    ECEF, then the rotation's rows), the one home of the ENU rotation for Python and compiled callers."""
    x, y, z = geodetic_to_ecef(lat_deg, lon_deg, h_m)
    dx, dy, dz = x - T[0], y - T[1], z - T[2]
    return (
        T[3] * dx + T[4] * dy + T[5] * dz,
        T[6] * dx + T[7] * dy + T[8] * dz,
        T[9] * dx + T[10] * dy + T[11] * dz,
    )


_enu_of_compiled = compiled(enu_of)


@dataclass(frozen=True)
class LocalFrame:
    """East-North-Up frame tangent to WGS-84 at an origin (lat/lon deg, height m)."""

    lat0_deg: float
    lon0_deg: float
    h0_m: float = 0.0
    _enu_tuple: tuple = field(init=False, repr=False, compare=False)
    """:attr:`enu_table` as Python floats (the plain-Python conversions read it)."""
    enu_table: np.ndarray = field(init=False, repr=False, compare=False)
    """The origin in ECEF (x, y, z) then the ECEF -> ENU rotation's rows (east, north, up): :func:`enu_of`'s table."""

    def __post_init__(self) -> None:
        if not -90.0 <= self.lat0_deg <= 90.0 or not -180.0 <= self.lon0_deg <= 180.0:
            raise ValueError(f"origin ({self.lat0_deg}, {self.lon0_deg}) deg is not a valid lat/lon")
        lat, lon = math.radians(self.lat0_deg), math.radians(self.lon0_deg)
        sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
        # rows: east, north, up unit vectors in ECEF
        rot = ((-so, co, 0.0), (-sl * co, -sl * so, cl), (cl * co, cl * so, sl))
        table = (*geodetic_to_ecef(self.lat0_deg, self.lon0_deg, self.h0_m), *rot[0], *rot[1], *rot[2])
        object.__setattr__(self, "_enu_tuple", table)
        object.__setattr__(self, "enu_table", np.array(table, dtype=np.float64))

    def to_enu(self, lat_deg: float, lon_deg: float, h_m: float) -> tuple[float, float, float]:
        """Geodetic point -> (east, north, up) in m (:func:`enu_of`, compiled)."""
        e, n, u = _enu_of_compiled(self.enu_table, lat_deg, lon_deg, h_m)
        return float(e), float(n), float(u)

    def enu_function(self) -> Callable[[float, float, float], tuple[float, float, float]]:
        """:meth:`to_enu` as one callable for a caller that converts every step: the compiled conversion by its
        entry point with this frame's table bound (:func:`geofence.jit.entry_point`: the table is this frame's own
        array; without numba, :meth:`to_enu`)."""
        if not _jit.COMPILED:
            return self.to_enu
        _enu_of_compiled(self.enu_table, self.lat0_deg, self.lon0_deg, self.h0_m)  # (its one specialization)
        return partial(_jit.entry_point(_enu_of_compiled), self.enu_table)

    def to_geodetic(self, east_m: float, north_m: float, up_m: float) -> tuple[float, float, float]:
        """(east, north, up) in m -> geodetic (lat deg, lon deg, height m)."""
        x0, y0, z0, e0, e1, e2, n0, n1, n2, u0, u1, u2 = self._enu_tuple
        x = x0 + e0 * east_m + n0 * north_m + u0 * up_m
        y = y0 + e1 * east_m + n1 * north_m + u1 * up_m
        z = z0 + e2 * east_m + n2 * north_m + u2 * up_m
        return ecef_to_geodetic(x, y, z)

    def to_enu_array(self, lat_deg, lon_deg, h_m) -> np.ndarray:
        """Vectorized :meth:`to_enu`; returns an (N, 3) array of east, north, up in m."""
        lat = np.radians(np.asarray(lat_deg, dtype=float))
        lon = np.radians(np.asarray(lon_deg, dtype=float))
        h = np.asarray(h_m, dtype=float)
        s, c = np.sin(lat), np.cos(lat)
        n = WGS84_A_M / np.sqrt(1.0 - _E2 * s * s)
        ecef = np.stack([(n + h) * c * np.cos(lon), (n + h) * c * np.sin(lon), (n * (1.0 - _E2) + h) * s], axis=-1)
        return (ecef - self.enu_table[:3]) @ self.enu_table[3:].reshape(3, 3).T

    def to_geodetic_array(self, enu_m) -> np.ndarray:
        """Vectorized :meth:`to_geodetic` for an (N, 3) ENU array; returns (N, 3) lat, lon, h."""
        enu = np.atleast_2d(np.asarray(enu_m, dtype=float))
        return np.array([self.to_geodetic(*row) for row in enu])


def geodesic_distance_m(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> float:
    """Geodesic (ellipsoidal) distance between two points in m."""
    return Geodesic.WGS84.Inverse(lat1_deg, lon1_deg, lat2_deg, lon2_deg, Geodesic.DISTANCE)["s12"]


def geodesic_azimuth_deg(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> float:
    """Initial geodesic azimuth from point 1 to point 2, deg clockwise from north."""
    return Geodesic.WGS84.Inverse(lat1_deg, lon1_deg, lat2_deg, lon2_deg, Geodesic.AZIMUTH)["azi1"]


def geodesic_destination(lat_deg: float, lon_deg: float, azimuth_deg: float, distance_m: float) -> tuple[float, float]:
    """The point reached by travelling ``distance_m`` along a geodesic at ``azimuth_deg``."""
    r = Geodesic.WGS84.Direct(lat_deg, lon_deg, azimuth_deg, distance_m, Geodesic.LATITUDE | Geodesic.LONGITUDE)
    return r["lat2"], r["lon2"]
