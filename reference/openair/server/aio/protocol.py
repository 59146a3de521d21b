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
* the bytes-level data path (issue #20), offered every read first;
* `fairness.Turns` — each peer address a bounded slice of every loop turn (issue #19).

Flow control follows uvicorn's helper: when the transport's write buffer passes its high-water
mark the connection stops reading, and reads again under the low-water mark; a peer that does not
read at all is cut off when the buffer passes a hard cap, so it can never make the server buffer
without bound. Reading also stops while a request holds the ones behind it (`Responder.held`).
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Callable, Sequence

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
from openair.server.aio.datapath.base import RESPLICE_MAX
from openair.server.aio.fairness import Turns
from openair.server.aio.pairing import Requester, Waiter, Wire, fail_waiter
from openair.server.aio.responder import Responder
from openair.server.aio.timers import ConnectionTimers
from openair.server.aio.writer import FrameWriter, Sliced, encode_parts, error_reply
from openair.server.core.budgets import Budget

__all__ = ["Role", "ServerConnection"]

log = logging.getLogger("openair.server")

#: First bytes that make a main-port connection an HTTP one (the monitor, as psyProbe was;
#: OA-EXT-3 requires GET/HEAD/POST and allows the others).
#: How much of a large reply goes to the transport at a time (`send_sliced`, issue #19).
_SLICE = 256 * 1024
_HTTP_METHODS = (b"GET ", b"HEAD ", b"POST ", b"PUT ", b"OPTIONS ", b"DELETE ")


#: The buffer every connection's reads land in (`get_buffer`): asyncio's own reads allocate
#: 256 KiB a read, which past glibc's fixed mmap threshold (`budgets.return_large_buffers`) is
#: an mmap, a shrinking mremap and a munmap per read — three system calls per message at a
#: modest rate (issue #20). The loop reads into it and hands it back before any other read.
_READ_SIZE = 256 * 1024
_READ_BUFFER = memoryview(bytearray(_READ_SIZE))


class ServerConnection(asyncio.BufferedProtocol):
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
        # The bytes-level data path offered every read first (issue #20); None: the reference.
        self._datapath: DataPath | None = datapath_of(host)
        self.reader = self._new_reader()
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
        self._turn_paused = False  # this peer spent its slice: waiting for a later turn
        self._in_turn = False  # `turn_ends` was set by the caller (a read, or the turn)
        self._turn_ns = 0  # when the oldest bytes waiting for that turn arrived (OA-TIME-3)
        self._last_read = 0  # bytes of the last read (what reading again will likely cost)
        self._kept: list[bytes] = []  # reads kept for this peer's next turn, unread
        self._kept_bytes = 0
        #: A large reply being written a slice at a time (`send_sliced`).
        self._sliced: Sliced | None = None
        self._slice_due = False  # a call to `_write_slices` is scheduled
        #: When this peer's slice of the loop turn runs out (`Turns.clock`); frame loops stop
        #: there and wait for a later turn (issue #19). Infinite without fairness.
        self.turn_ends = math.inf
        self.last_byte = time.monotonic()  # when the peer's last bytes arrived
        self.last_traffic = self.last_byte
        self.timers = ConnectionTimers(self)  # frame deadlines, idle KEEPALIVE
        self.frames_in = 0
        # The server's shared budget (OA-LIM-11/12); hosts built for tests may have none.
        self._budget: Budget | None = getattr(host, "budget", None)
        self._partial = 0  # unfinished-frame bytes counted in the budget (OA-LIM-12)
        self.turns: Turns | None = getattr(host, "turns", None)

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
        if self.turns is not None:
            self.turns.enter(self.peer[0])
        if self.role is Role.RESPONDER:
            self.conn_id = self.host.connection_opened(self)
        else:
            self.timers.arm_keepalive()

    def get_buffer(self, sizehint: int) -> memoryview:
        """Where the transport reads to: the loop's one buffer (read, then `buffer_updated`)."""
        return _READ_BUFFER

    def buffer_updated(self, nbytes: int) -> None:
        """Take the `nbytes` just read as `data_received` would.

        The rest of a large frame goes to the reader as a view of the loop's buffer, which the
        reader copies once, into the frame (the data path leaves such reads to it): a copy of
        each read first, a fresh mapping whose pages faulted in, cost the loop half a
        millisecond per MiB (issue #19). Anything else is a copy of exactly the bytes read.
        """
        view = _READ_BUFFER[:nbytes]
        self.data_received(view if self.reader.buffered > RESPLICE_MAX else view.tobytes())

    def data_received(self, data: bytes | memoryview) -> None:
        received_ns = time.time_ns()  # OA-TIME-3: the first act on receipt
        if self._closing:
            return  # OA-FRAME-9: nothing after a failure or a close is processed
        self.last_byte = self.last_traffic = time.monotonic()
        turns = self.turns
        if turns is None or not (turns.shared or turns.waiting):
            self._receive(data, received_ns)  # no one to be fair to
            return
        peer = self.peer[0]
        began = turns.clock()
        self._last_read = len(data)
        if not turns.may_run(peer):
            # This peer spent its slice of the turn (issue #19): keep the bytes, act later.
            if not self._kept:
                self._turn_ns = received_ns
            self._kept.append(bytes(data))  # a view of the loop's buffer is only lent
            self._kept_bytes += len(data)
            if self._hold_partial():
                self._wait_turn(received_ns)
            turns.charge(peer, turns.clock() - began + len(data) * turns.read_cost)
            return
        self.turn_ends = turns.deadline(peer) - len(data) * turns.read_cost
        self._in_turn = True
        try:
            self._receive(data, received_ns)
        finally:
            self._in_turn = False
            turns.charge(peer, turns.clock() - began + len(data) * turns.read_cost)

    def _receive(self, data: bytes | memoryview, received_ns: int) -> None:
        """Act on one read: the monitor's if it starts HTTP, else the frames in it."""
        if isinstance(data, memoryview):  # the rest of a large frame (`buffer_updated`)
            if self._feed_reader(data):
                self.process(received_ns)
            return
        if self.frames_in == 0 and self._taken_by_http(data):
            return
        self._take(data, received_ns)

    def _take(self, data: bytes, received_ns: int) -> None:
        """Act on one read: the data path first, then the reader and the reference path."""
        if self._datapath is not None and not self.responder.held:
            data = self._datapath.feed(self, data, received_ns)  # issue #20: bytes level first
            held = self._partial or self._kept_bytes or self.responder.held
            if not (data or held or self.reader.buffered):
                return  # it took every byte and nothing is held: `process` has no work
        if self._feed_reader(data):
            self.process(received_ns)

    def _feed_reader(self, data: bytes | memoryview) -> bool:
        """Buffer `data` in the frame reader; False (and closed) after a framing error."""
        try:
            self.reader.feed(data)
        except RemoteProtocolError as exc:
            self._framing_error(exc)
            return False
        return True

    def process(self, received_ns: int) -> None:
        """Act on the complete frames buffered, unless a request holds the connection.

        With fairness (issue #19) it stops when this peer's slice of the loop turn is spent
        and the connection waits for a later turn; otherwise it takes every complete frame.
        """
        responder = self.responder
        turns = self.turns
        if turns is not None and not self._in_turn:
            self.turn_ends = turns.deadline(self.peer[0])
        clock = turns.clock if turns is not None and self.turn_ends != math.inf else None
        out_of_turn = False
        try:
            while not self._closing and not responder.held:
                if clock is not None and clock() > self.turn_ends:
                    out_of_turn = True
                    break
                frame = self.reader.next_frame()
                if frame is None:
                    break
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
        if self._hold_partial() and out_of_turn and self.reader.buffered:
            self._wait_turn(received_ns)
        self.timers.arm_deadline()

    def _wait_turn(self, received_ns: int) -> None:
        """Read nothing more until this peer's next slice of a loop turn (issue #19)."""
        if self._turn_paused or self._closing or self.turns is None:
            return
        self._turn_paused = True
        self._turn_ns = received_ns
        if self.transport is not None:
            self.transport.pause_reading()
        self.turns.wait(self.peer[0], self._take_turn)

    def _take_turn(self) -> None:
        """This peer's turn: act on what was kept, then read again (issue #19)."""
        turns = self.turns
        if not self._turn_paused or self._closing or turns is None:
            return
        self._turn_paused = False
        peer = self.peer[0]
        began = turns.clock()
        self.turn_ends = turns.deadline(peer)
        self._in_turn = True
        try:
            kept, self._kept, self._kept_bytes = self._kept, [], 0
            if not kept:  # the frames the reader holds (few go through the data path again)
                self._take(b"", self._turn_ns)
            for data in kept:  # the reads kept while waiting, in order
                if self._closing:
                    break
                self._receive(data, self._turn_ns)
        finally:
            self._in_turn = False
            # Reading again lets the next read happen in the next turn: charged now, so a
            # turn does not let every waiting connection of a peer read at once.
            turns.charge(peer, turns.clock() - began + self._last_read * turns.read_cost)
        self._read_again()

    def _read_again(self) -> None:
        """Resume reading unless a slow reader, a held request or a turn still stops it."""
        if (
            self.transport is not None
            and not self._closing
            and not (self._reading_paused or self._held_paused or self._turn_paused)
        ):
            self.transport.resume_reading()

    def release_hold(self) -> None:
        """Read again after a request stopped holding the ones behind it."""
        if self._held_paused and self.transport is not None:
            self._held_paused = False
            self._read_again()

    def _hold_partial(self) -> bool:
        """Count the bytes still buffered after processing in the server's budget (OA-LIM-12).

        Counted after the complete frames are taken, so one read (at most the transport's read
        size) may pass the budget before it is checked. Growth past the budget is
        LIMIT_EXCEEDED and closes this connection; False then.
        """
        budget = self._budget
        if budget is None or self._closing:
            return not self._closing
        # A frame in decoding is held; so are reads kept for a later turn.
        held = self.reader.buffered + self.responder.decoding + self._kept_bytes
        if budget.hold_partial(held - self._partial):
            self._partial = held
            return True
        limit = self.host.limits.max_partial_bytes
        self._framing_error(
            LimitExceededError(
                f"unfinished frames of all connections passed max-partial-bytes ({limit} bytes)"
            )
        )
        self._drop_unfinished()
        return False

    def _new_reader(self) -> FrameReader:
        """A frame reader with the data path's search for `binarysizes` when it has one (#19)."""
        find = self._datapath.find_marker if self._datapath is not None else None
        return FrameReader(self.host.limits.frame_limits(), find_marker=find)

    def _drop_unfinished(self) -> None:
        """Forget the unfinished bytes of a connection that closes: nothing more is read.

        Given back to the budget of unfinished frames (OA-LIM-12) now, not when the connection
        is lost: a lingering close lasts until the peer has read the error, and the bytes of
        the refused read were in no budget (issue #19: 24 refused connections of `make
        stress`'s slowloris held 4-6 MiB past max-partial-bytes). A frame in decoding stays
        counted until the connection is lost.
        """
        self.reader = self._new_reader()  # the old one's buffer goes with it
        self._kept, self._kept_bytes = [], 0
        decoding = self.responder.decoding
        if self._budget is not None and self._partial > decoding:
            self._budget.hold_partial(decoding - self._partial)
            self._partial = decoding

    def _taken_by_http(self, data: bytes) -> bool:
        """Hand a fresh responder connection that starts with an HTTP method to the monitor."""
        if self.role is not Role.RESPONDER or self.reader.buffered:
            return False
        # OA-EXT-3: only when a monitor is attached (and `monitor` advertised).
        if not data[:8].startswith(_HTTP_METHODS) or not self.host.http_takeover(self, data):
            return False
        self._closing = True  # the monitor owns the transport now
        if self.turns is not None:
            self.turns.leave(self.peer[0])  # no connection_lost comes for it here
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
        _break_read_cycle(self.transport)
        log.debug(
            "event=close conn=%d role=%s peer=%s:%d", self.conn_id, self.role.value, *self.peer
        )
        turns = self.turns
        if turns is not None and self.role is not Role.OUTBOUND and not turns.may_run(self.peer[0]):
            # What the server does when a module goes (Lost notices, its queue) is this peer's
            # work too: a hundred connections closed at once wait for their turns (issue #19).
            turns.wait(self.peer[0], self._lost)
            return
        self._lost()

    def _lost(self) -> None:
        """Tell the server the connection is gone (in this peer's turn), then `closed`."""
        if self.turns is not None and self.transport is not None:
            self.turns.leave(self.peer[0])
        if self.role is not Role.OUTBOUND:
            turns = self.turns
            began = turns.clock() if turns is not None else 0.0
            self.host.connection_lost(self)
            if turns is not None:
                turns.charge(self.peer[0], turns.clock() - began)
        if not self.closed.done():
            self.closed.set_result(None)

    def pause_writing(self) -> None:
        # The peer reads slower than we answer: stop reading its requests until it catches up.
        if self.transport is not None and not self._reading_paused:
            self._reading_paused = True
            self.transport.pause_reading()

    def resume_writing(self) -> None:
        if self.transport is not None and self._reading_paused and not self._closing:
            self._reading_paused = False
            self._read_again()
            self._next_slice()

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

    def send_sliced(self, parts: Sequence[bytes], done: Callable[[], None]) -> None:
        """Write a large reply's frame (its parts) a slice at a time, then call `done` (#19).

        A slice goes out whenever the transport is under its high-water mark, one per loop turn,
        so one callback copies at most `_SLICE` bytes; the rest follows as the peer reads
        (`resume_writing`). Nothing else is written on the connection meanwhile: the responder
        holds it.
        """
        self._sliced = Sliced(parts=tuple(parts), done=done)
        self._write_slices()

    def _next_slice(self) -> None:
        """Write the next slice in the next loop turn (one pending call at most)."""
        if not self._slice_due and self._sliced is not None:
            self._slice_due = True
            asyncio.get_running_loop().call_soon(self._write_slices)

    def _write_slices(self) -> None:
        self._slice_due = False
        sliced = self._sliced
        if sliced is None:
            return
        transport = self.transport
        if self._closing or transport is None:
            self._sliced = None
            return
        # One slice per loop turn: a peer that reads as fast as we write would otherwise take
        # the whole frame in one callback. pause_writing (the transport past its high-water
        # mark) stops it until resume_writing.
        if not sliced.finished and not self._reading_paused:
            self.writer.write_part(transport, sliced.take(_SLICE))
        self.last_traffic = time.monotonic()
        if not sliced.finished:
            if not self._reading_paused:
                self._next_slice()
            return
        self._sliced = None
        self.writer.end_reply()
        sliced.done()

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


def _break_read_cycle(transport: asyncio.BaseTransport | None) -> None:
    """Let a closed transport be freed by reference counting, not by the garbage collector.

    asyncio (3.11) keeps a bound method of a socket transport on the transport itself
    (`_read_ready_cb`), a cycle that outlives the close: after a flood of connections, gen-0
    collections of tens of thousands of them stopped the loop for 20 ms (issue #19).
    """
    state = getattr(transport, "__dict__", None)
    if state is not None and state.get("_read_ready_cb") is not None:
        state["_read_ready_cb"] = None
