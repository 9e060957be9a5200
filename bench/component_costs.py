"""Benchmark: per-step cost of the outer-loop components, as multiples of one bare JSBSim frame.

Measured side by side in one run (median of interleaved repeats): a bare
JSBSim frame of the F450RD with its flight controller (``fdm.run()``), and one
call of each outer-loop component the closed loop makes per control step --
the wind field (steady + power-law profile + light Dryden turbulence + a
gust) as the flight samples it (compiled, :mod:`wind.field_kernel`) and as
its reference objects, Dryden turbulence alone, the geofence unit's sensor
suite (``SensorSuite.sample``), the unit's whole sensing chain (sensors,
estimator, wind estimator: :mod:`scenarios.flight.sensing`, one compiled
call), and the geofence unit's ``update`` near an edge of a
4-vertex and of a 1,000-vertex fence. The closed loop runs one control step
per 3 frames (40 Hz outer loop, 120 Hz JSBSim), so a component that costs
3 frames doubles the loop's cost.

    python bench/component_costs.py [--calls 20000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

from aircraft.factory import build_platform
from aircraft.sensors import SensorSuite
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import StickCommand, VehicleState
from geofence.unit.config import GeofenceConfig
from geofence.unit.geofence_unit import GeofenceUnit
from scenarios.definition.schema import load_scenario
from scenarios.flight.sensing import GeofenceSensing
from wind import SteadyWind
from wind.config import parse_wind, wind_from_config
from wind.dryden import DrydenTurbulence
from wind.field_kernel import compiled_wind

sys.path.insert(0, str(Path(__file__).parent))
import fence_scale  # noqa: E402  (the fence family and the moving-vehicle states)

SENSING_SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "geofence_multicopter_adversarial_wind.yaml"

WIND = {
    "speed_mps": 8,
    "from_deg": 270,
    "profile": {"law": "power", "exponent": 0.14, "reference_height_m": 10},
    "turbulence": {"severity": "light"},
    "gusts": [{"onset_s": 20, "amplitude_mps": 5, "length_m": 30}],
    "seed": 7,
}


def per_call_us(fn, calls: int) -> float:
    t0 = time.perf_counter()
    for k in range(calls):
        fn(k)
    return 1e6 * (time.perf_counter() - t0) / calls


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--calls", type=int, default=20000, help="calls per measurement (default 20000)")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved repeats, median reported (default 3)")
    args = ap.parse_args()

    platform = build_platform("F450RD")
    frame = LocalFrame(47.0, 8.0, 400.0)
    platform.reset(frame, 47.0, 8.0, 30.0, 0.0, 0.0)
    run = platform.model.fdm.run
    field = wind_from_config(parse_wind(WIND, "bench: wind"), seed=0)
    turb = DrydenTurbulence(severity="light", seed=0, mean_wind=SteadyWind(8.0, 270.0))
    suite = SensorSuite(seed=1)
    truth = VehicleState(lat_deg=47.0, lon_deg=8.0, alt_m=430.0, agl_m=30.0)
    units = {}
    for nv in (4, 1000):
        fence = fence_scale.star_fence(nv, 0)
        unit_states = fence_scale.moving_states(
            GeofenceUnit(
                GeofenceConfig(fence=fence, wind_prior_enu=fence_scale.WIND_EN),
                fence.to_local(fence_scale.FRAME),
                platform.envelope,
            ),
            True,
            args.calls,
        )
        units[nv] = (fence, unit_states)

    def restarted(source):
        """Samples from t = 0 each repeat: the wind sources refuse time going backwards (a reset starts them over)."""
        source.reset()
        return lambda k: source.sample(k * 0.025, 0.0, 0.0, 30.0, 12.0)

    def compiled_field():
        """The same field's compiled sampler, fresh from t = 0."""
        arrays = compiled_wind(wind_from_config(parse_wind(WIND, "bench: wind"), seed=0))
        assert arrays is not None
        return lambda k: arrays.sample(k * 0.025, 0.0, 0.0, 30.0, 12.0)

    sc = load_scenario(SENSING_SCENARIO)
    assert sc.geofence is not None

    truths = [replace(truth, t_s=k * 0.025) for k in range(args.calls)]

    def sensing():
        """The unit's sensing chain on a hovering truth from t = 0 (one GNSS fix every 8 calls)."""
        own = GeofenceSensing(sc, sc.geofence, sc.frame, platform.envelope)
        return lambda k: own.sense(truths[k], 0.025)

    def unit_fn(nv):
        fence, states = units[nv]
        unit = GeofenceUnit(
            GeofenceConfig(fence=fence, wind_prior_enu=fence_scale.WIND_EN), fence.to_local(fence_scale.FRAME), platform.envelope
        )
        pilot = StickCommand()

        def step(k):
            unit.update(states[k].t_s, states[k], pilot, fence_scale.DT_S, fence_scale.WIND_EN, True, 1.0, 1.0)
            assert unit.activations == 0, "the bench vehicle must stay outside the activation boundary"

        return step

    cases = {
        "bare JSBSim frame (F450RD + FC)": lambda: lambda k: run(),
        "wind field (profile+Dryden+gust)": compiled_field,
        "  reference objects": lambda: restarted(field),
        "Dryden turbulence alone (object)": lambda: restarted(turb),
        "sensor suite sample (object)": lambda: lambda k: suite.sample(truth),
        "unit's sensing chain": sensing,
        "geofence update, 4 vertices": lambda: unit_fn(4),
        "geofence update, 1,000 vertices": lambda: unit_fn(1000),
    }
    results = {name: [] for name in cases}
    for _ in range(args.repeats):
        for name, make in cases.items():
            results[name].append(per_call_us(make(), args.calls))
    frame_us = statistics.median(results["bare JSBSim frame (F450RD + FC)"])
    print(f"{'component':34s} {'us/call':>9s} {'JSBSim frames':>14s}")
    for name, r in results.items():
        us = statistics.median(r)
        print(f"{name:34s} {us:9.2f} {us / frame_us:14.2f}")


if __name__ == "__main__":
    main()
