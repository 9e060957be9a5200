"""The unit's history of estimates (:class:`geofence.estimation.history.EstimateHistory`): states appended one by
one and blocks of ring rows taken in read back as the same states in the same order, and trimming to a window
keeps exactly those no older than its start, as a deque of states trimmed the same way does."""

from collections import deque

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence.estimation.history import EstimateHistory, state_of_row
from geofence.interface import VehicleState


def _row(t: float, k: int) -> list[float]:
    return [t] + [float(k * 16 + j) for j in range(1, 15)] + [float(k % 2)]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.booleans(), st.integers(1, 12), st.floats(0.01, 0.5), st.floats(0.0, 3.0)), min_size=1, max_size=25))
def test_blocks_and_states_read_back_as_one_trimmed_deque(steps):
    history = EstimateHistory()
    reference: deque[VehicleState] = deque()
    t = 0.0
    k = 0
    for as_block, count, dt, window in steps:
        rows = []
        for _ in range(count if as_block else 1):
            t += dt
            k += 1
            rows.append(_row(t, k))
        states = [state_of_row(r) for r in rows]
        if as_block:
            history.extend_rows(np.array(rows))
        else:
            history.append(states[0])
        reference.extend(states)
        while reference[0].t_s < t - window:
            reference.popleft()
        history.trim(t - window)
        assert list(history) == list(reference)
        assert history.first_t_s() == reference[0].t_s
    assert bool(history)
    assert EstimateHistory().first_t_s() == float("inf") and not EstimateHistory()
