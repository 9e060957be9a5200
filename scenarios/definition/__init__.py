"""Scenario data: what to fly.

The scenario schema (YAML -> typed, validated dataclasses), sweeps, the fence-file block and the
pre-flight findings of a scenario. Imports the layers below (geofence, wind, aircraft profiles,
analysis) and never ``scenarios.campaign``, ``scenarios.flight`` or ``scenarios.app``.
"""
