"""A CI slice of issue 10's acceptance run (scenarios/rotor_drag/): a wind the platform cannot be sure to beat.

The F450RD (10.3 m/s at its 30 deg tilt limit) in 8 m/s mean wind with moderate turbulence (the
operator tells the unit the Dryden sigma, 2.8 m/s at 20 m) and a 4 m/s gust: mean + one sigma is beyond
90 % of its max speed, so return cannot be assured and the unit lands in the floor gap at once, before
the pilot's full-speed push takes it downwind of the only gap. The flights flown here (sweep indices)
breached before the landing was made wind-proof (lowest safe height on the way, aim upwind in the gap,
full-rate descent, finishing a touchdown below the floor rather than climbing back out of the gap): by
+6.1 m across the keep-in edge (mc032, true wind above the max speed for 40 s) and by +4.3 m below the
floor (mc039); mc031 (a 19 m/s gust 1 m above the ground) stays 0.3 m inside only because the touchdown
is finished, not climbed out of (+4.9 m below the floor without it). The full 50-seed run per platform
is ``geofence-testbed batch scenarios/rotor_drag``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from scenarios.definition.schema import parse_scenario, read_document
from scenarios.definition.sweep import expand
from scenarios.flight.runner import fly

SWEEP = Path(__file__).parents[1] / "scenarios" / "rotor_drag" / "f450rd_adversarial_wind_seeds.yaml"


@pytest.mark.parametrize("index", [31, 32, 39])
def test_wind_beyond_authority_lands_in_the_gap_without_a_breach(index):
    specs = expand(read_document(SWEEP), str(SWEEP), SWEEP.stem)
    spec = specs[index]
    sc = parse_scenario(spec.document, where=spec.flight_id, source=SWEEP)
    res = fly(sc)
    s = res.summary
    first = s["mode_transitions"][0]
    assert first["to"] == "LAND_IN_GAP" and "return impossible" in first["reason"], first
    assert s["final_mode"] == "LAND_IN_GAP"
    assert s["max_lateral_excursion_m"] < 0.0, "crossed the keep-in edge"
    assert s["max_vertical_excursion_m"] < 0.0, "below the floor outside the gap"
    assert not s["breached_keep_out"] and not s["landed_outside_gap"]
    assert res.recorder.column("agl_m")[-1] < 0.5, "still in the air at the end"
