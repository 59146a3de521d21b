"""One asyncio `Protocol` per server connection: transport, flow control, closing (spec 2, 6.1).

Frame first, then parse (OA-FRAME-*): bytes go through a `FrameReader`; only a complete frame is
acted on. A framing error closes this connection only (OA-FRAME-6/7/9, OA-ERR-4), after a
`RECEIVE_ERROR` where the error table names one and the server is the responder.

The connection's rules — its `Role` (RESPONDER, CALLBACK, OUTBOUND, PUSH; OA-SESS-28), the role
change when a module's `Receive` frame is accepted (OA-SESS-7), the pairing of replies with the
deliveries awaiting them (OA-SESS-33, OA-KEEP-3) and the answer to a PING or KEEPALIVE sent out of
turn — are the shared sans-I/O `openair.protocol.connection.Connection` (`self.machine`, with
`SERVER_RULES`), as uvicorn's protocol holds an `h11.Connection`. The parts around it:

* `responder.Responder` — as RESPONDER every frame is a request, handed to the router with the
  time it arrived (read as the first act on receipt, OA-TIME-3) and answered in order
  (OA-SESS-2), large ones decoded off the loop (issue #19);
* `pairing.Requester` — in the other roles every frame is a reply, paired with its request;
* `writer.FrameWriter` — encoding, batching, OA-LIM-5's replies in flight;
* `timers.ConnectionTimers` — frame deadlines (OA-FRAME-12, OA-LIM-13) and KEEPALIVE (OA-KEEP-1);
* the bytes-level data path (issue #20), offered every read first.

Flow control follows uvicorn's helper: when the transport's write buffer passes its high-water
mark the connection stops reading, and reads again under the low-water mark; a peer that does not
read at all is cut off when the buffer passes a hard cap, so it can never make the server buffer
without bound. Reading also stops while a request holds the ones behind it (`Responder.held`).
"""

from __future__ import annotations

import asyncio
import logging
import time

from openair.protocol.connection import SERVER_RULES, Connection, Role
from openair.protocol.errors import (
    ConnectionClosedError,
    FrameTruncatedError,
    LimitExceededError,
    OpenAIRError,
    RemoteProtocolError,
)
from openair.protocol.framing import FrameReader, FrameTag
from openair.protocol.message import Message
from openair.protocol.xmlsafe import XmlLimits
from openair.server.aio.connhost import ConnectionHost
from openair.server.aio.datapath import DataPath, datapath_of
from openair.server.aio.pairing import Requester, Waiter, Wire, fail_waiter
from openair.server.aio.responder import Responder
from openair.server.aio.timers import ConnectionTimers
from openair.server.aio.writer import FrameWriter, encode_parts, error_reply
from openair.server.core.budgets import Budget

__all__ = ["Role", "ServerConnection"]

log = logging.getLogger("openair.server")

#: First bytes that make a main-port connection an HTTP one (the monitor, as psyProbe was;
#: OA-EXT-3 requires GET/HEAD/POST and allows the others).
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
        self.reader = FrameReader(host.limits.frame_limits())
        self.xml_limits: XmlLimits = host.limits.xml_limits()
        self.writer = FrameWriter()
        self.responder = Responder(self)  # the requests, as RESPONDER
        self.requester = Requester(self)  # the requests sent and their replies, in other roles
        self.send_request = self.requester.send_request
        self.send_request_cb = self.requester.send_request_cb
        self.finish_wait = self.responder.finish_wait
        self.flush = self.writer.flush  # the dispatcher writes its batch before it waits
        self._closing = False
        self._reading_paused = False  # the peer reads slower than we answer
        self._held_paused = False  # a request holds the ones behind it
        self.last_byte = time.monotonic()  # when the peer's last bytes arrived
        self.last_traffic = self.last_byte
        self.timers = ConnectionTimers(self)  # frame deadlines, idle KEEPALIVE
        self.frames_in = 0
        # The server's shared budget (OA-LIM-11/12); hosts built for tests may have none.
        self._budget: Budget | None = getattr(host, "budget", None)
        self._partial = 0  # unfinished-frame bytes counted in the budget (OA-LIM-12)
        # The bytes-level data path offered every read first (issue #20); None: the reference.
        self._datapath: DataPath | None = datapath_of(host)

    @property
    def role(self) -> Role:
        """The connection's role (OA-SESS-28), as the machine has it."""
        return self.machine.role

    @role.setter
    def role(self, role: Role) -> None:
        self.machine.assume(role)

    @property
    def waiting(self) -> int | None:
        """The ticket of a WAIT_FOR_* whose reply is still to come (OA-STREAM-7)."""
        return self.responder.waiting

    # -- transport callbacks ------------------------------------------------------------------

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = self.writer.transport = transport
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
        if self._datapath is not None and not self.responder.held:
            data = self._datapath.feed(self, data, received_ns)  # issue #20: bytes level first
        try:
            self.reader.feed(data)
        except RemoteProtocolError as exc:
            self._framing_error(exc)
            return
        self.process(received_ns)

    def process(self, received_ns: int) -> None:
        """Act on every complete frame buffered, unless a request holds the connection."""
        responder = self.responder
        try:
            while (
                not self._closing
                and not responder.held
                and (frame := self.reader.next_frame()) is not None
            ):
                self.frames_in += 1
                if self.machine.role is Role.RESPONDER:
                    responder.on_request(frame, received_ns)
                else:
                    self.requester.on_reply(frame)
        except RemoteProtocolError as exc:
            self._framing_error(exc)
            return
        if responder.held and not self._held_paused and self.transport is not None:
            self._held_paused = True  # buffer no more than the frames already read
            self.transport.pause_reading()
        self._hold_partial()
        self.timers.arm_deadline()

    def release_hold(self) -> None:
        """Read again after a request stopped holding the ones behind it."""
        if self._held_paused and self.transport is not None:
            self._held_paused = False
            if not self._reading_paused:
                self.transport.resume_reading()

    def _hold_partial(self) -> bool:
        """Count the bytes still buffered after processing in the server's budget (OA-LIM-12).

        Counted after the complete frames are taken, so one read (at most the transport's read
        size) may pass the budget before it is checked. Growth past the budget is
        LIMIT_EXCEEDED and closes this connection; False then.
        """
        budget = self._budget
        if budget is None or self._closing:
            return not self._closing
        held = self.reader.buffered + self.responder.decoding  # a frame in decoding is held
        if budget.hold_partial(held - self._partial):
            self._partial = held
            return True
        limit = self.host.limits.max_partial_bytes
        self._framing_error(
            LimitExceededError(
                f"unfinished frames of all connections passed max-partial-bytes ({limit} bytes)"
            )
        )
        return False

    def _taken_by_http(self, data: bytes) -> bool:
        """Hand a fresh responder connection that starts with an HTTP method to the monitor."""
        if self.role is not Role.RESPONDER or self.reader.buffered:
            return False
        # OA-EXT-3: only when a monitor is attached (and `monitor` advertised).
        if not data[:8].startswith(_HTTP_METHODS) or not self.host.http_takeover(self, data):
            return False
        self._closing = True  # the monitor owns the transport now
        return True

    def eof_received(self) -> bool | None:
        if not self._closing and self.reader.in_frame:
            self.log_error(FrameTruncatedError("the peer closed inside a frame"))  # OA-FRAME-8
        if self.responder.decoding and not self._closing:
            self.responder.eof = True  # answer the request being decoded, then close
            return True
        return None  # close the transport

    def connection_lost(self, exc: Exception | None) -> None:
        self._closing = True
        self.writer.drop()
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
            if not self._held_paused:
                self.transport.resume_reading()

    # -- sending --------------------------------------------------------------------------------

    def send(
        self, msg: Message, tag: FrameTag = FrameTag.MESSAGE, wire: Wire | None = None
    ) -> bool:
        """Write one message; return False when the connection is closing or was cut off.

        `wire` is the message's Message frame when it was written already. As the responder a
        reply is written at once, as the requester it is batched (`FrameWriter`).
        """
        transport = self.transport
        if self._closing or transport is None:
            return False
        if wire is None or tag is not FrameTag.MESSAGE:
            parts = self.encode(msg, tag)
        else:
            parts = (wire,) if isinstance(wire, bytes) else wire
        size = len(parts[0]) if len(parts) == 1 else sum(map(len, parts))  # the hot path: one
        if self.machine.role is Role.RESPONDER:
            buffered = self.writer.write_reply(transport, parts, size)
        else:
            buffered = self.writer.write_request(transport, parts, size)
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
        return True

    def encode(self, msg: Message, tag: FrameTag) -> tuple[bytes, ...]:
        """The frame of `msg` as parts to write (`writer.encode_parts`; a subclass may differ)."""
        return encode_parts(msg, tag, sender=self.name, conn_id=self.conn_id)

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
        return self.reader.in_frame

    # -- closing --------------------------------------------------------------------------------

    def _framing_error(self, exc: RemoteProtocolError) -> None:
        """Answer where the table says so, then close this connection only (OA-FRAME-6/7/9)."""
        self.log_error(exc)
        if exc.reply and self.role is Role.RESPONDER:
            self.send(error_reply(self.name, exc.reply, exc.wire_text()))  # OA-FRAME-7, -4
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
        self.writer.flush()  # batched deliveries go out before the end of stream
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
        self.writer.drop()
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
