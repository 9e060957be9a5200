"""The efficacy campaign: generator (determinism, schema validity, sizes), report math, and the CI slice.

* the generator is reproducible from its seed and every generated document
  validates (~200 cases, no flying);
* generated fences fit their platform (inradius vs the turn/stop room and the
  worst-case shift), winds stay within each platform's limit, missions stay
  3 rooms inside every boundary;
* the report's statistics against known values (Clopper-Pearson 0 of 1000 ->
  0.00299, the Poisson bound) and its counting rules on synthetic rows;
* closed loop: the committed CI slice (``scenarios/campaign_ci``, 16 cases x 3
  variants) flown on two processes fails on any predictive keep-in breach,
  keep-out entry or out-of-gap landing.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.stats import binom, poisson

from aircraft.profile import available_profiles, load_profile
from analysis.campaign_report import (
    KEEP_IN_TOLERANCE_M,
    campaign_report_lines,
    campaign_rows,
    case_fence,
    clopper_pearson_upper,
    condition,
    describe_flight,
    excursion_comparison,
    flight_outcome,
    flight_summaries,
    group_stats,
    load_manifest,
    offending_flights,
    peak_sustained_wind_mps,
    poisson_rate_upper,
    score_unprotected,
    unprotected_vs_protected,
    write_campaign_report,
)
from geofence.geometry.fence import parse_fence
from geofence.geometry.geodesy import LocalFrame
from geofence.geometry.polygon import self_intersections, signed_area
from geofence.physics.dynamics import return_not_assured
from geofence.physics.rooms import worst_case_lateral_shift_m
from geofence.validation import ConfigError
from scenarios.campaign.generator import (
    BREACH_PUSH_FACTOR,
    CITY_BUILDINGS,
    CITY_VERTICES,
    DEFAULT_FAMILIES,
    MISSION_INSET_ROOMS,
    RANDOM_VERTICES,
    Attack,
    CampaignError,
    CaseFamily,
    Variant,
    build_case,
    case_family,
    generate_campaign,
    generate_cases,
    platform_room_m,
    random_simple_polygon,
    wind_authority,
    wind_limit_mps,
)
from scenarios.definition.schema import PilotKind, load_scenario, parse_scenario
from wind.dryden import SEVERITY_W20_MPS, dryden_scales

ROOT = Path(__file__).parents[1]
CI_SLICE = ROOT / "scenarios" / "campaign_ci"
CI_SEED, CI_CASES, CI_MAX_DURATION_S = 10, 16, 120.0
"""How scenarios/campaign_ci was generated (the seed was picked for coverage before flying: every platform, the
breach-attempts pilot on both platform kinds, each reaching the fence within 120 s, and normal missions)."""


# --------------------------------------------------------------------------- generator
@pytest.fixture(scope="module")
def campaign_200(tmp_path_factory):
    out = tmp_path_factory.mktemp("campaign200")
    paths = generate_campaign(out, 200, 2024)  # validates every document; a rejection raises CampaignError
    return out, paths, json.loads((out / "campaign.json").read_text())


def test_generator_is_deterministic_and_seed_dependent(tmp_path):
    a = generate_campaign(tmp_path / "a", 12, 5)
    b = generate_campaign(tmp_path / "b", 12, 5)
    assert [p.name for p in a] == [p.name for p in b]
    assert all(p.read_bytes() == q.read_bytes() for p, q in zip(a, b))
    assert (tmp_path / "a" / "campaign.json").read_bytes() == (tmp_path / "b" / "campaign.json").read_bytes()
    other = generate_cases(12, 6)
    assert [c.documents[Variant.PREDICTIVE] for c in other] != [
        json.loads(json.dumps(c.documents[Variant.PREDICTIVE])) for c in generate_cases(12, 5)
    ]
    # case i does not depend on how many cases are asked for
    assert generate_cases(3, 5)[2].documents == generate_cases(12, 5)[2].documents


def test_200_generated_cases_validate_and_cover_every_family_and_platform(campaign_200):
    out, paths, manifest = campaign_200
    cases = manifest["cases"]
    assert manifest["n_cases"] == len(cases) >= 190
    assert len(paths) == 3 * len(cases)
    assert {c["family"] for c in cases} == {f.value for f in DEFAULT_FAMILIES}
    assert {c["platform"] for c in cases} == set(manifest["platforms"])
    assert {"multirotor", "fixed_wing"} <= {c["platform_kind"] for c in cases}
    attacks = {c["attack"] for c in cases}
    assert {
        "head_on",
        "shallow",
        "corner",
        "turning",
        "repeated",
        "climb",
        "descend",
        "mission",
        "into_keep_out",
        "behind_keep_out",
        "gap_takeoff",
        "gap_descent_dash",
        "breach_attempts",
    } <= attacks
    breach_kinds = {c["platform_kind"] for c in cases if c["attack"] == "breach_attempts"}
    assert breach_kinds == {"multirotor", "fixed_wing"}
    assert all(c["pilot"] == "breach_attempts" for c in cases if c["attack"] == "breach_attempts")
    assert any(c["gps_fault"] for c in cases)
    lats = [c["site"]["lat_deg"] for c in cases]
    assert min(lats) < -60.0 and max(lats) > 60.0
    assert max(c["site"]["ground_alt_m"] for c in cases) > 2000.0
    assert len({c["site"]["continent"] for c in cases}) >= 7
    # an independent load of a sample of the files (the generator validated all of them)
    for p in paths[::7]:
        sc = load_scenario(p)
        assert sc.name == p.stem


def test_variants_share_the_flight_and_differ_only_in_the_geofence(campaign_200):
    out, _, manifest = campaign_200
    for c in manifest["cases"][:60]:
        docs = {v: yaml.safe_load((out / f).read_text()) for v, f in c["files"].items()}
        assert docs["predictive"]["geofence"]["trigger"] == "predictive"
        assert docs["reactive"]["geofence"]["trigger"] == "reactive"
        assert "geofence" not in docs["unprotected"]
        assert docs["predictive"]["geofence"]["fence"] == docs["reactive"]["geofence"]["fence"] == c["fence"]
        strip = [{k: v for k, v in d.items() if k not in ("name", "geofence")} for d in docs.values()]
        assert strip[0] == strip[1] == strip[2]
        assert docs["predictive"]["name"] == f"{c['case_id']}__predictive"


def test_fences_fit_their_platform_and_winds_stay_within_its_limit(campaign_200):
    _, _, manifest = campaign_200
    for c in manifest["cases"]:
        profile = load_profile(c["platform"])
        room = platform_room_m(profile)
        shift = worst_case_lateral_shift_m(profile.envelope, c["design_wind_mps"])
        fence = case_fence(c)
        r = fence.inradius()[2]
        assert r > shift, c["case_id"]
        if c["family"] not in ("corridor", "floor_gaps"):  # the corridor's rooms / gap sizing set these
            assert r >= 2.9 * room, (c["case_id"], r, room)
        assert c["fence_span_m"] <= 9000.0
        w = c["wind"]
        total = w["speed_mps"] + max([g["amplitude_mps"] for g in w.get("gusts", [])], default=0.0)
        assert total <= wind_limit_mps(profile) + 0.02, c["case_id"]
        assert 0.0 <= c["site"]["ground_alt_m"] <= 2800.0


def test_missions_keep_three_rooms_inside_every_boundary(campaign_200):
    out, _, manifest = campaign_200
    missions = [c for c in manifest["cases"] if c["pilot"] == "mission"]
    assert len(missions) >= 10
    for c in missions:
        doc = yaml.safe_load((out / c["files"]["predictive"]).read_text())
        st = c["start"]
        frame = LocalFrame(st["lat_deg"], st["lon_deg"], st["ground_alt_m"])
        fence = case_fence(c)
        room = platform_room_m(load_profile(c["platform"]))
        pts = [(0.0, 0.0)] + [frame.to_enu(i["lat_deg"], i["lon_deg"], frame.h0_m)[:2] for i in doc["mission"]["items"]]
        for a, b in zip(pts, pts[1:]):
            for s in np.linspace(0.0, 1.0, 25):
                e, n = a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])
                assert fence.lateral_margin_m(e, n) >= MISSION_INSET_ROOMS * room - 1.0, c["case_id"]


def test_acute_corners_and_stars_are_what_they_claim(campaign_200):
    _, _, manifest = campaign_200
    for c in manifest["cases"]:
        v = case_fence(c).keep_in.vertices
        k = len(v)
        angles = []
        for j in range(k):
            a, b = v[j - 1] - v[j], v[(j + 1) % k] - v[j]
            angles.append(math.degrees(math.acos(np.clip(a @ b / np.hypot(*a) / np.hypot(*b), -1, 1))))
        if c["family"] == "acute":
            assert 19.5 <= min(angles) <= 40.5, c["case_id"]
        if c["family"] == "star":
            assert k in (10, 12, 14)


def test_circle_family_writes_keep_in_circle_and_validates(tmp_path):
    generate_campaign(tmp_path, 3, 11, families=[CaseFamily.CIRCLE])  # validates every document
    cases = json.loads((tmp_path / "campaign.json").read_text())["cases"]
    assert len(cases) == 3
    for c in cases:
        assert c["family"] == "circle" and c["attack"] != "corner"
        fence = c["fence"]
        assert "keep_in" not in fence and set(fence["keep_in_circle"]) == {"center", "radius_m"}
        sc = load_scenario(tmp_path / c["files"]["predictive"])
        assert sc.geofence is not None and sc.geofence.fence.keep_in_circle is not None
        r = fence["keep_in_circle"]["radius_m"]
        local = case_fence(c)
        n = len(local.keep_in.vertices)
        assert n >= 16 and local.inradius()[2] == pytest.approx(r * math.cos(math.pi / n), rel=2e-3)
        # the polygon is the circle's (centred on its centre), the start is inside, sized like the other families
        st = c["start"]
        frame = LocalFrame(st["lat_deg"], st["lon_deg"], st["ground_alt_m"])
        ce, cn, _ = frame.to_enu(*fence["keep_in_circle"]["center"], frame.h0_m)
        assert math.hypot(local.inradius()[0] - ce, local.inradius()[1] - cn) < 0.01 * r
        assert max(np.hypot(*(local.keep_in.vertices - [ce, cn]).T)) == pytest.approx(r, rel=1e-3)  # ENU at the site height
        assert local.lateral_margin_m(0.0, 0.0) > 0.0
        assert r >= 2.9 * platform_room_m(load_profile(c["platform"]))


def _buildings(fence: dict) -> list[float]:
    polys = [k["ceiling_m"] for k in fence.get("keep_out_polygons", []) if isinstance(k, dict)]
    return polys + [k["ceiling_m"] for k in fence.get("keep_out_circles", []) if "ceiling_m" in k]


def test_city_family_writes_airspace_scale_fences_only_when_asked(tmp_path):
    """``--families city``: a ragged keep-in of thousands of vertices and tens to hundreds of buildings, sized to
    the platform (two rooms between buildings), every document validated; never in a default campaign."""
    assert CaseFamily.CITY not in DEFAULT_FAMILIES
    assert set(DEFAULT_FAMILIES) | {CaseFamily.CITY, CaseFamily.RANDOM} == set(CaseFamily)
    generate_campaign(tmp_path, 4, 2611, families=[CaseFamily.CITY], max_duration_s=60.0)
    manifest = json.loads((tmp_path / "campaign.json").read_text())
    assert manifest["families"] == ["city"] and manifest["n_cases"] >= 3
    for c in manifest["cases"]:
        sc = load_scenario(tmp_path / c["files"]["predictive"])
        fence = sc.geofence.fence
        assert CITY_VERTICES[0] <= len(fence.keep_in) <= CITY_VERTICES[1]
        assert CITY_BUILDINGS[0] <= len(fence.keep_out_polygons) <= CITY_BUILDINGS[1]
        local = fence.to_local(LocalFrame(sc.start.lat_deg, sc.start.lon_deg, sc.start.ground_alt_m))
        room = platform_room_m(load_profile(sc.aircraft))
        centres = np.array([p.vertices.mean(axis=0) for p in local.keep_out_polygons])
        gaps = np.hypot(*(centres[:, None, :] - centres[None, :, :]).transpose(2, 0, 1)) + np.eye(len(centres)) * 1e9
        assert gaps.min() >= 2.0 * room  # (centres: at least the clearance plus the buildings' own sizes apart)


def test_random_family_writes_simple_polygons_with_keep_outs_clear_of_the_pole(tmp_path):
    """``--families random``: a simple keep-in of 5-40 vertices sized like the lateral families,
    keep-outs (in about half the cases) inside it, clear of its pole and of each other, every document
    validated; never in a default campaign (published seeds keep their cases)."""
    assert CaseFamily.RANDOM not in DEFAULT_FAMILIES
    generate_campaign(tmp_path, 30, 2711, families=[CaseFamily.RANDOM], max_duration_s=60.0)
    manifest = json.loads((tmp_path / "campaign.json").read_text())
    assert manifest["families"] == ["random"] and manifest["n_cases"] >= 25
    with_keep_outs = 0
    attacks = set()
    for c in manifest["cases"]:
        attacks.add(c["attack"])
        local = case_fence(c)
        v = local.keep_in.vertices
        assert RANDOM_VERTICES[0] <= len(v) <= RANDOM_VERTICES[1]
        e, n, r_in = local.inradius()
        room = platform_room_m(load_profile(c["platform"]))
        assert r_in >= 2.9 * room
        assert not self_intersections(v), c["case_id"]  # simple
        outs = [(float(np.mean(p.vertices[:, 0])), float(np.mean(p.vertices[:, 1]))) for p in local.keep_out_polygons]
        outs += [(ce, cn) for ce, cn, _ in local.keep_out_circles]
        with_keep_outs += bool(outs)
        for ce, cn in outs:
            assert local.keep_in.signed_distance(ce, cn) > 0.0  # inside the keep-in
        assert local.lateral_margin_m(e, n) > 0.0  # the pole (the default recovery point) is clear of them
    assert 5 <= with_keep_outs <= 25
    assert len(attacks) >= 4


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(RANDOM_VERTICES[0], RANDOM_VERTICES[1]))
@example(seed=2332, k=5).via("a first draw that crosses its edges")
@example(seed=4854, k=6).via("a first draw that crosses its edges")
def test_random_keep_in_polygons_are_simple_whatever_the_draw(seed, k):
    """A random family keep-in is a simple polygon of k vertices with no sliver edge, also where an angular gap
    of pi or more puts an edge on the far side of the centre (5-vertex draws: one in eight; seed 26112703 once
    stopped on one that crossed its other edges)."""
    v = random_simple_polygon(np.random.default_rng(seed), k)
    assert v.shape == (k, 2)
    assert not self_intersections(v) and signed_area(v) != 0.0
    angles = np.arctan2(v[:, 0], v[:, 1]) % (2.0 * math.pi)
    gaps = np.diff(np.append(angles, angles[0] + 2.0 * math.pi))
    assert gaps.min() >= 0.25 * 2.0 * math.pi / k - 1e-9  # sorted, no two closer than a quarter share
    assert np.hypot(v[:, 0], v[:, 1]).max() <= 1.0


def test_keep_out_family_writes_buildings_with_their_own_ceiling():
    cases = generate_cases(24, 3, families=[CaseFamily.KEEP_OUT])
    polygon_buildings = 0
    for case in cases:
        fence = case.manifest["fence"]
        parsed = parse_fence(fence, case.case_id)  # the schema's fence parser accepts every form written
        for i, k in enumerate(fence.get("keep_out_polygons", [])):
            if isinstance(k, dict):
                assert set(k) == {"polygon", "ceiling_m"}
                assert parsed.keep_out_polygon_extents[i].ceiling_m == k["ceiling_m"]
                polygon_buildings += 1
        # a building stands above the flight (the pilot flies level into it) and below the fence's ceiling
        for top in _buildings(fence):
            assert case.manifest["start"]["agl_m"] + 4.9 <= top <= fence["ceiling_m"]
    assert polygon_buildings >= 1
    assert 0 < sum(bool(_buildings(c.manifest["fence"])) for c in cases) < len(cases)


def _breach_case(kind: str, seed: int = 7):
    platforms = [p for p in available_profiles() if load_profile(p).kind.value == kind]
    for i in range(300):
        case = build_case(i, seed, CaseFamily.CONVEX_BOX, platforms, max_duration_s=120.0)
        if case is not None and case.attack is Attack.BREACH_ATTEMPTS:
            return case
    raise AssertionError(f"no breach-attempts case for a {kind} in 300 box cases")


def _ray_exit_m(local, course_deg: float, limit_m: float, step_m: float = 0.25) -> float:
    """Distance from the start (the frame origin) along ``course_deg`` to the first point outside the keep-in."""
    ue, un = math.sin(math.radians(course_deg)), math.cos(math.radians(course_deg))
    for d in np.arange(0.0, limit_m + step_m, step_m):
        if local.keep_in.signed_distance(d * ue, d * un) < 0.0:
            return float(d)
    return math.inf


def _nearest_edge(ki, p: np.ndarray) -> int:
    t = np.clip(np.einsum("ij,ij->i", p - ki.starts, ki.directions), 0.0, ki.lengths)
    foot = ki.starts + t[:, None] * ki.directions
    return int(np.argmin(np.hypot(*(p - foot).T)))


@pytest.mark.parametrize("kind", ["multirotor", "fixed_wing"])
def test_breach_attempts_cases_validate_and_aim_at_the_keep_in(kind):
    case = _breach_case(kind)
    m = case.manifest
    assert m["pilot"] == "breach_attempts" and m["platform_kind"] == kind
    for variant, doc in case.documents.items():
        sc = parse_scenario(yaml.safe_load(yaml.safe_dump(doc)), where=f"{case.case_id}/{variant.value}")
        assert sc.pilot.kind is PilotKind.BREACH_ATTEMPTS and sc.pilot.breach is not None
    pilot = case.documents[Variant.PREDICTIVE]["pilot"]
    env = load_profile(m["platform"]).envelope
    lo, hi = pilot["speed_mps"]
    assert hi == pytest.approx(env.max_speed_mps, abs=0.01)
    assert lo == pytest.approx(0.5 * env.max_speed_mps if kind == "multirotor" else env.cruise_speed_mps, abs=0.01)
    assert pilot["home_agl_m"] == m["start"]["agl_m"] and pilot["rest_s"] == 3.0
    assert pilot["attempts"] >= 1 and m["duration_s"] <= 120.0
    bearings = [d for d in pilot["directions"] if not isinstance(d, str)]
    assert 2 <= len(bearings) <= 4 and set(pilot["directions"]) - set(bearings) <= {"up"}
    local = case_fence(m)
    ki = local.keep_in
    exits = []
    for b in bearings:
        d = _ray_exit_m(local, b, pilot["push_m"])
        assert d < pilot["push_m"], (case.case_id, b, d, pilot["push_m"])  # the ray leaves the keep-in within push_m
        exits.append(d)
        # it leaves head-on (within 5 deg of the edge's normal) or shallow (15-30 deg off the edge)
        ue, un = math.sin(math.radians(b)), math.cos(math.radians(b))
        p = np.array([d * ue, d * un])
        i = _nearest_edge(ki, p)
        off_edge = math.degrees(math.asin(min(1.0, abs(ue * ki.outward_normals[i][0] + un * ki.outward_normals[i][1]))))
        assert off_edge >= 84.5 or 14.5 <= off_edge <= 30.5, (case.case_id, b, off_edge)
    # push_m is 1.3 x the farthest target (a fixed-wing's: from its orbit's roll-out point, so at least that)
    assert pilot["push_m"] >= BREACH_PUSH_FACTOR * max(exits) - 1.0
    if kind == "multirotor":
        assert pilot["push_m"] == pytest.approx(BREACH_PUSH_FACTOR * max(exits), abs=1.0)


def test_the_circle_family_takes_over_only_its_own_cases():
    families = list(DEFAULT_FAMILIES)
    assert families[-1] is CaseFamily.CIRCLE
    for i in range(200):
        if i % len(families) == len(families) - 1:
            assert case_family(i, families) is CaseFamily.CIRCLE
        else:  # the family case i had before the circle family existed
            assert case_family(i, families) is families[i % (len(families) - 1)]
    counts = [sum(case_family(i, families) is f for i in range(90)) for f in families]
    assert counts == [9] * len(families)
    assert [case_family(i, [CaseFamily.STAR]) for i in range(3)] == [CaseFamily.STAR] * 3


def test_bad_arguments_are_rejected(tmp_path):
    """Bad arguments are user input (ConfigError, exit 2 in the CLI); CampaignError is kept for generator bugs."""
    with pytest.raises(ConfigError, match="platforms") as exc:
        generate_campaign(tmp_path, 2, 0, platforms=["NoSuchPlane"])
    assert not isinstance(exc.value, CampaignError)
    with pytest.raises(ConfigError, match="families"):
        generate_campaign(tmp_path, 2, 0, families=["box"])  # type: ignore[list-item]
    assert not issubclass(CampaignError, ConfigError)


def test_committed_ci_slice_is_the_generators_output(tmp_path):
    generate_campaign(tmp_path, CI_CASES, CI_SEED, max_duration_s=CI_MAX_DURATION_S)
    committed = sorted(p.name for p in CI_SLICE.iterdir())
    assert committed == sorted(p.name for p in tmp_path.iterdir())
    for name in committed:
        assert (CI_SLICE / name).read_text() == (tmp_path / name).read_text(), (
            f"{name} differs: regenerate with generate_campaign(Path('scenarios/campaign_ci'), {CI_CASES}, {CI_SEED}, max_duration_s={CI_MAX_DURATION_S})"
        )
    manifest = json.loads((CI_SLICE / "campaign.json").read_text())
    assert len(manifest["cases"]) == CI_CASES
    assert all(c["duration_s"] <= CI_MAX_DURATION_S for c in manifest["cases"])
    assert len({c["family"] for c in manifest["cases"]}) == len(DEFAULT_FAMILIES)
    assert len({c["platform"] for c in manifest["cases"]}) >= 5


def test_wind_authority_uses_the_scenarios_own_turbulence_and_the_units_rule():
    """Mean wind at the start height (profile applied) + one Dryden sigma there, judged like a told forecast."""
    f450rd = load_profile("F450RD")
    gusty = {
        "speed_mps": 5.99,
        "from_deg": 89.4,
        "profile": {"law": "power", "exponent": 0.14, "reference_height_m": 10},
        "turbulence": {"severity": "moderate"},
    }
    a = wind_authority(gusty, 18.4, f450rd, 34.0)
    assert a["mean_wind_mps"] == pytest.approx(5.99 * 1.84**0.14, abs=0.01)
    assert a["turbulence_sigma_mps"] == pytest.approx(dryden_scales(18.4, SEVERITY_W20_MPS["moderate"])[2], abs=0.01)
    assert a["beyond_authority"] and a["beyond_authority"].startswith("return impossible")
    calm_turb = dict(gusty, turbulence={"severity": "light"})
    assert wind_authority(calm_turb, 18.4, f450rd, 34.0)["beyond_authority"] is None
    # the same rule as the unit's, at the density of the site
    assert (wind_authority(gusty, 18.4, f450rd, 34.0)["beyond_authority"] is None) == (
        return_not_assured(a["mean_wind_mps"], a["turbulence_sigma_mps"], f450rd.envelope) is None
    )


def test_the_forecast_tells_the_turbulence_and_the_gusts_within_20_percent():
    cases = generate_cases(40, 11)
    told_sigma = told_gust = 0
    for c in cases:
        prior = c.documents[Variant.PREDICTIVE]["geofence"]["wind_prior"]
        assert c.documents[Variant.REACTIVE]["geofence"]["wind_prior"] == prior
        sigma = c.manifest["turbulence_sigma_mps"]
        if sigma > 0.0:
            told_sigma += 1
            assert 0.8 * sigma - 0.01 <= prior["turbulence_sigma_mps"] <= 1.2 * sigma + 0.01
        else:
            assert "turbulence_sigma_mps" not in prior
        gusts = c.manifest["wind"].get("gusts")
        if gusts:
            told_gust += 1
            top = max(g["amplitude_mps"] for g in gusts)
            assert 0.8 * top - 0.01 <= prior["gust_mps"] <= 1.2 * top + 0.01
        else:
            assert "gust_mps" not in prior
    assert told_sigma and told_gust


def test_the_wind_met_comes_from_the_summary_and_from_the_trajectory_only_where_the_summary_has_none(tmp_path):
    """A resumed batch mixes flights whose summary keeps ``peak_sustained_wind_mps`` with older ones whose cell
    in results.csv is empty: those are read from their trajectory (a steady 5 m/s), the others keep theirs."""
    t = np.arange(0.0, 30.0, 0.025)
    manifest = {"cases": [{"case_id": f"box-000{i}", "family": "box", "attack": "head_on", "platform": "F450"}
                          for i in range(2)]}  # fmt: skip
    for i in range(2):
        folder = tmp_path / f"box-000{i}__predictive"
        folder.mkdir()
        np.savetxt(folder / "trajectory.csv", np.column_stack([t, np.full_like(t, 5.0), np.zeros_like(t)]),
                   delimiter=",", header="time_s,wind_east_mps,wind_north_mps", comments="")  # fmt: skip
    rows = [{"flight": "box-0000__predictive", "peak_sustained_wind_mps": None},
            {"flight": "box-0001__predictive", "peak_sustained_wind_mps": 3.0}]  # fmt: skip
    got = {r["case_id"]: r["peak_sustained_wind_mps"] for r in campaign_rows(rows, manifest, tmp_path)}
    assert got["box-0000"] == pytest.approx(5.0, abs=1e-6) and got["box-0001"] == 3.0


def test_peak_sustained_wind_is_the_largest_moving_mean_over_the_window(tmp_path):
    """A 5 s burst of 20 m/s in a 3 m/s wind, sampled at 40 Hz: its 10 s mean is (5 x 20 + 5 x 3) / 10 = 11.5."""
    t = np.arange(0.0, 60.0, 0.025)
    we = np.where((t >= 30.0) & (t < 35.0), 20.0, 3.0)
    path = tmp_path / "trajectory.csv"
    np.savetxt(
        path,
        np.column_stack([t, we, np.zeros_like(t), t]),
        delimiter=",",
        header="time_s,wind_east_mps,wind_north_mps,x",
        comments="",
    )
    assert peak_sustained_wind_mps(path) == pytest.approx(11.5, abs=0.15)  # one 25 ms sample of slack
    assert peak_sustained_wind_mps(path, window_s=5.0) == pytest.approx(20.0, abs=0.15)
    np.savetxt(path, np.column_stack([t, t]), delimiter=",", header="time_s,x", comments="")
    assert math.isnan(peak_sustained_wind_mps(path))


def test_the_report_counts_nominal_gps_fault_and_beyond_authority_apart():
    manifest = {"cases": [dict(c) for c in SYNTH_MANIFEST["cases"]]}
    manifest["cases"][0]["beyond_authority"] = "return impossible: wind 9 m/s >= 90% of max speed 10 m/s"
    manifest["cases"][2]["gps_fault"] = {"gps_fail_at_s": 3.0}
    rows = campaign_rows([r for r in synthetic_rows()], manifest)
    by_case = {r["case_id"]: condition(r) for r in rows}
    assert by_case == {"box-0000": "beyond authority", "star-0001": "nominal", "box-0002": "GPS fault"}
    text = "\n".join(campaign_report_lines(rows, manifest))
    nominal = text.split("## Nominal conditions")[1].split("## Per variant and condition")[0]
    assert "| predictive | 1 |" in nominal  # only star-0001's predictive flight is nominal
    assert "| predictive | GPS fault | 1 |" in text and "| predictive | beyond authority | 1 |" in text
    assert "beyond authority (return impossible" in describe_flight(next(r for r in rows if r["flight"] == "box-0000__reactive"))
    assert "predates the authority test" not in text
    old_rows = campaign_rows(synthetic_rows(), SYNTH_MANIFEST)  # a manifest written before the authority test
    assert "predates the authority test" in "\n".join(campaign_report_lines(old_rows, SYNTH_MANIFEST))


def test_a_flight_that_met_a_wind_beyond_its_max_speed_is_classed_apart_breached_or_not(tmp_path):
    """The in-flight class reads every flight's own trajectory: box-0002's predictive flight met a 10 s
    mean of 12 m/s (max speed 10 m/s), its reactive twin 8 m/s, whatever their outcomes."""
    manifest = {"cases": [dict(c, max_speed_mps=10.0) for c in SYNTH_MANIFEST["cases"]]}
    manifest["cases"][2]["gps_fault"] = {"gps_fail_at_s": 3.0}  # the wind met comes before the GPS fault
    t = np.arange(0.0, 60.0, 0.025)
    for flight, burst in (("box-0002__predictive", 12.0), ("box-0002__reactive", 8.0), ("box-0000__predictive", 9.5)):
        (tmp_path / flight).mkdir()
        we = np.where((t >= 20.0) & (t < 40.0), burst, 2.0)
        np.savetxt(
            tmp_path / flight / "trajectory.csv",
            np.column_stack([t, we, np.zeros_like(t)]),
            delimiter=",",
            header="time_s,wind_east_mps,wind_north_mps",
            comments="",
        )
    raw = [dict(r) for r in synthetic_rows()]
    rows = campaign_rows(raw, manifest, batch_dir=tmp_path)
    by_flight = {r["flight"]: condition(r) for r in rows}
    assert by_flight["box-0002__predictive"] == "beyond max speed in flight"
    assert by_flight["box-0002__reactive"] == "GPS fault"
    assert by_flight["box-0000__predictive"] == "nominal"  # 9.5 m/s: within its max speed
    assert by_flight["star-0001__predictive"] == "nominal"  # no trajectory: judged by its case alone
    text = "\n".join(campaign_report_lines(rows, manifest))
    assert "| predictive | beyond max speed in flight | 1 |" in text
    assert "wind met 12.0 m/s over 10 s, 1.20 x its max speed 10.0 m/s" in describe_flight(
        next(r for r in rows if r["flight"] == "box-0002__predictive")
    )


def test_a_case_whose_predictive_unit_activated_at_its_first_step_is_classed_apart_in_every_variant():
    """box-0002's predictive unit overrode at t = 0 (its start was inside the activation boundary): the case's
    three flights leave the nominal figure, whatever their own units did; star-0001's first activation came
    later (nominal), and box-0000's summary predates the field (nominal)."""
    raw = [dict(r) for r in synthetic_rows()]
    for r in raw:
        if r["flight"] == "box-0002__predictive":
            r["first_activation_s"] = 0.0
        elif r["flight"] == "star-0001__predictive":
            r["first_activation_s"] = 12.5
        r.pop("activated_at_start", None)
    rows = campaign_rows(raw, SYNTH_MANIFEST)
    by_flight = {r["flight"]: condition(r) for r in rows}
    assert {f: c for f, c in by_flight.items() if f.startswith("box-0002")} == {
        "box-0002__predictive": "activated at start",
        "box-0002__reactive": "activated at start",
        "box-0002__unprotected": "activated at start",
    }
    assert by_flight["star-0001__predictive"] == "nominal" and by_flight["box-0000__predictive"] == "nominal"
    text = "\n".join(campaign_report_lines(rows, SYNTH_MANIFEST))
    assert "| predictive | activated at start | 1 |" in text
    nominal = text.split("## Nominal conditions")[1].split("## Per variant and condition")[0]
    assert "| predictive | 2 |" in nominal
    assert "activated at start (inside the activation boundary)" in describe_flight(
        next(r for r in rows if r["flight"] == "box-0002__reactive")
    )


# --------------------------------------------------------------------------- report math
def test_clopper_pearson_matches_known_values_and_the_binomial():
    assert clopper_pearson_upper(0, 1000) == pytest.approx(0.002991, abs=5e-6)
    assert clopper_pearson_upper(0, 1000) == pytest.approx(1.0 - 0.05 ** (1 / 1000), rel=1e-9)
    assert clopper_pearson_upper(3, 3) == 1.0
    assert math.isnan(clopper_pearson_upper(0, 0))
    for k, n in ((1, 10), (5, 20), (17, 300)):
        p = clopper_pearson_upper(k, n)
        assert binom.cdf(k, n, p) == pytest.approx(0.05, abs=1e-9)
        assert p > k / n
    with pytest.raises(ValueError):
        clopper_pearson_upper(4, 3)


def test_poisson_rate_bound_matches_known_values():
    assert poisson_rate_upper(0, 1.0) == pytest.approx(-math.log(0.05), rel=1e-9)  # 2.9957 per hour
    assert poisson_rate_upper(0, 10.0) == pytest.approx(0.29957, rel=1e-4)
    mu = poisson_rate_upper(4, 2.0) * 2.0
    assert poisson.cdf(4, mu) == pytest.approx(0.05, abs=1e-9)
    assert math.isnan(poisson_rate_upper(1, 0.0))


def _row(flight, **kw):
    base = {
        "flight": flight,
        "completed": True,
        "error": None,
        "sim_time_s": 60.0,
        "max_excursion_m": -5.0,
        "max_lateral_excursion_m": -5.0,
        "max_vertical_excursion_m": -20.0,
        "breached_keep_out": False,
        "landed_outside_gap": False,
        "activations": 1,
        "mission_finished": False,
    }
    base.update(kw)
    return base


SYNTH_MANIFEST = {
    "cases": [
        {
            "case_id": "box-0000",
            "family": "box",
            "attack": "head_on",
            "platform": "F450",
            "platform_kind": "multirotor",
            "pilot": "scripted",
        },
        {
            "case_id": "star-0001",
            "family": "star",
            "attack": "mission",
            "platform": "Tern",
            "platform_kind": "fixed_wing",
            "pilot": "mission",
        },
        {
            "case_id": "box-0002",
            "family": "box",
            "attack": "corner",
            "platform": "Tern",
            "platform_kind": "fixed_wing",
            "pilot": "scripted",
        },
    ]
}


def synthetic_rows():
    raw = [
        _row("box-0000__predictive", max_lateral_excursion_m=KEEP_IN_TOLERANCE_M, max_excursion_m=0.0),  # on the line: no breach
        _row("box-0000__reactive", max_lateral_excursion_m=3.0, max_excursion_m=3.0),
        _row("box-0000__unprotected", max_lateral_excursion_m=40.0, max_excursion_m=40.0, activations=0),
        _row("star-0001__predictive", activations=2, mission_finished=False),  # stalled by the geofence
        _row("star-0001__reactive", activations=0, mission_finished=True),
        _row(
            "star-0001__unprotected",
            completed=False,
            error="FloatingPointError: diverged",
            max_excursion_m=None,
            max_lateral_excursion_m=None,
            max_vertical_excursion_m=None,
        ),
        _row("box-0002__predictive", max_lateral_excursion_m=1e-6, max_excursion_m=1e-6, breached_keep_out=True),
        _row("box-0002__reactive", max_vertical_excursion_m=2.0, max_excursion_m=2.0, landed_outside_gap=True),
        _row("box-0002__unprotected", max_lateral_excursion_m=9.0, max_excursion_m=9.0, activations=0),
        _row("other-0009__predictive"),  # not in the manifest: left out
    ]
    return campaign_rows(raw, SYNTH_MANIFEST)


def test_every_flight_summary_says_its_status_and_whether_its_twin_breached():
    by = {r["flight"]: r for r in flight_summaries(synthetic_rows())}
    assert len(by) == 9
    # box-0000: the predictive flight held on the line while its twin flew 40 m out
    assert by["box-0000__predictive"]["breach"] is False and by["box-0000__predictive"]["twin_breached"] is True
    assert by["box-0000__unprotected"]["twin_breached"] == "" and by["box-0000__unprotected"]["breach"] is True
    # star-0001: a mission the geofence stalled is not an error; its twin erred, so nothing is said of it
    assert by["star-0001__predictive"]["status"] == "mission stalled by the geofence"
    assert by["star-0001__predictive"]["twin_breached"] == ""
    assert by["star-0001__reactive"]["status"] == "completed"
    assert by["star-0001__unprotected"]["status"] == "error" and by["star-0001__unprotected"]["breach"] == ""
    # box-0002: the predictive flight entered a keep-out, its twin breached too
    p = by["box-0002__predictive"]
    assert (p["breach"], p["keep_out_entry"], p["keep_in_breach"], p["twin_breached"]) == (True, True, True, True)
    assert by["box-0002__reactive"]["out_of_gap_landing"] is True and by["box-0002__reactive"]["vertical_breach"] is True


def test_counts_breaches_missions_and_errors_on_synthetic_rows():
    rows = synthetic_rows()
    assert len(rows) == 9
    pred = group_stats([r for r in rows if r["variant"] == "predictive"])
    assert (pred.flights, pred.scored, pred.keep_in_breaches, pred.keep_out_entries, pred.breaches) == (3, 3, 1, 1, 1)
    assert pred.hours == pytest.approx(3 * 60.0 / 3600.0)
    assert pred.breach_rate_upper == pytest.approx(clopper_pearson_upper(1, 3))
    assert pred.per_hour_upper == pytest.approx(poisson_rate_upper(1, 0.05))
    assert (pred.missions, pred.nuisance_missions, pred.stalled_missions) == (1, 1, 1)
    rea = group_stats([r for r in rows if r["variant"] == "reactive"])
    assert (rea.keep_in_breaches, rea.vertical_breaches, rea.out_of_gap_landings, rea.breaches) == (1, 1, 1, 2)
    assert (rea.nuisance_missions, rea.stalled_missions) == (0, 0)
    twin = group_stats([r for r in rows if r["variant"] == "unprotected"])
    assert (twin.flights, twin.errors, twin.scored, twin.breaches, twin.stalled_missions) == (3, 1, 2, 2, 0)
    assert [r["flight"] for r in offending_flights(rows)] == ["box-0002__predictive"]
    assert "keep-in, keep-out" in describe_flight(offending_flights(rows)[0])
    # a breach of the ceiling or floor alone is an offending flight too (the report lists it)
    over = campaign_rows([_row("box-0000__predictive", max_vertical_excursion_m=3.1, max_excursion_m=3.1)], SYNTH_MANIFEST)
    assert [r["flight"] for r in offending_flights(over)] == ["box-0000__predictive"]
    assert "vertical" in describe_flight(offending_flights(over)[0])
    cmp = unprotected_vs_protected(rows)
    assert cmp["predictive"] == {
        "twin_breached": 2,
        "twin_breached_and_held": 1,
        "twin_breached_and_breached": 1,
        "twin_clean_but_breached": 0,
    }
    assert cmp["reactive"]["twin_breached_and_breached"] == 2


def test_excursion_comparison_ratios_and_pairs():
    rows = synthetic_rows()
    box = next(c for c in excursion_comparison(rows) if c["family"] == "box")
    assert box["stats"]["reactive"].max_m == 3.0
    assert box["stats"]["predictive"].mean_m == pytest.approx(0.5e-6)
    assert box["mean_depth_ratio"] == pytest.approx(0.5e-6 / 2.5)  # depths: predictive (0, 1e-6), reactive (3, 2)
    assert box["max_depth_ratio"] == pytest.approx(1e-6 / 3.0)
    assert box["paired_n"] == 2
    assert box["paired_mean_m"] == pytest.approx(((0.0 - 3.0) + (1e-6 - 2.0)) / 2)


def test_unprotected_twin_is_scored_from_its_trajectory(tmp_path):
    case = next(c for c in load_manifest(CI_SLICE / "campaign.json")["cases"] if c["family"] == "box")
    fence = case_fence(case)
    e0, n0, r = fence.inradius()
    # fly straight east from the pole to 30 m beyond the fence
    edge = e0
    while fence.keep_in.signed_distance(edge, n0) > -30.0:
        edge += 1.0
    t = np.linspace(0.0, 60.0, 601)
    east = np.linspace(e0, edge, len(t))
    folder = tmp_path / f"{case['case_id']}__unprotected"
    folder.mkdir()
    cols = {
        "time_s": t,
        "east_m": east,
        "north_m": np.full_like(t, n0),
        "agl_m": np.full_like(t, 10.0),
        "alt_m": np.full_like(t, 10.0 + case["start"]["ground_alt_m"]),
        "geofence_mode": np.zeros_like(t),
    }
    with open(folder / "trajectory.csv", "w") as fh:
        fh.write(",".join(cols) + "\n")
        for i in range(len(t)):
            fh.write(",".join(f"{cols[k][i]:.6f}" for k in cols) + "\n")
    scores = score_unprotected(tmp_path, {"flight": folder.name}, case)
    assert scores["max_lateral_excursion_m"] == pytest.approx(-fence.keep_in.signed_distance(edge, n0), abs=0.05)
    assert flight_outcome(scores).keep_in_breach
    assert score_unprotected(tmp_path, {"flight": "missing__unprotected"}, case) == {}


# --------------------------------------------------------------------------- closed loop: the CI slice


@pytest.mark.closed_loop
def test_ci_slice_has_no_predictive_breach(tmp_path):
    from analysis.report import collect_results, read_results_csv, write_results_csv
    from scenarios.app.batch import discover, plan, run_batch

    t0 = time.perf_counter()
    specs = plan(discover([CI_SLICE]))
    assert len(specs) == 3 * CI_CASES and not [s.error for s in specs if s.error]
    outcome = run_batch(specs, tmp_path, jobs=2, progress=False)
    wall = time.perf_counter() - t0
    write_results_csv(collect_results(tmp_path), tmp_path / "results.csv")
    from aircraft.profile import load_profile
    from analysis.containment import ContingencyInputs

    envs = {p: load_profile(p).envelope for p in load_manifest(CI_SLICE / "campaign.json")["platforms"]}
    inputs = {p: ContingencyInputs(e.kind, e.max_speed_mps, e.reaction_time_s, e.max_bank_rad) for p, e in envs.items()}
    report = write_campaign_report(tmp_path, CI_SLICE / "campaign.json", contingency=inputs)
    text = report.read_text()
    assert "## Containment (predictive)" in text and (tmp_path / "campaign_containment.png").is_file()
    nominal = next(ln for ln in text.splitlines() if ln.startswith("| nominal |") and "(0." in ln)
    assert nominal.split(" | ")[4].startswith("0,"), nominal  # no predictive flight left its contingency volume
    rows = campaign_rows(read_results_csv(tmp_path / "results.csv"), load_manifest(CI_SLICE / "campaign.json"), tmp_path)
    print(f"CI slice: {len(specs)} flights in {wall:.1f} s wall; report {report}")
    assert not outcome.failed, f"flights failed: {outcome.failed}"
    assert len(rows) == 3 * CI_CASES
    # the twins must have been scored, and the fence must matter somewhere
    assert all(math.isfinite(float(r["max_excursion_m"])) for r in rows if r["variant"] == "unprotected")
    assert group_stats([r for r in rows if r["variant"] == "unprotected"]).breaches > 0
    # the breach attempts of both platform kinds reach the fence (the geofence acts on them)
    attempts = [r for r in rows if r["variant"] == "predictive" and r["attack"] == "breach_attempts"]
    assert {r["platform_kind"] for r in attempts} == {"multirotor", "fixed_wing"}
    assert all(float(r["activations"]) > 0 for r in attempts), [(r["flight"], r["activations"]) for r in attempts]
    with open(tmp_path / "campaign_flights.csv", newline="") as fh:
        flights = list(csv.DictReader(fh))
    assert len(flights) == 3 * CI_CASES
    assert all(f["twin_breached"] in ("True", "False") for f in flights if f["variant"] == "predictive")
    assert {f["status"] for f in flights} <= {"completed", "mission stalled by the geofence", "incomplete"}
    bad = offending_flights(rows, "predictive")
    for r in bad:
        print("PREDICTIVE BREACH:", describe_flight(r))
    assert not bad, "predictive keep-in breach / keep-out entry / vertical breach / out-of-gap landing:\n" + "\n".join(
        map(describe_flight, bad)
    )


def test_a_report_of_results_that_are_not_the_campaigns_is_refused_in_one_line(tmp_path):
    """Issue 41: results of another batch gave a report of "0 flights in the results" and exit 0."""
    from analysis.report import write_results_csv

    write_results_csv([_row("survey_calm"), _row("other-0001__predictive")], tmp_path / "results.csv")
    (tmp_path / "campaign.json").write_text(json.dumps(SYNTH_MANIFEST))
    with pytest.raises(ConfigError, match=r"none of its 2 flights is one of the campaign's .* e\.g\. box-0000__predictive"):
        write_campaign_report(tmp_path, tmp_path / "campaign.json")
    assert not (tmp_path / "campaign_report.md").exists()
    res = subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "campaign", "report", str(tmp_path), "--campaign", str(tmp_path)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "none of its 2 flights" in res.stderr, res.stderr
