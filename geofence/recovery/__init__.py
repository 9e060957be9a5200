"""Fence-aware recovery routes: a visibility-graph planner over the clearance-offset free space.

The modules: ``segments`` (segment and circle clearance tests, the segment grid), ``graph`` (the tangent
graph), ``search`` (the compiled A* and goal trees), ``follower`` (the route follower), ``path``
(:class:`SafePoint`, :class:`RecoveryPath`), ``planner`` (:class:`RecoveryPlanner`) and ``guidance`` (the
recovery laws that fly a route: the fixed-wing override step, the multirotor's, the landing). Imports
``physics`` and ``geometry``, never the margins or the unit.

The geofence unit used to fly straight at the recovery point, which in concave
fences (L, U, star shapes, corridors) and past keep-outs cuts across forbidden
ground. :class:`RecoveryPlanner` replaces that straight line by the shortest
route (up to the conservatism below) that keeps a lateral clearance ``c`` from
every boundary. Pure planar math in local ENU metres on a
:class:`~geofence.geometry.local_fence.LocalFence`; floor gaps and heights are not involved.

Free space and admissibility
----------------------------
``F = {p : lateral_margin_m(p) >= c}``: the keep-in shrunk by ``c`` minus every
keep-out polygon and circle grown by ``c``. A segment is **admissible** when
every point of it is in ``F``. This is decided *exactly* (no sampling): a
segment ``p-q`` with ``margin(p) >= t > 0`` has ``margin >= t`` everywhere iff
its distance to every keep-in/keep-out edge is ``>= t`` and its distance to
every keep-out circle centre is ``>= r + t`` (a segment that stays ``t > 0``
away from every boundary cannot change region, and inside the allowed region
the margin *is* the distance to the nearest boundary). Segment-segment
distances use floating point; a misjudged crossing can only happen within
~1e-12 relative of an endpoint, where the endpoint distance already fails the
test. Thresholds carry :data:`EPS_M` (1e-9 m) of slack for rounding, so an
admissible segment has ``margin >= c - 1e-9`` m everywhere.

The graph
---------
Nodes are the vertices of *circumscribed* polygons around the rounded corners
of the grown obstacles: at each reflex keep-in vertex and each convex
keep-out-polygon vertex, the arc of radius ``c' = c + 1e-6 m`` swept between the
two edge normals is replaced by ``k = ceil(turn / 30 deg)`` tangent pieces (nodes
at ``c' / cos(turn / 2k)`` from the vertex); each circle gets a 16-gon around the
radius ``r + c'``. The circumscribed pieces contain the true Minkowski sum, so
the routes are conservative (at most ~3.5 % longer round a corner, ~2 % round a
circle), and they are tangent to the clearance circles, so consecutive nodes see
each other. Nodes not in ``F`` (covered by another grown obstacle) are dropped.
The safe points (below) are nodes too. Edges join the pairs of nodes whose
segment is admissible (exact test above, vectorized over the pairs with
early rejection) and *tangent* at both corner nodes (the line supports the
node's circumscribed obstacle; a shortest path can only bend at a corner by
wrapping round it, so other edges are never needed: the classic reduced
visibility graph). Per query, the start and goal are joined to every node
they see (no pruning at the ends). Shortest paths: Dijkstra over this graph plus, per query,
the edges from the start and to the goal.

Guarantee of :meth:`RecoveryPlanner.plan`
-----------------------------------------
* Every segment of the returned path **after the first** is admissible
  (``margin >= c - 1e-9`` m everywhere on it); every vertex after the first is
  in ``F``.
* The **first leg** (start -> second point) keeps ``margin >= min(m_s, c) - tol``
  everywhere, where ``m_s`` is the start's margin: it never takes the vehicle
  closer to any boundary than it already is (and for a start in ``F`` it is an
  ordinary admissible segment). ``tol`` is 1e-9 m when ``m_s > 0`` (exact test,
  and the whole leg is inside the allowed area) and :data:`BREACHED_TOL_M`
  (1 mm) when ``m_s <= 0`` (the start is already outside the allowed area: the
  leg is certified by Lipschitz bisection of the 1-Lipschitz margin, i.e. it
  never goes deeper into the breach). The first leg goes to a graph node, to
  the goal, or to an *escape point* found by pushing the start along the
  steepest margin ascent until it is in ``F``.
* If the goal is not in ``F`` it is replaced by the point reached by the same
  margin-ascent push (the exact nearest point of ``F`` when one boundary feature
  binds), or failing that the nearest graph node.
* If the (replaced) goal is not reachable in the start's component of ``F``,
  the path ends at the reachable node nearest to it and
  ``RecoveryPath.reached_goal`` is ``False``. ``plan`` returns ``None`` only when
  no admissible first leg exists (the start's component of ``F`` is not
  reachable from the start under the first-leg rule: e.g. a start in a
  corridor narrower than ``2c``).
* When the start is in ``F`` and the straight segment to the goal is
  admissible, the path is exactly ``[start, goal]``.

Complexity
----------
Build: ``O(V^2 E)`` for ``V`` nodes and ``E`` edges + circles, vectorized and
with failed pairs dropped after each edge chunk (pairs blocked early cost
little); the safe points cost a 64 x 64 grid of margins. Query:
``O(V E)`` vectorized tests to connect the start and goal, then Dijkstra
``O(G log V)`` over ``G`` graph edges.

From :data:`LAZY_MIN_NODES` nodes on (airspace-scale fences: a 10,000-vertex
park has some 12,000), the ``V^2`` pairs are neither stored nor tested at
build: a node's graph edges are found when a search first expands it (the
same tangency filter and exact test, one row of pairs), and the searches stop
early: :meth:`RecoveryPlanner.plan` is A* toward the goal (Euclidean
heuristic, admissible and consistent: the route is still the shortest over
the same graph) and the safe-point searches stop at the first safe point
settled. Same graph, same routes; only the work done differs. The compiled A* takes its first legs from boxes of
nodes released in order of a lower bound of their keys (:func:`~geofence.recovery.search._lazy_astar`: not a
heap of every node per search). :meth:`RecoveryPlanner.prepare` (a unit's ``prepare_routes``, before flight)
instead files every node's edges at once (each tangent pair tested once,
:func:`~geofence.recovery.graph._tangent_pairs`) and, for each goal it is given, the shortest-route tree to it
over the whole graph (:func:`~geofence.recovery.search._goal_tree`). A search towards a prepared goal is then no
search: the route leaves for the first node, in order of the straight leg plus its route length, whose leg is
clear (:func:`~geofence.recovery.search._tree_first_leg`; the elements that blocked the last legs, and those
filed in the node's own cell, are tried first), then follows the tree. The same shortest length over the same
graph (to round-off; ``tests/test_recovery_clear_vector.py`` holds it to a Dijkstra oracle); a 10,000-vertex
park with 500 buildings answers in some 30 µs instead of 0.3-1 ms. Per step, :meth:`RecoveryPath.lookahead_point`
is a projection over the path's segments and one or two exact chord tests
(bounding-box filtered loops over the edges): one compiled call
(:data:`~geofence.recovery.follower.path_lookahead`) while the vehicle is inside by more than 1e-9 m; for a
breached vehicle the same candidates with the certified chord test.

Modules, each importing only those before it: :mod:`~geofence.recovery.segments` (the exact segment
tests and the segment grid), :mod:`~geofence.recovery.graph` (corner nodes, tangency, filing graph edges),
:mod:`~geofence.recovery.search` (the compiled searches), :mod:`~geofence.recovery.follower` (the route
follower's arithmetic), :mod:`~geofence.recovery.path` (:class:`RecoveryPath`, :class:`SafePoint`) and
:mod:`~geofence.recovery.planner` (:class:`RecoveryPlanner`). Every per-step algorithm is written once, as
numba-compilable functions; the entry points are :func:`geofence.jit.compiled` (the same source interpreted
without numba).
"""

from geofence.recovery.follower import (
    PROJECTION_CANDIDATES,
    follower_tables,
    path_follow,
    path_lookahead,
    path_project,
    path_rollout,
    route_arrays,
    route_follow,
    route_rollout,
)
from geofence.recovery.graph import (
    CIRCLE_SIDES,
    CORNER_STEP_RAD,
    NODE_INFLATION_M,
    corner_nodes,
    file_rows,
    tangent_pairs,
    tangent_row,
)
from geofence.recovery.path import (
    RecoveryPath,
    SafePoint,
)
from geofence.recovery.planner import (
    BREACHED_TOL_M,
    FULL_GRAPH_MAX_NODES,
    GRID_CELLS,
    LAZY_MIN_NODES,
    MAX_SAFE_POINTS,
    NODES_PER_BOX,
    ORBIT_CUT_STEP_M,
    RecoveryPlanner,
    Search,
)
from geofence.recovery.search import (
    by_key_in_chunks,
    goal_tree,
    lazy_astar,
    tree_first_leg,
)
from geofence.recovery.segments import (
    EPS_M,
    FAN_SLACK_M,
    SEGMENT_GRID_MIN_EDGES,
    SEGMENT_GRID_SLACK_M,
    Point,
    boundary_tables,
    fan_clear,
    fan_clear_grid,
    pairs_clear,
    segment_clear,
    segment_clear_grid,
    segment_grid,
    segment_segment_distance,
)

__all__ = [
    "BREACHED_TOL_M",
    "CIRCLE_SIDES",
    "CORNER_STEP_RAD",
    "EPS_M",
    "FAN_SLACK_M",
    "FULL_GRAPH_MAX_NODES",
    "GRID_CELLS",
    "LAZY_MIN_NODES",
    "MAX_SAFE_POINTS",
    "NODES_PER_BOX",
    "NODE_INFLATION_M",
    "ORBIT_CUT_STEP_M",
    "PROJECTION_CANDIDATES",
    "Point",
    "RecoveryPath",
    "RecoveryPlanner",
    "SEGMENT_GRID_MIN_EDGES",
    "SEGMENT_GRID_SLACK_M",
    "SafePoint",
    "Search",
    "boundary_tables",
    "by_key_in_chunks",
    "corner_nodes",
    "fan_clear",
    "fan_clear_grid",
    "file_rows",
    "follower_tables",
    "goal_tree",
    "lazy_astar",
    "pairs_clear",
    "path_follow",
    "path_lookahead",
    "path_project",
    "path_rollout",
    "route_arrays",
    "route_follow",
    "route_rollout",
    "segment_clear",
    "segment_clear_grid",
    "segment_grid",
    "segment_segment_distance",
    "tangent_pairs",
    "tangent_row",
    "tree_first_leg",
]
