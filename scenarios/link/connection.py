"""A MAVLink 2 connection from a URL with our system/component ids, the send helpers both ends use, the clock.

:func:`open_link` opens ``udpin:HOST:PORT``, ``udpout:HOST:PORT``, ``tcp:HOST:PORT``, ``tcpin:HOST:PORT`` or a
serial device (``/dev/ttyUSB0`` or ``/dev/ttyUSB0:57600``) through :func:`pymavlink.mavutil.mavlink_connection`,
always speaking MAVLink 2 with the ``ardupilotmega`` dialect (which includes ``common``), whatever dialect
pymavlink chose when it was first imported (``MAVLINK20`` is process-global state): the connection's encoder is
the v2.0 dialect's. Parsing is robust: garbage bytes and bad checksums become ``BAD_DATA`` messages, which
:func:`receive` drops, never an exception.

:data:`mavlink` is that dialect module (constants and message classes). The clock, :func:`now_s`, is monotonic:
link timeouts and rates never jump with the wall clock.
"""

from __future__ import annotations

import math
import os
import struct
import time
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402  (after MAVLINK20: pymavlink picks the wire protocol on import)
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

from geofence.validation import ConfigError  # noqa: E402

COMPANION_SYSTEM_ID = 255
"""ArduPilot accepts RC overrides only from SYSID_MYGCS, 255 by default."""
COMPANION_COMPONENT_ID = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER
VEHICLE_SYSTEM_ID = 1
VEHICLE_COMPONENT_ID = mavlink.MAV_COMP_ID_AUTOPILOT1

STATUSTEXT_CHARS = 50
"""The text field of one STATUSTEXT; MAVLink 2 chains longer texts by ``id`` and ``chunk_seq``."""
NAMED_VALUE_CHARS = 10

URL_SCHEMES = ("udpin", "udpout", "udp", "tcp", "tcpin", "serial")

Link = Any
"""A pymavlink ``mavfile`` (untyped upstream)."""


class LinkError(ConfigError):
    """A connection URL that cannot be opened (one line naming it)."""


def now_s() -> float:
    """The monotonic clock of the link (s)."""
    return time.monotonic()


def open_link(url: str, source_system: int = COMPANION_SYSTEM_ID, source_component: int = COMPANION_COMPONENT_ID) -> Link:
    """A MAVLink 2 connection on ``url`` sending as ``(source_system, source_component)``."""
    if not 1 <= source_system <= 255 or not 0 <= source_component <= 255:
        raise LinkError(f"{url}: source system must be 1..255 and component 0..255, got {source_system}/{source_component}")
    scheme, _, rest = url.partition(":")
    device, baud = url, 115200
    if scheme == "serial" or url.startswith("/dev/") or scheme.upper().startswith("COM"):
        dev = rest if scheme == "serial" else url
        name, _, rate = dev.rpartition(":") if dev.count(":") >= 1 and dev.rsplit(":", 1)[1].isdigit() else (dev, "", "")
        device, baud = name, int(rate) if rate else baud
    elif scheme not in URL_SCHEMES or not rest:
        raise LinkError(
            f"--connect {url!r}: expected udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or a serial device"
        )
    try:
        conn = mavutil.mavlink_connection(
            device, baud=baud, source_system=source_system, source_component=source_component, robust_parsing=True
        )
    except (OSError, ValueError) as exc:
        raise LinkError(f"--connect {url!r}: cannot open ({exc})") from None
    if getattr(conn.mav, "WIRE_PROTOCOL_VERSION", "1.0") != "2.0" or not isinstance(conn.mav, mavlink.MAVLink):
        conn.mav = mavlink.MAVLink(conn, srcSystem=source_system, srcComponent=source_component)
        conn.mav.robust_parsing = True
    conn.WIRE_PROTOCOL_VERSION = "2.0"  # (pymavlink's auto-switch would otherwise swap the encoder back)
    return conn


def receive(conn: Link, timeout_s: float = 0.0) -> Any | None:
    """The next parsed message, waiting up to ``timeout_s`` for one (None when none came); garbage and bad
    checksums are dropped, as is a datagram the parser chokes on."""
    deadline = now_s() + timeout_s
    while True:
        try:
            msg = conn.recv_msg()
        except (OSError, mavlink.MAVError, ValueError, struct.error, IndexError):
            msg = None
        if msg is not None and msg.get_type() != "BAD_DATA":
            return msg
        if msg is None:
            left = deadline - now_s()
            if left <= 0.0:
                return None
            conn.select(min(left, 0.05))


def send_heartbeat(conn: Link, mav_type: int, autopilot: int, system_status: int = mavlink.MAV_STATE_ACTIVE) -> None:
    conn.mav.heartbeat_send(mav_type, autopilot, 0, 0, system_status)


def send_statustext(conn: Link, text: str, severity: int = mavlink.MAV_SEVERITY_INFO) -> None:
    """``text`` as STATUSTEXT: one message up to 50 characters, else chunks sharing an ``id`` (MAVLink 2)."""
    data = text.encode("ascii", "replace")
    chunks = [data[i : i + STATUSTEXT_CHARS] for i in range(0, max(len(data), 1), STATUSTEXT_CHARS)]
    text_id = 0 if len(chunks) == 1 else (int(now_s() * 1000) % 65535) + 1
    for k, chunk in enumerate(chunks):
        conn.mav.statustext_send(severity, chunk, text_id, k)
    if len(chunks) > 1 and len(chunks[-1]) == STATUSTEXT_CHARS:
        conn.mav.statustext_send(severity, b"", text_id, len(chunks))  # a full last chunk: an empty one ends it


def send_named_float(conn: Link, name: str, time_boot_ms: int, value: float) -> None:
    conn.mav.named_value_float_send(int(time_boot_ms) & 0xFFFFFFFF, name.encode()[:NAMED_VALUE_CHARS], float(value))


def send_named_int(conn: Link, name: str, time_boot_ms: int, value: int) -> None:
    conn.mav.named_value_int_send(int(time_boot_ms) & 0xFFFFFFFF, name.encode()[:NAMED_VALUE_CHARS], int(value))


def decode_name(raw: Any) -> str:
    """A NAMED_VALUE_* ``name`` (bytes or str, NUL padded) as text."""
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", "replace")
    return str(raw).rstrip("\x00")


def finite_or(value: float, bound: float) -> float:
    """``value`` clipped to ``[-bound, bound]`` (inf to the bound; NaN stays NaN)."""
    if math.isnan(value):
        return value
    return max(-bound, min(bound, value))
