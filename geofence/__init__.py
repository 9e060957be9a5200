"""The geofence unit: fence geometry, boundary shifting, monitor/override logic and guidance.

Sub-packages by question, bottom up, each importing only those below it (``tests/test_architecture.py``):
``physics`` (how the aircraft moves, the rooms its manoeuvres need), ``geometry`` (where the fence is),
``estimation`` (where the aircraft is), ``margins`` (how close to acting), ``recovery`` (the way back) and
``unit`` (the state machine, its configuration, the pre-flight check). Three top-level modules are the
vocabulary all of them share: ``interface`` (the unit's inputs and outputs), ``validation`` (the parsing kit)
and ``jit`` (the compiler).

Imports nothing from JSBSim or :mod:`aircraft`, and reads no file; it sees a state estimate, a platform
:class:`~geofence.interface.Envelope`, the wind and outer-loop sticks, and emits sticks and a mode.

The public API, re-exported here (``from geofence import GeofenceUnit, parse_geofence``); each name is
imported on first use, so that ``import geofence.validation`` stays light:

=====================  ==========================================================================
``GeofenceUnit``       the unit: ``update(estimate, sticks, ...)`` -> sticks, and its :class:`Mode`
``GeofenceConfig``     its configuration (``parse_geofence`` validates a ``geofence:`` mapping)
``Fence``              the fence in WGS-84 (keep-in, keep-outs, ceiling, floor and its gaps)
``LocalFence``         the same in a local ENU frame (``Fence.to_local(LocalFrame(...))``)
``Envelope``           what the unit knows of an airframe: speeds, bank or tilt, rates, latency
``VehicleState``       a state estimate (ENU position and velocity, attitude, airspeed)
``StickCommand``       normalised roll, pitch, yaw, throttle sticks
``PlatformKind``       multirotor or fixed-wing
=====================  ==========================================================================
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

_PUBLIC = {
    "GeofenceUnit": "geofence.unit.geofence_unit",
    "Mode": "geofence.unit.geofence_unit",
    "GeofenceConfig": "geofence.unit.config",
    "parse_geofence": "geofence.unit.config",
    "Fence": "geofence.geometry.fence",
    "LocalFence": "geofence.geometry.local_fence",
    "LocalFrame": "geofence.geometry.geodesy",
    "Envelope": "geofence.interface",
    "VehicleState": "geofence.interface",
    "StickCommand": "geofence.interface",
    "PlatformKind": "geofence.interface",
}

__all__ = sorted(_PUBLIC)


def __getattr__(name: str) -> Any:
    if name in _PUBLIC:
        return getattr(import_module(_PUBLIC[name]), name)
    raise AttributeError(f"module 'geofence' has no attribute {name!r}")
