"""CPython's ``math.hypot`` as a function the compiled kernels can call: the same bits as the interpreter.

One question: the length of ``(x, y)`` exactly as CPython 3.11+ computes it. Its ``vector_norm`` is a
corrected square root, and the C library's ``hypot`` (what numba calls for ``math.hypot``) differs from it
in the last bit about once in a hundred calls. A kernel that must equal its Python reference bit for bit
(:mod:`geofence.lateral_kernel`, :mod:`geofence.margins_kernel`, :mod:`geofence.recovery_path`, the fixed-wing
recovery's step through :func:`geofence.control_laws.cpython_hypot`) calls :func:`hypot` instead.
Plain Python; :func:`geofence.jit.jitable`, so numba compiles it where a kernel calls it.
"""

from __future__ import annotations

import math

from geofence.jit import jitable

__all__ = ["hypot"]

_DBL_MIN = 2.2250738585072014e-308
_SPLIT = 134217729.0  # 2**27 + 1, Veltkamp's splitter


@jitable
def _two_product(x: float, y: float) -> tuple[float, float]:
    """``(hi, lo)`` with ``hi + lo == x·y`` exactly (Dekker's product with Veltkamp's split)."""
    hi = x * y
    c = _SPLIT * x
    xh = c - (c - x)
    xl = x - xh
    c = _SPLIT * y
    yh = c - (c - y)
    yl = y - yh
    lo = ((xh * yh - hi) + xh * yl + xl * yh) + xl * yl
    return hi, lo


@jitable
def _norm_scaled(ax: float, ay: float, mx: float) -> float:
    """CPython's ``vector_norm`` for two finite non-negative coordinates with ``mx = max(ax, ay) > 0``."""
    max_e = math.frexp(mx)[1]
    scale = math.ldexp(1.0, -max_e)
    csum = 1.0
    frac1 = 0.0
    frac2 = 0.0
    for v in (ax, ay):
        v = v * scale  # lossless scaling
        hi, lo = _two_product(v, v)  # lossless squaring
        s = csum + hi  # lossless addition (|csum| >= |hi|)
        frac2 += hi - (s - csum)
        csum = s
        frac1 += lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    hi, lo = _two_product(-h, h)
    s = csum + hi
    frac2 += hi - (s - csum)
    csum = s
    frac1 += lo
    x = csum - 1.0 + (frac1 + frac2)
    h += x / (2.0 * h)  # differential correction
    return h / scale


@jitable
def hypot(x: float, y: float) -> float:
    """``math.hypot(x, y)`` as CPython 3.11+ computes it (its ``vector_norm``, a corrected square root),
    so compiled code gets the interpreter's value bit for bit (the C library's ``hypot`` differs in the last
    bit about once in a hundred calls)."""
    ax = abs(x)
    ay = abs(y)
    if math.isinf(ax) or math.isinf(ay):
        return math.inf
    if math.isnan(ax) or math.isnan(ay):
        return math.nan
    mx = ax if ax > ay else ay
    if mx == 0.0:
        return mx
    if math.frexp(mx)[1] < -1023:  # subnormal: scale up first, as CPython does
        return _DBL_MIN * _norm_scaled(ax / _DBL_MIN, ay / _DBL_MIN, mx / _DBL_MIN)
    return _norm_scaled(ax, ay, mx)
