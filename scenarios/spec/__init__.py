"""Scenario data: what to fly.

The scenario schema (YAML -> typed, validated dataclasses), sweeps, the
adversarial campaign generator and the pre-flight findings of a scenario.
Imports the layers below (geofence, wind, aircraft profiles, analysis) and
never ``scenarios.flight`` or ``scenarios.app``.
"""
