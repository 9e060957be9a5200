"""A planned recovery route and a vehicle's following of it: :class:`RecoveryPath`, and :class:`SafePoint`.

Owns the route's points and arc lengths, its packed array for the compiled follower, and the follower's
façade: projection, carrot, roll-out point and the one-call step (:mod:`geofence.recovery.follower`'s entry
points) for a vehicle more than :data:`~geofence.recovery.segments.EPS_M` inside; for a breached vehicle the
same candidates with the planner's certified chord test (:meth:`RecoveryPlanner.chord_ok`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from geofence.recovery.follower import (
    PROJECTION_CANDIDATES,
    _next_candidate,
    _path_candidates,
    _path_point_at,
    path_follow,
    path_lookahead,
    path_project,
    path_rollout,
)
from geofence.recovery.segments import EPS_M, Point

if TYPE_CHECKING:  # pragma: no cover
    from geofence.recovery.planner import RecoveryPlanner


@dataclass(frozen=True)
class SafePoint:
    """A point deep inside the free space: ``(east_m, north_m)`` and its lateral margin ``clearance_m``."""

    east_m: float
    north_m: float
    clearance_m: float

    @property
    def en(self) -> Point:
        return (self.east_m, self.north_m)


class RecoveryPath:
    """A planned polyline, with carrot-chasing helpers (see :mod:`geofence.recovery` for its guarantee).

    Attributes: ``points`` (list of ``(east_m, north_m)``, start first),
    ``length_m``, ``goal_en`` (the goal asked for), ``reached_goal`` (``False``
    when the path ends at the reachable point nearest an unreachable goal),
    ``first_leg_floor_m`` (the margin guaranteed along the first leg, ``c`` for a
    start in the free space) and ``progress_m`` (arc length of the furthest
    projection so far; :meth:`lookahead_point` advances it, never backwards).
    """

    def __init__(
        self, planner: "RecoveryPlanner", points: Sequence[Point], goal_en: Point, reached_goal: bool, first_leg_floor_m: float
    ) -> None:
        self.planner = planner
        self.points = [(float(p[0]), float(p[1])) for p in points]
        cum = [0.0]
        for (ax, ay), (bx, by) in zip(self.points, self.points[1:]):
            cum.append(cum[-1] + math.hypot(bx - ax, by - ay))
        self.cum_m = cum
        self.length_m = cum[-1]
        self._rows = np.array([c for p in self.points for c in p] + self.cum_m, dtype=np.float64)
        k = len(self.points)
        self._pts, self._cum = self._rows[: 2 * k].reshape(k, 2), self._rows[2 * k :]
        self.goal_en = (float(goal_en[0]), float(goal_en[1]))
        self.reached_goal = reached_goal
        self.first_leg_floor_m = first_leg_floor_m
        self.progress_m = 0.0

    def __repr__(self) -> str:
        return f"RecoveryPath({len(self.points)} points, {self.length_m:.1f} m, reached_goal={self.reached_goal})"

    def _arrays(self) -> np.ndarray:
        """The points and their arc lengths packed as the compiled follower's array (the points' rows, then the arc
        lengths: :func:`~geofence.recovery.follower.route_arrays`)."""
        return self._rows

    def point_at(self, s_m: float) -> Point:
        """The path point at arc length ``s_m`` (clamped to the path)."""
        e, n = _path_point_at(self._pts, self._cum, s_m)
        return (float(e), float(n))

    def project(self, e: float, n: float) -> float:
        """Arc length of the projection of (e, n) onto the path, at or after ``progress_m``.

        Candidates are each segment's nearest point (the current segment
        clipped to start at ``progress_m``), nearest first; the first whose
        chord from (e, n) is safe (margin kept ``>= min(margin(e, n), c)``, see
        :meth:`RecoveryPlanner.chord_ok`) wins, so the projection never jumps
        across a wall to a later leg of the path. If none is, ``progress_m``.
        Does not change ``progress_m``. One compiled call (:data:`~geofence.recovery.follower.path_project`)
        while the vehicle is more than 1e-9 m inside.
        """
        if len(self.points) == 1:
            return 0.0
        thr = self._exact_chord_threshold(e, n)
        if thr is not None:
            return float(path_project(self._rows, *self.planner._follower, self.progress_m, e, n, thr))
        return self._project_certified(e, n)

    def _project_certified(self, e: float, n: float) -> float:
        """:meth:`project` for a vehicle whose chords are certified (:meth:`RecoveryPlanner.chord_ok`)."""
        s0 = self.progress_m
        C, c = _path_candidates(self._pts, self._cum, s0, e, n)
        m_v = self.planner.fence.lateral_margin_m(e, n)
        for _ in range(min(PROJECTION_CANDIDATES, c)):
            b = _next_candidate(C, c)
            if C[0, b] <= EPS_M or self.planner.chord_ok((e, n), (float(C[2, b]), float(C[3, b])), m_v):
                return float(C[1, b])
        return s0

    def _exact_chord_threshold(self, e: float, n: float) -> float | None:
        """:meth:`RecoveryPlanner.chord_ok`'s exact threshold ``min(margin, c) - EPS_M`` for chords from (e, n)
        when it is positive; else None (the chords are certified)."""
        planner = self.planner
        t = min(planner.fence.lateral_margin_m(e, n), planner.clearance_m) - EPS_M
        return t if t > 0.0 else None

    def remaining_m(self, e: float, n: float) -> float:
        """Path length (m) left from the projection of (e, n) (see :meth:`project`) to the end."""
        return max(0.0, self.length_m - self.project(e, n))

    def rollout_point(self, e: float, n: float, lookahead_m: float) -> Point:
        """Where a fixed-wing's recovery turn from (e, n) rolls out towards: ``lookahead_m`` along the path past
        the projection of (e, n) (:meth:`project`), with no chord test. Does not change ``progress_m``.

        The turn ends heading for the path a turn's length ahead, not for a point near the vehicle: a vertex
        a few metres away, or behind it, would have the turn swing round with every step (the margin scores
        this turn, :func:`geofence.margins.boundary_shift.activation_margins`, and the guidance flies it,
        :class:`geofence.recovery.guidance.FixedWingRecovery`). After the roll-out the guidance follows
        :meth:`lookahead_point`'s carrot, which does test its chord.
        """
        if len(self.points) > 1:
            args = self._kernel_arguments(e, n)
            if args is not None:
                P, Q, thr, c = args
                thr, ce, cn = path_rollout(self._rows, P, Q, self.progress_m, e, n, lookahead_m, thr, c)
                if thr > 0.0:
                    return (float(ce), float(cn))
        return self.point_at(self.project(e, n) + lookahead_m)

    def follow(self, e: float, n: float, lookahead_m: float) -> tuple[Point, float]:
        """``(carrot, remaining)``: :meth:`lookahead_point` (which advances ``progress_m``), then :meth:`remaining_m`
        from the advanced progress; one compiled call (:data:`~geofence.recovery.follower.path_follow`) as
        :meth:`project` is."""
        args = self._kernel_arguments(e, n)
        if args is not None:
            P, Q, thr, c = args
            thr, progress, ce, cn, s = path_follow(self._rows, P, Q, self.progress_m, e, n, lookahead_m, thr, c)
            if thr > 0.0:
                self.progress_m = float(progress)
                return (float(ce), float(cn)), max(0.0, self.length_m - float(s))
        carrot = self.lookahead_point(e, n, lookahead_m)
        return carrot, self.remaining_m(e, n)

    def constant_kernel_arguments(self) -> tuple | None:
        """:meth:`_kernel_arguments` where they do not depend on the position (a fence without an index), else
        None."""
        planner = self.planner
        return planner._follower_scan_arguments if planner._follower_scans else None

    def _kernel_arguments(self, e: float, n: float) -> tuple | None:
        """``(P, Q, thr, clearance)``: the planner's packed tables (:func:`~geofence.recovery.follower.follower_tables`)
        and the chord threshold of ``path_rollout`` and ``path_follow`` for a vehicle at (e, n). For a fence
        without an index ``thr`` is NaN: the compiled call finds :meth:`_exact_chord_threshold` itself (one call
        less per step; the planner keeps these arguments made). None: no positive threshold (certified chords)."""
        planner = self.planner
        if planner._follower_scans:
            return planner._follower_scan_arguments
        thr = self._exact_chord_threshold(e, n)
        return None if thr is None else (*planner._follower, thr, planner.clearance_m)

    def lookahead_point(self, e: float, n: float, lookahead_m: float) -> Point:
        """The carrot for a vehicle at (e, n): ``lookahead_m`` along the path past its projection.

        Advances ``progress_m`` to the projection. If the chord from (e, n) to
        the carrot is not safe (:meth:`RecoveryPlanner.chord_ok`: it would cut a
        corner), the next path vertex after the projection is returned instead,
        and if that chord is not safe either, the projection point itself. The
        returned point always lies on the path (so in the free space, except on
        the first leg). One compiled call (:data:`~geofence.recovery.follower.path_lookahead`) as
        :meth:`project` is.
        """
        thr = self._exact_chord_threshold(e, n)
        if thr is not None:
            s, ce, cn = path_lookahead(self._rows, *self.planner._follower, self.progress_m, e, n, lookahead_m, thr)
            if s > self.progress_m:
                self.progress_m = float(s)
            return (float(ce), float(cn))
        s = self.project(e, n)
        if s > self.progress_m:
            self.progress_m = s
        carrot = self.point_at(s + lookahead_m)
        m_v = self.planner.fence.lateral_margin_m(e, n)
        if self.planner.chord_ok((e, n), carrot, m_v):
            return carrot
        for i, c in enumerate(self.cum_m):
            if c > s + EPS_M:
                v = self.points[i]
                if self.planner.chord_ok((e, n), v, m_v):
                    return v
                break
        return self.point_at(s)
