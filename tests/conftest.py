"""Test-suite settings shared by every test module: hypothesis's profile and the two tiers.

Hypothesis runs without its per-example deadline: the compiled kernels compile on their first call (a second
or more from a cold numba cache, as in a clean clone), and which example pays for that depends on the test
order. Timing belongs in ``bench/``, not in the tests.

Tiers. ``python3 -m pytest`` runs the fast tier (``-m "not slow"`` in pyproject.toml); ``python3 -m pytest -m
"slow or not slow"`` runs everything (what ``.ci/run`` runs). A test is in the slow tier when it is marked
``slow`` or ``closed_loop`` (it flies JSBSim in closed loop), when its module is in :data:`SLOW_MODULES`, or
when its name is in :data:`SLOW_TESTS`: the tests that took more than about 3 s on the 2-core machine
(``python3 -m pytest -m "slow or not slow" --durations=60`` lists them again).
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import settings

settings.register_profile("testbed", deadline=None)
settings.load_profile("testbed")

SLOW_MODULES = {
    "test_batch",  # whole batches in subprocesses, a Dask cluster
    "test_bench_smoke",  # every bench/ script on a tiny workload
    "test_compiled_flights",
    "test_flight_step",
    "test_golden_flights",
    "test_recovery_cases",
    "test_trust",  # signals and resumes of real batches
}
"""Modules every test of which flies whole flights or batches."""

SLOW_TESTS = {
    "test_an_airspace_sized_fence_is_drawn_in_bounded_memory",
    "test_generator_refuses_an_impossible_park",
    "test_shipped_airspace_scenarios_validate",
    "test_pruned_equals_scan",
    "test_200_generated_cases_validate_and_cover_every_family_and_platform",
    "test_acute_corners_and_stars_are_what_they_claim",
    "test_breach_attempts_cases_validate_and_aim_at_the_keep_in",
    "test_ci_slice_has_no_predictive_breach",
    "test_city_family_writes_airspace_scale_fences_only_when_asked",
    "test_random_family_writes_simple_polygons_with_keep_outs_clear_of_the_pole",
    "test_campaign_generate_and_report_refuse_bad_folders",
    "test_check_passes_a_comfortable_mission_and_flags_one_that_ends_at_the_fence",
    "test_bad_fence_one_line_exit_2",
    "test_score_log_scores_a_real_flight_against_a_real_fence_file",
    "test_a_turn_that_leaves_any_fence_has_a_negative_margin",
    "test_circle_polygon_lies_inside_the_circle_within_the_tolerance",
    "test_dense_fences_indexed_equal_the_reference",
    "test_index_equals_full_scan",
    "test_compiled_margins_on_dense_fences_equal_the_reference",
    "test_compiled_route_following_equals_the_reference",
    "test_a_turn_that_leaves_a_convex_keep_in_has_a_negative_margin",
    "test_the_property_meets_turns_that_leave_the_fence",
    "test_corrupted_timestamp_no_longer_hides_the_excursion",
    "test_fence_far_from_the_log_is_flagged",
    "test_future_timestamps_are_rejected",
    "test_heavily_corrupted_tlog_is_refused_exit_2",
    "test_randomly_flipped_bytes_are_refused_or_scored_honestly",
    "test_text_output_prints_each_warning_once",
    "test_truncated_log_warns",
    "test_pip_and_signed_distance_agree_with_shapely",
    "test_polygon_relations_agree_with_shapely",
    "test_self_intersection_agrees_with_shapely_degenerate_grid",
    "test_compiled_search_plans_the_python_searchs_routes",
    "test_routes_by_the_goal_tree_are_the_searchs_shortest_routes",
    "test_the_whole_graph_built_at_once_is_the_graph_found_node_by_node",
    "test_plots_are_written",
    "test_variants_share_the_flight_and_differ_only_in_the_geofence",  # its fixture flies a campaign slice
    "test_routes_are_the_same_with_and_without_the_grid",
    "test_help_explains_every_subcommand",
    "test_generator_is_deterministic_and_seed_dependent",
    "test_fences_fit_their_platform_and_winds_stay_within_its_limit",
    "test_clean_vtol_log_scores_49_m_out_with_no_warning",
    "test_grid_segment_test_equals_the_loop",
    "test_a_fixed_wing_below_the_floor_in_a_gap_is_scored_on_its_whole_climb_back_circle",
    "test_committed_ci_slice_is_the_generators_output",
}
"""Single tests of about 3 s or more (the fast tier keeps a quick one of each kind)."""


def pytest_collection_modifyitems(config, items):
    for item in items:
        module = item.module.__name__.rpartition(".")[2] if item.module is not None else ""
        name = getattr(item, "originalname", item.name)
        if item.get_closest_marker("closed_loop") or module in SLOW_MODULES or name in SLOW_TESTS:
            item.add_marker(pytest.mark.slow)


WARM_UP_FLIGHTS = ("geofence_multicopter_adversarial_calm", "geofence_fixedwing_adversarial_calm")
"""Flown for their first 15 s (each overrides) before the tests start, one process each, in parallel."""
_WARM_UP = """
import dataclasses, sys
from scenarios.definition.schema import load_scenario
from scenarios.flight.runner import fly
fly(dataclasses.replace(load_scenario(sys.argv[1]), duration_s=15.0))
"""


def pytest_sessionstart(session):
    """Compile the kernels once, before any test: on a cold numba cache (a clean clone) every worker and every
    flying subprocess a test starts would otherwise compile the same kernels at the same time (about 36 s of CPU
    each). In the controller only (not in an xdist worker), and only where numba compiles."""
    if hasattr(session.config, "workerinput") or os.environ.get("NUMBA_DISABLE_JIT") == "1":
        return
    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")]))
    procs = [
        subprocess.Popen([sys.executable, "-c", _WARM_UP, str(root / "scenarios" / f"{name}.yaml")], cwd=root, env=env)
        for name in WARM_UP_FLIGHTS
    ]
    for p in procs:
        p.wait(timeout=600)  # (a failure here shows again, with its traceback, in the tests that fly)


def pytest_xdist_auto_num_workers(config):
    """``-n auto``: one worker more than the cores on a small machine. About a minute of the suite waits on
    sockets and subprocesses (the MAVLink link tests, a real-time flight, MAVProxy, the batch and signal tests),
    and a spare worker runs other tests meanwhile."""
    cores = os.cpu_count() or 1
    return cores + 1 if cores <= 4 else cores
