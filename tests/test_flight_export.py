"""Flight exports (analysis.formats.flight_export, ``export-flight``): GeoJSON checked against RFC 7946's structure,
KML parsed with ElementTree; the thinned track within its stated tolerance of the full one (hypothesis, brute-force
oracle); every mode change, transition and the peak kept exactly (the peak against analysis.scoring's score); bad
folders, columns and rows one line with exit 2."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from analysis.formats.flight_export import (
    MODE_COLOURS,
    TRACK_COLUMNS,
    decimate,
    export_flight,
    mode_segments,
    segment_distances,
)
from analysis.scoring import score_flight
from geofence.geometry.geodesy import LocalFrame
from geofence.unit.passes import Mode
from scenarios.app.cli import main
from scenarios.definition.schema import load_scenario
from tests.support import ROOT

SCENARIO = ROOT / "scenarios" / "geofence_multicopter_keep_in_circle.yaml"
KML = {"k": "http://www.opengis.net/kml/2.2"}
COLUMNS = TRACK_COLUMNS + ("agl_m",)


def synthetic_columns(n: int = 2000, rate_hz: float = 40.0, seed: int = 3) -> dict[str, np.ndarray]:
    """A wandering flight about the scenario's start with MONITOR -> OVERRIDE -> RECOVERED -> MONITOR cycles."""
    sc = load_scenario(SCENARIO)
    frame: LocalFrame = sc.frame
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate_hz
    east = 40.0 * np.sin(t / 7.0) + np.cumsum(rng.normal(0, 0.02, n))
    north = 30.0 * np.sin(t / 5.0)
    up = 20.0 + 5.0 * np.sin(t / 11.0)
    lat, lon, alt = np.array([frame.to_geodetic(e, nn, u) for e, nn, u in zip(east, north, up)]).T
    mode = np.zeros(n)
    for k in range(0, n - 120, 400):
        mode[k + 100 : k + 160], mode[k + 160 : k + 200] = int(Mode.OVERRIDE), int(Mode.RECOVERED)
    return {"time_s": t, "lat_deg": lat, "lon_deg": lon, "alt_m": alt, "east_m": east, "north_m": north,
            "up_m": up, "agl_m": up, "geofence_mode": mode}  # fmt: skip


def transitions_of(cols) -> list[dict]:
    m = cols["geofence_mode"].astype(int)
    at = np.flatnonzero(np.diff(m)) + 1
    return [{"t_s": round(float(cols["time_s"][i]), 3), "from": Mode(m[i - 1]).name, "to": Mode(m[i]).name,
             "reason": f"test {i}"} for i in at]  # fmt: skip


def write_run(folder: Path, cols: dict[str, np.ndarray], transitions: list[dict] | None = None) -> Path:
    """A flight folder as run writes it: the scenario, the summary's transitions, a trajectory.csv."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(SCENARIO, folder / "scenario.yaml")
    trs = transitions_of(cols) if transitions is None else transitions
    (folder / "summary.json").write_text(json.dumps({"scenario": "synthetic", "mode_transitions": trs}))
    names = list(cols)
    table = np.column_stack([cols[c] for c in names])
    np.savetxt(folder / "trajectory.csv", table, delimiter=",", header=",".join(names), comments="", fmt="%.10f")
    return folder


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    return write_run(tmp_path_factory.mktemp("flight") / "synthetic", synthetic_columns())


def exported(run_dir: Path, fmt: str, tmp: Path, *extra: str) -> str:
    out = tmp / f"flight.{fmt}"
    assert main(["export-flight", str(run_dir), "--to", fmt, "--out", str(out), *extra]) == 0
    return out.read_text()


def read_csv(run_dir: Path) -> dict[str, np.ndarray]:
    data = np.genfromtxt(run_dir / "trajectory.csv", delimiter=",", names=True)
    return {k: np.asarray(data[k], dtype=float) for k in data.dtype.names or ()}


def check_position(p, dims: int = 3) -> None:
    assert isinstance(p, list) and len(p) == dims and all(isinstance(v, float | int) and math.isfinite(v) for v in p)
    assert -180.0 <= p[0] <= 180.0 and -90.0 <= p[1] <= 90.0


def test_geojson_has_rfc7946_structure_and_mode_segments(run_dir, tmp_path):
    doc = json.loads(exported(run_dir, "geojson", tmp_path))
    cols = read_csv(run_dir)
    assert doc["type"] == "FeatureCollection" and isinstance(doc["features"], list)
    kinds: dict[str, list] = {}
    for f in doc["features"]:
        assert f["type"] == "Feature" and isinstance(f["properties"], dict)
        g = f["geometry"]
        kinds.setdefault(f["properties"].get("kind", f["properties"].get("geofence")), []).append(f)
        if g["type"] == "Polygon":
            for ring in g["coordinates"]:
                assert len(ring) >= 4 and ring[0] == ring[-1]
                for p in ring:
                    check_position(p, 2)
        elif g["type"] == "LineString":
            assert len(g["coordinates"]) >= 2
            for p in g["coordinates"]:
                check_position(p)
        else:
            assert g["type"] == "Point"
            check_position(g["coordinates"], len(g["coordinates"]))
    segs = mode_segments(cols["geofence_mode"])
    track = kinds["track"]
    assert [f["properties"]["mode"] for f in track] == [s.mode.name for s in segs]
    assert all(f["properties"]["stroke"] == MODE_COLOURS[Mode[f["properties"]["mode"]]] for f in track)
    assert len(kinds["keep_in"]) == 1 and len(kinds["keep_out"]) == 1
    # every vertex is a recorded sample, [lon, lat, alt_m]
    rows = {(lo, la, al) for lo, la, al in zip(cols["lon_deg"], cols["lat_deg"], cols["alt_m"])}
    assert all(tuple(p) in rows for f in track for p in f["geometry"]["coordinates"])
    dec = doc["properties"]["decimation"]
    assert dec["tolerance_m"] == 0.5 and dec["max_error_m"] <= 0.5 and dec["samples_recorded"] == len(cols["time_s"])
    assert dec["samples_kept"] < dec["samples_recorded"] / 4


def test_kml_one_placemark_per_segment(run_dir, tmp_path):
    root = ET.fromstring(exported(run_dir, "kml", tmp_path, "--extrude"))
    cols = read_csv(run_dir)
    segs = mode_segments(cols["geofence_mode"])
    folders = {f.findtext("k:name", namespaces=KML): f for f in root.iterfind(".//k:Folder", KML)}
    assert set(folders) == {"fence", "track", "events"}
    placemarks = folders["track"].findall("k:Placemark", KML)
    assert len(placemarks) == len(segs)
    for pm, seg in zip(placemarks, segs):
        assert pm.findtext("k:styleUrl", namespaces=KML) == f"#mode_{seg.mode.name}"
        line = pm.find("k:LineString", KML)
        assert line is not None and line.findtext("k:altitudeMode", namespaces=KML) == "absolute"
        assert line.findtext("k:extrude", namespaces=KML) == "1"
        pts = [tuple(float(v) for v in p.split(",")) for p in (line.findtext("k:coordinates", namespaces=KML) or "").split()]
        assert len(pts) >= 2 and all(len(p) == 3 for p in pts)
        first, last = pts[0], pts[-1]
        assert first == (cols["lon_deg"][seg.start], cols["lat_deg"][seg.start], cols["alt_m"][seg.start])
        assert last == (cols["lon_deg"][seg.stop], cols["lat_deg"][seg.stop], cols["alt_m"][seg.stop])
    styles = {s.get("id") for s in root.iterfind(".//k:Style", KML)}
    assert {f"mode_{m.name}" for m in Mode} <= styles
    # the fence in absolute heights over the scenario's ground (584 m): the 50 m ceiling at 634 m
    ring = folders["fence"].find(".//k:Polygon", KML)
    assert ring is not None and ring.findtext("k:altitudeMode", namespaces=KML) == "absolute"
    assert {float(p.split(",")[2]) for p in (ring.findtext(".//k:coordinates", namespaces=KML) or "").split()} == {634.0}


def test_transitions_and_peak_kept_exactly(run_dir, tmp_path):
    doc = json.loads(exported(run_dir, "geojson", tmp_path))
    cols = read_csv(run_dir)
    vertices = {tuple(p) for f in doc["features"] if f["properties"].get("kind") == "track" for p in f["geometry"]["coordinates"]}
    events = [f for f in doc["features"] if f["properties"].get("kind") == "transition"]
    want = transitions_of(cols)
    assert [(e["properties"]["t_s"], e["properties"]["from"], e["properties"]["to"]) for e in events] == [
        (w["t_s"], w["from"], w["to"]) for w in want
    ]
    for e in events:
        i = int(np.argmin(abs(cols["time_s"] - e["properties"]["t_s"])))
        assert e["geometry"]["coordinates"] == [cols["lon_deg"][i], cols["lat_deg"][i], cols["alt_m"][i]]
        assert tuple(e["geometry"]["coordinates"]) in vertices
    (peak,) = [f for f in doc["features"] if f["properties"].get("kind") == "peak_excursion"]
    sc = load_scenario(SCENARIO)
    score = score_flight(cols, sc.local_fence())
    assert peak["properties"]["excursion_m"] == pytest.approx(score["max_excursion_m"], abs=1e-3)
    assert tuple(peak["geometry"]["coordinates"]) in vertices


def polyline_distance(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Oracle: each point's distance to the nearest segment of ``line`` (brute force over all segments)."""
    if len(line) == 1:
        return np.linalg.norm(p - line[0], axis=1)
    return np.min([segment_distances(p, a, b) for a, b in zip(line[:-1], line[1:])], axis=0)


tracks = st.builds(
    lambda seed, n, step, turn: (seed, n, step, turn), st.integers(0, 10_000), st.integers(2, 300),
    st.floats(0.01, 3.0), st.floats(0.0, 1.0),
)  # fmt: skip


@settings(max_examples=60, deadline=None)
@given(tracks, st.floats(0.01, 5.0), st.floats(0.0, 0.1))
def test_decimated_track_within_tolerance(track, tolerance_m, keep_fraction):
    seed, n, step, turn = track
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0.0, turn, n))
    d = np.column_stack([np.cos(heading), np.sin(heading), rng.normal(0.0, 0.3, n)]) * step
    pts = np.cumsum(d, axis=0)
    keep = rng.random(n) < keep_fraction
    dec = decimate(pts, keep, tolerance_m)
    idx = dec.indices
    assert idx[0] == 0 and idx[-1] == n - 1 and np.all(np.diff(idx) > 0)
    assert set(np.flatnonzero(keep)) <= set(idx)
    dropped = np.setdiff1d(np.arange(n), idx)
    if len(dropped):
        err = polyline_distance(pts[dropped], pts[idx])
        assert err.max() <= tolerance_m + 1e-9
        assert err.max() <= dec.max_error_m + 1e-9 <= tolerance_m + 1e-9


@settings(max_examples=50, deadline=None)
@given(st.lists(st.integers(0, 4), min_size=2, max_size=80))
def test_mode_segments_cover_the_track(modes):
    m = np.array(modes, dtype=float)
    segs = mode_segments(m)
    assert segs[0].start == 0 and segs[-1].stop == len(m) - 1
    for a, b in zip(segs, segs[1:]):
        assert a.stop == b.start or (b.stop == len(m) - 1 and b.start == a.stop - 1)
        assert a.mode != b.mode
    for k, s in enumerate(segs):
        assert s.stop > s.start
        body = m[s.start : s.stop + (k == len(segs) - 1)]  # a segment ends on the next one's first sample
        if k == len(segs) - 1 and m[s.start] != s.mode:  # a one-sample last run, drawn from the sample before
            body = m[s.stop :]
        assert np.all(body == int(s.mode))


def test_an_hour_at_100_hz_gives_a_file_a_viewer_opens():
    n = 360_000
    t = np.arange(n) / 100.0
    east, north, up = 300.0 * np.cos(t / 60.0), 300.0 * np.sin(t / 60.0), 50.0 + 10.0 * np.sin(t / 30.0)
    frame = LocalFrame(47.0, 8.0, 400.0)
    lat = 47.0 + north / 111_200.0  # (the positions' geodesy does not matter here)
    lon = 8.0 + east / (111_200.0 * math.cos(math.radians(47.0)))
    mode = ((t % 600.0) > 550.0).astype(float)
    cols = {"time_s": t, "lat_deg": lat, "lon_deg": lon, "alt_m": frame.h0_m + up, "east_m": east, "north_m": north,
            "up_m": up, "geofence_mode": mode}  # fmt: skip
    start = time.perf_counter()
    out = export_flight(cols, "geojson", name="hour.csv", tolerance_m=0.5)
    took = time.perf_counter() - start
    assert len(out.decimated.indices) < 20_000 and len(out.text) < 5_000_000
    assert out.decimated.max_error_m <= 0.5 and took < 10.0
    # a noisy track (0.3 m, the tolerance's size) keeps a third of its samples: the tolerance is raised to fit
    rng = np.random.default_rng(1)
    k = 60_000  # (ten minutes of it)
    noisy = {c: v[:k] for c, v in cols.items()}
    noisy["east_m"], noisy["north_m"] = east[:k] + rng.normal(0.0, 0.3, k), north[:k] + rng.normal(0.0, 0.3, k)
    out = export_flight(noisy, "kml", name="hour.csv", tolerance_m=0.5, max_points=5_000)
    assert len(out.decimated.indices) <= 5_000 and out.tolerance_m > 0.5 and out.decimated.max_error_m <= out.tolerance_m
    assert f"<value>{out.tolerance_m!r}</value>" in out.text and any("raise --max-points" in w for w in out.warnings)


def run_cli(*args: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "scenarios.app.cli", "export-flight", *args]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=120)


def test_not_a_flight_folder_is_one_line_exit_2(tmp_path):
    p = run_cli(str(tmp_path), "--to", "kml", "--out", str(tmp_path / "x.kml"))
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.strip().splitlines() == [
        f"error: {tmp_path}: not a flight folder (no trajectory.csv): give one written by run or batch"
    ]


@pytest.mark.parametrize("damage", ["nan_row", "no_column", "bad_summary", "bad_mode"])
def test_bad_flight_files_are_one_line_exit_2(tmp_path, capsys, damage):
    cols = synthetic_columns(200)
    if damage == "nan_row":
        cols["lat_deg"][57] = np.nan
    if damage == "no_column":
        del cols["up_m"]
    if damage == "bad_mode":
        cols["geofence_mode"][9] = 7.0
    folder = write_run(tmp_path / "f", cols, [])
    if damage == "bad_summary":
        (folder / "summary.json").write_text('{"mode_transitions": [{"t_s": "soon"}]}')
    assert main(["export-flight", str(folder), "--to", "geojson", "--out", str(tmp_path / "x.geojson")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    want = {
        "nan_row": f"{folder / 'trajectory.csv'}: line 59: column 'lat_deg' is not a number",
        "no_column": f"{folder / 'trajectory.csv'}: not a trajectory CSV: no column 'up_m'",
        "bad_summary": f"{folder / 'summary.json'}: mode_transitions[0]: expected",
        "bad_mode": f"{folder / 'trajectory.csv'}: line 11: geofence_mode 7 is not a mode",
    }[damage]
    assert err[0].startswith(f"error: {want}"), err
    assert not (tmp_path / "x.geojson").exists()


@pytest.mark.slow
def test_a_real_flight_exports_with_its_peak_and_transitions(tmp_path):
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "scenarios.app.cli", "run", str(SCENARIO), "--out", str(out), "--no-plot", "--quiet"]
    subprocess.run(cmd, check=True, cwd=ROOT, timeout=600, capture_output=True)
    (flight,) = [p for p in out.iterdir() if p.is_dir()]
    summary = json.loads((flight / "summary.json").read_text())
    doc = json.loads(exported(flight, "geojson", tmp_path))
    (peak,) = [f for f in doc["features"] if f["properties"].get("kind") == "peak_excursion"]
    assert peak["properties"]["excursion_m"] == pytest.approx(summary["max_excursion_m"], abs=2e-3)
    events = [f for f in doc["features"] if f["properties"].get("kind") == "transition"]
    assert len(events) == len(summary["mode_transitions"])
    root = ET.fromstring(exported(flight, "kml", tmp_path))
    track = [f for f in root.iterfind(".//k:Folder", KML) if f.findtext("k:name", namespaces=KML) == "track"][0]
    assert len(track.findall("k:Placemark", KML)) == len(mode_segments(read_csv(flight)["geofence_mode"]))
