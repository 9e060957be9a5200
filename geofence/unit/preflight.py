"""Pre-flight mission check: will a planned route bring the activation margin to zero?

Autopilots check a mission against the fence at upload (is every waypoint
inside?). The geofence unit acts earlier than the fence line, at its
activation boundary, so a mission that merely stays inside can still be
overridden. This module flies the planned route *on paper* through the same
:func:`geofence.margins.boundary_shift.activation_margins` the unit uses in flight,
at the planned speed, in the expected wind (with the unit's turbulence and
gust allowance) and with the unit's nominal uncertainty margins, and reports
every leg, turn and loiter where the activation margin would fall below a
buffer. The goal: a mission that passes the check is never overridden.

What "on paper" means (the autopilot's flight, idealised):

* **legs**: straight from waypoint to waypoint at the planned speed (ground
  speed for a multirotor; airspeed for a fixed-wing, which crabs to hold the
  track in the wind); the height moves toward the next waypoint's at the
  platform's max climb or descent rate; sampled every ``step_m``;
* **fixed-wing turns**: the aircraft passes the waypoint, flies on for its
  roll-in (the envelope's ``reaction_time_s`` at its ground speed), then turns
  at its bank limit until its track is the next leg's: a circle of the bank
  limit's radius *in the air mass*, which drifts with the wind while it turns
  (a trochoid over the ground; the outside of the turn, where it sweeps toward
  the fence); sampled every 10 deg of heading; a turn of more than
  :data:`BOTH_WAYS_ABOVE_RAD` (120 deg) both ways round, as the navigator may take either;
* **fixed-wing loiters**: the orbit (clockwise, as the autopilot flies it) at
  ``max(radius, 1.5 R)`` around the loiter point, sampled every 10 deg; the
  last waypoint is one too: after its mission a fixed-wing orbits it (as
  ArduPlane and PX4 loiter at the last waypoint). Unchecked, a fixed-wing's orbit
  after a mission took it within the activation margin of a wall, overridden though it passed
  (case history: docs/campaigns.md#fresh-seeds-in-the-order-they-were-flown); it joins that orbit from the
  waypoint itself, outward along the autopilot's vector field (:func:`geofence.physics.control_laws.orbit_course_rad`,
  its default gain), so the join is checked too: every 10 deg at 0.25, 0.5, 0.75 and 0.9 of the radius, on
  the field's course there (any arrival direction). Unchecked, a fixed-wing joining the orbit outward
  from its last waypoint was overridden after its mission though it passed
  (case history: docs/campaigns.md#fresh-seeds-in-the-order-they-were-flown);
* a multirotor brakes to a stop at each waypoint; it is checked at full
  planned speed right up to the waypoint (conservative).

The expected wind is not what the unit will see. The forecast has its error (``forecast_speed_error``,
``forecast_direction_error_rad``: the true mean lies in an annular sector around it) and the unit's own
estimate in flight has its own (``wind_uncertainty_mps`` around the true mean): the route must pass for
every wind in that widened sector, sampled on its edge (:func:`winds_to_check`), and each stretch reports
its worst margin. Return must be assured against the strongest of them too. The unit reacts to data up to
``latency_s`` old (one control step plus the age of its newest GNSS fix), which it adds to its reaction
time in flight; the check adds the same.

Everything is in the fence's local ENU frame (m, m/s) and altitude reference.
Plain Python; a 20-leg mission in a 100-vertex fence checks in well under a
second.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Sequence

from geofence.geometry.local_fence import LocalFence
from geofence.interface import Envelope
from geofence.margins.boundary_shift import CompiledMargins
from geofence.physics.control_laws import orbit_course_rad
from geofence.physics.dynamics import return_not_assured
from geofence.physics.rooms import envelope_turn_radius_m

HEADING_STEP_RAD = math.radians(10.0)
BOTH_WAYS_ABOVE_RAD = math.radians(120.0)
"""A fixed-wing turn onto a leg more than this far from the incoming one is checked both ways round. The
navigator turns the way its course error points when it switches legs, and that error is not the legs'
angle: its vector field adds up to 60 deg of approach towards the new line (about 40 deg from an
acceptance radius's offset) and the crab adds the wind's. Near a reversal the way round is the flight's to
choose: a fixed-wing that turned the other way from the check was overridden in a mission that had passed
(case history: docs/campaigns.md#breach-classes-found-and-fixed). Checked on 183 campaign missions: beyond 150 deg (the
navigator's turn commitment) they were all caught too; 120 deg leaves 99 passing, 3 fewer."""


class RoutePart(str, Enum):
    """Where on the route a finding lies."""

    LEG = "leg"
    TURN = "turn"
    LOITER = "loiter"
    WIND = "wind"
    """The expected wind itself: return cannot be assured, so the unit lands at once (the whole route)."""


@dataclass(frozen=True)
class PlannedWaypoint:
    """One point of the planned route: ENU position (m), height in the fence's reference (m), optional loiter."""

    east_m: float
    north_m: float
    height_m: float
    label: str = ""
    loiter_radius_m: float = 0.0
    """> 0: the aircraft loiters here on a circle of (at least) this radius."""


@dataclass(frozen=True)
class PreflightFinding:
    """A stretch of the route where the activation margin falls below the buffer."""

    part: RoutePart
    index: int
    """Leg ``index`` goes from waypoint ``index`` to ``index + 1``; a turn or loiter is at waypoint ``index``."""
    label: str
    east_m: float
    north_m: float
    height_m: float
    activation_margin_m: float
    """The smallest activation margin on that stretch (m; <= buffer)."""
    reason: str
    """The binding constraint (lateral feature and edge, or vertical)."""

    def describe(self) -> str:
        if self.part is RoutePart.WIND:
            return f"expected wind: {self.reason}: the geofence would land at once instead of flying the mission"
        where = f"({self.east_m:.0f}, {self.north_m:.0f}) m ENU at {self.height_m:.0f} m"
        return f"{self.part.value} {self.label}: activation margin {self.activation_margin_m:.1f} m at {where}: {self.reason}"


@dataclass(frozen=True)
class _Sample:
    e: float
    n: float
    h: float
    ve: float
    vn: float
    vu: float


def _ground_velocity(env: Envelope, speed_mps: float, course_rad: float, wind_en: tuple[float, float]) -> tuple[float, float]:
    """Ground velocity (E, N) flying ``course_rad`` (math angle, counter-clockwise from east) at ``speed_mps``.

    Multirotor: the speed is the ground speed. Fixed-wing: the speed is the
    airspeed; the aircraft crabs so that its track is the course, and the
    ground speed is what the wind triangle leaves (at least 1 m/s).
    """
    ce, cn = math.cos(course_rad), math.sin(course_rad)
    if env.is_multirotor:
        return speed_mps * ce, speed_mps * cn
    we, wn = wind_en
    along = we * ce + wn * cn
    cross = -we * cn + wn * ce
    v_air_along2 = speed_mps * speed_mps - cross * cross
    gs = (math.sqrt(v_air_along2) if v_air_along2 > 0.0 else 0.0) + along
    gs = max(gs, 1.0)
    return gs * ce, gs * cn


def _vertical_rate(env: Envelope, h: float, h_goal: float) -> float:
    if h_goal > h + 0.5:
        return env.max_climb_rate_mps
    if h_goal < h - 0.5:
        return -env.max_descent_rate_mps
    return 0.0


def _leg_samples(env, a: PlannedWaypoint, b: PlannedWaypoint, speed: float, wind_en, step_m: float) -> list[_Sample]:
    de, dn = b.east_m - a.east_m, b.north_m - a.north_m
    length = math.hypot(de, dn)
    if length < 1e-6:
        return []
    course = math.atan2(dn, de)
    ve, vn = _ground_velocity(env, speed, course, wind_en)
    gs = math.hypot(ve, vn)
    k = max(1, int(math.ceil(length / step_m)))
    out = []
    h = a.height_m
    for i in range(k + 1):
        f = i / k
        # the height reached when flying at the platform's vertical rate from a's height toward b's
        t = f * length / gs
        vu = _vertical_rate(env, a.height_m, b.height_m)
        h = a.height_m + vu * t
        h = min(h, b.height_m) if vu > 0 else (max(h, b.height_m) if vu < 0 else h)
        out.append(_Sample(a.east_m + f * de, a.north_m + f * dn, h, ve, vn, _vertical_rate(env, h, b.height_m)))
    return out


def course_change_rad(prev: PlannedWaypoint, wp: PlannedWaypoint, nxt: PlannedWaypoint) -> float:
    """The route's course change at ``wp`` (rad, + = left, counter-clockwise; in [-pi, pi)): the leg out of it
    against the leg into it."""
    c_in = math.atan2(wp.north_m - prev.north_m, wp.east_m - prev.east_m)
    c_out = math.atan2(nxt.north_m - wp.north_m, nxt.east_m - wp.east_m)
    return (c_out - c_in + math.pi) % (2.0 * math.pi) - math.pi


def turn_samples(
    env, prev: PlannedWaypoint, wp: PlannedWaypoint, nxt: PlannedWaypoint, speed: float, wind_en, sign: float = 0.0
) -> list[_Sample]:
    """The fixed-wing's turn onto the next leg: past ``wp`` for its roll-in, then a circle in the drifting air mass.

    ``sign``: +1 left, -1 right (the long way round if that is not the short one); 0: the short way.

    Math angles (counter-clockwise from east). The air velocity turns at ``speed / r`` (``r``: the bank
    limit's radius at ``speed``) from the crab heading that held the incoming track, until the ground
    track (air velocity + wind) is the outgoing course; meanwhile the circle drifts with the wind.
    """
    c_in = math.atan2(wp.north_m - prev.north_m, wp.east_m - prev.east_m)
    delta = course_change_rad(prev, wp, nxt)
    if abs(delta) < HEADING_STEP_RAD:
        return []
    r = envelope_turn_radius_m(env, speed)
    s = sign if sign != 0.0 else (1.0 if delta > 0.0 else -1.0)
    if s * delta < 0.0:  # the long way round
        delta += s * 2.0 * math.pi
    we, wn = wind_en
    ge, gn = _ground_velocity(env, speed, c_in, wind_en)
    roll_in = env.reaction_time_s
    e0, n0 = wp.east_m + ge * roll_in, wp.north_m + gn * roll_in
    out = [_Sample(wp.east_m, wp.north_m, wp.height_m, ge, gn, 0.0)]
    psi0 = math.atan2(gn - wn, ge - we)  # the air velocity's heading on the incoming track
    omega = max(speed, 1e-3) / r
    track_prev = c_in
    turned = 0.0
    step = s * HEADING_STEP_RAD
    for i in range(int(round(2.0 * math.pi / HEADING_STEP_RAD)) + 1):
        psi = psi0 + step * i
        t = abs(psi - psi0) / omega
        e = e0 + we * t + s * r * (math.sin(psi) - math.sin(psi0))
        n = n0 + wn * t + s * r * (math.cos(psi0) - math.cos(psi))
        ve, vn = speed * math.cos(psi) + we, speed * math.sin(psi) + wn
        out.append(_Sample(e, n, wp.height_m, ve, vn, 0.0))
        track = math.atan2(vn, ve)
        turned += (track - track_prev + math.pi) % (2.0 * math.pi) - math.pi
        track_prev = track
        if s * turned >= abs(delta):
            break
    return out


def _loiter_samples(env, wp: PlannedWaypoint, speed: float, wind_en) -> list[_Sample]:
    r = max(wp.loiter_radius_m, 1.5 * envelope_turn_radius_m(env, speed))
    out = []
    k = int(round(2.0 * math.pi / HEADING_STEP_RAD))
    for i in range(k):
        a = 2.0 * math.pi * i / k
        e, n = wp.east_m + r * math.cos(a), wp.north_m + r * math.sin(a)
        course = a - 0.5 * math.pi  # clockwise orbit: the track is the radius turned right
        ve, vn = _ground_velocity(env, speed, course, wind_en)
        out.append(_Sample(e, n, wp.height_m, ve, vn, 0.0))
    return out


ORBIT_JOIN_RADII = (0.25, 0.5, 0.75, 0.9)
"""Where (fractions of the orbit's radius) the join from the last waypoint out to its orbit is checked."""


def _orbit_join_samples(env, wp: PlannedWaypoint, speed: float, wind_en) -> list[_Sample]:
    """The join from a waypoint out onto its clockwise orbit: the vector field's course at points inside the
    circle, every 10 deg at each of :data:`ORBIT_JOIN_RADII` (the arrival direction is not known here)."""
    r = max(wp.loiter_radius_m, 1.5 * envelope_turn_radius_m(env, speed))
    out = []
    k = int(round(2.0 * math.pi / HEADING_STEP_RAD))
    for frac in ORBIT_JOIN_RADII:
        for i in range(k):
            a = 2.0 * math.pi * i / k
            e, n = wp.east_m + frac * r * math.cos(a), wp.north_m + frac * r * math.sin(a)
            compass, _ = orbit_course_rad(e, n, wp.east_m, wp.north_m, r)  # clockwise from north
            ve, vn = _ground_velocity(env, speed, 0.5 * math.pi - compass, wind_en)
            out.append(_Sample(e, n, wp.height_m, ve, vn, 0.0))
    return out


def winds_to_check(
    forecast_en: tuple[float, float],
    estimate_error_mps: float = 0.0,
    speed_error: float = 0.0,
    direction_error_rad: float = 0.0,
) -> list[tuple[float, float]]:
    """The winds (E, N m/s) a route is checked in: the forecast first, then the edge of what the unit may estimate.

    A forecast ``f`` that is within ``speed_error`` (a fraction) of the true mean wind's speed and within
    ``direction_error_rad`` of its direction leaves the true mean in an annular sector around ``f``: speeds
    ``|f| / (1 + e)`` to ``|f| / (1 - e)``, bearings ``±d``. In flight the unit's estimate is within
    ``estimate_error_mps`` of that mean. The set of winds it may hold is the sector widened by that radius;
    the check samples its edge: the far arc at five bearings, the four corners pushed out sideways, the near
    arc, and (with no forecast error) the ring of eight winds around ``f``.
    """
    fe, fn = float(forecast_en[0]), float(forecast_en[1])
    speed = math.hypot(fe, fn)
    r = max(float(estimate_error_mps), 0.0)
    out = [(fe, fn)]
    if speed <= 0.0 or (speed_error <= 0.0 and direction_error_rad <= 0.0):
        if r > 0.0:
            out += [(fe + r * math.cos(a), fn + r * math.sin(a)) for a in (i * math.pi / 4.0 for i in range(8))]
        return out
    e = min(max(speed_error, 0.0), 0.9)
    d = min(max(direction_error_rad, 0.0), math.pi)
    bearing = math.atan2(fn, fe)  # math angle of the vector (E = x, N = y)
    lo, hi = speed / (1.0 + e), speed / (1.0 - e)

    def at(v: float, a: float, push: float = 0.0, side: float = 0.0) -> tuple[float, float]:
        # speed v at angle bearing + a, pushed `push` m/s outward (side 0: along it; side ±1: across it)
        th = bearing + a
        ue, un = math.cos(th), math.sin(th)
        if side:
            pe, pn = -un * side, ue * side
        else:
            pe, pn = ue, un
        return (v * ue + push * pe, v * un + push * pn)

    out += [at(hi, f * d, r) for f in (-1.0, -0.5, 0.0, 0.5, 1.0)]
    out += [at(v, s * d, r, s) for v in (lo, hi) for s in (-1.0, 1.0)]
    out.append(at(max(lo - r, 0.0), 0.0))
    return out


def check_route(
    fence: LocalFence,
    env: Envelope,
    waypoints: Sequence[PlannedWaypoint],
    speed_mps: float,
    *,
    wind_en: tuple[float, float] = (0.0, 0.0),
    wind_uncertainty_mps: float = 0.0,
    forecast_speed_error: float = 0.0,
    forecast_direction_error_rad: float = 0.0,
    wind_extra_mps: float = 0.0,
    turbulence_sigma_mps: float = 0.0,
    h_uncertainty_m: float = 0.0,
    v_uncertainty_m: float = 0.0,
    latency_s: float = 0.0,
    buffer_m: float = 0.0,
    step_m: float = 5.0,
) -> list[PreflightFinding]:
    """Every leg, turn and loiter of the route whose activation margin falls to ``buffer_m`` or below.

    ``speed_mps``: the planned speed (multirotor ground speed, fixed-wing
    airspeed). ``wind_en``: the expected mean wind (E, N m/s, toward); ``forecast_speed_error`` and
    ``forecast_direction_error_rad``: how far the true mean may be from it; ``wind_uncertainty_mps``: how far
    the wind the unit will estimate may be from the true mean (:func:`winds_to_check`); ``wind_extra_mps``, ``h_uncertainty_m``, ``v_uncertainty_m``: the same
    allowances the unit adds in flight (``turbulence_sigma_mps``: the forecast's σ behind
    ``wind_extra_mps``). One finding per offending stretch, with its smallest margin. An empty
    list means the route passes. When the expected wind is beyond what the platform can be sure
    to fly back against (:func:`geofence.physics.dynamics.return_not_assured`), the unit lands as soon as
    it flies: the one finding is then the wind itself.
    """
    findings: list[PreflightFinding] = []
    wps = list(waypoints)
    winds = winds_to_check(wind_en, wind_uncertainty_mps, forecast_speed_error, forecast_direction_error_rad)
    why = return_not_assured(max(math.hypot(*w) for w in winds), turbulence_sigma_mps, env)
    if why is not None and wps:
        w0 = wps[0]
        return [PreflightFinding(RoutePart.WIND, 0, "forecast", w0.east_m, w0.north_m, w0.height_m, -math.inf, why)]

    compiled = CompiledMargins(fence, env)  # (activation_margins with the fence's tables bound once)

    def score(sample_sets: list[tuple[tuple[float, float], list[_Sample]]], part: RoutePart, index: int, label: str) -> None:
        worst = None
        for wind, samples in sample_sets:
            for p in samples:
                r = compiled.margins(
                    p.e, p.n, p.h, p.ve, p.vn, p.vu, wind[0], wind[1], h_uncertainty_m, v_uncertainty_m, latency_s,
                    0.0, wind_extra_mps, None,
                )  # fmt: skip
                if worst is None or r.activation_margin_m < worst[0].activation_margin_m:
                    worst = (r, p)
        if worst is None or worst[0].activation_margin_m > buffer_m:
            return
        r, p = worst
        if r.lateral_activation_m <= r.vertical_activation_m:
            reason = f"{r.feature} edge {r.edge} needs {r.lateral_shift_m:.1f} m, has {r.edge_distance_m:.1f} m"
        else:
            reason = (
                f"vertical: ceiling margin {r.ceiling_margin_m:.1f} m (needs {r.ceiling_shift_m:.1f}), "
                f"floor margin {r.floor_margin_m:.1f} m (needs {r.floor_shift_m:.1f})"
            )
        findings.append(PreflightFinding(part, index, label, p.e, p.n, p.h, r.activation_margin_m, reason))

    for i in range(len(wps) - 1):
        a, b = wps[i], wps[i + 1]
        legs = [(w, _leg_samples(env, a, b, speed_mps, w, step_m)) for w in winds]
        score(legs, RoutePart.LEG, i, f"{a.label or i} -> {b.label or i + 1}")
        if not env.is_multirotor and 0 < i + 1 < len(wps) - 1:
            c = wps[i + 2]
            signs = (1.0, -1.0) if abs(course_change_rad(a, b, c)) > BOTH_WAYS_ABOVE_RAD else (0.0,)
            turns = [(w, turn_samples(env, a, b, c, speed_mps, w, sign)) for w in winds for sign in signs]
            score(turns, RoutePart.TURN, i + 1, b.label or str(i + 1))
    if not env.is_multirotor:
        for i, wp in enumerate(wps):
            last = i == len(wps) - 1
            if wp.loiter_radius_m > 0.0 or last:  # the last: the orbit after the mission, joined from the waypoint
                orbit = []
                for w in winds:
                    samples = _loiter_samples(env, wp, speed_mps, w)
                    if last:
                        samples += _orbit_join_samples(env, wp, speed_mps, w)
                    orbit.append((w, samples))
                score(orbit, RoutePart.LOITER, i, wp.label or str(i))
    return findings
