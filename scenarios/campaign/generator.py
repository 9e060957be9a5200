"""The efficacy campaign generator: random fences nobody tuned for, flown three ways.

:func:`generate_campaign` writes one scenario YAML per flight (the ordinary
scenario format: ``geofence-testbed batch <dir>`` flies them) and a
``campaign.json`` manifest, all reproducible from one seed. Each *case* is a
random fence at a random site, a platform, a wind and a pilot, built by one
:class:`CaseFamily` (a function of a numpy RNG returning the scenario
mapping). Every case is written three times (:class:`Variant`):

* ``<case_id>__predictive.yaml``: ``geofence.trigger: predictive``;
* ``<case_id>__reactive.yaml``: ``geofence.trigger: reactive`` (the seed work's baseline);
* ``<case_id>__unprotected.yaml``: no ``geofence:`` block at all (the
  "unprotected twin": the same flight with nothing in the loop).

The runner scores a flight only when a geofence is configured, so the twin's
fence lives in the manifest (``cases[i].fence``, the exact ``geofence.fence``
mapping of its protected siblings, and ``cases[i].start``, whose point is the
runner's ENU origin); :mod:`analysis.campaign_report` scores the twin's
``trajectory.csv`` against it with :func:`analysis.scoring.score_flight`.
Nothing in the twin's scenario hints at a fence, so it flies exactly as the
pilot would without one.

Sizes are scaled to the platform's declared envelope
(:func:`aircraft.profile.load_profile`): the *room* a platform needs is its
max-bank turn radius at cruise ``V^2/(g tan(bank))`` (fixed-wing) or its
stopping distance from top speed ``v t_r + v^2/(2 a)`` (multirotor), and the
allowed area's inradius is several times the larger of that room and the
geofence's worst-case lateral shift in the case's design wind
(:func:`geofence.physics.rooms.worst_case_lateral_shift_m`). A fence that
would not fit (wider than :data:`MAX_FENCE_SPAN_M`, or an infinite shift)
makes the case skip that platform and try the next one.

Families take turns (:func:`case_family`). Besides the scripted attacks, a lateral family (the keep-in
shapes, the corridor and the ``keep_in_circle``) may fly the ``breach_attempts`` pilot: 2-4 bearings from
a legal home at points on the keep-in boundary (head-on and shallow), optionally ``up``; a keep-out may be
a building (``ceiling_m`` of its own). Features added after campaigns had been published draw from a
child generator (:func:`_added_rng`), so the cases that do not use them stay as they were.

The geofence is told a forecast (``wind_prior``) as an operator gets one: the mean wind within
±20 % and ±20° (the error the pre-flight check allows for, :data:`scenarios.definition.preflight.FORECAST_SPEED_ERROR`
and :data:`~scenarios.definition.preflight.FORECAST_DIRECTION_ERROR_DEG`), and the turbulence sigma at the start height and the strongest gust, each within
±20 %, when the case has them.

Each case's manifest also says whether the wind is within the platform's *authority*
(:func:`wind_authority`): the mean wind at the start height plus one Dryden sigma there (the
scenario's own turbulence, by its MIL-F-8785C definition) tested with the same rule the unit applies
to a forecast it is told (:func:`geofence.physics.dynamics.return_not_assured`). A case beyond it is one no
controller can fly back against for long; the report counts its breaches apart and checks that the
unit landed instead. The ``design_wind_mps`` (steady + gust + 1.5 rough sigma) only sizes the fence.

Every written document is re-read from its YAML text and validated with
:func:`scenarios.definition.schema.parse_scenario`; a rejected document is a generator
bug and raises :class:`CampaignError`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from aircraft.profile import PlatformProfile, available_profiles, load_profile
from aircraft.sensors import SensorConfig
from geofence.geometry.fence import circle_to_polygon, parse_fence
from geofence.geometry.geodesy import LocalFrame
from geofence.geometry.local_fence import LocalFence
from geofence.geometry.polygon import PolygonIndex, self_intersections
from geofence.margins.boundary_shift import activation_margins
from geofence.physics.dynamics import envelope_at_density, isa_density_ratio, return_not_assured
from geofence.physics.rooms import multicopter_stopping_distance_m, turn_radius_m, worst_case_lateral_shift_m
from geofence.unit.config import GeofenceConfig
from geofence.validation import ConfigError
from scenarios.airspace.generate import park_boundary_en, place_buildings
from scenarios.definition.preflight import FORECAST_DIRECTION_ERROR_DEG, FORECAST_SPEED_ERROR
from scenarios.definition.schema import BREACH_SPEED_LIMIT_MPS, PilotKind
from wind.config import parse_wind
from wind.dryden import dryden_scales

MANIFEST = "campaign.json"
MAX_FENCE_SPAN_M = 9_000.0
"""Largest keep-in extent generated (the fence model is exact to < 3 mm up to 10 km across)."""
DEFAULT_MAX_DURATION_S = 180.0
MISSION_INSET_ROOMS = 3.0
"""Normal missions keep every waypoint and leg this many rooms inside every boundary."""
GPS_FAULT_PROBABILITY = 0.04
WIND_LIMIT_MULTIROTOR = 0.7
"""Wind (steady + gust) up to this fraction of a multirotor's top speed."""
WIND_LIMIT_FIXED_WING = 0.5
"""Wind (steady + gust) up to this fraction of a fixed-wing's cruise airspeed."""
TURBULENCE_SIGMA_MPS = {"none": 0.0, "light": 0.8, "moderate": 1.6}
"""Rough low-level Dryden sigma per severity, only to size the design wind (and so the fence; kept as it
was so that published campaigns regenerate). The authority test uses the real sigma (:func:`wind_authority`)."""


class CampaignError(RuntimeError):
    """The generator produced something the scenario schema rejects: a bug here, not bad user input.

    Bad arguments to :func:`generate_cases` / :func:`generate_campaign` are user input and raise
    :class:`~geofence.validation.ConfigError` instead.
    """


class CaseFamily(Enum):
    """What a case tests: the fence shape or feature, and the pilots that go with it."""

    CONVEX_BOX = "box"
    L_FENCE = "l_fence"
    U_FENCE = "u_fence"
    STAR = "star"
    ACUTE_CORNER = "acute"
    CORRIDOR = "corridor"
    KEEP_OUT = "keep_out"
    CEILING = "ceiling"
    FLOOR_GAPS = "floor_gaps"
    CIRCLE = "circle"
    """A circular keep-in (``keep_in_circle``), flown against with the lateral attacks (head-on is radial)."""
    CITY = "city"
    """An airspace-scale fence (:func:`family_city`): a ragged park boundary of thousands of vertices and
    hundreds of building keep-outs. Not among the :data:`DEFAULT_FAMILIES` (its flights cost more): asked for by
    name (``campaign generate --families city``)."""
    RANDOM = "random"
    """A random polygon (:func:`family_random`): a simple keep-in of 5-40 vertices at random angles and
    radii (notches, spikes, acute and reflex corners mixed), often with keep-outs scattered in the way back.
    Not among the :data:`DEFAULT_FAMILIES` (added after campaigns had been published, whose cases keep their
    families): asked for by name (``campaign generate --families random``)."""


class Attack(Enum):
    """The pilot of a case."""

    HEAD_ON = "head_on"
    SHALLOW = "shallow"
    CORNER = "corner"
    TURNING = "turning"
    REPEATED = "repeated"
    CLIMB = "climb"
    DESCEND = "descend"
    GAP_DESCENT_DASH = "gap_descent_dash"
    GAP_TAKEOFF = "gap_takeoff"
    INTO_KEEP_OUT = "into_keep_out"
    BEHIND_KEEP_OUT = "behind_keep_out"
    MISSION = "mission"
    BREACH_ATTEMPTS = "breach_attempts"
    """The ``breach_attempts`` pilot: repeated pushes from home at points on the keep-in boundary."""


class Variant(Enum):
    """The three flights of every case."""

    PREDICTIVE = "predictive"
    REACTIVE = "reactive"
    UNPROTECTED = "unprotected"


LATERAL_ATTACKS = (
    Attack.HEAD_ON,
    Attack.SHALLOW,
    Attack.CORNER,
    Attack.TURNING,
    Attack.REPEATED,
    Attack.MISSION,
    Attack.BREACH_ATTEMPTS,
)
LATERAL_WEIGHTS = (3.0, 2.0, 2.0, 2.0, 2.0, 2.0, 1.5)
ADDED_LATERAL_ATTACKS = 1
"""How many of :data:`LATERAL_ATTACKS` (the last ones) were added after campaigns had been published
(see :func:`_pick_keeping`)."""
CIRCLE_ATTACKS = tuple(a for a in LATERAL_ATTACKS if a is not Attack.CORNER)
"""A circle has no corner worth the name (its polygon's vertices turn by 360/n deg)."""
CIRCLE_WEIGHTS = tuple(w for a, w in zip(LATERAL_ATTACKS, LATERAL_WEIGHTS) if a is not Attack.CORNER)
BUILDING_PROBABILITY = 0.3
"""A keep-out is a building (``ceiling_m`` of its own, above the flight height) with this probability."""
BREACH_PUSH_FACTOR = 1.3
"""A breach attempt's ``push_m``: this times the distance to the farthest targeted boundary point."""
BREACH_REST_S = 3.0
BREACH_UP_PROBABILITY = 0.3
"""A breach-attempts case also pushes ``up`` (toward the ceiling) with this probability."""
BREACH_ORBIT_TURN_RADII, BREACH_MIN_ORBIT_RADIUS_M = 1.5, 30.0
"""The fixed-wing breach pilot's home orbit: this many turn radii at cruise, at least this (m); as in
:mod:`scenarios.flight.pilots.breach_attempts_fixedwing`, which this layer may not import."""
BREACH_SETTLE_S = 3.0
"""A multirotor breach pilot's settling in its home hover before the first push (s, estimate)."""

SITES: tuple[tuple[str, tuple[float, float], tuple[float, float]], ...] = (
    # (continent, (lat lo, hi), (lon lo, hi)): boxes on land, incl. +-60 deg and beyond
    ("north_america", (25.0, 62.0), (-124.0, -70.0)),
    ("north_america_arctic", (60.0, 70.0), (-165.0, -140.0)),
    ("south_america", (-55.0, 10.0), (-78.0, -40.0)),
    ("europe", (36.0, 70.0), (-9.0, 30.0)),
    ("africa", (-34.0, 35.0), (-17.0, 50.0)),
    ("asia", (5.0, 65.0), (60.0, 140.0)),
    ("oceania", (-45.0, -10.0), (113.0, 178.0)),
    ("antarctica", (-78.0, -60.0), (-179.0, 179.0)),
)
MAX_GROUND_ALT_M = 2800.0


# --------------------------------------------------------------------------- case context
@dataclass(frozen=True)
class CaseContext:
    """Everything a family needs: platform, site, wind and the sizes derived from them (SI)."""

    platform: str
    profile: PlatformProfile
    site: dict
    wind: dict
    design_wind_mps: float
    room_m: float
    """One turn (fixed-wing, radius at cruise and max bank) or one stop from top speed (multirotor)."""
    shift_m: float
    """The geofence's worst-case lateral shift in the design wind."""
    max_duration_s: float
    gps_fault: dict | None

    @property
    def multirotor(self) -> bool:
        return self.profile.envelope.is_multirotor

    @property
    def frame(self) -> LocalFrame:
        return LocalFrame(self.site["lat_deg"], self.site["lon_deg"], self.site["ground_alt_m"])

    @property
    def speed_max_mps(self) -> float:
        return self.profile.envelope.max_speed_mps

    def target_inradius_m(self, rng: np.random.Generator, low: float = 1.0) -> float:
        """An allowed-area inradius 'several times' the room (and beyond the worst-case shift)."""
        return max(rng.uniform(3.0, 6.0) * self.room_m, rng.uniform(1.4, 2.5) * self.shift_m) * low


class _DoesNotFit(Exception):
    """This case's fence does not fit this platform: try the next platform."""


def platform_room_m(profile: PlatformProfile) -> float:
    """One turn radius (fixed-wing, cruise at max bank) or one stop from top speed (multirotor), m."""
    env = profile.envelope
    if env.is_multirotor:
        return multicopter_stopping_distance_m(env.max_speed_mps, env.reaction_time_s, env.braking_decel_mps2)
    return turn_radius_m(env.cruise_speed_mps, env.max_bank_rad)


def wind_limit_mps(profile: PlatformProfile) -> float:
    env = profile.envelope
    return WIND_LIMIT_MULTIROTOR * env.max_speed_mps if env.is_multirotor else WIND_LIMIT_FIXED_WING * env.cruise_speed_mps


# --------------------------------------------------------------------------- geometry helpers
def _rot(points: np.ndarray, angle_rad: float) -> np.ndarray:
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return points @ np.array([[c, s], [-s, c]])


def _scaled(unit: Sequence[Sequence[float]] | np.ndarray, inradius_m: float, rng: np.random.Generator) -> np.ndarray:
    """A unit shape scaled to ``inradius_m``, centred on its pole, rotated at random."""
    p = np.asarray(unit, dtype=float)
    e, n, r = PolygonIndex(p).inradius(precision_m=1e-3)
    p = (p - [e, n]) * (inradius_m / r)
    return _rot(p, rng.uniform(0.0, 2.0 * math.pi))


def _course_deg(vec: Sequence[float] | np.ndarray) -> float:
    return math.degrees(math.atan2(vec[0], vec[1])) % 360.0


def _unit(deg: float) -> np.ndarray:
    r = math.radians(deg)
    return np.array([math.sin(r), math.cos(r)])


def _r(x: float, nd: int = 2) -> float:
    return round(float(x), nd)


def _ll(frame: LocalFrame, points: np.ndarray) -> list[list[float]]:
    out = []
    for e, n in np.atleast_2d(points):
        lat, lon, _ = frame.to_geodetic(float(e), float(n), 0.0)
        out.append([round(lat, 8), round(lon, 8)])
    return out


@dataclass
class FenceDraft:
    """A fence being built in the site's ENU frame (metres).

    ``keep_in`` is always a polygon (span, planning); with ``keep_in_circle`` (``(e, n, radius)``, made by
    :meth:`circle`) it is that circle's inscribed polygon as the unit builds it, and :meth:`mapping` writes
    ``keep_in_circle`` instead. ``keep_out_polygon_ceilings`` / ``keep_out_circle_ceilings`` (by index; a
    missing or None entry: full height) give a keep-out its own ``ceiling_m`` (a building).
    """

    keep_in: np.ndarray
    ceiling_m: float
    floor_m: float | None = None
    floor_gaps: tuple[np.ndarray, ...] = ()
    keep_out_polygons: tuple[np.ndarray, ...] = ()
    keep_out_circles: tuple[tuple[float, float, float], ...] = ()
    keep_in_circle: tuple[float, float, float] | None = None
    keep_out_polygon_ceilings: tuple[float | None, ...] = ()
    keep_out_circle_ceilings: tuple[float | None, ...] = ()

    @classmethod
    def circle(cls, frame: LocalFrame, e: float, n: float, radius_m: float, ceiling_m: float) -> FenceDraft:
        """A circular keep-in centred at ``(e, n)``; ``keep_in`` is its polygon (:func:`circle_to_polygon`) as written."""
        lat, lon = _ll(frame, np.array([[e, n]]))[0]
        verts = circle_to_polygon(lat, lon, _r(radius_m, 1))[0]
        poly = np.array([frame.to_enu(la, lo, frame.h0_m)[:2] for la, lo in verts])
        return cls(poly, ceiling_m, keep_in_circle=(float(e), float(n), float(radius_m)))

    def span_m(self) -> float:
        v = self.keep_in
        return float(max(np.ptp(v[:, 0]), np.ptp(v[:, 1])))

    def mapping(self, frame: LocalFrame) -> dict:
        m: dict[str, Any]
        if self.keep_in_circle is not None:
            e, n, r = self.keep_in_circle
            m = {"keep_in_circle": {"center": _ll(frame, np.array([[e, n]]))[0], "radius_m": _r(r, 1)}}
        else:
            m = {"keep_in": _ll(frame, self.keep_in)}
        m["ceiling_m"] = _r(self.ceiling_m, 1)
        if self.floor_m is not None:
            m["floor_m"] = _r(self.floor_m, 1)
        if self.floor_gaps:
            m["floor_gaps"] = [_ll(frame, g) for g in self.floor_gaps]
        if self.keep_out_polygons:
            m["keep_out_polygons"] = []
            for i, k in enumerate(self.keep_out_polygons):
                top = _at(self.keep_out_polygon_ceilings, i)
                m["keep_out_polygons"].append(
                    _ll(frame, k) if top is None else {"polygon": _ll(frame, k), "ceiling_m": _r(top, 1)}
                )
        if self.keep_out_circles:
            m["keep_out_circles"] = []
            for i, (e, n, r) in enumerate(self.keep_out_circles):
                c: dict[str, Any] = {"center": _ll(frame, np.array([[e, n]]))[0], "radius_m": _r(r, 1)}
                top = _at(self.keep_out_circle_ceilings, i)
                if top is not None:
                    c["ceiling_m"] = _r(top, 1)
                m["keep_out_circles"].append(c)
        return m

    def local(self, frame: LocalFrame) -> LocalFence:
        """The fence as the unit will see it (validated; lat/lon rounded as written), cached per mapping."""
        mapping = self.mapping(frame)
        key = json.dumps([frame.lat0_deg, frame.lon0_deg, frame.h0_m, mapping], sort_keys=True)
        if key not in _LOCAL_CACHE:
            _LOCAL_CACHE.clear()
            _LOCAL_CACHE[key] = parse_fence(mapping, "campaign").to_local(frame)
        return _LOCAL_CACHE[key]


_LOCAL_CACHE: dict[str, LocalFence] = {}


def _at(xs: Sequence[float | None], i: int) -> float | None:
    return xs[i] if i < len(xs) else None


# --------------------------------------------------------------------------- pilots
@dataclass
class Plan:
    """A pilot plan in local metres: start point, heading, height, segments, duration."""

    start_en: np.ndarray
    heading_deg: float
    agl_m: float
    segments: list[dict]
    approach_s: float
    duration_s: float
    mission: dict | None = None
    pilot: dict | None = None
    """The ``pilot:`` block (``type`` included) when it is not a scripted one (the segments are then unused)."""


def _approach_speed(ctx: CaseContext, speed: str = "max") -> float:
    env = ctx.profile.envelope
    v = {"max": env.max_speed_mps, "cruise": env.cruise_speed_mps, "min": env.min_speed_mps}[speed]
    if env.is_multirotor:  # it starts from a hover: average over the run-up
        v = max(0.6 * v, 2.0)
    return max(v, 1.0)


def _segment_ok(local: LocalFence, a: np.ndarray, b: np.ndarray, min_margin_m: float, skip_end_m: float = 0.0) -> bool:
    """Every point of a->b (but the last ``skip_end_m``) at least ``min_margin_m`` inside."""
    length = float(np.hypot(*(b - a)))
    n = max(2, int(length / max(local.inradius()[2] / 20.0, 1.0)) + 1)
    for s in np.linspace(0.0, 1.0, n):
        if s * length > length - skip_end_m and skip_end_m > 0.0:
            break
        p = a + s * (b - a)
        if local.lateral_margin_m(float(p[0]), float(p[1])) < min_margin_m:
            return False
    return True


def _run_up(
    rng: np.random.Generator, ctx: CaseContext, local: LocalFence, target: np.ndarray, course_deg: float, speed: str = "max"
) -> tuple[np.ndarray, float]:
    """A start point behind ``target`` on ``course_deg`` with the path inside; (start, approach time s).

    Prefers a start beyond the activation distance (so the pilot, not the start, provokes the override)
    and an approach time that leaves room for the recovery within the case's duration.
    """
    v = _approach_speed(ctx, speed)
    u = _unit(course_deg)
    r_in = local.inradius()[2]
    want = min(1.3 * ctx.shift_m, 0.8 * r_in)
    longest = max(v * (ctx.max_duration_s * 0.55), 1.0)
    best: tuple[float, np.ndarray, float] | None = None
    for _ in range(30):
        d = min(rng.uniform(1.2, 3.0) * max(ctx.shift_m, ctx.room_m), longest)
        d = max(d, 0.5 * want)
        start = target - d * u
        m = local.lateral_margin_m(float(start[0]), float(start[1]))
        if m <= 0.0 or not _segment_ok(local, start, target, 0.0, skip_end_m=0.3 * d):
            continue
        score = min(m, want)
        if best is None or score > best[0]:
            best = (score, start, d)
        if m >= want:
            break
    if best is None:  # walk back from the pole along the course line
        e, n, _ = local.inradius()
        start = np.array([e, n])
        d = float(np.hypot(*(target - start)))
        return start, d / v
    return best[1], best[2] / v


def _duration(ctx: CaseContext, approach_s: float, rng: np.random.Generator) -> float:
    env = ctx.profile.envelope
    turn_s = 0.0 if env.is_multirotor else math.pi * ctx.room_m / env.cruise_speed_mps
    want = approach_s + turn_s + rng.uniform(15.0, 30.0)
    return _r(min(want, ctx.max_duration_s), 1)


def _edge_targets(local: LocalFence, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, int]:
    """A random point on a random keep-in edge (weighted by length), the edge's outward normal, its index."""
    ki = local.keep_in
    w = ki.lengths / ki.lengths.sum()
    i = int(rng.choice(len(w), p=w))
    p = ki.starts[i] + rng.uniform(0.15, 0.85) * (ki.ends[i] - ki.starts[i])
    return p, ki.outward_normals[i], i


def _plan_lateral(
    rng: np.random.Generator, ctx: CaseContext, local: LocalFence, attack: Attack, agl_m: float, corner: int | None = None
) -> Plan:
    ki = local.keep_in
    speed = "max" if rng.random() < 0.7 else "cruise"
    if attack is Attack.CORNER:
        # a convex vertex (interior angle < 180 deg), aimed along its outward bisector
        v = ki.vertices
        k = len(v)
        convex = [j for j in range(k) if _is_convex_vertex(v, j, ki.ccw)]
        j = corner if corner is not None else int(rng.choice(convex))
        n_prev, n_next = ki.outward_normals[(j - 1) % k], ki.outward_normals[j]
        bis = n_prev + n_next
        bis = bis / np.hypot(*bis)
        course = _course_deg(bis) + rng.uniform(-10.0, 10.0)
        target = v[j]
    elif attack is Attack.SHALLOW:
        p, normal, i = _edge_targets(local, rng)
        along = ki.directions[i] * (1.0 if rng.random() < 0.5 else -1.0)
        a = math.radians(rng.uniform(10.0, 30.0))
        vec = math.cos(a) * along + math.sin(a) * normal
        course, target = _course_deg(vec), p
    else:
        p, normal, _ = _edge_targets(local, rng)
        course, target = _course_deg(normal) + float(rng.uniform(-5.0, 5.0)), p
    if attack is Attack.REPEATED:
        e, n, _ = local.inradius()
        start = np.array([e, n])
        v_run = _approach_speed(ctx, speed)
        segs: list[dict[str, Any]] = []
        t_total = 0.0
        for _ in range(int(rng.integers(3, 6))):
            p, normal, _ = _edge_targets(local, rng)
            c = _course_deg(p - start)
            push = float(np.hypot(*(p - start))) / v_run * float(rng.uniform(0.9, 1.4))
            back = float(rng.uniform(3.0, 8.0))
            segs += [
                {"duration_s": _r(push, 1), "course_deg": _r(c, 1), "speed": speed, "climb": "hold"},
                {"duration_s": _r(back, 1), "course_deg": _r((c + 180.0) % 360.0, 1), "speed": "cruise", "climb": "hold"},
            ]
            t_total += push + back
        first = segs[0]["course_deg"]
        approach = segs[0]["duration_s"]
        return Plan(start, first, agl_m, segs, approach, _r(min(t_total + 10.0, ctx.max_duration_s), 1))
    course = course % 360.0
    start, approach = _run_up(rng, ctx, local, np.asarray(target, float), course, speed)
    duration = _duration(ctx, approach, rng)
    if attack is Attack.TURNING:
        straight = _r(max(approach * rng.uniform(0.4, 0.8), 1.0), 1)
        side = 1.0 if rng.random() < 0.5 else -1.0
        if ctx.multirotor:
            sticks = {
                "roll": _r(side * rng.uniform(0.2, 0.6)),
                "pitch": _r(-rng.uniform(0.5, 1.0)),
                "yaw": _r(side * rng.uniform(0.1, 0.4)),
                "throttle": 0.0,
            }
        else:
            sticks = {"roll": _r(side * rng.uniform(0.4, 1.0)), "pitch": 0.0, "yaw": 0.0, "throttle": 1.0}
        segs = [
            {"duration_s": straight, "course_deg": _r(course, 1), "speed": speed, "climb": "hold"},
            {"duration_s": _r(max(duration - straight, 1.0), 1), "sticks": sticks},
        ]
    else:
        segs = [{"duration_s": duration, "course_deg": _r(course, 1), "speed": speed, "climb": "hold"}]
    return Plan(start, course, agl_m, segs, approach, duration)


def _is_convex_vertex(v: np.ndarray, j: int, ccw: bool) -> bool:
    """True if vertex ``j`` of polygon ``v`` turns toward the interior (interior angle < 180 deg)."""
    k = len(v)
    a, b, c = v[(j - 1) % k], v[j], v[(j + 1) % k]
    cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
    return cross > 0.0 if ccw else cross < 0.0


def _plan_mission(rng: np.random.Generator, ctx: CaseContext, local: LocalFence, frame: LocalFrame, agl_m: float) -> Plan | None:
    """Waypoints and legs at least :data:`MISSION_INSET_ROOMS` rooms inside every boundary (None: no room)."""
    inset = MISSION_INSET_ROOMS * ctx.room_m
    env = ctx.profile.envelope
    v = env.cruise_speed_mps
    x0, y0, x1, y1 = local.keep_in.bbox
    pts = []
    for _ in range(4000):
        p = np.array([rng.uniform(x0, x1), rng.uniform(y0, y1)])
        if local.lateral_margin_m(float(p[0]), float(p[1])) >= inset:
            pts.append(p)
        if len(pts) >= 60:
            break
    if len(pts) < 2:
        return None
    budget = ctx.max_duration_s - 15.0
    start = pts[0]
    route = [start]
    t = 0.0
    for p in pts[1:]:
        leg = float(np.hypot(*(p - route[-1])))
        if leg < max(3.0 * ctx.room_m, 20.0):
            continue
        dt = leg / v + (0.0 if env.is_multirotor else math.pi * ctx.room_m / v) + (leg / v * 0.1)
        if t + dt > budget or not _segment_ok(local, route[-1], p, inset):
            continue
        route.append(p)
        t += dt
        if len(route) >= int(rng.integers(3, 6)):
            break
    if len(route) < 2:
        return None
    items = []
    for p in route[1:]:
        lat, lon = _ll(frame, p)[0]
        items.append({"type": "waypoint", "lat_deg": lat, "lon_deg": lon, "agl_m": _r(agl_m, 1)})
    acceptance = 5.0 if env.is_multirotor else max(15.0, 0.3 * ctx.room_m)
    heading = _course_deg(route[1] - route[0])
    mission = {"acceptance_radius_m": _r(acceptance, 1), "items": items}
    return Plan(start, heading, agl_m, [], t, _r(min(t * 1.3 + 20.0, ctx.max_duration_s), 1), mission=mission)


def _ray_hit(local: LocalFence, origin: np.ndarray, course_deg: float) -> tuple[float, int]:
    """(distance m, edge index) of the first keep-in edge hit from ``origin`` on ``course_deg``; (inf, -1) if none."""
    ki = local.keep_in
    u = _unit(course_deg)
    d = ki.ends - ki.starts
    w = ki.starts - origin
    den = u[0] * d[:, 1] - u[1] * d[:, 0]
    ok = np.abs(den) > 1e-12
    safe = np.where(ok, den, 1.0)
    t = (w[:, 0] * d[:, 1] - w[:, 1] * d[:, 0]) / safe
    s = (w[:, 0] * u[1] - w[:, 1] * u[0]) / safe
    hit = ok & (t > 1e-6) & (s >= 0.0) & (s <= 1.0)
    if not hit.any():
        return math.inf, -1
    i = int(np.argmin(np.where(hit, t, np.inf)))
    return float(t[i]), i


def _breach_orbit_radius_m(ctx: CaseContext) -> float:
    """The fixed-wing breach pilot's home orbit radius (0 for a multirotor, which hovers)."""
    return 0.0 if ctx.multirotor else max(BREACH_ORBIT_TURN_RADII * ctx.room_m, BREACH_MIN_ORBIT_RADIUS_M)


def _push_reach_m(ctx: CaseContext, local: LocalFence, start: np.ndarray, course_deg: float) -> float:
    """How far a push on ``course_deg`` travels to the keep-in edge: from home, and (fixed-wing) from the
    point of its clockwise home orbit where it rolls out (``R`` left of home, seen along the push)."""
    reach = _ray_hit(local, start, course_deg)[0]
    orbit = _breach_orbit_radius_m(ctx)
    if orbit > 0.0:
        reach = max(reach, _ray_hit(local, start + orbit * _unit(course_deg - 90.0), course_deg)[0])
    return reach


def _breach_targets(
    rng: np.random.Generator, ctx: CaseContext, local: LocalFence, start: np.ndarray, corner: int | None
) -> list[tuple[float, float]]:
    """2-4 ``(bearing deg, push reach m)`` toward points on the keep-in boundary seen from ``start``.

    Half head-on (within 5 deg of an edge's normal), half shallow (15-30 deg off an edge's direction),
    each the first edge the ray meets, 15 deg or more apart; ``corner``: the first aims at that vertex.
    Falls back to random bearings (each still ends on the boundary) when the shape allows too few.
    """
    ki = local.keep_in
    want = int(rng.integers(2, 5))
    out: list[tuple[float, float]] = []

    def add(course: float, reach: float) -> None:
        if math.isfinite(reach) and all(abs((course - c + 180.0) % 360.0 - 180.0) >= 15.0 for c, _ in out):
            out.append((course % 360.0, reach))

    if corner is not None:
        v = ki.vertices[corner]
        course = _course_deg(v - start)
        t, _ = _ray_hit(local, start, course)
        if abs(t - float(np.hypot(*(v - start)))) < 0.02 * t:
            add(course, _push_reach_m(ctx, local, start, course))
    w = ki.lengths / ki.lengths.sum()
    for _ in range(80):
        if len(out) >= want:
            break
        i = int(rng.choice(len(w), p=w))
        a, d = ki.starts[i], ki.directions[i]
        along = float((start - a) @ d)
        h = float(abs((start - a) @ ki.outward_normals[i]))
        if rng.random() < 0.5:  # shallow: 15-30 deg off the edge's direction
            s = along + (1.0 if rng.random() < 0.5 else -1.0) * h / math.tan(math.radians(rng.uniform(15.0, 30.0)))
        else:  # head-on: the foot of the perpendicular, +-5 deg
            s = along + h * math.tan(math.radians(rng.uniform(-5.0, 5.0)))
        if not 0.05 * ki.lengths[i] <= s <= 0.95 * ki.lengths[i]:
            continue
        p = a + s * d
        course = _course_deg(p - start)
        t, j = _ray_hit(local, start, course)
        if j == i and abs(t - float(np.hypot(*(p - start)))) < 1e-6 * max(t, 1.0) + 1e-3:
            add(course, _push_reach_m(ctx, local, start, course))
    for _ in range(80):
        if len(out) >= 2:
            break
        course = float(rng.uniform(0.0, 360.0))
        add(course, _push_reach_m(ctx, local, start, course))
    return out


def _plan_breach(
    rng: np.random.Generator, ctx: CaseContext, draft: FenceDraft, local: LocalFence, agl_m: float, corner: int | None = None
) -> Plan | None:
    """The ``breach_attempts`` pilot from a legal home near the pole (None: no legal home found).

    Home: the pole or a point up to half the inradius from it, with room for the fixed-wing's home orbit.
    Speeds: [0.5 max, max] (multirotor) or [cruise, max] (fixed-wing); ``push_m``: :data:`BREACH_PUSH_FACTOR`
    times the farthest push to the boundary; as many attempts as fit in the case's duration, each estimated
    as out and back at the low speed, the rest, and (fixed-wing) one home orbit to align.
    """
    env = ctx.profile.envelope
    pole_e, pole_n, r_in = local.inradius()
    pole = np.array([pole_e, pole_n])
    orbit = _breach_orbit_radius_m(ctx)
    need = orbit + 0.5 * ctx.room_m if orbit > 0.0 else 0.3 * r_in
    home: tuple[np.ndarray, float] | None = None
    for k in range(30):
        start = pole if k == 0 else pole + _unit(rng.uniform(0.0, 360.0)) * rng.uniform(0.0, 0.5) * r_in
        heading = float(rng.uniform(0.0, 360.0))
        if local.lateral_margin_m(float(start[0]), float(start[1])) < need:
            continue
        if legal_start(ctx, draft, Plan(start, heading, agl_m, [], 0.0, 0.0)):
            home = (start, heading)
            if k > 0 or rng.random() < 0.3:  # mostly off the pole: shallow pushes need an edge at an angle
                break
    if home is None:
        return None
    start, heading = home
    targets = _breach_targets(rng, ctx, local, start, corner)
    limit = BREACH_SPEED_LIMIT_MPS[ctx.profile.kind]
    hi = min(env.max_speed_mps, limit)
    lo = min(0.5 * env.max_speed_mps if env.is_multirotor else env.cruise_speed_mps, hi)
    push = BREACH_PUSH_FACTOR * max(t for _, t in targets)
    directions: list[float | str] = [_r(c, 1) for c, _ in targets]
    orbit_s = 2.0 * math.pi * orbit / env.cruise_speed_mps if orbit > 0.0 else 0.0
    per_attempt = [2.0 * t / lo + BREACH_REST_S + orbit_s for _, t in targets]
    if rng.random() < BREACH_UP_PROBABILITY:
        directions.append("up")
        climb = draft.ceiling_m - agl_m
        per_attempt.append(climb / min(lo, env.max_climb_rate_mps) + climb / env.max_descent_rate_mps + BREACH_REST_S + orbit_s)
    lead = BREACH_SETTLE_S if env.is_multirotor else 1.5 * math.pi * orbit / env.cruise_speed_mps
    attempts, t = 0, lead
    while attempts < 50 and (attempts == 0 or t + per_attempt[attempts % len(per_attempt)] <= ctx.max_duration_s):
        t += per_attempt[attempts % len(per_attempt)]
        attempts += 1
    pilot = {
        "type": PilotKind.BREACH_ATTEMPTS.value,
        "attempts": attempts,
        "directions": directions,
        "speed_mps": [_r(lo), _r(hi)],
        "push_m": _r(push, 1),
        "rest_s": BREACH_REST_S,
        "home_agl_m": _r(agl_m, 1),
        "seed": int(rng.integers(0, 2**31 - 1)),
    }
    approach = lead + orbit_s + targets[0][1] / lo
    duration = _r(min(t + 5.0, ctx.max_duration_s), 1)
    return Plan(start, heading, agl_m, [], approach, duration, pilot=pilot)


# --------------------------------------------------------------------------- families
def _heights(rng: np.random.Generator, ctx: CaseContext) -> tuple[float, float]:
    """(ceiling m AGL, start/flight height m AGL) for a lateral case."""
    if ctx.multirotor:
        ceiling = rng.uniform(40.0, 120.0)
        return ceiling, rng.uniform(15.0, ceiling - 15.0)
    ceiling = rng.uniform(120.0, 400.0)
    return ceiling, rng.uniform(60.0, ceiling - 40.0)


def _lateral_case(
    rng: np.random.Generator,
    ctx: CaseContext,
    unit_shape: Sequence[Sequence[float]] | None,
    attack: Attack | None = None,
    corner_angle: bool = False,
) -> tuple[FenceDraft, Plan, Attack]:
    """A keep-in shape (``unit_shape``, scaled and turned; None: a ``keep_in_circle`` on the site) and a lateral attack."""
    attack = attack or _pick_keeping(rng, LATERAL_ATTACKS, LATERAL_WEIGHTS, ADDED_LATERAL_ATTACKS)
    r = ctx.target_inradius_m(rng) * (1.6 if attack is Attack.MISSION else 1.0)
    ceiling, agl = _heights(rng, ctx)
    frame = ctx.frame
    if unit_shape is None:
        draft = FenceDraft.circle(frame, 0.0, 0.0, r, ceiling)
    else:
        draft = FenceDraft(_scaled(unit_shape, r, rng), ceiling)
    if draft.span_m() > MAX_FENCE_SPAN_M:
        raise _DoesNotFit
    local = draft.local(frame)
    plan, attack = _mission_or_breach(rng, ctx, draft, local, attack, agl, 0 if corner_angle else None)
    if plan is not None:
        return draft, plan, attack
    corner = None
    if corner_angle:  # the acute corner is vertex 0 of the unit triangle
        attack = Attack.CORNER if rng.random() < 0.6 else attack
        corner = 0
    return draft, _plan_lateral(rng, ctx, local, attack, agl, corner), attack


def _mission_or_breach(
    rng: np.random.Generator,
    ctx: CaseContext,
    draft: FenceDraft,
    local: LocalFence,
    attack: Attack,
    agl: float,
    breach_vertex: int | None = None,
) -> tuple[Plan | None, Attack]:
    """``(plan, attack)`` for a mission or a breach-attempts attack (:func:`_plan_mission`, :func:`_plan_breach`,
    ``breach_vertex`` its aim), or ``(None, attack)``: another attack, or ``HEAD_ON`` when the plan did not fit."""
    if attack is Attack.MISSION:
        plan = _plan_mission(rng, ctx, local, ctx.frame, agl)
        if plan is not None:
            return plan, attack
        attack = Attack.HEAD_ON
    if attack is Attack.BREACH_ATTEMPTS:
        plan = _plan_breach(rng, ctx, draft, local, agl, breach_vertex)
        if plan is not None:
            return plan, attack
        attack = Attack.HEAD_ON
    return None, attack


def _pick(rng: np.random.Generator, options: Sequence, weights: Sequence[float]):
    w = np.asarray(weights, dtype=float)
    return options[int(rng.choice(len(options), p=w / w.sum()))]


def _added_rng(rng: np.random.Generator) -> np.random.Generator:
    """A child generator for draws a feature added later needs; ``rng``'s own stream is left as it was.

    (:meth:`numpy.random.Generator.spawn` derives the child from the seed sequence without drawing from
    ``rng``, so every case that does not use the feature draws exactly what it drew before.)
    """
    return rng.spawn(1)[0]


def _pick_keeping(rng: np.random.Generator, options: Sequence, weights: Sequence[float], n_added: int):
    """:func:`_pick` where the last ``n_added`` options were added after campaigns had been published.

    The added options get their share of the weight from a child generator (:func:`_added_rng`); otherwise
    the older options are picked from ``rng`` exactly as before they were added, so those cases do not change.
    """
    w = np.asarray(weights, dtype=float)
    extra = _added_rng(rng)
    if extra.random() < w[-n_added:].sum() / w.sum():
        return options[len(options) - n_added + int(extra.choice(n_added, p=w[-n_added:] / w[-n_added:].sum()))]
    return _pick(rng, options[:-n_added], weights[:-n_added])


def family_box(rng: np.random.Generator, ctx: CaseContext):
    a = rng.uniform(1.0, 2.5)
    return _lateral_case(rng, ctx, [(-a, -1), (a, -1), (a, 1), (-a, 1)])


def family_l(rng: np.random.Generator, ctx: CaseContext):
    w, h = rng.uniform(3.0, 5.0), rng.uniform(3.0, 5.0)
    return _lateral_case(rng, ctx, [(0, 0), (w, 0), (w, 1), (1, 1), (1, h), (0, h)])


def family_u(rng: np.random.Generator, ctx: CaseContext):
    w, h, b = rng.uniform(3.0, 5.0), rng.uniform(3.0, 5.0), rng.uniform(1.0, 1.6)
    return _lateral_case(rng, ctx, [(0, 0), (w, 0), (w, h), (w - 1, h), (w - 1, b), (1, b), (1, h), (0, h)])


def family_star(rng: np.random.Generator, ctx: CaseContext):
    k = int(rng.integers(5, 8))
    inner = rng.uniform(0.45, 0.7)
    pts = []
    for i in range(2 * k):
        rad = 1.0 if i % 2 == 0 else inner
        a = math.pi * i / k
        pts.append((rad * math.sin(a), rad * math.cos(a)))
    return _lateral_case(rng, ctx, pts)


def family_acute(rng: np.random.Generator, ctx: CaseContext):
    alpha = math.radians(rng.uniform(20.0, 40.0))
    l2 = rng.uniform(0.8, 1.2)
    tri = [(0.0, 0.0), (1.0, 0.0), (l2 * math.cos(alpha), l2 * math.sin(alpha))]
    if rng.random() < 0.5:  # triangle-ish: blunt the far side with a fourth vertex
        mid = (np.asarray(tri[1]) + np.asarray(tri[2])) / 2.0
        out = mid / np.hypot(*mid) * rng.uniform(0.05, 0.2)
        tri = [tri[0], tri[1], tuple(mid + out), tri[2]]
    return _lateral_case(rng, ctx, tri, corner_angle=True)


def family_circle(rng: np.random.Generator, ctx: CaseContext):
    """A ``keep_in_circle`` of the lateral families' size, centred on the site; no corner attack."""
    return _lateral_case(rng, ctx, None, attack=_pick(rng, CIRCLE_ATTACKS, CIRCLE_WEIGHTS))


def family_corridor(rng: np.random.Generator, ctx: CaseContext):
    r = ctx.target_inradius_m(rng)
    c = min(rng.uniform(2.0, 4.0) * ctx.room_m, 1.6 * r)
    half_len = rng.uniform(0.5, 1.5) * r
    h = c / 2.0
    x0, x1 = half_len, half_len + 2.0 * r
    poly = np.array(
        [(-x1, -r), (-x0, -r), (-x0, -h), (x0, -h), (x0, -r), (x1, -r), (x1, r), (x0, r), (x0, h), (-x0, h), (-x0, r), (-x1, r)]
    )
    poly = _rot(poly, rng.uniform(0.0, 2.0 * math.pi))
    ceiling, agl = _heights(rng, ctx)
    draft = FenceDraft(poly, ceiling)
    if draft.span_m() > MAX_FENCE_SPAN_M:
        raise _DoesNotFit
    frame = ctx.frame
    local = draft.local(frame)
    attack = _pick_keeping(
        rng,
        (Attack.HEAD_ON, Attack.CORNER, Attack.TURNING, Attack.MISSION, Attack.SHALLOW, Attack.BREACH_ATTEMPTS),
        (2, 1, 1, 1, 3, 1),
        1,
    )
    if attack is Attack.BREACH_ATTEMPTS:
        plan = _plan_breach(rng, ctx, draft, local, agl)
        if plan is not None:
            return draft, plan, attack
        attack = Attack.HEAD_ON
    if attack is Attack.SHALLOW and rng.random() < 0.6:
        # through the corridor: start in one room, fly along the corridor at the far room
        pole = np.array(local.inradius()[:2])
        far = -pole
        course = _course_deg(far - pole) + rng.uniform(-8.0, 8.0)
        start = pole
        v = _approach_speed(ctx)
        approach = float(np.hypot(*(far - pole))) / v
        duration = _duration(ctx, approach, rng)
        segs_d = [{"duration_s": duration, "course_deg": _r(course % 360.0, 1), "speed": "max", "climb": "hold"}]
        return draft, Plan(start, course % 360.0, agl, segs_d, approach, duration), Attack.SHALLOW
    if attack is Attack.MISSION:
        plan = _plan_mission(rng, ctx, local, frame, agl)
        if plan is not None:
            return draft, plan, attack
        attack = Attack.HEAD_ON
    return draft, _plan_lateral(rng, ctx, local, attack, agl), attack


def _keep_out_polygon(rng: np.random.Generator, centre: np.ndarray, radius_m: float, k: int) -> np.ndarray:
    """A keep-out of ``k`` vertices on a circle round ``centre``: at sorted random angles, or a triangle turned at
    random (three random angles can make a sliver)."""
    ang = np.sort(rng.uniform(0.0, 2 * math.pi, k)) if k > 3 else np.array([0.0, 2.1, 4.2]) + rng.uniform(0, 1)
    return np.column_stack([centre[0] + radius_m * np.sin(ang), centre[1] + radius_m * np.cos(ang)])


def family_keep_out(rng: np.random.Generator, ctx: CaseContext):
    r = ctx.target_inradius_m(rng) * 1.5
    a = rng.uniform(1.0, 1.8)
    box = _scaled([(-a, -1), (a, -1), (a, 1), (-a, 1)], r, rng)
    ceiling, agl = _heights(rng, ctx)
    draft = FenceDraft(box, ceiling)
    if draft.span_m() > MAX_FENCE_SPAN_M:
        raise _DoesNotFit
    frame = ctx.frame
    # the first keep-out sits off-centre; the pole of what is left is the default recovery point
    rad = rng.uniform(0.15, 0.3) * r
    off = _unit(rng.uniform(0, 360)) * rng.uniform(0.25, 0.5) * r
    circles, polys = [], []
    if rng.random() < 0.6:
        circles.append((float(off[0]), float(off[1]), float(rad)))
    else:
        polys.append(_keep_out_polygon(rng, off, rad, int(rng.integers(3, 7))))
    draft.keep_out_circles, draft.keep_out_polygons = tuple(circles), tuple(polys)
    # buildings: a keep-out's own ceiling above the flight height (the unit treats it as full height: planning
    # is unchanged); drawn from a child generator so the cases drawn before buildings existed stay as they were
    extra = _added_rng(rng)

    def building() -> float | None:
        return float(extra.uniform(agl + 5.0, ceiling)) if extra.random() < BUILDING_PROBABILITY else None

    draft.keep_out_circle_ceilings = tuple(building() for _ in circles)
    draft.keep_out_polygon_ceilings = tuple(building() for _ in polys)
    local = draft.local(frame)
    pole = np.array(local.inradius()[:2])
    attack = _pick(rng, (Attack.BEHIND_KEEP_OUT, Attack.INTO_KEEP_OUT, Attack.MISSION), (3, 3, 1))
    if rng.random() < 0.5:  # a second, small keep-out near the path
        mid = (pole + off) / 2.0 + _unit(rng.uniform(0, 360)) * 0.2 * r
        draft.keep_out_circles = draft.keep_out_circles + ((float(mid[0]), float(mid[1]), float(0.08 * r)),)
        draft.keep_out_circle_ceilings = (*draft.keep_out_circle_ceilings, building())
        local = draft.local(frame)
        pole = np.array(local.inradius()[:2])
    if attack is Attack.MISSION:
        plan = _plan_mission(rng, ctx, local, frame, agl)
        if plan is not None:
            return draft, plan, attack
        attack = Attack.INTO_KEEP_OUT
    if attack is Attack.INTO_KEEP_OUT:
        course = _course_deg(off - pole) + rng.uniform(-10.0, 10.0)
        start, approach = _run_up(rng, ctx, local, off - _unit(course) * rad, course % 360.0)
        duration = _duration(ctx, approach, rng)
        segs = [{"duration_s": duration, "course_deg": _r(course % 360.0, 1), "speed": "max", "climb": "hold"}]
        return draft, Plan(start, course % 360.0, agl, segs, approach, duration), attack
    # behind the keep-out: start on its far side from the recovery point and push at the keep-in edge there,
    # so the way back to the recovery point leads past (through, if straight) the keep-out
    away = (off - pole) / max(np.hypot(*(off - pole)), 1e-9)
    course = _course_deg(away) + rng.uniform(-15.0, 15.0)
    u = _unit(course)
    # the keep-in edge hit along the course from behind the keep-out
    p = off + u * (rad + 1.0)
    target = p
    for s in np.linspace(0.0, 4.0 * r, 400):
        q = p + u * s
        if local.keep_in.signed_distance(float(q[0]), float(q[1])) < 0.0:
            target = q
            break
    start = off + u * (rad + rng.uniform(0.1, 0.3) * r)
    if local.lateral_margin_m(float(start[0]), float(start[1])) <= 0.0:
        start = (target + off) / 2.0
    v = _approach_speed(ctx)
    approach = float(np.hypot(*(target - start))) / v
    duration = _duration(ctx, approach, rng)
    segs = [{"duration_s": duration, "course_deg": _r(course % 360.0, 1), "speed": "max", "climb": "hold"}]
    return draft, Plan(start, course % 360.0, agl, segs, approach, duration), Attack.BEHIND_KEEP_OUT


def family_ceiling(rng: np.random.Generator, ctx: CaseContext):
    r = ctx.target_inradius_m(rng)
    a = rng.uniform(1.0, 2.0)
    box = _scaled([(-a, -1), (a, -1), (a, 1), (-a, 1)], r, rng)
    env = ctx.profile.envelope
    below = rng.uniform(8.0, 40.0)
    agl = rng.uniform(15.0, 60.0) if ctx.multirotor else rng.uniform(60.0, 200.0)
    draft = FenceDraft(box, agl + below)
    if draft.span_m() > MAX_FENCE_SPAN_M:
        raise _DoesNotFit
    local = draft.local(ctx.frame)
    pole = np.array(local.inradius()[:2])
    course = rng.uniform(0.0, 360.0)
    start = pole - _unit(course) * rng.uniform(0.0, 0.5) * r
    approach = below / env.max_climb_rate_mps
    duration = _duration(ctx, approach, rng)
    speed = "cruise" if not ctx.multirotor or rng.random() < 0.5 else "min"
    segs = [{"duration_s": duration, "course_deg": _r(course, 1), "speed": speed, "climb": "max"}]
    return draft, Plan(start, course, agl, segs, approach, duration), Attack.CLIMB


def _box_poly(ce: float, cn: float, half: float, angle: float) -> np.ndarray:
    return _rot(np.array([(-half, -half), (half, -half), (half, half), (-half, half)]), angle) + [ce, cn]


def family_floor_gaps(rng: np.random.Generator, ctx: CaseContext):
    env = ctx.profile.envelope
    options = [Attack.DESCEND, Attack.MISSION]
    weights = [2, 1]
    if ctx.multirotor:
        options += [Attack.GAP_DESCENT_DASH, Attack.GAP_TAKEOFF]
        weights += [2, 2]
    attack = _pick(rng, options, weights)
    if attack is Attack.DESCEND and not ctx.multirotor and rng.random() < 0.5:
        # a fixed-wing below the floor inside a gap, then a dash at its edge: it cannot hover, so the override
        # must circle inside the gap until it has climbed back (a draw made only for a fixed-wing's descent: every
        # other case of a seed is unchanged)
        attack = Attack.GAP_DESCENT_DASH
    if attack is Attack.GAP_TAKEOFF:
        gap_half = max(rng.uniform(0.5, 1.0) * ctx.room_m, 10.0)  # small: about one stop
    elif attack is Attack.GAP_DESCENT_DASH:
        gap_half = rng.uniform(2.0, 3.5) * ctx.room_m
    else:
        gap_half = rng.uniform(1.5, 3.0) * ctx.room_m
    r = max(ctx.target_inradius_m(rng), 2.5 * gap_half)
    angle = rng.uniform(0.0, 2 * math.pi)
    a = rng.uniform(1.0, 1.8)
    keep_in = _rot(np.array([(-a * r, -r), (a * r, -r), (a * r, r), (-a * r, r)]), angle)
    if ctx.multirotor:
        floor = rng.uniform(8.0, 25.0)
        ceiling = floor + rng.uniform(30.0, 80.0)
    else:
        floor = rng.uniform(30.0, 60.0)
        ceiling = floor + rng.uniform(100.0, 250.0)
    g0 = _rot(np.array([[rng.uniform(-0.3, 0.3) * r, rng.uniform(-0.3, 0.3) * r]]), angle)[0]
    gaps = [_box_poly(float(g0[0]), float(g0[1]), gap_half, angle)]
    if rng.random() < 0.5:  # a second gap near a corner
        c = _rot(np.array([[0.6 * a * r * rng.choice([-1, 1]), 0.6 * r * rng.choice([-1, 1])]]), angle)[0]
        half2 = min(gap_half, 0.3 * r)
        gaps.append(_box_poly(c[0], c[1], half2, angle))
    draft = FenceDraft(keep_in, ceiling, floor, tuple(gaps))
    if draft.span_m() > MAX_FENCE_SPAN_M:
        raise _DoesNotFit
    frame = ctx.frame
    local = draft.local(frame)
    gap_c = gaps[0].mean(axis=0)
    if attack is Attack.MISSION:
        plan = _plan_mission(
            rng, ctx, local, frame, rng.uniform(floor + 0.3 * (ceiling - floor), floor + 0.7 * (ceiling - floor))
        )
        if plan is not None:
            return draft, plan, attack
        attack = Attack.DESCEND
    if attack is Attack.GAP_TAKEOFF:
        course = rng.uniform(0.0, 360.0)
        duration = _r(min(rng.uniform(25.0, 45.0), ctx.max_duration_s), 1)
        segs = [{"duration_s": duration, "course_deg": _r(course, 1), "speed": "max", "climb": "max"}]
        return draft, Plan(gap_c, course, 0.0, segs, 2.0, duration), attack
    if attack is Attack.GAP_DESCENT_DASH:
        course = rng.uniform(0.0, 360.0)
        agl = floor + rng.uniform(5.0, 15.0)
        low = rng.uniform(2.0, max(floor - 3.0, 3.0))
        down_s = (agl - low) / env.max_descent_rate_mps
        dash = _r(min(rng.uniform(15.0, 30.0), max(ctx.max_duration_s - down_s - 2.0, 5.0)), 1)
        segs = [
            {"duration_s": _r(down_s, 1), "course_deg": _r(course, 1), "speed": "min", "climb": "descend"},
            {"duration_s": dash, "course_deg": _r((course + rng.uniform(-60, 60)) % 360.0, 1), "speed": "max", "climb": "hold"},
        ]
        duration = _r(min(down_s + dash, ctx.max_duration_s), 1)
        return draft, Plan(gap_c, course, agl, segs, down_s, duration), attack
    # descend to the floor outside every gap
    agl = floor + rng.uniform(8.0, 30.0)
    for _ in range(50):
        p = _rot(np.array([[rng.uniform(-0.8, 0.8) * a * r, rng.uniform(-0.8, 0.8) * r]]), angle)[0]
        if (
            local.gap_distance_m(float(p[0]), float(p[1])) < -ctx.room_m
            and local.lateral_margin_m(float(p[0]), float(p[1])) > 0.5 * r
        ):
            break
    course = rng.uniform(0.0, 360.0)
    approach = (agl - floor) / env.max_descent_rate_mps
    duration = _duration(ctx, approach, rng)
    speed = "cruise" if not ctx.multirotor else ("min" if rng.random() < 0.5 else "cruise")
    segs = [{"duration_s": duration, "course_deg": _r(course, 1), "speed": speed, "climb": "descend"}]
    return draft, Plan(p, course, agl, segs, approach, duration), Attack.DESCEND


CITY_VERTICES = (2_000, 6_000)
"""The city family's keep-in vertices (drawn uniformly between): above the planner's lazy-graph and segment-grid
sizes (:data:`geofence.recovery_path.LAZY_MIN_NODES`, :data:`~geofence.recovery_path.SEGMENT_GRID_MIN_EDGES`)."""
CITY_BUILDINGS = (40, 300)
"""The city family's building keep-outs (drawn uniformly between); the park's radius grows to hold them."""
CITY_BUILDING_SIZE_M = (10.0, 40.0)


def family_city(rng: np.random.Generator, ctx: CaseContext):
    """An airspace-scale fence: a ragged park boundary of :data:`CITY_VERTICES` vertices
    (:func:`scenarios.airspace.generate.park_boundary_en`, star-shaped, bays and headlands down to metre-scale
    wiggles), at least twice the lateral families' size, with :data:`CITY_BUILDINGS` building
    keep-outs (:func:`~scenarios.airspace.generate.place_buildings`: rectangles and hexagons 10-40 m across, at
    least two rooms apart and from the boundary, none in a meadow of two rooms round the centre), then a
    lateral attack or a mission. The unit flies it with its fence index, and a fixed-wing's roll-out target
    and every recovery route come from the lazy route graph searched through the buildings."""
    attack = _pick(rng, LATERAL_ATTACKS, LATERAL_WEIGHTS)
    clearance = max(2.0 * ctx.room_m, 20.0)
    meadow = 2.0 * ctx.room_m
    pitch = clearance + CITY_BUILDING_SIZE_M[1]  # the ground one building takes, at the density below, is pitch²/0.25
    n = int(rng.integers(CITY_BUILDINGS[0], CITY_BUILDINGS[1] + 1))
    # a radius with room for them (the boundary dips to 0.8 of it) and at least twice the lateral families'
    r = max(
        (math.sqrt(n * pitch**2 / (0.25 * math.pi) + (meadow + pitch) ** 2) + clearance) / 0.8,
        2.0 * ctx.target_inradius_m(rng),
    )
    if 2.4 * r > MAX_FENCE_SPAN_M:
        raise _DoesNotFit
    boundary = park_boundary_en(rng, int(rng.integers(CITY_VERTICES[0], CITY_VERTICES[1] + 1)), r, float(rng.uniform(0.05, 0.2)))
    ceiling, agl = _heights(rng, ctx)
    draft = FenceDraft(boundary, ceiling)
    if draft.span_m() > MAX_FENCE_SPAN_M:
        raise _DoesNotFit
    buildings = place_buildings(
        rng, boundary, n, size_m=CITY_BUILDING_SIZE_M, clearance_m=clearance, meadow_radius_m=meadow, max_tries=200_000
    )
    draft.keep_out_polygons = tuple(buildings)
    local = draft.local(ctx.frame)
    plan, attack = _mission_or_breach(rng, ctx, draft, local, attack, agl)
    if plan is not None:
        return draft, plan, attack
    return draft, _plan_lateral(rng, ctx, local, attack, agl), attack


RANDOM_VERTICES = (5, 40)
"""How many vertices a :func:`family_random` keep-in has (inclusive)."""
RANDOM_KEEP_OUT_PROBABILITY = 0.5
"""The chance that a :func:`family_random` fence has keep-outs (1 to 3) in it."""


def _place_keep_outs(rng: np.random.Generator, ctx: CaseContext, draft: FenceDraft, local: LocalFence, r: float) -> None:
    """Add 1-3 keep-outs to ``draft`` (``local``: its keep-in alone) for :func:`family_random`: each a circle or a
    3-7-gon of radius 0.08-0.25 ``r`` on a ray from the pole, clear of the pole, the keep-in edge and the others
    by a room, and kept only if the allowed area keeps the inradius the families are sized to."""
    frame = ctx.frame
    pole = np.array(local.inradius()[:2])
    # what the allowed area keeps, as the families are sized (ctx.target_inradius_m's least) and as the schema
    # checks it (a shifted fence that does not vanish)
    min_inradius = max(3.0 * ctx.room_m, 1.4 * ctx.shift_m)
    circles: list[tuple[float, float, float]] = []
    polys: list[np.ndarray] = []

    def clear_of_the_others(c: np.ndarray, rad: float) -> bool:
        if any(float(np.hypot(c[0] - e, c[1] - n)) < rad + q + ctx.room_m for e, n, q in circles):
            return False
        for p in polys:
            mid = p.mean(axis=0)
            if float(np.hypot(*(c - mid))) < rad + float(np.max(np.hypot(*(p - mid).T))) + ctx.room_m:
                return False
        return True

    for _ in range(int(rng.integers(1, 4))):
        for _try in range(20):  # a place on a ray from the pole, clear of the pole and of the keep-in edge
            u = _unit(rng.uniform(0.0, 360.0))
            reach, _ = _ray_hit(local, pole, _course_deg(u))
            rad = rng.uniform(0.08, 0.25) * r
            c = pole + u * rng.uniform(0.3, 0.8) * reach
            near_pole = float(np.hypot(*(c - pole))) < rad + ctx.room_m
            if near_pole or local.lateral_margin_m(float(c[0]), float(c[1])) < rad + 0.5 * ctx.room_m:
                continue
            if not clear_of_the_others(c, rad):
                continue
            added: list = circles if rng.random() < 0.5 else polys
            if added is circles:
                circles.append((float(c[0]), float(c[1]), float(rad)))
            else:
                polys.append(_keep_out_polygon(rng, c, rad, int(rng.integers(3, 8))))
            draft.keep_out_circles, draft.keep_out_polygons = tuple(circles), tuple(polys)
            if draft.local(frame).inradius()[2] < min_inradius:  # it took too much of the allowed area: not kept
                added.pop()
                draft.keep_out_circles, draft.keep_out_polygons = tuple(circles), tuple(polys)
            break


def random_simple_polygon(rng: np.random.Generator, k: int) -> np.ndarray:
    """``k`` vertices (rows east, north; outer radius 1) at sorted random angles round a centre, no two closer
    than a quarter of an even share (no sliver edge), each at a random fraction of the outer radius (the
    least fraction itself drawn from 0.3-0.8: from a ragged star to a near-convex blob); a simple polygon.

    While every angular gap is under pi the polygon is star-shaped about the centre, hence simple. A gap of
    pi or more (one draw in eight with 5 vertices, one in a thousand with 10) puts its edge on the far side
    of the centre: often still simple (then kept), sometimes across other edges (a campaign's generation
    stopped on such a keep-in (case history: docs/campaigns.md#fresh-seeds-in-the-order-they-were-flown)), and
    then the whole polygon is drawn again. A polygon that was simple at its
    first draw is kept as drawn, so the campaigns that never met a crossing keep their cases.
    """
    share = 2.0 * math.pi / k
    while True:
        gaps = share * (0.25 + rng.dirichlet(np.ones(k)) * k * 0.75)  # each at least a quarter share; they sum to 2 pi
        angles = np.cumsum(gaps) - gaps[0]
        lowest = rng.uniform(0.3, 0.8)
        radii = rng.uniform(lowest, 1.0, k)
        unit = np.column_stack([radii * np.sin(angles), radii * np.cos(angles)])
        if not self_intersections(unit):
            return unit


def family_random(rng: np.random.Generator, ctx: CaseContext):
    """A random polygon (:func:`random_simple_polygon`, :data:`RANDOM_VERTICES` vertices) scaled so its inradius is
    the lateral families' and turned at random: it mixes notches, spikes, acute and reflex corners the archetype
    families hold one at a time.
    With :data:`RANDOM_KEEP_OUT_PROBABILITY`, keep-outs between the pole and the keep-in edge, where the
    override's way back runs (:func:`_place_keep_outs`). Then a lateral attack or a mission."""
    k = int(rng.integers(RANDOM_VERTICES[0], RANDOM_VERTICES[1] + 1))
    unit = random_simple_polygon(rng, k)
    attack = _pick(rng, LATERAL_ATTACKS, LATERAL_WEIGHTS)
    r = ctx.target_inradius_m(rng) * (1.6 if attack is Attack.MISSION else 1.0)
    ceiling, agl = _heights(rng, ctx)
    draft = FenceDraft(_scaled(unit, r, rng), ceiling)
    if draft.span_m() > MAX_FENCE_SPAN_M:
        raise _DoesNotFit
    frame = ctx.frame
    local = draft.local(frame)
    if rng.random() < RANDOM_KEEP_OUT_PROBABILITY:
        _place_keep_outs(rng, ctx, draft, local, r)
        local = draft.local(frame)
    plan, attack = _mission_or_breach(rng, ctx, draft, local, attack, agl)
    if plan is not None:
        return draft, plan, attack
    return draft, _plan_lateral(rng, ctx, local, attack, agl), attack


FAMILY_BUILDERS: dict[CaseFamily, Callable[[np.random.Generator, CaseContext], tuple[FenceDraft, Plan, Attack]]] = {
    CaseFamily.CONVEX_BOX: family_box,
    CaseFamily.L_FENCE: family_l,
    CaseFamily.U_FENCE: family_u,
    CaseFamily.STAR: family_star,
    CaseFamily.ACUTE_CORNER: family_acute,
    CaseFamily.CORRIDOR: family_corridor,
    CaseFamily.KEEP_OUT: family_keep_out,
    CaseFamily.CEILING: family_ceiling,
    CaseFamily.FLOOR_GAPS: family_floor_gaps,
    CaseFamily.CIRCLE: family_circle,
    CaseFamily.CITY: family_city,
    CaseFamily.RANDOM: family_random,
}

DEFAULT_FAMILIES: tuple[CaseFamily, ...] = tuple(f for f in CaseFamily if f not in (CaseFamily.CITY, CaseFamily.RANDOM))
"""The families a campaign draws from unless asked for others (every family but :attr:`CaseFamily.CITY` and
:attr:`CaseFamily.RANDOM`)."""


# --------------------------------------------------------------------------- site, wind, faults
def draw_site(rng: np.random.Generator) -> dict:
    continent, (la0, la1), (lo0, lo1) = SITES[int(rng.integers(len(SITES)))]
    ground = float(rng.uniform(0.0, MAX_GROUND_ALT_M)) if rng.random() < 0.5 else float(rng.uniform(0.0, 400.0))
    return {
        "continent": continent,
        "lat_deg": round(float(rng.uniform(la0, la1)), 6),
        "lon_deg": round(float(rng.uniform(lo0, lo1)), 6),
        "ground_alt_m": round(ground, 1),
    }


def draw_wind(rng: np.random.Generator, profile: PlatformProfile, approach_hint_s: float) -> tuple[dict, float]:
    """The ``wind:`` block (steady + gusts up to the platform's limit, turbulence) and its design speed, m/s."""
    limit = wind_limit_mps(profile)
    total = limit * float(rng.uniform(0.0, 1.0))
    from_deg = float(rng.uniform(0.0, 360.0))
    severity = _pick(rng, ("none", "light", "moderate"), (3, 4, 3))
    n_gusts = int(rng.integers(0, 3))
    steady = total * (float(rng.uniform(0.6, 1.0)) if n_gusts else 1.0)
    wind: dict[str, Any] = {"speed_mps": _r(steady), "from_deg": _r(from_deg, 1)}
    if rng.random() < 0.5:
        wind["profile"] = {"law": "power", "exponent": 0.14, "reference_height_m": 10}
    if severity != "none":
        wind["turbulence"] = {"severity": severity}
    gust = total - steady
    if n_gusts:
        wind["gusts"] = [
            {
                "onset_s": _r(max(1.0, approach_hint_s + rng.uniform(-4.0, 1.0)), 1),
                "amplitude_mps": _r(gust * rng.uniform(0.7, 1.0)),
                "length_m": _r(rng.uniform(20.0, 80.0), 1),
                "from_deg": _r((from_deg + rng.uniform(-30.0, 30.0)) % 360.0, 1),
            }
            for _ in range(n_gusts)
        ]
    design = steady + gust + 1.5 * TURBULENCE_SIGMA_MPS[severity]
    return wind, design


def wind_authority(wind: Mapping[str, Any], agl_m: float, profile: PlatformProfile, ground_alt_m: float) -> dict:
    """The case's wind against the platform's authority, at the start height ``agl_m``.

    ``mean_wind_mps``: the steady wind there (its height profile applied); ``turbulence_sigma_mps``:
    the Dryden sigma_u there (:func:`wind.dryden.dryden_scales` of the scenario's W20);
    ``beyond_authority``: why return cannot be assured against them
    (:func:`geofence.physics.dynamics.return_not_assured`, the envelope at the site's density), or None;
    ``max_speed_mps``: that envelope's max speed (the report compares the wind a breached flight met with it).
    """
    cfg = parse_wind(dict(wind), "wind")
    factor = cfg.profile.build().factor(agl_m) if cfg.profile is not None else 1.0
    mean = cfg.speed_mps * factor
    w20 = cfg.turbulence.resolved_w20_mps if cfg.turbulence is not None else 0.0
    sigma = dryden_scales(agl_m, w20)[2] if w20 > 0.0 else 0.0
    env = envelope_at_density(profile.envelope, isa_density_ratio(ground_alt_m + agl_m))
    return {
        "mean_wind_mps": round(mean, 2),
        "turbulence_sigma_mps": round(sigma, 2),
        "beyond_authority": return_not_assured(mean, sigma, env),
        "max_speed_mps": round(env.max_speed_mps, 2),
    }


def _gps_fault(rng: np.random.Generator) -> dict | None:
    if rng.random() >= GPS_FAULT_PROBABILITY:
        return None
    return {
        "kind": "fail" if rng.random() < 0.5 else "outage",
        "at_fraction": round(float(rng.uniform(0.5, 1.0)), 3),
        "length_s": round(float(rng.uniform(2.0, 8.0)), 2),
    }


DOWNWARD_SENSORS: dict[str, dict] = {"rangefinder": {}, "optical_flow": {}}
"""The ``sensors:`` keys ``downward_sensors`` fits to a multirotor's unit: a rangefinder and an optical flow with
their defaults (:mod:`aircraft.sensors`, the PX4Flow-class figures of ``docs/validation.md``)."""
FAULT_STREAM = 0xFA17
"""The fault draws' own generator, ``default_rng([case_seed, FAULT_STREAM])``: a campaign with ``faults`` has the
same cases as one without, each with one failure added."""
FAULT_MOMENTS = ("in the override", "at the approach", "in the recovery")
"""When a drawn fault starts: 0-1.5 s after the unit's first activation (it is overriding), 3 s before to 1 s after
the planned approach, or 2-8 s after the first activation (recovering, handing back, landing)."""


def draw_fault(rng: np.random.Generator, multirotor: bool, approach_s: float, duration_s: float) -> dict:
    """One single failure as a ``faults:`` item: a kind that applies to the platform, at one of the
    :data:`FAULT_MOMENTS`, with its parameters in the ranges of issue 38's trials (a 1-2 Hz receiver 0.3-0.6 s late
    with a 3-5 m bias; a 0.2-1 m/s walk-off; 3-10 m of barometer drift; a 10-45 deg compass error)."""
    from scenarios.definition.faults import FIXED_WING_ONLY, FaultKind

    kinds = [k for k in FaultKind if not (multirotor and k in FIXED_WING_ONLY)]
    kind = kinds[int(rng.integers(len(kinds)))]
    moment = FAULT_MOMENTS[int(rng.integers(len(FAULT_MOMENTS)))]
    f: dict[str, Any] = {"kind": kind.value}
    if moment == "at the approach":
        f["at_s"] = _r(min(max(1.0, approach_s + rng.uniform(-3.0, 1.0)), duration_s - 3.0), 1)
    else:
        f["at_first_activation"] = True
        f["delay_s"] = _r(rng.uniform(0.0, 1.5) if moment == "in the override" else rng.uniform(2.0, 8.0), 2)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    if kind is FaultKind.GNSS_DEGRADED:
        f.update(
            rate_hz=_r(rng.uniform(1.0, 2.0), 2), latency_s=_r(rng.uniform(0.3, 0.6), 2), bias_m=_r(rng.uniform(3.0, 5.0), 2)
        )
    elif kind is FaultKind.GNSS_WALKOFF:
        f.update(drift_mps=_r(rng.uniform(0.2, 1.0), 2), direction_deg=_r(rng.uniform(0.0, 360.0), 1))
    elif kind is FaultKind.BARO_DRIFT:
        f["drift_m"] = _r(sign * rng.uniform(3.0, 10.0), 2)
    elif kind is FaultKind.COMPASS_ERROR:
        f["error_deg"] = _r(sign * rng.uniform(10.0, 45.0), 1)
    return f


# --------------------------------------------------------------------------- one case
@dataclass(frozen=True)
class Case:
    """One generated case: its id, family, the three scenario documents and the manifest entry."""

    case_id: str
    family: CaseFamily
    attack: Attack
    documents: dict[Variant, dict]
    manifest: dict


def build_case(
    index: int,
    seed: int,
    family: CaseFamily,
    platforms: Sequence[str],
    max_duration_s: float = DEFAULT_MAX_DURATION_S,
    faults: bool = False,
    *,
    downward_sensors: bool = False,
) -> Case | None:
    """Case ``index`` of a campaign (reproducible from ``(seed, index)``); None when no platform fits. With
    ``faults``, one single failure (:func:`draw_fault`) in place of a GPS fault, the other draws unchanged; with
    ``downward_sensors``, a multirotor's unit carries a rangefinder and an optical flow (:data:`DOWNWARD_SENSORS`)."""
    rng = np.random.default_rng([int(seed), int(index)])
    site = draw_site(rng)
    gps = _gps_fault(rng)
    gps = None if faults else gps  # (drawn all the same: the case's later draws stay as they were)
    order = [platforms[int(i)] for i in rng.permutation(len(platforms))]
    case_seed = int(rng.integers(0, 2**31 - 1))
    for platform in order:
        sub = np.random.default_rng([int(seed), int(index), len(platform), sum(map(ord, platform))])
        profile = load_profile(platform)
        hint = sub.uniform(5.0, 20.0)
        wind, design = draw_wind(sub, profile, hint)
        shift = worst_case_lateral_shift_m(profile.envelope, design)
        if not math.isfinite(shift):
            continue
        ctx = CaseContext(platform, profile, site, wind, design, platform_room_m(profile), shift, max_duration_s, gps)
        try:
            draft, plan, attack = FAMILY_BUILDERS[family](sub, ctx)
        except _DoesNotFit:
            continue
        if not legal_start(ctx, draft, plan):
            continue  # the geofence would have to act at t = 0: not a fair case for this platform
        return _assemble(index, family, attack, ctx, draft, plan, wind, case_seed, sub, faults, downward_sensors)
    return None


def legal_start(ctx: CaseContext, draft: FenceDraft, plan: Plan) -> bool:
    """True when the start is outside the unit's activation boundary (positive margin at t = 0).

    The start state as flown: a multirotor at rest, a fixed-wing at cruise (equivalent) airspeed on the
    start heading, crabbing in the mean wind; the envelope at the site's air density; the unit's
    nominal k·sigma margins of the default sensors. A case whose start already needs an override
    cannot be won by any geofence and measures nothing.
    """
    env = envelope_at_density(ctx.profile.envelope, isa_density_ratio(ctx.site["ground_alt_m"] + plan.agl_m))
    local = draft.local(ctx.frame)
    to = math.radians(float(ctx.wind["from_deg"]) + 180.0)
    we, wn = float(ctx.wind["speed_mps"]) * math.sin(to), float(ctx.wind["speed_mps"]) * math.cos(to)
    ve = vn = 0.0
    if not env.is_multirotor:
        hdg = math.radians(plan.heading_deg)
        ve, vn = env.cruise_speed_mps * math.sin(hdg) + we, env.cruise_speed_mps * math.cos(hdg) + wn
    e, n = float(plan.start_en[0]), float(plan.start_en[1])
    sensors = SensorConfig()
    k = GeofenceConfig.uncertainty_k_sigma  # the unit's default k
    r = activation_margins(
        local,
        e,
        n,
        plan.agl_m,
        ve,
        vn,
        0.0,
        env,
        we,
        wn,
        h_uncertainty_m=k * sensors.gps_h_sigma_m,
        v_uncertainty_m=k * sensors.gps_v_sigma_m,
    )
    return r.lateral_activation_m > 0.0


def _assemble(
    index: int,
    family: CaseFamily,
    attack: Attack,
    ctx: CaseContext,
    draft: FenceDraft,
    plan: Plan,
    wind: dict,
    case_seed: int,
    rng: np.random.Generator,
    faults: bool = False,
    downward_sensors: bool = False,
) -> Case:
    frame = ctx.frame
    case_id = f"{family.value}-{index:04d}"
    lat, lon = _ll(frame, np.asarray(plan.start_en, float))[0]
    start = {
        "lat_deg": lat,
        "lon_deg": lon,
        "ground_alt_m": ctx.site["ground_alt_m"],
        "agl_m": _r(plan.agl_m, 1),
        "heading_deg": _r(plan.heading_deg % 360.0, 1),
    }
    # gusts: re-time them at the planned approach (the wind was drawn before the plan existed)
    for g in wind.get("gusts", []):
        g["onset_s"] = _r(max(1.0, plan.approach_s + rng.uniform(-4.0, 1.0)), 1)
    duration = float(plan.duration_s)
    doc: dict[str, Any] = {
        "name": case_id,
        "description": f"campaign case {case_id}: {family.value} fence, {attack.value} pilot, {ctx.platform} at "
        f"{ctx.site['continent']} ({ctx.site['lat_deg']:.3f}, {ctx.site['lon_deg']:.3f}, "
        f"{ctx.site['ground_alt_m']:.0f} m), wind {wind['speed_mps']:g} m/s from {wind['from_deg']:g} deg",
        "aircraft": ctx.platform,
        "seed": case_seed,
        "duration_s": duration,
        "start": start,
    }
    if plan.mission is not None:
        doc["mission"] = plan.mission
        doc["pilot"] = {"type": "mission"}
    elif plan.pilot is not None:
        doc["pilot"] = dict(plan.pilot)
    else:
        doc["pilot"] = {"type": "scripted", "segments": plan.segments}
    doc["wind"] = wind
    fault = None
    if ctx.gps_fault is not None:
        at = _r(max(1.0, min(plan.approach_s, duration - 3.0) * ctx.gps_fault["at_fraction"]), 1)
        if ctx.gps_fault["kind"] == "fail":
            doc["sensors"] = {"gps_fail_at_s": at}
        else:
            doc["sensors"] = {"gps_outages": [[at, _r(at + ctx.gps_fault["length_s"], 1)]]}
        fault = doc["sensors"]
    fence = draft.mapping(frame)
    forecast: dict[str, Any] = {
        "speed_mps": _r(wind["speed_mps"] * rng.uniform(1.0 - FORECAST_SPEED_ERROR, 1.0 + FORECAST_SPEED_ERROR)),
        "from_deg": _r((wind["from_deg"] + rng.uniform(-FORECAST_DIRECTION_ERROR_DEG, FORECAST_DIRECTION_ERROR_DEG)) % 360.0, 1),
    }
    authority = wind_authority(wind, plan.agl_m, ctx.profile, ctx.site["ground_alt_m"])
    # the forecast states what an operator's does: the turbulence and the gusts too, each within 20 %
    # (drawn from a child generator: the cases' other draws stay as they were)
    told = _added_rng(rng)
    if authority["turbulence_sigma_mps"] > 0.0:
        forecast["turbulence_sigma_mps"] = _r(authority["turbulence_sigma_mps"] * told.uniform(0.8, 1.2))
    if wind.get("gusts"):
        forecast["gust_mps"] = _r(max(g["amplitude_mps"] for g in wind["gusts"]) * told.uniform(0.8, 1.2))
    single = (
        draw_fault(np.random.default_rng([case_seed, FAULT_STREAM]), ctx.multirotor, plan.approach_s, duration)
        if faults
        else None
    )
    documents = {}
    for variant in Variant:
        d = dict(doc)
        d["name"] = f"{case_id}__{variant.value}"
        if variant is not Variant.UNPROTECTED:
            d["geofence"] = {"fence": fence, "trigger": variant.value, "wind_prior": forecast}
            if downward_sensors and ctx.profile.envelope.is_multirotor:
                d["sensors"] = {**d.get("sensors", {}), **DOWNWARD_SENSORS}
        if single is not None and (variant is not Variant.UNPROTECTED or "at_s" in single):
            d["faults"] = [single]  # (the unprotected twin has no unit to time a fault from its activation)
        documents[variant] = d
    local = draft.local(frame)
    manifest = {
        "case_id": case_id,
        "family": family.value,
        "attack": attack.value,
        "pilot": (
            PilotKind.MISSION if plan.mission is not None else PilotKind(plan.pilot["type"]) if plan.pilot else PilotKind.SCRIPTED
        ).value,
        "platform": ctx.platform,
        "platform_kind": ctx.profile.kind.value,
        "seed": case_seed,
        "site": dict(ctx.site),
        "wind": wind,
        "design_wind_mps": round(ctx.design_wind_mps, 2),
        **authority,
        "gps_fault": fault,
        **({"faults": [single]} if single is not None else {}),
        "room_m": round(ctx.room_m, 1),
        "worst_case_shift_m": round(ctx.shift_m, 1),
        "inradius_m": round(local.inradius()[2], 1),
        "fence_span_m": round(draft.span_m(), 1),
        "duration_s": duration,
        "start": start,
        "fence": fence,
        "files": {v.value: f"{case_id}__{v.value}.yaml" for v in Variant},
    }
    return Case(case_id, family, attack, documents, manifest)


# --------------------------------------------------------------------------- the campaign
_OWN_TEXT_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
"""Reads back the documents the generator itself wrote: libyaml's C parser (about 8x faster) where PyYAML has it.
Never for a user's file: a hostile document (deep nesting) crashes the C parser, where the Python one refuses it
in one line (``scenarios.definition.schema.read_document``)."""


def _validate(text: str, where: str) -> None:
    from scenarios.definition.schema import parse_scenario

    try:
        parse_scenario(yaml.load(text, Loader=_OWN_TEXT_LOADER), where=where)  # noqa: S506 - a SafeLoader
    except ConfigError as exc:
        raise CampaignError(f"generator bug: the schema rejects a generated scenario: {exc}") from None


def case_family(i: int, families: Sequence[CaseFamily]) -> CaseFamily:
    """The family of case ``i``: the last of ``n`` families takes every n-th case (``i % n == n - 1``), the
    others take turns in the rest (``families[i % (n - 1)]``); every family gets 1 in n of the cases.

    A family added at the end of a list that was cycled by plain turns (``i % (n - 1)``) so takes over only
    its own cases: the default list's last family, :attr:`CaseFamily.CIRCLE`, was added after campaigns with
    the other nine had been published, and every other case of those campaigns keeps its family.
    """
    n = len(families)
    if n == 1:
        return families[0]
    return families[-1] if i % n == n - 1 else families[i % (n - 1)]


DEFAULT_PLATFORMS = ("F450", "F450RD", "J3Cub", "Micro250", "Tern", "c172x")
"""The platforms a campaign draws from unless told (``--platforms``): the profiles measured by hand. A fixed list,
so that a seed keeps drawing the same cases when profiles are added (``characterize`` writes new ones)."""


def generate_cases(
    n_cases: int,
    seed: int,
    *,
    platforms: Sequence[str] | None = None,
    families: Sequence[CaseFamily] | None = None,
    max_duration_s: float = DEFAULT_MAX_DURATION_S,
    faults: bool = False,
    downward_sensors: bool = False,
    first_case: int = 0,
) -> list[Case]:
    """The cases of a campaign, in memory (see :func:`generate_campaign`)."""
    if n_cases < 0:
        raise ConfigError(f"n_cases: must be >= 0, got {n_cases}")
    if isinstance(first_case, bool) or not isinstance(first_case, int) or first_case < 0:
        raise ConfigError(f"first_case: must be an integer >= 0, got {first_case!r}")
    if not max_duration_s >= 20.0:
        raise ConfigError(f"max_duration_s: must be >= 20 s, got {max_duration_s}")
    known = available_profiles()
    platforms = list(platforms) if platforms is not None else list(DEFAULT_PLATFORMS)
    bad = [p for p in platforms if p not in known]
    if bad or not platforms:
        raise ConfigError(f"platforms: unknown {bad} (known: {', '.join(known)})" if bad else "platforms: empty")
    families = list(families) if families is not None else list(DEFAULT_FAMILIES)
    if not families or not all(isinstance(f, CaseFamily) for f in families):
        raise ConfigError(f"families: expected CaseFamily members, got {families!r}")
    cases = []
    for i in range(first_case, first_case + n_cases):
        family = case_family(i, families)
        case = build_case(i, seed, family, platforms, max_duration_s, faults, downward_sensors=downward_sensors)
        if case is not None:
            cases.append(case)
    return cases


def generate_campaign(
    out_dir: Path,
    n_cases: int,
    seed: int,
    *,
    platforms: Sequence[str] | None = None,
    families: Sequence[CaseFamily] | None = None,
    max_duration_s: float = DEFAULT_MAX_DURATION_S,
    faults: bool = False,
    downward_sensors: bool = False,
    first_case: int = 0,
) -> list[Path]:
    """Write ``n_cases`` cases x 3 variants of scenario YAML and ``campaign.json`` into ``out_dir``: cases
    ``first_case`` to ``first_case + n_cases - 1`` (a shard of a larger campaign: case ``i`` is the same in every
    shard that holds it).

    Families take turns (:func:`case_family`); everything else
    is drawn from ``numpy.random.default_rng([seed, i])``, so the same
    arguments always write the same files, and case ``i`` does not depend on
    ``n_cases``. ``platforms`` defaults to :data:`DEFAULT_PLATFORMS`; a case whose
    fence fits none of them is left out (the manifest counts it). Flights last
    at most ``max_duration_s`` of simulated time. With ``faults`` every case carries one single failure
    (:func:`draw_fault`) instead of the GPS faults some draw; with ``downward_sensors`` every multirotor's unit carries
    a rangefinder and an optical flow (the seed unit's downward sensing). Returns the YAML paths written.
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise ConfigError(f"seed: must be an integer in [0, 2^63) (numpy seeds are non-negative), got {seed!r}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cases = generate_cases(
        n_cases, seed, platforms=platforms, families=families, max_duration_s=max_duration_s, faults=faults,
        downward_sensors=downward_sensors, first_case=first_case,
    )  # fmt: skip
    written = []
    for case in cases:
        for variant, doc in case.documents.items():
            path = out_dir / case.manifest["files"][variant.value]
            text = (
                f"# generated by scenarios/campaign/generator.py (seed {seed}); {case.case_id} / {variant.value}\n"
                + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=140)
            )
            _validate(text, str(path))
            path.write_text(text)
            written.append(path)
    manifest = {
        "generator": "scenarios/campaign/generator.py",
        "seed": int(seed),
        **({"first_case": int(first_case)} if first_case else {}),  # (a shard's; campaigns from case 0 as before)
        "n_cases_requested": int(n_cases),
        "n_cases": len(cases),
        "skipped_cases": int(n_cases) - len(cases),
        "max_duration_s": float(max_duration_s),
        "platforms": list(platforms) if platforms is not None else list(DEFAULT_PLATFORMS),
        "families": [f.value for f in (families or DEFAULT_FAMILIES)],
        "variants": [v.value for v in Variant],
        **({"faults": "one single failure per case"} if faults else {}),
        **({"downward_sensors": "a rangefinder and an optical flow on every multirotor"} if downward_sensors else {}),
        "cases": [c.manifest for c in cases],
    }
    (out_dir / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n")
    return written
