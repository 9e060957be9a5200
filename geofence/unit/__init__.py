"""The geofence unit: its state machine, its configuration and its pre-flight check.

``geofence_unit``: :class:`~geofence.unit.geofence_unit.GeofenceUnit` (monitor, override, recovered, land in
a gap, terminate) and its :class:`~geofence.unit.geofence_unit.Mode`. ``passes``: the unit's monitoring and
fixed-wing override steps on arrays, the decisions both the unit and the compiled flight step take.
``config``: :class:`~geofence.unit.config.GeofenceConfig` and its parser from a mapping (no file).
``preflight``: whether a mission's return is assured before it is flown. The top of the package: it may
import every other sub-package.
"""
