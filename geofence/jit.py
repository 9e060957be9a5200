"""The compiler: marks the functions the compiled kernels are built from, and compiles their entry points.

Every per-step algorithm is written once, as plain Python over floats, arrays and records that numba can
compile. :func:`jitable` marks a function a kernel calls from machine code (a room formula, the drag law's
push): called from Python it *is* the Python function. :func:`compiled` makes a function an entry point of
compiled code (``njit(cache=True)``). Without numba, or with numba's own ``NUMBA_DISABLE_JIT=1``
(``COMPILED`` false), both return the function itself: the same source, interpreted (slowly, for a debugger),
never a second copy.

:func:`entry_point` gives a kernel's machine code without numba's per-call choice of a specialization (about
0.02 µs an argument), where that is safe; the per-step callers take it after their first call.

The machine code is cached in a folder named by a hash of the sources the kernels are built from
(:func:`kernel_sources`, :func:`kernel_sources_stamp`): numba checks a cached kernel against its own file
only, and a kernel inlines functions from other modules (a room formula, the lateral search), so after an
edit to one of those it would load stale machine code without a word. A changed source is a new folder,
compiled afresh; the other folders are removed. A source that no kernel is built from (a file format, the
application) leaves the cache alone.
"""

from __future__ import annotations

import hashlib
import os
import re
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


KERNEL_PACKAGES = ("geofence", "wind", "aircraft", "scenarios", "analysis")
"""The packages (folders under the repository root) searched for compiled modules."""

_USES_JIT = re.compile(r"^\s*(from geofence\.jit import|from geofence import jit\b|import geofence\.jit)", re.M)
_IMPORTS = re.compile(r"^\s*(?:from|import)\s+((?:" + "|".join(KERNEL_PACKAGES) + r")(?:\.\w+)*)", re.M)


def kernel_sources(root: Path) -> list[Path]:
    """The sources the compiled code is built from: every module of :data:`KERNEL_PACKAGES` that imports this one
    (it defines a kernel, an entry point or a function a kernel inlines, each marked :func:`jitable` or
    :func:`compiled`), and the project modules those import (whose constants a kernel may freeze into its machine
    code). Anything else (a file format, the application, a docstring in them) leaves the cache alone."""
    compiled = [
        p
        for package in KERNEL_PACKAGES
        for p in sorted((root / package).rglob("*.py"))
        if p.name == "jit.py" or _USES_JIT.search(p.read_text())
    ]
    found = set(compiled)
    for path in compiled:
        for dotted in _IMPORTS.findall(path.read_text()):
            parts = dotted.split(".")
            for n in range(len(parts), 0, -1):  # the longest prefix that is a module or a package
                base = root.joinpath(*parts[:n])
                hit = base.with_suffix(".py") if base.with_suffix(".py").is_file() else base / "__init__.py"
                if hit.is_file():
                    found.add(hit)
                    break
    return sorted(found)


def kernel_sources_stamp(root: Path) -> str:
    """A hash of the :func:`kernel_sources` under ``root`` (their paths and bytes)."""
    h = hashlib.sha256()
    for path in kernel_sources(root):
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
    if not overloads or len(overloads) != 1:
        return kernel
    known = _ENTRY_POINTS.get(id(kernel))
    if known is not None and known[0] is kernel:  # found with the one specialization it still has
        return known[1]
    ((signature, compiled),) = overloads.items()
    for t in signature:
        if not (isinstance(t, numba.types.Array) or t == numba.types.float64 or t == numba.types.boolean):
            return kernel
    _ENTRY_POINTS[id(kernel)] = (kernel, compiled.entry_point)
    return compiled.entry_point


_ENTRY_POINTS: dict[int, tuple[Callable, Callable]] = {}
"""The entry points found, by kernel (its identity checked: the entry holds it). Reading a specialization's types
costs some 100 µs (numba hashes each type), more than a margins call: an object built per call, as
:func:`geofence.margins.boundary_shift.activation_margins` builds one, would pay it every time. Specializations
are only ever added, so while a kernel still has exactly one, the entry point found is that one's; once it has
two, :func:`entry_point` gives the kernel itself again."""
