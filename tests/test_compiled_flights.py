"""Every shipped scenario flies: the top-level examples, the CI pair, the paper's and the rotor-drag ones (both
platform kinds, missions and scripted and breach-attempt pilots, calm, steady, turbulent and gusty wind,
activation-timed gusts, GNSS loss, floors with gaps, keep-out circles) fly their first 20 s without a numerical
error, and a gust timed from the first override blows from then on only.
"""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from scenarios.definition.schema import parse_scenario, read_document
from scenarios.definition.sweep import expand
from scenarios.flight.runner import fly

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
def test_a_shipped_scenario_flies(name):
    """A sweep file flies its first two flights: every step recorded, the time advancing by the outer-loop step."""
    path = ROOT / "scenarios" / name
    for spec in expand(read_document(path), str(path), path.stem)[:2]:
        sc = parse_scenario(spec.document, str(path), source=path)
        result = fly(replace(sc, duration_s=min(sc.duration_s, 20.0)))
        assert result.summary["error"] is None
        t = result.recorder.column("time_s")
        assert result.recorder.n > 10 and np.all(np.diff(t) > 0.0)
        assert np.isfinite(result.recorder.column("east_m")).all()


@pytest.mark.closed_loop
def test_a_gust_timed_from_the_first_override_blows_from_then_on():
    """The activation-timed gust reaches the wind sampler through the runner's first-activation hook: the flight
    with it and its calm-gust twin record the same wind until the first override, and different winds after."""
    path = ROOT / "scenarios" / "geofence_multicopter_adversarial_wind.yaml"
    doc = read_document(path)
    gust = {"onset_s": 1.0, "onset_after": "first_activation", "amplitude_mps": 4.0, "length_m": 20.0}
    runs = {}
    for amplitude in (0.0, 4.0):
        doc["wind"]["gusts"] = [dict(gust, amplitude_mps=amplitude)]
        runs[amplitude] = fly(replace(parse_scenario(doc, str(path), source=path), duration_s=60.0))
    first = runs[4.0].summary["first_activation_s"]
    assert runs[4.0].summary["activations"] > 0 and first == runs[0.0].summary["first_activation_s"]
    calm, gusty = (runs[a].recorder.column("wind_east_mps") for a in (0.0, 4.0))
    t = runs[4.0].recorder.column("time_s")
    n = min(len(calm), len(gusty))
    before = t[:n] <= first
    assert np.array_equal(calm[:n][before], gusty[:n][before])
    assert (calm[:n] != gusty[:n]).any()
