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
    gains:                      # flight-controller property -> value, written before run_ic
      fc/roll-kp: 4.0

The platform adapters read it; scenarios pick it by model name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from geofence.interface import Envelope, PlatformKind

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
}


class ProfileError(ValueError):
    """A profile file is missing or malformed."""


@dataclass(frozen=True)
class PlatformProfile:
    model: str
    kind: PlatformKind
    envelope: Envelope
    frame_rate_hz: float = 120.0
    gains: dict[str, float] = field(default_factory=dict)


def available_profiles() -> list[str]:
    """Model names that have a profile (and so can fly in a scenario)."""
    return sorted(p.stem for p in PROFILES_DIR.glob("*.yaml"))


def load_profile(model: str) -> PlatformProfile:
    """Read ``aircraft/profiles/<model>.yaml`` into a :class:`PlatformProfile`."""
    path = PROFILES_DIR / f"{model}.yaml"
    if not path.is_file():
        raise ProfileError(f"no platform profile for aircraft {model!r}; known: {', '.join(available_profiles())}")
    raw = yaml.safe_load(path.read_text())
    try:
        kind = PlatformKind(raw["kind"])
        env_raw = raw["envelope"]
        values = {}
        for key, scale in _ENVELOPE_FIELDS.items():
            values[key.replace("_deg_s", "_radps").replace("_deg", "_rad")] = float(env_raw[key]) * scale
        envelope = Envelope(kind=kind, **values)
        return PlatformProfile(
            model=raw.get("model", model),
            kind=kind,
            envelope=envelope,
            frame_rate_hz=float(raw.get("frame_rate_hz", 120.0)),
            gains={str(k): float(v) for k, v in (raw.get("gains") or {}).items()},
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise ProfileError(f"{path}: malformed profile ({exc})") from exc
