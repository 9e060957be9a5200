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
"""

from __future__ import annotations

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
