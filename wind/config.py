"""Wind configuration: frozen dataclasses, YAML validation and the field builder.

The ``wind:`` block of a scenario::

    wind:
      speed_mps: 8                 # steady speed at the profile's reference height (default 0)
      from_deg: 270                # direction FROM, deg clockwise from north (required if speed_mps > 0)
      profile: {law: power, exponent: 0.14, reference_height_m: 10}      # optional
      #        {law: log, roughness_length_m: 0.03, reference_height_m: 10}
      #        {law: uniform}      (the default: same speed at every height)
      turbulence: {severity: light}     # light | moderate | severe | none, or {w20_mps: 7.7} (<= 23.15,
                                        # severe); optional
      gusts:                            # optional list of discrete 1-cos gusts
        - {onset_s: 20, amplitude_mps: 5, length_m: 30, from_deg: 270}
        - {onset_s: 1.5, onset_after: first_activation, amplitude_mps: 4, length_m: 20}
                                        # onset_after: start (default) | first_activation (1.5 s after the
                                        # geofence first overrides the pilot: a gust at the worst moment)
        #   optional per gust: vertical_mps (signed, + up), hold_m (>= 0, .inf = rise and hold),
        #   penetration_speed_mps (fixed speed: time-based gust); from_deg defaults to the steady one
      random_gusts:                     # optional: gusts drawn from the seed
        {count: 3, start_s: 10, end_s: 60, amplitude_mps: [2, 6], length_m: [10, 40],
         spread_deg: 30}                #   optional: from_deg (default steady), vertical_mps: [lo, hi]
      seed: 7                           # optional; else the scenario seed is used

:func:`parse_wind` validates such a mapping; every error is a :class:`~geofence.validation.ConfigError`
with one line ``<where>.<field>: <problem>`` (``where`` names the block, e.g.
``"scenarios/x.yaml: wind"``). Unknown keys are errors (typo protection).

:func:`wind_from_config` builds the :class:`~wind.field.WindField`. Seeds: the
turbulence and the random gusts get independent streams derived from the wind
seed (``numpy.random.SeedSequence(seed, spawn_key=(k,))``), distinct from a
plain ``default_rng(seed)`` that other parts of a scenario may use.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from geofence.validation import (
    ConfigError,
    direction_deg,
    enum_value,
    field_default,
    integer,
    kind,
    number,
    number_range,
    reject_unknown_keys,
    require_mapping,
    string,
)
from wind.dryden import SEVERITY_W20_MPS, DrydenTurbulence
from wind.field import CalmWind, CompositeWind, WindField
from wind.gust import Gust, GustTrain
from wind.steady import LogLawProfile, PowerLawProfile, SteadyWind, UniformProfile, WindProfile

PROFILE_LAWS = ("uniform", "power", "log")
SEVERITIES = (*SEVERITY_W20_MPS, "none")

MAX_W20_MPS = SEVERITY_W20_MPS["severe"]
"""The largest ``turbulence.w20_mps`` (45 kt, 23.15 m/s: MIL-HDBK-1797's "severe"): the Dryden
low-altitude model is specified up to there, and beyond it the gusts exceed what a small UAS flies in
(at 10^9 m/s the flight diverges)."""

_TURBULENCE_STREAM = 0
_GUST_STREAM = 1


@dataclass(frozen=True)
class ProfileConfig:
    """Height profile of the steady wind (see :mod:`wind.steady`)."""

    law: str = "uniform"
    exponent: float = 0.14
    reference_height_m: float = 10.0
    roughness_length_m: float = 0.03

    def build(self) -> WindProfile:
        if self.law == "power":
            return PowerLawProfile(self.exponent, self.reference_height_m)
        if self.law == "log":
            return LogLawProfile(self.roughness_length_m, self.reference_height_m)
        if self.law == "uniform":
            return UniformProfile()
        raise ConfigError(f"unknown profile law {self.law!r} (known: {', '.join(PROFILE_LAWS)})")


@dataclass(frozen=True)
class TurbulenceConfig:
    """Dryden turbulence: a severity name, or an explicit W20 (wind speed at 20 ft) in m/s."""

    severity: str | None = None
    w20_mps: float | None = None

    @property
    def resolved_w20_mps(self) -> float:
        if self.w20_mps is not None:
            return self.w20_mps
        if self.severity is None or self.severity == "none":
            return 0.0
        return SEVERITY_W20_MPS[self.severity]


class GustOnset(StrEnum):
    """What a gust's ``onset_s`` counts from."""

    START = "start"
    """The start of the flight (the default)."""
    FIRST_ACTIVATION = "first_activation"
    """The geofence's first override of the pilot: a gust at the worst moment, whenever that comes."""


@dataclass(frozen=True)
class GustConfig:
    """One discrete gust; ``from_deg`` None means the steady wind's direction."""

    onset_s: float
    amplitude_mps: float
    length_m: float
    from_deg: float | None = None
    vertical_mps: float = 0.0
    hold_m: float = 0.0
    penetration_speed_mps: float | None = None
    onset_after: GustOnset = GustOnset.START


@dataclass(frozen=True)
class RandomGustsConfig:
    """``count`` gusts drawn from the wind seed (see :meth:`wind.gust.GustTrain.random`)."""

    count: int
    start_s: float
    end_s: float
    amplitude_mps: tuple[float, float]
    length_m: tuple[float, float]
    from_deg: float | None = None
    spread_deg: float = 0.0
    vertical_mps: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class WindConfig:
    """The whole wind configuration of a scenario. The default is calm air."""

    speed_mps: float = 0.0
    from_deg: float = 0.0
    profile: ProfileConfig | None = None
    turbulence: TurbulenceConfig | None = None
    gusts: tuple[GustConfig, ...] = ()
    random_gusts: RandomGustsConfig | None = None
    seed: int | None = None

    @property
    def is_calm(self) -> bool:
        t = self.turbulence
        return (
            self.speed_mps == 0.0
            and (t is None or t.resolved_w20_mps == 0.0)
            and not any(g.amplitude_mps > 0.0 or g.vertical_mps != 0.0 for g in self.gusts)
            and (self.random_gusts is None or self.random_gusts.count == 0)
        )


# --------------------------------------------------------------------------- builder


def wind_from_config(cfg: WindConfig | None, seed: int | None = None) -> WindField:
    """The wind field a configuration describes.

    ``seed`` is the scenario seed, used when ``cfg.seed`` is None (0 if both are
    None, so a run is always reproducible). Components: steady wind (if
    speed_mps > 0), Dryden turbulence (if W20 > 0) and a gust train (if any
    gusts), summed; calm air gives :class:`~wind.field.CalmWind`.
    """
    if cfg is None:
        return CalmWind()
    s = cfg.seed if cfg.seed is not None else (seed if seed is not None else 0)
    components: list[WindField] = []
    steady = None
    if cfg.speed_mps > 0.0:
        profile = cfg.profile.build() if cfg.profile is not None else None
        steady = SteadyWind(cfg.speed_mps, cfg.from_deg, profile)
        components.append(steady)
    if cfg.turbulence is not None and cfg.turbulence.resolved_w20_mps > 0.0:
        components.append(
            DrydenTurbulence(
                cfg.turbulence.resolved_w20_mps,
                seed=np.random.SeedSequence(s, spawn_key=(_TURBULENCE_STREAM,)),
                mean_wind=steady,
            )
        )

    def gust(g: GustConfig) -> Gust:
        return Gust(
            onset_s=g.onset_s,
            amplitude_mps=g.amplitude_mps,
            length_m=g.length_m,
            from_deg=cfg.from_deg if g.from_deg is None else g.from_deg,
            vertical_mps=g.vertical_mps,
            hold_m=g.hold_m,
            penetration_speed_mps=g.penetration_speed_mps,
        )

    gusts = [gust(g) for g in cfg.gusts if g.onset_after is GustOnset.START]
    after_activation = [gust(g) for g in cfg.gusts if g.onset_after is GustOnset.FIRST_ACTIVATION]
    rg = cfg.random_gusts
    if rg is not None and rg.count > 0:
        drawn = GustTrain.random(
            np.random.SeedSequence(s, spawn_key=(_GUST_STREAM,)),
            count=rg.count,
            start_s=rg.start_s,
            end_s=rg.end_s,
            amplitude_mps=rg.amplitude_mps,
            length_m=rg.length_m,
            from_deg=cfg.from_deg if rg.from_deg is None else rg.from_deg,
            spread_deg=rg.spread_deg,
            vertical_mps=rg.vertical_mps,
        )
        gusts.extend(drawn.gusts)
    if gusts or after_activation:
        components.append(GustTrain(gusts, mean_wind=steady, after_first_activation=after_activation))
    if not components:
        return CalmWind()
    if len(components) == 1:
        return components[0]
    return CompositeWind(components)


# --------------------------------------------------------------------------- validation (geofence.validation)

_WIND_KEYS = ("speed_mps", "from_deg", "profile", "turbulence", "gusts", "random_gusts", "seed")
_PROFILE_KEYS = {
    "uniform": ("law",),
    "power": ("law", "exponent", "reference_height_m"),
    "log": ("law", "roughness_length_m", "reference_height_m"),
}
_TURBULENCE_KEYS = ("severity", "w20_mps")
_GUST_KEYS = (
    "onset_s",
    "onset_after",
    "amplitude_mps",
    "length_m",
    "from_deg",
    "vertical_mps",
    "hold_m",
    "penetration_speed_mps",
)
_RANDOM_GUST_KEYS = ("count", "start_s", "end_s", "amplitude_mps", "length_m", "from_deg", "spread_deg", "vertical_mps")


def parse_wind(mapping: Any, where: str = "wind") -> WindConfig:
    """Validate the ``wind:`` block of a scenario (already loaded from YAML).

    ``where`` names the block in messages (e.g. ``"scenarios/x.yaml: wind"``);
    errors read ``"<where>.gusts[1].amplitude_mps: must be >= 0, got -3"``.
    An empty block (None) is calm air.
    """
    if mapping is None:
        return WindConfig()
    m = require_mapping(mapping, where)
    reject_unknown_keys(m, _WIND_KEYS, where)

    speed = number(m.get("speed_mps", field_default(WindConfig, "speed_mps")), f"{where}.speed_mps", minimum=0.0)
    if "from_deg" in m:
        from_deg = direction_deg(m["from_deg"], f"{where}.from_deg")
    elif speed > 0.0:
        raise ConfigError(f"{where}.from_deg: missing (required when speed_mps > 0)")
    else:
        from_deg = field_default(WindConfig, "from_deg")

    profile = _parse_profile(m["profile"], f"{where}.profile") if m.get("profile") is not None else None
    turbulence = _parse_turbulence(m["turbulence"], f"{where}.turbulence") if m.get("turbulence") is not None else None

    gusts: tuple[GustConfig, ...] = ()
    if m.get("gusts") is not None:
        raw = m["gusts"]
        if not isinstance(raw, (list, tuple)):
            raise ConfigError(f"{where}.gusts: expected a list of gusts, got {kind(raw)}")
        gusts = tuple(_parse_gust(g, f"{where}.gusts[{i}]") for i, g in enumerate(raw))

    random_gusts = None
    if m.get("random_gusts") is not None:
        random_gusts = _parse_random_gusts(m["random_gusts"], f"{where}.random_gusts")

    seed = integer(m["seed"], f"{where}.seed", minimum=0) if m.get("seed") is not None else None
    return WindConfig(speed, from_deg, profile, turbulence, gusts, random_gusts, seed)


def _parse_profile(raw: Any, where: str) -> ProfileConfig:
    m = require_mapping(raw, where)
    if "law" not in m:
        raise ConfigError(f"{where}.law: missing (one of {', '.join(PROFILE_LAWS)})")
    law = string(m["law"], f"{where}.law", choices=PROFILE_LAWS)
    for key in m:
        if key not in _PROFILE_KEYS[law]:
            if any(key in keys for keys in _PROFILE_KEYS.values()):
                raise ConfigError(f"{where}.{key}: not used by law {law!r} (allowed: {', '.join(_PROFILE_KEYS[law])})")
    reject_unknown_keys(m, _PROFILE_KEYS[law], where)
    defaults = ProfileConfig()
    zref = number(m.get("reference_height_m", defaults.reference_height_m), f"{where}.reference_height_m", strictly_positive=True)
    exponent = defaults.exponent
    z0 = defaults.roughness_length_m
    if law == "power":
        exponent = number(m.get("exponent", defaults.exponent), f"{where}.exponent", strictly_positive=True, maximum=1.0)
    if law == "log":
        z0 = number(
            m.get("roughness_length_m", defaults.roughness_length_m), f"{where}.roughness_length_m", strictly_positive=True
        )
        if not zref > z0:
            raise ConfigError(f"{where}.reference_height_m: must be > roughness_length_m ({z0:g}), got {zref:g}")
    return ProfileConfig(law, exponent, zref, z0)


def _parse_turbulence(raw: Any, where: str) -> TurbulenceConfig:
    m = require_mapping(raw, where)
    reject_unknown_keys(m, _TURBULENCE_KEYS, where)
    has_sev, has_w20 = m.get("severity") is not None, m.get("w20_mps") is not None
    if has_sev == has_w20:
        raise ConfigError(f"{where}: give exactly one of severity ({', '.join(SEVERITIES)}) or w20_mps")
    if has_sev:
        sev = m["severity"]
        return TurbulenceConfig(
            severity=string(sev.lower() if isinstance(sev, str) else sev, f"{where}.severity", choices=SEVERITIES)
        )
    w20_mps = number(m["w20_mps"], f"{where}.w20_mps", minimum=0.0)
    if w20_mps > MAX_W20_MPS:
        raise ConfigError(
            f"{where}.w20_mps: must be <= {MAX_W20_MPS:.2f} m/s (45 kt, MIL-HDBK-1797 severe: the Dryden model's "
            f"range), got {m['w20_mps']!r}"
        )
    return TurbulenceConfig(w20_mps=w20_mps)


def _parse_gust(raw: Any, where: str) -> GustConfig:
    m = require_mapping(raw, where)
    reject_unknown_keys(m, _GUST_KEYS, where)
    for key in ("onset_s", "amplitude_mps", "length_m"):
        if key not in m:
            raise ConfigError(f"{where}.{key}: missing (required)")
    pen = m.get("penetration_speed_mps")

    def default(key: str) -> Any:
        return m.get(key, field_default(GustConfig, key))

    return GustConfig(
        onset_s=number(m["onset_s"], f"{where}.onset_s", minimum=0.0),
        amplitude_mps=number(m["amplitude_mps"], f"{where}.amplitude_mps", minimum=0.0),
        length_m=number(m["length_m"], f"{where}.length_m", strictly_positive=True),
        from_deg=direction_deg(m["from_deg"], f"{where}.from_deg") if m.get("from_deg") is not None else None,
        vertical_mps=number(default("vertical_mps"), f"{where}.vertical_mps"),
        hold_m=number(default("hold_m"), f"{where}.hold_m", minimum=0.0, allow_inf=True),
        penetration_speed_mps=None if pen is None else number(pen, f"{where}.penetration_speed_mps", strictly_positive=True),
        onset_after=enum_value(default("onset_after"), f"{where}.onset_after", GustOnset),
    )


def _parse_random_gusts(raw: Any, where: str) -> RandomGustsConfig:
    m = require_mapping(raw, where)
    reject_unknown_keys(m, _RANDOM_GUST_KEYS, where)
    for key in ("count", "start_s", "end_s", "amplitude_mps", "length_m"):
        if key not in m:
            raise ConfigError(f"{where}.{key}: missing (required)")
    start = number(m["start_s"], f"{where}.start_s", minimum=0.0)
    end = number(m["end_s"], f"{where}.end_s", minimum=0.0)
    if end < start:
        raise ConfigError(f"{where}.end_s: must be >= start_s ({start:g}), got {m['end_s']!r}")
    return RandomGustsConfig(
        count=integer(m["count"], f"{where}.count", minimum=0),
        start_s=start,
        end_s=end,
        amplitude_mps=number_range(m["amplitude_mps"], f"{where}.amplitude_mps", minimum=0.0),
        length_m=number_range(m["length_m"], f"{where}.length_m", strictly_positive=True),
        from_deg=direction_deg(m["from_deg"], f"{where}.from_deg") if m.get("from_deg") is not None else None,
        spread_deg=number(
            m.get("spread_deg", field_default(RandomGustsConfig, "spread_deg")), f"{where}.spread_deg", minimum=0.0, maximum=180.0
        ),
        vertical_mps=number_range(
            m.get("vertical_mps", field_default(RandomGustsConfig, "vertical_mps")), f"{where}.vertical_mps"
        ),
    )
