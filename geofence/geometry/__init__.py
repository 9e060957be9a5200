"""Where the fence is: geodesy, polygons, the fence in WGS-84 and in a local frame, and its tables.

``geodesy``: WGS-84 and the local ENU frame. ``polygon``: polygon distances and the pole of inaccessibility.
``heights``: altitude references and vertical extents. ``fence``: the WGS-84 :class:`~geofence.geometry.fence.Fence`
with its validation. ``local_fence``: the same in ENU metres, with its danger edges, margins and gaps.
``fence_grid``: the per-step candidate index of a large fence. ``scan``: the lateral margin's full scan.
``elements``: the fence's elements as the float tables the compiled margins and the index read. Imports
``physics`` at most; nothing here knows a room or an envelope.
"""
