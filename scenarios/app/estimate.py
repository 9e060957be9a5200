"""The ``estimate`` command: the probability that a flight's margin falls below a level, on the falsify family.

Owns the subparser, the flying of each batch the estimator asks for, and what it writes. The family is
:mod:`scenarios.campaign.falsify_family` (a point of [0, 1]^d -> a scenario document); the estimators are
:mod:`scenarios.campaign.subset_simulation` (subset simulation, or plain Monte Carlo for a check); each
batch is flown by :func:`scenarios.app.falsify.fly_points` (processes or Dask), and g is the flight's
scored ``min_margin_m``. The input distribution is every family coordinate uniform and independent on its
range (docs/rare_events.md says what that assumes). A flight that did not complete counts as no breach
(g = +10,000 m); their number is printed and recorded, and the estimate is then a lower bound.

``DIR`` receives ``flights/`` (every flight's folder; the same command re-flies nothing already flown),
``estimate.json`` (the estimate, its CoV or interval, the levels, every evaluation) and ``estimate.png``
(:func:`analysis.rare_event_plots.plot_levels`).
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

MAX_SAMPLES = 100_000
RESULTS = "estimate.json"
INPUT_DISTRIBUTION = (
    "every coordinate of the falsify family uniform and independent on its range (docs/falsify.md): attack "
    "incidence, speed (cruise or max, even odds), start distance, steady wind speed and direction, gust amplitude "
    "and timing, turbulence seed and box size; one site, one fence shape, the scripted attack pilot"
)


def register(sub) -> None:
    """Add the ``estimate`` subparser; its handler is ``args.handler``."""
    from scenarios.app.falsify import add_family_arguments

    p = sub.add_parser(
        "estimate",
        help="estimate the probability that the margin falls below a level (subset simulation)",
        description=(
            "Estimate P[min margin <= BELOW] on the falsify family (docs/falsify.md) with every coordinate uniform on "
            "its range: by subset simulation (levels of N flights, Markov chains toward the event, the estimate and "
            "its coefficient of variation) or by plain Monte Carlo (N flights, the exact 95 % interval) to check it. "
            "Writes DIR/estimate.json and DIR/estimate.png; docs/rare_events.md."
        ),
    )
    p.add_argument("--below-m", type=float, default=0.0, metavar="M", help="the event: min margin <= M (default 0: a breach)")
    p.add_argument("--method", choices=("subset", "monte-carlo"), default="subset", help="estimator (default subset)")
    p.add_argument(
        "--samples",
        type=int,
        default=None,
        metavar="N",
        help="flights per level (subset, default 100) or in all (monte-carlo, default 1000)",
    )
    p.add_argument("--p0", type=float, default=0.1, help="subset: each level's conditional probability (default 0.1)")
    p.add_argument("--max-levels", type=int, default=6, metavar="L", help="subset: conditional levels at most (default 6)")
    add_family_arguments(p, "the sampler's seed")
    p.set_defaults(handler=run)


def check_args(args) -> None:
    """Refuse bad arguments in one line (:class:`~geofence.validation.ConfigError`, exit 2), before anything flies."""
    from geofence.validation import ConfigError
    from scenarios.app.falsify import check_family_args

    if args.samples is None:
        args.samples = 100 if args.method == "subset" else 1000
    if not 1 <= args.samples <= MAX_SAMPLES:
        raise ConfigError(f"--samples: must be 1..{MAX_SAMPLES} flights, got {args.samples}")
    if not math.isfinite(args.below_m) or abs(args.below_m) > 1e4:
        raise ConfigError(f"--below-m: must be a finite margin within +-10,000 m, got {args.below_m:g}")
    if args.method == "subset":
        subset_options(args)  # p0, N, levels: refused in one line
    check_family_args(args)


def subset_options(args):
    from geofence.validation import ConfigError
    from scenarios.campaign.subset_simulation import SubsetOptions

    if not 0.0 < args.p0 <= 0.5:
        raise ConfigError(f"--p0: must be in (0, 0.5], got {args.p0:g}")
    try:
        return SubsetOptions(args.samples, args.p0, args.max_levels, seed=args.seed)
    except ConfigError as exc:
        raise ConfigError(f"--samples/--p0/--max-levels: {exc}") from None


def run(args) -> int:
    """``estimate``: check, sample, write; exit 0 (1 if every flight failed)."""
    from scenarios.app.falsify import Search
    from scenarios.campaign.falsify_family import DEFAULT_MAX_DURATION_S, DIMENSION
    from scenarios.campaign.subset_simulation import monte_carlo, subset_simulation

    check_args(args)
    args.out.mkdir(parents=True, exist_ok=True)
    search = Search(args.platform, args.variant, 0, args.seed)
    evaluate = _evaluator(args, search, args.max_duration_s or DEFAULT_MAX_DURATION_S)
    if args.method == "subset":
        est = subset_simulation(evaluate, DIMENSION, args.below_m, subset_options(args))
    else:
        est = monte_carlo(evaluate, DIMENSION, args.below_m, args.samples, seed=args.seed)
    write_outputs(args, search, est)
    return 0 if any(e["completed"] for e in search.evaluations) else 1


def _evaluator(args, search, max_duration_s: float):
    """The estimator's ``evaluate(points, tag)``: one batch of flights named ``<tag>-NNN``, their margins."""
    import numpy as np

    from scenarios.app.falsify import fly_points

    def evaluate(points, tag: str):
        width = max(3, len(str(len(points) - 1)))
        names = [f"{tag}-{i:0{width}d}" for i in range(len(points))]
        level = int(tag[1:].split("-")[0]) if tag.startswith("l") else 0
        if len(points) > 50:
            print(f"{tag}: writing {len(points)} scenarios, then flying them", flush=True)
        margins = fly_points(args, search, names, list(points), level, max_duration_s, progress=len(points) > 50)
        g = np.array(margins, dtype=float)
        low = int(np.count_nonzero(g <= args.below_m))
        print(
            f"{tag}: {len(points)} flights ({len(search.evaluations)} in all), {low} at or below {args.below_m:+g} m", flush=True
        )
        return g

    return evaluate


def estimate_record(args, search, est) -> dict[str, Any]:
    """What ``estimate.json`` holds."""
    from scenarios.app.falsify import FAILED_MARGIN_M
    from scenarios.campaign.falsify_family import PARAMETERS

    failed = [e["flight"] for e in search.evaluations if not e["completed"]]
    return {
        "platform": args.platform,
        "variant": args.variant,
        "method": est.method,
        "event": f"min_margin_m <= {args.below_m:g}",
        "below_m": args.below_m,
        "input_distribution": INPUT_DISTRIBUTION,
        "parameters": [{"name": p.name, "low": p.low, "high": p.high, "unit": p.unit} for p in PARAMETERS],
        "seed": args.seed,
        "probability": est.probability,
        "cov": None if math.isinf(est.cov) else est.cov,
        "interval_95": None if est.interval is None else list(est.interval),
        "reached": est.reached,
        "stalled": est.stalled,
        "bound_threshold_m": None if est.reached else est.levels[-1].threshold,
        "flights": est.evaluations,
        "monte_carlo_flights_for_same_cov": None
        if math.isinf(est.monte_carlo_equivalent())
        else round(est.monte_carlo_equivalent()),
        "failed_flights": failed,
        "failed_margin_m": FAILED_MARGIN_M,
        "levels": [dataclasses.asdict(level) for level in est.levels],
        "evaluations": [
            {k: e[k] for k in ("flight", "generation", "x", "values", "completed", "margin_m")} for e in search.evaluations
        ],
    }


def write_outputs(args, search, est) -> None:
    """``estimate.json`` and ``estimate.png``, and the result on the console."""
    from analysis.formats.replace import replace_text
    from analysis.rare_event_plots import plot_levels

    record = estimate_record(args, search, est)
    replace_text(args.out / RESULTS, json.dumps(record, indent=1) + "\n")
    title = f"{args.platform}, {args.variant} fence: P[min margin <= {args.below_m:+g} m]"
    thresholds = [level.threshold for level in est.levels]
    bound = None if est.reached else est.levels[-1].threshold
    plot_levels(est.values, thresholds, args.below_m, est.probability, est.cov, est.interval, args.out / "estimate", title, bound)
    print(summary_line(args, est), flush=True)
    if record["failed_flights"]:
        print(
            f"warning: {len(record['failed_flights'])} flight(s) did not complete and count as no breach: the estimate is a lower bound"
        )
    print(f"wrote {args.out / RESULTS} and {args.out / 'estimate.png'}")


def summary_line(args, est) -> str:
    """One line: the estimate, its error, the flights it took and what plain Monte Carlo would need."""
    head = f"P[min margin <= {args.below_m:+g} m] = {est.probability:.3g}"
    if est.interval is not None:
        low, high = est.interval
        err = f"95 % interval [{low:.3g}, {high:.3g}]" + (f", CoV {est.cov:.2f}" if math.isfinite(est.cov) else "")
    else:
        err = f"CoV {est.cov:.2f}"
        if not est.reached:
            why = "the chains found no lower margin" if est.stalled else f"stopped after {len(est.levels) - 1} levels"
            head = f"P[min margin <= {args.below_m:+g} m] <= P[min margin <= {est.levels[-1].threshold:+.2f} m] = {est.probability:.3g}"
            err += f" ({why}: an upper bound)"
    equivalent = est.monte_carlo_equivalent()
    tail = (
        f"; plain Monte Carlo needs about {equivalent:,.0f} for that CoV"
        if est.method == "subset" and math.isfinite(equivalent)
        else ""
    )
    return f"{head}, {err} ({est.evaluations} flights{tail})"
