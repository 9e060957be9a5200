"""How close the aircraft is to needing the override: the activation margins.

``lateral``: the binding lateral element of a state (its per-edge fixed-wing turn and multirotor braking
terms, the candidate search). ``kernel``: the compiled margins of one state (lateral, ceiling, floor and its
gaps) and the unit's skip shortcut, written once and compiled. ``boundary_shift``: the façade
(:func:`~geofence.margins.boundary_shift.activation_margins`, :class:`~geofence.margins.boundary_shift.ShiftResult`),
the uncertainty margin and the pre-flight feasibility of the shifted fence.
"""
