"""How the aircraft moves, and how much room its manoeuvres need.

``dynamics``: gravity, ISA air density, the multirotor drag law and the wind's push. ``control_laws``: angle
wrapping and the course and orbit laws the recoveries fly. ``rooms``: the one home of every room formula (turn
radius and rate, trochoid excursion, reaction travel, braking, arrest, their upper bounds), derived in its
docstring. Imports only the top-level vocabulary (``geofence.interface``, ``geofence.jit``).
"""
