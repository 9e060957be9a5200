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

With both, each grid point gets ``count`` draws; a file may stand for at most
:data:`MAX_SWEEP_FLIGHTS` (100,000) flights, counted before anything is
expanded. Each flight is named
``<name>__<param>=<value>...`` (grid) and ``__mc<k>`` (draws); its document is
validated like any scenario. Draws use numpy's PCG64 seeded by ``seed``, so the
same file always expands to the same flights.

Every dotted path is checked when the sweep expands: a path into a list must
name an existing index, and a path that adds a key the scenario does not have
must add one the schema knows (``wind.speedd_mps`` is refused up front, not
once per flight).

Each flight carries a :func:`scenario_hash`: the sha256 of a canonical JSON of
its fully resolved document (after expansion, with its name), the shipped
platform profile it names, and the project version. A batch resumes only
flights whose stored hash matches, so an edited scenario is flown again.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from geofence.validation import ConfigError, integer, number, reject_unknown_keys, require_mapping, string

DISTRIBUTIONS = ("uniform", "normal", "choice", "integers")


@dataclass(frozen=True)
class FlightSpec:
    """One flight of a batch: its id, its (expanded) scenario document and where it came from."""

    flight_id: str
    document: dict | None
    source: str
    error: str | None = None
    """Set when the source file could not be read or expanded; the flight is recorded as failed."""
    scenario_hash: str = ""
    """The flight's identity (:func:`scenario_hash` of ``document``, or of ``error``)."""

    def __post_init__(self) -> None:
        if not self.scenario_hash:
            h = (
                scenario_hash(self.document)
                if self.document is not None
                else _sha256({"error": self.error, "version": project_version()})
            )
            object.__setattr__(self, "scenario_hash", h)


def project_version() -> str:
    """The installed version of ``geofence-testbed`` (``"unknown"`` when run from a bare checkout)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("geofence-testbed")
    except PackageNotFoundError:
        return "unknown"


CODE_PACKAGES = ("aircraft", "analysis", "geofence", "scenarios", "wind")
"""The folders whose code decides a flight and its scores (their ``.py`` files, and the models and systems
JSBSim loads: ``.xml``; the platform profiles are hashed per flight by name)."""


def code_fingerprint(root: Path | None = None) -> str:
    """sha256 of the project's code as it is on disk: every ``.py`` and ``.xml`` file under :data:`CODE_PACKAGES`.

    A result flown by other code is another result: a resumed batch flies it again (the package version alone
    does not change with every edit, and an editable install runs whatever the checkout holds). The running
    code's (``root`` None) is read once per process; another tree's every time.
    """
    return _running_code_fingerprint() if root is None else _fingerprint_of_tree(Path(root))


@lru_cache(maxsize=1)
def _running_code_fingerprint() -> str:
    return _fingerprint_of_tree(Path(__file__).resolve().parents[2])


def _fingerprint_of_tree(base: Path) -> str:
    h = hashlib.sha256()
    files = sorted(
        p
        for pkg in CODE_PACKAGES
        for p in (base / pkg).rglob("*")
        if p.suffix in (".py", ".xml") and p.is_file() and "__pycache__" not in p.parts
    )
    for p in files:
        h.update(p.relative_to(base).as_posix().encode("utf-8") + b"\0")
        h.update(hashlib.sha256(p.read_bytes()).digest())
    return h.hexdigest()


def scenario_hash(document: dict, *, version: str | None = None, code: str | None = None) -> str:
    """A flight's identity: sha256 of the canonical JSON of its resolved document, its shipped profile(s), the
    version and the code that flies it.

    ``version`` defaults to :func:`project_version` (the installed package's), ``code`` to :func:`code_fingerprint`.
    """
    doc = dict(document)
    payload = {
        "scenario": doc,
        "version": project_version() if version is None else version,
        "code": code_fingerprint() if code is None else code,
        "profiles": _profile_texts(doc),
    }
    return _sha256(payload)


def _sha256(payload: Any) -> str:
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _profile_texts(doc: dict) -> dict[str, str]:
    """The shipped profile files a document resolves through (its aircraft, an inline profile's base)."""
    names = [doc.get("aircraft")]
    if isinstance(doc.get("profile"), dict):
        names.append(doc["profile"].get("base"))
    return {n: _profile_text(n) for n in names if isinstance(n, str) and _profile_text(n)}


@lru_cache(maxsize=64)
def _profile_text(name: str) -> str:
    from aircraft.profile import PROFILES_DIR

    path = PROFILES_DIR / f"{name}.yaml"
    try:
        return path.read_text() if path.is_file() else ""
    except OSError:
        return ""


MAX_SWEEP_FLIGHTS = 100_000
"""A sweep file may stand for at most this many flights (grid points x Monte Carlo draws): counted from the
list lengths and ``count`` before anything is expanded (at some 5 KB per flight document, 10^9 draws would
fill the memory long before the first was judged; 100,000 flights are days of compute on one machine)."""


def expand(document: dict, where: str, default_name: str, *, max_flights: int = MAX_SWEEP_FLIGHTS) -> list[FlightSpec]:
    """The flights a scenario document stands for (one without a ``sweep:`` block); a sweep of more than
    ``max_flights`` is refused before it is expanded."""
    require_mapping(document, f"{where}: (top level)")
    doc = dict(document)
    sweep = doc.pop("sweep", None)
    base_name = string(doc["name"], f"{where}: name") if "name" in doc else str(default_name)  # typed before use
    if sweep is None:
        return [FlightSpec(base_name, doc if "name" in doc else dict(doc, name=base_name), where)]
    require_mapping(sweep, f"{where}: sweep")
    reject_unknown_keys(sweep, {"grid", "monte_carlo"}, f"{where}: sweep")
    mc = sweep.get("monte_carlo")
    _check_flight_count(sweep.get("grid"), mc, where, max_flights)
    grid_points = _grid(sweep.get("grid"), f"{where}: sweep.grid")
    if grid_points and grid_points[0]:
        for path, value in grid_points[0]:
            _check_path(doc, path, value, f"{where}: sweep.grid.{path}", where)
    specs: list[FlightSpec] = []
    for point in grid_points:
        suffix = "".join(f"__{_short(k)}={_fmt(v)}" for k, v in point)
        draws = _draws(mc, f"{where}: sweep.monte_carlo", len(specs), doc, where) if mc is not None else [()]
        for k, draw in enumerate(draws):
            variant = copy.deepcopy(doc)
            for path, value in (*point, *draw):
                _set_path(variant, path, value, f"{where}: sweep")
            name = base_name + suffix + (f"__mc{k:03d}" if mc is not None else "")
            variant["name"] = name
            specs.append(FlightSpec(name, variant, where))
    return specs


def _check_flight_count(grid: Any, mc: Any, where: str, max_flights: int) -> None:
    """Refuse a sweep of more than ``max_flights`` flights, from its sizes alone."""
    points = 1
    if isinstance(grid, dict):
        for vals in grid.values():
            points *= len(vals) if isinstance(vals, list) and vals else 1
    draws = 1
    if isinstance(mc, dict):
        count = mc.get("count", 10)
        draws = integer(count, f"{where}: sweep.monte_carlo.count", minimum=1)
    if points * draws > max_flights:
        field = "sweep.monte_carlo.count" if draws > max_flights else "sweep"
        raise ConfigError(
            f"{where}: {field}: {points:,} grid point(s) x {draws:,} draw(s) = {points * draws:,} flights exceed the "
            f"limit of {max_flights:,} per file; split the sweep into several files"
        )


_DOTTED_PATH = re.compile(r"[A-Za-z0-9_\-]+(\.[A-Za-z0-9_\-]+)*")


def _dotted_path(key: Any, where: str) -> str:
    """A sweep key: a dotted field path such as ``wind.gusts.0.onset_s`` (quoted in the message otherwise)."""
    if not isinstance(key, str) or not _DOTTED_PATH.fullmatch(key):
        raise ConfigError(f"{where}: {key!r} is not a dotted field path (such as wind.speed_mps)")
    return key


def _grid(raw: Any, where: str) -> list[tuple[tuple[str, Any], ...]]:
    if raw is None:
        return [()]
    require_mapping(raw, where)
    keys, values = [], []
    for key, vals in raw.items():
        _dotted_path(key, where)
        if not isinstance(vals, list) or not vals:
            raise ConfigError(f"{where}.{key}: expected a non-empty list of values")
        keys.append(str(key))
        values.append(vals)
    return [tuple(zip(keys, combo)) for combo in itertools.product(*values)]


def _draws(raw: Any, where: str, salt: int, base_doc: dict, file_where: str) -> list[tuple[tuple[str, Any], ...]]:
    require_mapping(raw, where)
    reject_unknown_keys(raw, {"count", "seed", "draws"}, where)
    count = integer(raw.get("count", 10), f"{where}.count", minimum=1)
    seed = integer(raw.get("seed", 0), f"{where}.seed", minimum=0)
    draws = require_mapping(raw.get("draws", {}), f"{where}.draws")
    rng = np.random.default_rng([seed, salt])
    samplers = []
    for key, spec in draws.items():
        _dotted_path(key, f"{where}.draws")
        require_mapping(spec, f"{where}.draws.{key}")
        if len(spec) != 1 or next(iter(spec)) not in DISTRIBUTIONS:
            raise ConfigError(f"{where}.draws.{key}: give exactly one of {', '.join(DISTRIBUTIONS)}")
        kind, args = next(iter(spec.items()))
        if not isinstance(args, list) or not args:
            raise ConfigError(f"{where}.draws.{key}.{kind}: expected a list of parameters")
        if kind in ("uniform", "normal", "integers"):
            if len(args) != 2:
                raise ConfigError(f"{where}.draws.{key}.{kind}: expected [low, high] (uniform, integers) or [mean, sd] (normal)")
            args = [number(a, f"{where}.draws.{key}.{kind}[{i}]") for i, a in enumerate(args)]
        samplers.append((str(key), kind, args))
    out = []
    for key, kind, args in samplers if salt == 0 else ():  # each path checked once, with a representative value
        probe = args[0] if kind == "choice" else (int(args[0]) if kind == "integers" else float(args[0]))
        _check_path(base_doc, key, probe, f"{where}.draws.{key}", file_where)
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


def _check_path(doc: dict, path: str, value: Any, label: str, where: str) -> None:
    """Refuse a dotted path that points nowhere: a missing list index, or a new key the schema does not know."""
    parts = path.split(".")
    node: Any = doc
    missing_from = None
    for i, part in enumerate(parts):
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        else:
            missing_from = i
            break
    if missing_from is None:
        return  # the path exists in the base scenario
    trial = copy.deepcopy(doc)
    _set_path(trial, path, value, f"{where}: sweep")  # a bad list index or scalar parent raises here
    from scenarios.definition.schema import parse_scenario

    try:
        parse_scenario(trial, where=where)
    except ConfigError as exc:
        msg = str(exc)
        for created in parts[missing_from:]:  # geofence.validation words it "<path>.x: unknown key"
            if f"{created}: unknown key" in msg:
                problem = msg[len(where) + 2 :] if msg.startswith(f"{where}: ") else msg
                raise ConfigError(f"{label}: no such field in a scenario ({problem})") from None


def _short(path: str) -> str:
    return path.split(".")[-1]


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}" if math.isfinite(value) else str(value)
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", str(value))


def with_referenced_files(specs: Iterable[FlightSpec], base_dir: Path) -> list[FlightSpec]:
    """The specs, each ``scenario_hash`` also covering the bytes of the files its scenario references.

    A ``geofence.fence.file`` (relative to ``base_dir``, the scenario file's folder) is part of the
    flight: editing it must re-fly a resumed batch, though the scenario document did not change.
    A file that cannot be read hashes as missing (the flight then fails with the schema's message).
    """
    from scenarios.definition.schema import referenced_files

    out = []
    for spec in specs:
        try:
            files = referenced_files(spec.document, base_dir) if spec.document is not None else []
        except ValueError:  # a malformed file: key; the schema reports it when the flight is parsed
            files = []
        if not files:
            out.append(spec)
            continue
        digests = {}
        for p in files:
            try:
                digests[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
            except OSError:
                digests[str(p)] = "missing"
        payload = json.dumps({"scenario_hash": spec.scenario_hash, "files": sorted(digests.values())})
        out.append(replace(spec, scenario_hash=hashlib.sha256(payload.encode("utf-8")).hexdigest()))
    return out
