"""Geofence unit configuration: the ``geofence:`` block of a scenario, validated into a frozen dataclass.

Example (every key but ``fence`` optional)::

    geofence:
      fence: {keep_in: [[lat, lon], ...], ceiling_m: 60, floor_m: 5, floor_gaps: [...]}
      # or a fence file (any format geofence.importers.load_fence_file reads: GeoJSON, QGC .plan, WPL 110,
      # MAVProxy), its path relative to the scenario file; the other keys override or add to the file's:
      # fence: {file: airspace/city_park.geojson, ceiling_m: 60, floor_m: 5, floor_gaps: [...],
      #         recovery_point: [lat, lon], altitude_reference: agl}
      trigger: predictive          # predictive (shifted boundary) | reactive (act on the fence line)
      min_override_s: 2.0          # hold an override at least this long
      handback_margin_m: 5.0       # hand back once this far inside the activation boundary and moving inward
      recovery_radius_m: 10.0      # ... or once within this distance of the recovery point
      uncertainty_k_sigma: 2.0     # margin = k * estimator position sigma
      extra_margin_m: 0.0          # a fixed extra margin on every boundary
      multirotor_law: velocity     # velocity (default: brake, then fly back) | seed_pd (published PD + ramp)
      seed_pd: {kp_xy: 0.2, kd_xy: 0.4, kp_z: 0.4, kp_yaw: 0.5, ...}   # stick units per m, per m/s, per rad
      ramp_s: 3.0                  # seed_pd set-point ramp time
      recovery_speed_mps: 5.0      # multirotor return speed (default: half cruise)
      max_reactivations: 3         # still outside after this many override periods -> land in a gap
      wind_prior: {speed_mps: 8, from_deg: 240, turbulence_sigma_mps: 1.0, gust_mps: 3}
                                   # forecast: mean wind until the estimate converges; turbulence
                                   # sigma and gust amplitude (m/s) for the activation margin
      turbulence_k_sigma: 1.5      # wind allowance = k * turbulence sigma + gust
      turbulence_source: estimate  # estimate (max of forecast and the unit's estimate, default) | forecast
      vertical_handback_m: 2.0     # hand back only this far inside the vertical activation boundary
      state_source: estimate       # estimate (own sensors + Kalman filter, default) | truth (e.g. indoor motion capture)

All messages are one line: ``<where>.<field>: <problem>``.

Fence files (``fence: {file: ...}``): a relative path is resolved against ``base_dir`` (the scenario
file's folder, see :func:`scenarios.spec.schema.parse_scenario`); against the working directory only when
no ``base_dir`` is known. Inline ``ceiling_m``, ``floor_m`` and ``altitude_reference`` win over the
file's values (GeoJSON properties); ``floor_gaps`` are added (no format carries them); an inline
``recovery_point`` replaces the file's return point as the recovery point. A ceiling is required:
inline, or in the file (a scenario never flies under the importer's silent default). The importer's
warnings (dropped keep-outs, ignored zones, ...) are kept in :attr:`GeofenceConfig.fence_warnings`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any

from geofence.fence import ALTITUDE_REFERENCES, Fence, FenceError, parse_fence
from geofence.importers import load_fence_file

TRIGGERS = ("predictive", "reactive")
MULTIROTOR_LAWS = ("velocity", "seed_pd")


class TurbulenceSource(str, Enum):
    """Which turbulence intensity the activation margin allows for."""

    FORECAST = "forecast"
    """The forecast's ``wind_prior.turbulence_sigma_mps`` only."""
    ESTIMATE = "estimate"
    """The larger of the forecast and the unit's own estimate (the spread of its wind samples, noise included),
    the default: on the rotor-drag multirotors in 8 m/s wind with moderate turbulence it cut breaches from
    16 to 5 of 50 (Micro250)."""


class GeofenceConfigError(ValueError):
    """A bad ``geofence:`` block; the message is one line naming the field."""


@dataclass(frozen=True)
class SeedPDGains:
    """The seed work's decoupled PD law, in stick units (1 stick = 500 µs of RC PWM; see README).

    ``*_limit`` are the per-axis saturations of the override command,
    ``*_deadband`` the dead zones inside which an axis gets the neutral stick.
    """

    kp_xy: float = 0.2  # 100 µs/m
    kd_xy: float = 0.4  # 200 µs/(m/s)
    kp_z: float = 0.4  # 200 µs/m
    kd_z: float = 0.0
    kp_yaw: float = 0.5  # per rad; yaw is purely proportional
    xy_limit: float = 0.24  # ±120 µs
    z_limit: float = 0.15  # ±75 µs
    yaw_limit: float = 0.15  # ±75 µs
    z_deadband_m: float = 0.05
    yaw_deadband_rad: float = 0.009


@dataclass(frozen=True)
class GeofenceConfig:
    fence: Fence
    trigger: str = "predictive"
    min_override_s: float = 2.0
    handback_margin_m: float = 5.0
    recovery_radius_m: float = 10.0
    uncertainty_k_sigma: float = 2.0
    extra_margin_m: float = 0.0
    multirotor_law: str = "velocity"
    seed_pd: SeedPDGains = field(default_factory=SeedPDGains)
    ramp_s: float = 3.0
    recovery_speed_mps: float | None = None
    max_reactivations: int = 3
    wind_prior_enu: tuple[float, float] = (0.0, 0.0)
    """Forecast wind (east, north m/s, toward) used until the estimate converges."""
    state_source: str = "estimate"
    """``estimate``: the unit's own sensors and filter; ``truth``: a perfect position source (motion capture)."""
    turbulence_sigma_mps: float = 0.0
    """Forecast turbulence intensity (1-sigma of the horizontal gust velocity, m/s)."""
    gust_mps: float = 0.0
    """Forecast discrete-gust amplitude (m/s) added to the wind the margin allows for."""
    turbulence_k_sigma: float = 1.5
    """The wind allowance is ``k * sigma + gust_mps`` (sigma per :attr:`turbulence_source`)."""
    turbulence_source: TurbulenceSource = TurbulenceSource.ESTIMATE
    vertical_handback_m: float = 2.0
    """Vertical hysteresis: hand back only with the vertical activation margin at least this large."""
    fence_file: str | None = None
    """The fence file the fence was read from (resolved path), or None for an inline fence."""
    fence_warnings: tuple[str, ...] = ()
    """The importer's warnings about the fence file (one line each)."""


_KEYS = {
    "fence", "trigger", "min_override_s", "handback_margin_m", "recovery_radius_m", "uncertainty_k_sigma",
    "extra_margin_m", "multirotor_law", "seed_pd", "ramp_s", "recovery_speed_mps", "max_reactivations", "wind_prior",
    "state_source", "turbulence_k_sigma", "vertical_handback_m", "turbulence_source",
}


FENCE_FILE_KEYS = ("file", "ceiling_m", "floor_m", "floor_gaps", "recovery_point", "altitude_reference")
"""The keys of a ``fence:`` block that references a fence file."""


def parse_geofence(raw: Any, where: str = "geofence", base_dir: str | Path | None = None) -> GeofenceConfig:
    """Validate a ``geofence:`` mapping into a :class:`GeofenceConfig`.

    ``base_dir``: the folder a relative ``fence: {file: ...}`` is resolved against (the scenario file's).
    """
    if not isinstance(raw, Mapping):
        raise GeofenceConfigError(f"{where}: expected a mapping with at least a fence: block")
    unknown = sorted(str(k) for k in raw if k not in _KEYS)
    if unknown:
        raise GeofenceConfigError(f"{where}: unknown key {unknown[0]!r} (allowed: {', '.join(sorted(_KEYS))})")
    if "fence" not in raw:
        raise GeofenceConfigError(f"{where}.fence: missing (required)")
    fence_file, fence_warnings = None, ()
    try:
        if isinstance(raw["fence"], Mapping) and "file" in raw["fence"]:
            fence, fence_file, fence_warnings = _fence_from_file(raw["fence"], f"{where}.fence", base_dir)
        else:
            fence = parse_fence(raw["fence"], f"{where}.fence")
    except FenceError as exc:
        raise GeofenceConfigError(str(exc)) from None

    def num(key: str, default: float, lo: float = 0.0, hi: float = math.inf) -> float:
        x = raw.get(key, default)
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x) or not lo <= x <= hi:
            raise GeofenceConfigError(f"{where}.{key}: must be a number in [{lo:g}, {hi:g}], got {x!r}")
        return float(x)

    def choice(key: str, default: str, options: tuple[str, ...]) -> str:
        x = raw.get(key, default)
        if x not in options:
            raise GeofenceConfigError(f"{where}.{key}: {x!r} is not one of {', '.join(options)}")
        return x

    gains = SeedPDGains()
    if raw.get("seed_pd") is not None:
        g = raw["seed_pd"]
        if not isinstance(g, Mapping):
            raise GeofenceConfigError(f"{where}.seed_pd: expected a mapping of gains")
        allowed = set(SeedPDGains.__dataclass_fields__)
        values = {}
        for k, v in g.items():
            if k not in allowed:
                raise GeofenceConfigError(f"{where}.seed_pd: unknown key {k!r} (allowed: {', '.join(sorted(allowed))})")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise GeofenceConfigError(f"{where}.seed_pd.{k}: must be a number >= 0, got {v!r}")
            values[k] = float(v)
        gains = SeedPDGains(**values)

    prior = (0.0, 0.0)
    turb = gust = 0.0
    if raw.get("wind_prior") is not None:
        w = raw["wind_prior"]
        allowed = ("speed_mps", "from_deg", "turbulence_sigma_mps", "gust_mps")
        if not isinstance(w, Mapping) or set(w) - set(allowed):
            raise GeofenceConfigError(f"{where}.wind_prior: expected a mapping with keys from {', '.join(allowed)}")
        values = {k: w.get(k, 0.0) for k in allowed}
        for k, v in values.items():
            nonneg = k != "from_deg"
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (nonneg and v < 0):
                raise GeofenceConfigError(f"{where}.wind_prior.{k}: must be a finite number{' >= 0' if nonneg else ''}, got {v!r}")
        speed, to = values["speed_mps"], math.radians(values["from_deg"] + 180.0)
        prior = (speed * math.sin(to), speed * math.cos(to))
        turb, gust = float(values["turbulence_sigma_mps"]), float(values["gust_mps"])

    speed = raw.get("recovery_speed_mps")
    max_react = raw.get("max_reactivations", 3)
    if isinstance(max_react, bool) or not isinstance(max_react, int) or max_react < 0:
        raise GeofenceConfigError(f"{where}.max_reactivations: must be an integer >= 0, got {max_react!r}")
    return GeofenceConfig(
        fence=fence,
        trigger=choice("trigger", "predictive", TRIGGERS),
        min_override_s=num("min_override_s", 2.0, 0.0, 60.0),
        handback_margin_m=num("handback_margin_m", 5.0, 0.0, 1000.0),
        recovery_radius_m=num("recovery_radius_m", 10.0, 0.1, 10000.0),
        uncertainty_k_sigma=num("uncertainty_k_sigma", 2.0, 0.0, 10.0),
        extra_margin_m=num("extra_margin_m", 0.0, 0.0, 1000.0),
        multirotor_law=choice("multirotor_law", "velocity", MULTIROTOR_LAWS),
        seed_pd=gains,
        ramp_s=num("ramp_s", 3.0, 0.0, 60.0),
        recovery_speed_mps=None if speed is None else num("recovery_speed_mps", 0.0, 0.1, 100.0),
        max_reactivations=max_react,
        wind_prior_enu=prior,
        state_source=choice("state_source", "estimate", ("estimate", "truth")),
        turbulence_sigma_mps=turb,
        gust_mps=gust,
        turbulence_k_sigma=num("turbulence_k_sigma", 1.5, 0.0, 10.0),
        vertical_handback_m=num("vertical_handback_m", 2.0, 0.0, 100.0),
        turbulence_source=TurbulenceSource(choice("turbulence_source", "estimate", tuple(t.value for t in TurbulenceSource))),
        fence_file=fence_file,
        fence_warnings=tuple(fence_warnings),
    )


def fence_file_path(file: Any, where: str, base_dir: str | Path | None) -> Path:
    """The path a ``fence.file`` value names: relative ones against ``base_dir`` (the scenario's folder)."""
    if not isinstance(file, str) or not file.strip():
        raise GeofenceConfigError(f"{where}.file: must be a path to a fence file, got {file!r}")
    path = Path(file).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    return path


def _fence_from_file(block: Mapping, where: str, base_dir: str | Path | None) -> tuple[Fence, str, list[str]]:
    """A ``fence: {file: ..., <overrides>}`` block: the file read by the importer, the inline keys applied."""
    unknown = [k for k in block if k not in FENCE_FILE_KEYS]
    if unknown:
        extra = " (keep_in comes from the file)" if "keep_in" in unknown else ""
        raise GeofenceConfigError(f"{where}: unknown key(s) {', '.join(repr(k) for k in unknown)} with a fence file "
                                  f"(allowed: {', '.join(FENCE_FILE_KEYS)}){extra}")
    path = fence_file_path(block["file"], where, base_dir)
    if not path.is_file():
        place = f" (relative to {base_dir})" if base_dir is not None and not Path(block["file"]).is_absolute() else ""
        if path.exists():
            raise GeofenceConfigError(f"{where}.file: {block['file']!r} is not a file{place}")
        raise GeofenceConfigError(f"{where}.file: no such file {block['file']!r}{place}")
    for key in ("ceiling_m", "floor_m"):
        v = block.get(key)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)):
            raise GeofenceConfigError(f"{where}.{key}: must be a number, got {v!r}")
    ref = block.get("altitude_reference")
    if ref is not None and (not isinstance(ref, str) or ref.lower() not in ALTITUDE_REFERENCES):
        raise GeofenceConfigError(f"{where}.altitude_reference: must be 'agl' or 'amsl', got {ref!r}")
    gaps = block.get("floor_gaps")
    if gaps is not None and (isinstance(gaps, (str, Mapping)) or not isinstance(gaps, (list, tuple))):
        raise GeofenceConfigError(f"{where}.floor_gaps: must be a list of polygons, got {type(gaps).__name__}")
    try:
        imported = load_fence_file(path, ceiling_m=block.get("ceiling_m"), floor_m=block.get("floor_m"),
                                   altitude_reference=ref, floor_gaps=tuple(gaps or ()),
                                   recovery_point=block.get("recovery_point"))
    except FenceError as exc:
        msg = str(exc)
        rest = msg[len(str(path)) + 2:] if msg.startswith(f"{path}: ") else msg
        field = re.match(r"[a-z_]*", rest).group(0)
        if field in block and field != "file":  # the inline value is the problem (e.g. a floor gap outside the keep-in)
            raise GeofenceConfigError(f"{where}.{rest}") from None
        raise GeofenceConfigError(f"{where}.file: {msg}") from None
    if imported.ceiling_source == "default":
        raise GeofenceConfigError(f"{where}.ceiling_m: required: the fence file {block['file']!r} gives no ceiling")
    return imported.fence, str(path), list(imported.warnings)
