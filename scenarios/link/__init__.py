"""The MAVLink vocabulary the simulated vehicle and the companion share.

This sub-layer owns what crosses the link, written once for both ends:

* :mod:`scenarios.link.sticks`: :class:`~geofence.interface.StickCommand` <-> RC_CHANNELS_OVERRIDE (ArduPilot) and
  MANUAL_CONTROL (PX4) fields, the release message, the override timeouts, and the vehicle's record of which
  override it honours (:class:`~scenarios.link.sticks.OverrideInput`).
* :mod:`scenarios.link.telemetry`: the telemetry messages (HEARTBEAT, ATTITUDE, GLOBAL_POSITION_INT, GPS_RAW_INT,
  SCALED_PRESSURE, VFR_HUD, WIND) encoded from the simulated truth and the unit's sensor outputs, and decoded back
  into :mod:`geofence.estimation.measurements` and :class:`~geofence.interface.VehicleState`; the ISA pressure
  <-> altitude conversion; the default rates and the lock-step marker's name.
* :mod:`scenarios.link.connection` and :mod:`scenarios.link.mission_fence` (the companion's side): opening a
  connection, the mission-protocol fence.

It sits between ``scenarios.definition`` and ``scenarios.flight``: it imports geofence, analysis and
scenarios.definition, never scenarios.flight or scenarios.app. MAVLink 2 is selected here
(``MAVLINK20=1`` before pymavlink's ``mavutil`` is first imported), dialect ``ardupilotmega``.
"""

import os

os.environ.setdefault("MAVLINK20", "1")
