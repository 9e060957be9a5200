"""A scenario's ``faults:``: single failures injected into the simulated flight, as typed, validated data.

Each item of the list names a :class:`FaultKind`, when it starts (``at_s: <time>``, or ``at_first_activation:
true`` with an optional ``delay_s``: that long after the geofence unit first overrides the pilot), an optional
``duration_s`` (else it lasts to the end) and its kind's parameters (units in their names)::

    faults:
      - {kind: gnss_walkoff, at_s: 20, drift_mps: 0.5, direction_deg: 90}
      - {kind: fc_ignores_override, at_first_activation: true, delay_s: 0.5}

The sensor faults (GNSS, barometer, pitot, compass) become rows of the unit's sensor fault table
(:func:`sensor_fault_rows`, read by :func:`aircraft.sensors.sensors_step`); the flight-controller faults and the
loss of propulsion are applied by the runner (:mod:`scenarios.flight.runner`). The unit is never told which
fault occurred. Bad input is one line, ``<file>: faults[i].<field>: <problem>`` (:class:`ConfigError`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from aircraft import sensors as sk
from geofence.interface import PlatformKind
from geofence.validation import ConfigError, boolean, enum_value, kind, number, reject_unknown_keys, require_mapping


class FaultKind(Enum):
    GNSS_LOSS = "gnss_loss"
    GNSS_DEGRADED = "gnss_degraded"
    GNSS_WALKOFF = "gnss_walkoff"
    BARO_DRIFT = "baro_drift"
    PITOT_BLOCKED = "pitot_blocked"
    COMPASS_ERROR = "compass_error"
    FC_IGNORES_OVERRIDE = "fc_ignores_override"
    FC_FREEZES = "fc_freezes"
    PROPULSION_LOSS = "propulsion_loss"


FIXED_WING_ONLY = frozenset({FaultKind.PITOT_BLOCKED, FaultKind.PROPULSION_LOSS})
"""Kinds that apply to a fixed-wing only (a multirotor has no pitot; its propulsion is its control)."""
FC_KINDS = frozenset({FaultKind.FC_IGNORES_OVERRIDE, FaultKind.FC_FREEZES})
"""Kinds between the unit's sticks and the platform (applied by the runner)."""

_SENSOR_CODE = {
    FaultKind.GNSS_LOSS: sk.GNSS_LOSS,
    FaultKind.GNSS_DEGRADED: sk.GNSS_DEGRADED,
    FaultKind.GNSS_WALKOFF: sk.GNSS_WALKOFF,
    FaultKind.BARO_DRIFT: sk.BARO_DRIFT,
    FaultKind.PITOT_BLOCKED: sk.PITOT_BLOCKED,
    FaultKind.COMPASS_ERROR: sk.COMPASS_ERROR,
}

# the parameters of each kind: name -> (minimum, maximum, required); SI, units in the names
_PARAMS: dict[FaultKind, dict[str, tuple[float, float, bool]]] = {
    FaultKind.GNSS_LOSS: {},
    FaultKind.GNSS_DEGRADED: {"rate_hz": (0.1, 50.0, False), "latency_s": (0.0, 2.0, False), "bias_m": (0.0, 100.0, False)},
    FaultKind.GNSS_WALKOFF: {"drift_mps": (0.0, 50.0, True), "direction_deg": (0.0, 360.0, True)},
    FaultKind.BARO_DRIFT: {"drift_m": (-1000.0, 1000.0, False), "drift_rate_mps": (-10.0, 10.0, False)},
    FaultKind.PITOT_BLOCKED: {},
    FaultKind.COMPASS_ERROR: {"error_deg": (-180.0, 180.0, True)},
    FaultKind.FC_IGNORES_OVERRIDE: {},
    FaultKind.FC_FREEZES: {},
    FaultKind.PROPULSION_LOSS: {},
}
_AT_LEAST_ONE = frozenset({FaultKind.GNSS_DEGRADED, FaultKind.BARO_DRIFT})
_START_KEYS = ("kind", "at_s", "at_first_activation", "delay_s", "duration_s")


@dataclass(frozen=True)
class Fault:
    """One injected fault: its kind, start, duration and parameters (SI: angles in rad, rates in Hz)."""

    kind: FaultKind
    at_s: float | None = None
    """Its onset time (None: it starts ``delay_s`` after the unit's first activation)."""
    delay_s: float = 0.0
    duration_s: float = math.inf
    rate_hz: float | None = None
    latency_s: float | None = None
    bias_m: float | None = None
    drift_mps: float = 0.0
    direction_rad: float = 0.0
    """The walk-off's direction, toward, clockwise from north."""
    drift_m: float = 0.0
    drift_rate_mps: float = 0.0
    error_rad: float = 0.0

    @property
    def at_first_activation(self) -> bool:
        return self.at_s is None

    def onset_s(self, first_activation_s: float | None) -> float | None:
        """When it starts, given the unit's first activation (None: it has no onset yet)."""
        if self.at_s is not None:
            return self.at_s
        return None if first_activation_s is None else first_activation_s + self.delay_s

    def active(self, t_s: float, first_activation_s: float | None) -> bool:
        """It acts at ``t_s``."""
        onset = self.onset_s(first_activation_s)
        return onset is not None and onset <= t_s < onset + self.duration_s


def sensor_fault_rows(faults: tuple[Fault, ...]) -> np.ndarray:
    """The sensor faults as rows of the sensors' fault table (:func:`aircraft.sensors.fault_row`)."""
    rows = [_sensor_row(f) for f in faults if f.kind in _SENSOR_CODE]
    return np.array(rows).reshape(-1, sk.FAULT_COLUMNS)


def _sensor_row(f: Fault) -> np.ndarray:
    nan = math.nan
    params: tuple[float, ...] = ()
    if f.kind is FaultKind.GNSS_DEGRADED:
        params = (nan if f.rate_hz is None else 1.0 / f.rate_hz, nan if f.latency_s is None else f.latency_s)
        params += (nan if f.bias_m is None else f.bias_m,)
    elif f.kind is FaultKind.GNSS_WALKOFF:
        params = (f.drift_mps * math.sin(f.direction_rad), f.drift_mps * math.cos(f.direction_rad))
    elif f.kind is FaultKind.BARO_DRIFT:
        params = (f.drift_m, f.drift_rate_mps)
    elif f.kind is FaultKind.COMPASS_ERROR:
        params = (f.error_rad,)
    start = f.delay_s if f.at_s is None else f.at_s
    return sk.fault_row(_SENSOR_CODE[f.kind], start, f.duration_s, params, after_activation=f.at_s is None)


def parse_faults(raw: Any, where: str, platform: PlatformKind, duration_s: float, has_geofence: bool) -> tuple[Fault, ...]:
    """Validate an optional ``faults:`` list (None -> no faults) for a flight of ``duration_s`` on ``platform``."""
    if raw is None:
        return ()
    if not isinstance(raw, list):
        raise ConfigError(f"{where}: expected a list of faults (each a mapping with a kind), got {kind(raw)}")
    return tuple(_parse_fault(item, f"{where}[{i}]", platform, duration_s, has_geofence) for i, item in enumerate(raw))


def _parse_fault(raw: Any, where: str, platform: PlatformKind, duration_s: float, has_geofence: bool) -> Fault:
    require_mapping(raw, where)
    if "kind" not in raw:
        raise ConfigError(f"{where}.kind: missing (required; one of {', '.join(k.value for k in FaultKind)})")
    fk = enum_value(raw["kind"], f"{where}.kind", FaultKind)
    spec = _PARAMS[fk]
    reject_unknown_keys(raw, (*_START_KEYS, *spec), where)
    if fk in FIXED_WING_ONLY and platform is not PlatformKind.FIXED_WING:
        raise ConfigError(f"{where}.kind: {fk.value} applies to a fixed-wing only, the aircraft is a {platform.value}")
    at_s, delay_s = _parse_start(raw, where, duration_s, has_geofence)
    out: dict[str, Any] = {"kind": fk, "at_s": at_s, "delay_s": delay_s}
    if "duration_s" in raw:
        if fk is FaultKind.PROPULSION_LOSS:
            raise ConfigError(f"{where}.duration_s: a lost engine stays lost (propulsion_loss has no duration)")
        out["duration_s"] = number(raw["duration_s"], f"{where}.duration_s", strictly_positive=True)
    for name, (lo, hi, required) in spec.items():
        if name not in raw:
            if required:
                raise ConfigError(f"{where}.{name}: missing (required for {fk.value})")
            continue
        value = number(raw[name], f"{where}.{name}", minimum=lo, maximum=hi)
        if name == "rate_hz" and value <= 0.0:
            raise ConfigError(f"{where}.rate_hz: must be > 0, got {raw[name]!r}")
        if name.endswith("_deg"):
            out[name.replace("_deg", "_rad")] = math.radians(value)
        else:
            out[name] = value
    if fk in _AT_LEAST_ONE and not any(name in raw for name in spec):
        raise ConfigError(f"{where}: {fk.value} needs at least one of {', '.join(spec)}")
    return Fault(**out)


def _parse_start(raw: Any, where: str, duration_s: float, has_geofence: bool) -> tuple[float | None, float]:
    """``(at_s, delay_s)``: exactly one of ``at_s`` and ``at_first_activation: true``; ``delay_s`` with the latter."""
    after = boolean(raw["at_first_activation"], f"{where}.at_first_activation") if "at_first_activation" in raw else False
    if after == ("at_s" in raw):
        raise ConfigError(f"{where}: give exactly one start, at_s: <time> or at_first_activation: true")
    if not after:
        if "delay_s" in raw:
            raise ConfigError(f"{where}.delay_s: only with at_first_activation: true (else use at_s)")
        at_s = number(raw["at_s"], f"{where}.at_s", minimum=0.0)
        if at_s >= duration_s:
            raise ConfigError(f"{where}.at_s: {at_s:g} s is not before the flight's end (duration_s = {duration_s:g} s)")
        return at_s, 0.0
    if not has_geofence:
        raise ConfigError(f"{where}.at_first_activation: the scenario has no geofence, so there is no activation")
    delay_s = number(raw.get("delay_s", 0.0), f"{where}.delay_s", minimum=0.0)
    if delay_s >= duration_s:
        raise ConfigError(f"{where}.delay_s: {delay_s:g} s is not before the flight's end (duration_s = {duration_s:g} s)")
    return None, delay_s
