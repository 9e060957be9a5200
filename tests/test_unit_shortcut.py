"""Property: the unit's skip shortcut never hides a needed activation.

A monitoring unit skips the per-edge computation when it decides that no edge, ceiling or floor is within
reach (its activation margin is then reported as infinite). The guarantee: where it skips, the full activation
margin (the public :func:`geofence.margins.boundary_shift.activation_margins`) is positive -- for every state, including
speeds above the envelope's max speed, strong wind with a turbulence and gust allowance, banked fixed-wings,
floors with gaps and keep-outs, fences with and without their index (the case found once in 80,000 random states
before: a c172x at 1.27x max speed).
"""

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from geofence.geometry.geodesy import LocalFrame
from geofence.interface import Envelope, PlatformKind, StickCommand, VehicleState
from geofence.margins.boundary_shift import activation_margins
from geofence.unit.config import parse_geofence
from geofence.unit.geofence_unit import GeofenceUnit, Mode
from geofence.unit.passes import latency_s

FRAME = LocalFrame(47.0, 8.0, 400.0)
MC = Envelope(
    PlatformKind.MULTIROTOR,
    6.0,
    11.0,
    0.0,
    math.radians(30),
    math.radians(30),
    math.radians(90),
    3.0,
    2.0,
    5.6,
    4.5,
    0.25,
    drag_linear_per_s=0.45,
    drag_quadratic_per_m=0.01,
)
MC_OLD = Envelope(
    PlatformKind.MULTIROTOR, 15.0, 28.5, 0.0, math.radians(30), math.radians(30), math.radians(90), 3.0, 2.0, 5.6, 4.5, 0.25
)
FW = Envelope(
    PlatformKind.FIXED_WING, 16.0, 24.0, 12.0, math.radians(40), math.radians(25), math.radians(28), 5.0, 3.0, 0.6, 5.0, 1.1
)


def _ll(e, n):
    return list(FRAME.to_geodetic(e, n, 0.0)[:2])


def _unit(env, half, notch, floor, circle, turb, gust, index=None):
    keep_in = [(-half, -half), (half, -half), (half, half), (0.0, half - notch), (-half, half)]
    fence = {"keep_in": [_ll(*p) for p in keep_in], "ceiling_m": 120.0}
    if floor:
        fence["floor_m"] = 20.0
        g = 0.2 * half
        fence["floor_gaps"] = [
            [_ll(-g, -g - 0.5 * half), _ll(g, -g - 0.5 * half), _ll(g, g - 0.5 * half), _ll(-g, g - 0.5 * half)]
        ]
    if circle:
        fence["keep_out_circles"] = [{"center": _ll(0.5 * half, -0.5 * half), "radius_m": 0.1 * half}]
    cfg = parse_geofence({"fence": fence, "wind_prior": {"speed_mps": 0.0, "turbulence_sigma_mps": turb, "gust_mps": gust}})
    return GeofenceUnit(cfg, cfg.fence.to_local(FRAME, index=index), env)


PILOT = StickCommand(0.1, 0.2, 0.0, 0.3)

# fences are costly to build (validation, pole of inaccessibility): a fixed family, states vary
PARAMS = [
    (env, half, notch * half, floor, circle, turb, gust, index)
    for index in (False, True)
    for env in (MC, MC_OLD, FW)
    for half, notch, floor, circle, turb, gust in (
        (150.0, 0.0, False, False, 0.0, 0.0),
        (300.0, 0.6, True, True, 1.0, 3.0),
        (800.0, 0.3, True, False, 2.5, 0.0),
        (2500.0, 0.7, False, True, 0.5, 5.0),
    )
]


UNITS = {k: _unit(*p) for k, p in enumerate(PARAMS)}


def _monitoring(k: int) -> GeofenceUnit:
    """The unit of parameters ``k``, monitoring (a new one after an activation)."""
    if UNITS[k].mode is not Mode.MONITOR:
        UNITS[k] = _unit(*PARAMS[k])
    return UNITS[k]


@settings(max_examples=1000, deadline=None)
@given(
    k=st.sampled_from(range(len(PARAMS))),
    fe=st.floats(-1.0, 1.0),
    fn=st.floats(-1.0, 1.0),
    h=st.floats(0.0, 130.0),
    speed_factor=st.floats(0.0, 1.6),
    course=st.floats(-math.pi, math.pi),
    vu=st.floats(-6.0, 6.0),
    wind=st.floats(0.0, 12.0),
    wind_dir=st.floats(-math.pi, math.pi),
    sigma_h=st.floats(0.0, 5.0),
    sigma_v=st.floats(0.0, 5.0),
    bank=st.floats(-0.7, 0.7),
)
def test_far_implies_a_positive_activation_margin(k, fe, fn, h, speed_factor, course, vu, wind, wind_dir, sigma_h, sigma_v, bank):
    u = _monitoring(k)
    env = u.env
    half = u.fence.keep_in.bbox[2]
    we, wn = wind * math.cos(wind_dir), wind * math.sin(wind_dir)
    v = speed_factor * env.max_speed_mps
    s = VehicleState(
        east_m=fe * half,
        north_m=fn * half,
        agl_m=h,
        alt_m=400.0 + h,
        v_east_mps=v * math.cos(course),
        v_north_mps=v * math.sin(course),
        v_up_mps=vu,
        roll_rad=bank,
    )
    dt = 0.025
    u.update(0.0, s, PILOT, dt, wind_en=(we, wn), sigma_h_m=sigma_h, sigma_v_m=sigma_v)
    if u.activation_margin_m == math.inf:  # the shortcut held
        cfg = u.config
        r = activation_margins(
            u.fence, s.east_m, s.north_m, h, s.v_east_mps, s.v_north_mps, vu, u.env, we, wn,
            h_uncertainty_m=cfg.uncertainty_k_sigma * sigma_h + cfg.extra_margin_m,
            v_uncertainty_m=cfg.uncertainty_k_sigma * sigma_v + cfg.extra_margin_m, latency_s=latency_s(dt, 0.0),
            bank_rad=bank, wind_extra_mps=u.wind_allowance_mps,
        )  # fmt: skip
        assert r.activation_margin_m > 0.0, r
