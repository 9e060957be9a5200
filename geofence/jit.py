"""The optional compiler: which pure-math functions the compiled kernels may call, and whether they are compiled.

:func:`jitable` marks a plain-Python function of floats (a room formula, the
drag law's push) that :mod:`geofence.lateral_kernel` calls from machine code.
Called from Python it *is* the Python function, unchanged: the interpreter
keeps running the reference. With numba installed the kernels compile these
functions from the same source, so each formula still has one home.

``COMPILED`` is true when numba is importable and not switched off by its own
``NUMBA_DISABLE_JIT=1`` (then the kernels run as Python, slowly, for a
debugger). The kernels compile on first use and cache the machine code beside
their source (numba's ``cache=True``), so later processes load it.

``ACTIVE`` says whether the per-step code takes the kernels (``COMPILED`` by
default) or the plain-Python reference they are tested against;
:func:`use_compiled` is the named hook that switches it for a process (the
benchmarks time both side by side).

:func:`entry_point` gives a kernel's machine code without numba's per-call choice of a specialization
(about 0.02 µs an argument), where that is safe; the per-step callers take it after their first call, and
:func:`use_entry_points` is the named hook that switches it off.

The machine code is cached in a folder named by a hash of every source the
kernels compile from (:func:`kernel_sources_stamp`): numba checks a cached
kernel against its own file only, and a kernel inlines functions from other
modules (a room formula, the lateral search), so after an edit to one of those
it would load stale machine code without a word. A changed source is a new
folder, compiled afresh; the other folders are removed.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path
from typing import Any, Callable, TypeVar

F = TypeVar("F", bound=Callable)

numba: Any
_register_jitable: Any
try:  # numba is a dependency; without it everything runs as the Python reference
    import numba
    from numba.extending import register_jitable as _register_jitable

    COMPILED: bool = not getattr(numba.config, "DISABLE_JIT", False)
except ImportError:  # pragma: no cover - exercised only where numba is missing
    numba = None
    _register_jitable = None
    COMPILED = False


KERNEL_SOURCES = (
    "geofence/*.py",
    "geofence/recovery/*.py",
    "wind/*.py",
    "aircraft/sensor*.py",
    "scenarios/flight/sensing.py",
    "scenarios/flight/recorder.py",
    "scenarios/flight/step_kernel.py",
    "scenarios/flight/pilots/law_kernel.py",
    "scenarios/flight/pilots/nav_laws.py",
)
"""The sources (globs from the repository root) the compiled kernels are built from, their inlined functions
included."""


def kernel_sources_stamp(root: Path) -> str:
    """A hash of the :data:`KERNEL_SOURCES` under ``root`` (their paths and bytes)."""
    h = hashlib.sha256()
    for pattern in KERNEL_SOURCES:
        for path in sorted(root.glob(pattern)):
            h.update(path.relative_to(root).as_posix().encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:16]


def cache_dir_for(root: Path) -> Path | None:
    """``<root>/.numba-cache/<stamp>``, the tree's folders of other stamps removed (stale machine code: a source
    has changed since); under the user's cache folder when the tree is not writable (shared by every install,
    so nothing is removed there); ``None`` when neither can be written (numba then keeps its own default)."""
    stamp = kernel_sources_stamp(root)
    for base in (root / ".numba-cache", Path.home() / ".cache" / "geofence-testbed" / "numba"):
        try:
            (base / stamp).mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if base.parent == root:
            for other in base.iterdir():
                if other.name != stamp and other.is_dir():
                    shutil.rmtree(other, ignore_errors=True)
        return base / stamp
    return None


if COMPILED and not os.environ.get("NUMBA_CACHE_DIR"):  # a cache folder the user chose is theirs to manage
    _folder = cache_dir_for(Path(__file__).resolve().parents[1])
    if _folder is not None:
        numba.config.CACHE_DIR = str(_folder)


def compiled(fn: F) -> F:
    """``fn`` compiled by numba (``njit(cache=True)``), an entry point of compiled code; without numba, or with
    ``NUMBA_DISABLE_JIT=1``, ``fn`` itself: the same source interpreted, never a second copy."""
    if not COMPILED:
        return fn
    return numba.njit(cache=True)(fn)


def jitable(fn: F) -> F:
    """``fn`` itself, also callable from compiled kernels (numba's ``register_jitable``) when numba is present."""
    if _register_jitable is None:  # pragma: no cover
        return fn
    return _register_jitable(fn)


ACTIVE: bool = COMPILED
"""The per-step code takes the compiled kernels (read at each call; set by :func:`use_compiled`)."""


def use_compiled(on: bool) -> bool:
    """Take the compiled kernels (``True``, the default where numba is) or the plain-Python reference
    (``False``), process-wide; returns the previous setting. ``True`` without numba stays the reference."""
    global ACTIVE
    previous = ACTIVE
    ACTIVE = bool(on) and COMPILED
    return previous


ENTRY_POINTS: bool = True
"""Callers take their kernels' entry points (:func:`entry_point`; set by :func:`use_entry_points`)."""


def use_entry_points(on: bool) -> bool:
    """Let :func:`entry_point` answer entry points (``True``, the default) or the kernels themselves (``False``:
    every call through numba's dispatcher), for the kernels bound from now on; returns the previous setting."""
    global ENTRY_POINTS
    previous = ENTRY_POINTS
    ENTRY_POINTS = bool(on)
    return previous


def entry_point(kernel: Callable) -> Callable:
    """``kernel``'s machine code without numba's per-call choice of a specialization, where that is safe: the entry
    point of its one specialization once it has exactly one and its scalar arguments are all ``float64`` or
    ``bool``; else ``kernel`` itself (and so without numba).

    At each call numba's dispatcher reads every argument's type to choose the machine code (some 0.02 µs an
    argument: 0.4 µs of a 22-argument margins call); the entry point only converts the arguments to the one
    specialization's types. A scalar converts as it would anyway (an int to a float exactly, ``None`` raises
    ``TypeError``), but an array of another dtype, number of dimensions or memory layout would be misread. So a
    caller takes it after its first call through the dispatcher, and only where every array it passes is built
    by its own code with fixed dtype, dimensions and C layout (its tables, refilled in place or rebuilt the same
    way). The Tern's closed loop runs 0.3 µs a frame faster this way (``bench/closed_loop.py``), the same
    trajectory bit for bit."""
    overloads = getattr(kernel, "overloads", None)
    if not ENTRY_POINTS or not overloads or len(overloads) != 1:
        return kernel
    ((signature, compiled),) = overloads.items()
    for t in signature:
        if not (isinstance(t, numba.types.Array) or t == numba.types.float64 or t == numba.types.boolean):
            return kernel
    return compiled.entry_point
