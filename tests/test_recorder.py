"""The flight recorder: one row per step, read back as floats exactly as appended, beyond its first capacity too."""

import math

import numpy as np

from geofence.interface import StickCommand, VehicleState
from scenarios.flight.recorder import COLUMN_INDEX, COLUMNS, Recorder


def _state(k: int) -> VehicleState:
    return VehicleState(*(0.1 * k + i for i in range(15)), False)


def test_rows_read_back_as_appended_across_the_buffer_growing():
    rec = Recorder(capacity_rows=2)  # grows twice below
    for k in range(7):
        s = _state(k)
        est = _state(-k) if k % 2 else None
        rec.append(s, (1.0 + k, 2.0, 3.0), StickCommand(0.1, 0.2, 0.3, 0.4), StickCommand(-0.1, k, 0.0, 1.0), k % 3, k, est)
    assert rec.n == 7
    assert rec.data.shape == (7, len(COLUMNS))
    c = rec.column
    assert c("time_s").tolist() == [_state(k).t_s for k in range(7)]
    assert c("ground_speed_mps")[3] == math.hypot(_state(3).v_east_mps, _state(3).v_north_mps)
    assert c("yaw_deg")[5] == _state(5).yaw_rad * (180.0 / math.pi)
    assert c("wind_east_mps").tolist() == [1.0 + k for k in range(7)]
    assert c("cmd_pitch").tolist() == [float(k) for k in range(7)]
    assert c("geofence_mode").tolist() == [float(k % 3) for k in range(7)]
    assert c("est_east_m")[1] == _state(-1).east_m and np.isnan(c("est_east_m")[2])
    assert np.isnan(c("est_wind_east_mps")).all() and np.isnan(c("activation_margin_m")).all()
    assert rec.rows()[4, COLUMN_INDEX["mission_item"]] == 4.0


def test_an_empty_recorder_has_no_rows():
    rec = Recorder()
    assert rec.n == 0 and rec.data.shape == (0, len(COLUMNS))


def test_a_day_long_flight_does_not_reserve_its_whole_buffer_up_front():
    """A 24-hour scenario at 40 Hz asks for 3.5 million rows: the recorder reserves at most PREALLOCATED_ROWS_MAX."""
    from scenarios.flight.recorder import PREALLOCATED_ROWS_MAX

    rec = Recorder(capacity_rows=24 * 3600 * 40 + 1)
    assert rec.capacity_rows == PREALLOCATED_ROWS_MAX
