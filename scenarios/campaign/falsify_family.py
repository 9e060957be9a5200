"""The falsifier's parametrised family: a point of the unit cube -> an ordinary scenario document.

One case is a box keep-in at a fixed site, flown at by a scripted pilot who holds a course into its
east edge (outward normal 090) and keeps pushing. Every continuous parameter is normalised to [0, 1]
(:data:`PARAMETERS`, in this order); :func:`case_document` maps a point to the scenario mapping for a
platform and a geofence variant (predictive or reactive), deterministically (the same point, platform and
variant give the same document, byte for byte once dumped). The document passes
:func:`scenarios.definition.schema.parse_scenario` for every point of the cube (tested with hypothesis).

Sizes follow the campaign generator's (:mod:`scenarios.campaign.generator`): the *scale* of a case is
the larger of the platform's room (:func:`~scenarios.campaign.generator.platform_room_m`) and the
geofence's worst-case lateral shift in the case's design wind (steady + gust + 1.5 rough turbulence
sigma); the box's half-depth is ``size`` scales, the start ``distance`` scales from the edge. The wind
(steady + gust) stays within the generator's fair-case limit
(:func:`~scenarios.campaign.generator.wind_limit_mps`: 0.7 x a multirotor's top speed, 0.5 x a
fixed-wing's cruise), below the mean wind the schema refuses. The geofence is told the true mean wind, the
turbulence sigma and the gust amplitude as its forecast (``wind_prior``).

The speed is a fraction, but the scripted pilot flies named speeds: below one half it flies ``cruise``,
from one half ``max`` (the generator's two lateral speeds). The turbulence seed is ``floor(x * 10_000)``
(the scenario ``seed``: the turbulence and the sensor noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from aircraft.profile import PlatformProfile, load_profile
from geofence.geometry.geodesy import LocalFrame
from geofence.physics.rooms import worst_case_lateral_shift_m
from geofence.validation import ConfigError
from scenarios.campaign.generator import (
    TURBULENCE_SIGMA_MPS,
    CaseContext,
    FenceDraft,
    Plan,
    Variant,
    legal_start,
    platform_room_m,
    wind_authority,
    wind_limit_mps,
)


@dataclass(frozen=True)
class Parameter:
    """One coordinate of the family: its name, what 0 and 1 stand for, and its unit."""

    name: str
    low: float
    high: float
    unit: str
    meaning: str

    def value(self, x: float) -> float:
        return self.low + min(max(float(x), 0.0), 1.0) * (self.high - self.low)


PARAMETERS: tuple[Parameter, ...] = (
    Parameter("incidence", -75.0, 75.0, "deg", "course off the edge's outward normal (+: toward the north corner)"),
    Parameter("speed", 0.0, 1.0, "", "speed fraction: < 0.5 cruise, >= 0.5 max"),
    Parameter("distance", 1.2, 3.0, "scales", "start distance from the edge (perpendicular)"),
    Parameter("wind_speed", 0.0, 1.0, "of limit", "steady wind as a fraction of the fair-case wind limit"),
    Parameter("wind_from", 0.0, 360.0, "deg", "direction the wind comes from (090: straight out of the edge)"),
    Parameter("gust", 0.0, 1.0, "of rest", "gust amplitude as a fraction of the limit left above the steady wind"),
    Parameter("gust_timing", -6.0, 4.0, "s", "gust onset relative to the expected arrival at the edge"),
    Parameter("seed", 0.0, 9_999.0, "", "turbulence (and sensor noise) seed, floor of the value"),
    Parameter("size", 3.0, 6.0, "scales", "box half-depth (and half-length beyond the attack's run)"),
)
"""The family's coordinates in the order of a parameter vector."""
DIMENSION = len(PARAMETERS)

SITE: dict[str, Any] = {"continent": "oceania", "lat_deg": -35.363262, "lon_deg": 149.165237, "ground_alt_m": 584.0}
HEIGHTS_M = {True: (30.0, 80.0), False: (100.0, 250.0)}
"""(flight height, ceiling) m AGL for a multirotor (True) and a fixed-wing (False)."""
TURBULENCE = "light"
GUST_LENGTH_M = 40.0
SETTLE_S = 20.0
"""Flown after the expected arrival at the edge (a fixed-wing adds its half turn)."""
DEFAULT_MAX_DURATION_S = 120.0
FALSIFY_VARIANTS = (Variant.PREDICTIVE, Variant.REACTIVE)


@dataclass(frozen=True)
class CaseGeometry:
    """A point's physical values (SI) and the sizes derived from them, as written in the document."""

    values: dict[str, float]
    scale_m: float
    approach_s: float
    legal_start: bool
    """The start is outside the predictive unit's activation boundary (:func:`~scenarios.campaign.generator.legal_start`)."""


def physical_values(x: np.ndarray | list[float]) -> dict[str, float]:
    """The named physical values of a point of the cube (clipped into it)."""
    x = np.asarray(x, dtype=float)
    if x.shape != (DIMENSION,) or not np.all(np.isfinite(x)):
        raise ConfigError(f"falsify family: expected {DIMENSION} finite coordinates, got shape {x.shape}")
    return {p.name: p.value(v) for p, v in zip(PARAMETERS, x)}


def _wind(values: dict[str, float], profile: PlatformProfile) -> tuple[dict[str, Any], float, float]:
    """The ``wind:`` block without its gust onset, the gust amplitude and the design wind (m/s)."""
    limit = wind_limit_mps(profile)
    steady = round(values["wind_speed"] * limit, 2)
    gust = round(values["gust"] * max(limit - steady, 0.0), 2)
    wind: dict[str, Any] = {"speed_mps": steady, "from_deg": round(values["wind_from"] % 360.0, 1)}
    wind["turbulence"] = {"severity": TURBULENCE}
    return wind, gust, steady + gust + 1.5 * TURBULENCE_SIGMA_MPS[TURBULENCE]


def _approach_speed_mps(profile: PlatformProfile, speed: str) -> float:
    env = profile.envelope
    v = env.max_speed_mps if speed == "max" else env.cruise_speed_mps
    return max(0.6 * v, 2.0) if env.is_multirotor else v  # a multirotor starts from a hover


def case_document(
    x: np.ndarray | list[float],
    platform: str,
    variant: Variant,
    name: str = "falsify",
    max_duration_s: float = DEFAULT_MAX_DURATION_S,
) -> tuple[dict[str, Any], CaseGeometry]:
    """The scenario mapping of point ``x`` for ``platform`` and ``variant`` (predictive or reactive), and its geometry."""
    if variant not in FALSIFY_VARIANTS:
        raise ConfigError(f"falsify family: variant {variant.value}: only predictive or reactive")
    values = physical_values(x)
    profile = load_profile(platform)
    multirotor = profile.envelope.is_multirotor
    wind, gust, design = _wind(values, profile)
    shift = worst_case_lateral_shift_m(profile.envelope, design)
    room = platform_room_m(profile)
    scale = max(room, shift if math.isfinite(shift) else 0.0)
    theta = math.radians(values["incidence"])
    speed = "max" if values["speed"] >= 0.5 else "cruise"
    depth = values["distance"] * scale
    half_e, run_n = values["size"] * scale, depth * math.tan(theta)
    half_n = values["size"] * scale + abs(run_n) / 2.0
    start_en = np.array([half_e - depth, -run_n / 2.0])  # the target is (half_e, +run_n / 2)
    keep_in = np.array([[-half_e, -half_n], [half_e, -half_n], [half_e, half_n], [-half_e, half_n]])
    agl, ceiling = HEIGHTS_M[multirotor]
    course = (90.0 - values["incidence"]) % 360.0
    approach = depth / math.cos(theta) / _approach_speed_mps(profile, speed)
    turn_s = 0.0 if multirotor else math.pi * room / profile.envelope.cruise_speed_mps
    duration = round(min(approach + turn_s + SETTLE_S, max_duration_s), 1)
    if gust > 0.0:
        onset = round(max(approach + values["gust_timing"], 0.0), 1)
        wind["gusts"] = [{"onset_s": onset, "amplitude_mps": gust, "length_m": GUST_LENGTH_M}]
    frame = LocalFrame(SITE["lat_deg"], SITE["lon_deg"], SITE["ground_alt_m"])
    draft = FenceDraft(keep_in, ceiling)
    lat, lon, _ = frame.to_geodetic(float(start_en[0]), float(start_en[1]), 0.0)
    authority = wind_authority(wind, agl, profile, SITE["ground_alt_m"])
    prior: dict[str, Any] = {"speed_mps": wind["speed_mps"], "from_deg": wind["from_deg"]}
    if authority["turbulence_sigma_mps"] > 0.0:
        prior["turbulence_sigma_mps"] = authority["turbulence_sigma_mps"]
    if gust > 0.0:
        prior["gust_mps"] = gust
    doc: dict[str, Any] = {
        "name": name,
        "description": f"falsify family: box fence, scripted {speed} attack at {values['incidence']:.1f} deg incidence, "
        f"{platform}, {variant.value}",
        "aircraft": platform,
        "seed": int(values["seed"]),
        "duration_s": duration,
        "start": {
            "lat_deg": round(lat, 8),
            "lon_deg": round(lon, 8),
            "ground_alt_m": SITE["ground_alt_m"],
            "agl_m": agl,
            "heading_deg": round(course, 1),
        },  # fmt: skip
        "pilot": {"type": "scripted", "segments": [{"duration_s": duration, "course_deg": round(course, 1), "speed": speed}]},
        "wind": wind,
        "geofence": {"fence": draft.mapping(frame), "trigger": variant.value, "wind_prior": prior},
    }
    ctx = CaseContext(platform, profile, SITE, wind, design, room, shift, max_duration_s, None)
    legal = legal_start(ctx, draft, Plan(start_en, course, agl, [], approach, duration))
    return doc, CaseGeometry(values, round(scale, 1), round(approach, 1), legal)
