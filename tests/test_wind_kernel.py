"""Property: the compiled wind field blows the reference objects' wind, bit for bit.

:class:`wind.field_kernel.WindArrays` samples a field :func:`wind.config.wind_from_config` builds in one compiled
call. For random configurations (any of steady, turbulence and gusts, each alone or together; uniform, power and
log profiles; gusts held, with fixed penetration speeds, from any direction, some timed from the first activation
and armed at a random moment) and random paths (hovering, flying, climbing through the ground and above the
model's top, steps repeated and longer than a second, past the turbulence's noise blocks) every sample must equal
the field objects' as floats' bits. Fields it does not know are left to the objects (None).
"""

import math
import random

from hypothesis import given, settings
from hypothesis import strategies as st

from wind.config import GustConfig, GustOnset, ProfileConfig, RandomGustsConfig, TurbulenceConfig, WindConfig, wind_from_config
from wind.dryden import NORMALS_PER_STEP, POOL_NORMALS, DrydenTurbulence
from wind.field import CalmWind, CompositeWind, notify_first_activation
from wind.field_kernel import compiled_wind
from wind.steady import SteadyWind

gusts = st.builds(
    GustConfig,
    onset_s=st.floats(0.0, 40.0),
    amplitude_mps=st.floats(0.0, 8.0),
    length_m=st.floats(1.0, 80.0),
    from_deg=st.one_of(st.none(), st.floats(0.0, 360.0)),
    vertical_mps=st.sampled_from([0.0, -1.5, 2.0]),
    hold_m=st.sampled_from([0.0, 15.0, math.inf]),
    penetration_speed_mps=st.sampled_from([None, None, 12.0]),
    onset_after=st.sampled_from(list(GustOnset)),
)
configs = st.builds(
    WindConfig,
    speed_mps=st.sampled_from([0.0, 0.0, 3.0, 9.5]),
    from_deg=st.sampled_from([0.0, 90.0, 225.0, 301.7]),
    profile=st.one_of(
        st.none(),
        st.just(ProfileConfig("power", exponent=0.2, reference_height_m=12.0)),
        st.just(ProfileConfig("log", roughness_length_m=0.1, reference_height_m=10.0)),
    ),
    turbulence=st.one_of(st.none(), st.just(TurbulenceConfig(severity="light")), st.just(TurbulenceConfig(w20_mps=9.0))),
    gusts=st.lists(gusts, max_size=5).map(tuple),
    random_gusts=st.one_of(st.none(), st.just(RandomGustsConfig(3, 5.0, 30.0, (1.0, 5.0), (10.0, 60.0), spread_deg=40.0))),
    seed=st.integers(0, 1000),
)


@settings(max_examples=60, deadline=None)
@given(cfg=configs, seed=st.integers(0, 10_000), path_seed=st.integers(0, 10_000))
def test_the_compiled_field_is_the_reference_field(cfg, seed, path_seed):
    reference = wind_from_config(cfg, seed)
    arrays = compiled_wind(wind_from_config(cfg, seed))
    if isinstance(reference, CalmWind):
        assert arrays is None
        return
    assert arrays is not None
    rng = random.Random(path_seed)
    e = n = 0.0
    up = rng.uniform(-2.0, 60.0)
    ve, vn = rng.uniform(-15, 15), rng.uniform(-15, 15)
    t = 0.0
    arm_at = rng.uniform(0.0, 50.0)
    armed = False
    steps = POOL_NORMALS // NORMALS_PER_STEP + 300  # past the turbulence's first noise block
    for k in range(steps):
        airspeed = rng.uniform(0.0, 25.0)
        a = reference.sample(t, e, n, up, airspeed)
        b = arrays.sample(t, e, n, up, airspeed)
        assert [x.hex() for x in a] == [x.hex() for x in b], (k, t)
        if not armed and t >= arm_at:
            notify_first_activation(reference, t)
            arrays.first_activation(t)
            armed = True
        r = rng.random()
        if r < 0.02:
            continue  # the same time again: the cached sample
        dt = 1.5 if r < 0.025 else 1.0 if r < 0.03 else 0.025  # longer than, and exactly, the velocity's limit
        if rng.random() < 0.01:
            ve, vn = rng.uniform(-15, 15), rng.uniform(-15, 15)
        t += dt
        e += ve * dt
        n += vn * dt
        up = min(max(up + rng.uniform(-0.5, 0.5), -3.0), 400.0)


def test_fields_it_does_not_know_are_left_to_the_objects():
    steady = SteadyWind(5.0, 270.0)
    other = SteadyWind(3.0, 90.0)
    assert compiled_wind(CalmWind()) is None
    assert compiled_wind(CompositeWind([steady, steady])) is None  # a part twice
    assert compiled_wind(CompositeWind([DrydenTurbulence(5.0), steady])) is None  # out of order
    assert compiled_wind(CompositeWind([steady, DrydenTurbulence(5.0, mean_wind=other)])) is None  # another mean wind
    assert compiled_wind(CompositeWind([steady, DrydenTurbulence(5.0, mean_wind=steady)])) is not None
