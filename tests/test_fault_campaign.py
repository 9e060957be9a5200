"""Campaigns where every case carries one single failure (``campaign generate --faults``)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence.interface import PlatformKind
from scenarios.campaign.generator import Variant, draw_fault, generate_cases
from scenarios.definition.faults import FIXED_WING_ONLY, FaultKind, parse_faults
from scenarios.definition.schema import parse_scenario


@given(seed=st.integers(0, 2**32 - 1), multirotor=st.booleans(), approach=st.floats(5.0, 100.0))
def test_every_drawn_fault_is_one_the_schema_accepts_for_the_platform(seed, multirotor, approach):
    f = draw_fault(np.random.default_rng(seed), multirotor, approach, 120.0)
    kind = PlatformKind.MULTIROTOR if multirotor else PlatformKind.FIXED_WING
    (parsed,) = parse_faults([f], "x.yaml: faults", kind, 120.0, has_geofence=True)
    assert not (multirotor and parsed.kind in FIXED_WING_ONLY)
    assert (parsed.at_s is None) == bool(f.get("at_first_activation"))


@settings(max_examples=5)
@given(seed=st.integers(0, 1000))
def test_a_fault_campaign_has_the_same_cases_each_with_one_failure(seed):
    plain = generate_cases(6, seed, max_duration_s=60.0)
    faulty = generate_cases(6, seed, max_duration_s=60.0, faults=True)
    assert [c.case_id for c in plain] == [c.case_id for c in faulty]
    for a, b in zip(plain, faulty):
        pa, pb = a.documents[Variant.PREDICTIVE], b.documents[Variant.PREDICTIVE]
        assert {k: v for k, v in pa.items() if k not in ("sensors",)} == {k: v for k, v in pb.items() if k != "faults"}
        assert len(pb["faults"]) == 1 and "sensors" not in pb and b.manifest["faults"] == pb["faults"]
        sc = parse_scenario(pb, f"{b.case_id}.yaml")
        assert len(sc.faults) == 1
        unprotected = b.documents[Variant.UNPROTECTED]
        assert "faults" not in unprotected or "at_s" in unprotected["faults"][0]


@settings(max_examples=5)
@given(seed=st.integers(0, 1000))
def test_downward_sensors_fit_every_multirotor_unit_and_change_nothing_else(seed):
    """``--downward-sensors``: each protected multirotor flight's unit gets a rangefinder and an optical flow (which
    parse), a fixed-wing's and every unprotected flight nothing; the cases are the same otherwise."""
    plain = generate_cases(6, seed, max_duration_s=60.0, faults=True)
    fitted = generate_cases(6, seed, max_duration_s=60.0, faults=True, downward_sensors=True)
    assert [c.case_id for c in plain] == [c.case_id for c in fitted]
    for a, b in zip(plain, fitted):
        multirotor = b.manifest["platform_kind"] == PlatformKind.MULTIROTOR.value
        for variant in Variant:
            da, db = a.documents[variant], b.documents[variant]
            fits = multirotor and variant is not Variant.UNPROTECTED
            sensors = db.get("sensors", {})
            assert ("optical_flow" in sensors and "rangefinder" in sensors) == fits
            rest = {k: v for k, v in sensors.items() if k not in ("optical_flow", "rangefinder")}
            assert {**db, "sensors": rest} == {**da, "sensors": da.get("sensors", {})}
            if fits:
                sc = parse_scenario(db, f"{b.case_id}.yaml")
                assert sc.sensors.rangefinder is not None and sc.sensors.optical_flow is not None


def test_the_fault_draws_cover_every_kind_and_moment():
    kinds, moments = set(), set()
    rng = np.random.default_rng(7)
    for _ in range(400):
        f = draw_fault(rng, bool(rng.integers(2)), 40.0, 120.0)
        kinds.add(f["kind"])
        moments.add("at_s" if "at_s" in f else "late" if f["delay_s"] >= 2.0 else "override")
    assert kinds == {k.value for k in FaultKind} and moments == {"at_s", "late", "override"}
