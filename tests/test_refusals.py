"""Issue 41, the input half: inputs that gave wrong answers with exit 0, unbounded time or memory, or a
traceback, are refused in one line ``error: <file>: <field>: <problem>`` with exit code 2, before any work."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from analysis.formats.fence_files import ImportOptions, load_fence_file
from geofence.geometry.fence import FenceError
from geofence.validation import ConfigError
from scenarios.app.cli import build_parser, read_trajectory
from scenarios.definition.schema import read_document
from scenarios.definition.sweep import expand

ROOT = Path(__file__).parents[1]
GOOD = ROOT / "scenarios" / "multicopter_survey_calm.yaml"
TERN = ROOT / "scenarios" / "fixedwing_survey_calm.yaml"
REALWORLD = next(
    (p for p in (ROOT.parent / "shared" / "realworld", ROOT.parents[1] / "shared" / "realworld") if p.is_dir()), ROOT
)
SQUARE = [(47.3977, 8.5452), (47.3977, 8.5468), (47.3990, 8.5468), (47.3990, 8.5452)]
OTHER = [(47.3970, 8.5440), (47.3970, 8.5450), (47.3975, 8.5450), (47.3975, 8.5440)]


def run_cli(*args, cwd=None, timeout=120):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=timeout
    )


def assert_refused(res, *expected):
    """Exit 2, exactly one ``error:`` line on stderr holding every ``expected`` piece, no traceback."""
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert res.returncode == 2, res.stderr
    assert len(lines) == 1 and lines[0].startswith("error: "), res.stderr
    assert "Traceback" not in res.stderr
    for piece in expected:
        assert piece in lines[0], lines[0]
    return lines[0]


def wpl(polygons) -> str:
    """A QGC WPL 110 fence file: each polygon as MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION (5001) items."""
    lines, k = ["QGC WPL 110"], 0
    for poly in polygons:
        for lat, lon in poly:
            lines.append(f"{k}\t0\t0\t5001\t{len(poly)}\t0\t0\t0\t{lat!r}\t{lon!r}\t0\t1")
            k += 1
    return "\n".join(lines) + "\n"


def scenario(tmp_path, text, name="s.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def good_text(path=GOOD, **replace):
    text = path.read_text()
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    return text


# --------------------------------------------------------------------------- 1. several inclusion polygons
def test_two_inclusion_polygons_are_refused_with_how_to_proceed(tmp_path):
    p = scenario(tmp_path, wpl([SQUARE, OTHER]), "two.txt")
    line = assert_refused(
        run_cli("import-fence", str(p), "--ceiling", "50"), str(p), "2 inclusion areas", "--inclusion-polygon N"
    )
    assert "intersection" in line
    with pytest.raises(FenceError, match="2 inclusion areas"):
        load_fence_file(p, ImportOptions(ceiling_m=50))


def test_the_chosen_inclusion_polygon_is_the_keep_in_whatever_the_order(tmp_path):
    a = scenario(tmp_path, wpl([SQUARE, OTHER]), "a.txt")
    b = scenario(tmp_path, wpl([OTHER, SQUARE]), "b.txt")
    for poly, alone in ((SQUARE, "square.txt"), (OTHER, "other.txt")):
        single = load_fence_file(scenario(tmp_path, wpl([poly]), alone), ImportOptions(ceiling_m=50)).fence
        i_a, i_b = (0, 1) if poly is SQUARE else (1, 0)
        assert load_fence_file(a, ImportOptions(ceiling_m=50, inclusion_polygon=i_a)).fence == single
        assert load_fence_file(b, ImportOptions(ceiling_m=50, inclusion_polygon=i_b)).fence == single
    res = run_cli("import-fence", str(a), "--ceiling", "50", "--inclusion-polygon", "1")
    assert res.returncode == 0, res.stderr
    assert [tuple(v) for v in yaml.safe_load(res.stdout)["geofence"]["fence"]["keep_in"]] == OTHER
    assert_refused(run_cli("import-fence", str(a), "--ceiling", "50", "--inclusion-polygon", "2"), "no such inclusion area")


def test_a_scenario_fence_file_with_two_inclusions_needs_inclusion_polygon(tmp_path):
    big = [(47.393, 8.541), (47.393, 8.551), (47.403, 8.551), (47.403, 8.541)]  # 1.1 km x 0.75 km
    fence = scenario(tmp_path, wpl([big, OTHER]), "two.txt")
    base = good_text(**{"lat_deg: -35.363262, lon_deg: 149.165237": "lat_deg: 47.398, lon_deg: 8.546"})
    doc = yaml.safe_load(base)
    doc.pop("mission")
    doc["pilot"] = {"type": "scripted", "segments": [{"duration_s": 5, "course_deg": 90, "speed": "cruise"}]}
    doc["geofence"] = {"fence": {"file": fence.name, "ceiling_m": 50}}
    p = scenario(tmp_path, yaml.safe_dump(doc))
    assert_refused(run_cli("validate", str(p)), "geofence.fence.file", "2 inclusion areas")
    doc["geofence"]["fence"]["inclusion_polygon"] = 0
    p.write_text(yaml.safe_dump(doc))
    res = run_cli("validate", str(p))
    assert res.returncode == 0, res.stderr


def test_score_log_scores_each_chosen_polygon_as_itself(tmp_path):
    log, foamy = REALWORLD / "uavlogviewer_vtol.tlog", REALWORLD / "mavproxy_cmac-foamy-fence.txt"
    if not (log.is_file() and foamy.is_file()):
        pytest.skip("shared/realworld is not beside the repo")
    poly = list(load_fence_file(foamy, ImportOptions(ceiling_m=100)).fence.keep_in)
    box = [(lat + 0.002, lon + 0.002) for lat, lon in poly]
    scores = {}
    for name, polys, pick in (("alone", [poly], None), ("first", [poly, box], 0), ("second", [box, poly], 1)):
        f = scenario(tmp_path, wpl(polys), f"{name}.txt")
        args = ["score-log", str(log), "--fence", str(f), "--ceiling", "100", "--json"]
        res = run_cli(*args, *([] if pick is None else ["--inclusion-polygon", str(pick)]))
        assert res.returncode == 0, res.stderr
        scores[name] = {k: v for k, v in json.loads(res.stdout).items() if k != "warnings"}
    assert scores["first"] == scores["alone"] == scores["second"]
    res = run_cli("score-log", str(log), "--fence", str(tmp_path / "first.txt"), "--ceiling", "100")
    assert_refused(res, "2 inclusion areas")


# --------------------------------------------------------------------------- 2. the distance guard
@pytest.mark.parametrize("km", ["nan", "inf", "-inf", "100000", "0", "-5", "100.5"])
def test_max_fence_distance_must_be_finite_and_within_the_flat_frame(tmp_path, km):
    res = run_cli("score-log", str(tmp_path / "no.tlog"), "--fence", str(tmp_path / "no.txt"), f"--max-fence-distance-km={km}")
    assert_refused(res, "--max-fence-distance-km", "<= 100 km")


def test_max_fence_distance_help_states_the_bound():
    assert "at most 100" in " ".join(run_cli("score-log", "--help").stdout.split())


# --------------------------------------------------------------------------- 3 and 10. physical bounds
@pytest.mark.parametrize(
    "envelope, expected",
    [
        ("{min_speed_mps: 30, max_speed_mps: 20}", "min_speed_mps: must be <= cruise_speed_mps (16 m/s)"),
        ("{max_speed_mps: 10}", "max_speed_mps: must be >= cruise_speed_mps"),
        ("{max_bank_deg: 0}", "max_bank_deg: must be > 0"),
        ("{max_pitch_deg: 0}", "max_pitch_deg: must be > 0"),
        ("{max_climb_rate_mps: 0}", "max_climb_rate_mps: must be > 0"),
        ("{max_bank_deg: 95}", "max_bank_deg: must be <= 80"),
        ("{cruise_speed_mps: 1.0e+9}", "cruise_speed_mps: must be <= 150"),
    ],
)
def test_an_envelope_out_of_its_physical_bounds_is_refused(tmp_path, envelope, expected):
    text = good_text(TERN, **{"aircraft: Tern": f"aircraft: Tern\nprofile: {{base: Tern, envelope: {envelope}}}"})
    p = scenario(tmp_path, text)
    assert_refused(run_cli("validate", str(p)), str(p), "profile.envelope.", expected)


def test_turbulence_beyond_severe_is_refused(tmp_path):
    p = scenario(tmp_path, good_text(**{"duration_s: 240": "duration_s: 240\nwind: {turbulence: {w20_mps: 1.0e+9}}"}))
    assert_refused(run_cli("validate", str(p)), str(p), "wind.turbulence.w20_mps", "<= 23.15 m/s")


def test_a_ceiling_beyond_any_small_uas_is_refused(tmp_path):
    p = scenario(tmp_path, wpl([SQUARE]), "one.txt")
    assert_refused(run_cli("import-fence", str(p), "--ceiling", "1e9"), str(p), "ceiling_m", "10000 m")
    assert_refused(run_cli("import-fence", str(p), "--ceiling", "nan"), "ceiling_m", "finite")


# --------------------------------------------------------------------------- 4. YAML alias bombs
BOMB = "\n".join(
    ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    + [f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]" for p, c in zip("abcdefgh", "bcdefghi")]
    + ["name: *i", "aircraft: F450", "start: {lat_deg: 0, lon_deg: 0}", "duration_s: 10", ""]
)


def test_an_alias_bomb_is_refused_within_a_second_and_bounded_memory(tmp_path):
    p = scenario(tmp_path, BOMB)
    assert len(BOMB) < 1024
    tracemalloc.start()
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match=r"YAML aliases: expand the document beyond 1,000,000 nodes"):
        read_document(p)
    elapsed_s = time.perf_counter() - t0
    _, peak_b = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert elapsed_s < 1.0 and peak_b < 20e6
    assert_refused(run_cli("validate", str(p), timeout=30), str(p), "YAML aliases")


def test_a_recursive_alias_and_deep_nesting_are_one_line(tmp_path):
    loop = scenario(tmp_path, "a: &a [*a]\naircraft: F450\n", "loop.yaml")
    deep = scenario(tmp_path, "x: " + "[" * 100_000 + "]" * 100_000 + "\n", "deep.yaml")
    assert_refused(run_cli("validate", str(loop), timeout=30), "recursive alias")
    assert_refused(run_cli("validate", str(deep), timeout=30), "nested too deeply")


def test_a_name_is_type_checked_before_it_is_stringified():
    with pytest.raises(ConfigError, match="s.yaml: name: expected a non-empty string, got a list"):
        expand({"name": [1, 2], "aircraft": "F450"}, "s.yaml", "s")


@settings(max_examples=30, deadline=None)
@given(width=st.integers(1, 12), depth=st.integers(1, 8))
def test_aliases_load_or_are_refused_by_their_expanded_size(tmp_path_factory, width, depth):
    lines = ['l0: &l0 ["x"]'] + [f"l{k}: &l{k} [{', '.join([f'*l{k - 1}'] * width)}]" for k in range(1, depth + 1)]
    p = tmp_path_factory.mktemp("aliases") / "a.yaml"
    p.write_text("\n".join(lines) + "\n")
    level = [2]  # a sequence of one scalar, then each level a sequence of `width` copies of the one below
    for _ in range(depth):
        level.append(1 + width * level[-1])
    expanded = 1 + sum(1 + n for n in level)  # the top mapping, each key and its value
    try:
        doc = read_document(p)
    except ConfigError as exc:
        assert "YAML aliases" in str(exc) and expanded > 1_000_000
    else:
        assert expanded <= 1_000_000 and len(doc) == depth + 1


# --------------------------------------------------------------------------- 5. sweeps counted first
@pytest.mark.parametrize(
    "block, expected",
    [
        ({"monte_carlo": {"count": 1_000_000_000, "draws": {"seed": {"integers": [0, 9]}}}}, "sweep.monte_carlo.count"),
        ({"grid": {"seed": list(range(1200)), "start.heading_deg": list(range(1200))}}, "1,440,000 flights"),
    ],
    ids=["monte-carlo-1e9", "grid-1.44M"],
)
def test_a_huge_sweep_is_refused_before_it_is_expanded(block, expected):
    doc = dict(yaml.safe_load(GOOD.read_text()), sweep=block)
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match="limit of 100,000 per file") as exc:
        expand(doc, "s.yaml", "s")
    assert time.perf_counter() - t0 < 1.0 and expected in str(exc.value)


@settings(max_examples=40, deadline=None)
@given(n_grid=st.integers(0, 8), count=st.none() | st.integers(1, 8))
def test_a_sweep_expands_to_its_count_or_is_refused(n_grid, count):
    block: dict = {"grid": {"seed": list(range(n_grid))}} if n_grid else {}
    if count is not None:
        block["monte_carlo"] = {"count": count}
    expected = max(n_grid, 1) * (count or 1)
    doc = {"name": "s", "aircraft": "F450", "seed": 0, "sweep": block}
    try:
        specs = expand(doc, "s.yaml", "s", max_flights=20)
    except ConfigError as exc:
        assert expected > 20 and "limit of 20 per file" in str(exc)
    else:
        assert len(specs) == expected <= 20


# --------------------------------------------------------------------------- 6-9. tracebacks
def test_a_name_with_a_nul_byte_is_refused_before_flying(tmp_path):
    p = scenario(tmp_path, good_text(**{"name: multicopter_survey_calm": 'name: "bad\\0name"'}))
    assert_refused(run_cli("run", str(p), "--out", str(tmp_path / "out")), str(p), "name:", "control characters")
    assert not (tmp_path / "out").exists()


def test_a_deeply_nested_geojson_is_one_line(tmp_path):
    p = scenario(tmp_path, '{"type": "FeatureCollection", "features": ' + "[" * 100_000 + "]" * 100_000 + "}", "d.geojson")
    assert_refused(run_cli("import-fence", str(p)), str(p), "nested too deeply")


def test_a_negative_campaign_seed_is_one_line(tmp_path):
    assert_refused(run_cli("campaign", "generate", str(tmp_path / "c"), "--seed", "-1", "--cases", "1"), "--seed", "[0, 2^63)")
    assert not (tmp_path / "c").exists()


def test_a_malformed_scheduler_address_is_one_line(tmp_path):
    res = run_cli("batch", str(GOOD), "--out", str(tmp_path / "o"), "--executor", "dask", "--scheduler", "http://[::1")
    assert_refused(res, "--scheduler http://[::1", "not a valid address")
    assert not (tmp_path / "o").exists()


# --------------------------------------------------------------------------- 11. validate-models output
def test_validate_models_writes_to_the_current_folder_by_default():
    args = build_parser().parse_args(["validate-models"])
    assert args.out == Path("validation.md")
    assert "current folder" in " ".join(run_cli("validate-models", "--help").stdout.split())


def test_validate_models_refuses_an_unwritable_out_before_flying(tmp_path):
    (tmp_path / "file").write_text("")
    t0 = time.perf_counter()
    res = run_cli("validate-models", "--models", "F450", "--out", str(tmp_path / "file" / "v.md"))
    assert_refused(res, "--out", "is not a folder")
    res = run_cli("validate-models", "--models", "F450", "--out", str(tmp_path))
    assert_refused(res, "--out", "is a folder")
    assert time.perf_counter() - t0 < 60.0  # nothing was flown


# --------------------------------------------------------------------------- 12. plot on a broken trajectory
def _trajectory_text() -> str:
    from scenarios.flight.recorder import COLUMNS

    rows = [",".join(f"{0.1 * k + j:.6e}" for j in range(len(COLUMNS))) for k in range(20)]
    return ",".join(COLUMNS) + "\n" + "\n".join(rows) + "\n"


@pytest.mark.parametrize(
    "content, expected",
    [
        (lambda t: t[: len(t) // 2 + 7].encode(), "cut short"),
        (lambda t: bytes(range(256)) * 8, "not text"),
        (lambda t: t[:100].encode(), "cut short"),
        (lambda t: b"", "empty"),
    ],
    ids=["truncated", "binary", "header-cut", "empty"],
)
def test_plot_on_a_broken_trajectory_is_one_line(tmp_path, content, expected):
    (tmp_path / "f").mkdir()
    (tmp_path / "f" / "trajectory.csv").write_bytes(content(_trajectory_text()))
    assert_refused(run_cli("plot", str(tmp_path / "f")), "trajectory.csv", expected)


@settings(max_examples=60, deadline=None)
@given(cut=st.integers(0, 10_000))
def test_any_prefix_of_a_trajectory_reads_or_is_refused(tmp_path_factory, cut):
    text = _trajectory_text()
    p = tmp_path_factory.mktemp("traj") / "trajectory.csv"
    p.write_text(text[: cut % (len(text) + 1)])
    try:
        traj = read_trajectory(p)
    except ConfigError as exc:
        assert str(exc).startswith(str(p))
    else:
        assert len(traj["time_s"]) >= 2
