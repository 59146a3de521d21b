"""One asyncio `Protocol` per server connection: frames in, router outcomes out (spec 2, 6.1).

Frame first, then parse (OA-FRAME-*): bytes go through a `FrameReader`; only a complete frame is
decoded. A decode error is answered `RECEIVE_ERROR` with `NAME: detail` and the connection stays
usable (OA-ERR-2, OA-ERR-3); a framing error closes this connection only (OA-FRAME-6/7/9,
OA-ERR-4), after a `RECEIVE_ERROR` where the error table names one and the server is the
responder.

The connection's rules — its `Role` (RESPONDER, CALLBACK, OUTBOUND, PUSH; OA-SESS-28), the role
change when a module's `Receive` frame is accepted (OA-SESS-7), the pairing of replies with the
deliveries awaiting them (OA-SESS-33, OA-KEEP-3) and the answer to a PING or KEEPALIVE sent out of
turn — are the shared sans-I/O `openair.protocol.connection.Connection` (`self.machine`, with
`SERVER_RULES`), as uvicorn's protocol holds an `h11.Connection`. As RESPONDER every frame is a
request, handed to the router with the time it arrived (read as the first act on receipt,
OA-TIME-3) and answered in order (OA-SESS-2); in the other roles every frame is a reply.

Flow control follows uvicorn's helper: when the transport's write buffer passes its high-water
mark the connection stops reading, and reads again under the low-water mark; a peer that does not
read at all is cut off when the buffer passes a hard cap, so it can never make the server buffer
without bound.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections import deque

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.connection import SERVER_RULES, Connection, Role, answer_type
from openair.protocol.errors import (
    ApiMisuseError,
    ConnectionClosedError,
    FrameTruncatedError,
    LimitExceededError,
    OpenAIRError,
    RemoteProtocolError,
)
from openair.protocol.framing import Frame, FrameReader, FrameTag, encode_frame, encode_frame_parts
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.xmlsafe import XmlLimits
from openair.server.aio.connhost import ConnectionHost
from openair.server.aio.datapath import DataPath, datapath_of
from openair.server.aio.offloop import OFF_LOOP_XML, decode_off_loop, reply_off_loop
from openair.server.aio.pairing import (
    ReplyCallback,
    Waiter,
    Wire,
    fail_waiter,
    resolve,
    salvage,
)
from openair.server.aio.timers import ConnectionTimers
from openair.server.core.budgets import Budget
from openair.server.core.router import Outcome

__all__ = ["Role", "ServerConnection"]

log = logging.getLogger("openair.server")

#: First bytes that make a main-port connection an HTTP one (the monitor, as psyProbe was;
#: OA-EXT-3 requires GET/HEAD/POST and allows the others).
#: Chunks of at least this many bytes are written as parts of their own, never joined (11.2).
_SEPARATE_CHUNKS = 64 * 1024
_HTTP_METHODS = (b"GET ", b"HEAD ", b"POST ", b"PUT ", b"OPTIONS ", b"DELETE ")


class ServerConnection(asyncio.Protocol):
    """One TCP connection of the server, in any of its four roles (`Role`, OA-SESS-28)."""

    def __init__(
        self, host: ConnectionHost, role: Role = Role.RESPONDER, *, name: str = "CNS"
    ) -> None:
        self.host = host
        #: The connection's rules: role, pairing, out-of-turn answers (sans-I/O, shared).
        self.machine: Connection[Waiter] = Connection(role, rules=SERVER_RULES)
        self.name = name  # `from` of the replies the adapter makes itself
        self.conn_id = -1
        self.module = ""  # the module this CALLBACK or OUTBOUND connection serves
        self.peer = ("", 0)
        self.transport: asyncio.Transport | None = None
        self.closed = asyncio.get_running_loop().create_future()
        self._reader = FrameReader(host.limits.frame_limits())
        self._xml_limits: XmlLimits = host.limits.xml_limits()
        self._closing = False
        self._reading_paused = False
        self._written = 0
        self._unflushed: deque[int] = deque()  # end offsets of replies not yet flushed
        self._batch: list[bytes] = []  # frames to write at the end of this loop turn
        self._batch_bytes = 0
        self.last_byte = time.monotonic()  # when the peer's last bytes arrived
        self.last_traffic = self.last_byte
        self.timers = ConnectionTimers(self)  # frame deadlines, idle KEEPALIVE
        self.frames_in = 0
        # A WAIT_FOR_* in progress (OA-STREAM-7): later requests wait behind it (OA-SESS-2).
        self.waiting: int | None = None
        self._wait_paused = False
        # The server's shared budget (OA-LIM-11/12); hosts built for tests may have none.
        self._budget: Budget | None = getattr(host, "budget", None)
        self._partial = 0  # unfinished-frame bytes counted in the budget (OA-LIM-12)
        self._decoding = 0  # XML bytes of a request being decoded off the loop (0: none)
        self._eof = False  # the peer closed its side while a request was being decoded
        # The bytes-level data path offered every read first (issue #20); None: the reference.
        self._datapath: DataPath | None = datapath_of(host)

    @property
    def role(self) -> Role:
        """The connection's role (OA-SESS-28), as the machine has it."""
        return self.machine.role

    @role.setter
    def role(self, role: Role) -> None:
        self.machine.assume(role)

    # -- transport callbacks ------------------------------------------------------------------

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        peer = transport.get_extra_info("peername")
        self.peer = (str(peer[0]), int(peer[1])) if peer else ("", 0)
        # The transport's own marks drive pause_writing/resume_writing (the flow-control helper).
        transport.set_write_buffer_limits(self.host.flow.high_water, self.host.flow.low_water)
        if self.role is Role.RESPONDER:
            self.conn_id = self.host.connection_opened(self)
        else:
            self.timers.arm_keepalive()

    def data_received(self, data: bytes) -> None:
        received_ns = time.time_ns()  # OA-TIME-3: the first act on receipt
        if self._closing:
            return  # OA-FRAME-9: nothing after a failure or a close is processed
        self.last_byte = self.last_traffic = time.monotonic()
        if self.frames_in == 0 and self._taken_by_http(data):
            return
        if self._datapath is not None and self.waiting is None and not self._decoding:
            data = self._datapath.feed(self, data, received_ns)  # issue #20: bytes level first
        try:
            self._reader.feed(data)
        except RemoteProtocolError as exc:
            self._framing_error(exc)
            return
        self._process(received_ns)

    def _process(self, received_ns: int) -> None:
        """Act on every complete frame buffered, unless a wait holds the connection."""
        try:
            while (
                not self._closing
                and self.waiting is None
                and not self._decoding
                and (frame := self._reader.next_frame()) is not None
            ):
                self.frames_in += 1
                self._on_frame(frame, received_ns)
        except RemoteProtocolError as exc:
            self._framing_error(exc)
            return
        held = self.waiting is not None or self._decoding
        if held and not self._wait_paused and self.transport is not None:
            self._wait_paused = True  # buffer no more than the frames already read
            self.transport.pause_reading()
        self._hold_partial()
        self.timers.arm_deadline()

    def _hold_partial(self) -> bool:
        """Count the bytes still buffered after processing in the server's budget (OA-LIM-12).

        Counted after the complete frames are taken, so one read (at most the transport's read
        size) may pass the budget before it is checked. Growth past the budget is
        LIMIT_EXCEEDED and closes this connection; False then.
        """
        budget = self._budget
        if budget is None or self._closing:
            return not self._closing
        held = self._reader.buffered + self._decoding  # a frame in decoding is still held
        if budget.hold_partial(held - self._partial):
            self._partial = held
            return True
        self._framing_error(
            LimitExceededError(
                f"unfinished frames of all connections passed max-partial-bytes"
                f" ({self.host.limits.max_partial_bytes} bytes)"
            )
        )
        return False

    def finish_wait(self, ticket: int, reply: Message) -> None:
        """Send the deferred reply of a WAIT_FOR_* and take requests again (OA-STREAM-7)."""
        if self.waiting != ticket or self._closing:
            return
        self.waiting = None
        self._send(reply)
        if self._wait_paused and self.transport is not None:
            self._wait_paused = False
            if not self._reading_paused:
                self.transport.resume_reading()
        # Later frames already buffered are processed in a later loop turn, not inside the
        # event (another connection's post) that resolved this wait.
        asyncio.get_running_loop().call_soon(self._process, time.time_ns())

    def _taken_by_http(self, data: bytes) -> bool:
        """Hand a fresh responder connection that starts with an HTTP method to the monitor."""
        if self.role is not Role.RESPONDER or self._reader.buffered:
            return False
        # OA-EXT-3: only when a monitor is attached (and `monitor` advertised).
        if not data[:8].startswith(_HTTP_METHODS) or not self.host.http_takeover(self, data):
            return False
        self._closing = True  # the monitor owns the transport now
        return True

    def eof_received(self) -> bool | None:
        if not self._closing and self._reader.in_frame:
            self.log_error(FrameTruncatedError("the peer closed inside a frame"))  # OA-FRAME-8
        if self._decoding and not self._closing:
            self._eof = True  # answer the request being decoded, then close
            return True
        return None  # close the transport

    def connection_lost(self, exc: Exception | None) -> None:
        self._closing = True
        if self._budget is not None and self._partial:
            self._budget.hold_partial(-self._partial)  # OA-LIM-12: released with the connection
            self._partial = 0
        self.timers.cancel()
        reason = f"connection lost: {exc}" if exc else "connection closed"
        for pending in self.machine.peer_closed():
            fail_waiter(pending.token, ConnectionClosedError(reason))
        if self.role is not Role.OUTBOUND:
            self.host.connection_lost(self)
        if not self.closed.done():
            self.closed.set_result(None)
        log.debug(
            "event=close conn=%d role=%s peer=%s:%d", self.conn_id, self.role.value, *self.peer
        )

    def pause_writing(self) -> None:
        # The peer reads slower than we answer: stop reading its requests until it catches up.
        if self.transport is not None and not self._reading_paused:
            self._reading_paused = True
            self.transport.pause_reading()

    def resume_writing(self) -> None:
        if self.transport is not None and self._reading_paused and not self._closing:
            self._reading_paused = False
            if not self._wait_paused:
                self.transport.resume_reading()

    # -- frames ---------------------------------------------------------------------------------

    def _on_frame(self, frame: Frame, received_ns: int) -> None:
        """Act on one complete frame according to the connection's role."""
        if self.role is Role.RESPONDER:
            self._on_request(frame, received_ns)
        else:
            self._on_reply(frame)

    def _on_request(self, frame: Frame, received_ns: int) -> None:
        """Decode a request, hand it to the router and send its replies in order (OA-SESS-2)."""
        if frame.tag is FrameTag.BINARY:
            # OA-STREAM-11: a sample for the connection's current stream, if it has one.
            outcome = self.host.handle_binary(self, frame.chunks[0], received_ns=received_ns)
            for reply in outcome.replies:
                self._send(reply)
            if outcome.close_this:
                self.close()
            return
        if len(frame.xml) >= OFF_LOOP_XML:
            decode_off_loop(self, frame, received_ns)
            return
        try:
            msg = from_frame(frame, self._xml_limits)
        except RemoteProtocolError as exc:
            self._undecodable(frame, exc)
            return
        self._route(frame, msg, received_ns)

    def _undecodable(self, frame: Frame, exc: RemoteProtocolError) -> None:
        self.log_error(exc)
        ident, sender = salvage(frame.xml, self._xml_limits)
        reply = self._error_reply("RECEIVE_ERROR", exc.wire_text(), ident, sender)
        self._send(reply)  # OA-ERR-3: the connection stays usable

    def _resume(self) -> None:
        """Take the frames behind a request decoded or answered off the loop again (OA-SESS-2)."""
        if self._decoding:
            return  # that request's reply is being written off the loop in turn
        if self._eof:
            self._process(time.time_ns())  # what the peer sent before its end, then close
            self.close()
            return
        if self.waiting is None and self._wait_paused and self.transport is not None:
            self._wait_paused = False
            if not self._reading_paused:
                self.transport.resume_reading()
        self._process(time.time_ns())

    def _route(self, frame: Frame, msg: Message, received_ns: int) -> None:
        """Hand a decoded request to the router and act on its outcome (OA-SESS-2)."""
        if self._in_flight() >= self.host.limits.max_in_flight:
            exc2 = LimitExceededError(f"more than {self.host.limits.max_in_flight} in flight")
            self._send(self._error_reply("RECEIVE_ERROR", exc2.wire_text(), msg.id, msg.sender))
            return  # OA-LIM-5: answered in its turn
        outcome = self.host.handle(self, msg, tag=frame.tag, received_ns=received_ns)
        for reply in outcome.replies:
            self._send(reply)
        if outcome.later is not None:
            reply_off_loop(self, outcome.later)  # issue #19: a large reply
        if outcome.wait is not None:
            self.waiting = outcome.wait.ticket  # OA-STREAM-7: the reply comes later
        if outcome.close_this:
            self.close()
        elif outcome.push_stream:
            self.machine.turn(Role.PUSH)  # 11.6: the server is the requester now (OA-SESS-28)
            self.module = msg.sender
        elif frame.tag is FrameTag.RECEIVE and _is_notification(msg, outcome):
            self.machine.turn(Role.CALLBACK)  # OA-SESS-7, OA-SESS-28: the server requests now
            self.module = msg.sender
            self.host.callback_opened(self, msg.sender)
            self.timers.arm_keepalive()

    def _on_reply(self, frame: Frame) -> None:
        """Pair a reply with the oldest delivery awaiting one (OA-SESS-33)."""
        try:
            msg = from_frame(frame, self._xml_limits)
        except RemoteProtocolError as exc:
            self.log_error(exc)
            self._resolve(None, exc)  # an unreadable reply is still the reply (OA-SESS-33)
            return
        if self.machine.is_out_of_turn(msg):
            self._send(msg.reply(answer_type(msg.type), sender=self.name))  # OA-SESS-10, KEEP-2
            return
        self._resolve(msg, None)

    def _resolve(self, msg: Message | None, error: Exception | None) -> None:
        """Hand a reply (or its decode error) to the delivery it answers (`SERVER_RULES`)."""
        resolve(self.machine, msg, error, conn_id=self.conn_id, module=self.module)

    # -- sending --------------------------------------------------------------------------------

    def _error_reply(self, kind: str, text: str, ident: str = "", sender: str = "") -> Message:
        """Build a reply the adapter makes itself (the router never saw the request)."""
        now = AirTime.from_ns(time.time_ns())
        return Message(
            type=kind, sender=self.name, to=sender, isresponse=ident, content=text, posted=now
        )

    def _send(
        self, msg: Message, tag: FrameTag = FrameTag.MESSAGE, wire: Wire | None = None
    ) -> bool:
        """Write one message; return False when the connection is closing or was cut off.

        `wire` is the message's Message frame when it was written already.
        """
        if self._closing or self.transport is None:
            return False
        if wire is None or tag is not FrameTag.MESSAGE:
            parts = self._encode(msg, tag)
        else:
            parts = (wire,) if isinstance(wire, bytes) else wire
        size = len(parts[0]) if len(parts) == 1 else sum(map(len, parts))  # the hot path: one
        if self.role is Role.RESPONDER:
            for part in parts:  # at once: OA-LIM-5 counts what the peer has not read
                self.transport.write(part)
            buffered = self.transport.get_write_buffer_size()
        else:
            # As the requester (deliveries), the frames of one event-loop turn go out in one
            # write: one system call for a burst of wakeups instead of one each.
            if not self._batch:
                asyncio.get_running_loop().call_soon(self._flush)
            self._batch.extend(parts)
            self._batch_bytes += size
            buffered = self.transport.get_write_buffer_size() + self._batch_bytes
        self._written += size
        self.last_traffic = time.monotonic()
        if buffered > self.host.flow.hard_cap:
            log.warning(
                "event=cut_off conn=%d peer=%s:%d detail=%s",
                self.conn_id,
                *self.peer,
                "write buffer over the hard cap",
            )
            self.abort()
            return False
        if self.role is Role.RESPONDER:
            self._unflushed.append(self._written)
        return True

    def _encode(self, msg: Message, tag: FrameTag) -> tuple[bytes, ...]:
        """Encode a frame; large binary chunks (stream samples) stay separate parts, uncopied."""
        try:
            frame = to_frame(msg, tag)
            if msg.binary and sum(len(c) for c in msg.binary) >= _SEPARATE_CHUNKS:
                return encode_frame_parts(frame)
            return (encode_frame(frame),)
        except ApiMisuseError as exc:  # OA-MSG-14: content XML cannot carry
            log.error("event=encode_error conn=%d type=%s detail=%s", self.conn_id, msg.type, exc)
            reply = self._error_reply("RECEIVE_ERROR", "", msg.isresponse)
            return (encode_frame(to_frame(reply)),)

    def _flush(self) -> None:
        """Write the frames batched in this event-loop turn: small ones joined, big ones alone."""
        batch, self._batch, self._batch_bytes = self._batch, [], 0
        if not batch or self.transport is None or self._closing:
            return
        if len(batch) == 1:
            self.transport.write(batch[0])
            return
        small: list[bytes] = []
        for part in batch:
            if len(part) < _SEPARATE_CHUNKS:
                small.append(part)
                continue
            if small:
                self.transport.write(b"".join(small))
                small = []
            self.transport.write(part)
        if small:
            self.transport.write(b"".join(small))

    def _in_flight(self) -> int:
        """Count the replies still waiting in the write buffer (OA-LIM-5's requests in flight)."""
        if self.transport is None:
            return 0
        flushed = self._written - self.transport.get_write_buffer_size()
        while self._unflushed and self._unflushed[0] <= flushed:
            self._unflushed.popleft()
        return len(self._unflushed)

    def send_request(self, msg: Message, wire: Wire | None = None) -> asyncio.Future[Message]:
        """Send a request on a CALLBACK or OUTBOUND connection; return its reply's future.

        `wire`, when given, is the Message frame of `msg` already written (sent as it is).
        A `noreply` message (only sent to a module that declared `noreply`) expects no reply:
        its future is already resolved with the message itself (OA-MSG-15).
        """
        if self.role is Role.RESPONDER:
            raise ApiMisuseError("the server is not the requester on this connection")
        future: asyncio.Future[Message] = asyncio.get_running_loop().create_future()
        if self._closing:
            future.set_exception(ConnectionClosedError("the connection is closed"))
            return future
        self.machine.send_request(msg.id, msg.type, future, expects_reply=not msg.noreply)
        if not self._send(msg, wire=wire):
            if not future.done():
                future.set_exception(ConnectionClosedError("the connection was cut off"))
        elif msg.noreply:
            future.set_result(msg)
        return future

    def send_request_cb(self, msg: Message, wire: Wire | None, callback: ReplyCallback) -> None:
        """Send a request like `send_request`, but hand the outcome to `callback` (no future).

        The callback runs at most once, possibly before this returns (a closed connection,
        `noreply`).
        """
        if self.role is Role.RESPONDER:
            raise ApiMisuseError("the server is not the requester on this connection")
        if self._closing:
            callback(None, ConnectionClosedError("the connection is closed"))
            return
        pending = self.machine.send_request(
            msg.id, msg.type, callback, expects_reply=not msg.noreply
        )
        if not self._send(msg, wire=wire):
            if pending is not None:
                pending.token = None  # it keeps its place in the pairing, but says nothing
            callback(None, ConnectionClosedError("the connection was cut off"))
        elif msg.noreply:
            callback(msg, None)

    def flush(self) -> None:
        """Write the frames batched so far now (the dispatcher calls it before it waits)."""
        if self._batch:
            self._flush()

    @property
    def in_flight(self) -> int:
        """How many requests sent on this connection await their reply."""
        return self.machine.in_flight

    @property
    def is_closing(self) -> bool:
        """True once the connection is failed, closing or closed."""
        return self._closing

    @property
    def in_frame(self) -> bool:
        """True while part of a frame is buffered (its deadlines run; OA-FRAME-12, OA-LIM-13)."""
        return self._reader.in_frame

    # -- closing --------------------------------------------------------------------------------

    def _framing_error(self, exc: RemoteProtocolError) -> None:
        """Answer where the table says so, then close this connection only (OA-FRAME-6/7/9)."""
        self.log_error(exc)
        if exc.reply and self.role is Role.RESPONDER:
            self._send(self._error_reply(exc.reply, exc.wire_text()))  # OA-FRAME-7, OA-FRAME-4
            self.close()
        else:
            self.abort()  # OA-FRAME-6: at once, without a reply

    def close(self, *, linger: bool = True) -> None:
        """Stop processing, flush what was written, and end the connection.

        With `linger` the write side is shut first so the peer reads every reply before the end
        of stream, and bytes the peer still sends are discarded for at most `linger_s` (a
        lingering close: closing with unread bytes resets the connection, which can destroy the
        last reply). Without it the transport closes as soon as its buffer is flushed.
        """
        if self.transport is None:
            return
        if self._closing:
            if not linger:
                self.transport.close()  # end a lingering close now (at shutdown)
            return
        self._flush()  # batched deliveries go out before the end of stream
        self._closing = True
        self.resume_writing()
        transport = self.transport
        if linger and transport.can_write_eof():
            try:
                transport.write_eof()
            except OSError:  # the peer is already gone (ENOTCONN): nothing left to linger for
                transport.abort()
                return
            transport.resume_reading()
            loop = asyncio.get_running_loop()
            loop.call_later(self.host.flow.linger_s, transport.abort)
        else:
            transport.close()

    def abort(self) -> None:
        """End the connection at once, dropping anything unsent."""
        self._closing = True
        self._batch.clear()
        self._batch_bytes = 0
        if self.transport is not None:
            self.transport.abort()

    def log_error(self, exc: OpenAIRError) -> None:
        log.info(
            "event=protocol_error conn=%d role=%s peer=%s:%d error=%s detail=%r",
            self.conn_id,
            self.role.value,
            *self.peer,
            exc.name,
            exc.detail,
        )


def _is_notification(msg: Message, outcome: Outcome) -> bool:
    """Whether a `Receive` frame made its connection a callback connection (OA-SESS-7)."""
    return msg.type == "RECEIVE_NAME_NOTIFICATION" and not outcome.replies
