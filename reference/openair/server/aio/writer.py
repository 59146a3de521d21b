"""The write side of one server connection: encoding, batching, replies in flight (OA-LIM-5).

As the responder the server writes each reply at once and counts it until the transport has
flushed it: OA-LIM-5's requests in flight are the replies the peer has not read yet. As the
requester (deliveries, pushed samples) the frames of one event-loop turn go out in one write:
one system call for a burst of wakeups instead of one each. Large binary chunks (stream samples)
stay parts of their own and are never copied into one buffer (spec 11.2).
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from openair.protocol.codec import to_frame
from openair.protocol.errors import ApiMisuseError
from openair.protocol.framing import FrameTag, coalesce, encode_frame, encode_frame_parts
from openair.protocol.message import Message
from openair.protocol.times import AirTime

__all__ = ["FrameWriter", "Sliced", "encode_parts", "error_reply"]

log = logging.getLogger("openair.server")

#: Chunks of at least this many bytes are written as parts of their own, never joined (11.2).
_SEPARATE_CHUNKS = 64 * 1024


def error_reply(sender: str, kind: str, text: str, ident: str = "", to: str = "") -> Message:
    """Build a reply the connection makes itself (the router never saw the request)."""
    now = AirTime.from_ns(time.time_ns())
    return Message(type=kind, sender=sender, to=to, isresponse=ident, content=text, posted=now)


def encode_parts(msg: Message, tag: FrameTag, *, sender: str, conn_id: int) -> tuple[bytes, ...]:
    """Encode a frame; large binary chunks (stream samples) stay separate parts, uncopied.

    A message whose content XML cannot carry (OA-MSG-14) is logged and replaced by an empty
    RECEIVE_ERROR answering it.
    """
    try:
        frame = to_frame(msg, tag)
        if msg.binary and sum(len(c) for c in msg.binary) >= _SEPARATE_CHUNKS:
            return encode_frame_parts(frame)
        return (encode_frame(frame),)
    except ApiMisuseError as exc:
        log.error("event=encode_error conn=%d type=%s detail=%s", conn_id, msg.type, exc)
        reply = error_reply(sender, "RECEIVE_ERROR", "", msg.isresponse)
        return (encode_frame(to_frame(reply)),)


class FrameWriter:
    """Writes one connection's frames to its transport (set by `connection_made`)."""

    __slots__ = ("_batch", "_batch_bytes", "_unflushed", "transport", "written")

    def __init__(self) -> None:
        self.transport: asyncio.Transport | None = None
        self.written = 0  # bytes handed to the transport or the batch, ever
        self._unflushed: deque[int] = deque()  # end offsets of replies not yet flushed
        self._batch: list[bytes] = []  # frames to write at the end of this loop turn
        self._batch_bytes = 0

    def write_reply(self, transport: asyncio.Transport, parts: Sequence[bytes], size: int) -> int:
        """Write a reply at once and count it until it is flushed; return the bytes buffered."""
        for part in parts:  # at once: OA-LIM-5 counts what the peer has not read
            transport.write(part)
        self.written += size
        self._unflushed.append(self.written)
        return transport.get_write_buffer_size()

    def write_part(self, transport: asyncio.Transport, part: memoryview) -> None:
        """Write a slice of a reply written in slices (issue #19); `end_reply` ends it."""
        transport.write(part)
        self.written += len(part)

    def end_reply(self) -> None:
        """Count a reply written with `write_part` until it is flushed (OA-LIM-5)."""
        self._unflushed.append(self.written)

    def write_request(self, transport: asyncio.Transport, parts: Sequence[bytes], size: int) -> int:
        """Batch a request for the end of this loop turn; return the bytes buffered."""
        if not self._batch:
            asyncio.get_running_loop().call_soon(self.flush)
        self._batch.extend(parts)
        self._batch_bytes += size
        self.written += size
        return transport.get_write_buffer_size() + self._batch_bytes

    def flush(self) -> None:
        """Write the frames batched in this event-loop turn: small ones joined, big ones alone."""
        batch, self._batch, self._batch_bytes = self._batch, [], 0
        transport = self.transport
        if not batch or transport is None:
            return
        if len(batch) == 1:
            transport.write(batch[0])
            return
        for part in coalesce(batch, _SEPARATE_CHUNKS):
            transport.write(part)

    @property
    def batched(self) -> bool:
        """True while frames wait for the end of this loop turn."""
        return bool(self._batch)

    def drop(self) -> None:
        """Forget the frames not yet written and write no more (the connection ended)."""
        self._batch.clear()
        self._batch_bytes = 0
        self.transport = None

    def replies_in_flight(self) -> int:
        """Count the replies still waiting in the write buffer (OA-LIM-5's requests in flight)."""
        if self.transport is None:
            return 0
        flushed = self.written - self.transport.get_write_buffer_size()
        while self._unflushed and self._unflushed[0] <= flushed:
            self._unflushed.popleft()
        return len(self._unflushed)


@dataclass(slots=True)
class Sliced:
    """A large reply's frame being written a slice at a time, and what to call after it."""

    parts: tuple[bytes, ...]
    done: Callable[[], None]
    part: int = 0  # the part being written
    offset: int = 0  # bytes of it written

    @property
    def finished(self) -> bool:
        return self.part >= len(self.parts)

    def take(self, most: int) -> memoryview:
        """Return the next at most `most` bytes (never across two parts)."""
        data = self.parts[self.part]
        end = min(self.offset + most, len(data))
        piece = memoryview(data)[self.offset : end]
        if end >= len(data):
            self.part, self.offset = self.part + 1, 0
        else:
            self.offset = end
        return piece
