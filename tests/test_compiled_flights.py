"""Property: the compiled kernels change the speed of a flight, never the flight.

Every shipped scenario (the top-level examples, the CI pair, the paper's and the rotor-drag ones: both platform
kinds, missions and scripted and breach-attempt pilots, calm, steady, turbulent and gusty wind, activation-timed
gusts, GNSS loss, floors with gaps, keep-out circles) flies its first 20 s twice, with the compiled kernels
(the sensing chain, the wind field, the margins, the scans, the ENU conversion) and on the plain-Python
reference (:func:`geofence.jit.use_compiled` off), and records the same trajectory bytes either way.
"""

from dataclasses import replace
from pathlib import Path

import pytest
from test_lateral_kernel import fly_both_ways

from scenarios.spec.schema import parse_scenario, read_document
from scenarios.spec.sweep import expand

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted(
    p.relative_to(ROOT / "scenarios").as_posix()
    for pattern in ("*.yaml", "ci/*.yaml", "paper/*.yaml", "rotor_drag/*.yaml")
    for p in (ROOT / "scenarios").glob(pattern)
)


def test_the_list_is_not_empty():
    assert len(SHIPPED) >= 15


@pytest.mark.closed_loop
@pytest.mark.parametrize("name", SHIPPED)
def test_a_shipped_scenario_flies_the_same_compiled_and_in_python(name):
    """A sweep file flies its first two flights."""
    path = ROOT / "scenarios" / name
    for spec in expand(read_document(path), str(path), path.stem)[:2]:
        sc = parse_scenario(spec.document, str(path), source=path)
        fly_both_ways(replace(sc, duration_s=min(sc.duration_s, 20.0)))
