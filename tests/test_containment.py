"""The containment section: contingency volume sizes against independent computations, exits and class rates."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from analysis.containment import (
    ContingencyInputs,
    class_rates,
    containment_lines,
    contingency_volume,
    flight_exits,
)
from geofence.interface import PlatformKind
from geofence.physics.dynamics import G_MPS2
from geofence.physics.rooms import turn_radius_m

MR = ContingencyInputs(PlatformKind.MULTIROTOR, v0_mps=10.0, reaction_time_s=0.5, limit_rad=math.radians(30))
FW = ContingencyInputs(PlatformKind.FIXED_WING, v0_mps=24.0, reaction_time_s=1.1, limit_rad=math.radians(40))


def _stopping_distance_m(v0: float, decel: float) -> float:
    """Integrated: a point braking at a constant deceleration until it stops (scipy, an event at v = 0)."""
    stop = lambda t, y: y[1]  # noqa: E731
    stop.terminal = True  # type: ignore[attr-defined]
    sol = solve_ivp(lambda t, y: [y[1], -decel], (0.0, 1e4), [0.0, v0], events=stop, rtol=1e-10, atol=1e-10)
    return float(sol.y_events[0][0][0])


def test_the_multirotor_manoeuvre_term_is_its_stopping_distance_at_the_tilt_limit():
    cv = contingency_volume(MR, 0.0)
    s_cm = _stopping_distance_m(MR.v0_mps, G_MPS2 * math.tan(MR.limit_rad))
    assert cv.s_cv_m == pytest.approx(3.0 + 3.0 + 1.0 + MR.v0_mps * MR.reaction_time_s + s_cm, rel=1e-6)
    climb = _stopping_distance_m(MR.v0_mps, G_MPS2)  # the speed traded for height: v0²/(2g)
    assert cv.h_cv_m == pytest.approx(1.0 + 0.707 * MR.v0_mps * MR.reaction_time_s + climb, rel=1e-6)


def test_the_fixed_wing_manoeuvre_term_is_half_its_turn_radius():
    cv = contingency_volume(FW, 120.0)
    half_turn = 0.5 * turn_radius_m(FW.v0_mps, FW.limit_rad)
    assert cv.s_cv_m - (7.0 + FW.v0_mps * FW.reaction_time_s) == pytest.approx(half_turn, rel=1e-6)
    assert cv.s_grb_m == pytest.approx(120.0 + cv.h_cv_m)  # the 1:1 rule: as wide as the volume's top is high


@given(
    v=st.floats(1.0, 80.0), dv=st.floats(0.1, 20.0), t=st.floats(0.0, 5.0), dt=st.floats(0.01, 2.0),
    phi=st.floats(math.radians(5), math.radians(60)), dphi=st.floats(0.01, 0.3),
)  # fmt: skip
def test_the_volume_grows_with_speed_and_reaction_time_and_shrinks_with_the_limit(v, dv, t, dt, phi, dphi):
    base = contingency_volume(ContingencyInputs(PlatformKind.MULTIROTOR, v, t, phi), 50.0)
    for other in (
        ContingencyInputs(PlatformKind.MULTIROTOR, v + dv, t, phi),
        ContingencyInputs(PlatformKind.MULTIROTOR, v, t + dt, phi),
    ):
        bigger = contingency_volume(other, 50.0)
        assert bigger.s_cv_m > base.s_cv_m and bigger.h_cv_m > base.h_cv_m
    steeper = contingency_volume(ContingencyInputs(PlatformKind.MULTIROTOR, v, t, phi + dphi), 50.0)
    assert steeper.s_cv_m < base.s_cv_m and steeper.h_cv_m == pytest.approx(base.h_cv_m)


def _row(lat_m: float, ver_m: float = -10.0, **extra) -> dict:
    row = dict(platform="F450RD", ceiling_m=60.0, max_lateral_excursion_m=lat_m, max_vertical_excursion_m=ver_m,
               max_excursion_m=max(lat_m, ver_m), sim_time_s=1800.0, condition="nominal")  # fmt: skip
    return {**row, **extra}


def test_each_volume_is_left_only_beyond_its_edge():
    cv = contingency_volume(MR, 60.0)
    assert flight_exits(_row(-2.0), cv)[:3] == (False, False, False)
    assert flight_exits(_row(0.5), cv)[:3] == (True, False, False)
    assert flight_exits(_row(cv.s_cv_m + 0.1), cv)[:3] == (True, True, False)
    assert flight_exits(_row(cv.s_cv_m + cv.s_grb_m + 0.1), cv)[:3] == (True, True, True)
    assert flight_exits(_row(-5.0, ver_m=cv.h_cv_m + 0.1), cv)[:3] == (True, True, True)
    assert flight_exits(_row(-5.0, breached_keep_out="true"), cv).fence


def test_a_fall_through_a_floor_is_counted_apart_from_the_volumes():
    """Below a floor outside its gaps (the vertical excursion is the floor's, the ceiling's is negative) is a fence
    exit and a floor count, not a volume's exit; above the ceiling by more than ``H_CV`` is; a row scored before the
    ceiling's own field falls back to the vertical excursion (the conservative reading)."""
    cv = contingency_volume(MR, 60.0)
    below = flight_exits(_row(-5.0, ver_m=cv.h_cv_m + 10.0, max_ceiling_excursion_m=-40.0, landed_outside_gap="true"), cv)
    assert (below.fence, below.contingency, below.buffer, below.floor) == (True, False, False, True)
    above = flight_exits(_row(-5.0, ver_m=cv.h_cv_m + 1.0, max_ceiling_excursion_m=cv.h_cv_m + 1.0), cv)
    assert (above.fence, above.contingency, above.floor) == (True, True, False)
    old = flight_exits(_row(-5.0, ver_m=cv.h_cv_m + 1.0), cv)
    assert old.contingency and not old.floor


def test_a_touchdown_outside_the_fence_is_the_fences_exit_not_the_floors():
    """A flight that came down outside the keep-in (a fall at its edge) landed where landing is not allowed, as one
    below a floor outside its gaps does, but it left laterally: a fence exit, and no floor count."""
    cv = contingency_volume(MR, 60.0)
    out = flight_exits(_row(2.9, landed_outside_gap="true"), cv)
    assert (out.fence, out.contingency, out.floor) == (True, False, False)
    inside = flight_exits(_row(-3.0, landed_outside_gap="true"), cv)
    assert (inside.fence, inside.floor) == (True, True)


def test_every_class_is_reported_side_by_side_with_its_hours():
    inputs = {"F450RD": MR}
    cv = contingency_volume(MR, 60.0)
    rows = [_row(-3.0) for _ in range(4)] + [_row(cv.s_cv_m + 1.0, condition="GPS fault")]
    rows += [_row(1.0, faults="fc_ignores_override"), _row(-1.0, error="boom"), _row(-1.0, platform="unknown")]
    rates = {c.name: c for c in class_rates(rows, inputs)}
    assert list(rates) == ["nominal", "GPS fault", "fault: fc_ignores_override"]  # nominal first; errors left out
    assert (
        rates["nominal"].flights == 4 and rates["nominal"].hours == pytest.approx(2.0) and rates["nominal"].exits == (0, 0, 0, 0)
    )
    assert rates["GPS fault"].exits == (1, 1, 0, 0) and rates["fault: fc_ignores_override"].exits == (1, 0, 0, 0)
    text = "\n".join(containment_lines(rows, inputs))
    assert "| F450RD |" in text and "| nominal | 4 | 2.0 |" in text and "| GPS fault | 1 | 0.5 |" in text
