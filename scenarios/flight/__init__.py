"""The simulated flight: one scenario flown in closed loop.

The runner (``fly``: JSBSim platform, wind, the geofence unit's sensors and the
unit, with a typed ``FlightResult``), the recorder and the pilots. Imports
``scenarios.definition`` and the layers below, never ``scenarios.app``.
"""
