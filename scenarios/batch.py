"""Batches: fly many scenarios in parallel, loss-free and resumable.

* :func:`discover` finds scenario YAML files under the given paths and
  :func:`plan` expands each (sweeps included) into :class:`FlightSpec` s.
* :func:`run_batch` flies the specs on local processes (default: all cores)
  or on a Dask cluster, with a progress bar (done/total, failures, ETA).
* Every finished flight is written atomically into ``<out>/<flight_id>/``
  (``scenario.yaml``, ``trajectory.csv``, ``summary.json`` last, which marks
  it done). Re-running the same command skips finished flights; a crash or
  Ctrl-C keeps them. A flight that fails (bad configuration, divergence, an
  exception) gets a ``summary.json`` with ``completed: false`` and the
  ``error``, and the batch goes on.
* At the end, ``results.csv`` (one row per flight) and ``report.md`` with
  figures are (re)written from all summaries in the folder.
"""

from __future__ import annotations

import json
import os
import signal
import sys
import time
import traceback
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from scenarios.errors import ConfigError
from scenarios.sweep import FlightSpec, expand

SUMMARY = "summary.json"


@dataclass
class BatchOutcome:
    total: int
    skipped: int
    flown: int
    failed: list[str] = field(default_factory=list)
    interrupted: bool = False
    wall_time_s: float = 0.0


def discover(paths: Iterable[str | Path]) -> list[Path]:
    """Scenario files: the given files, and every ``*.yaml`` below the given folders (sorted)."""
    found: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found.extend(sorted(q for q in p.rglob("*.yaml") if q.is_file()))
        elif p.is_file():
            found.append(p)
        else:
            raise ConfigError(f"{p}: no such scenario file or folder")
    return found


def plan(files: Iterable[Path]) -> list[FlightSpec]:
    """Expand files into flights; a file that cannot be read or expanded becomes one failed spec."""
    from scenarios.schema import read_document

    specs: list[FlightSpec] = []
    for path in files:
        try:
            raw = read_document(path)
            specs.extend(expand(raw, str(path), path.stem))
        except ConfigError as exc:
            specs.append(FlightSpec(path.stem, None, str(path), error=str(exc)))
    seen: dict[str, str] = {}
    unique = []
    for spec in specs:
        if spec.flight_id in seen:
            msg = f"{spec.source}: name: flight {spec.flight_id!r} is also defined in {seen[spec.flight_id]}"
            unique.append(FlightSpec(f"{spec.flight_id}__dup{len(unique)}", None, spec.source, error=msg))
            continue
        seen[spec.flight_id] = spec.source
        unique.append(spec)
    return unique


def is_done(out_dir: Path, flight_id: str) -> bool:
    return (Path(out_dir) / flight_id / SUMMARY).is_file()


def fly_spec(spec: FlightSpec, out_dir: str, flight_plots: bool = False) -> dict:
    """Fly one spec and write its folder; never raises (failures are written as a failed summary)."""
    from scenarios.runner import fly, write_result
    from scenarios.schema import parse_scenario

    folder = Path(out_dir) / spec.flight_id
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    try:
        if spec.error:
            raise ConfigError(spec.error)
        _atomic_write(folder / "scenario.yaml", yaml.safe_dump(spec.document, sort_keys=False))
        scenario = parse_scenario(spec.document, where=spec.source, default_name=spec.flight_id)
        result = fly(scenario)
        result.summary["flight"] = spec.flight_id
        result.summary["source"] = spec.source
        if flight_plots:  # before the summary, which marks the flight done
            from analysis.plots import plot_result

            plot_result(result, folder)
        write_result(result, out_dir, folder_name=spec.flight_id)
        return result.summary
    except Exception as exc:  # a failed flight is a result, not a crash of the batch
        kind = "bad configuration" if isinstance(exc, ValueError) else type(exc).__name__
        summary = {
            "flight": spec.flight_id,
            "scenario": spec.flight_id,
            "source": spec.source,
            "completed": False,
            "error": f"{kind}: {exc}",
            "wall_time_s": round(time.perf_counter() - t0, 3),
        }
        if not isinstance(exc, ConfigError):
            _atomic_write(folder / "error.txt", traceback.format_exc())
        _atomic_write(folder / SUMMARY, json.dumps(summary, indent=2) + "\n")
        return summary


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def run_batch(
    specs: list[FlightSpec],
    out_dir: Path,
    jobs: int | None = None,
    executor: str = "process",
    scheduler: str | None = None,
    progress: bool = True,
    on_done: Callable[[dict], None] | None = None,
    flight_plots: bool = False,
) -> BatchOutcome:
    """Fly every spec not already done in ``out_dir``; see the module docstring."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    todo = [s for s in specs if not is_done(out_dir, s.flight_id)]
    outcome = BatchOutcome(total=len(specs), skipped=len(specs) - len(todo), flown=0)
    t0 = time.perf_counter()
    bar = _bar(len(specs), outcome.skipped, progress)

    def finished(summary: dict) -> None:
        outcome.flown += 1
        if not summary.get("completed"):
            outcome.failed.append(summary.get("flight", "?"))
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"failed {len(outcome.failed)}")
        if on_done is not None:
            on_done(summary)

    try:
        if not todo:
            pass
        elif executor == "dask":
            _run_dask(todo, out_dir, scheduler, finished, flight_plots)
        elif (jobs or os.cpu_count() or 1) == 1:
            for spec in todo:
                finished(fly_spec(spec, str(out_dir), flight_plots))
        else:
            _run_processes(todo, out_dir, jobs or os.cpu_count() or 1, finished, flight_plots)
    except KeyboardInterrupt:
        outcome.interrupted = True
    finally:
        if bar is not None:
            bar.close()
        outcome.wall_time_s = time.perf_counter() - t0
    return outcome


def _ignore_sigint() -> None:
    """Workers leave Ctrl-C to the parent, which cancels what has not started; running flights finish."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run_processes(todo: list[FlightSpec], out_dir: Path, jobs: int, finished: Callable[[dict], None], flight_plots: bool) -> None:
    """At most ``jobs`` flights in flight at a time, so an interrupt only waits for those."""
    pool = ProcessPoolExecutor(max_workers=jobs, initializer=_ignore_sigint)
    queue = iter(todo)
    pending = set()
    try:
        for spec in queue:
            pending.add(pool.submit(fly_spec, spec, str(out_dir), flight_plots))
            if len(pending) >= jobs:
                break
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                finished(fut.result())
                nxt = next(queue, None)
                if nxt is not None:
                    pending.add(pool.submit(fly_spec, nxt, str(out_dir), flight_plots))
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


def _run_dask(
    todo: list[FlightSpec], out_dir: Path, scheduler: str | None, finished: Callable[[dict], None], flight_plots: bool
) -> None:
    try:
        from dask.distributed import Client, as_completed
    except ImportError:
        raise ConfigError("--executor dask: dask.distributed is not installed (pip install 'geofence-testbed[dask]')") from None
    if not scheduler:
        raise ConfigError("--executor dask: give the cluster with --scheduler ADDRESS (e.g. tcp://127.0.0.1:8786)")
    with Client(scheduler) as client:
        futures = [
            client.submit(fly_spec, spec, str(out_dir), flight_plots, key=f"flight-{spec.flight_id}", pure=False) for spec in todo
        ]
        try:
            for fut in as_completed(futures):
                finished(fut.result())
        finally:
            client.cancel(futures)


def _bar(total: int, initial: int, enabled: bool):
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, desc="flights", unit="flight", file=sys.stderr, dynamic_ncols=True)
