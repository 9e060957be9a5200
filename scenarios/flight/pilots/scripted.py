"""The scripted ("adversarial") pilot: timed segments of raw sticks or blunt behaviours.

Used to provoke breaches: "fly course 090 at full speed", "climb at max",
"hold these sticks". Each segment lasts ``duration_s``; when the last one's
duration has passed the script has run to its end (every segment counted in
``items_reached``, ``finished`` set) and the pilot keeps flying it. Behaviours use the same navigation laws as the mission
autopilot but with saturated speed/climb demands.
"""

from __future__ import annotations

import math

import numpy as np

from geofence.geometry.geodesy import LocalFrame
from geofence.interface import Envelope, StickCommand, VehicleState
from geofence.physics.control_laws import airspeed_to_stick
from scenarios.definition.schema import ScriptSegment, SegmentEnd
from scenarios.flight.pilots import law_kernel as lk
from scenarios.flight.pilots.nav_laws import FixedWingNavigator, MultirotorNavigator

_CLIMB_STICK = {"hold": 0.0, "max": 1.0, "descend": -1.0}
END_TOLERANCE_STEPS = 0.5
"""The last segment has ended within half a step of its end time (a script whose segments sum to the
scenario's ``duration_s`` ends on the flight's last step, whose time is that sum within rounding)."""


class ScriptedPilot:
    """Flies its segments in order; a segment lasts ``duration_s`` or ends earlier on its ``end_on`` event.

    ``handback``: the geofence overrode the pilot during the segment and has handed control back (the pilot
    notices it through :meth:`notice_control`, as a pilot feels the sticks come back); ``reach``: the vehicle
    is within the radius of a point. After an event the later segments keep their durations from that moment.

    A raw-sticks segment and a fixed-wing's course are flown by its law array (:meth:`law_array`,
    :mod:`scenarios.flight.pilots.law_kernel`), which a compiled step of the closed loop flies itself after
    :meth:`decide`; a multirotor's velocity loop is its navigator's.
    """

    def __init__(
        self,
        segments: tuple[ScriptSegment, ...],
        env: Envelope,
        start: VehicleState,
        dt_s: float,
        frame: LocalFrame | None = None,
    ):
        self.segments = segments
        self.env = env
        self.dt_s = dt_s
        self._reach_en: list[tuple[float, float, float] | None] = []
        for seg in segments:
            if seg.reach is None:
                self._reach_en.append(None)
                continue
            if frame is None:
                raise ValueError("a segment with end_on: reach needs the flight's frame")
            e, n, _ = frame.to_enu(seg.reach[0], seg.reach[1], frame.h0_m)
            self._reach_en.append((e, n, seg.reach[2]))
        self._index = 0
        self._last = len(segments) - 1
        self._start_s = 0.0  # nominal start of the current segment (the sum of the earlier durations, or the event time)
        # when the current segment may end: its nominal end, and whether an event may end it earlier
        self._end_s = self._start_s + segments[0].duration_s if segments else 0.0
        self._on_event = bool(segments) and segments[0].end_on is not None
        self._in_control = True
        self._overridden = False  # the geofence took the sticks during the current segment
        self.mc = MultirotorNavigator(env) if env.is_multirotor else None
        self.fw = None if env.is_multirotor else FixedWingNavigator(env)
        self._hold_up_m = start.up_m
        self._hold_yaw_rad = start.yaw_rad
        # the current segment's demands (set by _start_segment)
        self._course_rad = 0.0
        self._speed_mps = 0.0
        self._v_en = (0.0, 0.0)
        self._v_up = 0.0
        self._sticks: StickCommand | None = None  # a raw-sticks segment's command (immutable: returned as is)
        self._climb_stick: float | None = None  # the fixed-wing climb stick (None: hold the height)
        self._hold_climb = True
        self._segment_index = -1
        self._law = lk.law_array()  # the current segment's law, where it has a compiled form (else GIVEN)
        self._law_flies = False  # (its kind is not GIVEN)
        self.finished = False  # the last segment's duration has passed: the script ran to its end

    @property
    def items_total(self) -> int:
        return len(self.segments)

    @property
    def items_reached(self) -> int:
        """The segments flown to their end: the earlier ones, and the last once its duration has passed."""
        if self.finished:
            return len(self.segments)
        i = self._segment_index
        return i if i > 0 else 0  # (-1 before the first command)

    def notice_control(self, in_control: bool) -> None:
        """Whether the pilot's sticks fly the aircraft this step (False while the geofence overrides them)."""
        if not in_control:
            self._overridden = True
        self._in_control = in_control

    def _event(self, seg: ScriptSegment, i: int, s: VehicleState) -> bool:
        if seg.end_on is SegmentEnd.HANDBACK:
            return self._overridden and self._in_control
        if seg.end_on is SegmentEnd.REACH:
            reach = self._reach_en[i]
            return reach is not None and math.hypot(s.east_m - reach[0], s.north_m - reach[1]) <= reach[2]
        return False

    def _segment_at(self, s: VehicleState) -> tuple[ScriptSegment, int]:
        last = self._last
        while self._index < last:
            seg = self.segments[self._index]
            if s.t_s >= self._start_s + seg.duration_s:
                self._start_s += seg.duration_s
            elif seg.end_on is not None and self._event(seg, self._index, s):
                self._start_s = s.t_s
            else:
                break
            self._index += 1
            self._overridden = False
        seg = self.segments[self._index]
        self._end_s = self._start_s + seg.duration_s
        self._on_event = seg.end_on is not None
        return seg, self._index

    def _start_segment(self, seg: ScriptSegment, s: VehicleState) -> None:
        """Latch the height and heading to hold, and the segment's fixed demands (once, not every step)."""
        self._hold_up_m = s.up_m
        self._hold_yaw_rad = s.yaw_rad
        self._sticks = StickCommand(*seg.sticks) if seg.sticks is not None else None
        self._hold_climb = seg.climb == "hold"
        self._climb_stick = None if self._hold_climb else _CLIMB_STICK[seg.climb]
        law = self._law
        lk.law_record(law).kind = lk.GIVEN
        self._latch_course(seg)
        if self._sticks is not None:  # raw sticks (they win)
            lk.hold_sticks(law, *self._sticks)
        self._law_flies = lk.law_kind(law) != lk.GIVEN

    def _latch_course(self, seg: ScriptSegment) -> None:
        """A course segment's demands (none for raw sticks), in the law array where it flies them."""
        if seg.course_deg is None:  # raw sticks
            return
        env = self.env
        self._course_rad = math.radians(seg.course_deg)
        self._speed_mps = {"max": env.max_speed_mps, "cruise": env.cruise_speed_mps, "min": env.min_speed_mps}[seg.speed]
        # multirotor: the ground velocity (E, N) and the climb rate (unless "hold": see command)
        self._v_en = (self._speed_mps * math.sin(self._course_rad), self._speed_mps * math.cos(self._course_rad))
        self._v_up = {"hold": 0.0, "max": env.max_climb_rate_mps, "descend": -env.max_descent_rate_mps}[seg.climb]
        fw = self.fw
        if fw is not None and fw.turn_commit_rad is None:  # (FixedWingNavigator.sticks the short way)
            lk.fly_course(
                self._law, self._course_rad, self._hold_up_m, self._climb_stick,
                airspeed_to_stick(self._speed_mps, env), fw.kh, fw.k_course, env,
            )  # fmt: skip

    def law_array(self) -> np.ndarray:
        """The current segment's law (:mod:`scenarios.flight.pilots.law_kernel`; kind ``GIVEN`` where its law has no
        compiled form), rewritten in place when a segment starts (in :meth:`decide`)."""
        return self._law

    def decide(self, s: VehicleState) -> StickCommand | None:
        """This step's decisions (a segment that ends, the next one's demands latched): the sticks where the
        segment's law has no compiled form (:meth:`command`'s), else None: :meth:`law_array` flies this step."""
        # per step: the segment's demands were latched when it started; it ends only at its end time or on its event
        # (and the last one never)
        if self._index < self._last and (s.t_s >= self._end_s or self._on_event):
            self._segment_at(s)
        if self._index == self._last and not self.finished and s.t_s >= self._end_s - END_TOLERANCE_STEPS * self.dt_s:
            self.finished = True  # the last segment's duration has passed (the pilot keeps flying it)
        if self._index != self._segment_index:
            self._segment_index = i = self._index
            self._start_segment(self.segments[i], s)
        if self._law_flies:
            return None
        if self.mc is not None:
            vz = self._v_up
            if self._hold_climb:
                env = self.env
                vz = max(-env.max_descent_rate_mps, min(env.max_climb_rate_mps, self._hold_up_m - s.up_m))
            ve, vn = self._v_en
            return self.mc.sticks_for_velocity(s, ve, vn, vz, self._hold_yaw_rad, self.dt_s)
        assert self.fw is not None  # not a multirotor
        return self.fw.sticks(s, self._course_rad, self._hold_up_m, self._speed_mps, self._climb_stick)

    def command(self, s: VehicleState) -> StickCommand:
        sticks = self.decide(s)
        if sticks is not None:
            return sticks
        # the law array's sticks, by the objects (law_kernel.law_sticks flies the same functions)
        if self._sticks is not None:  # a raw-sticks segment
            return self._sticks
        assert self.fw is not None  # a fixed-wing's course
        return self.fw.sticks(s, self._course_rad, self._hold_up_m, self._speed_mps, self._climb_stick)
