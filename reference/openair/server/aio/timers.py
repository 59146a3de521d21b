"""The timers of one server connection: frame deadlines and the idle KEEPALIVE.

- A frame that stops arriving (no byte for `frame_deadline_ms`, OA-FRAME-12) or trickles in
  slower than its whole deadline (`frame_total_deadline_ms`, OA-LIM-13) is discarded and the
  connection closed.
- On a connection where the server is the requester (CALLBACK, OUTBOUND, PUSH), KEEPALIVE is
  sent after `keepalive_s` of silence when nothing awaits a reply (OA-KEEP-1).

One timer handle of each kind at most, re-armed for the time left rather than on every read.
"""

from __future__ import annotations

import asyncio
import time
import weakref
from typing import TYPE_CHECKING

from openair.protocol.errors import FrameTruncatedError
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.server.aio.pairing import consume

if TYPE_CHECKING:
    from openair.server.aio.protocol import ServerConnection

__all__ = ["ConnectionTimers"]


class ConnectionTimers:
    """The deadline and KEEPALIVE timers of `conn` (owned by it, cancelled when it closes)."""

    __slots__ = ("_deadline", "_frame_began", "_frame_no", "_keepalive", "_ref")

    def __init__(self, conn: ServerConnection) -> None:
        self._ref = weakref.ref(conn)  # weak: no cycle with the connection (see Responder)
        self._deadline: asyncio.TimerHandle | None = None
        self._keepalive: asyncio.TimerHandle | None = None
        self._frame_began = 0.0  # monotonic time of the current frame's first byte
        self._frame_no = -1  # conn.frames_in when that frame began (-1: no frame begun)

    @property
    def _conn(self) -> ServerConnection:
        conn = self._ref()
        assert conn is not None, "a timer outlived its connection (cancel() was not called)"
        return conn

    def cancel(self) -> None:
        """Stop both timers (the connection is gone)."""
        for handle in (self._deadline, self._keepalive):
            if handle is not None:
                handle.cancel()
        self._deadline = self._keepalive = None

    # -- frame deadlines ------------------------------------------------------------------------

    def arm_deadline(self) -> None:
        """Watch for a frame that stops arriving (OA-FRAME-12) or takes too long (OA-LIM-13)."""
        conn = self._conn
        if not conn.in_frame or conn.is_closing:
            return
        if self._frame_no != conn.frames_in:  # a new frame began with the bytes just read
            self._frame_no = conn.frames_in
            self._frame_began = conn.last_byte
        if self._deadline is None:
            delay = self._deadline_left(time.monotonic())
            self._deadline = asyncio.get_running_loop().call_later(delay, self.check_deadline)

    def _deadline_left(self, now: float) -> float:
        """Seconds until the gap (OA-FRAME-12) or whole-frame (OA-LIM-13) deadline passes."""
        limits = self._conn.host.limits
        gap = self._conn.last_byte + limits.frame_deadline_ms / 1000
        whole = self._frame_began + limits.frame_total_deadline_ms / 1000
        return min(gap, whole) - now

    def check_deadline(self) -> None:
        """Cut the connection off when the frame in progress is past a deadline."""
        self._deadline = None
        conn = self._conn
        if conn.is_closing or not conn.in_frame:
            return
        now = time.monotonic()
        left = self._deadline_left(now)
        if left > 0:
            self._deadline = asyncio.get_running_loop().call_later(left, self.check_deadline)
            return
        limits = conn.host.limits
        if now - conn.last_byte >= limits.frame_deadline_ms / 1000:
            detail = f"no byte of the frame for {limits.frame_deadline_ms / 1000:g} s"
        else:  # OA-LIM-13: a frame trickled in slower than its whole deadline allows
            detail = f"the frame took more than {limits.frame_total_deadline_ms / 1000:g} s"
        conn.log_error(FrameTruncatedError(detail))
        conn.abort()  # OA-FRAME-12: the frame is discarded, the connection closed

    # -- KEEPALIVE ------------------------------------------------------------------------------

    def arm_keepalive(self) -> None:
        """Send KEEPALIVE after idle time on a connection where the server is the requester."""
        delay = self._conn.host.flow.keepalive_s
        self._keepalive = asyncio.get_running_loop().call_later(delay, self._check_keepalive)

    def _check_keepalive(self) -> None:
        self._keepalive = None
        conn = self._conn
        if conn.is_closing:
            return
        keepalive_s = conn.host.flow.keepalive_s
        idle = time.monotonic() - conn.last_traffic
        if idle >= keepalive_s and not conn.machine.in_flight:
            now = AirTime.from_ns(time.time_ns())
            future = conn.send_request(Message(type="KEEPALIVE", posted=now))  # OA-KEEP-1
            future.add_done_callback(consume)
            idle = 0.0
        delay = max(keepalive_s - idle, 0.001)
        self._keepalive = asyncio.get_running_loop().call_later(delay, self._check_keepalive)
