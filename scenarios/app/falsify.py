"""The ``falsify`` command: CMA-ES hunts the falsify family for the flight of least margin.

Owns the subparser, the search loop and what it writes. The family is
:mod:`scenarios.campaign.falsify_family` (a point of [0, 1]^d -> a scenario document); the optimiser is
CMA-ES from the ``cma`` package (ask/tell, bounds [0, 1], its own seeded sampler); each generation is
flown as one batch by :func:`scenarios.app.batch.run_batch` (processes or Dask), and the objective is
the flight's scored ``min_margin_m`` (negative: a breach). A flight that did not complete scores
:data:`FAILED_MARGIN_M` (the search moves away from it) and is listed as failed. The last generation
flies only what is left of the budget (those flights are recorded, not told to the optimiser).

``DIR`` receives ``flights/`` (every flight's folder, as ``batch`` writes them), ``falsify.json`` (every
point: its coordinates, physical values, margin, generation), ``worst-NN__<flight>.yaml`` (the
:data:`WORST_KEPT` flights of least margin as ordinary scenarios, their margin in the description and a
header comment) and ``convergence.png`` (:func:`analysis.falsify_plots.plot_convergence`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

MAX_BUDGET = 100_000
WORST_KEPT = 5
FAILED_MARGIN_M = 1.0e4
SIGMA0 = 0.3
"""CMA-ES's initial step size in the unit cube (a third of it, the usual advice for [0, 1] bounds)."""
RESULTS = "falsify.json"


def register(sub) -> None:
    """Add the ``falsify`` subparser; its handler is ``args.handler``."""
    p = sub.add_parser(
        "falsify",
        help="search a parametrised family of cases for the flight of least margin (CMA-ES)",
        description=(
            "Minimise the flight's minimum margin (negative: a breach) over the falsify family (a box fence, a scripted "
            "attack on its edge: incidence, speed, start distance, wind speed and direction, gust amplitude and timing, "
            "turbulence seed, fence size; docs/falsify.md) with CMA-ES, each generation flown as a batch. Writes DIR/"
            "falsify.json, the worst cases as scenario YAMLs and DIR/convergence.png."
        ),
    )
    p.add_argument("--budget", required=True, type=int, metavar="N", help=f"flights to fly (1..{MAX_BUDGET})")
    p.add_argument("--popsize", type=int, default=None, metavar="K", help="flights per generation (default: CMA-ES's)")
    add_family_arguments(p, "the optimiser's seed")
    p.set_defaults(handler=run)


def add_family_arguments(p, seed_help: str) -> None:
    """The options of a command that flies the falsify family (``falsify``, ``estimate``): what is flown, where
    to, and on what executor."""
    p.add_argument("--platform", required=True, metavar="NAME", help="the aircraft (geofence-testbed list)")
    p.add_argument("--variant", required=True, choices=("reactive", "predictive"), help="the geofence trigger flown")
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="output folder")
    p.add_argument("--seed", type=int, default=1, metavar="S", help=f"{seed_help} (default 1)")
    p.add_argument("--jobs", type=int, default=None, metavar="J", help="parallel flights (default: all cores)")
    p.add_argument("--max-duration-s", type=float, default=None, metavar="S", help="longest flight (default 120 s)")
    p.add_argument("--executor", choices=("process", "dask"), default="process", help="batch executor")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="the Dask scheduler (with --executor dask)")
    p.add_argument(
        "--trajectories", choices=("all", "notable"), default="all",
        help="whose trajectory.csv to write under DIR/flights: all (default, about 0.6 MB a flight), or notable: "
        "only the flights that left the fence, failed, were terminated or touched down hard (as batch's)",
    )  # fmt: skip


def check_args(args) -> None:
    """Refuse bad arguments in one line (:class:`~geofence.validation.ConfigError`, exit 2), before anything flies."""
    from geofence.validation import ConfigError

    if not 1 <= args.budget <= MAX_BUDGET:
        raise ConfigError(f"--budget: must be 1..{MAX_BUDGET} flights, got {args.budget}")
    if args.popsize is not None and not 2 <= args.popsize <= 1000:
        raise ConfigError(f"--popsize: must be 2..1000, got {args.popsize}")
    check_family_args(args)


def check_family_args(args) -> None:
    """Refuse bad :func:`add_family_arguments` in one line (:class:`~geofence.validation.ConfigError`, exit 2)."""
    from aircraft.profile import load_profile
    from geofence.validation import ConfigError
    from scenarios.app.cli import check_output_dir, check_scheduler_address

    if args.jobs is not None and args.jobs < 1:
        raise ConfigError(f"--jobs: must be >= 1, got {args.jobs}")
    if args.max_duration_s is not None and not 10.0 <= args.max_duration_s <= 3600.0:
        raise ConfigError(f"--max-duration-s: must be 10..3600 s, got {args.max_duration_s:g}")
    if not 0 <= args.seed < 2**31:
        raise ConfigError(f"--seed: must be 0..{2**31 - 1}, got {args.seed}")
    if args.executor == "dask" and args.scheduler is None:
        raise ConfigError("--executor dask: give the cluster with --scheduler ADDRESS (e.g. tcp://127.0.0.1:8786)")
    if args.scheduler is not None:
        check_scheduler_address(args.scheduler)
    load_profile(args.platform)  # an unknown aircraft is one line
    check_output_dir(args.out, "--out")


@dataclass
class Search:
    """What the search has flown so far (every evaluation, in order)."""

    platform: str
    variant: str
    budget: int
    seed: int
    evaluations: list[dict[str, Any]] = field(default_factory=list)

    def best(self) -> dict[str, Any] | None:
        return min(self.evaluations, key=lambda e: e["margin_m"], default=None)

    def first_breach(self) -> int | None:
        """Flights flown up to and including the first with a negative margin (None: none yet)."""
        return next((i + 1 for i, e in enumerate(self.evaluations) if e["margin_m"] < 0.0), None)


def run(args) -> int:
    """``falsify``: check, search, write; exit 0 (1 if every flight failed)."""
    import cma
    import numpy as np

    from scenarios.campaign.falsify_family import DEFAULT_MAX_DURATION_S, DIMENSION

    check_args(args)
    args.out.mkdir(parents=True, exist_ok=True)
    options: dict[str, Any] = {"bounds": [0.0, 1.0], "seed": args.seed + 1, "verbose": -9}
    if args.popsize is not None:
        options["popsize"] = args.popsize
    es = cma.CMAEvolutionStrategy(np.full(DIMENSION, 0.5), SIGMA0, options)
    search = Search(args.platform, args.variant, args.budget, args.seed)
    max_duration = args.max_duration_s or DEFAULT_MAX_DURATION_S
    generation = 0
    while len(search.evaluations) < args.budget:
        points = es.ask()
        left = args.budget - len(search.evaluations)
        margins = fly_generation(args, search, generation, [np.asarray(p) for p in points[:left]], max_duration)
        if len(margins) == len(points):
            es.tell(points, margins)
        report_generation(search, generation)
        generation += 1
    write_outputs(args.out, search)
    return 0 if any(e["completed"] for e in search.evaluations) else 1


def fly_generation(args, search: Search, generation: int, points: list[np.ndarray], max_duration_s: float) -> list[float]:
    """Fly ``points`` as one batch into ``DIR/flights``; record and return their margins."""
    names = [f"g{generation:03d}-{i:02d}" for i in range(len(points))]
    return fly_points(args, search, names, points, generation, max_duration_s)


def fly_points(
    args,
    search: Search,
    names: list[str],
    points: list[np.ndarray],
    generation: int,
    max_duration_s: float,
    progress: bool = False,
) -> list[float]:
    """Fly the family's ``points`` (one flight each, named ``names``) as one batch into ``args.out/flights``
    (``args.jobs``, ``args.executor``, ``args.scheduler``); record each in ``search`` and return the margins."""
    from scenarios.app.batch import Trajectories, run_batch
    from scenarios.campaign.falsify_family import case_document
    from scenarios.campaign.generator import Variant
    from scenarios.definition.sweep import expand

    variant = Variant(search.variant)
    specs, geometry = [], {}
    for name, x in zip(names, points):
        doc, geo = case_document(x, search.platform, variant, name=name, max_duration_s=max_duration_s)
        specs.extend(expand(doc, f"falsify {name}", name))
        geometry[name] = (x, geo, doc)
    summaries: dict[str, dict] = {}
    run_batch(
        specs,
        args.out / "flights",
        jobs=args.jobs,
        executor=args.executor,
        scheduler=args.scheduler,
        progress=progress,
        on_done=lambda s: summaries.__setitem__(str(s.get("flight")), s),
        trajectories=Trajectories(args.trajectories),
    )
    margins = []
    for spec in specs:
        x, geo, doc = geometry[spec.flight_id]
        summary = summaries.get(spec.flight_id) or read_summary(args.out / "flights" / spec.flight_id)
        margin = flight_margin(summary)
        margins.append(margin)
        search.evaluations.append(
            {
                "flight": spec.flight_id,
                "generation": generation,
                "x": [round(float(v), 6) for v in x],
                "values": {k: round(v, 4) for k, v in geo.values.items()},
                "scale_m": geo.scale_m,
                "legal_start": geo.legal_start,
                "completed": bool(summary.get("completed")),
                "margin_m": margin,
                "document": doc,
            }
        )
    return margins


def read_summary(folder: Path) -> dict:
    """A flight's ``summary.json`` (a flight resumed from an earlier run reports no summary to ``on_done``)."""
    try:
        return json.loads((folder / "summary.json").read_text())
    except (OSError, ValueError):
        return {}


def flight_margin(summary: dict) -> float:
    """The flight's scored minimum margin (m, + inside), or :data:`FAILED_MARGIN_M` for a failed flight."""
    value = summary.get("min_margin_m") if summary.get("completed") else None
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        return FAILED_MARGIN_M
    return round(float(value), 3)


def report_generation(search: Search, generation: int) -> None:
    best = search.best()
    assert best is not None
    first = search.first_breach()
    this = [e["margin_m"] for e in search.evaluations if e["generation"] == generation]
    print(
        f"generation {generation}: {len(search.evaluations)}/{search.budget} flights, best margin {best['margin_m']:+.2f} m "
        f"({best['flight']}), this generation's best {min(this):+.2f} m"
        + (f", first breach at flight {first}" if first is not None else ""),
        flush=True,
    )


def write_outputs(out: Path, search: Search) -> None:
    """``falsify.json``, the worst cases' YAMLs and ``convergence.png``."""
    import numpy as np

    from analysis.falsify_plots import plot_convergence
    from analysis.formats.replace import replace_text
    from scenarios.campaign.falsify_family import PARAMETERS

    ranked = sorted((e for e in search.evaluations if e["completed"]), key=lambda e: e["margin_m"])
    worst_files = []
    for k, e in enumerate(ranked[:WORST_KEPT], start=1):
        path = out / f"worst-{k:02d}__{e['flight']}.yaml"
        replace_text(path, worst_yaml(e, search))
        worst_files.append(path.name)
    best = search.best()
    record = {
        "platform": search.platform,
        "variant": search.variant,
        "budget": search.budget,
        "seed": search.seed,
        "optimiser": "CMA-ES (cma), bounds [0, 1], sigma0 0.3",
        "parameters": [{"name": p.name, "low": p.low, "high": p.high, "unit": p.unit, "meaning": p.meaning} for p in PARAMETERS],
        "flights": len(search.evaluations),
        "flights_to_first_breach": search.first_breach(),
        "worst_margin_m": None if best is None else best["margin_m"],
        "worst_flight": None if best is None else best["flight"],
        "breaches": [e["flight"] for e in search.evaluations if e["margin_m"] < 0.0],
        "worst_files": worst_files,
        "evaluations": [{k: v for k, v in e.items() if k != "document"} for e in search.evaluations],
    }
    replace_text(out / RESULTS, json.dumps(record, indent=1) + "\n")
    flights = np.arange(1, len(search.evaluations) + 1)
    margins = np.array([e["margin_m"] for e in search.evaluations], dtype=float)
    plot_convergence(flights, margins, out / "convergence", f"{search.platform}, {search.variant} fence")
    print(f"wrote {out / RESULTS}, {len(worst_files)} worst case(s) and {out / 'convergence.png'}")


def worst_yaml(e: dict[str, Any], search: Search) -> str:
    """An evaluation's scenario as an ordinary YAML, its margin in a header comment and the description."""
    import yaml

    doc = dict(e["document"])
    doc["name"] = f"falsify-{search.platform}-{search.variant}-s{search.seed}-{e['flight']}"  # unique beside other runs' cases
    doc["description"] = f"{doc['description']}; falsify: min margin {e['margin_m']:+.2f} m"
    header = (
        f"# found by geofence-testbed falsify --platform {search.platform} --variant {search.variant} "
        f"--seed {search.seed}: flight {e['flight']} (generation {e['generation']}), min margin {e['margin_m']:+.3f} m\n"
    )
    return header + yaml.safe_dump(doc, sort_keys=False)
