"""The compiled override step's hand-back question (:func:`geofence.unit_kernel.no_hand_back`, which
:func:`~geofence.unit_kernel.override_pass` asks after the minimum override period) against the unit's own
(:meth:`geofence.unit.GeofenceUnit._handback_ok`): where the compiled step goes on flying the override, the unit
would not have handed back and its state is unchanged; where it does not, the unit hands back (or clears its climb
back above the floor first). And the vertical hysteresis has one formula both ways."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from geofence.boundary_shift import ShiftResult
from geofence.config import parse_geofence
from geofence.geodesy import LocalFrame
from geofence.interface import Envelope, PlatformKind, VehicleState
from geofence.unit import GeofenceUnit
from geofence.unit_kernel import N_UNIT, no_hand_back

FRAME = LocalFrame(47.0, 8.0, 400.0)
TERN = Envelope(
    PlatformKind.FIXED_WING, 16.0, 24.0, 12.0, math.radians(40), math.radians(25), math.radians(28), 5.0, 3.0, 0.6, 5.0, 1.1
)


def _unit(floor_m: float | None, ceiling_m: float) -> GeofenceUnit:
    half = 400.0
    corners = [(-half, -half), (half, -half), (half, half), (-half, half)]
    fence: dict = {"keep_in": [list(FRAME.to_geodetic(e, n, 0.0)[:2]) for e, n in corners], "ceiling_m": ceiling_m}
    if floor_m is not None:
        gap = [(-50.0, -50.0), (50.0, -50.0), (50.0, 50.0), (-50.0, 50.0)]
        fence.update(floor_m=floor_m, floor_gaps=[[list(FRAME.to_geodetic(e, n, 0.0)[:2]) for e, n in gap]])
    cfg = parse_geofence({"fence": fence}, "test")
    return GeofenceUnit(cfg, cfg.fence.to_local(FRAME), TERN)


def _margins(lateral_activation: float, closing: float, vertical_activation: float) -> ShiftResult:
    return ShiftResult(
        min(lateral_activation, vertical_activation), 50.0, 10.0, lateral_activation, "keep_in", 0, 1, 1.0, 0.0, 60.0,
        closing, math.inf, 1, 0.3, 40.0, 5.0, 30.0, 5.0, vertical_activation, math.inf,
    )  # fmt: skip


near = st.floats(-3.0, 12.0)  # round the hysteresis thresholds (5 m lateral, 2 m vertical)


@settings(max_examples=300, deadline=None)
@given(
    floor=st.none() | st.floats(5.0, 30.0),
    band=st.floats(2.0, 120.0),
    climb_back=st.none() | st.floats(0.0, 60.0),
    goal=st.none() | st.floats(0.0, 150.0),
    latency=st.floats(0.0, 1.0),
    sigma_v=st.floats(0.0, 5.0),
    lateral=near,
    closing=st.floats(-3.0, 3.0),
    vertical=near,
    e=st.floats(-30.0, 30.0),
    n=st.floats(-30.0, 30.0),
    h=st.floats(0.0, 150.0),
)
def test_the_compiled_step_flies_on_only_where_the_unit_would_not_hand_back(
    floor, band, climb_back, goal, latency, sigma_v, lateral, closing, vertical, e, n, h
):
    unit = _unit(floor, (floor or 0.0) + band)
    unit._climb_back_to_m = climb_back
    unit._goal_h_m, unit._goal_short_of_band = (math.nan, False) if goal is None else (goal, True)
    unit._latency_s, unit._sigma_v_m = latency, sigma_v
    U = np.zeros(N_UNIT)
    unit._pack_margins_inputs(U)
    unit._pack_hand_back(U)
    assert unit._compiled is not None
    V = unit._compiled._terms
    r = _margins(lateral, closing, vertical)
    fields = tuple(r[:4]) + (0,) + tuple(r[7:])  # the kernel's fields: the element's id for its name and index
    flies_on = no_hand_back(U, V, fields, e, n, h, latency, sigma_v)
    s = VehicleState(east_m=e, north_m=n, agl_m=h, alt_m=400.0 + h)
    hands_back = unit._handback_ok(s, r, r.activation_margin_m)
    if flies_on:
        assert not hands_back
        assert unit._climb_back_to_m == climb_back  # nothing changed
    else:
        assert hands_back or (climb_back is not None and unit._climb_back_to_m is None)


@settings(max_examples=200, deadline=None)
@given(
    floor=st.none() | st.floats(5.0, 30.0),
    band=st.floats(2.0, 120.0),
    goal=st.none() | st.floats(0.0, 150.0),
    latency=st.floats(0.0, 1.0),
    sigma_v=st.floats(0.0, 5.0),
)
def test_the_vertical_hysteresis_is_half_the_room_at_rest_at_a_goal_short_of_the_band(floor, band, goal, latency, sigma_v):
    """At most the configured hysteresis; below it only for a goal short of the band, and then half the room the
    vehicle has at rest there (never negative)."""
    unit = _unit(floor, (floor or 0.0) + band)
    unit._goal_h_m, unit._goal_short_of_band = (math.nan, False) if goal is None else (goal, True)
    unit._latency_s, unit._sigma_v_m = latency, sigma_v
    hyst = unit._vertical_handback_m
    got = unit._vertical_handback_at_goal_m()
    if goal is None:
        assert got == hyst
    else:
        assert 0.0 < got <= hyst
