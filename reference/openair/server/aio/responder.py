"""The request side of a server connection: requests routed and answered in order (OA-SESS-2).

As RESPONDER every frame is a request. It is decoded (OA-ERR-2/3: a decode error is answered
`RECEIVE_ERROR` and the connection stays usable), handed to the router with the time it arrived
(OA-TIME-3), and its replies are sent in order. Three things hold the requests behind one:

* a WAIT_FOR_* whose reply comes later (`waiting`, OA-STREAM-7);
* a request with at least `OFF_LOOP_XML` bytes of XML, decoded on a worker thread, and a large
  reply the router hands over as `Outcome.later` (a retrieve of thousands of messages), written
  on one (`decoding`, issue #19): one client's 16 MiB post must not hold every other client for
  its parse;
* the peer's end of stream while such a request is decoded (`eof`): answered, then closed.

While one holds, the connection takes no further frame and stops reading (`held`).
"""

from __future__ import annotations

import asyncio
import logging
import time
import weakref
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING

from openair.protocol.codec import decode_with_lxml, from_frame
from openair.protocol.connection import Role
from openair.protocol.errors import LimitExceededError, RemoteProtocolError
from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message
from openair.server.aio.budgets import off_loop_executor, pause_for_the_loop
from openair.server.aio.pairing import Wire, salvage
from openair.server.aio.writer import error_reply
from openair.server.core.outcome import AwaitedReply
from openair.server.core.router import Outcome

if TYPE_CHECKING:
    from openair.server.aio.protocol import ServerConnection

__all__ = ["OFF_LOOP_XML", "Responder"]

log = logging.getLogger("openair.server")

#: Requests with at least this much XML are decoded on a worker thread, and the connection waits
#: for them: one client's 16 MiB post must not hold every other client for its parse (issue #19).
#: They take the lxml path, which lets go of the interpreter lock while it parses; the regular
#: expressions of the fast path hold it (12 ms per MiB), which would stall the loop all the same.
OFF_LOOP_XML = 256 * 1024
#: A reply written off the loop and larger than this goes to the transport a slice at a time.
SLICED_REPLY = 1024 * 1024


class Responder:
    """Routes the requests of one connection and keeps their answers in order."""

    __slots__ = ("_conn", "decoding", "eof", "waiting")

    def __init__(self, conn: ServerConnection) -> None:
        # Weak: a connection and its parts would otherwise form a cycle that only the garbage
        # collector frees, in pauses of tens of ms after a flood of connections (issue #19).
        # The callbacks that may outlive the connection's other owners hold it themselves.
        self._conn = weakref.ref(conn)
        self.waiting: int | None = None  # the ticket of a WAIT_FOR_* in progress (OA-STREAM-7)
        self.decoding = 0  # XML bytes of a request decoded off the loop (1: a reply to come)
        self.eof = False  # the peer closed its side while a request was decoded

    @property
    def conn(self) -> ServerConnection:
        """The connection whose requests these are."""
        conn = self._conn()
        assert conn is not None, "a callback outlived its connection"
        return conn

    @property
    def held(self) -> bool:
        """True while a request holds the ones behind it (OA-SESS-2)."""
        return self.waiting is not None or self.decoding != 0

    def on_request(self, frame: Frame, received_ns: int) -> None:
        """Decode a request, hand it to the router and send its replies in order (OA-SESS-2)."""
        conn = self.conn
        if frame.tag is FrameTag.BINARY:
            # OA-STREAM-11: a sample for the connection's current stream, if it has one.
            outcome = conn.host.handle_binary(conn, frame.chunks[0], received_ns=received_ns)
            for reply in outcome.replies:
                conn.send(reply)
            if outcome.close_this:
                conn.close()
            return
        if len(frame.xml) >= OFF_LOOP_XML:
            self._decode_off_loop(frame, received_ns)
            return
        try:
            msg = from_frame(frame, conn.xml_limits)
        except RemoteProtocolError as exc:
            self.undecodable(frame, exc)
            return
        self.route(frame, msg, received_ns)

    def undecodable(self, frame: Frame, exc: RemoteProtocolError) -> None:
        """Answer a request that did not decode; the connection stays usable (OA-ERR-3)."""
        conn = self.conn
        conn.log_error(exc)
        ident, sender = salvage(frame.xml, conn.xml_limits)
        conn.send(error_reply(conn.name, "RECEIVE_ERROR", exc.wire_text(), ident, sender))

    def route(self, frame: Frame, msg: Message, received_ns: int) -> None:
        """Hand a decoded request to the router and act on its outcome (OA-SESS-2)."""
        conn = self.conn
        limit = conn.host.limits.max_in_flight
        if conn.writer.replies_in_flight() >= limit:
            text = LimitExceededError(f"more than {limit} in flight").wire_text()
            conn.send(error_reply(conn.name, "RECEIVE_ERROR", text, msg.id, msg.sender))
            return  # OA-LIM-5: answered in its turn
        outcome = conn.host.handle(conn, msg, tag=frame.tag, received_ns=received_ns)
        for reply in outcome.replies:
            conn.send(reply)
        if outcome.later is not None:
            self._reply_off_loop(outcome.later)  # issue #19: a large reply
        if outcome.awaited is not None:
            self._reply_when_done(outcome.awaited)  # spec 17: a cluster's store or node
        if outcome.wait is not None:
            self.waiting = outcome.wait.ticket  # OA-STREAM-7: the reply comes later
        if outcome.close_this:
            conn.close()
        elif outcome.push_stream:
            conn.machine.turn(Role.PUSH)  # 11.6: the server is the requester now (OA-SESS-28)
            conn.module = msg.sender
        elif frame.tag is FrameTag.RECEIVE and _is_notification(msg, outcome):
            conn.machine.turn(Role.CALLBACK)  # OA-SESS-7, OA-SESS-28: the server requests now
            conn.module = msg.sender
            conn.host.callback_opened(conn, msg.sender)
            conn.timers.arm_keepalive()

    def finish_wait(self, ticket: int, reply: Message) -> None:
        """Send the deferred reply of a WAIT_FOR_* and take requests again (OA-STREAM-7)."""
        conn = self.conn
        if self.waiting != ticket or conn.is_closing:
            return
        self.waiting = None
        conn.send(reply)
        conn.release_hold()
        # Later frames already buffered are processed in a later loop turn, not inside the
        # event (another connection's post) that resolved this wait.
        asyncio.get_running_loop().call_soon(conn.process, time.time_ns())

    def _resume(self) -> None:
        """Take the frames behind a request decoded or answered off the loop again (OA-SESS-2)."""
        conn = self.conn
        if self.decoding:
            return  # that request's reply is being written off the loop in turn
        if self.eof:
            conn.process(time.time_ns())  # what the peer sent before its end, then close
            conn.close()
            return
        if self.waiting is None:
            conn.release_hold()
        conn.process(time.time_ns())

    # -- off the loop (issue #19) ---------------------------------------------------------------

    def _decode_off_loop(self, frame: Frame, received_ns: int) -> None:
        """Decode a large request on a worker thread; later frames wait for it (OA-SESS-2)."""
        self.decoding = max(len(frame.xml), 1)
        loop = asyncio.get_running_loop()
        decode = partial(decode_with_lxml, pause=pause_for_the_loop)  # lets the loop in (#19)
        future = loop.run_in_executor(
            off_loop_executor(), decode, frame.xml, frame.chunks, self.conn.xml_limits
        )
        conn = self.conn

        def decoded(done: asyncio.Future[Message]) -> None:
            assert conn is not None  # the callback holds the connection until it has run
            self._decoded(done, frame, received_ns)

        future.add_done_callback(decoded)

    def _decoded(self, done: asyncio.Future[Message], frame: Frame, received_ns: int) -> None:
        """Route a request decoded off the loop, then take the frames behind it again."""
        self.decoding = 0
        if self.conn.is_closing:
            return
        exc = done.exception()
        if isinstance(exc, RemoteProtocolError):
            self.undecodable(frame, exc)
        elif exc is not None:
            log.warning("event=decode_failed conn=%d detail=%r", self.conn.conn_id, str(exc))
            self.conn.abort()
            return
        else:
            self.route(frame, done.result(), received_ns)
        self._resume()

    def _reply_off_loop(self, later: Callable[[], tuple[Message, Wire | None]]) -> None:
        """Write a large reply on a worker thread; later requests wait for it (OA-SESS-2).

        A retrieve of thousands of messages takes a second to write (issue #19, item 6).
        """
        self.decoding = 1
        future = asyncio.get_running_loop().run_in_executor(off_loop_executor(), later)
        conn = self.conn

        def replied(done: asyncio.Future[tuple[Message, Wire | None]]) -> None:
            assert conn is not None  # the callback holds the connection until it has run
            self._replied(done)

        future.add_done_callback(replied)

    def _reply_when_done(self, pending: AwaitedReply) -> None:
        """Answer once a cluster's store or another node did; later requests wait (OA-SESS-2).

        The loop goes on serving every other connection meanwhile (spec 17).
        """
        self.decoding = 1
        conn = self.conn

        def done(_: object) -> None:
            assert conn is not None  # the callback holds the connection until it has run
            self._done(pending)

        asyncio.wrap_future(pending.done).add_done_callback(done)

    def _done(self, pending: AwaitedReply) -> None:
        self.decoding = 0
        if self.conn.is_closing:
            return
        self.conn.send(pending.reply(pending.done, time.time_ns()))
        self._resume()

    def _replied(self, done: asyncio.Future[tuple[Message, Wire | None]]) -> None:
        self.decoding = 0
        if self.conn.is_closing:
            return
        exc = done.exception()
        if exc is not None:
            log.warning("event=reply_failed conn=%d detail=%r", self.conn.conn_id, str(exc))
            self.conn.abort()
            return
        reply, wire = done.result()
        parts = (wire,) if isinstance(wire, bytes) else wire
        if parts is not None and sum(map(len, parts)) > SLICED_REPLY:
            # Written a slice at a time as the peer reads: handing the transport megabytes at
            # once copies them all in one callback (issue #19, item 6). Held until the end.
            self.decoding = 1
            self.conn.send_sliced(parts, self._sliced_done)
            return
        self.conn.send(reply, wire=wire)
        self._resume()

    def _sliced_done(self) -> None:
        self.decoding = 0
        if not self.conn.is_closing:
            self._resume()


def _is_notification(msg: Message, outcome: Outcome) -> bool:
    """Whether a `Receive` frame made its connection a callback connection (OA-SESS-7)."""
    return msg.type == "RECEIVE_NAME_NOTIFICATION" and not outcome.replies
