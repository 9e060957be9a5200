"""Geofence unit configuration: the ``geofence:`` block of a scenario, validated into a frozen dataclass.

Example (every key but ``fence`` optional)::

    geofence:
      fence: {keep_in: [[lat, lon], ...], ceiling_m: 60, floor_m: 5, floor_gaps: [...]}
      # or a fence file (any format analysis.formats.fence_files reads: GeoJSON, QGC .plan, WPL 110,
      # MAVProxy), its path relative to the scenario file; the other keys override or add to the file's:
      # fence: {file: airspace/city_park.geojson, ceiling_m: 60, floor_m: 5, floor_gaps: [...],
      #         recovery_point: [lat, lon], altitude_reference: agl,
      #         inclusion_polygon: 0}   # required when the file has several inclusion areas
      trigger: predictive          # predictive (shifted boundary) | reactive (act on the fence line)
      min_override_s: 2.0          # hold an override at least this long
      handback_margin_m: 5.0       # hand back once this far inside the activation boundary and moving inward
      recovery_radius_m: 10.0      # ... or once within this distance of the recovery point
      uncertainty_k_sigma: 3.0     # margin = k * estimator position sigma
      extra_margin_m: 0.0          # a fixed extra margin on every boundary
      multirotor_law: velocity     # velocity (default: brake, then fly back) | seed_pd (published PD + ramp)
      seed_pd: {kp_xy: 0.2, kd_xy: 0.4, kp_z: 0.4, kp_yaw: 0.5, ...}   # stick units per m, per m/s, per rad
      ramp_s: 3.0                  # seed_pd set-point ramp time
      recovery_speed_mps: 5.0      # multirotor return speed (default: half cruise)
      max_reactivations: 3         # still outside after this many override periods -> land in a gap
      wind_prior: {speed_mps: 8, from_deg: 240, turbulence_sigma_mps: 1.0, gust_mps: 3}
                                   # forecast: mean wind until the estimate converges; turbulence
                                   # sigma and gust amplitude (m/s) for the activation margin
      turbulence_k_sigma: 1.5      # wind allowance = k * turbulence sigma + gust
      turbulence_source: estimate  # estimate (max of forecast and the unit's estimate, default) | forecast
      vertical_handback_m: 2.0     # hand back only this far inside the vertical activation boundary
      state_source: estimate       # estimate (own sensors + Kalman filter, default) | truth (e.g. indoor motion capture)
      compliance_grace_s: 0.5      # the sticks sent not followed this long (the climb: twice) -> plan termination
      termination_terminal_speed_mps: 8.0   # the slowest terminal fall speed at termination (the footprint's drag end)

All messages are one line: ``<where>.<field>: <problem>``.

A ``fence: {file: ...}`` block is read by the scenario loader's reader
(:mod:`scenarios.definition.fence_file`, passed as ``fence_file_reader``): the unit reads no file.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from geofence.geometry.fence import MAX_CEILING_M, Fence, parse_fence
from geofence.jit import jitable
from geofence.recovery.guidance import SeedPDGains
from geofence.validation import (
    ConfigError,
    enum_value,
    field_default,
    integer,
    number,
    reject_unknown_keys,
    require_mapping,
)


class Trigger(StrEnum):
    """When the unit overrides the pilot."""

    PREDICTIVE = "predictive"
    """On the activation boundary: the fence shifted inward by the room the aircraft needs to turn or stop."""
    REACTIVE = "reactive"
    """On the fence line itself (the seed work's baseline)."""


class MultirotorLaw(StrEnum):
    """The multirotor override's control law."""

    VELOCITY = "velocity"
    """Brake, then fly back along the recovery route with a velocity loop (the default)."""
    SEED_PD = "seed_pd"
    """The seed work's decoupled PD law on position error with a linear set-point ramp (:class:`SeedPDGains`)."""


class StateSource(StrEnum):
    """Where the unit's state estimate comes from."""

    ESTIMATE = "estimate"
    """The unit's own sensors and Kalman filter (the default)."""
    TRUTH = "truth"
    """A perfect position source (indoor motion capture)."""


TRIGGERS = tuple(t.value for t in Trigger)
MULTIROTOR_LAWS = tuple(m.value for m in MultirotorLaw)


class TurbulenceSource(StrEnum):
    """Which turbulence intensity the activation margin allows for."""

    FORECAST = "forecast"
    """The forecast's ``wind_prior.turbulence_sigma_mps`` only."""
    ESTIMATE = "estimate"
    """The larger of the forecast and the unit's own estimate (the spread of its wind samples, noise included),
    the default: on the rotor-drag multirotors in 8 m/s wind with moderate turbulence it cut breaches from
    16 to 5 of 50 (Micro250)."""


@jitable
def wind_allowance_mps(k_sigma: float, sigma_mps: float, gust_mps: float) -> float:
    """The turbulence and gust allowance added to the wind in every margin, ``k * sigma + gust_mps`` (m/s): the one
    home of that formula (compiled too, for the unit's monitoring step: :mod:`geofence.unit.passes`)."""
    return k_sigma * sigma_mps + gust_mps


@jitable
def allowance_in_use_mps(
    estimated: bool, sigma_estimate_mps: float, sigma_forecast_mps: float, k_sigma: float, gust_mps: float,
    forecast_allowance_mps: float,
) -> float:  # fmt: skip
    """The wind allowance a unit adds in its margins now (m/s): the forecast's (``forecast_allowance_mps``, its
    :func:`wind_allowance_mps`), or with ``turbulence_source: estimate`` (``estimated``) the one of the unit's own
    turbulence estimate where that is the larger sigma."""
    if estimated and sigma_estimate_mps > sigma_forecast_mps:
        return wind_allowance_mps(k_sigma, sigma_estimate_mps, gust_mps)
    return forecast_allowance_mps


class GeofenceConfigError(ConfigError):
    """A bad ``geofence:`` block; the message is one line naming the field."""


@dataclass(frozen=True)
class GeofenceConfig:
    fence: Fence
    trigger: Trigger = Trigger.PREDICTIVE
    min_override_s: float = 2.0
    handback_margin_m: float = 5.0
    recovery_radius_m: float = 10.0
    uncertainty_k_sigma: float = 3.0
    """Every margin keeps ``k`` estimator sigmas: 3 is the two-sided 99.7 % bound. With 2 (95 %) a
    baro drift of 2.1 sigma let a climbing Micro250 through the ceiling by 0.34 m in a 160-case
    campaign (1 of 160; 0 with 3, at the same number of activations and 1.5 m less median room)."""
    extra_margin_m: float = 0.0
    multirotor_law: MultirotorLaw = MultirotorLaw.VELOCITY
    seed_pd: SeedPDGains = field(default_factory=SeedPDGains)
    ramp_s: float = 3.0
    recovery_speed_mps: float | None = None
    max_reactivations: int = 3
    wind_prior_enu: tuple[float, float] = (0.0, 0.0)
    """Forecast wind (east, north m/s, toward) used until the estimate converges."""
    state_source: StateSource = StateSource.ESTIMATE
    turbulence_sigma_mps: float = 0.0
    """Forecast turbulence intensity (1-sigma of the horizontal gust velocity, m/s)."""
    gust_mps: float = 0.0
    """Forecast discrete-gust amplitude (m/s) added to the wind the margin allows for."""
    turbulence_k_sigma: float = 1.5
    """The wind allowance is ``k * sigma + gust_mps`` (sigma per :attr:`turbulence_source`)."""
    turbulence_source: TurbulenceSource = TurbulenceSource.ESTIMATE
    vertical_handback_m: float = 2.0
    """Vertical hysteresis: hand back only with the vertical activation margin at least this large."""
    compliance_grace_s: float = 0.5
    """The compliance monitor (:mod:`geofence.unit.compliance`) flags a vehicle that lags behind the unit's
    sent attitude this long on end (s; a climb above its bound twice this long), from the envelope's reaction time
    into each stretch of one mode: over twice the longest lag a following vehicle showed on the golden flights, the
    shipped scenarios and the CI campaign slice (0.2 s, an F450RD reversing a full pitch; a fixed-wing 0 s; the
    climb 0.125 s), and short, since each 0.1 s at 10-25 m/s carries the fall 1-2.5 m farther."""
    termination_terminal_speed_mps: float = 8.0
    """The slowest terminal speed of the terminated vehicle (m/s), the footprint's drag end
    (:mod:`geofence.physics.termination`): a spinning fixed-wing measured 8.4 m/s mean descent (Tern, 70 m in
    8.3 s), a multirotor with its motors off falls faster (F450RD, 70 m in 4.2 s)."""
    fence_file: str | None = None
    """The fence file the fence was read from (resolved path), or None for an inline fence."""
    fence_warnings: tuple[str, ...] = ()
    """The importer's warnings about the fence file (one line each)."""

    def __post_init__(self) -> None:
        # the option fields hold enum members even when built from strings, so the unit can compare with `is`
        for name, enum_type in (
            ("trigger", Trigger),
            ("multirotor_law", MultirotorLaw),
            ("state_source", StateSource),
            ("turbulence_source", TurbulenceSource),
        ):
            object.__setattr__(self, name, enum_type(getattr(self, name)))

    def wind_allowance_mps(self, sigma_mps: float) -> float:
        """The turbulence and gust allowance added to the wind in every margin (m/s; :func:`wind_allowance_mps`
        with this configuration's ``turbulence_k_sigma`` and ``gust_mps``): the unit passes the sigma it holds, the
        pre-flight check the forecast's."""
        return wind_allowance_mps(self.turbulence_k_sigma, sigma_mps, self.gust_mps)


_KEYS = {
    "fence",
    "trigger",
    "min_override_s",
    "handback_margin_m",
    "recovery_radius_m",
    "uncertainty_k_sigma",
    "extra_margin_m",
    "multirotor_law",
    "seed_pd",
    "ramp_s",
    "recovery_speed_mps",
    "max_reactivations",
    "wind_prior",
    "state_source",
    "turbulence_k_sigma",
    "vertical_handback_m",
    "turbulence_source",
    "compliance_grace_s",
    "termination_terminal_speed_mps",
}


def _default(name: str) -> Any:
    """The default of a :class:`GeofenceConfig` field (each default is written once, in the dataclass)."""
    return field_default(GeofenceConfig, name)


FenceFileReader = Callable[[Mapping, str], tuple[Fence, str, list[str]]]
"""Reads a ``fence: {file: ...}`` block: ``(block, where) -> (fence, the file's path, the importer's
warnings)``. The unit reads no file: the scenario loader passes one
(:func:`scenarios.definition.fence_file.fence_from_file`)."""


def parse_geofence(raw: Any, where: str = "geofence", fence_file_reader: FenceFileReader | None = None) -> GeofenceConfig:
    """Validate a ``geofence:`` mapping into a :class:`GeofenceConfig`.

    ``fence_file_reader``: what reads a ``fence: {file: ...}`` block (without one such a block is refused).
    Every value is read with :mod:`geofence.validation`; a missing key takes the dataclass field's default.
    """
    if not isinstance(raw, Mapping):
        raise GeofenceConfigError(f"{where}: expected a mapping with at least a fence: block")
    try:
        return _parse_geofence(raw, where, fence_file_reader)
    except GeofenceConfigError:
        raise
    except ConfigError as exc:  # one domain type for the geofence block (FenceError, kit readers)
        raise GeofenceConfigError(str(exc)) from None


def _parse_geofence(raw: Mapping, where: str, fence_file_reader: FenceFileReader | None) -> GeofenceConfig:
    reject_unknown_keys(raw, _KEYS, where)
    if "fence" not in raw:
        raise GeofenceConfigError(f"{where}.fence: missing (required)")
    fence_file: str | None = None
    fence_warnings: list[str] | tuple[str, ...] = ()
    if isinstance(raw["fence"], Mapping) and "file" in raw["fence"]:
        if fence_file_reader is None:
            raise GeofenceConfigError(f"{where}.fence.file: fence files are read by the scenario loader, not here")
        fence, fence_file, fence_warnings = fence_file_reader(raw["fence"], f"{where}.fence")
    else:
        fence = parse_fence(raw["fence"], f"{where}.fence")
        if fence.ceiling_m > MAX_CEILING_M:
            raise GeofenceConfigError(
                f"{where}.fence.ceiling_m: {fence.ceiling_m:g} m is above {MAX_CEILING_M:g} m, the highest any small UAS flies"
            )

    def num(key: str, lo: float = 0.0, hi: float = math.inf) -> float:
        return number(raw.get(key, _default(key)), f"{where}.{key}", minimum=lo, maximum=hi)

    gains = _default("seed_pd")
    if raw.get("seed_pd") is not None:
        g = require_mapping(raw["seed_pd"], f"{where}.seed_pd")
        reject_unknown_keys(g, SeedPDGains.__dataclass_fields__, f"{where}.seed_pd")
        gains = SeedPDGains(**{k: number(v, f"{where}.seed_pd.{k}", minimum=0.0) for k, v in g.items()})

    prior = _default("wind_prior_enu")
    turb, gust = _default("turbulence_sigma_mps"), _default("gust_mps")
    if raw.get("wind_prior") is not None:
        w = require_mapping(raw["wind_prior"], f"{where}.wind_prior")
        reject_unknown_keys(w, _WIND_PRIOR_KEYS, f"{where}.wind_prior")
        speed = number(w.get("speed_mps", 0.0), f"{where}.wind_prior.speed_mps", minimum=0.0)
        from_deg = number(w.get("from_deg", 0.0), f"{where}.wind_prior.from_deg")
        turb = number(w.get("turbulence_sigma_mps", turb), f"{where}.wind_prior.turbulence_sigma_mps", minimum=0.0)
        gust = number(w.get("gust_mps", gust), f"{where}.wind_prior.gust_mps", minimum=0.0)
        to = math.radians(from_deg + 180.0)
        prior = (speed * math.sin(to), speed * math.cos(to))

    speed_key = raw.get("recovery_speed_mps")
    return GeofenceConfig(
        fence=fence,
        trigger=enum_value(raw.get("trigger", _default("trigger")), f"{where}.trigger", Trigger),
        min_override_s=num("min_override_s", 0.0, 60.0),
        handback_margin_m=num("handback_margin_m", 0.0, 1000.0),
        recovery_radius_m=num("recovery_radius_m", 0.1, 10000.0),
        uncertainty_k_sigma=num("uncertainty_k_sigma", 0.0, 10.0),
        extra_margin_m=num("extra_margin_m", 0.0, 1000.0),
        multirotor_law=enum_value(
            raw.get("multirotor_law", _default("multirotor_law")), f"{where}.multirotor_law", MultirotorLaw
        ),
        seed_pd=gains,
        ramp_s=num("ramp_s", 0.0, 60.0),
        recovery_speed_mps=None if speed_key is None else num("recovery_speed_mps", 0.1, 100.0),
        max_reactivations=integer(
            raw.get("max_reactivations", _default("max_reactivations")), f"{where}.max_reactivations", minimum=0
        ),
        wind_prior_enu=prior,
        state_source=enum_value(raw.get("state_source", _default("state_source")), f"{where}.state_source", StateSource),
        turbulence_sigma_mps=turb,
        gust_mps=gust,
        turbulence_k_sigma=num("turbulence_k_sigma", 0.0, 10.0),
        vertical_handback_m=num("vertical_handback_m", 0.0, 100.0),
        turbulence_source=enum_value(
            raw.get("turbulence_source", _default("turbulence_source")), f"{where}.turbulence_source", TurbulenceSource
        ),
        compliance_grace_s=num("compliance_grace_s", 0.0, 10.0),
        termination_terminal_speed_mps=num("termination_terminal_speed_mps", 1.0, 100.0),
        fence_file=fence_file,
        fence_warnings=tuple(fence_warnings),
    )


_WIND_PRIOR_KEYS = ("speed_mps", "from_deg", "turbulence_sigma_mps", "gust_mps")
