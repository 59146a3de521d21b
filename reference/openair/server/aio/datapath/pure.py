"""The pure-Python data path (issue #20): frames split and acknowledgements paired at bytes level.

What it takes (everything else is left, in order, to the connection's reader and the reference
decoder; see DESIGN-NOTES "2026-11-28 — a bytes-level data path"):

* on a RESPONDER connection, a complete `Message` frame whose XML has no `binarysizes` (so it
  carries no chunks, OA-FRAME-4), is under the off-loop size and that the strict canonical
  decoder (`fastcodec.fast_decode`, the reference decoder's own first step) reads: it is routed
  exactly as the reference path routes it (`Responder.route`), without a `FrameReader`
  pass or a `Frame` object;
* on a CALLBACK or OUTBOUND connection, a complete `Message` frame whose XML is a canonical
  RECEIVE_ACCEPT (`base.ACK_XML`) answering a delivery the dispatcher sent with a callback: it
  is paired with the oldest request in flight (OA-SESS-33) without decoding — the dispatcher
  reads only the reply's type (OA-DELIV-4). A malformed or unusual ack goes to the decoder.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from openair.protocol.fastcodec import fast_decode
from openair.protocol.message import Message
from openair.server.aio.datapath.base import (
    ACK_XML,
    MARKER,
    MESSAGE_FRAME,
    MESSAGE_TAG,
    RESPLICE_MAX,
)
from openair.server.aio.pairing import is_callback
from openair.server.aio.protocol import Role
from openair.server.aio.responder import OFF_LOOP_XML

if TYPE_CHECKING:
    from openair.server.aio.protocol import ServerConnection

__all__ = ["ACK", "PurePath", "Split", "take_buffered"]

#: The reply handed to a delivery's callback for an acknowledgement recognised by its bytes.
ACK = Message(type="RECEIVE_ACCEPT", id="")

#: (start, end) of the XML of one plain Message frame, as a splitter returns them.
Split = list[tuple[int, int]]


def take_buffered(conn: ServerConnection, data: bytes) -> bytes | None:
    """Return the bytes the connection's reader still holds followed by `data`.

    None when the reader keeps them (too many, or a frame it found ahead of time): the data path
    must then leave this read to the reader too, or it would act on it out of order.
    """
    reader = conn.reader
    if not reader.buffered:
        return data
    held = reader.take_unread(RESPLICE_MAX)
    return None if held is None else held + data


def split_plain(buf: bytes, pos: int, max_xml: int) -> Split:
    """Return the XML spans of the complete plain Message frames from `pos` on.

    Plain: tag `Message`, L within `max_xml` (OA-LIM-1) and no `binarysizes` in the XML. Stops
    at the first frame that is not plain or not complete.
    """
    spans: Split = []
    n = len(buf)
    while n - pos >= 12 and buf.startswith(MESSAGE_TAG, pos):
        length = int.from_bytes(buf[pos + 8 : pos + 12], "little")
        start, end = pos + 12, pos + 12 + length
        if length > max_xml or end > n or MARKER.search(buf, start, end):
            break
        spans.append((start, end))
        pos = end
    return spans


class PurePath:
    """The data path in pure Python; `native.NativePath` swaps in the C splitter."""

    name = "python"

    def __init__(self) -> None:
        self.split = split_plain
        self.find_marker: Callable[[bytearray, int, int], bool] | None = None  # the reader's
        self.requests = 0  # requests it routed
        self.acks = 0  # acknowledgements it paired

    def feed(self, conn: ServerConnection, data: bytes, received_ns: int) -> bytes:
        buf = take_buffered(conn, data) if conn.reader.buffered else data
        if buf is None:
            return data
        if conn.role is Role.RESPONDER:
            pos = self._requests(conn, buf, received_ns)
        elif conn.role is Role.PUSH:
            return buf
        else:
            pos = self._replies(conn, buf)
        return buf[pos:] if pos else buf

    def _requests(self, conn: ServerConnection, buf: bytes, received_ns: int) -> int:
        """Route the recognised requests at the front of `buf`; return where the rest starts."""
        limits = conn.xml_limits
        max_xml = min(conn.host.limits.max_frame_xml, OFF_LOOP_XML - 1)
        pos = 0
        clock = _clock_of(conn)
        for start, end in self.split(buf, 0, max_xml):
            if clock is not None and clock() > conn.turn_ends:
                break  # this peer's slice of the loop turn is spent (issue #19)
            msg = fast_decode(buf[start:end], (), limits)
            if msg is None:
                break  # the reference decoder decides (and reports any error, OA-ERR-2)
            pos = end
            conn.frames_in += 1
            self.requests += 1
            conn.responder.route(MESSAGE_FRAME, msg, received_ns)
            if (
                conn.is_closing
                or conn.responder.held  # a WAIT_FOR_*, a reply written off the loop (OA-SESS-2)
                or conn.role is not Role.RESPONDER
            ):
                break  # the reference path stops here too (OA-FRAME-9, OA-STREAM-7)
        return pos

    def _replies(self, conn: ServerConnection, buf: bytes) -> int:
        """Pair the canonical acks at the front of `buf`; return where the rest starts."""
        limits = conn.xml_limits
        if limits.max_depth < 2:
            return 0
        pos = 0
        clock = _clock_of(conn)
        for start, end in self.split(buf, 0, limits.max_bytes):
            if clock is not None and clock() > conn.turn_ends:
                break  # this peer's slice of the loop turn is spent (issue #19)
            if not _callback_next(conn) or ACK_XML.fullmatch(buf, start, end) is None:
                break
            pos = end
            conn.frames_in += 1
            self.acks += 1
            conn.requester.resolve(ACK, None)
            if conn.is_closing:
                break
        return pos


def _clock_of(conn: ServerConnection) -> Callable[[], float] | None:
    """The clock of the connection's fairness turns (issue #19); None without fairness."""
    turns = conn.turns
    return None if turns is None or conn.turn_ends == math.inf else turns.clock


def _callback_next(conn: ServerConnection) -> bool:
    """Whether the request an ack would pair with was sent with a callback (the dispatcher's).

    Leading KEEPALIVEs are passed over by the pairing (OA-KEEP-3), as `Requester.resolve` does.
    A PING expects PING_SUCCESS, so a RECEIVE_ACCEPT answering it is a refusal whose text the
    dispatcher logs: that one goes to the decoder.
    """
    for pending in conn.machine.pending():
        if pending.type != "KEEPALIVE":
            return is_callback(pending) and pending.type != "PING"
    return False
