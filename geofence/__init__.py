"""The geofence unit: fence geometry, boundary shifting, monitor/override logic and guidance.

Imports nothing from JSBSim or :mod:`aircraft`; it sees a state estimate, a
platform :class:`~geofence.interface.Envelope` and outer-loop sticks.
"""
