"""Flight-log reading (tlog, DataFlash .bin) on the real logs in ../shared/realworld, and scoring one of them."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np
import pytest

from analysis.logs import LogError, describe, load_log, read_log
from analysis.scoring import score_flight
from geofence.fence import Fence
from geofence.geodesy import LocalFrame

REALWORLD = Path(__file__).parents[2] / "shared" / "realworld"
COLUMNS = ("time_s", "lat_deg", "lon_deg", "alt_m", "agl_m", "east_m", "north_m", "up_m",
           "v_east_mps", "v_north_mps", "v_up_mps", "ground_speed_mps", "mode")


def real(name: str) -> Path:
    p = REALWORLD / name
    if not p.is_file():
        pytest.skip(f"real-world file {p} is not available")
    return p


_cache: dict = {}


def _load(name: str):
    if name not in _cache:
        _cache[name] = load_log(real(name))
    return _cache[name]


def _common_checks(traj, info):
    n = info.n_positions
    for c in COLUMNS:
        assert c in traj and len(traj[c]) == n, c
    for c in COLUMNS[:-1]:
        assert traj[c].dtype == float and np.isfinite(traj[c]).all(), c
    assert traj["mode"].dtype.kind == "U"
    assert (np.diff(traj["time_s"]) > 0).all()
    assert not ((traj["lat_deg"] == 0) & (traj["lon_deg"] == 0)).any()
    assert np.allclose(traj["ground_speed_mps"], np.hypot(traj["v_east_mps"], traj["v_north_mps"]))
    # east/north/up are about info.frame: the frame origin is the first fix
    fr = info.frame
    assert (fr.lat0_deg, fr.lon0_deg, fr.h0_m) == (traj["lat_deg"][0], traj["lon_deg"][0], traj["alt_m"][0])
    assert abs(traj["east_m"][0]) < 1e-6 and abs(traj["north_m"][0]) < 1e-6 and abs(traj["up_m"][0]) < 1e-6


def test_arduleader_tlog():
    traj, info = _load("arduleader_test.tlog")
    _common_checks(traj, info)
    assert info.log_format == "tlog" and info.vehicle_type == "FIXED_WING" and info.autopilot == "ARDUPILOTMEGA"
    assert not info.simulated
    assert sum(info.message_counts.values()) == 47872
    assert info.message_counts["GLOBAL_POSITION_INT"] == 3011 and info.message_counts["GPS_RAW_INT"] == 1958
    assert info.position_source == "GLOBAL_POSITION_INT"
    # 296 of the 3011 GLOBAL_POSITION_INT messages are before the first fix (lat = lon = 0)
    assert info.n_positions + info.n_skipped == 3011
    assert info.n_positions == 2715
    assert info.duration_s == pytest.approx(1351, abs=1.0)
    assert traj["lat_deg"].min() == pytest.approx(-33.823995, abs=1e-6)
    assert traj["lat_deg"].max() == pytest.approx(-33.820168, abs=1e-6)
    assert traj["lon_deg"].min() == pytest.approx(151.059766, abs=1e-6)
    assert traj["lon_deg"].max() == pytest.approx(151.068773, abs=1e-6)
    assert traj["alt_m"].min() == pytest.approx(-0.2, abs=0.1) and traj["alt_m"].max() == pytest.approx(70.5, abs=0.1)
    assert traj["agl_m"].min() == pytest.approx(0.5, abs=0.1) and traj["agl_m"].max() == pytest.approx(56.0, abs=0.1)
    assert traj["ground_speed_mps"].max() == pytest.approx(28.0, abs=0.5)
    assert np.ptp(traj["east_m"]) == pytest.approx(830, abs=20) and np.ptp(traj["north_m"]) == pytest.approx(430, abs=20)
    assert info.modes == ("MANUAL", "AUTO", "MANUAL")
    assert "2715 positions" in describe(info)


def test_vtol_sitl_tlog():
    traj, info = _load("uavlogviewer_vtol.tlog")
    _common_checks(traj, info)
    assert info.simulated and info.vehicle_type == "FIXED_WING"
    assert sum(info.message_counts.values()) == 23894
    assert info.message_counts["GLOBAL_POSITION_INT"] == 807 and info.message_counts["GPS_RAW_INT"] == 799
    assert info.n_positions == 807 and info.n_skipped == 0
    assert info.duration_s == pytest.approx(207.6, abs=0.1)
    assert (traj["lat_deg"].min(), traj["lat_deg"].max()) == pytest.approx((-35.364806, -35.360757), abs=1e-6)
    assert (traj["lon_deg"].min(), traj["lon_deg"].max()) == pytest.approx((149.163919, 149.165879), abs=1e-6)
    assert (traj["alt_m"].min(), traj["alt_m"].max()) == pytest.approx((586.6, 644.5), abs=0.1)
    assert (traj["agl_m"].min(), traj["agl_m"].max()) == pytest.approx((-2.7, 63.4), abs=0.1)
    flown = [m for m in info.modes if m != "UNKNOWN"]
    assert flown == ["QLOITER", "CIRCLE", "GUIDED", "QLAND"]


def test_dataflash_bin():
    traj, info = _load("flightdata_center_0003.bin")
    _common_checks(traj, info)
    assert info.log_format == "dataflash" and info.vehicle_type == "FIXED_WING"
    assert info.autopilot.startswith("ArduPlane V4.2.3")
    assert sum(info.message_counts.values()) == 17972
    assert info.message_counts["GPS"] == 209 and info.message_counts["POS"] == 916 and info.message_counts["PARM"] == 1083
    assert info.position_source == "GPS" and info.n_positions == 209
    assert "POS.RelHomeAlt" in info.agl_source
    assert info.duration_s == pytest.approx(48.9, abs=0.1)
    assert (traj["lat_deg"].min(), traj["lat_deg"].max()) == pytest.approx((51.641576, 51.641806), abs=1e-6)
    assert (traj["lon_deg"].min(), traj["lon_deg"].max()) == pytest.approx((-2.525922, -2.525650), abs=1e-6)
    assert (traj["alt_m"].min(), traj["alt_m"].max()) == pytest.approx((8.62, 14.85), abs=0.01)  # PROVENANCE: 8.6..14.9
    assert traj["ground_speed_mps"].max() < 2.5  # a hand-carried ground test
    assert np.ptp(traj["east_m"]) < 30 and np.ptp(traj["north_m"]) < 30
    assert np.abs(traj["agl_m"]).max() < 1.0


def test_given_frame_is_used():
    path = real("uavlogviewer_vtol.tlog")
    fr = LocalFrame(-35.3632, 149.1652, 584.0)
    traj = read_log(path, frame=fr)
    e, n, u = fr.to_enu(traj["lat_deg"][10], traj["lon_deg"][10], traj["alt_m"][10])
    assert traj["up_m"][10] == pytest.approx(u, abs=1e-6)
    e0, n0, _ = fr.to_enu(traj["lat_deg"][10], traj["lon_deg"][10], fr.h0_m)
    assert (traj["east_m"][10], traj["north_m"][10]) == pytest.approx((e0, n0), abs=1e-6)


# --------------------------------------------------------------------------- scoring a real log
def _box_fence(info, traj, offset_m: float) -> Fence:
    """A keep-in box around the flight's ENU extent, grown by offset_m (negative: shrunk)."""
    fr = info.frame
    w, e = traj["east_m"].min() - offset_m, traj["east_m"].max() + offset_m
    s, n = traj["north_m"].min() - offset_m, traj["north_m"].max() + offset_m
    corners = [(w, s), (e, s), (e, n), (w, n)]
    return Fence(keep_in=[fr.to_geodetic(x, y, fr.h0_m)[:2] for x, y in corners], ceiling_m=120.0)


def test_score_real_log_against_box_fences():
    traj, info = _load("arduleader_test.tlog")
    inside = _box_fence(info, traj, -50.0)
    sc = score_flight(traj, inside.to_local(info.frame))
    assert sc["max_excursion_m"] == pytest.approx(50.0, abs=0.5)
    assert sc["max_lateral_excursion_m"] == pytest.approx(50.0, abs=0.5)
    assert sc["time_outside_s"] > 0
    outside = _box_fence(info, traj, 100.0)
    sc = score_flight(traj, outside.to_local(info.frame))
    assert sc["max_excursion_m"] <= 0.0 and sc["time_outside_s"] == 0.0
    assert sc["max_lateral_excursion_m"] == pytest.approx(-100.0, abs=0.5)
    # ceiling 120 m, highest relative altitude 56 m: the binding margin is vertical
    assert sc["max_excursion_m"] == pytest.approx(-(120.0 - traj["agl_m"].max()), abs=1e-6)
    assert not sc["breached_keep_out"]


# --------------------------------------------------------------------------- hand-made logs
def _tlog(path: Path, msgs) -> Path:
    from pymavlink.dialects.v10 import ardupilotmega as mav1

    mav = mav1.MAVLink(None, srcSystem=1, srcComponent=1)
    with open(path, "wb") as fh:
        for t_s, make in msgs:
            fh.write(struct.pack(">Q", int(t_s * 1e6)) + make(mav1).pack(mav))
    return path


def test_gps_raw_int_fallback(tmp_path):
    t0 = 1.7e9
    hb = lambda m: m.MAVLink_heartbeat_message(2, 3, 1, 3, 4, 3)  # QUADROTOR, ARDUPILOTMEGA, custom mode 3
    msgs = [(t0, hb), (t0 + 0.1, lambda m: m.MAVLink_gps_raw_int_message(0, 1, 0, 0, 0, 65535, 65535, 65535, 65535, 0))]
    for k in range(20):  # 3D fix, moving north-east at 5 m/s, climbing 1 m/s
        lat = int(round((47.0 + 5.0 * k / 111_200 / math.sqrt(2)) * 1e7))
        msgs.append((t0 + 1 + k, lambda m, lat=lat, k=k: m.MAVLink_gps_raw_int_message(
            int(k * 1e6), 3, lat, 85000000, 500_000 + 1000 * k, 100, 100, 500, 4500, 9)))
    p = _tlog(tmp_path / "synthetic.tlog", msgs)
    traj, info = load_log(p)
    assert info.position_source == "GPS_RAW_INT" and info.vehicle_type == "QUADROTOR"
    assert info.n_positions == 20 and info.n_skipped == 1
    assert "first sample" in info.agl_source
    assert traj["agl_m"][0] == 0.0 and traj["agl_m"][-1] == pytest.approx(19.0)
    assert np.allclose(traj["v_east_mps"], 5 / math.sqrt(2)) and np.allclose(traj["v_north_mps"], 5 / math.sqrt(2))
    assert np.allclose(traj["v_up_mps"], 1.0)
    assert traj["time_s"][0] == pytest.approx(1.0)
    assert set(traj["mode"]) == {"AUTO"} and info.modes == ("AUTO",)


def test_log_errors(tmp_path):
    with pytest.raises(LogError, match="not found"):
        load_log(tmp_path / "missing.tlog")
    junk = tmp_path / "junk.tlog"
    junk.write_text("this is not a log\n" * 20)
    with pytest.raises(LogError) as ei:
        load_log(junk)
    assert str(junk) in str(ei.value) and "\n" not in str(ei.value)
    hb = lambda m: m.MAVLink_heartbeat_message(1, 3, 0, 0, 4, 3)
    p = _tlog(tmp_path / "nopos.tlog", [(1.7e9, hb), (1.7e9 + 1, hb)])
    with pytest.raises(LogError, match="no GLOBAL_POSITION_INT or GPS_RAW_INT"):
        load_log(p)
    p = _tlog(tmp_path / "nofix.tlog", [(1.7e9, lambda m: m.MAVLink_gps_raw_int_message(0, 1, 0, 0, 0, 1, 1, 0, 0, 0))])
    with pytest.raises(LogError, match="no valid position fix"):
        load_log(p)
