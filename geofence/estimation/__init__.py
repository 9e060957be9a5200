"""Where the aircraft is, as the unit's own sensors tell it.

``measurements``: the sensor messages. ``estimator``: the state estimator (a Kalman filter, one compiled
step over its record, the class a façade). ``wind_estimator``: the wind and turbulence estimate, the same
pattern. ``history``: the last seconds of estimates, replayed by ``dead_reckoning`` when the position source
is lost.
"""
