"""Build the platform adapter for an aircraft model from its profile."""

from __future__ import annotations

from aircraft.platform import Platform
from aircraft.profile import load_profile
from geofence.interface import PlatformKind


def build_platform(model: str) -> Platform:
    """A ready-to-reset platform for ``model`` (multirotor or fixed-wing, per its profile)."""
    profile = load_profile(model)
    if profile.kind is PlatformKind.MULTIROTOR:
        from aircraft.multicopter import MulticopterPlatform

        return MulticopterPlatform(profile)
    from aircraft.fixedwing import FixedWingPlatform

    return FixedWingPlatform(profile)
