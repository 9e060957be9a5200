"""Batches: fly many scenarios in parallel, loss-free and resumable.

* :func:`discover` finds scenario YAML files under the given paths and
  :func:`plan` expands each (sweeps included) into :class:`FlightSpec` s.
* :func:`run_batch` flies the specs on local processes (default: all cores)
  or on a Dask cluster, with a progress bar (done/total, failures, ETA).
* Every finished flight is written into a temporary folder beside
  ``<out>/<flight_id>/`` and swapped in as a whole (``scenario.yaml``,
  ``trajectory.csv``, figures, ``summary.json``), so a folder is either the
  complete result of one flight or absent. Its ``summary.json`` holds the
  flight's ``scenario_hash`` (sha256 of the resolved scenario, the version and the code that flew it,
  :func:`scenarios.definition.sweep.scenario_hash`, and of the bytes of a fence file it references,
  :func:`with_referenced_files`): re-running skips only flights whose
  stored hash matches, and flies an edited scenario again. A crash or Ctrl-C
  keeps finished flights. A flight that fails (bad configuration, divergence,
  an exception) gets a ``summary.json`` with ``completed: false`` and the
  ``error``, and the batch goes on.
* Refused up front (:class:`ConfigError`, nothing flown): two flights with the
  same name, a sweep whose structure or dotted paths are wrong, a scenario
  folder with no ``*.yaml`` in it, an unreachable Dask scheduler, and an
  output folder another batch is writing into: a batch holds an exclusive
  ``fcntl.flock`` on ``<out>/.batch.lock`` (the holder's pid, host and start
  time written in it) while it flies, released when it ends, Ctrl-C included;
  the kernel drops the lock of a process that died, so a stale file never
  blocks.
* ``<out>/.batch.json`` records the flights the batch planned and whether it
  ran to its end: ``results.csv`` and ``report.md`` of an interrupted batch
  say it is partial (:func:`analysis.report.batch_progress`). On Ctrl-C the
  flights already in the air are waited for and counted, so the console's
  count is the folders written.
* Temporary JSBSim model folders never outlive a model's load
  (:mod:`aircraft.jsbsim_model`); a worker that gets SIGTERM removes any
  in-progress one before it exits.
* At the end, ``results.csv`` (one row per flight) and ``report.md`` with
  figures are (re)written from all summaries in the folder.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import signal
import socket
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import NamedTuple

import yaml

from geofence.validation import ConfigError
from scenarios.definition.sweep import FlightSpec, expand, with_referenced_files

SUMMARY = "summary.json"


class Executor(str, Enum):
    """Where a batch's flights fly (``--executor``)."""

    PROCESS = "process"
    """Local worker processes (the default)."""
    DASK = "dask"
    """A Dask cluster (``--scheduler``)."""


class Trajectories(Enum):
    """Which flights keep their ``trajectory.csv`` (``--trajectories``)."""

    ALL = "all"
    """Every flight (the default)."""
    NOTABLE = "notable"
    """Only those a reviewer or the campaign report reads one of (:func:`notable`): at campaign scale the rest are
    about 0.5 MB a flight and a tenth of its wall time, and the summary keeps their scores."""


NOTABLE_TOUCHDOWN_VERTICAL_MPS = 1.0
"""A touchdown faster than this downwards is notable (m/s): issue 38's landing requirement."""
NOTABLE_TOUCHDOWN_HORIZONTAL_MPS = 0.5
"""... or faster than this over the ground (m/s)."""


def notable(summary: dict) -> bool:
    """Whether a flight's trajectory is kept under :attr:`Trajectories.NOTABLE`: it has no geofence (an unprotected
    twin, which the campaign report scores from its trajectory), did not complete or failed, went outside the fence
    (``max_excursion_m`` above 0), entered a keep-out, landed outside a gap, was terminated, or touched down faster
    than :data:`NOTABLE_TOUCHDOWN_VERTICAL_MPS` / :data:`NOTABLE_TOUCHDOWN_HORIZONTAL_MPS`."""
    if not summary.get("geofence") or not summary.get("completed") or summary.get("error"):
        return True
    if summary.get("breached_keep_out") or summary.get("landed_outside_gap") or summary.get("terminated_at_s") is not None:
        return True
    limits = (("max_excursion_m", 0.0), ("touchdown_vertical_mps", NOTABLE_TOUCHDOWN_VERTICAL_MPS),
              ("touchdown_horizontal_mps", NOTABLE_TOUCHDOWN_HORIZONTAL_MPS))  # fmt: skip
    return any(isinstance(summary.get(k), (int, float)) and summary[k] > limit for k, limit in limits)


class Writing(NamedTuple):
    """What a batch writes of each flight besides its ``summary.json`` and ``scenario.yaml``."""

    flight_plots: bool = False
    """``flight.png``/``.svg``."""
    trajectories: Trajectories = Trajectories.ALL
    """Whose ``trajectory.csv``."""


LOCK = ".batch.lock"
"""The file in the output folder a batch holds an exclusive ``flock`` on while it flies."""
STATE = ".batch.json"
"""The batch's plan in its output folder (:data:`analysis.report.BATCH_STATE`)."""


@dataclass
class BatchOutcome:
    total: int
    skipped: int
    flown: int
    failed: list[str] = field(default_factory=list)
    changed: int = 0
    """Flights whose stored result was of another version of the scenario: flown again."""
    reasons: dict[str, str] = field(default_factory=dict)
    """Why each failed flight did not complete (its ``incomplete_reason``)."""
    interrupted: bool = False
    wall_time_s: float = 0.0


def discover(paths: Iterable[str | Path]) -> list[Path]:
    """Scenario files: the given files, and every ``*.yaml`` below the given folders (sorted)."""
    found: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            files = sorted(q for q in p.rglob("*.yaml") if q.is_file())
            if not files:
                raise ConfigError(f"{p}: no scenario files (*.yaml) in this folder")
            found.extend(files)
        elif p.is_file():
            found.append(p)
        else:
            raise ConfigError(f"{p}: no such scenario file or folder")
    return found


def plan(files: Iterable[Path]) -> list[FlightSpec]:
    """Expand files into flights.

    A file that cannot be read becomes one failed spec (recorded, the batch goes on); a sweep that
    cannot be expanded (bad structure, a dotted path that points nowhere) and two flights with the
    same name are refused up front with a :class:`ConfigError`.
    """
    from scenarios.definition.schema import read_document

    specs: list[FlightSpec] = []
    for path in files:
        try:
            raw = read_document(path)
        except ConfigError as exc:
            specs.append(FlightSpec(path.stem, None, str(path), error=str(exc)))
            continue
        specs.extend(with_referenced_files(expand(raw, str(path), path.stem), path.parent))
    check_unique_names(specs)
    return specs


def check_unique_names(specs: Iterable[FlightSpec]) -> None:
    """Two flights of one invocation must not write the same folder: refuse, naming both files."""
    seen: dict[str, str] = {}
    for spec in specs:
        if spec.flight_id in seen:
            first = seen[spec.flight_id]
            where = f"{spec.source} and {first}" if spec.source != first else spec.source
            raise ConfigError(
                f"{spec.source}: name: flight {spec.flight_id!r} is defined twice ({where}); names must be unique in one run"
            )
        seen[spec.flight_id] = spec.source


@dataclass
class ResumeState:
    """Which specs already have a matching result in the output folder."""

    done: list[FlightSpec] = field(default_factory=list)
    changed: list[FlightSpec] = field(default_factory=list)
    """A result exists, but of another version of the scenario (or without a hash): flown again."""
    new: list[FlightSpec] = field(default_factory=list)


def resume_state(specs: Iterable[FlightSpec], out_dir: Path) -> ResumeState:
    state = ResumeState()
    for spec in specs:
        stored = stored_hash(out_dir, spec.flight_id)
        if stored is None:
            state.new.append(spec)
        elif stored == spec.scenario_hash:
            state.done.append(spec)
        else:
            state.changed.append(spec)
    return state


def stored_hash(out_dir: Path, flight_id: str) -> str | None:
    """The ``scenario_hash`` of the result in ``out_dir/flight_id`` ("" if it has none); None without a result."""
    path = Path(out_dir) / flight_id / SUMMARY
    if not path.is_file():
        return None
    try:
        return str(json.loads(path.read_text()).get("scenario_hash") or "")
    except (OSError, ValueError, AttributeError):
        return ""


def is_done(out_dir: Path, spec: FlightSpec) -> bool:
    """True if ``out_dir`` holds this exact flight's result (same name and same scenario hash)."""
    return stored_hash(out_dir, spec.flight_id) == spec.scenario_hash


def fly_spec(spec: FlightSpec, out_dir: str, writing: Writing = Writing()) -> dict:
    """Fly one spec and write its folder (``writing``: its figures, its trajectory); never raises (failures are
    written as a failed summary)."""
    from scenarios.definition.schema import parse_scenario
    from scenarios.flight.runner import fly, replace_folder, write_result

    final = Path(out_dir) / spec.flight_id
    t0 = time.perf_counter()
    try:
        if spec.error:
            raise ConfigError(spec.error)
        scenario = parse_scenario(spec.document, where=spec.source, default_name=spec.flight_id)
        result = fly(scenario)
        result.summary["flight"] = spec.flight_id
        result.summary["source"] = spec.source
        write_result(
            result,
            Path(out_dir),
            folder_name=spec.flight_id,
            scenario_text=yaml.safe_dump(spec.document, sort_keys=False),
            plot=writing.flight_plots,
            scenario_hash=spec.scenario_hash,
            trajectory=writing.trajectories is Trajectories.ALL or notable(result.summary),
        )
        return result.summary
    except Exception as exc:  # a failed flight is a result, not a crash of the batch
        kind = "bad configuration" if isinstance(exc, ValueError) else type(exc).__name__
        summary = {
            "flight": spec.flight_id,
            "scenario": spec.flight_id,
            "source": spec.source,
            "completed": False,
            "error": f"{kind}: {exc}",
            "incomplete_reason": f"{kind}: {exc}",
            "scenario_hash": spec.scenario_hash,
            "wall_time_s": round(time.perf_counter() - t0, 3),
        }
        trace = None if isinstance(exc, ConfigError) else traceback.format_exc()

        def fill(folder: Path) -> None:
            if spec.document is not None:
                (folder / "scenario.yaml").write_text(yaml.safe_dump(spec.document, sort_keys=False))
            if trace is not None:
                (folder / "error.txt").write_text(trace)
            (folder / SUMMARY).write_text(json.dumps(summary, indent=2) + "\n")

        replace_folder(final, fill)
        return summary


def remove_stale_staging(out_dir: Path) -> None:
    """Remove temporary flight folders (``.<flight>.*.tmp``) a killed run left behind."""
    import shutil

    from scenarios.flight.runner import STAGING_SUFFIX

    for p in Path(out_dir).glob(f".*{STAGING_SUFFIX}"):
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)


SLOW_START_NOTICE_S = 3.0
"""A flight whose first step has not ended after this long says why (s)."""
SLOW_START_NOTICE = (
    "starting: the first flight after an install compiles the per-step kernels "
    "(about 15 s, once; later runs load them from the cache)"
)
BATCH_SLOW_START_S = 30.0
"""A batch with no flight finished after this long says what the first flights after an install do (s)."""
BATCH_SLOW_START_NOTICE = (
    "no flight finished yet: the first flights after an install compile the per-step kernels "
    "(about 15 s in each worker, once; later runs load them from the cache)"
)


def slow_start_notice(bar, after_s: float, message: str = SLOW_START_NOTICE) -> threading.Timer:
    """A started timer that writes ``message`` above the progress ``bar`` after ``after_s`` unless cancelled."""
    notice = threading.Timer(after_s, bar.write, args=(message,), kwargs={"file": bar.fp})
    notice.daemon = True
    notice.start()
    return notice


_HELD: set[Path] = set()
"""Output folders this process holds the lock of (a nested :func:`output_lock` of the same folder passes)."""


@contextlib.contextmanager
def output_lock(out_dir: Path) -> Iterator[None]:
    """Hold the exclusive lock of ``out_dir`` (:data:`LOCK`) while the block runs, or refuse in one line.

    The lock is the kernel's ``flock``: released when the block ends (an exception or Ctrl-C included) and
    when the process dies, so a file left by a killed batch never blocks another.
    """
    out_dir = Path(out_dir).resolve()
    if out_dir in _HELD:
        yield
        return
    fh = open(out_dir / LOCK, "a+")
    try:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = " ".join(fh.read().split()) or "a process that has not said who it is"
            raise ConfigError(
                f"--out {out_dir}: another batch is writing into this folder ({holder}); "
                "wait for it to end, or choose another folder"
            ) from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()} on {socket.gethostname()}, started {time.strftime('%Y-%m-%d %H:%M:%S %Z')}\n")
        fh.flush()
        _HELD.add(out_dir)
        try:
            yield
        finally:
            _HELD.discard(out_dir)
            fh.seek(0)
            fh.truncate()  # (then the kernel's lock goes with the file's closing)
    finally:
        fh.close()


def write_state(out_dir: Path, specs: Iterable[FlightSpec], finished: bool) -> None:
    """:data:`STATE`: the flights planned and whether the batch ran to its end (written atomically)."""
    path = Path(out_dir) / STATE
    tmp = path.with_name(f"{path.name}.part")
    tmp.write_text(json.dumps({"planned": [s.flight_id for s in specs], "finished": finished}, indent=1) + "\n")
    os.replace(tmp, path)


def run_batch(
    specs: list[FlightSpec],
    out_dir: Path,
    jobs: int | None = None,
    executor: Executor | str = Executor.PROCESS,
    scheduler: str | None = None,
    progress: bool = True,
    on_done: Callable[[dict], None] | None = None,
    flight_plots: bool = False,
    slow_start_s: float = BATCH_SLOW_START_S,
    trajectories: Trajectories = Trajectories.ALL,
    dask_in_flight: int | None = None,
) -> BatchOutcome:
    """Fly every spec not already done in ``out_dir``; see the module docstring. With ``progress``, a batch
    with no flight finished after ``slow_start_s`` says why it may be (:data:`BATCH_SLOW_START_NOTICE`).
    ``trajectories``: whose ``trajectory.csv`` is written (a flight done without one is not flown again for it).
    ``dask_in_flight``: on a Dask cluster, how many flights are submitted at a time (default :func:`dask_window`)."""
    out_dir = Path(out_dir)
    check_unique_names(specs)
    out_dir.mkdir(parents=True, exist_ok=True)
    with output_lock(out_dir):  # before anything is touched: a running batch's staging folders are its own
        writing = Writing(flight_plots, trajectories)
        executors = Executors(jobs, Executor(executor), scheduler, dask_in_flight)
        return _run_locked(specs, out_dir, executors, progress, on_done, writing, slow_start_s)


class Executors(NamedTuple):
    """Where a batch's flights fly: ``jobs`` local processes, or a Dask cluster (:attr:`Executor.DASK` at
    ``scheduler``, ``dask_in_flight`` submitted at a time; None: :func:`dask_window`)."""

    jobs: int | None
    executor: Executor
    scheduler: str | None
    dask_in_flight: int | None


def _run_locked(specs, out_dir, executors: Executors, progress, on_done, writing, slow_start_s) -> BatchOutcome:
    """:func:`run_batch` once the output folder's lock is held."""
    remove_stale_staging(out_dir)
    write_state(out_dir, specs, finished=False)
    state = resume_state(specs, out_dir)
    done = {s.flight_id for s in state.done}
    todo = [s for s in specs if s.flight_id not in done]
    outcome = BatchOutcome(total=len(specs), skipped=len(done), flown=0, changed=len(state.changed))
    t0 = time.perf_counter()
    jobs, scheduler = executors.jobs, executors.scheduler
    client = _dask_client(scheduler) if executors.executor is Executor.DASK and todo else None  # refused before any progress
    bar = _bar(len(specs), outcome.skipped, progress)
    notice = slow_start_notice(bar, slow_start_s, BATCH_SLOW_START_NOTICE) if bar is not None and todo else None

    def finished(summary: dict) -> None:
        if notice is not None:
            notice.cancel()
        outcome.flown += 1
        if not summary.get("completed"):
            flight = summary.get("flight", "?")
            outcome.failed.append(flight)
            outcome.reasons[flight] = str(summary.get("incomplete_reason") or summary.get("error") or "")
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"failed {len(outcome.failed)}")
        if on_done is not None:
            on_done(summary)

    try:
        if not todo:
            pass
        elif client is not None:
            _run_dask(todo, out_dir, client, finished, writing, executors.dask_in_flight)
        elif (jobs or os.cpu_count() or 1) == 1:
            for spec in todo:
                finished(fly_spec(spec, str(out_dir), writing))
        else:
            _run_processes(todo, out_dir, jobs or os.cpu_count() or 1, finished, writing)
    except KeyboardInterrupt:
        outcome.interrupted = True
        outcome.flown = sum(is_done(out_dir, s) for s in todo)  # the folders written, whatever was reported
    finally:
        if notice is not None:
            notice.cancel()
        if bar is not None:
            bar.close()
        outcome.wall_time_s = time.perf_counter() - t0
    write_state(out_dir, specs, finished=not outcome.interrupted)
    return outcome


def _ignore_sigint() -> None:
    """Workers leave Ctrl-C to the parent, which cancels what has not started; running flights finish.

    On SIGTERM a worker removes its temporary files (a JSBSim model folder being loaded) and exits at once:
    a pool worker does not run ``atexit`` handlers.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _worker_sigterm)


def _worker_sigterm(signum, frame) -> None:  # pragma: no cover - runs in a worker being killed
    from aircraft.jsbsim_model import remove_temporary_folders

    remove_temporary_folders()
    os._exit(128 + signum)


class _DeferredInterrupt:
    """The first Ctrl-C only raises a flag, read between flights, so it never lands between a submit and its
    bookkeeping (a flight submitted but not tracked would land after the count); a second one stops at once.
    Off the main thread (where no handler can be installed) Ctrl-C stays an exception, as before."""

    def __init__(self) -> None:
        self.requested = False
        self._installed = False
        self._previous: object = signal.SIG_DFL

    def __enter__(self) -> _DeferredInterrupt:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._handle)
            self._installed = True
        return self

    def __exit__(self, *exc) -> None:
        if self._installed:
            signal.signal(signal.SIGINT, self._previous if self._previous is not None else signal.SIG_DFL)  # type: ignore[arg-type]

    def _handle(self, signum, frame) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True


POLL_S = 0.1
"""How often the process executor looks for a Ctrl-C while it waits for flights."""


def _run_processes(todo: list[FlightSpec], out_dir: Path, jobs: int, finished: Callable[[dict], None], writing: Writing) -> None:
    """At most ``jobs`` flights in flight at a time, so an interrupt only waits for those."""
    pool = ProcessPoolExecutor(max_workers=jobs, initializer=_ignore_sigint)
    queue = iter(todo)
    pending: set = set()
    with _DeferredInterrupt() as stop:
        try:
            for spec in queue:
                pending.add(pool.submit(fly_spec, spec, str(out_dir), writing))
                if len(pending) >= jobs:
                    break
            while pending and not stop.requested:
                done, pending = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
                for fut in done:
                    finished(fut.result())
                    nxt = None if stop.requested else next(queue, None)
                    if nxt is not None:
                        pending.add(pool.submit(fly_spec, nxt, str(out_dir), writing))
            if stop.requested:
                raise KeyboardInterrupt
        except KeyboardInterrupt:
            _land_running(pending, finished)
            raise
        finally:
            pool.shutdown(wait=False, cancel_futures=True)


def _land_running(pending: set, finished: Callable[[dict], None]) -> None:
    """After Ctrl-C: cancel the flights not started, wait for those in the air (their workers ignore it) and count
    them, so what is reported is what is on disk. A second Ctrl-C stops the waiting."""
    for fut in pending:
        fut.cancel()
    running = [f for f in pending if not f.cancelled()]
    if running:
        print(
            f"interrupted: waiting for the {len(running)} flight(s) in the air to land (Ctrl-C again: stop now)", file=sys.stderr
        )
    for fut in wait(running).done:
        if fut.exception() is None:
            finished(fut.result())


def _dask_client(scheduler: str | None):
    if not scheduler:
        raise ConfigError("--executor dask: give the cluster with --scheduler ADDRESS (e.g. tcp://127.0.0.1:8786)")
    _probe_scheduler(scheduler)  # before the slow import of dask
    try:
        from dask.distributed import Client
    except ImportError:
        raise ConfigError("--executor dask: dask.distributed is not installed (pip install 'geofence-testbed[dask]')") from None
    return connect_dask(Client, scheduler)


DASK_IN_FLIGHT_PER_THREAD = 4
"""Flights submitted to a Dask cluster at a time, per worker thread (at least :data:`DASK_IN_FLIGHT_MIN`): the
scheduler always has work queued, and the client holds a bounded number of futures whatever the batch's size."""
DASK_IN_FLIGHT_MIN = 16
DASK_RESIZE_EVERY = 256
"""The cluster's thread count is asked again after this many flights (a cluster that scales up gets more)."""


def _run_dask(
    todo: list[FlightSpec], out_dir: Path, client, finished: Callable[[dict], None], writing: Writing,
    in_flight: int | None,
) -> None:  # fmt: skip
    """The flights on a Dask cluster, at most ``in_flight`` submitted at a time (None: :func:`dask_window`, asked
    again every :data:`DASK_RESIZE_EVERY` flights); on any exit the rest are cancelled."""
    from dask.distributed import as_completed

    def submit(spec: FlightSpec):
        fut = client.submit(fly_spec, spec, str(out_dir), writing, key=f"flight-{spec.flight_id}", pure=False)
        outstanding.add(fut)
        return fut

    with client:
        queue = iter(todo)
        outstanding: set = set()
        window = in_flight or dask_window(client)
        running = as_completed([submit(spec) for _, spec in zip(range(window), queue)])
        try:
            for done, fut in enumerate(running, start=1):
                outstanding.discard(fut)
                finished(fut.result())
                if in_flight is None and done % DASK_RESIZE_EVERY == 0:
                    window = dask_window(client)
                for _, spec in zip(range(window - len(outstanding)), queue):
                    running.add(submit(spec))
        finally:
            client.cancel(list(outstanding))


def dask_window(client) -> int:
    """How many flights to keep submitted: :data:`DASK_IN_FLIGHT_PER_THREAD` per worker thread of the cluster now."""
    threads = sum(client.nthreads().values())
    return max(DASK_IN_FLIGHT_MIN, DASK_IN_FLIGHT_PER_THREAD * threads)


DASK_CONNECT_TIMEOUT_S = 10.0


def connect_dask(client_cls, scheduler: str):
    """A Dask client of ``scheduler``, or a one-line :class:`ConfigError` (see also :func:`_probe_scheduler`)."""
    import logging

    where = f"--scheduler {scheduler}"
    quiet = logging.getLogger("distributed")
    level = quiet.level
    quiet.setLevel(logging.CRITICAL)  # the connection failure is reported below, once
    try:
        return client_cls(scheduler, timeout=DASK_CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as exc:
        first = (str(exc).splitlines() or [type(exc).__name__])[0]
        raise ConfigError(f"{where}: cannot reach the Dask scheduler ({first})") from None
    finally:
        quiet.setLevel(level)


def _probe_scheduler(scheduler: str) -> None:
    """A TCP address where nothing listens is refused at once (instead of the client's connect timeout)."""
    import socket
    from urllib.parse import urlsplit

    where = f"--scheduler {scheduler}"
    try:
        parts = urlsplit(scheduler if "://" in scheduler else f"tcp://{scheduler}")
        if parts.scheme not in ("tcp", "tls"):
            return
        host, port = parts.hostname, parts.port
    except ValueError:  # a malformed address ("http://[::1")
        host = port = None
    if not host or not port:
        raise ConfigError(f"{where}: expected an address like tcp://HOST:PORT")
    try:
        socket.create_connection((host, port), timeout=min(5.0, DASK_CONNECT_TIMEOUT_S)).close()
    except OSError as exc:
        raise ConfigError(f"{where}: cannot reach the Dask scheduler ({exc.strerror or exc})") from None


def _bar(total: int, initial: int, enabled: bool):
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, desc="flights", unit="flight", file=sys.stderr, dynamic_ncols=True)
