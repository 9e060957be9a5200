"""Golden flights: whole closed-loop flights compared with trajectories committed in the repository.

Each ``tests/data/golden/<name>.yaml`` (a copy of a shipped scenario or campaign case, frozen here so that
editing the examples does not move it) is flown and its trajectory compared, within
:data:`support.GOLDEN_TOLERANCE`, with ``<name>.csv``. A refactoring that keeps behaviour passes; a change
of behaviour fails here first, and its author regenerates the tables on purpose, after reading why they
moved:

    GOLDEN_WRITE=1 python -m pytest tests/test_golden_flights.py -m slow

(and says so in the commit). The same flight twice gives the same bytes (determinism).
"""

from __future__ import annotations

import os

import pytest
from support import GOLDEN, GOLDEN_COLUMNS, compare_golden, golden_table, read_golden, write_golden

from scenarios.definition.schema import load_scenario
from scenarios.flight.runner import fly

pytestmark = [pytest.mark.slow, pytest.mark.closed_loop]

NAMES = sorted(p.stem for p in GOLDEN.glob("*.yaml"))


@pytest.mark.parametrize("name", NAMES)
def test_the_flight_matches_its_golden_trajectory(name):
    result = fly(load_scenario(GOLDEN / f"{name}.yaml"))
    table = golden_table(result)
    path = GOLDEN / f"{name}.csv"
    if os.environ.get("GOLDEN_WRITE") == "1":
        write_golden(path, table)
    assert not compare_golden(table, read_golden(path)), compare_golden(table, read_golden(path))


def test_the_same_flight_twice_gives_the_same_bytes():
    sc = load_scenario(GOLDEN / "fixedwing_adversarial_wind.yaml")
    a, b = fly(sc), fly(sc)
    assert a.recorder.n == b.recorder.n > 0
    assert a.recorder.data[: a.recorder.n].tobytes() == b.recorder.data[: b.recorder.n].tobytes()


def test_the_golden_tables_are_not_trivial():
    """The set covers both platform kinds' overrides: most golden flights record an override (mode 1), and each
    table holds more than 10 s of flight."""
    from geofence.unit.geofence_unit import Mode

    tables = {name: read_golden(GOLDEN / f"{name}.csv") for name in NAMES}
    assert len(tables) >= 6
    assert all(t.shape[0] > 100 for t in tables.values())
    overridden = [name for name, t in tables.items() if (t[:, GOLDEN_COLUMNS.index("geofence_mode")] == 1).any()]
    assert Mode(1) is Mode.OVERRIDE and len(overridden) >= 5, overridden
