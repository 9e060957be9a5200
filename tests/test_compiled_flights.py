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
from support import fly_both_ways

from scenarios.definition.schema import parse_scenario, read_document
from scenarios.definition.sweep import expand

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


@pytest.mark.closed_loop
def test_a_gust_timed_from_the_first_override_blows_the_same_either_way():
    """The activation-timed gust reaches the compiled wind sampler through the runner's first-activation hook: it
    blows (the wind differs from its calm-gust twin after the first override) and the flight is the same on the
    reference objects."""
    path = ROOT / "scenarios" / "geofence_multicopter_adversarial_wind.yaml"
    doc = read_document(path)
    gust = {"onset_s": 1.0, "onset_after": "first_activation", "amplitude_mps": 4.0, "length_m": 20.0}
    runs = {}
    for amplitude in (0.0, 4.0):
        doc["wind"]["gusts"] = [dict(gust, amplitude_mps=amplitude)]
        sc = replace(parse_scenario(doc, str(path), source=path), duration_s=60.0)
        runs[amplitude], _ = fly_both_ways(sc)
    calm, gusty = (runs[a].recorder.column("wind_east_mps") for a in (0.0, 4.0))
    assert runs[4.0].summary["activations"] > 0
    assert (calm != gusty).any()
