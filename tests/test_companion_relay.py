"""The companion between a ground station and the vehicle (``companion --connect V --gcs G``) on loopback UDP.

A fake vehicle (pymavlink, system 1/1, a thread: HEARTBEAT, GLOBAL_POSITION_INT and ATTITUDE at 20 Hz; answers
COMMAND_LONG with COMMAND_ACK and takes waypoint uploads) and a fake ground station (pymavlink, 250/190) talk through
the companion process. The ground station sees the vehicle's telemetry and the companion's HEARTBEAT and STATUSTEXT,
with no lost sequence numbers; its COMMAND_LONG reaches the vehicle and the ACK comes back; a fence it addresses to
the vehicle is answered by the companion as the vehicle (ACCEPTED, downloadable) and never reaches the vehicle; a bad
one and hostile bytes leave the accepted fence in place; a waypoint mission reaches the vehicle untouched. MAVProxy
as the ground station does the same (skipped without it). The renumbering of spliced frames is checked alone, and
a bad --gcs is one line, exit 2.
"""

from __future__ import annotations

import importlib.util
import json
import os
import random
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support import SQUARE_FENCE_WPL, free_udp_port

from geofence.estimation.measurements import AttitudeSample
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import PlatformKind, VehicleState
from scenarios.link import telemetry
from scenarios.link.connection import mavlink, now_s, open_link, receive
from scenarios.link.mission_fence import FENCE, MissionItem, download, upload
from scenarios.link.router import SeqSplice, fence_transfer_for, with_seq
from scenarios.link.sticks import Autopilot

ROOT = Path(__file__).resolve().parents[1]
LAT0, LON0, GROUND_M = 47.397, 8.545, 500.0
START_WPL = SQUARE_FENCE_WPL
VEHICLE, GCS, COMPANION = (1, 1), (250, 190), (255, 191)


def item(seq: int, cmd: int, p1: float, lat: float, lon: float, frame: int = 0, z: float = 0.0) -> MissionItem:
    return MissionItem(seq, frame, cmd, float(p1), 0.0, 0.0, 0.0, round(lat * 1e7), round(lon * 1e7), z)


SMALLER = [(47.3962, 8.5433), (47.3962, 8.5467), (47.3978, 8.5467), (47.3978, 8.5433)]
GOOD = [item(k, 5001, 4, lat, lon) for k, (lat, lon) in enumerate(SMALLER)] + [item(4, 5000, 0, LAT0, LON0, z=30.0)]
BOWTIE = [item(k, 5001, 4, lat, lon) for k, (lat, lon) in enumerate([SMALLER[0], SMALLER[2], SMALLER[1], SMALLER[3]])]
WAYPOINTS = [item(k, mavlink.MAV_CMD_NAV_WAYPOINT, 0, LAT0 + 1e-4 * k, LON0, frame=6, z=20.0) for k in range(3)]


# --------------------------------------------------------------------------- the frames' renumbering, alone
def _frame(seq: int, src: tuple[int, int], text: str) -> bytes:
    mav = mavlink.MAVLink(None, srcSystem=src[0], srcComponent=src[1])
    mav.seq = seq & 0xFF
    return mavlink.MAVLink_statustext_message(4, text.encode(), 0, 0).pack(mav)


def _parse(buf: bytes):
    return mavlink.MAVLink(None).parse_char(bytearray(buf))


@settings(max_examples=60, deadline=None)
@given(seq=st.integers(0, 255), new=st.integers(0, 255), text=st.text("abcxyz ", max_size=40))
def test_a_renumbered_frame_parses_with_its_new_number_and_the_same_fields(seq, new, text):
    out = with_seq(_frame(seq, VEHICLE, text), new)
    assert out is not None
    msg = _parse(out)  # (a bad CRC would be BAD_DATA or raise)
    assert msg.get_type() == "STATUSTEXT" and msg.get_seq() == new and msg.text == text
    assert (msg.get_srcSystem(), msg.get_srcComponent()) == VEHICLE


def test_splicing_own_frames_into_a_stream_keeps_it_gapless_and_keeps_its_gaps():
    splice = SeqSplice()
    seqs, n = [], 250  # the vehicle's numbers wrap past 255
    for k, own in enumerate([0, 0, 1, 0, 1, 1, 0, 0]):  # ours between the vehicle's frames
        if own:
            seqs.append(_parse(splice.own(_frame(99, VEHICLE, "ours"))).get_seq())
        else:
            n += 3 if k == 6 else 1  # two of the vehicle's frames lost on its link before the 7th
            seqs.append(_parse(splice.forwarded(_frame(n, VEHICLE, "v"))).get_seq())
    gaps = [(b - a - 1) & 0xFF for a, b in zip(seqs, seqs[1:], strict=False)]
    assert gaps == [0, 0, 0, 0, 0, 2, 0], seqs
    other = _frame(7, GCS, "other source")
    assert splice.forwarded(other) == other  # another source's frames pass byte for byte


def test_only_fence_and_rally_transfers_to_the_given_ids_are_taken():
    fence_count = mavlink.MAVLink_mission_count_message(1, 1, 3, FENCE)
    wp_count = mavlink.MAVLink_mission_count_message(1, 1, 3, mavlink.MAV_MISSION_TYPE_MISSION)
    rally_list = mavlink.MAVLink_mission_request_list_message(1, 0, mavlink.MAV_MISSION_TYPE_RALLY)
    to_other = mavlink.MAVLink_mission_count_message(2, 1, 3, FENCE)
    command = mavlink.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
    assert fence_transfer_for(fence_count, VEHICLE) and fence_transfer_for(rally_list, VEHICLE)
    assert not fence_transfer_for(wp_count, VEHICLE) and not fence_transfer_for(to_other, VEHICLE)
    assert not fence_transfer_for(command, VEHICLE) and fence_transfer_for(to_other, None)


# --------------------------------------------------------------------------- the processes
class FakeVehicle:
    """System 1/1 in a thread: telemetry at 20 Hz; COMMAND_LONG answered; waypoint uploads taken; all it got kept."""

    def __init__(self, port: int) -> None:
        self.conn = open_link(f"udpout:127.0.0.1:{port}", *VEHICLE)
        self.frame = LocalFrame(LAT0, LON0, GROUND_M)
        self.got: list = []
        self.waypoints: list[MissionItem] = []
        self._upload: tuple[tuple[int, int], int] | None = None
        self._stop = threading.Event()
        self.errors: list[BaseException] = []
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            k = 0
            while not self._stop.is_set():
                self._tick(k)
                t_next = now_s() + 0.05
                while (left := t_next - now_s()) > 0:
                    msg = receive(self.conn, left)
                    if msg is not None:
                        self._take(msg)
                k += 1
        except BaseException as exc:
            self.errors.append(exc)

    def _tick(self, k: int) -> None:
        t = k * 0.05
        lat, lon, alt = self.frame.to_geodetic(0.0, 0.0, 20.0)
        state = VehicleState(t_s=t, lat_deg=lat, lon_deg=lon, alt_m=alt, up_m=20.0, agl_m=20.0)
        if k % 10 == 0:
            self.conn.mav.send(telemetry.heartbeat(PlatformKind.MULTIROTOR, Autopilot.ARDUPILOT))
        self.conn.mav.send(telemetry.global_position_int(state, GROUND_M))
        self.conn.mav.send(telemetry.attitude(AttitudeSample(t, 0.0, 0.0, 0.0)))

    def _take(self, msg) -> None:
        self.got.append(msg)
        kind, src = msg.get_type(), (msg.get_srcSystem(), msg.get_srcComponent())
        mav = self.conn.mav
        if kind == "COMMAND_LONG" and msg.target_system == VEHICLE[0]:
            mav.command_ack_send(msg.command, mavlink.MAV_RESULT_ACCEPTED, 0, 0, src[0], src[1])
        elif kind == "MISSION_COUNT" and msg.mission_type == mavlink.MAV_MISSION_TYPE_MISSION:
            self._upload, self.waypoints = (src, msg.count), []
            mav.mission_request_int_send(src[0], src[1], 0, msg.mission_type)
        elif kind == "MISSION_ITEM_INT" and self._upload is not None and msg.seq == len(self.waypoints):
            self.waypoints.append(MissionItem(msg.seq, msg.frame, msg.command, msg.param1, msg.param2, msg.param3, msg.param4, msg.x, msg.y, msg.z))  # fmt: skip
            peer, n = self._upload
            if len(self.waypoints) < n:
                mav.mission_request_int_send(peer[0], peer[1], len(self.waypoints), msg.mission_type)
            else:
                mav.mission_ack_send(peer[0], peer[1], mavlink.MAV_MISSION_ACCEPTED, msg.mission_type)
                self._upload = None

    def fence_messages(self) -> list:
        """What reached the vehicle of any fence or rally transfer."""
        return [m for m in list(self.got) if fence_transfer_for(m, None)]

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        for _ in range(3):
            self.conn.mav.send(telemetry.heartbeat(PlatformKind.MULTIROTOR, Autopilot.ARDUPILOT, powering_off=True))
        self.conn.close()


def start_companion(tmp_path: Path, vehicle_port: int, gcs_url: str) -> subprocess.Popen:
    (tmp_path / "start.txt").write_text(START_WPL)
    cmd = [
        sys.executable, "-m", "scenarios.app.cli", "companion", "--connect", f"udpin:127.0.0.1:{vehicle_port}",
        "--gcs", gcs_url, "--fence", str(tmp_path / "start.txt"), "--profile", "F450", "--ceiling-m", "60",
        "--max-duration-s", "120", "--report", str(tmp_path / "report.json"),
    ]  # fmt: skip
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    ready = proc.stdout.readline()
    assert ready.startswith("companion: listening") and "relaying" in ready, (ready, proc.poll())
    return proc


class Setup:
    def __init__(self, proc, vehicle, gcs, tmp_path) -> None:
        self.proc, self.vehicle, self.gcs, self.tmp_path = proc, vehicle, gcs, tmp_path
        self.report: dict = {}


@pytest.fixture(scope="module")
def relay(tmp_path_factory) -> Iterator[Setup]:
    tmp_path = tmp_path_factory.mktemp("relay")
    v_port, g_port = free_udp_port(), free_udp_port()
    gcs = open_link(f"udpin:127.0.0.1:{g_port}", *GCS)  # bound first: the companion sends to it (udpout)
    proc = start_companion(tmp_path, v_port, f"udpout:127.0.0.1:{g_port}")
    vehicle = FakeVehicle(v_port)
    setup = Setup(proc, vehicle, gcs, tmp_path)
    try:
        seen_vehicle(gcs, 10.0)
        yield setup
    finally:
        vehicle.stop()
        try:
            proc.communicate(timeout=20)
        finally:
            proc.kill()
        gcs.close()
    assert proc.returncode == 0
    assert not vehicle.errors
    report = json.loads((tmp_path / "report.json").read_text())
    # (only what holds whichever of this module's tests ran here: xdist may share them out among workers, each
    # with its own companion; what a test did is checked in that test)
    assert report["handler_errors"] == 0 and report["fence_server"]["accepted"] <= 1


def seen_vehicle(gcs, timeout_s: float) -> list:
    """The ground station's messages until the vehicle's HEARTBEAT came through (raises after ``timeout_s``)."""
    got, t0 = [], now_s()
    while now_s() - t0 < timeout_s:
        msg = receive(gcs, 0.05)
        if msg is not None:
            got.append(msg)
            if msg.get_type() == "HEARTBEAT" and (msg.get_srcSystem(), msg.get_srcComponent()) == VEHICLE:
                return got
    raise AssertionError(f"no vehicle HEARTBEAT at the ground station within {timeout_s} s: {got[-5:]}")


def collect(gcs, seconds: float) -> list:
    got, t0 = [], now_s()
    while now_s() - t0 < seconds:
        msg = receive(gcs, 0.05)
        if msg is not None:
            got.append(msg)
    return got


def by_source(msgs) -> dict[tuple[int, int], set[str]]:
    out: dict[tuple[int, int], set[str]] = {}
    for m in msgs:
        out.setdefault((m.get_srcSystem(), m.get_srcComponent()), set()).add(m.get_type())
    return out


@pytest.mark.slow
def test_the_ground_station_sees_the_vehicle_and_the_companion_and_commands_the_vehicle(relay):
    gcs = relay.gcs
    gcs.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    seen = by_source(collect(gcs, 1.5))
    assert {"HEARTBEAT", "ATTITUDE", "GLOBAL_POSITION_INT"} <= seen[VEHICLE]
    assert "HEARTBEAT" in seen[COMPANION]
    gcs.mav.command_long_send(*VEHICLE, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    acks = [m for m in collect(gcs, 1.0) if m.get_type() == "COMMAND_ACK"]
    assert [(m.get_srcSystem(), m.command, m.result) for m in acks] == [(1, 400, mavlink.MAV_RESULT_ACCEPTED)]
    got = [m for m in list(relay.vehicle.got) if m.get_type() in ("COMMAND_LONG", "HEARTBEAT")]
    assert {(m.get_type(), m.get_srcSystem()) for m in got} >= {("COMMAND_LONG", 250), ("HEARTBEAT", 250)}


@pytest.mark.slow
def test_a_fence_for_the_vehicle_is_answered_by_the_companion_and_never_reaches_the_vehicle(relay):
    gcs = relay.gcs
    assert upload(gcs, GOOD, VEHICLE, FENCE) == mavlink.MAV_MISSION_ACCEPTED
    texts = [(m.get_srcSystem(), m.text) for m in collect(gcs, 0.5) if m.get_type() == "STATUSTEXT"]
    assert (COMPANION[0], "fence accepted: 5 items") in texts  # the operator is told, by the companion
    assert download(gcs, VEHICLE, FENCE) == GOOD
    assert relay.vehicle.fence_messages() == []
    assert gcs.mav_loss == 0  # (pymavlink's count of sequence gaps per sender: the companion's frames spliced in)


@pytest.mark.slow
def test_a_bad_fence_or_garbage_from_the_ground_station_changes_nothing(relay):
    gcs = relay.gcs
    before = download(gcs, VEHICLE, FENCE)
    rng = random.Random(37)
    for _ in range(20):
        gcs.write(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 80))))
    gcs.mav.mission_item_int_send(*VEHICLE, 3, 0, 5001, 0, 1, 4, 0, 0, 0, 0, 0, 0, FENCE)  # no upload under way
    assert upload(gcs, BOWTIE, VEHICLE, FENCE) == mavlink.MAV_MISSION_INVALID
    assert upload(gcs, GOOD[:2], VEHICLE, FENCE) != mavlink.MAV_MISSION_ACCEPTED  # a polygon of 4 with 2 vertices
    assert download(gcs, VEHICLE, FENCE) == before
    assert relay.vehicle.fence_messages() == []
    assert relay.proc.poll() is None


@pytest.mark.slow
def test_a_waypoint_mission_goes_to_the_vehicle_untouched(relay):
    gcs = relay.gcs
    assert upload(gcs, WAYPOINTS, VEHICLE, mavlink.MAV_MISSION_TYPE_MISSION) == mavlink.MAV_MISSION_ACCEPTED
    assert relay.vehicle.waypoints == WAYPOINTS
    assert gcs.mav_loss == 0


@pytest.mark.slow
def test_a_ground_station_of_the_companions_system_id_uploads_waypoints_too(relay):
    """MAVProxy and QGC send as 255 (component 0 or 190), the companion's own system: the vehicle's requests to
    255/0 are the ground station's, not the companion's."""
    gcs, ours = relay.gcs, relay.gcs.mav
    gcs.mav = mavlink.MAVLink(gcs, srcSystem=COMPANION[0], srcComponent=0)
    gcs.mav.robust_parsing = True
    try:
        wps = [w._replace(z=35.0) for w in WAYPOINTS]
        assert upload(gcs, wps, VEHICLE, mavlink.MAV_MISSION_TYPE_MISSION) == mavlink.MAV_MISSION_ACCEPTED
        assert relay.vehicle.waypoints == wps
    finally:
        gcs.mav = ours


# --------------------------------------------------------------------------- MAVProxy as the ground station
MAVPROXY = shutil.which("mavproxy.py")
ROW = "{seq}\t0\t0\t{cmd}\t{p1:.6f}\t0.000000\t0.000000\t0.000000\t{lat:.6f}\t{lon:.6f}\t0.000000\t1"


def _lines(proc: subprocess.Popen, seen: list[str]) -> None:
    assert proc.stdout is not None
    for line in proc.stdout:
        seen.append(line)


def _wait_line(seen: list[str], text: str, start: int, timeout_s: float = 30.0) -> int:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        for k in range(start, len(seen)):
            if text in seen[k]:
                return k
        time.sleep(0.05)
    raise AssertionError(f"no line with {text!r}; saw: {''.join(seen[-20:])}")


@pytest.mark.slow
@pytest.mark.skipif(MAVPROXY is None or importlib.util.find_spec("MAVProxy") is None, reason="MAVProxy not installed")
def test_mavproxy_uploads_a_fence_to_the_vehicle_through_the_companion(tmp_path):
    v_port, g_port = free_udp_port(), free_udp_port()
    wpl = "QGC WPL 110\n" + "".join(ROW.format(seq=i.seq, cmd=i.command, p1=i.param1, lat=i.x / 1e7, lon=i.y / 1e7) + "\n" for i in GOOD)  # fmt: skip
    (tmp_path / "in.txt").write_text(wpl)
    proc = start_companion(tmp_path, v_port, f"udpin:127.0.0.1:{g_port}")
    vehicle = FakeVehicle(v_port)
    mavproxy, seen = None, []
    try:
        mavproxy = subprocess.Popen(
            [str(MAVPROXY), f"--master=udpout:127.0.0.1:{g_port}", "--source-system", "250", "--target-system", "1",
             "--target-component", "1", "--state-basedir", str(tmp_path / "mavproxy"), "--default-modules=fence"],
            cwd=tmp_path, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1,
        )  # fmt: skip
        threading.Thread(target=_lines, args=(mavproxy, seen), daemon=True).start()
        assert mavproxy.stdin is not None
        at = _wait_line(seen, "Detected vehicle 1:1", 0)
        mavproxy.stdin.write(f"fence load {tmp_path / 'in.txt'}\n")
        mavproxy.stdin.flush()
        at = _wait_line(seen, "Got MISSION_ACK: TYPE_FENCE", at)
        assert "ACCEPTED" in seen[at]
        mavproxy.stdin.write(f"fence save {tmp_path / 'out.txt'}\n")
        mavproxy.stdin.flush()
        _wait_line(seen, "Saved 5 fence items", at)
        assert (tmp_path / "out.txt").read_text() == wpl
        mavproxy.stdin.write("exit\n")
        mavproxy.stdin.close()
        mavproxy.wait(timeout=20)
        vehicle_fence = vehicle.fence_messages()
    finally:
        vehicle.stop()
        if mavproxy is not None and mavproxy.poll() is None:
            mavproxy.kill()
        try:
            _, err = proc.communicate(timeout=20)
        finally:
            proc.kill()
    assert proc.returncode == 0, err
    assert vehicle_fence == [] and not vehicle.errors
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["fence_server"]["accepted"] == 1
    assert report["relay"]["taken_from_gcs"]["MISSION_COUNT"] >= 1
    assert report["relay"]["forwarded_to_vehicle"].get("HEARTBEAT", 0) > 0  # MAVProxy's, on to the vehicle


@pytest.mark.parametrize(
    ("gcs", "says"),
    [("udpin:127.0.0.1:{port}", "the same link as --connect"), ("bogus:x", "--gcs 'bogus:x': expected udpin")],
)
def test_a_bad_ground_station_link_is_one_line_and_exit_2(tmp_path, capsys, gcs, says):
    from scenarios.app.cli import main

    (tmp_path / "start.txt").write_text(START_WPL)
    port = free_udp_port()
    argv = ["companion", "--connect", f"udpin:127.0.0.1:{port}", "--gcs", gcs.format(port=port)]
    assert main([*argv, "--fence", str(tmp_path / "start.txt"), "--profile", "F450"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and says in err[0], err
