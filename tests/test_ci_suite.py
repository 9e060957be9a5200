"""The CI comparison suite (scenarios/ci) tests what it says: every lateral edge, the ceiling and the floor.

* :func:`test_ci_courses_point_at_every_edge_with_enough_run` checks, without
  flying, that each scripted flight's first segment points head-on at one
  keep-in edge from the start, that the segment is long enough to cross that
  edge at full speed unprotected, that per platform and wind the four flights
  cover the four edges, and that every flight has a climb segment long enough
  to reach the ceiling and a descent segment long enough to reach the floor
  (away from the floor gap).
* :func:`support.assert_ci_suite_approaches` checks the *flown* suite (a batch output
  folder with ``*/trajectory.csv`` and ``scenario.yaml``): each flight's
  closest approach to its target edge is below 2 x the platform's worst-case
  lateral activation room at that wind
  (:func:`geofence.physics.rooms.worst_case_lateral_shift_m`), and per
  platform and wind the ceiling and the floor were approached within 2 x the
  vertical room (arrest distance plus k·sigma of the GPS vertical error). It is
  called from the CI-suite batch test in ``tests/test_batch.py`` on the
  flights that test already flies (no second batch).
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import numpy as np
from support import scenario_local_fence, target_edge, vertical_room_m

from scenarios.app.batch import discover, plan
from scenarios.definition.schema import parse_scenario

ROOT = Path(__file__).parents[1]
CI_SUITE = ROOT / "scenarios" / "ci"
HEAD_ON_COS = math.cos(math.radians(10.0))
"""A course counts as pointing at an edge when within 10 degrees of its outward normal."""


def _vertical_sticks(seg, multirotor: bool) -> float:
    """The climb demand of a segment in [-1, 1] (+ climb)."""
    if seg.sticks is not None:
        return seg.sticks[3] if multirotor else seg.sticks[1]
    return {"hold": 0.0, "max": 1.0, "descend": -1.0}[seg.climb]


def _ci_scenarios():
    specs = plan(discover([CI_SUITE]))
    assert specs and not any(s.error for s in specs), [s.error for s in specs if s.error]
    return [(s.flight_id, parse_scenario(s.document, s.source, s.flight_id)) for s in specs]


def test_ci_courses_point_at_every_edge_with_enough_run():
    covered: dict[tuple[str, float], set[int]] = defaultdict(set)
    for name, sc in _ci_scenarios():
        fence = scenario_local_fence(sc)
        env = sc.profile.envelope
        seg0 = sc.pilot.segments[0]
        assert seg0.course_deg is not None and seg0.speed == "max" and seg0.climb == "hold", name
        edge, dist = target_edge(sc, fence)
        assert edge >= 0, f"{name}: course {seg0.course_deg} leaves the fence through no edge"
        c = math.radians(seg0.course_deg)
        normal = fence.keep_in.outward_normals[edge]
        assert normal @ np.array([math.sin(c), math.cos(c)]) >= HEAD_ON_COS, f"{name}: course not head-on at edge {edge}"
        run = env.max_speed_mps * seg0.duration_s
        assert run >= dist, f"{name}: {run:.0f} m of run at full speed < {dist:.0f} m to edge {edge}"
        # the approach line does not cross a floor gap (the floor stays in force along it)
        for g in fence.floor_gaps:
            s = np.linspace(0.0, dist, 200)[:, None] * np.array([math.sin(c), math.cos(c)])
            assert not g.contains_array(s).any(), f"{name}: the approach to edge {edge} crosses a floor gap"
        covered[(sc.aircraft, sc.wind.speed_mps if sc.wind else 0.0)].add(edge)

        assert fence.floor_m is not None and fence.floor_gaps, f"{name}: no floor with a gap"
        # nominal height through the vertical segments, in order: each must reach the room above the floor or
        # below the ceiling (where the unit takes over) from where the previous one left it
        lo = fence.floor_m + vertical_room_m(sc, env.max_descent_rate_mps)
        hi = fence.ceiling_m - vertical_room_m(sc, env.max_climb_rate_mps)
        h, reached = sc.start.agl_m, set()
        for seg in sc.pilot.segments[1:]:
            v = _vertical_sticks(seg, env.is_multirotor)
            h += seg.duration_s * v * (env.max_climb_rate_mps if v > 0 else env.max_descent_rate_mps)
            if h >= hi:
                h, _ = hi, reached.add("ceiling")
            if h <= lo:
                h, _ = lo, reached.add("floor")
        assert reached == {"ceiling", "floor"}, f"{name}: the vertical segments reach only {sorted(reached)}"
    assert {a for a, _ in covered} == {"F450RD", "Tern"}
    for key, edges in covered.items():
        assert edges == {0, 1, 2, 3}, f"{key}: courses reach edges {sorted(edges)} only"
    winds = {a: {w for b, w in covered if b == a} for a, _ in covered}
    assert winds == {"F450RD": {0, 3, 6}, "Tern": {0, 4, 8}}, winds
