"""A recorded flight as GeoJSON (QGIS) or KML (Google Earth): the flown track, its geofence modes, its events.

What is written, from a flight's columns (``trajectory.csv``'s names: ``time_s``, ``lat_deg``, ``lon_deg``,
``alt_m``, ``east_m``, ``north_m``, ``up_m``, ``geofence_mode``), its mode transitions (``summary.json``'s
``mode_transitions``) and its fence:

* the track as 3-D lines ([lon, lat, alt_m]), one per run of one geofence mode (MONITOR, OVERRIDE, RECOVERED,
  LAND_IN_GAP, TERMINATE). A segment ends on the first sample of the next one, so the line is unbroken.
  GeoJSON: ``properties.mode`` and a simplestyle-spec ``stroke`` colour (:data:`MODE_COLOURS`); KML: one
  ``Placemark`` per segment with the mode's ``LineStyle``, ``altitudeMode`` absolute.
* a point at each mode transition (its time, from, to, reason), at the first sample recorded in the new mode,
  and a point at the peak excursion: the sample of smallest 3-D fence margin
  (:func:`analysis.scoring.margins`, whose minimum is the score's ``max_excursion_m``).
* the fence, written by :mod:`analysis.formats.fence_files` (the same features and placemarks as
  ``export-fence``); in KML its heights are made absolute over the flight's ground, as the track is.

Heights: ``alt_m`` is the height the platforms report, above the WGS-84 ellipsoid (RFC 7946's third coordinate);
KML's ``absolute`` is above mean sea level, so Google Earth draws the track offset by the geoid height there (tens
of metres), and against its own terrain, not the scenario's flat ground at ``ground_alt_m``.

Decimation: a flight recorded at 40-100 Hz for an hour has ~10^5 samples. :func:`decimate` keeps the first and
last samples, every mode change, every transition's sample and the peak, and thins the rest with
Ramer-Douglas-Peucker in the flight's local ENU frame (``east_m``, ``north_m``, ``up_m``): every dropped sample
lies within ``tolerance_m`` (3-D) of the kept polyline. The tolerance, the largest deviation actually left and
the sample counts are written in the file (past :data:`DEFAULT_MAX_POINTS` vertices the tolerance is doubled
until the track fits, with a warning) (GeoJSON collection ``properties.decimation``, KML ``ExtendedData``).
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from analysis.formats.fence_files import (
    KML_NAMESPACE,
    geojson_fence_features,
    kml_fence_placemarks,
    kml_fence_styles,
    kml_text,
)
from analysis.scoring import margins
from geofence.geometry.fence import Fence
from geofence.geometry.local_fence import LocalFence
from geofence.unit.passes import Mode
from geofence.validation import ConfigError

FLIGHT_EXPORT_FORMATS = ("geojson", "kml")
DEFAULT_TOLERANCE_M = 0.5
"""Default decimation tolerance, m (3-D, local ENU)."""
DEFAULT_MAX_POINTS = 50_000
"""Most track vertices a file gets by default: past them the tolerance is doubled until the track fits (a noisy
track at 0.5 m can keep a third of an hour's 360,000 samples; 50,000 is a few MB that QGIS and Google Earth open)."""
TRACK_COLUMNS = ("time_s", "lat_deg", "lon_deg", "alt_m", "east_m", "north_m", "up_m", "geofence_mode")
"""The columns a track export reads (all finite on every row)."""
MODE_COLOURS = {
    Mode.MONITOR: "#2b83ba",
    Mode.OVERRIDE: "#d7191c",
    Mode.RECOVERED: "#1a9641",
    Mode.LAND_IN_GAP: "#fdae61",
    Mode.TERMINATE: "#000000",
}
"""Each geofence mode's line colour (``#rrggbb``): blue, red, green, orange, black."""
TRANSITION_COLOUR = "#7b3294"
PEAK_COLOUR = "#ff00ff"


class Transition(NamedTuple):
    """One mode transition of ``summary.json``'s ``mode_transitions``."""

    t_s: float
    from_mode: str
    to_mode: str
    reason: str


class Peak(NamedTuple):
    """The sample of the largest scored excursion (m beyond the fence; <= 0: never outside)."""

    sample: int
    excursion_m: float


class Decimated(NamedTuple):
    """The kept sample indices (ascending) and the largest 3-D distance of a dropped sample to the kept line, m."""

    indices: np.ndarray
    max_error_m: float


class Segment(NamedTuple):
    """Samples ``start`` .. ``stop`` (inclusive) flown in ``mode``."""

    mode: Mode
    start: int
    stop: int


@dataclass(frozen=True)
class FlightExport:
    """What one export holds: the file's text and the numbers it states."""

    text: str
    segments: tuple[Segment, ...]
    decimated: Decimated
    tolerance_m: float
    """The decimation tolerance the file states (the one asked for, or doubled past ``max_points``)."""
    peak: Peak | None
    warnings: tuple[str, ...] = ()


def check_track(columns: Mapping[str, np.ndarray], name: str, extra: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """The :data:`TRACK_COLUMNS` (and ``extra``) of a flight as float arrays, or a one-line :class:`ConfigError`
    naming ``name`` and the problem: a column missing, a row that is not a number (its CSV line: header = line 1),
    an unknown mode, time going backwards."""
    out: dict[str, np.ndarray] = {}
    for col in TRACK_COLUMNS + extra:
        if col not in columns:
            raise ConfigError(f"{name}: no column {col!r}: not a flight's trajectory")
        a = np.asarray(columns[col], dtype=float).reshape(-1)
        bad = np.flatnonzero(~np.isfinite(a))
        if len(bad):
            raise ConfigError(f"{name}: line {bad[0] + 2}: column {col!r} is not a number ({len(bad)} such rows)")
        out[col] = a
    n = len(out["time_s"])
    if n < 2:
        raise ConfigError(f"{name}: fewer than two rows: no track to export")
    known = np.isin(out["geofence_mode"], [int(m) for m in Mode])
    if not known.all():
        i = int(np.flatnonzero(~known)[0])
        raise ConfigError(f"{name}: line {i + 2}: geofence_mode {float(out['geofence_mode'][i]):g} is not a mode (0-4)")
    if np.any(np.diff(out["time_s"]) < 0):
        i = int(np.flatnonzero(np.diff(out["time_s"]) < 0)[0]) + 1
        raise ConfigError(f"{name}: line {i + 2}: time_s goes backwards")
    return out


def mode_segments(mode: np.ndarray) -> tuple[Segment, ...]:
    """The runs of one mode; each ends on the next run's first sample (a one-sample last run starts one earlier)."""
    m = np.asarray(mode).astype(int)
    n = len(m)
    starts = np.concatenate([[0], np.flatnonzero(np.diff(m) != 0) + 1])
    stops = np.concatenate([starts[1:], [n - 1]])
    return tuple(Segment(Mode(int(m[a])), int(a) if a < b else int(a) - 1, int(b)) for a, b in zip(starts, stops))


def peak_excursion(columns: Mapping[str, np.ndarray], fence: LocalFence) -> Peak:
    """The first sample of smallest 3-D margin (:func:`analysis.scoring.margins`) and its excursion (m)."""
    total = margins(dict(columns), fence)["total"]
    i = int(np.argmin(total))
    return Peak(i, float(-total[i]))


def transition_samples(time_s: np.ndarray, transitions: Sequence[Transition]) -> np.ndarray:
    """Each transition's sample: the first at or after its time (times are rounded to 1 ms in summary.json)."""
    t = np.asarray([tr.t_s for tr in transitions], dtype=float) - 5e-4
    return np.minimum(np.searchsorted(time_s, t, side="left"), len(time_s) - 1).astype(np.intp)


def segment_distances(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """3-D distances of points ``p`` (k, 3) to the segment ``a``-``b``."""
    ab = b - a
    den = float(ab @ ab)
    t = np.zeros(len(p)) if den == 0.0 else np.clip((p - a) @ ab / den, 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * ab), axis=1)


def decimate(points: np.ndarray, keep: np.ndarray, tolerance_m: float) -> Decimated:
    """Ramer-Douglas-Peucker on ``points`` (n, 3), m, keeping every sample where ``keep`` is true (and both ends):
    every dropped point lies within ``tolerance_m`` of the segment between the kept samples around it."""
    p = np.asarray(points, dtype=float)
    n = len(p)
    chosen = np.asarray(keep, dtype=bool).copy()
    chosen[[0, -1]] = True
    if tolerance_m <= 0.0:
        return Decimated(np.arange(n), 0.0)
    anchors = np.flatnonzero(chosen)
    stack = [(int(a), int(b)) for a, b in zip(anchors[:-1], anchors[1:]) if b - a > 1]
    worst = 0.0
    while stack:
        a, b = stack.pop()
        d = segment_distances(p[a + 1 : b], p[a], p[b])
        k = int(np.argmax(d))
        if d[k] <= tolerance_m:
            worst = max(worst, float(d[k]))
            continue
        i = a + 1 + k
        chosen[i] = True
        stack += [(lo, hi) for lo, hi in ((a, i), (i, b)) if hi - lo > 1]
    return Decimated(np.flatnonzero(chosen), worst)


def _plan(
    cols: Mapping[str, np.ndarray],
    transitions: Sequence[Transition],
    fence: LocalFence | None,
    tolerance_m: float,
    max_points: int,
) -> tuple[tuple[Segment, ...], np.ndarray, Peak | None, Decimated, float]:
    """Segments, transition samples, peak, the decimation that keeps them all and its tolerance (``tolerance_m``,
    doubled until at most ``max_points`` vertices are kept, if the forced ones allow)."""
    segments = mode_segments(cols["geofence_mode"])
    at = transition_samples(cols["time_s"], transitions)
    peak = peak_excursion(cols, fence) if fence is not None else None
    keep = np.zeros(len(cols["time_s"]), dtype=bool)
    keep[[s.start for s in segments] + [s.stop for s in segments]] = True
    keep[at] = True
    if peak is not None:
        keep[peak.sample] = True
    enu = np.column_stack([cols["east_m"], cols["north_m"], cols["up_m"]])
    dec = decimate(enu, keep, tolerance_m)
    while len(dec.indices) > max(max_points, int(keep.sum()) + 2) and tolerance_m > 0.0:
        tolerance_m *= 2.0
        dec = decimate(enu, keep, tolerance_m)
    return segments, at, peak, dec, tolerance_m


def _decimation_props(dec: Decimated, n: int, tolerance_m: float) -> dict[str, Any]:
    return {
        "method": "Ramer-Douglas-Peucker (3-D, local ENU); mode changes, transitions and the peak kept",
        "tolerance_m": tolerance_m, "max_error_m": round(dec.max_error_m, 4),
        "samples_recorded": n, "samples_kept": len(dec.indices),
    }  # fmt: skip


def _lla(cols: Mapping[str, np.ndarray], i: int) -> list[float]:
    return [float(cols["lon_deg"][i]), float(cols["lat_deg"][i]), float(cols["alt_m"][i])]


def export_flight(
    columns: Mapping[str, np.ndarray],
    fmt: str,
    *,
    name: str,
    title: str = "",
    transitions: Sequence[Transition] = (),
    fence: Fence | None = None,
    local_fence: LocalFence | None = None,
    ground_alt_m: float = 0.0,
    tolerance_m: float = DEFAULT_TOLERANCE_M,
    max_points: int = DEFAULT_MAX_POINTS,
    extrude: bool = False,
) -> FlightExport:
    """A flight as a file of ``fmt`` (:data:`FLIGHT_EXPORT_FORMATS`); see the module docstring. ``columns``: checked
    by :func:`check_track` (errors name ``name``, the file); ``title``: the flight's name in the file; ``local_fence``: ``fence`` in the flight's ENU frame (the peak excursion is scored
    against it); ``ground_alt_m``: the flight's flat ground (KML fence heights over it); ``max_points``: see
    :data:`DEFAULT_MAX_POINTS` (the tolerance used is the one the file states)."""
    if fmt not in FLIGHT_EXPORT_FORMATS:
        raise ConfigError(f"--to: unknown flight format {fmt!r}; expected one of {', '.join(FLIGHT_EXPORT_FORMATS)}")
    if not (math.isfinite(tolerance_m) and tolerance_m >= 0.0):
        raise ConfigError(f"--tolerance: {tolerance_m!r}: must be a number >= 0 (m)")
    if max_points < 2:
        raise ConfigError(f"--max-points: {max_points}: must be at least 2")
    cols = check_track(columns, name, ("agl_m",) if local_fence is not None else ())
    segments, at, peak, dec, used_m = _plan(cols, transitions, local_fence, tolerance_m, max_points)
    warnings: list[str] = []
    if used_m != tolerance_m:
        warnings.append(f"{name}: {len(dec.indices)} vertices at tolerance {used_m:g} m ({tolerance_m:g} m kept more "
                        f"than {max_points}; raise --max-points to keep them)")  # fmt: skip
    tolerance_m = used_m
    parts = _Parts(title or name, cols, segments, transitions, at, peak, dec, tolerance_m)
    if fmt == "geojson":
        text = _geojson(parts, fence, warnings)
    else:
        text = _kml(parts, fence, ground_alt_m, extrude, warnings)
    return FlightExport(text, segments, dec, tolerance_m, peak, tuple(warnings))


class _Parts(NamedTuple):
    name: str
    cols: Mapping[str, np.ndarray]
    segments: tuple[Segment, ...]
    transitions: Sequence[Transition]
    at: np.ndarray
    peak: Peak | None
    dec: Decimated
    tolerance_m: float

    def kept(self, seg: Segment) -> np.ndarray:
        idx = self.dec.indices
        return idx[(idx >= seg.start) & (idx <= seg.stop)]


def _geojson(p: _Parts, fence: Fence | None, warnings: list[str]) -> str:
    feats: list[dict[str, Any]] = []
    top: dict[str, Any] = {}
    if fence is not None:
        feats, top = geojson_fence_features(fence, (), warnings)
    t = p.cols["time_s"]
    for k, seg in enumerate(p.segments):
        coords = [_lla(p.cols, int(i)) for i in p.kept(seg)]
        props = {"kind": "track", "segment": k, "mode": seg.mode.name, "stroke": MODE_COLOURS[seg.mode],
                 "stroke-width": 3, "t_start_s": float(t[seg.start]), "t_end_s": float(t[seg.stop])}  # fmt: skip
        feats.append({"type": "Feature", "properties": props, "geometry": {"type": "LineString", "coordinates": coords}})
    for tr, i in zip(p.transitions, p.at):
        props = {"kind": "transition", "t_s": tr.t_s, "from": tr.from_mode, "to": tr.to_mode, "reason": tr.reason,
                 "marker-color": TRANSITION_COLOUR, "marker-size": "small"}  # fmt: skip
        feats.append({"type": "Feature", "properties": props, "geometry": {"type": "Point", "coordinates": _lla(p.cols, int(i))}})
    if p.peak is not None:
        props = {"kind": "peak_excursion", "t_s": float(t[p.peak.sample]), "excursion_m": round(p.peak.excursion_m, 3),
                 "marker-color": PEAK_COLOUR, "marker-symbol": "cross"}  # fmt: skip
        geom = {"type": "Point", "coordinates": _lla(p.cols, p.peak.sample)}
        feats.append({"type": "Feature", "properties": props, "geometry": geom})
    top = {"flight": p.name, "altitude": "alt_m, m above the WGS-84 ellipsoid", **top,
           "decimation": _decimation_props(p.dec, len(t), p.tolerance_m)}  # fmt: skip
    return json.dumps({"type": "FeatureCollection", "properties": top, "features": feats}, indent=1) + "\n"


def _kml_colour(hex_rgb: str, alpha: str = "ff") -> str:
    """``#rrggbb`` as KML's ``aabbggrr``."""
    r, g, b = hex_rgb[1:3], hex_rgb[3:5], hex_rgb[5:7]
    return f"{alpha}{b}{g}{r}"


def _kml_styles(doc: ET.Element) -> None:
    for mode, colour in MODE_COLOURS.items():
        style = ET.SubElement(doc, "Style", id=f"mode_{mode.name}")
        line = ET.SubElement(style, "LineStyle")
        ET.SubElement(line, "color").text = _kml_colour(colour)
        ET.SubElement(line, "width").text = "3"
        ET.SubElement(ET.SubElement(style, "PolyStyle"), "color").text = _kml_colour(colour, "40")
    for sid, colour in (("transition", TRANSITION_COLOUR), ("peak_excursion", PEAK_COLOUR)):
        icon = ET.SubElement(ET.SubElement(doc, "Style", id=sid), "IconStyle")
        ET.SubElement(icon, "color").text = _kml_colour(colour)


def _kml_point(parent: ET.Element, name: str, style: str, where: list[float], description: str) -> None:
    pm = ET.SubElement(parent, "Placemark")
    ET.SubElement(pm, "name").text = name
    ET.SubElement(pm, "description").text = description
    ET.SubElement(pm, "styleUrl").text = f"#{style}"
    pt = ET.SubElement(pm, "Point")
    ET.SubElement(pt, "altitudeMode").text = "absolute"
    ET.SubElement(pt, "coordinates").text = ",".join(repr(v) for v in where)


def _kml(p: _Parts, fence: Fence | None, ground_alt_m: float, extrude: bool, warnings: list[str]) -> str:
    root = ET.Element("kml", xmlns=KML_NAMESPACE)
    doc = ET.SubElement(root, "Document")
    ET.SubElement(doc, "name").text = p.name
    ext = ET.SubElement(doc, "ExtendedData")
    for key, value in _decimation_props(p.dec, len(p.cols["time_s"]), p.tolerance_m).items():
        ET.SubElement(ET.SubElement(ext, "Data", name=f"decimation_{key}"), "value").text = str(value)
    _kml_styles(doc)
    if fence is not None:
        kml_fence_styles(doc)
        folder = ET.SubElement(doc, "Folder")
        ET.SubElement(folder, "name").text = "fence"
        kml_fence_placemarks(folder, fence, (), warnings, ground_alt_m=ground_alt_m)
    track = ET.SubElement(doc, "Folder")
    ET.SubElement(track, "name").text = "track"
    t = p.cols["time_s"]
    for k, seg in enumerate(p.segments):
        pm = ET.SubElement(track, "Placemark")
        ET.SubElement(pm, "name").text = f"{k} {seg.mode.name} {t[seg.start]:.3f}-{t[seg.stop]:.3f} s"
        ET.SubElement(pm, "styleUrl").text = f"#mode_{seg.mode.name}"
        line = ET.SubElement(pm, "LineString")
        ET.SubElement(line, "extrude").text = "1" if extrude else "0"
        ET.SubElement(line, "altitudeMode").text = "absolute"
        ET.SubElement(line, "coordinates").text = " ".join(",".join(repr(v) for v in _lla(p.cols, int(i))) for i in p.kept(seg))
    events = ET.SubElement(doc, "Folder")
    ET.SubElement(events, "name").text = "events"
    for tr, i in zip(p.transitions, p.at):
        _kml_point(events, f"{tr.t_s:.3f} s {tr.from_mode}->{tr.to_mode}", "transition", _lla(p.cols, int(i)), tr.reason)
    if p.peak is not None:
        what = f"peak excursion {p.peak.excursion_m:.2f} m (<= 0: never outside) at {t[p.peak.sample]:.3f} s"
        _kml_point(events, what, "peak_excursion", _lla(p.cols, p.peak.sample), what)
    return kml_text(root)


def transitions_from_summary(records: Any, name: str) -> tuple[Transition, ...]:
    """``summary.json``'s ``mode_transitions`` (a list of ``{t_s, from, to, reason}``), or a one-line
    :class:`ConfigError` naming ``name`` and the bad entry."""
    if records is None:
        return ()
    if not isinstance(records, list):
        raise ConfigError(f"{name}: mode_transitions: must be a list, got {type(records).__name__}")
    out = []
    for i, r in enumerate(records):
        ok = isinstance(r, dict) and isinstance(r.get("t_s"), (int, float)) and math.isfinite(r["t_s"])
        ok = ok and all(isinstance(r.get(k), str) for k in ("from", "to")) and r.get("to") in Mode.__members__
        if not ok:
            raise ConfigError(f"{name}: mode_transitions[{i}]: expected {{t_s, from, to, reason}}, got {json.dumps(r)[:80]}")
        out.append(Transition(float(r["t_s"]), r["from"], r["to"], str(r.get("reason", ""))))
    return tuple(out)
