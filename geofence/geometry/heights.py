"""What a fence's heights mean: the altitude reference they are measured from, and a keep-out's own
vertical extent (its floor and ceiling).

The one home of these two types. :mod:`geofence.geometry.fence` (the WGS-84 fence and its parser) and
:mod:`geofence.geometry.local_fence` (its projected, per-step form) both use them; keeping them here lets the
local form depend on the fence model's types without importing the fence model, so the two modules
import one way (``fence`` -> ``local_fence``).
"""

from __future__ import annotations

from enum import StrEnum
from typing import NamedTuple

import numpy as np


class AltitudeReference(StrEnum):
    """What the fence's heights (ceiling, floor, recovery altitude) are measured from."""

    AGL = "agl"
    """Above the ground under the vehicle (the scenario's flat ground at the start's ground altitude)."""
    AMSL = "amsl"
    """Above mean sea level (the WGS-84 height the platforms report)."""


ALTITUDE_REFERENCES = tuple(r.value for r in AltitudeReference)


class VerticalExtent(NamedTuple):
    """A keep-out's own floor and ceiling (m, in the fence's altitude reference); ``None`` = unbounded.

    ``VerticalExtent()`` is a full-height keep-out (the default). The geofence unit treats every keep-out
    as full-height (see :mod:`geofence.geometry.fence`); the scoring uses :meth:`volume_margin_array`.
    """

    floor_m: float | None = None
    ceiling_m: float | None = None

    @property
    def full_height(self) -> bool:
        """True when neither bound is set."""
        return self.floor_m is None and self.ceiling_m is None

    def volume_margin_array(self, outside_m: np.ndarray, h: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Distance outside the keep-out's volume (m, + outside, - inside), from the lateral one.

        ``outside_m``: each sample's distance outside the keep-out's footprint (+ outside, - inside);
        ``h``: its height. The result is ``max(outside_m, h - ceiling_m, floor_m - h)`` (an unbounded side
        drops out): negative only inside laterally *and* strictly between the floor and the ceiling, and then
        minus the smallest penetration along any axis; positive outside, where it is at most the Euclidean
        distance to the volume (conservative, like the gap-aware floor margin). ``out`` may be ``outside_m``
        itself (in place).
        """
        if out is None:
            out = np.array(outside_m, dtype=float)
        elif out is not outside_m:
            np.copyto(out, outside_m)
        h = np.asarray(h, dtype=float)
        if self.ceiling_m is not None:
            np.maximum(out, h - self.ceiling_m, out=out)
        if self.floor_m is not None:
            np.maximum(out, self.floor_m - h, out=out)
        return out


FULL_HEIGHT = VerticalExtent()
"""A keep-out with no floor and no ceiling of its own."""
