"""A campaign flown in shards (issue 39's SORA-scale run): ``campaign generate --first-case`` numbers a shard's
cases, ``campaign report`` writes its containment counts, ``campaign combine`` adds the shards up. The counts of
shards add up to those of the whole (against :func:`analysis.containment.class_rates` on every row at once); shards
of different campaigns, overlapping ones and stale counts are refused in one line; and the whole chain runs on a
Dask cluster, resumably."""

from __future__ import annotations

import json
import math
import random
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from analysis.campaign_report import COUNTS_JSON, check_shards, combine_containment, read_shard
from analysis.containment import VOLUMES, ContingencyInputs, add_class_rates, class_rates
from geofence.interface import PlatformKind
from geofence.validation import ConfigError
from scenarios.app.batch import Trajectories, discover, plan, run_batch
from scenarios.campaign.generator import generate_cases

INPUTS = {
    "MR": ContingencyInputs(PlatformKind.MULTIROTOR, v0_mps=10.0, reaction_time_s=0.5, limit_rad=math.radians(30)),
    "FW": ContingencyInputs(PlatformKind.FIXED_WING, v0_mps=24.0, reaction_time_s=1.1, limit_rad=math.radians(40)),
}


def _row(rng: random.Random) -> dict:
    lateral, up = rng.choice([-5.0, 0.5, 20.0, 90.0, 400.0]), rng.choice([-3.0, 2.0, 15.0])
    return {
        "platform": rng.choice(list(INPUTS)), "ceiling_m": 60.0, "sim_time_s": rng.uniform(20.0, 120.0),
        "max_lateral_excursion_m": lateral, "max_vertical_excursion_m": up, "max_ceiling_excursion_m": up,
        "max_excursion_m": max(lateral, up), "breached_keep_out": rng.random() < 0.1,
        "landed_outside_gap": rng.random() < 0.1, "faults": rng.choice(["", "", "gnss_loss", "fc_ignores"]),
        "condition": rng.choice(["nominal", "activated at start"]),
    }  # fmt: skip


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 80), cuts=st.lists(st.integers(0, 80), max_size=4))
def test_the_shards_counts_add_up_to_the_whole_campaigns(seed, n, cuts):
    rng = random.Random(seed)
    rows = [_row(rng) for _ in range(n)]
    bounds = sorted({0, n, *(c for c in cuts if c < n)})
    shards = [class_rates(rows[a:b], INPUTS) for a, b in zip(bounds, bounds[1:])]
    whole = class_rates(rows, INPUTS)
    added = add_class_rates(shards)
    assert [(c.name, c.flights, c.exits) for c in added] == [(c.name, c.flights, c.exits) for c in whole]
    assert [c.hours for c in added] == pytest.approx([c.hours for c in whole], rel=1e-12)


def _counts_folder(tmp: Path, name: str, first: int, n: int, seed: int = 7, flights: int = 10) -> Path:
    folder = tmp / name
    folder.mkdir()
    (folder / "results.csv").write_text(f"flight\n{name}\n")
    from analysis.campaign_report import file_sha256

    doc = {
        "campaign": {"generator": "g", "seed": seed, "max_duration_s": 60.0, "platforms": ["F450"], "families": ["box"],
                     "faults": None, "downward_sensors": None},
        "cases": [first, n], "results_sha256": file_sha256(folder / "results.csv"), "variant": "predictive",
        "classes": [{"name": "nominal", "flights": flights, "hours": 0.25, "exits": {v: 1 for v in VOLUMES}}],
    }  # fmt: skip
    (folder / COUNTS_JSON).write_text(json.dumps(doc))
    return folder


def test_shards_of_one_campaign_are_combined_and_others_refused_in_one_line(tmp_path):
    a, b = _counts_folder(tmp_path, "a", 0, 10), _counts_folder(tmp_path, "b", 10, 10, flights=30)
    out = combine_containment([a, b], tmp_path / "combined.md")
    text = out.read_text()
    assert "| nominal | 40 | 0.5 | 2, 0.05" in text and "0..9" in text and "10..19" in text
    cases = [
        ([a, _counts_folder(tmp_path, "c", 5, 10)], "overlap"),
        ([a, _counts_folder(tmp_path, "d", 20, 10, seed=8)], "campaign.seed is 8"),
        ([a, tmp_path / "missing"], "missing"),
    ]
    for folders, problem in cases:
        with pytest.raises(ConfigError, match=problem) as exc:
            check_shards([read_shard(f) for f in folders])
        assert "\n" not in str(exc.value)
    (b / "results.csv").write_text("flight\nb\nanother\n")  # the batch went on after the report
    with pytest.raises(ConfigError, match="stale"):
        read_shard(b)
    (a / COUNTS_JSON).write_text("{")
    with pytest.raises(ConfigError, match="not a containment counts file"):
        read_shard(a)


def test_a_shard_holds_the_same_cases_as_the_whole_campaign():
    """Case ``i`` depends on the seed and ``i`` only: cases 3..5 of a shard are cases 3..5 of the campaign."""
    whole = generate_cases(6, 11, max_duration_s=40.0)
    shard = generate_cases(3, 11, max_duration_s=40.0, first_case=3)
    assert [c.case_id for c in shard] == [c.case_id for c in whole[3:]]
    assert [c.documents for c in shard] == [c.documents for c in whole[3:]]


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "scenarios.app.cli", *args], capture_output=True, text=True, timeout=600)


@pytest.mark.slow
def test_a_campaign_in_two_shards_flies_on_a_dask_cluster_resumes_and_combines(tmp_path):
    """The documented SORA-scale run, small: two shards generated, flown on a local Dask cluster with notable
    trajectories only, reported and combined; flying a shard again flies nothing."""
    distributed = pytest.importorskip("dask.distributed")
    camp, res = tmp_path / "camp", tmp_path / "res"
    for k, first in enumerate((0, 3)):
        gen = cli("campaign", "generate", str(camp / f"shard-{k}"), "--cases", "3", "--first-case", str(first),
                  "--seed", "20261204", "--max-duration-s", "40")  # fmt: skip
        assert gen.returncode == 0, gen.stderr
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        for k in range(2):
            specs = plan(discover(sorted((camp / f"shard-{k}").glob("*__predictive.yaml"))))
            outcome = run_batch(
                specs, res / f"shard-{k}", executor="dask", scheduler=cluster.scheduler_address, progress=False,
                trajectories=Trajectories.NOTABLE,
            )  # fmt: skip
            assert outcome.flown == len(specs) == 3 and not outcome.failed, outcome.reasons
        again = run_batch(specs, res / "shard-1", executor="dask", scheduler=cluster.scheduler_address, progress=False)
        assert again.skipped == 3 and again.flown == 0
    from analysis.report import collect_results, write_results_csv

    for k in range(2):
        write_results_csv(collect_results(res / f"shard-{k}"), res / f"shard-{k}" / "results.csv")
        rep = cli("campaign", "report", str(res / f"shard-{k}"), "--campaign", str(camp / f"shard-{k}"))
        assert rep.returncode == 0, rep.stderr
    comb = cli("campaign", "combine", str(res / "shard-0"), str(res / "shard-1"), "--out", str(tmp_path / "all.md"))
    assert comb.returncode == 0, comb.stderr
    text = (tmp_path / "all.md").read_text()
    assert "0..2" in text and "3..5" in text and "2 shards, 6 cases requested, 6 scored flights" in text
    bad = cli("campaign", "combine", str(res / "shard-0"), str(res / "shard-0"), "--out", str(tmp_path / "x.md"))
    assert bad.returncode == 2 and "overlap" in bad.stderr and "Traceback" not in bad.stderr
