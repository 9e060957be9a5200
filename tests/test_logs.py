"""Flight-log reading (tlog, DataFlash .bin) on the real logs in ../shared/realworld, and scoring one of them."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np
import pytest

from analysis.formats.logs import LogError, describe, load_log, read_log
from analysis.scoring import score_flight
from geofence.geometry.fence import Fence
from geofence.geometry.geodesy import LocalFrame
from geofence.validation import ConfigError

REALWORLD = Path(__file__).parents[2] / "shared" / "realworld"
COLUMNS = (
    "time_s",
    "lat_deg",
    "lon_deg",
    "alt_m",
    "agl_m",
    "east_m",
    "north_m",
    "up_m",
    "v_east_mps",
    "v_north_mps",
    "v_up_mps",
    "ground_speed_mps",
    "mode",
)


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

    def hb(m):  # QUADROTOR, ARDUPILOTMEGA, custom mode 3
        return m.MAVLink_heartbeat_message(2, 3, 1, 3, 4, 3)

    msgs = [(t0, hb), (t0 + 0.1, lambda m: m.MAVLink_gps_raw_int_message(0, 1, 0, 0, 0, 65535, 65535, 65535, 65535, 0))]
    for k in range(20):  # 3D fix, moving north-east at 5 m/s, climbing 1 m/s
        lat = int(round((47.0 + 5.0 * k / 111_200 / math.sqrt(2)) * 1e7))
        msgs.append(
            (
                t0 + 1 + k,
                lambda m, lat=lat, k=k: m.MAVLink_gps_raw_int_message(
                    int(k * 1e6), 3, lat, 85000000, 500_000 + 1000 * k, 100, 100, 500, 4500, 9
                ),
            )
        )
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

    def hb(m):
        return m.MAVLink_heartbeat_message(1, 3, 0, 0, 4, 3)

    p = _tlog(tmp_path / "nopos.tlog", [(1.7e9, hb), (1.7e9 + 1, hb)])
    with pytest.raises(LogError, match="no GLOBAL_POSITION_INT or GPS_RAW_INT"):
        load_log(p)
    p = _tlog(tmp_path / "nofix.tlog", [(1.7e9, lambda m: m.MAVLink_gps_raw_int_message(0, 1, 0, 0, 0, 1, 1, 0, 0, 0))])
    with pytest.raises(LogError, match="no valid position fix"):
        load_log(p)


# --------------------------------------------------------------------------- sanity checks (issue 11: honest scoring)
import json  # noqa: E402
import random  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402

from analysis.formats.logs import (  # noqa: E402
    LogFenceDistanceError,
    LogIntegrityError,
    SanityLimits,
    check_near_fence,
    log_fence_distance_m,
)

REPO = Path(__file__).parents[1]
VTOL, FOAMY = "uavlogviewer_vtol.tlog", "mavproxy_cmac-foamy-fence.txt"


def score_cli(log, fence, *extra):
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "scenarios.app.cli",
            "score-log",
            str(log),
            "--fence",
            str(fence),
            "--ceiling",
            "100",
            "--json",
            *extra,
        ],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=300,
    )
    return res


def _message_offsets(path: Path, kind: str) -> list[int]:
    """File offsets of the messages of one type in a tlog (the start of their 8-byte timestamp)."""
    from pymavlink import mavutil

    m = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    offsets = []
    while True:
        off = m.f.tell()
        msg = m.recv_match()
        if msg is None:
            return offsets
        if msg.get_type() == kind:
            offsets.append(off)


def _assert_honest(res):
    """Refused with exit 2 and one line, or scored with a warning and the true ~49 m excursion."""
    assert "Traceback" not in res.stderr
    if res.returncode == 2:
        assert res.stdout == "" and len(res.stderr.strip().splitlines()) == 1 and res.stderr.startswith("error: ")
        return None
    assert res.returncode == 0, res.stderr
    scores = json.loads(res.stdout)
    assert res.stderr.startswith("warning: ") and scores["warnings"]
    lines = res.stderr.strip().splitlines()
    assert len(lines) == len(set(lines))  # each warning once
    assert 40.0 < scores["max_lateral_excursion_m"] < 60.0 and scores["time_outside_s"] > 10.0
    return scores


def test_clean_vtol_log_scores_49_m_out_with_no_warning():
    res = score_cli(real(VTOL), real(FOAMY))
    assert res.returncode == 0 and res.stderr == "", res.stderr
    scores = json.loads(res.stdout)  # --json: pure JSON on stdout
    assert scores["max_lateral_excursion_m"] == pytest.approx(49.35, abs=0.1) and scores["time_outside_s"] > 10.0
    assert scores["warnings"] == []


def test_corrupted_timestamp_no_longer_hides_the_excursion(tmp_path):
    """One flipped bit in the (CRC-less) timestamp of an early position message used to push the log's time to
    ~1e9 s ahead, every later position was dropped as 'not increasing', and the flight scored 0 s outside."""
    src = real(VTOL)
    data = bytearray(src.read_bytes())
    gpi = _message_offsets(src, "GLOBAL_POSITION_INT")
    for k, bit in ((100, 0x08), (300, 0x40), (500, 0x01)):
        data[gpi[k] + 1] ^= bit  # second byte of the big-endian microseconds: +~1e9..1e10 s
    bad = tmp_path / "ts.tlog"
    bad.write_bytes(data)
    # the log's time now holds absurd future timestamps (years past 2090) ...
    assert max(struct.unpack(">Q", bytes(data[o : o + 8]))[0] * 1e-6 for o in gpi) > 4e9
    traj, info = load_log(bad)  # ... that is dropped as a time fault, and said so
    assert info.n_position_time_faults == 3 and info.n_positions == 804
    assert info.duration_s == pytest.approx(207.6, abs=0.1)
    assert any("dropped 3 of 807" in w and "time fault" in w for w in info.warnings)
    scores = _assert_honest(score_cli(bad, real(FOAMY)))
    assert scores is not None


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_randomly_flipped_bytes_are_refused_or_scored_honestly(tmp_path, seed):
    src = real(VTOL)
    data = bytearray(src.read_bytes())
    rng = random.Random(seed)
    gpi = _message_offsets(src, "GLOBAL_POSITION_INT")
    for _ in range(12):  # anywhere: payloads fail their CRC ...
        data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
    for _ in range(4):  # ... and timestamps of position messages, which have none
        o = gpi[rng.randrange(len(gpi))]
        data[o + rng.randrange(4)] ^= 1 << rng.randrange(8)
    bad = tmp_path / f"flipped{seed}.tlog"
    bad.write_bytes(data)
    _assert_honest(score_cli(bad, real(FOAMY)))


def test_heavily_corrupted_tlog_is_refused_exit_2(tmp_path):
    data = bytearray(real(VTOL).read_bytes())
    rng = random.Random(7)
    for _ in range(len(data) // 200):
        data[rng.randrange(len(data))] ^= 0xFF
    bad = tmp_path / "mangled.tlog"
    bad.write_bytes(data)
    with pytest.raises(LogIntegrityError, match="refused"):
        load_log(bad)
    res = score_cli(bad, real(FOAMY))
    assert res.returncode == 2 and res.stdout == "" and len(res.stderr.strip().splitlines()) == 1
    assert "refused" in res.stderr and "CRC" in res.stderr


def test_crc_failures_are_counted(tmp_path):
    data = bytearray(real(VTOL).read_bytes())
    rng = random.Random(5)
    for _ in range(8):
        data[rng.randrange(len(data))] ^= 0xFF
    bad = tmp_path / "crc.tlog"
    bad.write_bytes(data)
    _, info = load_log(bad)
    assert info.n_bad_crc >= 5 and info.bad_bytes > 0
    assert any("failed their MAVLink CRC" in w for w in info.warnings)


def test_truncated_log_warns(tmp_path):
    data = real(VTOL).read_bytes()
    cut = tmp_path / "cut.tlog"
    cut.write_bytes(data[: len(data) // 2 + 17])  # mid-message
    traj, info = load_log(cut)
    assert info.truncated_bytes > 0 and any("truncated" in w for w in info.warnings)
    res = score_cli(cut, real(FOAMY))
    assert res.returncode == 0 and "truncated" in res.stderr
    json.loads(res.stdout)
    # a clean original has no such warning
    assert _load(VTOL)[1].truncated_bytes == 0 and _load(VTOL)[1].warnings == ()


def _walk(t0, n=30, jumps=(), dt=1.0, times=None):
    """A GPS_RAW_INT walk north at 5 m/s; ``jumps`` are sample indices moved 5 km east (glitches)."""
    msgs = [(t0, lambda m: m.MAVLink_heartbeat_message(2, 3, 1, 3, 4, 3))]
    for k in range(n):
        lat = int(round((47.0 + 5.0 * k * dt / 111_195) * 1e7))
        lon = 85000000 + (int(5000 / 75_800 * 1e7) if k in jumps else 0)
        t = times[k] if times is not None else t0 + 1 + k * dt
        msgs.append(
            (
                t,
                lambda m, lat=lat, lon=lon, k=k: m.MAVLink_gps_raw_int_message(
                    int(k * dt * 1e6), 3, lat, lon, 500_000, 100, 100, 500, 0, 9
                ),
            )
        )
    return msgs


def test_future_timestamps_are_rejected(tmp_path):
    t0 = 1.7e9
    # every message 6e10 s after 1970 (year ~3900): refused
    p = _tlog(tmp_path / "future.tlog", _walk(6e10))
    with pytest.raises(LogIntegrityError, match="plausible time"):
        load_log(p)
    res = score_cli(p, real(FOAMY))
    assert res.returncode == 2 and res.stdout == "" and len(res.stderr.strip().splitlines()) == 1
    # two samples stamped in the future among 60: dropped, with a warning, and the rest of the flight kept
    times = [t0 + 1 + k for k in range(60)]
    times[5], times[6] = 6e10, 6e10 + 1
    traj, info = load_log(_tlog(tmp_path / "spike.tlog", _walk(t0, n=60, times=times)))
    assert info.n_positions == 58 and info.n_position_time_faults == 2
    assert traj["time_s"][-1] == pytest.approx(60.0) and info.duration_s == pytest.approx(60.0)
    assert any("2 time faults" in w for w in info.warnings)
    # a backward jump of a few samples: those are dropped, not the rest of the log
    times = [t0 + 1 + k for k in range(60)]
    times[10:12] = [t0 - 500, t0 - 499]
    traj, info = load_log(_tlog(tmp_path / "back.tlog", _walk(t0, n=60, times=times)))
    assert info.n_positions == 58 and info.n_position_time_faults == 2
    # too many bad times: refused
    times = [t0 + 1 + k if k % 4 else 6e10 + k for k in range(60)]
    with pytest.raises(LogIntegrityError, match="refused"):
        load_log(_tlog(tmp_path / "many.tlog", _walk(t0, n=60, times=times)))
    # time since boot is a plausible axis too; 3e8 s (9.5 years since boot) is not
    _, info = load_log(_tlog(tmp_path / "boot.tlog", _walk(100.0)))
    assert info.n_positions == 30 and info.warnings == ()
    with pytest.raises(LogIntegrityError):
        load_log(_tlog(tmp_path / "weird.tlog", _walk(3e8)))


def test_position_glitches_are_dropped_or_refused(tmp_path):
    t0 = 1.7e9
    traj, info = load_log(_tlog(tmp_path / "glitch.tlog", _walk(t0, jumps=(0, 12))))  # one at the very start
    assert info.n_glitches == 2 and info.n_positions == 28
    assert np.ptp(traj["east_m"]) < 1.0  # the 5 km jumps are gone
    w = [x for x in info.warnings if "glitch" in x]
    assert len(w) == 1 and "dropped 2 of 30" in w[0] and "150 m/s" in w[0] and " s of the " in w[0]
    with pytest.raises(LogIntegrityError, match="glitches"):
        load_log(_tlog(tmp_path / "many.tlog", _walk(t0, jumps=tuple(range(0, 30, 3)))))
    # a faster bound is a parameter
    _, info = load_log(_tlog(tmp_path / "glitch2.tlog", _walk(t0, jumps=(12,))), limits=SanityLimits(max_speed_mps=1e5))
    assert info.n_glitches == 0


def test_real_logs_pass_the_checks_untouched():
    for name in ("arduleader_test.tlog", VTOL, "flightdata_center_0003.bin"):
        _, info = _load(name)
        assert info.warnings == () and info.n_glitches == 0 and info.n_position_time_faults == 0, name
        assert info.n_bad_crc == 0 and info.truncated_bytes == 0, name


@pytest.mark.parametrize("header", [b"", b"\xa3\x95\x80"])
def test_random_bin_is_one_line_exit_2_without_parser_noise(tmp_path, header):
    junk = tmp_path / "random.bin"
    junk.write_bytes(header + random.Random(3).randbytes(200_000))
    res = score_cli(junk, real(FOAMY))
    assert res.returncode == 2 and res.stdout == ""
    assert len(res.stderr.strip().splitlines()) == 1 and res.stderr.startswith("error: ") and str(junk) in res.stderr


def test_random_bytes_tlog_is_one_line_exit_2(tmp_path):
    junk = tmp_path / "random.tlog"
    junk.write_bytes(random.Random(4).randbytes(200_000))
    res = score_cli(junk, real(FOAMY))
    assert res.returncode == 2 and res.stdout == "" and len(res.stderr.strip().splitlines()) == 1


def test_fence_far_from_the_log_is_flagged(tmp_path):
    traj, info = _load(VTOL)
    near = _box_fence(info, traj, 100.0)
    assert log_fence_distance_m(traj, near) == 0.0 and check_near_fence(traj, near) == 0.0
    # the same box moved 45 degrees of latitude north (5,000 km)
    far = Fence(keep_in=[(lat + 45.0, lon) for lat, lon in near.keep_in], ceiling_m=120.0)
    d = log_fence_distance_m(traj, far)
    assert d == pytest.approx(5004e3, rel=0.01)
    with pytest.raises(LogFenceDistanceError, match=r"5,00\d km apart.*wrong fence"):
        check_near_fence(traj, far, name="vtol")
    with pytest.raises(ConfigError, match="max_distance_m"):  # no bound lets it through: the flat frame fails
        check_near_fence(traj, far, max_distance_m=6e6)
    # the CLI: a Canberra log against a Boulder fence is refused with one line, whatever bound is asked for
    for extra in ((), ("--max-fence-distance-km", "20000")):
        res = score_cli(real(VTOL), real("pymavlink_fence-110.txt"), *extra)
        assert res.returncode == 2 and res.stdout == "" and len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert "km apart" in score_cli(real(VTOL), real("pymavlink_fence-110.txt")).stderr


def test_text_output_prints_each_warning_once(tmp_path):
    data = real(VTOL).read_bytes()
    cut = tmp_path / "cut.tlog"
    cut.write_bytes(data[: len(data) - 5])
    traj, info = _load(VTOL)
    box = _box_fence(info, traj, 100.0)  # a fence around the log's own site (a far one is refused)
    plan = tmp_path / "box.plan"
    polygon = [[lat, lon] for lat, lon in box.keep_in]
    plan.write_text(
        json.dumps(
            {
                "fileType": "Plan",
                "version": 1,
                "geoFence": {"version": 2, "circles": [], "polygons": [{"inclusion": True, "polygon": polygon, "version": 1}]},
            }
        )
    )
    res = subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "score-log", str(cut), "--fence", str(plan), "--ceiling", "120"],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr
    assert "warning:" not in res.stdout  # warnings go to stderr only ...
    lines = res.stderr.strip().splitlines()
    assert lines and all(x.startswith("warning: ") for x in lines) and len(lines) == len(set(lines))  # ... once each
    json.loads(res.stdout[res.stdout.index("{") :])


def test_corrupted_dataflash_bin_counts_skipped_chunks_quietly(tmp_path, capfd):
    data = bytearray(real("flightdata_center_0003.bin").read_bytes())
    rng = random.Random(1)
    for _ in range(20):
        data[rng.randrange(3000, len(data))] ^= 0xFF
    bad = tmp_path / "flipped.bin"
    bad.write_bytes(data)
    traj, info = load_log(bad)
    assert info.n_bad_crc >= 1 and any("corrupt chunk" in w for w in info.warnings)
    assert info.n_positions == 209
    out, err = capfd.readouterr()  # pymavlink's prints (Python and its compiled indexer) are captured
    assert out == "" and err == ""


def test_ulog_is_read(tmp_path):
    traj, info = load_log(real("pyulog_sample_px4_events.ulg"))  # (scored in tests/test_tlog.py)
    assert info.log_format == "ulog" and len(traj["time_s"]) == info.n_positions == 109
