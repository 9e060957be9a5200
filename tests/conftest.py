"""Test-suite settings shared by every test module.

Hypothesis runs without its per-example deadline: the compiled kernels compile on their first call (a second
or more from a cold numba cache, as in a clean clone), and which example pays for that depends on the test
order. Timing belongs in ``bench/``, not in the tests.
"""

from hypothesis import settings

settings.register_profile("testbed", deadline=None)
settings.load_profile("testbed")
