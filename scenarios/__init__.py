"""Scenarios, bottom up: ``spec`` (scenario data), ``flight`` (the simulated flight), ``app`` (the application).

The YAML files beside these subpackages are the shipped scenarios.
"""
