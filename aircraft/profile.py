"""Platform profiles: per-model envelope and flight-controller gains, as data.

A profile lives in ``aircraft/profiles/<model>.yaml``::

    model: F450                 # JSBSim model name (wheel or aircraft/models)
    kind: multirotor            # or fixed_wing
    frame_rate_hz: 120          # JSBSim frame rate
    envelope:                   # SI units; angles in deg (converted here)
      cruise_speed_mps: 8
      max_speed_mps: 15
      min_speed_mps: 0
      max_bank_deg: 30
      max_pitch_deg: 30
      max_yaw_rate_deg_s: 90
      max_climb_rate_mps: 3
      max_descent_rate_mps: 2
      braking_decel_mps2: 5
      vertical_accel_mps2: 3
      reaction_time_s: 0.2
      drag_linear_per_s: 0.45   # optional: drag law a = k1 v + k2 v^2 (multirotor)
      drag_quadratic_per_m: 0.01
    gains:                      # flight-controller property -> value, written before run_ic
      fc/roll-kp: 4.0
    measured_on: F450           # optional: the JSBSim model the figures were measured on (default: model;
                                #   an inline profile with base: inherits the base's)

Every envelope value is checked against a physical bound (:data:`ENVELOPE_BOUNDS`), and
``min_speed_mps <= cruise_speed_mps <= max_speed_mps``. The platform adapters read it; scenarios
pick it by model name.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from geofence.interface import Envelope, PlatformKind
from geofence.validation import ConfigError, enum_value, field_default, number, reject_unknown_keys, require_mapping

PROFILES_DIR = Path(__file__).parent / "profiles"

_ENVELOPE_FIELDS = {
    "cruise_speed_mps": 1.0,
    "max_speed_mps": 1.0,
    "min_speed_mps": 1.0,
    "max_bank_deg": math.pi / 180.0,
    "max_pitch_deg": math.pi / 180.0,
    "max_yaw_rate_deg_s": math.pi / 180.0,
    "max_climb_rate_mps": 1.0,
    "max_descent_rate_mps": 1.0,
    "braking_decel_mps2": 1.0,
    "vertical_accel_mps2": 1.0,
    "reaction_time_s": 1.0,
    "drag_linear_per_s": 1.0,
    "drag_quadratic_per_m": 1.0,
}
ENVELOPE_BOUNDS: dict[str, tuple[float, float, bool]] = {
    "cruise_speed_mps": (0.0, 150.0, True),
    "max_speed_mps": (0.0, 150.0, True),
    "min_speed_mps": (0.0, 150.0, False),
    "max_bank_deg": (0.0, 80.0, True),
    "max_pitch_deg": (0.0, 80.0, True),
    "max_yaw_rate_deg_s": (0.0, 720.0, True),
    "max_climb_rate_mps": (0.0, 50.0, True),
    "max_descent_rate_mps": (0.0, 50.0, True),
    "braking_decel_mps2": (0.0, 50.0, True),
    "vertical_accel_mps2": (0.0, 50.0, True),
    "reaction_time_s": (0.0, 10.0, False),
    "drag_linear_per_s": (0.0, 10.0, False),
    "drag_quadratic_per_m": (0.0, 10.0, False),
}
"""``(low, high, low excluded)`` per envelope key, in the file's units. Physical bounds of a small UAS:
speeds up to 150 m/s (above any small UAS; the shipped Cessna 172 tops at 58), bank and pitch limits up
to 80 deg (a level turn at 80 deg bank pulls 5.8 g; a multirotor tilted 90 deg has no lift),
accelerations up to 50 m/s^2 (~5 g), a reaction time up to 10 s. The sticks scale by bank, pitch, yaw
rate, climb and descent rates (the control laws divide by them), and the fence's stopping distances by
the decelerations, so those must be > 0."""
_OPTIONAL_ENVELOPE_FIELDS = ("drag_linear_per_s", "drag_quadratic_per_m")
"""Envelope keys a profile may leave out: they take the :class:`geofence.interface.Envelope` field's default."""


class ProfileError(ConfigError):
    """A profile file is missing or malformed."""


@dataclass(frozen=True)
class PlatformProfile:
    model: str
    kind: PlatformKind
    envelope: Envelope
    frame_rate_hz: float = 120.0
    gains: dict[str, float] = field(default_factory=dict)
    measured_on: str | None = None
    """The JSBSim model the envelope and gains were measured on (``characterize MODEL`` writes it); a profile file
    without the key measured them on its own ``model``, an inline profile with ``base:`` inherits the base's."""


_SHIPPED_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
"""The shipped profiles (a flight loads several) are read with libyaml's C parser where PyYAML has it (about 8x
faster); a user's inline profile comes in through the scenario's own (pure-Python, hostile-input safe) loader."""


def available_profiles() -> list[str]:
    """Model names that have a profile (and so can fly in a scenario)."""
    return sorted(p.stem for p in PROFILES_DIR.glob("*.yaml"))


def load_profile(model: str) -> PlatformProfile:
    """Read ``aircraft/profiles/<model>.yaml`` into a :class:`PlatformProfile`."""
    path = PROFILES_DIR / f"{model}.yaml"
    if not path.is_file():
        raise ProfileError(f"no platform profile for aircraft {model!r}; known: {', '.join(available_profiles())}")
    return parse_profile(yaml.load(path.read_text(), Loader=_SHIPPED_LOADER), model, str(path))  # noqa: S506 - safe


def parse_profile(raw: Any, model: str, where: str) -> PlatformProfile:
    """Validate a profile mapping (the file format above, or a scenario's inline ``profile:`` block).

    An inline profile may name ``base: <model>`` to start from a shipped
    profile and override only some envelope values or gains.
    """
    try:
        return _parse_profile(raw, model, where)
    except ProfileError:
        raise
    except ConfigError as exc:  # a kit reader's message, as the profile's error type
        raise ProfileError(str(exc)) from None


def _check_speed_order(values: dict[str, float], given: Mapping, where: str) -> None:
    """``min_speed_mps <= cruise_speed_mps <= max_speed_mps`` (a fixed-wing's throttle spans them: a stall
    speed above the top speed leaves no speed to fly at). The message names the key the block gave."""
    for low, high in (("min_speed_mps", "cruise_speed_mps"), ("cruise_speed_mps", "max_speed_mps")):
        if values[low] > values[high]:
            key, other, rel = (high, low, ">=") if high in given and low not in given else (low, high, "<=")
            raise ProfileError(f"{where}.envelope.{key}: must be {rel} {other} ({values[other]:g} m/s), got {values[key]:g} m/s")


def _parse_profile(raw: Any, model: str, where: str) -> PlatformProfile:
    if not isinstance(raw, Mapping):
        raise ProfileError(f"{where}: expected a mapping with kind, envelope and gains")
    reject_unknown_keys(raw, ("model", "kind", "frame_rate_hz", "envelope", "gains", "base", "measured_on"), where)
    base = load_profile(str(raw["base"])) if raw.get("base") is not None else None
    kind = enum_value(raw.get("kind", base.kind if base else None), f"{where}.kind", PlatformKind)
    env_raw = require_mapping(raw.get("envelope") or {}, f"{where}.envelope")
    reject_unknown_keys(env_raw, _ENVELOPE_FIELDS, f"{where}.envelope")
    values = {}
    for key, scale in _ENVELOPE_FIELDS.items():
        field_name = key.replace("_deg_s", "_radps").replace("_deg", "_rad")
        if key in env_raw:
            low, high, open_low = ENVELOPE_BOUNDS[key]
            x = number(env_raw[key], f"{where}.envelope.{key}", minimum=low, maximum=high, strictly_positive=open_low)
            values[field_name] = x * scale
        elif base is not None:
            values[field_name] = getattr(base.envelope, field_name)
        elif key in _OPTIONAL_ENVELOPE_FIELDS:
            values[field_name] = field_default(Envelope, field_name)
        else:
            raise ProfileError(f"{where}.envelope.{key}: missing (required)")
    _check_speed_order(values, env_raw, where)
    gains = dict(base.gains) if base else {}
    gains_raw = require_mapping(raw.get("gains") or {}, f"{where}.gains")
    for k, v in gains_raw.items():
        gains[str(k)] = number(v, f"{where}.gains.{k}")
    rate = number(
        raw.get("frame_rate_hz", base.frame_rate_hz if base else field_default(PlatformProfile, "frame_rate_hz")),
        f"{where}.frame_rate_hz",
        minimum=30.0,
        maximum=1000.0,
    )
    name = str(raw.get("model", model))
    measured_on = raw.get("measured_on", base.measured_on if base else name)
    if not isinstance(measured_on, str) or not measured_on:
        raise ProfileError(f"{where}.measured_on: expected a JSBSim model name, got {measured_on!r}")
    return PlatformProfile(
        model=name,
        kind=kind,
        envelope=Envelope(kind=kind, **values),
        frame_rate_hz=float(rate),
        gains=gains,
        measured_on=measured_on,
    )
