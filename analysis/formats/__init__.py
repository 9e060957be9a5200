"""File formats in, the testbed's own types out: the adapters between other tools' files and the unit.

* :mod:`analysis.formats.fence_files`: fence and rally files (QGroundControl ``.plan``, WPL 110, MAVProxy
  text, RFC 7946 GeoJSON) into a :class:`geofence.geometry.fence.Fence`, and a fence back into a scenario's
  ``geofence:`` block.
* :mod:`analysis.formats.logs`: MAVLink ``.tlog`` and DataFlash ``.bin`` flight logs into the recorder's
  trajectory columns, so that a real flight is scored like a simulated one.
* :mod:`analysis.formats.replace`: an output file written whole (a temporary file renamed over it).

The geofence unit reads no file: these sit above it (the scenario loader and the CLI call them).
"""
