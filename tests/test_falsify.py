"""The falsifier: its family maps the unit cube onto valid scenarios, its refusals, and a short closed-loop search."""

import json

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from support import only_summary

from scenarios.app.cli import main
from scenarios.campaign.falsify_family import DIMENSION, case_document
from scenarios.campaign.generator import Variant
from scenarios.definition.schema import parse_scenario

PLATFORMS = ("F450", "F450RD", "Tern", "J3Cub")
MARGIN_TOLERANCE_M = 0.05


@settings(max_examples=50, deadline=None)
@given(
    x=st.lists(st.floats(0.0, 1.0), min_size=DIMENSION, max_size=DIMENSION),
    platform=st.sampled_from(PLATFORMS),
    variant=st.sampled_from((Variant.PREDICTIVE, Variant.REACTIVE)),
)
def test_every_point_of_the_cube_is_a_scenario_the_schema_accepts(x, platform, variant):
    doc, geometry = case_document(x, platform, variant)
    text = yaml.safe_dump(doc, sort_keys=False)
    sc = parse_scenario(yaml.safe_load(text), where="falsify.yaml")
    assert sc.aircraft == platform
    assert doc["geofence"]["trigger"] == variant.value
    assert geometry.scale_m > 0.0


def test_the_mapping_is_deterministic_and_moves_with_its_parameters():
    x = np.linspace(0.13, 0.77, DIMENSION)
    first, _ = case_document(x, "Tern", Variant.REACTIVE)
    again, _ = case_document(x.copy(), "Tern", Variant.REACTIVE)
    assert yaml.safe_dump(first) == yaml.safe_dump(again)
    for i in range(DIMENSION):  # every coordinate changes the document
        y = x.copy()
        y[i] = 1.0 - y[i]
        assert yaml.safe_dump(case_document(y, "Tern", Variant.REACTIVE)[0]) != yaml.safe_dump(first), i


@pytest.mark.parametrize(
    "args, expected",
    [
        (["--budget", "0"], "--budget: must be 1..100000 flights, got 0"),
        (["--budget", "-3"], "--budget: must be 1..100000 flights, got -3"),
        (["--budget", "10000000"], "--budget: must be 1..100000 flights, got 10000000"),
        (["--jobs", "0"], "--jobs: must be >= 1, got 0"),
        (["--platform", "Wright_Flyer"], "no platform profile for aircraft 'Wright_Flyer'"),
        (["--executor", "dask"], "--executor dask: give the cluster with --scheduler ADDRESS"),
    ],
)
def test_bad_arguments_are_refused_in_one_line(tmp_path, capsys, args, expected):
    base = {"--platform": "F450", "--variant": "reactive", "--budget": "10", "--out": str(tmp_path / "out")}
    base.update(dict(zip(args[::2], args[1::2])))
    code = main(["falsify", *[t for kv in base.items() for t in kv]])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and expected in err
    assert not (tmp_path / "out").exists()


@pytest.mark.closed_loop
def test_a_short_reactive_search_breaches_and_its_worst_case_reflies_to_its_margin(tmp_path, capsys):
    out = tmp_path / "falsify"
    argv = ["falsify", "--platform", "F450", "--variant", "reactive", "--budget", "12", "--popsize", "6"]
    argv += ["--trajectories", "notable"]
    assert main([*argv, "--out", str(out), "--jobs", "1", "--seed", "3", "--max-duration-s", "40"]) == 0
    console = capsys.readouterr().out
    assert "generation 1: 12/12 flights" in console
    record = json.loads((out / "falsify.json").read_text())
    margins = [e["margin_m"] for e in record["evaluations"]]
    assert len(margins) == 12 and [e["generation"] for e in record["evaluations"]] == [0] * 6 + [1] * 6
    assert record["worst_margin_m"] == min(margins) < 0.0  # the reactive fence is breached
    assert record["flights_to_first_breach"] is not None
    for e in record["evaluations"]:  # (notable: the trajectory of a flight that left the fence, not of one inside)
        kept = (out / "flights" / e["flight"] / "trajectory.csv").is_file()
        assert kept == (e["margin_m"] < 0.0 or not e["completed"]), e
    assert (out / "convergence.png").stat().st_size > 10_000
    worst = out / record["worst_files"][0]
    assert f"{min(margins):+.2f} m" in yaml.safe_load(worst.read_text())["description"]
    assert main(["run", str(worst), "--out", str(tmp_path / "again"), "--quiet", "--no-plot"]) == 0
    assert only_summary(tmp_path / "again")["min_margin_m"] == pytest.approx(min(margins), abs=MARGIN_TOLERANCE_M)
