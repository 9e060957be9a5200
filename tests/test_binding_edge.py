"""Property: the binding search finds the exhaustive minimum.

:func:`geofence.margins.lateral.lateral_binding` scores a fixed-wing's elements exactly only where a cheap lower
bound of their activation cannot rule them out (its pruning), and an index cell's walk stops early. Here every
element of the fence is scored, one by one, from its own room formula (:func:`~geofence.physics.rooms.fixed_wing_edge_room_m`
for each of the two turns, the better turn kept; :func:`~geofence.margins.lateral.multirotor_edge_room_m`), and
the smallest ``d - room`` must be the search's activation (within 1e-9 m), its element one that attains it: on a
large wavy fence (many edges within a fixed-wing's reach) scanned and indexed, with a keep-out square, duplicated
keep-outs (exact ties) and circles, for both platform kinds in wind, from the free space and from breached points.
"""

import math
import random

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from support import FRAME, FW, MC, latlon, random_margin_call

from geofence.geometry.elements import edge_scored
from geofence.geometry.fence import Fence, KeepOutCircle
from geofence.margins.kernel import envelope_terms, state_terms
from geofence.margins.lateral import (
    fixed_wing_edge_terms,
    lateral_binding,
    multirotor_edge_room_m,
    wind_toward_mps,
)
from geofence.physics.rooms import fixed_wing_edge_room_m

TOL_M = 1e-9


def close(a: float, b: float) -> bool:
    """Equal within :data:`TOL_M` (relative beyond a metre; infinities equal to themselves)."""
    return a == b or abs(a - b) <= TOL_M * (1.0 + abs(b))


def _wavy_fence(n_vertices: int, index: bool):
    """A wavy keep-in about 1.2 km across, finely sampled, with a keep-out square twice over and two circles."""
    keep_in = []
    for i in range(n_vertices):
        a = 2.0 * math.pi * i / n_vertices
        r = 600.0 * (1.0 + 0.15 * math.sin(5.0 * a) + 0.04 * math.sin(41.0 * a))
        keep_in.append(latlon(r * math.cos(a), r * math.sin(a)))
    square = tuple(latlon(200.0 + x, y) for x, y in ((-15, -15), (15, -15), (15, 15), (-15, 15)))
    circles = (KeepOutCircle(*latlon(-150.0, 80.0), 25.0), KeepOutCircle(*latlon(-150.0, 80.0), 25.0))
    fence = Fence(keep_in=tuple(keep_in), ceiling_m=120.0, keep_out_polygons=(square, square), keep_out_circles=circles)
    return fence.to_local(FRAME, index=index)


WAVY = {index: _wavy_fence(1500, index) for index in (False, True)}


def exhaustive_binding(E: np.ndarray, e: float, n: float, n_line: int, free: bool, T) -> tuple[float, list[float]]:
    """``(smallest activation, every element's activation)``: each element scored by its room formula (those that
    cannot bind, ``d - bound >= d_min``, at ``inf``)."""
    scored = []
    for a, b, c, dd, il2, nx, ny in E:
        if il2 >= 0.0:
            d, db, ux, uy = edge_scored(e - a, n - b, c, dd, il2, nx, ny, len(scored) < n_line, free)
        else:
            dist = math.hypot(a - e, b - n)
            ux, uy = ((a - e) / dist, (b - n) / dist) if dist > 0.0 else (1.0, 0.0)
            d = db = dist - c
        scored.append((d, db, ux, uy))
    d_min = min(s[0] for s in scored)
    turns = T.turns
    acts = []
    for _d, db, ux, uy in scored:
        if db - T.bound >= d_min:
            acts.append(math.inf)
            continue
        w_n = wind_toward_mps(T.state, ux, uy)
        if T.env.fixed_wing == 0.0:
            v_n = T.state.ve * ux + T.state.vn * uy
            acts.append(db - multirotor_edge_room_m(T.env, T.state, T.brake, v_n, w_n))
            continue
        base, gap, psi0 = fixed_wing_edge_terms(T.state, T.turn, ux, uy, w_n)
        t = T.turn
        per_turn = [
            db - fixed_wing_edge_room_m(base, gap, t.radius, t.inv_omega, t.v_turn, w_n, psi0, s, delta)
            for s, delta in ((turns.s1, turns.delta1), (turns.s2, turns.delta2))
        ]
        acts.append(per_turn)
    if T.env.fixed_wing == 0.0:
        return min(acts), acts
    best = max(min(a[k] if isinstance(a, list) else a for a in acts) for k in (0, 1))
    return best, acts


@settings(max_examples=120, deadline=None)
@given(
    seed=st.integers(0, 10**6),
    a=st.floats(0.0, 2.0 * math.pi),
    inset=st.floats(-5.0, 300.0),
    index=st.booleans(),
    fixed_wing=st.booleans(),
    near_keep_out=st.booleans(),
)
def test_the_binding_search_finds_the_exhaustive_minimum(seed, a, inset, index, fixed_wing, near_keep_out):
    local = WAVY[index]
    rng = random.Random(seed)
    if near_keep_out:  # next to, on or inside the duplicated square or the duplicated circles
        e, n = rng.choice([(200.0, 0.0), (-150.0, 80.0)])
        e, n = e + rng.uniform(-45.0, 45.0), n + rng.uniform(-45.0, 45.0)
    else:
        r = 600.0 * (1.0 + 0.15 * math.sin(5.0 * a) + 0.04 * math.sin(41.0 * a)) - inset
        e, n = r * math.cos(a), r * math.sin(a)
    env = FW if fixed_wing else MC
    args, kw = random_margin_call(rng, e, n, env, bank_rad=0.7, wrap_heading=True, rollout=False)
    _, _, _, ve, vn, vu, _, we, wn = args
    re, rn = local.recovery_en
    T = state_terms(
        envelope_terms(env), ve, vn, vu, we, wn, kw["h_uncertainty_m"], kw["latency_s"], kw["bank_rad"],
        kw["wind_extra_mps"], re - e, rn - n, 9.80665,
    )  # fmt: skip
    E, _meta, all_ids, zeros = local.element_table()
    free = local.lateral_margin_m(e, n) >= 0.0
    grid = local.grid()
    if grid is not None:
        ids, lbs, delta = grid.candidates(e, n, T.bound)
        walk = True
    else:
        ids, lbs, delta, walk = all_ids, zeros, 0.0, False
    n_line = local.line_scored_edges()
    got = lateral_binding(
        E, ids, lbs, walk, e, n, T.bound, delta, n_line, free, fixed_wing, T.env, T.state, T.turn, T.brake, T.turns
    )
    want, acts = exhaustive_binding(E, e, n, n_line, free, T)
    act, s, i = got[0], got[1], got[2]
    assert close(act, want), (e, n, act, want)
    k = 0 if not fixed_wing or s == T.turns.s1 else 1
    mine = acts[i][k] if isinstance(acts[i], list) else acts[i]
    assert close(mine, want), (e, n, i, mine, want)
