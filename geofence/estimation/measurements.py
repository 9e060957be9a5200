"""What the geofence unit's own sensors deliver (SI units, plain floats).

The geofence is an independent add-on unit: it does not read the autopilot's
state, it reads these three messages from its own GNSS receiver, air-data
sensors and AHRS, and estimates the state itself (:mod:`geofence.estimation.estimator`).
In the simulation they are produced from truth by :mod:`aircraft.sensors`; on
real hardware a driver fills them from the receivers' messages.

Times ``t_s`` are on the unit's clock (the simulation time). A GNSS fix is
stamped with its **time of validity** (the epoch the receiver solved for, like
u-blox ``iTOW``), and arrives some latency later; the estimator uses the
difference between the arrival time and ``t_s`` to compensate the latency.

The messages are immutable named tuples: one is built per sensor per step, and a
tuple is built in a third of the time of a frozen dataclass.
"""

from __future__ import annotations

from typing import NamedTuple


class GpsFix(NamedTuple):
    """One GNSS navigation solution.

    ``alt_m`` is the height above the WGS-84 ellipsoid (the simulation takes the
    geoid separation as zero, so it equals the truth altitude). Velocities are
    ground-relative ENU in m/s. ``horizontal_accuracy_m`` and
    ``vertical_accuracy_m`` are the receiver's own 1-sigma-per-axis accuracy
    estimates (like u-blox ``hAcc``/``vAcc``).

    When ``valid`` is False (no 3-D fix: outage, jamming, receiver failure) the
    numeric fields carry no information (NaN, accuracies inf) and must not be used.
    """

    t_s: float
    lat_deg: float
    lon_deg: float
    alt_m: float
    v_east_mps: float
    v_north_mps: float
    v_up_mps: float
    horizontal_accuracy_m: float
    vertical_accuracy_m: float
    valid: bool = True


class AirData(NamedTuple):
    """Air-data sample: pitot true airspeed (None without a pitot, e.g. multirotors) and baro altitude.

    ``baro_alt_m`` is the pressure altitude referenced to the same datum as the
    GNSS height at start-up; it drifts slowly (weather, temperature), so the
    estimator calibrates its offset against GNSS in flight.
    """

    t_s: float
    airspeed_mps: float | None
    baro_alt_m: float


class AttitudeSample(NamedTuple):
    """AHRS attitude in rad: roll (+ right wing down), pitch (+ nose up), yaw (true heading, clockwise from north)."""

    t_s: float
    roll_rad: float
    pitch_rad: float
    yaw_rad: float


class RangeFlowSample(NamedTuple):
    """A downward rangefinder's and optical-flow sensor's sample (NaN: no reading this step).

    ``range_m`` is the slant range along the body's down axis (the estimator levels it with the AHRS attitude);
    ``flow_fwd_mps`` / ``flow_right_mps`` the body-frame ground velocity from the flow scaled by the measured
    range (the estimator rotates it by its heading); ``flow_quality`` 0..1.
    """

    t_s: float
    range_m: float
    flow_fwd_mps: float
    flow_right_mps: float
    flow_quality: float
