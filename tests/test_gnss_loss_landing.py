"""A multirotor landing without GNSS: the rangefinder and optical-flow models, their fusion, the flared touchdown.

Issue 38: with GNSS lost, a multirotor landing on dead reckoning had no height above ground and descended at the
full rate into it. The unit can now carry a downward rangefinder and an optical-flow sensor
(:mod:`aircraft.sensors`); the estimator takes its height above ground and, with no fix, its velocity from them;
the landing flares on the measured height and nulls the measured velocity before touchdown.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from support import FRAME, flow_suite, gnss_loss_landing, sample_flow_range

from aircraft.sensors import OpticalFlowConfig, RangefinderConfig, SensorConfig, parse_sensors
from analysis.scoring import touchdown_index
from geofence.estimation.estimator import GeofenceEstimator
from geofence.interface import VehicleState
from geofence.validation import ConfigError

FITTED = SensorConfig(rangefinder=RangefinderConfig(), optical_flow=OpticalFlowConfig())


# -- the sensor models ------------------------------------------------------------------------------------------------
def test_the_rangefinder_reads_only_inside_its_range_and_cone():
    r = RangefinderConfig()
    assert math.isnan(sample_flow_range(FITTED, agl_m=r.min_range_m - 0.1).range_m)
    assert math.isnan(sample_flow_range(FITTED, agl_m=r.max_range_m + 0.5).range_m)
    assert sample_flow_range(FITTED, agl_m=5.0).range_m == pytest.approx(5.0, abs=0.3)
    tilted = math.radians(r.max_tilt_deg + 5.0)
    assert math.isnan(sample_flow_range(FITTED, agl_m=5.0, roll_rad=tilted).range_m)
    slant = sample_flow_range(FITTED, agl_m=5.0, roll_rad=math.radians(30.0)).range_m  # the slant range, not agl
    assert slant == pytest.approx(5.0 / math.cos(math.radians(30.0)), abs=0.3)


def test_the_rangefinder_noise_grows_with_range_past_its_floor():
    near = [sample_flow_range(FITTED, agl_m=2.0, seed=k).range_m - 2.0 for k in range(300)]
    far = [sample_flow_range(FITTED, agl_m=11.0, seed=k).range_m - 11.0 for k in range(300)]
    assert np.std(near) == pytest.approx(0.04, rel=0.25)  # the noise floor (TFmini: +-4 cm)
    assert np.std(far) == pytest.approx(0.11, rel=0.25)  # 1 % of the range
    assert abs(np.mean(far)) < 0.03


def test_the_flow_velocity_noise_grows_with_height_and_its_quality_falls():
    def errors(agl: float) -> tuple[float, float]:
        samples = [sample_flow_range(FITTED, agl_m=agl, v_east_mps=2.0, yaw_rad=0.0, seed=k) for k in range(300)]
        return float(np.std([s.flow_right_mps - 2.0 for s in samples])), samples[0].flow_quality

    (low, q_low), (high, q_high) = errors(1.0), errors(10.0)
    assert q_low == 1.0 and q_high < 0.7
    assert low == pytest.approx(0.15, rel=0.3)  # noise_min_radps at 1 m
    assert high > 10.0 * low  # 10x the height and a lower quality


def test_the_flow_measures_the_body_frame_velocity():
    s = sample_flow_range(FITTED, agl_m=2.0, v_east_mps=1.0, v_north_mps=0.0, yaw_rad=math.radians(90.0))
    assert s.flow_fwd_mps == pytest.approx(1.0, abs=1.0) and abs(s.flow_right_mps) < 1.0  # heading east (0.3 sigma)


def test_the_flow_reads_nothing_without_a_range_or_in_the_dark():
    assert math.isnan(sample_flow_range(FITTED, agl_m=15.0).flow_fwd_mps)  # beyond the rangefinder
    dark = SensorConfig(rangefinder=RangefinderConfig(), optical_flow=OpticalFlowConfig(light_level=0.1))
    assert math.isnan(sample_flow_range(dark, agl_m=2.0).flow_fwd_mps)
    assert math.isnan(sample_flow_range(SensorConfig(), agl_m=2.0).range_m)  # not fitted (the default)


def test_fitting_them_leaves_the_other_sensors_noise_unchanged():
    a, b = flow_suite(SensorConfig(), seed=9), flow_suite(FITTED, seed=9)
    for k in range(200):
        truth = VehicleState(t_s=0.02 * k, lat_deg=FRAME.lat0_deg, lon_deg=FRAME.lon0_deg, alt_m=FRAME.h0_m + 3.0)
        fa, aa, ta = a.sample(truth)
        fb, ab, tb = b.sample(truth)
        assert (fa, aa, ta) == (fb, ab, tb)
        assert math.isfinite(b.range_flow().range_m)


def test_the_sensors_block_takes_them_validated():
    cfg = parse_sensors({"rangefinder": {"max_range_m": 8}, "optical_flow": {}})
    assert cfg.rangefinder == RangefinderConfig(max_range_m=8.0) and cfg.optical_flow == OpticalFlowConfig()
    assert parse_sensors({}).rangefinder is None and parse_sensors({}).optical_flow is None
    for raw, says in (
        ({"optical_flow": {}}, "sensors.optical_flow: needs a rangefinder"),
        ({"rangefinder": {"max_range_m": 0.2}}, "sensors.rangefinder.max_range_m: must be > min_range_m"),
        ({"rangefinder": {"range_m": 3}}, "sensors.rangefinder"),
        ({"rangefinder": {}, "optical_flow": {"light_level": 2}}, "sensors.optical_flow.light_level"),
    ):
        with pytest.raises(ConfigError, match=says):
            parse_sensors(raw)


# -- the fusion -------------------------------------------------------------------------------------------------------
def _descent(cfg: SensorConfig, seconds: float = 40.0, gps_fail_at_s: float = 5.0) -> list[tuple]:
    """A vehicle descending from 11 m at 0.25 m/s to 1 m and drifting east at 1 m/s, its GNSS lost at
    ``gps_fail_at_s`` and its barometer 2 m further off than its drift: per step ``(truth, estimate, sigma_v,
    flow aided, position valid)``."""
    from dataclasses import replace

    cfg = replace(cfg, gps_fail_at_s=gps_fail_at_s)
    suite = flow_suite(cfg, seed=2)
    est = GeofenceEstimator(FRAME, cfg.estimator_config())
    dt, out = 0.025, []
    for k in range(int(seconds / dt)):
        t = k * dt
        agl = max(11.0 - 0.25 * t, 1.0)
        lat, lon, alt = FRAME.to_geodetic(1.0 * t, 0.0, agl)
        truth = VehicleState(t_s=t, lat_deg=lat, lon_deg=lon, alt_m=alt, east_m=t, agl_m=agl, v_east_mps=1.0,
                             v_up_mps=-0.25 if agl > 1.0 else 0.0, yaw_rad=0.4)  # fmt: skip
        fix, air, att = suite.sample(truth)
        air = air._replace(baro_alt_m=air.baro_alt_m + 2.0)
        s = est.step(dt, fix, air, att, suite.range_flow())
        out.append((truth, s, est.sigma_v_m, est.flow_aided, est.position_valid))
    return out


def test_the_height_above_ground_comes_from_the_rangefinder_in_range():
    for truth, s, sigma_v, _, _ in _descent(FITTED)[80:]:  # (2 s: the baro's offset calibrated out)
        assert s.agl_m == pytest.approx(truth.agl_m, abs=0.2) and sigma_v < 0.1
    truth, s, sigma_v, _, _ = _descent(SensorConfig())[-1]
    assert s.agl_m - truth.agl_m > 1.0 and sigma_v > 0.5  # the barometer alone: 2 m off, and it says so


def test_with_gnss_lost_the_velocity_comes_from_the_flow():
    run = _descent(FITTED)
    late = [s for truth, s, _, _, _ in run if truth.agl_m < 3.0]  # (the noise grows with the height)
    assert run[-1][3] and not run[-1][4]  # flow aided, no position
    assert float(np.mean([math.hypot(s.v_east_mps - 1.0, s.v_north_mps) for s in late])) < 0.25
    truth, s = run[-1][:2]
    assert math.hypot(s.east_m - truth.east_m, s.north_m) < 4.0  # 35 s on flow velocity
    bare_truth, bare = _descent(SensorConfig())[-1][:2]  # the last fix's extrapolation
    assert math.hypot(bare.east_m - bare_truth.east_m, bare.north_m) > 10.0


def test_a_fix_after_the_flow_is_fused_again():
    cfg = SensorConfig(rangefinder=RangefinderConfig(), optical_flow=OpticalFlowConfig(), gps_outages=((3.0, 8.0),))
    suite, est = flow_suite(cfg, seed=4), GeofenceEstimator(FRAME, cfg.estimator_config())
    aided = valid_after = False
    for k in range(480):
        t = 0.025 * k
        truth = VehicleState(t_s=t, lat_deg=FRAME.lat0_deg, lon_deg=FRAME.lon0_deg, alt_m=FRAME.h0_m + 4.0, agl_m=4.0)
        fix, air, att = suite.sample(truth)
        est.step(0.025, fix, air, att, suite.range_flow())
        aided |= est.flow_aided
        valid_after = est.position_valid if t > 10.0 else valid_after
    assert aided and valid_after and not est.flow_aided


# -- the touchdown score ----------------------------------------------------------------------------------------------
def test_the_touchdown_is_the_first_gear_contact_of_the_final_landing():
    agl = np.array([5.0, 3.0, 1.0, 0.4, 0.3, 0.2, 0.15, 0.15])
    assert touchdown_index(agl) == 4  # within 0.2 m of the resting 0.15 m
    assert touchdown_index(np.array([5.0, 3.0, 2.0])) == -1  # still flying


# -- closed loop ------------------------------------------------------------------------------------------------------
@pytest.mark.closed_loop
@pytest.mark.parametrize("aircraft", ["F450", "F450RD"])
def test_gnss_lost_hovering_without_a_floor_lands_softly_on_flow_and_range(aircraft):
    fitted = gnss_loss_landing(aircraft, fitted=True, wind_mps=6.0)
    assert fitted["touchdown_vertical_mps"] <= 1.0 and fitted["touchdown_horizontal_mps"] <= 0.5, fitted
    assert fitted["max_excursion_m"] < 0.0
    bare = gnss_loss_landing(aircraft, fitted=False, wind_mps=6.0)  # today's: no height above ground, no velocity
    assert bare["touchdown_horizontal_mps"] > fitted["touchdown_horizontal_mps"] + 0.5, bare


@pytest.mark.closed_loop
def test_gnss_lost_in_an_override_near_an_edge_lands_softly_inside():
    fitted = gnss_loss_landing("F450", fitted=True, wind_mps=6.0, toward_edge=True)
    assert fitted["activations"] >= 1 and fitted["max_excursion_m"] < 0.0, fitted
    assert fitted["touchdown_vertical_mps"] <= 1.0 and fitted["touchdown_horizontal_mps"] <= 0.5, fitted
    bare = gnss_loss_landing("F450", fitted=False, wind_mps=6.0, toward_edge=True)
    assert bare["touchdown_horizontal_mps"] > fitted["touchdown_horizontal_mps"] + 0.5, bare


@pytest.mark.closed_loop
def test_a_barometer_reading_high_no_longer_lands_at_the_full_rate():
    bare = gnss_loss_landing("F450", fitted=False, wind_mps=6.0, baro_high_m=6.0)  # below 5 m it thinks it is at 11
    assert bare["touchdown_vertical_mps"] > 1.5, bare
    fitted = gnss_loss_landing("F450", fitted=True, wind_mps=6.0, baro_high_m=6.0)
    assert fitted["touchdown_vertical_mps"] <= 1.0 and fitted["touchdown_horizontal_mps"] <= 0.5, fitted


def test_without_gnss_a_multirotor_flies_to_its_landing_point_within_the_downward_sensors_range():
    """A multirotor 45 m up in a 40 m wide strip loses GNSS 700 m from the only points with room for its drift: it
    descends on the way to no lower than :data:`DEAD_RECKONING_TRANSIT_AGL_M`, inside a flow's and a rangefinder's
    range, instead of crossing at its height (before: it held 45 m until over the point)."""
    from support import MC, latlon

    from geofence.interface import StickCommand
    from geofence.unit.config import parse_geofence
    from geofence.unit.geofence_unit import DEAD_RECKONING_TRANSIT_AGL_M, GeofenceUnit, Mode

    strip = [list(latlon(e, n)) for e, n in ((-800.0, -20.0), (800.0, -20.0), (800.0, 20.0), (-800.0, 20.0))]
    cfg = parse_geofence({"fence": {"keep_in": strip, "ceiling_m": 120}}, "test")
    unit = GeofenceUnit(cfg, cfg.fence.to_local(FRAME), MC)

    def throttle(agl_m: float, t_s: float, valid: bool = False) -> float:
        est = VehicleState(t_s=t_s, east_m=-700.0, north_m=0.0, agl_m=agl_m, alt_m=FRAME.h0_m + agl_m)
        return unit.update(t_s, est, StickCommand(), 0.025, position_valid=valid).throttle

    for k in range(40):  # (a second with a fix: the dead reckoning has one to start from)
        throttle(45.0, k * 0.025, valid=True)
    assert throttle(45.0, 1.0) < -0.25 and unit.mode is Mode.LAND_IN_GAP  # (down on the way, far from its point)
    assert unit.dead_reckoning.active
    assert throttle(DEAD_RECKONING_TRANSIT_AGL_M, 1.025) == pytest.approx(0.0, abs=0.05)  # (holds there)
    assert throttle(DEAD_RECKONING_TRANSIT_AGL_M - 3.0, 1.05) > 0.0
