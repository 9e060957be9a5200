"""Generate a synthetic city park as a large GeoJSON airspace fence (for scale tests of the geofence).

::

    python -m scenarios.airspace.generate                      # the shipped scenarios/airspace/city_park.geojson
    python -m scenarios.airspace.generate --seed 7 --vertices 20000 --buildings 800 -o /tmp/park.geojson

What it writes (an RFC 7946 FeatureCollection, coordinates ``[lon, lat]``; our own synthetic data):

* **keep-in**: the park boundary, one Polygon with ``--vertices`` vertices around the centre. Its
  radius is ``--radius-m`` times ``1 + roughness * s(theta)``, where ``s`` is a sum of harmonics
  ``k = 2 .. vertices/20`` with random phases and amplitudes falling as ``k**-1.3`` (a ragged,
  fractal-looking edge: bays and headlands down to metre-scale wiggles), normalised to ``|s| <= 1``.
  The vertices are taken at strictly increasing angles around the centre, so the polygon is
  star-shaped about it and therefore simple (no self-intersection) by construction.
* **keep-outs**: ``--buildings`` buildings, rotated rectangles (10-40 m sides) and hexagons (10-40 m
  across corners), each one Polygon feature with ``"geofence": "keep_out"``. Placed by rejection
  sampling so that their circumscribed circles are at least ``--clearance-m`` apart from each
  other and from the park boundary (so the polygons are too, and a 1 m-class drone can pass
  between any two), and outside a building-free *meadow* of ``--meadow-radius-m`` around the
  centre and ``--avenues`` straight radial *avenues* ``--avenue-width-m`` wide from the meadow to
  the boundary (open ground where missions can fly legs and the pole of inaccessibility is large).
* a ``"geofence": "return_point"`` Point at the centre of the meadow (the fence's recovery point);
* collection properties: ``ceiling_m``, ``name``, and ``generator``, the command that regenerates
  the file.

Everything is deterministic for a seed (numpy PCG64). Coordinates are rounded to 1e-8 deg
(about 1 mm); buildings are placed with :data:`ROUNDING_SLACK_M` extra clearance so the stated
clearance still holds for the rounded coordinates.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from analysis.formats.replace import replace_text
from geofence.geometry.geodesy import LocalFrame

DEFAULT_OUT = Path(__file__).with_name("city_park.geojson")
DEFAULT_CENTER = (-35.3632, 149.1652)
"""A flat site (the CMAC field near Canberra used by the other shipped scenarios), deg."""
COORD_DECIMALS = 8
ROUNDING_SLACK_M = 0.05
"""Extra clearance (m) used when placing buildings, covering the 1e-8 deg rounding of the written coordinates."""


def park_boundary_en(rng: np.random.Generator, n_vertices: int, radius_m: float, roughness: float = 0.3) -> np.ndarray:
    """``(n_vertices, 2)`` east/north (m) of a star-shaped ragged boundary around (0, 0), counter-clockwise."""
    if n_vertices < 16:
        raise ValueError(f"--vertices must be >= 16, got {n_vertices}")
    if not 0.0 <= roughness < 0.9:
        raise ValueError(f"roughness must be in [0, 0.9), got {roughness}")
    k = np.arange(2, max(3, n_vertices // 20) + 1)
    amp = k**-1.3 * rng.uniform(0.5, 1.0, len(k))
    phase = rng.uniform(0.0, 2.0 * math.pi, len(k))
    # strictly increasing angles: a uniform grid jittered by at most a quarter step
    step = 2.0 * math.pi / n_vertices
    theta = (np.arange(n_vertices) + rng.uniform(-0.25, 0.25, n_vertices)) * step
    s = np.zeros(n_vertices)
    for kk, a, ph in zip(k, amp, phase):
        s += a * np.cos(kk * theta + ph)
    s /= np.abs(s).max()
    r = radius_m * (1.0 + roughness * s)
    return np.stack([r * np.cos(theta), r * np.sin(theta)], axis=1)


def _building(rng: np.random.Generator, size_m: tuple[float, float]) -> tuple[np.ndarray, float]:
    """A building footprint around (0, 0): ``(vertices (N, 2), circumradius m)``."""
    lo, hi = size_m
    rot = rng.uniform(0.0, math.pi)
    if rng.uniform() < 0.7:  # rotated rectangle
        w, length = rng.uniform(lo, hi, 2)
        pts = np.array([[-w, -length], [w, -length], [w, length], [-w, length]]) * 0.5
    else:  # hexagon, lo..hi across corners
        rc = 0.5 * rng.uniform(lo, hi)
        a = np.arange(6) * math.pi / 3.0
        pts = np.stack([rc * np.cos(a), rc * np.sin(a)], axis=1)
    c, s = math.cos(rot), math.sin(rot)
    pts = pts @ np.array([[c, s], [-s, c]])
    return pts, float(np.hypot(pts[:, 0], pts[:, 1]).max())


def _boundary_distance(points: np.ndarray, boundary: np.ndarray) -> np.ndarray:
    """Unsigned distance (m) from each point to the closed polyline ``boundary``."""
    a = boundary
    d = np.roll(boundary, -1, axis=0) - a
    l2 = np.einsum("ij,ij->i", d, d)
    out = np.empty(len(points))
    for i, p in enumerate(points):
        t = np.clip(((p[0] - a[:, 0]) * d[:, 0] + (p[1] - a[:, 1]) * d[:, 1]) / l2, 0.0, 1.0)
        out[i] = np.sqrt(np.min((a[:, 0] + t * d[:, 0] - p[0]) ** 2 + (a[:, 1] + t * d[:, 1] - p[1]) ** 2))
    return out


def _boundary_radius(theta: np.ndarray, boundary: np.ndarray) -> np.ndarray:
    """Radius of the star-shaped boundary along direction ``theta`` (intersection with the edge in that sector)."""
    ang = np.mod(np.arctan2(boundary[:, 1], boundary[:, 0]), 2.0 * math.pi)
    order = np.argsort(ang)
    ang, b = ang[order], boundary[order]
    th = np.mod(theta, 2.0 * math.pi)
    j = np.searchsorted(ang, th) % len(b)
    i = (j - 1) % len(b)
    p, q = b[i], b[j]
    ux, uy = np.cos(th), np.sin(th)
    # ray t*(ux, uy) meets segment p + s (q - p): solve t u - s (q - p) = p
    dx, dy = q[:, 0] - p[:, 0], q[:, 1] - p[:, 1]
    det = -ux * dy + uy * dx
    return (-p[:, 0] * dy + p[:, 1] * dx) / det


def place_buildings(
    rng: np.random.Generator,
    boundary: np.ndarray,
    n: int,
    *,
    size_m: tuple[float, float] = (10.0, 40.0),
    clearance_m: float = 30.0,
    meadow_radius_m: float = 250.0,
    avenue_angles_rad: tuple[float, ...] = (),
    avenue_width_m: float = 120.0,
    max_tries: int = 400_000,
) -> list[np.ndarray]:
    """``n`` building footprints (east/north m) inside ``boundary``, each at least ``clearance_m`` from the others and the boundary.

    Raises ValueError when ``max_tries`` candidates could not place ``n``.
    """
    r_max = float(np.hypot(boundary[:, 0], boundary[:, 1]).max())
    cell = 2.0 * (0.5 * math.sqrt(2.0) * size_m[1]) + clearance_m  # >= any centre separation that matters
    grid: dict[tuple[int, int], list[int]] = {}
    centres: list[tuple[float, float, float]] = []
    out: list[np.ndarray] = []
    tries = 0
    batch = 256
    while len(out) < n:
        if tries >= max_tries:
            raise ValueError(
                f"placed only {len(out)} of {n} buildings in {max_tries} tries: "
                f"use a larger radius, fewer buildings or a smaller clearance"
            )
        # candidates uniform in the disk; cheap filters first, exact boundary distance last
        rr = r_max * np.sqrt(rng.uniform(0.0, 1.0, batch))
        th = rng.uniform(0.0, 2.0 * math.pi, batch)
        shapes = [_building(rng, size_m) for _ in range(batch)]
        tries += batch
        rb = _boundary_radius(th, boundary)
        for c_r, c_th, (pts, rho), r_b in zip(rr, th, shapes, rb):
            if len(out) >= n:
                break
            if c_r + rho + clearance_m > r_b or c_r < meadow_radius_m + rho:
                continue
            e, nn = c_r * math.cos(c_th), c_r * math.sin(c_th)
            if any(
                abs(e * math.sin(a) - nn * math.cos(a)) < 0.5 * avenue_width_m + rho and e * math.cos(a) + nn * math.sin(a) > 0.0
                for a in avenue_angles_rad
            ):
                continue
            gx, gy = int(math.floor(e / cell)), int(math.floor(nn / cell))
            clash = False
            for ix in (gx - 1, gx, gx + 1):
                for iy in (gy - 1, gy, gy + 1):
                    for j in grid.get((ix, iy), ()):
                        ce, cn, cr = centres[j]
                        if math.hypot(ce - e, cn - nn) < cr + rho + clearance_m:
                            clash = True
                            break
                    if clash:
                        break
                if clash:
                    break
            if clash:
                continue
            if _boundary_distance(np.array([[e, nn]]), boundary)[0] < rho + clearance_m:
                continue
            grid.setdefault((gx, gy), []).append(len(centres))
            centres.append((e, nn, rho))
            out.append(pts + np.array([e, nn]))
    return out


def generate_park(
    *,
    seed: int = 2026,
    center: tuple[float, float] = DEFAULT_CENTER,
    radius_m: float = 1600.0,
    n_vertices: int = 10_000,
    n_buildings: int = 500,
    clearance_m: float = 30.0,
    size_m: tuple[float, float] = (10.0, 40.0),
    meadow_radius_m: float = 250.0,
    avenues: int = 4,
    avenue_width_m: float = 120.0,
    roughness: float = 0.3,
    ceiling_m: float = 120.0,
    generator: str | None = None,
) -> dict:
    """The park as a GeoJSON FeatureCollection (a dict ready for :func:`json.dump`); see the module docstring."""
    rng = np.random.default_rng(seed)
    boundary = park_boundary_en(rng, n_vertices, radius_m, roughness)
    if meadow_radius_m + clearance_m >= radius_m * (1.0 - roughness):
        raise ValueError(
            f"--meadow-radius-m {meadow_radius_m:g} does not fit inside the park (radius {radius_m:g} m, roughness {roughness:g})"
        )
    offset = rng.uniform(0.0, 2.0 * math.pi)
    angles = tuple(offset + 2.0 * math.pi * k / avenues for k in range(avenues)) if avenues > 0 else ()
    buildings = place_buildings(
        rng,
        boundary,
        n_buildings,
        size_m=size_m,
        clearance_m=clearance_m + ROUNDING_SLACK_M,
        meadow_radius_m=meadow_radius_m,
        avenue_angles_rad=angles,
        avenue_width_m=avenue_width_m,
    )
    frame = LocalFrame(center[0], center[1], 0.0)

    def ring(en: np.ndarray) -> list[list[float]]:
        pts = [
            [round(lon, COORD_DECIMALS), round(lat, COORD_DECIMALS)]
            for lat, lon, _ in (frame.to_geodetic(float(e), float(n), 0.0) for e, n in en)
        ]
        return pts + [pts[0]]  # RFC 7946: closed rings

    def feature(props: dict, geometry: dict) -> dict:
        return {"type": "Feature", "properties": props, "geometry": geometry}

    if generator is None:
        generator = (
            "python -m scenarios.airspace.generate "
            f"--seed {seed} --center {center[0]:.10g} {center[1]:.10g} --radius-m {radius_m:g} --vertices {n_vertices} "
            f"--buildings {n_buildings} --clearance-m {clearance_m:g} --meadow-radius-m {meadow_radius_m:g} "
            f"--avenues {avenues} --avenue-width-m {avenue_width_m:g} --roughness {roughness:g} --ceiling-m {ceiling_m:g}"
        )

    def ccw(en: np.ndarray) -> np.ndarray:  # RFC 7946 right-hand rule: exterior rings counter-clockwise (east/north)
        return en if _area(en) > 0.0 else en[::-1]

    features = [
        feature({"geofence": "keep_in", "name": "park boundary"}, {"type": "Polygon", "coordinates": [ring(ccw(boundary))]})
    ]
    for i, b in enumerate(buildings):
        features.append(
            feature({"geofence": "keep_out", "name": f"building {i}"}, {"type": "Polygon", "coordinates": [ring(ccw(b))]})
        )
    features.append(
        feature(
            {"geofence": "return_point", "name": "meadow"},
            {"type": "Point", "coordinates": [round(center[1], COORD_DECIMALS), round(center[0], COORD_DECIMALS)]},
        )
    )
    return {
        "type": "FeatureCollection",
        "properties": {
            "name": "synthetic city park",
            "ceiling_m": ceiling_m,
            "generator": generator,
            "license": "generated by the geofence testbed; no real-world data",
        },
        "features": features,
    }


def bounding_rectangle(park: dict, generator: str | None = None) -> dict:
    """The 4-vertex twin of a park: its keep-in's lon/lat bounding box, no keep-outs, the same ceiling and return point.

    For wall-time comparisons: the same missions fly inside it, against a fence of 4 vertices.
    """
    keep_in = next(f for f in park["features"] if f["properties"].get("geofence") == "keep_in")
    ring = keep_in["geometry"]["coordinates"][0]
    w, e = min(p[0] for p in ring), max(p[0] for p in ring)
    s, n = min(p[1] for p in ring), max(p[1] for p in ring)
    props = {k: v for k, v in park.get("properties", {}).items() if k != "generator"}
    props["name"] = f"bounding rectangle of the {props.get('name', 'park')}"
    if generator is not None:
        props["generator"] = generator
    features = [
        {
            "type": "Feature",
            "properties": {"geofence": "keep_in", "name": "rectangle"},
            "geometry": {"type": "Polygon", "coordinates": [[[w, s], [e, s], [e, n], [w, n], [w, s]]]},
        }
    ]
    features += [f for f in park["features"] if f["properties"].get("geofence") in ("return_point", "rally")]
    return {"type": "FeatureCollection", "properties": props, "features": features}


def _area(en: np.ndarray) -> float:
    x, y = en[:, 0], en[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def write_geojson(doc: dict, path: str | Path) -> Path:
    """Write ``doc`` compactly (one feature per line), atomically."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    head = {k: v for k, v in doc.items() if k != "features"}
    lines = [json.dumps(f, separators=(",", ":")) for f in doc["features"]]
    text = json.dumps(head, separators=(",", ":"))[:-1] + ',"features":[\n' + ",\n".join(lines) + "\n]}\n"
    return replace_text(path, text)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m scenarios.airspace.generate",
        description=(
            "Write a synthetic city park as an RFC 7946 GeoJSON airspace fence: a ragged star-shaped keep-in "
            "boundary with many vertices, many small building keep-outs with guaranteed clearances, a "
            "building-free meadow (with the return point) and avenues. Deterministic for a seed."
        ),
    )
    p.add_argument(
        "-o",
        "--output",
        type=Path,
        default=DEFAULT_OUT,
        metavar="FILE.geojson",
        help="where to write (default: scenarios/airspace/city_park.geojson beside this script)",
    )
    p.add_argument("--seed", type=int, default=2026, help="random seed (default 2026)")
    p.add_argument(
        "--center",
        type=float,
        nargs=2,
        default=list(DEFAULT_CENTER),
        metavar=("LAT", "LON"),
        help="park centre, deg (default: %(default)s)",
    )
    p.add_argument("--radius-m", type=float, default=1600.0, help="mean boundary radius, m (default 1600)")
    p.add_argument("--vertices", type=int, default=10_000, help="keep-in vertex count (default 10000)")
    p.add_argument("--buildings", type=int, default=500, help="number of building keep-outs (default 500)")
    p.add_argument(
        "--clearance-m",
        type=float,
        default=30.0,
        help="least free space between buildings, and between a building and the boundary, m (default 30)",
    )
    p.add_argument("--meadow-radius-m", type=float, default=250.0, help="building-free meadow around the centre, m (default 250)")
    p.add_argument(
        "--avenues", type=int, default=4, help="building-free radial avenues from the meadow to the boundary (default 4)"
    )
    p.add_argument("--avenue-width-m", type=float, default=120.0, help="avenue width, m (default 120)")
    p.add_argument(
        "--roughness", type=float, default=0.3, help="boundary radius varies within +/- this fraction of --radius-m (default 0.3)"
    )
    p.add_argument("--ceiling-m", type=float, default=120.0, help="ceiling written into the file, m AGL (default 120)")
    p.add_argument(
        "--rectangle",
        type=Path,
        default=None,
        metavar="FILE.geojson",
        help="also write the park's 4-vertex twin here: its bounding rectangle, no keep-outs, the same "
        "ceiling and return point (for wall-time comparisons)",
    )
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        doc = generate_park(
            seed=args.seed,
            center=tuple(args.center),
            radius_m=args.radius_m,
            n_vertices=args.vertices,
            n_buildings=args.buildings,
            clearance_m=args.clearance_m,
            meadow_radius_m=args.meadow_radius_m,
            avenues=args.avenues,
            avenue_width_m=args.avenue_width_m,
            roughness=args.roughness,
            ceiling_m=args.ceiling_m,
        )
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    path = write_geojson(doc, args.output)
    n_in = len(doc["features"][0]["geometry"]["coordinates"][0]) - 1
    print(f"wrote {path}: keep-in {n_in} vertices, {len(doc['features']) - 2} building keep-outs")
    if args.rectangle is not None:
        rect = bounding_rectangle(doc, generator=f"{doc['properties']['generator']} --rectangle {args.rectangle}")
        print(f"wrote {write_geojson(rect, args.rectangle)}: its 4-vertex bounding rectangle")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
