"""Continuous push of a stream's samples over one push connection (spec 11.6).

The reader's connection sent `RECEIVE_NAME_NOTIFICATION` to a stream; the server is now the
requester on it. Each new sample is offered to a bounded `SampleBuffer` (OA-STREAM-8): the
pusher sends one `DATASAMPLE` at a time and the next only after the reader's acknowledgement
(OA-DELIV-5), so a slow reader holds at most one frame in flight and its buffer overflows — for
it alone — instead of delaying the writers or the other readers (OA-STREAM-12).
"""

from __future__ import annotations

import logging
import time

from openair.protocol.message import Message
from openair.server.aio.protocol import ServerConnection
from openair.server.core.samplebuffer import SampleBuffer
from openair.server.core.streamspec import StoredSample
from openair.server.core.streamwire import push_frame, push_message

__all__ = ["Pusher"]

log = logging.getLogger("openair.server")


class Pusher:
    """The push subscription of one connection to one stream."""

    def __init__(
        self,
        conn: ServerConnection,
        *,
        stream: str,
        capacity: int,
        window: int = 1,
        max_bytes: int = 0,
    ) -> None:
        self.conn = conn
        self.stream = stream
        self.buffer = SampleBuffer(capacity, max_bytes)  # OA-STREAM-8, OA-LIM-16
        self.window = window  # samples sent and not yet acknowledged (OA-DELIV-5)
        self.sent = 0
        self.refused = 0
        self._in_flight = 0

    @property
    def reader(self) -> str:
        """The reader's name: the `from` of its RECEIVE_NAME_NOTIFICATION."""
        return self.conn.module

    def offer(self, sample: StoredSample) -> int:
        """Take a new sample; return how many were dropped for room (OA-STREAM-8)."""
        dropped = self.buffer.offer(sample)
        self._send_more()
        return dropped

    def _send_more(self) -> None:
        while self._in_flight < self.window and not self.conn.is_closing:
            taken = self.buffer.take()
            if taken is None:
                break
            sample, dropped = taken
            msg = push_message(
                sample, stream=self.stream, to=self.reader, dropped=dropped, now_ns=time.time_ns()
            )  # OA-STREAM-12
            self._in_flight += 1
            self.conn.send_request_cb(msg, push_frame(msg), self._acked)
        self.conn.flush()

    def _acked(self, reply: Message | None, error: BaseException | None) -> None:
        self._in_flight -= 1
        if error is not None or reply is None:
            return  # the connection closed: the subscription ends with it
        self.sent += 1
        if reply.type != "RECEIVE_ACCEPT":
            self.refused += 1
            log.info(
                "event=push_refused stream=%s reader=%s reply=%s",
                self.stream,
                self.reader,
                reply.type,
            )
        self._send_more()
