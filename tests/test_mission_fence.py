"""The mission-protocol fence server and client (scenarios.link.mission_fence) over real loopback UDP sockets,
pymavlink on both ends: uploads and downloads round-trip; every hostile input (garbage, wrong ids, missing or
out-of-order items, a bad fence, a flood, a link that stops mid-upload) leaves the fence in use unchanged and the
server answering. A hypothesis test drives the server's state machine with random message sequences."""

from __future__ import annotations

import random
import socket
import threading
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support import free_udp_port

from analysis.formats.fence_files import ImportOptions, load_fence_file
from geofence.geometry.fence import Fence
from scenarios.link.connection import mavlink, now_s, open_link, receive
from scenarios.link.mission_fence import (
    FENCE,
    RALLY,
    FenceServer,
    MissionError,
    MissionItem,
    download,
    mission_items_from_fence,
    send_item,
    upload,
)

LAT0, LON0 = 47.397, 8.545
D = 0.002  # deg: about 220 m north, 150 m east
SQUARE = ((LAT0, LON0), (LAT0, LON0 + D), (LAT0 + D, LON0 + D), (LAT0 + D, LON0))
BASE = Fence(keep_in=SQUARE, ceiling_m=80.0)
SERVER = (255, 191)
CLIENT_ID = (250, 190)


def item(seq: int, cmd: int, p1: float, lat: float, lon: float, z: float = 0.0, frame: int = 0) -> MissionItem:
    return MissionItem(seq, frame, cmd, float(p1), 0.0, 0.0, 0.0, round(lat * 1e7), round(lon * 1e7), z)


def polygon_items(cmd: int, poly, start: int = 0) -> list[MissionItem]:
    return [item(start + k, cmd, len(poly), lat, lon) for k, (lat, lon) in enumerate(poly)]


SMALLER = ((LAT0 + 0.0002, LON0 + 0.0002), (LAT0 + 0.0002, LON0 + 0.0015), (LAT0 + 0.0015, LON0 + 0.0012))
GOOD = [*polygon_items(5001, SMALLER), item(3, 5000, 0, LAT0 + 0.0006, LON0 + 0.0008, 30.0)]
BOWTIE = ((LAT0, LON0), (LAT0 + D, LON0 + D), (LAT0, LON0 + D), (LAT0 + D, LON0))


class Server:
    """A FenceServer on ``udpin:127.0.0.1:PORT`` in a thread (the companion's loop: handle, poll)."""

    def __init__(self, refuse: str | None = None, item_timeout_s: float = 0.2, retries: int = 2) -> None:
        self.port = free_udp_port()
        self.conn = open_link(f"udpin:127.0.0.1:{self.port}", *SERVER)
        self.server = FenceServer(self.conn, BASE, lambda f: refuse, item_timeout_s=item_timeout_s, retries=retries)
        self.errors: list[BaseException] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                msg = receive(self.conn, 0.01)
                if msg is not None:
                    self.server.handle(msg)
                self.server.poll()
        except BaseException as exc:  # the test fails on it: the server must never raise
            self.errors.append(exc)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5.0)
        self.conn.close()
        assert not self.errors, self.errors


@pytest.fixture
def server():
    s = Server()
    yield s
    s.close()


@pytest.fixture
def client(server):
    c = open_link(f"udpout:127.0.0.1:{server.port}", *CLIENT_ID)
    yield c
    c.close()


def test_upload_replaces_the_fence_and_download_lists_it_back(server, client):
    assert upload(client, GOOD, SERVER) == mavlink.MAV_MISSION_ACCEPTED
    assert server.server.fence.keep_in == SMALLER
    assert server.server.fence.recovery_point == (LAT0 + 0.0006, LON0 + 0.0008)
    assert server.server.fence.ceiling_m == BASE.ceiling_m  # the vertical limits stay the fence in use's
    assert download(client, SERVER) == GOOD
    deadline = now_s() + 2.0
    while server.server.stats.downloads == 0 and now_s() < deadline:  # the client's final ACK is on its way
        time.sleep(0.01)
    assert server.server.stats.accepted == 1 and server.server.stats.downloads == 1


def test_initial_download_is_the_fence_in_use_and_reads_back_the_same(server, client, tmp_path):
    got = download(client, SERVER)
    assert got == mission_items_from_fence(BASE)
    # the downloaded items, written as WPL 110, read by the file importer: the same keep-in (to 1e-7 deg)
    lines = ["QGC WPL 110"] + [
        f"{i.seq}\t0\t{i.frame}\t{i.command}\t{i.param1}\t0\t0\t0\t{i.x * 1e-7:.7f}\t{i.y * 1e-7:.7f}\t{i.z}\t1" for i in got
    ]
    (tmp_path / "f.txt").write_text("\n".join(lines) + "\n")
    back = load_fence_file(tmp_path / "f.txt", ImportOptions(ceiling_m=80.0)).fence
    assert all(abs(a - b) < 1e-7 for p, q in zip(back.keep_in, BASE.keep_in) for a, b in zip(p, q))


def test_rally_points_upload_download_and_clear(server, client):
    rally = [item(0, 5100, 0, LAT0 + 0.001, LON0 + 0.001, 25.0, frame=3)]
    assert upload(client, rally, SERVER, RALLY) == mavlink.MAV_MISSION_ACCEPTED
    assert download(client, SERVER, RALLY) == rally
    assert server.server.rally_points[0].alt_m == 25.0
    assert upload(client, [], SERVER, RALLY) == mavlink.MAV_MISSION_ACCEPTED  # count 0 clears
    assert server.server.rally_points == ()


@pytest.mark.parametrize(
    "items, result",
    [
        (polygon_items(5001, BOWTIE), mavlink.MAV_MISSION_INVALID),  # self-intersecting
        ([*polygon_items(5001, SMALLER)[:2], item(2, 5001, 4, LAT0 + 0.001, LON0)], mavlink.MAV_MISSION_INVALID_PARAM1),
        ([item(0, 5001, 2, LAT0, LON0), item(1, 5001, 2, LAT0 + D, LON0)], mavlink.MAV_MISSION_INVALID_PARAM1),
        ([item(0, 5003, -5.0, LAT0 + 0.001, LON0 + 0.001)], mavlink.MAV_MISSION_INVALID_PARAM1),  # negative radius
        ([*polygon_items(5001, SMALLER)[:2], item(2, 5001, 3, 91.0, LON0)], mavlink.MAV_MISSION_INVALID_PARAM5_X),
        ([*polygon_items(5001, SMALLER)[:2], item(2, 5001, 3, LAT0, 181.0)], mavlink.MAV_MISSION_INVALID_PARAM6_Y),
        ([*polygon_items(5001, SMALLER)[:2], item(2, 16, 3, LAT0, LON0)], mavlink.MAV_MISSION_UNSUPPORTED),  # a waypoint
        ([*polygon_items(5001, SMALLER)[:2], item(2, 5001, 3, LAT0, LON0, frame=1)], mavlink.MAV_MISSION_UNSUPPORTED_FRAME),
        ([item(0, 5002, 3, *p) for p in SMALLER], mavlink.MAV_MISSION_INVALID),  # only a keep-out: no keep-in
        ([*polygon_items(5001, SMALLER), *polygon_items(5001, SQUARE, 3)], mavlink.MAV_MISSION_INVALID),  # two keep-ins
    ],
    ids=["bowtie", "count-mismatch", "two-vertices", "radius", "lat", "lon", "command", "frame", "no-keep-in", "two-keep-ins"],
)
def test_a_bad_fence_is_nacked_with_its_result_and_changes_nothing(server, client, items, result):
    assert upload(client, items, SERVER) == result
    assert server.server.fence is BASE
    assert download(client, SERVER) == mission_items_from_fence(BASE)


def test_the_owner_may_refuse_and_clearing_the_fence_is_refused(client, server):
    assert upload(client, [], SERVER) == mavlink.MAV_MISSION_DENIED  # never without a fence
    refusing = Server(refuse="overriding")
    try:
        c = open_link(f"udpout:127.0.0.1:{refusing.port}", *CLIENT_ID)
        assert upload(c, GOOD, SERVER) == mavlink.MAV_MISSION_DENIED
        assert refusing.server.fence is BASE
        c.close()
    finally:
        refusing.close()


def test_wrong_target_ids_are_ignored(server, client):
    for target in ((1, 191), (255, 1)):
        with pytest.raises(MissionError):
            upload(client, GOOD, target, timeout_s=0.6)
    assert server.server.fence is BASE and server.server.stats.ignored >= 2


def test_garbage_bytes_then_a_valid_upload(server):
    rng = random.Random(1)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as raw:
        for k in range(300):
            data = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 300)))
            if k % 3 == 0:
                data = b"\xfd" + data  # MAVLink 2 start byte, then junk
            raw.sendto(data, ("127.0.0.1", server.port))
    time.sleep(0.3)
    assert server.server.fence is BASE
    c = open_link(f"udpout:127.0.0.1:{server.port}", *CLIENT_ID)
    assert upload(c, GOOD, SERVER) == mavlink.MAV_MISSION_ACCEPTED
    c.close()


def _expect(conn, kind: str, timeout_s: float = 2.0):
    deadline = now_s() + timeout_s
    while now_s() < deadline:
        msg = receive(conn, 0.05)
        if msg is not None and msg.get_type() == kind:
            return msg
    raise AssertionError(f"no {kind} within {timeout_s} s")


def test_out_of_order_and_repeated_items_are_re_requested(server, client):
    client.mav.mission_count_send(*SERVER, len(GOOD), FENCE)
    assert _expect(client, "MISSION_REQUEST_INT").seq == 0
    send_item(client, SERVER, GOOD[2])  # out of order
    assert _expect(client, "MISSION_REQUEST_INT").seq == 0
    send_item(client, SERVER, GOOD[0])
    assert _expect(client, "MISSION_REQUEST_INT").seq == 1
    send_item(client, SERVER, GOOD[0])  # a repeat
    assert _expect(client, "MISSION_REQUEST_INT").seq == 1
    for i in GOOD[1:]:
        send_item(client, SERVER, i)
    assert _expect(client, "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED
    assert server.server.fence.keep_in == SMALLER


def test_a_link_that_stops_mid_upload_is_abandoned_and_the_old_fence_stays(server, client):
    client.mav.mission_count_send(*SERVER, len(GOOD), FENCE)
    _expect(client, "MISSION_REQUEST_INT")
    send_item(client, SERVER, GOOD[0])
    t0 = now_s()
    ack = _expect(client, "MISSION_ACK", 3.0)  # 0.2 s timeout, 2 retries: abandoned after ~0.6 s
    assert ack.type == mavlink.MAV_MISSION_OPERATION_CANCELLED and now_s() - t0 < 2.0
    assert server.server.fence is BASE and not server.server.uploading and server.server.stats.abandoned == 1


def test_an_upload_from_a_second_sender_is_denied_meanwhile(server, client):
    client.mav.mission_count_send(*SERVER, len(GOOD), FENCE)
    _expect(client, "MISSION_REQUEST_INT")
    other = open_link(f"udpout:127.0.0.1:{server.port}", 251, 190)
    try:
        other.mav.mission_count_send(*SERVER, 3, FENCE)
        # the server answers the last address it heard from (a udpin link has one peer); the ACK goes to `other`
        assert _expect(other, "MISSION_ACK").type == mavlink.MAV_MISSION_DENIED
    finally:
        other.close()
    assert server.server.fence is BASE


def test_a_flood_of_random_mission_messages_changes_nothing(server, client):
    rng = random.Random(7)
    mav = client.mav
    t0 = now_s()
    for _ in range(3000):
        k = rng.randrange(5)
        seq = rng.randrange(-1, 8) & 0xFFFF
        if k == 0:
            mav.mission_count_send(*SERVER, rng.randrange(0, 70000) & 0xFFFF, rng.choice((FENCE, RALLY, 0, 7)))
        elif k == 1:
            lat = rng.uniform(-100, 100) if rng.random() < 0.2 else LAT0 + rng.uniform(0, D)
            cmd = rng.choice((5001, 5002, 5003, 5004, 5000, 5100, 16))
            send_item(client, SERVER, item(seq, cmd, rng.choice((3, 4, 0, -1, 1e30)), lat, LON0 + rng.uniform(0, D)))
        elif k == 2:
            mav.mission_request_int_send(*SERVER, seq, FENCE)
        elif k == 3:
            mav.mission_request_list_send(*SERVER, rng.choice((FENCE, RALLY, 0)))
        else:
            mav.mission_ack_send(*SERVER, rng.randrange(16), FENCE)
    rate = 3000 / (now_s() - t0)
    time.sleep(1.0)  # the server drains its socket; any upload left half-way times out
    fence = server.server.fence
    assert isinstance(fence, Fence)
    # whatever the flood did, the fence in use is one the server accepted whole, and it still answers
    assert download(client, SERVER) == server.server.items(FENCE)
    assert rate > 500


# ---------------------------------------------------------------------------------------- the state machine alone
class _Sink:
    """A link's write side that keeps what the server sends (no socket: the state machine alone)."""

    def __init__(self) -> None:
        self.sent: list[bytes] = []

    def write(self, data: bytes) -> None:
        self.sent.append(bytes(data))


class _Link:
    def __init__(self) -> None:
        self.mav = mavlink.MAVLink(_Sink(), srcSystem=SERVER[0], srcComponent=SERVER[1])


_ENC = mavlink.MAVLink(None, srcSystem=CLIENT_ID[0], srcComponent=CLIENT_ID[1])
_DEC = mavlink.MAVLink(None)
_DEC.robust_parsing = True

_coord = st.one_of(st.integers(-2**31, 2**31 - 1), st.integers(473_960_000, 474_000_000))  # fmt: skip
_msg = st.one_of(
    st.builds(lambda n, t: mavlink.MAVLink_mission_count_message(*SERVER, n, t), st.integers(0, 8), st.sampled_from((FENCE, RALLY))),
    st.builds(
        lambda s, c, p1, x, y: mavlink.MAVLink_mission_item_int_message(*SERVER, s, 0, c, 0, 1, p1, 0, 0, 0, x, 85_450_000 + y % 20_000, 0.0, FENCE),
        st.integers(0, 8), st.sampled_from((5000, 5001, 5002, 5003, 5004, 5100)),
        st.one_of(st.sampled_from((3.0, 4.0, 30.0)), st.floats(allow_nan=True, allow_infinity=True, width=32)), _coord, _coord,
    ),
    st.builds(lambda s: mavlink.MAVLink_mission_request_int_message(*SERVER, s, FENCE), st.integers(0, 9)),
    st.builds(lambda: mavlink.MAVLink_mission_request_list_message(*SERVER, FENCE)),
    st.builds(lambda dt: ("tick", dt), st.floats(0.0, 3.0)),
)  # fmt: skip


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(_msg, max_size=40))
def test_any_message_sequence_leaves_an_accepted_fence_or_the_old_one(messages):
    server = FenceServer(_Link(), BASE, item_timeout_s=0.5, retries=1)
    t = 0.0
    for m in messages:
        if isinstance(m, tuple):
            t += m[1]
            server.poll(t)
            continue
        decoded = _DEC.parse_char(m.pack(_ENC))
        server.handle(decoded, t)
    assert server.fence is BASE or server.stats.accepted >= 1
    assert server.items(FENCE) == (mission_items_from_fence(BASE) if server.fence is BASE else server.items(FENCE))
    Fence(**{k: getattr(server.fence, k) for k in ("keep_in", "ceiling_m", "keep_out_polygons", "keep_out_circles")})
