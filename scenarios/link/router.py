"""The companion between a ground station and an autopilot: which messages it takes, and forwarding the rest.

:class:`Router` holds the two links (vehicle, ground station) and forwards each received frame to the other side as
received, byte for byte (source ids, sequence number, signature kept), so the ground station keeps seeing and
commanding the vehicle. What the router does not decide is what the companion takes: :func:`fence_transfer_for`
says whether a message is part of a fence or rally-point transfer (the mission protocol with ``mission_type``
FENCE or RALLY) addressed to given ids; the companion answers those itself and does not forward them.

Answering as the vehicle: :meth:`Router.face_as` gives a link-like :class:`Face` whose ``.mav`` encoder sends as
the vehicle's system/component on the ground-station link. The ground station then receives one stream of frames
from those ids, some forwarded from the vehicle and some the companion's: :class:`SeqSplice` renumbers the stream
(the companion's frame takes the next sequence number, the vehicle's later frames shift by one, CRC recomputed), so
the ground station counts no lost messages; gaps the vehicle's link had are kept. A signed frame cannot be
renumbered (its signature covers the header): it is forwarded as is.
"""

from __future__ import annotations

import select
import time
from collections import Counter
from typing import Any

from scenarios.link.connection import Link, mavlink
from scenarios.link.mission_fence import FENCE, RALLY

MISSION_TRANSFER = frozenset(
    {
        "MISSION_COUNT", "MISSION_REQUEST_LIST", "MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ITEM_INT",
        "MISSION_ITEM", "MISSION_ACK", "MISSION_CLEAR_ALL",
    }
)  # fmt: skip
"""The mission-protocol messages that carry a ``mission_type``: one transfer of a mission, a fence or rally points."""


def is_fence_transfer(msg: Any) -> bool:
    """A mission-protocol message of a fence or rally-point transfer (``mission_type`` FENCE or RALLY)."""
    return msg.get_type() in MISSION_TRANSFER and getattr(msg, "mission_type", None) in (FENCE, RALLY)


def addressed_to(msg: Any, ids: tuple[int, int]) -> bool:
    """``msg`` targets system ``ids[0]`` and component ``ids[1]`` (or all of its components, 0)."""
    return getattr(msg, "target_system", -1) == ids[0] and getattr(msg, "target_component", -1) in (ids[1], 0)


def fence_transfer_for(msg: Any, ids: tuple[int, int] | None) -> bool:
    """A fence/rally transfer message addressed to ``ids`` (None: the vehicle is not known yet, so any target)."""
    return is_fence_transfer(msg) and (ids is None or addressed_to(msg, ids))


def frame_source(buf: bytes | bytearray) -> tuple[int, int] | None:
    """The (system, component) of a MAVLink 1 or 2 frame, None for anything else."""
    if len(buf) >= 10 and buf[0] == mavlink.PROTOCOL_MARKER_V2:
        return buf[5], buf[6]
    if len(buf) >= 6 and buf[0] == mavlink.PROTOCOL_MARKER_V1:
        return buf[3], buf[4]
    return None


def with_seq(buf: bytes | bytearray, seq: int) -> bytes | None:
    """The frame ``buf`` with sequence number ``seq`` and its CRC recomputed; None when it cannot be (signed, an
    unknown message id, not a frame)."""
    if len(buf) >= 12 and buf[0] == mavlink.PROTOCOL_MARKER_V2:
        if buf[2] & mavlink.MAVLINK_IFLAG_SIGNED:
            return None
        at, msgid, end = 4, buf[7] | buf[8] << 8 | buf[9] << 16, 10 + buf[1]
    elif len(buf) >= 8 and buf[0] == mavlink.PROTOCOL_MARKER_V1:
        at, msgid, end = 2, buf[5], 6 + buf[1]
    else:
        return None
    kind = mavlink.mavlink_map.get(msgid)
    if kind is None or len(buf) != end + 2:
        return None
    out = bytearray(buf)
    out[at] = seq & 0xFF
    crc = mavlink.x25crc(out[1:end])
    crc.accumulate(bytes([kind.crc_extra]))
    out[end:] = crc.crc.to_bytes(2, "little")
    return bytes(out)


class SeqSplice:
    """One outgoing link's sequence numbers per source, for frames of the same ids from two origins (see the module
    docstring): forwarded frames keep their numbers plus an offset, each frame of our own adds one to it."""

    def __init__(self) -> None:
        self._offset: dict[tuple[int, int], int] = {}
        self._last: dict[tuple[int, int], int] = {}

    def forwarded(self, buf: bytes | bytearray) -> bytes | bytearray:
        """A received frame as it goes out (renumbered only once frames of our own were put in its stream)."""
        src = frame_source(buf)
        if src is None:
            return buf
        seq = buf[4] if buf[0] == mavlink.PROTOCOL_MARKER_V2 else buf[2]
        offset = self._offset.get(src, 0)
        out = with_seq(buf, seq + offset) if offset else None
        self._last[src] = (seq + offset) & 0xFF if out is not None or not offset else seq
        return buf if out is None else out

    def own(self, buf: bytes | bytearray) -> bytes | bytearray:
        """One of our frames sent as a source we also forward: the stream's next number."""
        src = frame_source(buf)
        if src is None or src not in self._last:
            return buf
        seq = (self._last[src] + 1) & 0xFF
        out = with_seq(buf, seq)
        if out is None:
            return buf
        self._last[src] = seq
        self._offset[src] = (self._offset.get(src, 0) + 1) & 0xFF
        return out


class _SplicedWriter:
    """The file a :class:`Face`'s encoder writes to: the link, through its :class:`SeqSplice`."""

    def __init__(self, link: Link, splice: SeqSplice) -> None:
        self.link, self.splice = link, splice

    def write(self, buf: bytes) -> None:
        self.link.write(self.splice.own(buf))


class Face:
    """A link-like object whose ``.mav`` sends as ``ids`` on another process's link (what FenceServer answers with)."""

    def __init__(self, link: Link, splice: SeqSplice, ids: tuple[int, int]) -> None:
        self.ids = ids
        self.mav = mavlink.MAVLink(_SplicedWriter(link, splice), srcSystem=ids[0], srcComponent=ids[1])


class Router:
    """The vehicle link and the ground-station link: forwarding between them, counted per direction and type."""

    def __init__(self, vehicle: Link, gcs: Link) -> None:
        self.vehicle, self.gcs = vehicle, gcs
        self._splice = SeqSplice()
        self._faces: dict[tuple[int, int], Face] = {}
        self.to_gcs_count: Counter[str] = Counter()
        self.to_vehicle_count: Counter[str] = Counter()
        self.taken: Counter[str] = Counter()
        """Messages from the ground station the companion took (answered itself, not forwarded)."""
        self.dropped: Counter[str] = Counter()
        """Fence transfers from the ground station before the vehicle was known (neither answered nor forwarded)."""

    def to_gcs(self, msg: Any) -> None:
        self.gcs.write(self._splice.forwarded(msg.get_msgbuf()))
        self.to_gcs_count[msg.get_type()] += 1

    def to_vehicle(self, msg: Any) -> None:
        self.vehicle.write(msg.get_msgbuf())
        self.to_vehicle_count[msg.get_type()] += 1

    def face_as(self, ids: tuple[int, int]) -> Face:
        """The ground-station side speaking as ``ids`` (the vehicle's): one per id pair, sharing the splice."""
        face = self._faces.get(ids)
        if face is None:
            face = self._faces[ids] = Face(self.gcs, self._splice, ids)
        return face

    def wait(self, timeout_s: float) -> None:
        """Until either link has bytes to read, at most ``timeout_s``."""
        fds = [link.fd for link in (self.vehicle, self.gcs) if getattr(link, "fd", None) is not None]
        if fds:
            select.select(fds, [], [], timeout_s)
        else:
            time.sleep(timeout_s)

    def report(self) -> dict[str, Any]:
        return {
            "forwarded_to_gcs": sum(self.to_gcs_count.values()),
            "forwarded_to_vehicle": dict(sorted(self.to_vehicle_count.items())),
            "taken_from_gcs": dict(sorted(self.taken.items())),
            "dropped_from_gcs": dict(sorted(self.dropped.items())),
        }
