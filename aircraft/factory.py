"""Build the platform adapter for an aircraft model from its profile."""

from __future__ import annotations

from aircraft.platform import Platform
from aircraft.profile import PlatformProfile, load_profile
from geofence.interface import PlatformKind


def build_platform(model_or_profile: str | PlatformProfile) -> Platform:
    """A ready-to-reset platform for a model name (shipped profile) or an explicit profile."""
    profile = load_profile(model_or_profile) if isinstance(model_or_profile, str) else model_or_profile
    if profile.kind is PlatformKind.MULTIROTOR:
        from aircraft.multicopter import MulticopterPlatform

        return MulticopterPlatform(profile)
    from aircraft.fixedwing import FixedWingPlatform

    return FixedWingPlatform(profile)
