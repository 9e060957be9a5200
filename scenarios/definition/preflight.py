"""The pre-flight mission check of a scenario: its mission as the unit will see it, through :mod:`geofence.unit.preflight`.

This module owns the translation from a scenario (mission items in WGS-84, the
platform, the geofence configuration, the sensors) to what the check needs:
the planned route in the fence's local frame, the planned speed, the expected
wind (the geofence block's forecast ``wind_prior``, taken as the 10 m wind and raised
to the mission's highest point by a 1/7 power law), how far the true mean may be from it
(:data:`FORECAST_SPEED_ERROR`, :data:`FORECAST_DIRECTION_ERROR_DEG`) and the unit's estimate from that
(:data:`geofence.estimation.wind_estimator.WIND_ESTIMATE_ERROR_MPS`, :data:`TURBULENCE_IN_ESTIMATE_SIGMAS`), the unit's reaction latency, its turbulence and
gust allowance from that forecast, and its nominal uncertainty margins
(``k·σ`` of the GNSS errors the sensors declare). The check itself, and what
it guarantees, lives in :mod:`geofence.unit.preflight`.

Only missions are checked; a scripted or breach-attempt pilot has no plan.
"""

from __future__ import annotations

import math

from geofence.estimation.wind_estimator import WIND_ESTIMATE_ERROR_MPS
from geofence.geometry.fence import AltitudeReference
from geofence.geometry.geodesy import LocalFrame
from geofence.geometry.local_fence import LocalFence
from geofence.physics.dynamics import envelope_at_density
from geofence.unit.config import StateSource
from geofence.unit.preflight import PlannedWaypoint, PreflightFinding, check_route
from scenarios.definition.schema import PilotKind, Scenario
from wind.steady import PowerLawProfile

BUFFER_M = 2.0
"""A mission passes when its activation margin stays above this everywhere (m): tracking errors, estimator noise."""
FORECAST_PROFILE = PowerLawProfile(exponent=1.0 / 7.0, reference_height_m=10.0)
"""A forecast's wind is the wind at 10 m (the WMO surface wind); above it the check assumes the neutral-atmosphere
power law up to the mission's highest point: the wind aloft is stronger than the forecast's (by 42 % at 120 m),
never weaker."""
FORECAST_SPEED_ERROR = 0.2
"""The forecast's speed may be off by this fraction of the true mean wind's speed."""
FORECAST_DIRECTION_ERROR_DEG = 20.0
"""The forecast's direction may be off by this much (deg)."""
TURBULENCE_IN_ESTIMATE_SIGMAS = 1.5
"""How much of the forecast's turbulence sigma the unit's 20 s wind estimate may still hold. A first-order
average over ``tau`` of turbulence with time scale ``T`` keeps ``sqrt(T / (T + tau))`` of its sigma: 0.65 for the
15 s of a Dryden gust at 20 m in 8 m/s, so 1.5 sigma is 2.3 of the estimate's own standard deviations. Measured:
the 122 missions of the largest campaign stayed within 1 m/s + 1.5 sigma of the mean wind at the vehicle, apart
from start-up and landing transients (case history: docs/campaigns.md#the-largest-campaign-seed-20261125)."""


def planned_route(scenario: Scenario, frame: LocalFrame) -> list[PlannedWaypoint]:
    """The mission's positioned items as planned waypoints (ENU m, heights AGL as the mission gives them)."""
    st = scenario.start
    e0, n0 = 0.0, 0.0
    h = st.agl_m
    out = [PlannedWaypoint(e0, n0, h, "start")]
    if scenario.mission is None:
        return out
    for i, item in enumerate(scenario.mission.items):
        if item.lat_deg is not None and item.lon_deg is not None:
            e, n, _ = frame.to_enu(item.lat_deg, item.lon_deg, frame.h0_m)
        else:
            e, n = out[-1].east_m, out[-1].north_m
        h = item.agl_m if item.agl_m is not None else out[-1].height_m
        if item.kind == "land":
            h = out[-1].height_m  # the descent itself is over the land point
        radius = item.radius_m if item.kind == "loiter" else 0.0
        if item.kind == "loiter" and radius <= 0.0:
            radius = 1e-3  # the platform's default orbit (check_route takes max(radius, 1.5 R))
        out.append(PlannedWaypoint(e, n, h, f"{i + 1}:{item.kind}", radius))
    return out


def expected_wind(
    forecast_en: tuple[float, float], top_agl_m: float, turbulence_sigma_mps: float = 0.0
) -> tuple[tuple[float, float], float]:
    """The wind the check flies the route in (E, N m/s) and the radius of winds around it the route must pass for.

    The forecast raised to the route's highest point by :data:`FORECAST_PROFILE` (never below its 10 m value);
    the radius is how far the unit's estimate may be from the true mean: ``WIND_ESTIMATE_ERROR_MPS`` plus
    :data:`TURBULENCE_IN_ESTIMATE_SIGMAS` of the forecast's turbulence sigma. (The forecast's own error, which
    places the true mean, is :data:`FORECAST_SPEED_ERROR` and :data:`FORECAST_DIRECTION_ERROR_DEG`.)
    """
    scale = FORECAST_PROFILE.factor(max(top_agl_m, FORECAST_PROFILE.reference_height_m))
    wind_en = (forecast_en[0] * scale, forecast_en[1] * scale)
    return wind_en, WIND_ESTIMATE_ERROR_MPS + TURBULENCE_IN_ESTIMATE_SIGMAS * max(turbulence_sigma_mps, 0.0)


def latency_bound_s(scenario: Scenario) -> float:
    """The longest the unit's reaction can lag its data (s): one control step plus, unless it is given the true
    state, the age of the newest GNSS fix (its latency plus one fix period), as the unit adds in flight."""
    lag = 1.0 / scenario.control_rate_hz
    if scenario.geofence is not None and scenario.geofence.state_source is not StateSource.TRUTH:
        lag += scenario.sensors.gps_latency_s + 1.0 / scenario.sensors.gps_rate_hz
    return lag


def preflight_findings(scenario: Scenario, fence: LocalFence | None = None) -> list[PreflightFinding] | None:
    """The findings of the pre-flight check, or None when the scenario has no mission or no geofence. ``fence``: the
    scenario's fence in its frame where the caller has it already (its tables are built once)."""
    cfg = scenario.geofence
    if cfg is None or scenario.mission is None or scenario.pilot.kind is not PilotKind.MISSION:
        return None
    st = scenario.start
    frame = scenario.frame
    fence = cfg.fence.to_local(frame) if fence is None else fence
    env = scenario.profile.envelope
    env = envelope_at_density(env, st.density_ratio)
    speed = scenario.mission.speed_mps or env.cruise_speed_mps
    k = cfg.uncertainty_k_sigma
    sensors = scenario.sensors
    route = planned_route(scenario, frame)
    wind_en, wind_uncertainty_mps = expected_wind(cfg.wind_prior_enu, max(w.height_m for w in route), cfg.turbulence_sigma_mps)
    if fence.altitude_reference is AltitudeReference.AMSL:
        route = [PlannedWaypoint(w.east_m, w.north_m, w.height_m + st.ground_alt_m, w.label, w.loiter_radius_m) for w in route]
    return check_route(
        fence,
        env,
        route,
        speed,
        wind_en=wind_en,
        wind_uncertainty_mps=wind_uncertainty_mps,
        forecast_speed_error=FORECAST_SPEED_ERROR,
        forecast_direction_error_rad=math.radians(FORECAST_DIRECTION_ERROR_DEG),
        wind_extra_mps=cfg.wind_allowance_mps(cfg.turbulence_sigma_mps),
        turbulence_sigma_mps=cfg.turbulence_sigma_mps,
        h_uncertainty_m=k * sensors.gps_h_sigma_m + cfg.extra_margin_m,
        v_uncertainty_m=k * sensors.gps_v_sigma_m + cfg.extra_margin_m,
        latency_s=latency_bound_s(scenario),
        buffer_m=BUFFER_M,
    )


def describe_findings(findings: list[PreflightFinding] | None) -> str:
    """One line per finding (or a one-line verdict)."""
    if findings is None:
        return "pre-flight check: nothing to check (no mission with a geofence)"
    if not findings:
        return "pre-flight check: passed (the activation margin stays above %.0f m along the whole mission)" % BUFFER_M
    lines = [f"pre-flight check: {len(findings)} place(s) where the geofence would override the mission:"]
    lines += [f"  {f.describe()}" for f in findings]
    return "\n".join(lines)


def findings_summary(findings: list[PreflightFinding] | None) -> dict | None:
    """The check's result for summary.json."""
    if findings is None:
        return None
    return {
        "passed": not findings,
        "findings": [
            {
                "part": f.part.value,
                "index": f.index,
                "label": f.label,
                "east_m": round(f.east_m, 1),
                "north_m": round(f.north_m, 1),
                "height_m": round(f.height_m, 1),
                "activation_margin_m": round(f.activation_margin_m, 2) if math.isfinite(f.activation_margin_m) else None,
                "reason": f.reason,
            }
            for f in findings
        ],
    }
