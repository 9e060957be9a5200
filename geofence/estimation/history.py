"""The unit's estimates of the last seconds, which dead reckoning replays from the last fix.

One question: which estimates did the unit see since a time, oldest first? The unit appends each step's state
(:meth:`EstimateHistory.append`) and keeps those no older than a window before the newest
(:meth:`EstimateHistory.trim`). A compiled step keeps its states as rows of a ring (the layout of
:data:`geofence.unit.passes.RING_COLUMNS`: :class:`~geofence.interface.VehicleState`'s fields in order, then
``on_ground``); the unit takes them in as one block of rows (:meth:`EstimateHistory.extend_rows`), and they
become states only when they are read: dead reckoning starts rarely, a compiled flight takes its steps in often.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections import deque
from collections.abc import Iterator
from typing import Any

import numpy as np

from geofence.interface import VehicleState


def state_of_row(fields: list[Any]) -> VehicleState:
    """The :class:`VehicleState` of a ring row's values (a list: ``tolist`` of the row)."""
    est = VehicleState(*fields[:15])
    est.on_ground = fields[15] != 0.0
    return est


class _Rows:
    """A block of ring rows taken in, its times, and the first row still kept."""

    __slots__ = ("block", "times", "start")

    def __init__(self, block: np.ndarray) -> None:
        self.block = block
        self.times: list[float] = block[:, 0].tolist()
        self.start = 0


class EstimateHistory:
    """The states of the last window, oldest first: each a :class:`VehicleState` or a row of a block taken in."""

    def __init__(self) -> None:
        self._parts: deque[VehicleState | _Rows] = deque()

    def append(self, est: VehicleState) -> None:
        self._parts.append(est)

    def extend_rows(self, rows: np.ndarray) -> None:
        """States as ring rows, oldest first (the array is kept: a copy of the ring's)."""
        if len(rows):
            self._parts.append(_Rows(rows))

    def first_t_s(self) -> float:
        """The oldest state's time (inf when there is none)."""
        if not self._parts:
            return math.inf
        first = self._parts[0]
        return first.times[first.start] if isinstance(first, _Rows) else first.t_s

    def trim(self, oldest_t_s: float) -> None:
        """Forget the states older than ``oldest_t_s`` (they are in time order)."""
        parts = self._parts
        while parts:
            first = parts[0]
            if not isinstance(first, _Rows):
                if first.t_s < oldest_t_s:
                    parts.popleft()
                    continue
                return
            times = first.times
            if times[-1] < oldest_t_s:
                parts.popleft()
                continue
            first.start = bisect_left(times, oldest_t_s, first.start)  # the first row with t >= oldest_t_s
            return

    def __bool__(self) -> bool:
        return bool(self._parts)

    def __iter__(self) -> Iterator[VehicleState]:
        for part in self._parts:
            if isinstance(part, _Rows):
                for fields in part.block[part.start :].tolist():
                    yield state_of_row(fields)
            else:
                yield part
