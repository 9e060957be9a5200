"""The compiled kernels' entry points (:func:`geofence.jit.entry_point`): taken only where they are safe, and the
same numbers as the dispatcher's; a flight that takes them records the trajectory of one that does not."""

from pathlib import Path

import numpy as np
import pytest

from geofence import jit

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(not jit.COMPILED, reason="numba is not installed")


def _kernel():
    return jit.numba.njit(lambda a, x, flag: a[0] * x + (1.0 if flag else 0.0))


def test_the_entry_point_of_one_float_specialization_gives_the_dispatchers_numbers():
    k = _kernel()
    a = np.array([1.5, 2.0])
    assert jit.entry_point(k) is k  # not compiled yet: the dispatcher
    want = k(a, 0.1, True)
    ep = jit.entry_point(k)
    assert ep is not k
    assert ep(a, 0.1, True) == want and ep(a, 3, False) == k(a, 3.0, False)  # an int converts to float, exactly


def test_an_entry_point_found_once_is_given_again_until_a_second_specialization_appears():
    k = _kernel()
    k(np.ones(2), 1.0, True)
    first = jit.entry_point(k)
    assert first is not k and jit.entry_point(k) is first  # remembered
    k(np.ones((2, 2)), 1.0, True)  # a second specialization: the remembered one no longer fits every caller
    assert jit.entry_point(k) is k


def test_no_entry_point_for_several_specializations_or_integer_scalars():
    k = _kernel()
    k(np.ones(2), 1.0, True)
    k(np.ones((2, 2)), 1.0, True)[0]  # a second specialization: the dispatcher must choose
    assert jit.entry_point(k) is k
    i = jit.numba.njit(lambda a, n: a[0] * n)
    i(np.ones(2), 3)  # an int64 scalar: a float passed later would be cut, so no entry point
    assert jit.entry_point(i) is i
    assert jit.entry_point(len) is len  # not a kernel at all
