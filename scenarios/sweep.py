"""Sweeps: one scenario file that expands into many flights (parameter grids and Monte Carlo draws).

A scenario may carry a ``sweep:`` block; every other key is the base scenario.
Parameters are dotted paths into the scenario document (``wind.speed_mps``,
``start.heading_deg``, ``seed``, ``aircraft``, ``pilot.segments.0.course_deg``)::

    sweep:
      grid:                                # every combination
        wind.speed_mps: [0, 8]
        wind.from_deg: [0, 90, 180, 270]
      monte_carlo:                         # and/or random draws, reproducible by seed
        count: 20
        seed: 7
        draws:
          wind.speed_mps: {uniform: [0, 10]}
          start.heading_deg: {choice: [0, 90, 180, 270]}
          seed: {integers: [0, 1000000]}

With both, each grid point gets ``count`` draws. Each flight is named
``<name>__<param>=<value>...`` (grid) and ``__mc<k>`` (draws); its document is
validated like any scenario. Draws use numpy's PCG64 seeded by ``seed``, so the
same file always expands to the same flights.
"""

from __future__ import annotations

import copy
import itertools
import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenarios.errors import ConfigError, integer, reject_unknown_keys, require_mapping

DISTRIBUTIONS = ("uniform", "normal", "choice", "integers")


@dataclass(frozen=True)
class FlightSpec:
    """One flight of a batch: its id, its (expanded) scenario document and where it came from."""

    flight_id: str
    document: dict | None
    source: str
    error: str | None = None
    """Set when the source file could not be read or expanded; the flight is recorded as failed."""


def expand(document: dict, where: str, default_name: str) -> list[FlightSpec]:
    """The flights a scenario document stands for (one without a ``sweep:`` block)."""
    require_mapping(document, f"{where}: (top level)")
    doc = dict(document)
    sweep = doc.pop("sweep", None)
    base_name = str(doc.get("name", default_name))
    if sweep is None:
        return [FlightSpec(base_name, doc, where)]
    require_mapping(sweep, f"{where}: sweep")
    reject_unknown_keys(sweep, {"grid", "monte_carlo"}, f"{where}: sweep")
    grid_points = _grid(sweep.get("grid"), f"{where}: sweep.grid")
    mc = sweep.get("monte_carlo")
    specs = []
    for point in grid_points:
        suffix = "".join(f"__{_short(k)}={_fmt(v)}" for k, v in point)
        draws = _draws(mc, f"{where}: sweep.monte_carlo", salt=len(specs)) if mc is not None else [()]
        for k, draw in enumerate(draws):
            variant = copy.deepcopy(doc)
            for path, value in (*point, *draw):
                _set_path(variant, path, value, f"{where}: sweep")
            name = base_name + suffix + (f"__mc{k:03d}" if mc is not None else "")
            variant["name"] = name
            specs.append(FlightSpec(name, variant, where))
    return specs


def _grid(raw: Any, where: str) -> list[tuple[tuple[str, Any], ...]]:
    if raw is None:
        return [()]
    require_mapping(raw, where)
    keys, values = [], []
    for key, vals in raw.items():
        if not isinstance(vals, list) or not vals:
            raise ConfigError(f"{where}.{key}: expected a non-empty list of values")
        keys.append(str(key))
        values.append(vals)
    return [tuple(zip(keys, combo)) for combo in itertools.product(*values)]


def _draws(raw: Any, where: str, salt: int) -> list[tuple[tuple[str, Any], ...]]:
    require_mapping(raw, where)
    reject_unknown_keys(raw, {"count", "seed", "draws"}, where)
    count = integer(raw.get("count", 10), f"{where}.count", minimum=1)
    seed = integer(raw.get("seed", 0), f"{where}.seed", minimum=0)
    draws = require_mapping(raw.get("draws", {}), f"{where}.draws")
    rng = np.random.default_rng([seed, salt])
    samplers = []
    for key, spec in draws.items():
        require_mapping(spec, f"{where}.draws.{key}")
        if len(spec) != 1 or next(iter(spec)) not in DISTRIBUTIONS:
            raise ConfigError(f"{where}.draws.{key}: give exactly one of {', '.join(DISTRIBUTIONS)}")
        kind, args = next(iter(spec.items()))
        if not isinstance(args, list) or not args:
            raise ConfigError(f"{where}.draws.{key}.{kind}: expected a list of parameters")
        if kind in ("uniform", "normal", "integers") and (len(args) != 2 or not all(isinstance(a, (int, float)) and not isinstance(a, bool) for a in args)):
            raise ConfigError(f"{where}.draws.{key}.{kind}: expected [low, high] (uniform, integers) or [mean, sd] (normal)")
        samplers.append((str(key), kind, args))
    out = []
    for _ in range(count):
        draw = []
        for key, kind, args in samplers:
            if kind == "uniform":
                value = float(rng.uniform(args[0], args[1]))
            elif kind == "normal":
                value = float(rng.normal(args[0], args[1]))
            elif kind == "integers":
                value = int(rng.integers(int(args[0]), int(args[1]) + 1))
            else:
                value = args[int(rng.integers(0, len(args)))]
            draw.append((key, value))
        out.append(tuple(draw))
    return out


def _set_path(doc: dict, path: str, value: Any, where: str) -> None:
    parts = path.split(".")
    node: Any = doc
    for i, part in enumerate(parts[:-1]):
        key: Any = int(part) if isinstance(node, list) and part.isdigit() else part
        try:
            child = node[key]
        except (KeyError, IndexError, TypeError):
            if isinstance(node, dict):
                node[key] = child = {}
            else:
                raise ConfigError(f"{where}: {path}: no such place in the scenario ({'.'.join(parts[: i + 1])})") from None
        node = child
    last = parts[-1]
    if isinstance(node, list):
        if not last.isdigit() or int(last) >= len(node):
            raise ConfigError(f"{where}: {path}: no such list index")
        node[int(last)] = value
    elif isinstance(node, dict):
        node[last] = value
    else:
        raise ConfigError(f"{where}: {path}: cannot set a value inside a {type(node).__name__}")


def _short(path: str) -> str:
    return path.split(".")[-1]


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}" if math.isfinite(value) else str(value)
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", str(value))
