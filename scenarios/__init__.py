"""Scenarios, bottom up: ``airspace`` (the park generator, data), ``definition`` (scenario data), ``campaign`` (the
adversarial case generator), ``link`` (MAVLink), ``flight`` (the simulated flight), ``app`` (the application).

The YAML files beside these subpackages are the shipped scenarios.
"""
