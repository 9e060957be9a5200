"""Scenario YAML validation: every bad input becomes one line naming file, field and problem."""

import math
import re
from pathlib import Path

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence.validation import ConfigError
from scenarios.definition.schema import PilotKind, load_scenario, parse_scenario, read_document

SHIPPED = sorted((Path(__file__).parents[1] / "scenarios").rglob("*.yaml"))

BASE = {
    "aircraft": "F450",
    "duration_s": 10,
    "start": {"lat_deg": 47.0, "lon_deg": 8.0, "ground_alt_m": 400},
    "mission": {"items": [{"type": "takeoff", "agl_m": 5}, {"type": "land"}]},
}


def with_(**changes):
    doc = yaml.safe_load(yaml.safe_dump(BASE))
    for dotted, value in changes.items():
        keys = dotted.split("__")
        target = doc
        for k in keys[:-1]:
            target = target[k]
        target[keys[-1]] = value
    return doc


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_scenarios_are_valid(path):
    """Every shipped file (sweeps expanded) validates into scenarios."""
    from scenarios.app.batch import plan

    specs = plan([path])
    assert specs and not [s.error for s in specs if s.error]
    for spec in specs:
        sc = parse_scenario(spec.document, str(path), path.stem)
        assert sc.duration_s > 0
    if len(specs) == 1:
        assert load_scenario(path).name in (path.stem, specs[0].flight_id)


def test_base_document_parses():
    sc = parse_scenario(BASE, "x.yaml")
    assert sc.aircraft == "F450" and sc.pilot.kind is PilotKind.MISSION and len(sc.mission.items) == 2


@pytest.mark.parametrize(
    "doc, field, problem",
    [
        (with_(start__lat_deg=123), "start.lat_deg", "<= 90"),
        (with_(start__lon_deg=-200), "start.lon_deg", ">= -180"),
        (with_(duration_s=-5), "duration_s", "> 0"),
        (with_(duration_s="long"), "duration_s", "expected a number"),
        (with_(aircraft="Wright_Flyer_3000"), "aircraft", "unknown aircraft 'Wright_Flyer_3000'"),
        (with_(aircraft="Concorde"), "aircraft", "without a shipped profile; add a profile: block"),
        (
            with_(aircraft="c172p", profile={"base": "c172x", "envelope": {"max_bank_deg": -5}}),
            "profile.envelope.max_bank_deg",
            "must be > 0",
        ),
        (with_(aircraft="c172p", profile={"kind": "glider"}), "profile.kind", "is not one of multirotor, fixed_wing"),
        (with_(colour="red"), "bad.yaml: colour", "colour: unknown key (allowed: "),
        (with_(mission__items=[{"type": "hover"}]), "mission.items[0].type", "not one of"),
        (with_(mission__items=[{"type": "waypoint", "lat_deg": 1}]), "mission.items[0].lon_deg", "missing"),
        (with_(mission__items=[{"type": "land"}, {"type": "takeoff", "agl_m": 3}]), "mission.items[0]", "last"),
        (with_(mission__acceptance_radius_m=0), "mission.acceptance_radius_m", "> 0"),
        (with_(pilot={"type": "scripted", "segments": [{"duration_s": 3}]}), "pilot.segments[0]", "exactly one of"),
        (
            with_(pilot={"type": "scripted", "segments": [{"duration_s": 3, "sticks": {"roll": 2}}]}),
            "pilot.segments[0].sticks.roll",
            "<= 1",
        ),
        (with_(wind={"speed_mps": -3}), "wind", "speed_mps"),
    ],
)
def test_bad_values_name_file_and_field(doc, field, problem):
    with pytest.raises(ConfigError) as err:
        parse_scenario(doc, "bad.yaml")
    msg = str(err.value)
    assert msg.startswith("bad.yaml: ")
    assert field in msg and problem in msg
    assert "\n" not in msg


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="no such scenario file"):
        load_scenario(tmp_path / "nope.yaml")


def test_malformed_yaml_reports_line(tmp_path):
    p = tmp_path / "broken.yaml"
    p.write_text("aircraft: F450\nstart: {lat_deg: 1\n")
    with pytest.raises(ConfigError, match=r"broken.yaml: malformed YAML at line \d+"):
        load_scenario(p)


def test_empty_file(tmp_path):
    p = tmp_path / "empty.yaml"
    p.write_text("")
    with pytest.raises(ConfigError, match="empty"):
        load_scenario(p)


@settings(max_examples=200)
@given(
    st.recursive(
        st.none() | st.booleans() | st.floats(allow_nan=True) | st.integers() | st.text(max_size=8),
        lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=12), children, max_size=5),
        max_leaves=20,
    )
)
def test_parser_never_crashes_on_arbitrary_documents(doc):
    """Whatever the YAML holds, the parser either accepts it or raises a one-line ConfigError."""
    try:
        parse_scenario(doc, "fuzz.yaml")
    except ConfigError as exc:
        assert str(exc).startswith("fuzz.yaml: ") and "\n" not in str(exc)


@settings(max_examples=100)
@given(
    st.fixed_dictionaries(
        {},
        optional={
            k: st.one_of(st.floats(), st.integers(), st.text(max_size=5), st.none())
            for k in ("lat_deg", "lon_deg", "agl_m", "heading_deg", "airspeed_mps", "ground_alt_m")
        },
    )
)
def test_start_block_fuzz(start):
    doc = with_(start=start)
    try:
        sc = parse_scenario(doc, "f.yaml")
    except ConfigError as exc:
        assert "f.yaml: start" in str(exc)
    else:
        assert -90 <= sc.start.lat_deg <= 90 and -180 <= sc.start.lon_deg <= 180


def test_inline_profile_makes_any_wheel_model_flyable():
    sc = parse_scenario(with_(aircraft="c172p", profile={"base": "c172x", "envelope": {"max_bank_deg": 25}}), "x.yaml")
    assert sc.profile.model == "c172p"
    assert sc.profile.envelope.max_bank_rad == pytest.approx(0.43633, rel=1e-4)
    assert sc.profile.gains  # inherited from the c172x profile


def _profile_doc(**envelope):
    """A complete fixed-wing profile in the file format of aircraft/profiles/*.yaml (the c172x's figures)."""
    from aircraft.profile import load_profile

    c172 = load_profile("c172x")
    env = {"cruise_speed_mps": 50, "max_speed_mps": 58, "min_speed_mps": 38, "max_bank_deg": 35, "max_pitch_deg": 15,
           "max_yaw_rate_deg_s": 7.5, "max_climb_rate_mps": 3, "max_descent_rate_mps": 4, "braking_decel_mps2": 0.8,
           "vertical_accel_mps2": 4.0, "reaction_time_s": 1.5}  # fmt: skip
    env.update(envelope)
    return {"model": "c172p", "kind": "fixed_wing", "envelope": env, "gains": dict(c172.gains)}


def test_a_profile_file_beside_the_scenario_is_flown(tmp_path):
    """``profile: FILE`` (e.g. a characterized profile) is read relative to the scenario's folder."""
    (tmp_path / "profiles").mkdir()
    (tmp_path / "profiles" / "mine.yaml").write_text(yaml.safe_dump(_profile_doc(max_bank_deg=25)))
    src = tmp_path / "s.yaml"
    src.write_text(yaml.safe_dump(with_(aircraft="c172p", profile="profiles/mine.yaml", mission=None)))
    doc = yaml.safe_load(src.read_text())
    del doc["mission"]
    doc["pilot"] = {"type": "scripted", "segments": [{"duration_s": 5, "course_deg": 0}]}
    doc["start"]["agl_m"] = 300
    src.write_text(yaml.safe_dump(doc))
    sc = load_scenario(src)
    assert sc.profile.model == "c172p" and sc.profile.envelope.max_bank_rad == pytest.approx(math.radians(25))


@pytest.mark.parametrize(
    "content, expected",
    [
        (None, r"^x/s\.yaml.*nope\.yaml: no such profile file"),
        ("envelope: [", r"^\S*nope\.yaml: malformed YAML"),
        ("BAD", r"^\S*nope\.yaml\.envelope\.max_bank_deg: "),
    ],
)
def test_a_bad_profile_file_is_one_line_naming_it(tmp_path, content, expected):
    if content == "BAD":
        content = yaml.safe_dump(_profile_doc(max_bank_deg=95))
    if content is not None:
        (tmp_path / "nope.yaml").write_text(content)
    with pytest.raises(ConfigError) as exc:
        parse_scenario(with_(aircraft="c172p", profile="nope.yaml"), "x/s.yaml", base_dir=tmp_path)
    msg = str(exc.value)
    assert "\n" not in msg and re.search(expected, msg), msg


def test_editing_a_profile_file_refiles_the_flight_in_a_resumed_batch(tmp_path):
    """The profile file is part of the flight's identity, as a fence file is (a resumed batch re-flies it)."""
    from scenarios.app.batch import plan

    (tmp_path / "mine.yaml").write_text(yaml.safe_dump(_profile_doc()))
    doc = with_(aircraft="c172p", profile="mine.yaml")
    doc["start"]["agl_m"] = 300
    del doc["mission"]
    doc["pilot"] = {"type": "scripted", "segments": [{"duration_s": 5, "course_deg": 0}]}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    before = plan([tmp_path / "s.yaml"])[0].scenario_hash
    (tmp_path / "mine.yaml").write_text(yaml.safe_dump(_profile_doc(max_bank_deg=30)))
    assert plan([tmp_path / "s.yaml"])[0].scenario_hash != before


def test_a_profile_borrowed_from_another_model_warns_once_and_a_measured_one_does_not():
    """``base: c172x`` on a pa28 flies the Cessna's figures: one warning naming both models (summary.json and the
    console carry Scenario.warnings); a profile measured on the model flown (shipped or characterized) is silent."""
    fw = dict(with_(), start=dict(BASE["start"], agl_m=300))
    del fw["mission"]
    fw["pilot"] = {"type": "scripted", "segments": [{"duration_s": 5, "course_deg": 0}]}
    borrowed = parse_scenario(dict(fw, aircraft="pa28", profile={"base": "c172x"}), "x.yaml")
    (w,) = borrowed.warnings
    assert w.startswith("x.yaml: profile: ") and "measured on C172W, not on pa28" in w and "characterize pa28" in w
    for aircraft in ("pa28", "c172x", "F450"):
        assert not parse_scenario(dict(fw, aircraft=aircraft), "x.yaml").warnings, aircraft
    own = parse_scenario(dict(fw, aircraft="F450RD", profile={"base": "F450RD", "envelope": {"max_bank_deg": 20}}), "x.yaml")
    assert not own.warnings


def test_validate_prints_the_borrowed_profile_warning(tmp_path):
    import subprocess
    import sys

    doc = dict(with_(aircraft="c182", profile={"base": "c172x"}), start=dict(BASE["start"], agl_m=300))
    del doc["mission"]
    doc["pilot"] = {"type": "scripted", "segments": [{"duration_s": 5, "course_deg": 0}]}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    root = Path(__file__).parents[1]
    res = subprocess.run([sys.executable, "-m", "scenarios.app.cli", "validate", str(tmp_path / "s.yaml")], cwd=root,
                         capture_output=True, text=True)  # fmt: skip
    assert res.returncode == 0, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if "measured on C172W, not on c182" in ln]
    assert len(lines) == 1 and lines[0].startswith("warning: "), res.stderr


def test_a_fence_too_small_for_the_platform_says_so_with_the_numbers():
    from geofence.geometry.geodesy import LocalFrame

    frame = LocalFrame(47.0, 8.0, 400.0)
    box = [list(frame.to_geodetic(e, n, 0.0)[:2]) for e, n in [(-30, -30), (30, -30), (30, 30), (-30, 30)]]
    doc = with_(aircraft="Tern", geofence={"fence": {"keep_in": box, "ceiling_m": 120}})
    doc["start"]["agl_m"] = 60
    with pytest.raises(ConfigError) as err:
        parse_scenario(doc, "small.yaml")
    msg = str(err.value)
    assert msg.startswith("small.yaml: geofence") and "vanishes" in msg and "inradius 30.0 m" in msg
    assert "\n" not in msg


@pytest.mark.parametrize(
    "segment, problem",
    [
        (
            {"duration_s": 3, "course_deg": 0, "end_on": "later"},
            "pilot.segments[0].end_on: 'later' is not one of handback, reach",
        ),
        ({"duration_s": 3, "course_deg": 0, "end_on": "reach"}, "pilot.segments[0].reach: missing"),
        ({"duration_s": 3, "course_deg": 0, "end_on": "reach", "reach": {"lat_deg": 1, "lon_deg": 2}}, "reach.radius_m: missing"),
        (
            {"duration_s": 3, "course_deg": 0, "reach": {"lat_deg": 1, "lon_deg": 2, "radius_m": 5}},
            "reach: only with end_on: reach",
        ),
    ],
)
def test_event_ended_segments_are_validated(segment, problem):
    with pytest.raises(ConfigError, match=re.escape(problem)):
        parse_scenario(with_(pilot={"type": "scripted", "segments": [segment]}), "bad.yaml")


def test_a_key_given_twice_is_refused_and_merge_keys_still_merge(tmp_path):
    """YAML forbids a key twice in one mapping (PyYAML would keep the last silently); ``<<:`` merges are not
    repeats: the explicit key overrides the merged one."""
    twice = tmp_path / "twice.yaml"
    twice.write_text("wind: {speed_mps: 3}\nseed: 1\nwind: {speed_mps: 9}\n")
    with pytest.raises(
        ConfigError, match=r"twice.yaml: malformed YAML at line 3, column 1: duplicate key 'wind' \(first at line 1\)"
    ):
        read_document(twice)
    merged = tmp_path / "merged.yaml"
    merged.write_text("base: &b {speed_mps: 3, from_deg: 90}\nwind: {<<: *b, speed_mps: 9}\n")
    assert read_document(merged)["wind"] == {"speed_mps": 9, "from_deg": 90}
