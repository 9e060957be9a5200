"""The MAVLink mission protocol for fences and rally points: the companion's server and a client for tools and tests.

Upload (ground station -> companion)::

    MISSION_COUNT(n, mission_type) -> [MISSION_REQUEST_INT(i) -> MISSION_ITEM_INT(i)] x n -> MISSION_ACK(result)

Download: ``MISSION_REQUEST_LIST -> MISSION_COUNT -> [MISSION_REQUEST_INT -> MISSION_ITEM_INT] x n -> MISSION_ACK``.
``mission_type`` is ``MAV_MISSION_TYPE_FENCE`` (items 5001/5002 polygon vertices, ``param1`` = the polygon's vertex
count; 5003/5004 circles, ``param1`` = radius m; 5000 the return point) or ``MAV_MISSION_TYPE_RALLY`` (5100);
``x``/``y`` are lat/lon in 1e-7 deg. The plain ``MISSION_REQUEST``/``MISSION_ITEM`` (float lat/lon) are answered and
read too.

:class:`FenceServer` checks each item as it arrives (command, frame, coordinates: the ``MAV_MISSION_RESULT``
naming the field) and the whole list when the last arrives, with the file importer's code
(:func:`analysis.formats.fence_files.fence_from_items`: vertex counts, polygons, self-intersection, ranges, then
:class:`~geofence.geometry.fence.Fence`'s own validation), keeping the vertical limits and floor gaps of the fence
in use (no mission item carries them). Only a fence that passes all of it, and that the owner's ``replace``
callback takes, replaces the fence in use; anything else is NACKed and changes nothing. An upload whose items stop
coming is re-requested ``retries`` times, ``item_timeout_s`` apart, then abandoned (``OPERATION_CANCELLED``); the
old fence stays. Messages for another system or component, from another sender than the upload's, or out of order
are not taken as items. A download returns the accepted items as they were uploaded (initially the items of the
fence the companion started with, :func:`mission_items_from_fence`). Each transfer is answered from the ``face``
it came in on (:meth:`FenceServer.handle`): the server's own link and ids, or another id it answers for.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

from analysis.formats.fence_files import (
    FenceItem,
    ImportOptions,
    RallyPoint,
    fence_from_items,
    fence_items,
    rally_from_items,
    rally_items,
)
from geofence.geometry.fence import Fence, FenceError
from geofence.validation import ConfigError
from scenarios.link.connection import Link, mavlink, now_s, receive

FENCE = mavlink.MAV_MISSION_TYPE_FENCE
RALLY = mavlink.MAV_MISSION_TYPE_RALLY
FENCE_COMMANDS = frozenset(range(5000, 5005))
RALLY_COMMANDS = frozenset({5100})
FRAMES = frozenset(
    {
        mavlink.MAV_FRAME_GLOBAL,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        mavlink.MAV_FRAME_GLOBAL_INT,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)
"""The global frames a fence or rally item may use (the local and mission frames mean nothing for a fence)."""
MAX_ITEMS = 2000
"""The most items one upload may announce (MAV_MISSION_NO_SPACE beyond)."""
ITEM_TIMEOUT_S = 1.0
ITEM_RETRIES = 3
RESULT_NAMES = {v: k for k, v in vars(mavlink).items() if k.startswith("MAV_MISSION_") and "TYPE" not in k}


class MissionItem(NamedTuple):
    """One ``MISSION_ITEM_INT`` as sent (``x``, ``y``: lat, lon in 1e-7 deg; ``z``: altitude, m)."""

    seq: int
    frame: int
    command: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float


def item_of_message(msg: Any) -> MissionItem:
    """A received MISSION_ITEM_INT (or float MISSION_ITEM, its lat/lon rounded to 1e-7 deg) as a :class:`MissionItem`."""
    x, y = msg.x, msg.y
    if msg.get_type() == "MISSION_ITEM":
        x, y = (round(v * 1e7) if math.isfinite(v) and abs(v) < 1e3 else 2**31 - 1 for v in (x, y))
    return MissionItem(msg.seq, msg.frame, msg.command, msg.param1, msg.param2, msg.param3, msg.param4, x, y, msg.z)


def fence_item(item: MissionItem) -> FenceItem:
    """The importer's view of a mission item (deg, m), named ``item <seq>`` in messages."""
    p = (item.param1, item.param2, item.param3, item.param4, item.x / 1e7, item.y / 1e7, item.z)
    return FenceItem(f"item {item.seq}", item.frame, item.command, p)


def mission_items_from_fence(fence: Fence) -> list[MissionItem]:
    """The MISSION_ITEM_INT list of a fence (:func:`analysis.formats.fence_files.fence_items`: return point 5000,
    the keep-in 5003 or 5001, keep-outs 5002/5004)."""
    return [_mission_item(i, it) for i, it in enumerate(fence_items(fence))]


def mission_items_from_rally(points: Sequence[RallyPoint]) -> list[MissionItem]:
    """The MISSION_ITEM_INT list of rally points (5100, altitude relative to home)."""
    return [_mission_item(i, it) for i, it in enumerate(rally_items(points))]


def _mission_item(seq: int, item: FenceItem) -> MissionItem:
    p1, p2, p3, p4, lat, lon, alt = item.params
    return MissionItem(seq, item.frame, item.command, p1, p2, p3, p4, round(lat * 1e7), round(lon * 1e7), float(alt))


def check_item(item: MissionItem, mission_type: int) -> int:
    """An item's own fields: ``MAV_MISSION_ACCEPTED`` or the result naming the first bad one."""
    commands = FENCE_COMMANDS if mission_type == FENCE else RALLY_COMMANDS
    if item.command not in commands:
        return mavlink.MAV_MISSION_UNSUPPORTED
    if item.frame not in FRAMES:
        return mavlink.MAV_MISSION_UNSUPPORTED_FRAME
    if not math.isfinite(item.param1):
        return mavlink.MAV_MISSION_INVALID_PARAM1
    if not -900_000_000 <= item.x <= 900_000_000:
        return mavlink.MAV_MISSION_INVALID_PARAM5_X
    if not -1_800_000_000 <= item.y <= 1_800_000_000:
        return mavlink.MAV_MISSION_INVALID_PARAM6_Y
    if not math.isfinite(item.z):
        return mavlink.MAV_MISSION_INVALID_PARAM7
    return mavlink.MAV_MISSION_ACCEPTED


def fence_of_items(items: Sequence[MissionItem], base: Fence) -> tuple[Fence, list[str]]:
    """The fence an item list describes, with ``base``'s vertical limits and floor gaps: ``(fence, warnings)``.
    Raises :class:`FenceError` naming the item."""
    imported = fence_from_items(
        [fence_item(i) for i in items], "fence upload", ImportOptions(ceiling_m=base.ceiling_m, floor_m=base.floor_m,
        altitude_reference=base.altitude_reference.value, floor_gaps=base.floor_gaps),
    )  # fmt: skip
    return imported.fence, list(imported.warnings)


def result_of_error(message: str) -> int:
    """The ``MAV_MISSION_RESULT`` of a whole-list refusal: ``INVALID_PARAM1`` for a vertex count or radius (the
    field the items carry them in), ``INVALID_PARAM5_X`` for a position, else ``INVALID``."""
    if "param1" in message or "vertex count" in message or "radius" in message:
        return mavlink.MAV_MISSION_INVALID_PARAM1
    if "latitude" in message or "(0, 0)" in message:
        return mavlink.MAV_MISSION_INVALID_PARAM5_X
    if "longitude" in message:
        return mavlink.MAV_MISSION_INVALID_PARAM6_Y
    return mavlink.MAV_MISSION_INVALID


class Peer(NamedTuple):
    """Who a transfer is with, and the ``face`` (a link whose ``.mav`` encoder carries the id the sender
    addressed) that answers it."""

    system: int
    component: int
    face: Any


@dataclass
class _Upload:
    peer: Peer
    mission_type: int
    count: int
    deadline_s: float
    items: list[MissionItem] = field(default_factory=list)
    retries_left: int = ITEM_RETRIES


@dataclass
class ServerStats:
    """What the server did: uploads accepted / refused (NACKed) / abandoned (timeout), downloads served, messages
    ignored (not for us, not from the upload's sender, out of order)."""

    accepted: int = 0
    refused: int = 0
    abandoned: int = 0
    downloads: int = 0
    ignored: int = 0
    last_result: int = mavlink.MAV_MISSION_ACCEPTED
    last_message: str = ""


class FenceServer:
    """The companion's side of the mission protocol for its fence and rally points (see the module docstring).

    ``replace(fence)`` installs an accepted fence and returns None, or returns why it cannot (the upload is then
    NACKed ``MAV_MISSION_DENIED``). Call :meth:`handle` with every received message and :meth:`poll` regularly
    (the item timeouts run on :func:`~scenarios.link.connection.now_s` or the ``now_s`` given).
    """

    def __init__(
        self, conn: Link, fence: Fence, replace: Callable[[Fence], str | None] | None = None,
        rally: Sequence[RallyPoint] = (), *, item_timeout_s: float = ITEM_TIMEOUT_S, retries: int = ITEM_RETRIES,
        max_items: int = MAX_ITEMS, on_event: Callable[[str], None] | None = None,
    ) -> None:  # fmt: skip
        self.conn = conn
        self.fence = fence
        self.rally_points: tuple[RallyPoint, ...] = tuple(rally)
        self.warnings: list[str] = []
        self.stats = ServerStats()
        self._replace = replace or (lambda f: None)
        self._on_event = on_event or (lambda text: None)
        self._items = {FENCE: mission_items_from_fence(fence), RALLY: mission_items_from_rally(self.rally_points)}
        self._upload: _Upload | None = None
        self._downloads: dict[tuple[Peer, int], list[MissionItem]] = {}
        self.item_timeout_s, self.retries, self.max_items = item_timeout_s, retries, max_items
        self._handlers = {
            "MISSION_COUNT": self._on_count,
            "MISSION_ITEM_INT": self._on_item,
            "MISSION_ITEM": self._on_item,
            "MISSION_REQUEST_LIST": self._on_request_list,
            "MISSION_REQUEST_INT": self._on_request,
            "MISSION_REQUEST": self._on_request,
            "MISSION_ACK": self._on_ack,
            "MISSION_CLEAR_ALL": self._on_clear,
        }

    def items(self, mission_type: int = FENCE) -> list[MissionItem]:
        """The items a download gets (the accepted upload's, as uploaded)."""
        return list(self._items.get(mission_type, ()))

    @property
    def uploading(self) -> bool:
        return self._upload is not None

    def handle(self, msg: Any, t_s: float | None = None, face: Link | None = None) -> bool:
        """Take one received message; True when it was a mission-protocol message addressed to us. ``face``
        (default: the server's own link): the link and ids it came in as, and answers from (a relay answers a
        ground station as the vehicle it addressed)."""
        handler = self._handlers.get(msg.get_type())
        if handler is None:
            return False
        face = self.conn if face is None else face
        mav = face.mav
        if getattr(msg, "target_system", -1) != mav.srcSystem or msg.target_component not in (mav.srcComponent, 0):
            self.stats.ignored += 1
            return False
        handler(msg, Peer(msg.get_srcSystem(), msg.get_srcComponent(), face), now_s() if t_s is None else t_s)
        return True

    def poll(self, t_s: float | None = None) -> None:
        """Re-request an item whose answer is overdue; abandon the upload after ``retries`` re-requests."""
        up = self._upload
        t = now_s() if t_s is None else t_s
        if up is None or t < up.deadline_s:
            return
        if up.retries_left > 0:
            up.retries_left -= 1
            up.deadline_s = t + self.item_timeout_s
            self._request(up)
            return
        self.stats.abandoned += 1
        self._finish(up, mavlink.MAV_MISSION_OPERATION_CANCELLED, f"upload abandoned: no item {len(up.items)} came")

    # ---- upload
    def _on_count(self, msg: Any, peer: Peer, t: float) -> None:
        mt, n = msg.mission_type, msg.count
        up = self._upload
        if up is not None and up.peer != peer:
            return self._ack(peer, mt, mavlink.MAV_MISSION_DENIED, "refused: another upload is in progress")
        if mt not in (FENCE, RALLY):
            return self._ack(peer, mt, mavlink.MAV_MISSION_UNSUPPORTED, f"refused: mission type {mt} (fence/rally only)")
        if n > self.max_items:
            return self._ack(peer, mt, mavlink.MAV_MISSION_NO_SPACE, f"refused: {n} items (at most {self.max_items})")
        self._upload = None  # a new count from the upload's sender restarts it
        if n == 0:
            return self._clear(peer, mt)
        self._upload = _Upload(peer, mt, n, t + self.item_timeout_s, retries_left=self.retries)
        self._request(self._upload)

    def _on_item(self, msg: Any, peer: Peer, t: float) -> None:
        up = self._upload
        if up is None or up.peer != peer or msg.mission_type != up.mission_type:
            self.stats.ignored += 1
            return
        item = item_of_message(msg)
        if item.seq != len(up.items):  # a repeat or out of order: ask again for the one expected
            self.stats.ignored += 1
            self._request(up)
            return
        result = check_item(item, up.mission_type)
        if result != mavlink.MAV_MISSION_ACCEPTED:
            self.stats.refused += 1
            self._finish(up, result, f"item {item.seq}: command {item.command}: {RESULT_NAMES.get(result, result)}")
            return
        up.items.append(item)
        up.deadline_s, up.retries_left = t + self.item_timeout_s, self.retries
        if len(up.items) < up.count:
            self._request(up)
            return
        self._complete(up)

    def _complete(self, up: _Upload) -> None:
        """The last item came: check the whole list, replace what is in use only if all of it passes."""
        try:
            if up.mission_type == FENCE:
                fence, warnings = fence_of_items(up.items, self.fence)
                refusal = self._replace(fence)
                if refusal is not None:
                    self.stats.refused += 1
                    return self._finish(up, mavlink.MAV_MISSION_DENIED, f"fence refused: {refusal}")
                self.fence, self.warnings = fence, warnings
            else:
                self.rally_points = rally_from_items([fence_item(i) for i in up.items], "rally upload")
        except (FenceError, ConfigError) as exc:
            self.stats.refused += 1
            return self._finish(up, result_of_error(str(exc)), f"refused: {exc}")
        except Exception as exc:  # hostile input never crashes the server: a refusal, the fence unchanged
            self.stats.refused += 1
            return self._finish(up, mavlink.MAV_MISSION_ERROR, f"refused: {type(exc).__name__}: {exc}")
        self._items[up.mission_type] = list(up.items)
        self.stats.accepted += 1
        what = "fence" if up.mission_type == FENCE else "rally points"
        self._finish(up, mavlink.MAV_MISSION_ACCEPTED, f"{what} accepted: {up.count} items")

    def _clear(self, peer: Peer, mission_type: int) -> None:
        if mission_type == FENCE:  # the companion never flies without a fence
            self.stats.refused += 1
            return self._ack(peer, FENCE, mavlink.MAV_MISSION_DENIED, "refused: clearing the fence")
        self.rally_points, self._items[RALLY] = (), []
        self._ack(peer, RALLY, mavlink.MAV_MISSION_ACCEPTED, "rally points cleared")

    def _on_clear(self, msg: Any, peer: Peer, t: float) -> None:
        if msg.mission_type in (FENCE, RALLY):
            self._clear(peer, msg.mission_type)

    def _request(self, up: _Upload) -> None:
        up.peer.face.mav.mission_request_int_send(up.peer[0], up.peer[1], len(up.items), up.mission_type)

    def _finish(self, up: _Upload, result: int, text: str) -> None:
        self._upload = None
        self._ack(up.peer, up.mission_type, result, text)

    def _ack(self, peer: Peer, mission_type: int, result: int, text: str) -> None:
        self.stats.last_result, self.stats.last_message = result, text
        peer.face.mav.mission_ack_send(peer[0], peer[1], result, mission_type)
        self._on_event(text)

    # ---- download
    def _on_request_list(self, msg: Any, peer: Peer, t: float) -> None:
        mt = msg.mission_type
        if mt not in (FENCE, RALLY):
            return self._ack(peer, mt, mavlink.MAV_MISSION_UNSUPPORTED, f"download of mission type {mt} refused")
        self._downloads[(peer, mt)] = items = self.items(mt)
        if len(self._downloads) > 16:  # senders that never finish their downloads
            del self._downloads[next(iter(self._downloads))]
        peer.face.mav.mission_count_send(peer[0], peer[1], len(items), mt)

    def _on_request(self, msg: Any, peer: Peer, t: float) -> None:
        mt = msg.mission_type
        items = self._downloads.get((peer, mt))
        if items is None:
            items = self.items(mt)
        if not 0 <= msg.seq < len(items):
            return self._ack(peer, mt, mavlink.MAV_MISSION_INVALID_SEQUENCE, f"request of item {msg.seq}: no such item")
        i = items[msg.seq]
        if msg.get_type() == "MISSION_REQUEST":
            peer.face.mav.mission_item_send(
                peer[0], peer[1], i.seq, i.frame, i.command, 0, 1, i.param1, i.param2, i.param3, i.param4,
                i.x / 1e7, i.y / 1e7, i.z, mt,
            )  # fmt: skip
            return
        peer.face.mav.mission_item_int_send(
            peer[0], peer[1], i.seq, i.frame, i.command, 0, 1, i.param1, i.param2, i.param3, i.param4, i.x, i.y, i.z, mt
        )

    def _on_ack(self, msg: Any, peer: Peer, t: float) -> None:
        if self._downloads.pop((peer, msg.mission_type), None) is not None:
            self.stats.downloads += 1


# --------------------------------------------------------------------------- the client side
class MissionError(RuntimeError):
    """A client transfer that failed: a NACK (``result``) or no answer in time (``result`` None)."""

    def __init__(self, text: str, result: int | None = None) -> None:
        super().__init__(text)
        self.result = result


def upload(
    conn: Link, items: Sequence[MissionItem], target: tuple[int, int], mission_type: int = FENCE,
    timeout_s: float = 10.0, retry_s: float = 0.5,
) -> int:  # fmt: skip
    """Upload ``items`` (their ``seq`` renumbered 0..n-1) to ``target = (system, component)``: the
    ``MAV_MISSION_RESULT`` of its ACK. Raises :class:`MissionError` when no ACK came within ``timeout_s``."""
    items = [i._replace(seq=k) for k, i in enumerate(items)]
    drain(conn)
    mav = conn.mav
    mav.mission_count_send(target[0], target[1], len(items), mission_type)
    deadline, asked = now_s() + timeout_s, False
    last = now_s()
    while now_s() < deadline:
        msg = receive(conn, 0.05)
        if msg is None or (msg.get_srcSystem(), msg.get_srcComponent()) != target:
            if not asked and now_s() - last > retry_s:  # the count was lost: send it again
                mav.mission_count_send(target[0], target[1], len(items), mission_type)
                last = now_s()
            continue
        kind = msg.get_type()
        if kind == "MISSION_ACK" and msg.mission_type == mission_type:
            return int(msg.type)
        if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST") and msg.mission_type == mission_type:
            asked = True
            if 0 <= msg.seq < len(items):
                send_item(conn, target, items[msg.seq], mission_type)
    raise MissionError(f"upload to {target}: no MISSION_ACK within {timeout_s:g} s")


def drain(conn: Link) -> int:
    """Drop the messages already waiting (answers to an earlier exchange are not this one's): how many."""
    n = 0
    while receive(conn) is not None:
        n += 1
    return n


def send_item(conn: Link, target: tuple[int, int], i: MissionItem, mission_type: int = FENCE) -> None:
    conn.mav.mission_item_int_send(
        target[0], target[1], i.seq, i.frame, i.command, 0, 1, i.param1, i.param2, i.param3, i.param4, i.x, i.y, i.z,
        mission_type,
    )  # fmt: skip


def download(
    conn: Link, target: tuple[int, int], mission_type: int = FENCE, timeout_s: float = 10.0, retry_s: float = 0.5
) -> list[MissionItem]:
    """The items ``target`` holds of ``mission_type`` (MISSION_REQUEST_LIST, then each item; the ACK sent at the
    end). Raises :class:`MissionError` on a NACK or when it stops answering for ``timeout_s``."""
    drain(conn)
    mav = conn.mav
    count: int | None = None
    got: list[MissionItem] = []
    deadline = now_s() + timeout_s
    last = -math.inf
    while now_s() < deadline:
        if now_s() - last > retry_s:  # (re)ask: the list, or the item expected
            if count is None:
                mav.mission_request_list_send(target[0], target[1], mission_type)
            else:
                mav.mission_request_int_send(target[0], target[1], len(got), mission_type)
            last = now_s()
        msg = receive(conn, 0.05)
        if msg is None or (msg.get_srcSystem(), msg.get_srcComponent()) != target:
            continue
        kind = msg.get_type()
        if kind == "MISSION_ACK" and msg.mission_type == mission_type:
            raise MissionError(f"download from {target}: {RESULT_NAMES.get(msg.type, msg.type)}", int(msg.type))
        if kind == "MISSION_COUNT" and msg.mission_type == mission_type and count is None:
            count, last = msg.count, -math.inf
        elif kind == "MISSION_ITEM_INT" and msg.mission_type == mission_type and count is not None:
            if msg.seq == len(got):
                got.append(item_of_message(msg))
                last, deadline = -math.inf, now_s() + timeout_s
        if count is not None and len(got) == count:
            mav.mission_ack_send(target[0], target[1], mavlink.MAV_MISSION_ACCEPTED, mission_type)
            return got
    raise MissionError(f"download from {target}: no answer within {timeout_s:g} s")
