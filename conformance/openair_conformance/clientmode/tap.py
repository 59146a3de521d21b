"""The kit's frame-capturing proxy between the library and the server it talks to.

The library connects to the `Tap`'s port instead of the server's; each connection is forwarded
frame by frame to the server, and every frame in either direction is recorded in the `Capture`
(and the scenario's trace) with the wall-clock time it was complete. Connections the server
opens to the module's bound port go through the tap as well (`Tap.reverse_port`), and so do the
connections the kit itself opens to that port (`Tap.open_listener`). The kit can therefore check
what the library put on the wire whatever server runs behind the tap.

Roles (OA-SESS-28): on a connection the library opened, the library is the requester, unless its
first frame is a `Receive` frame (a callback connection, OA-SESS-7); on a connection to its bound
port the library is the responder. On responder connections the tap keeps the requests the
library has to answer, in order, so that it can pair each answer with its request (OA-SESS-2),
check it (`AckRecord`), and swallow the answers to requests the kit injected (`TapConn.inject`).

`Behaviour` makes the tap misbehave on purpose for the scripted peers: keep the `Receive` frame
from the server, answer GET_CAPABILITIES itself with UNKNOWN_COMMAND, delay replies, cut a reply
in the middle and close, replace a reply with malformed XML, or close a push connection after
some samples.
"""

from __future__ import annotations

import asyncio
import contextlib
import enum
import time
from collections import deque
from dataclasses import dataclass, field, replace

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.connection import ANSWER_FOR, answer_type
from openair.protocol.errors import OpenAIRError
from openair.protocol.framing import Frame, FrameLimits, FrameReader, FrameTag, encode_frame
from openair.protocol.matching import matches
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair_conformance.harness.trace import Trace

__all__ = [
    "ANSWER_FOR",
    "AckRecord",
    "Behaviour",
    "Capture",
    "ConnKind",
    "Tap",
    "TapConn",
    "WireFrame",
]

#: The answer a module owes each kind of request (OA-SESS-11, OA-DELIV-4, OA-KEEP-2).
_READ = 65_536
_DECLARING = frozenset({"BIND", "BIND_NOLISTEN", "RECEIVE_NAME_NOTIFICATION"})


class ConnKind(enum.Enum):
    """What a connection is to the library."""

    UNKNOWN = "unknown"  # no frame yet
    PRIMARY = "primary"  # opened by the library, which sends requests
    CALLBACK = "callback"  # opened by the library with a Receive frame (OA-SESS-7)
    LISTENER = "listener"  # opened to the module's bound port (by the server or the kit)


@dataclass(frozen=True, slots=True, kw_only=True)
class Behaviour:
    """How the tap misbehaves (the scripted peers of schemas/scenario.xsd)."""

    keep_receive: bool = False  # bound-port-delivery: the server never sees the Receive frame
    legacy: bool = False  # answer GET_CAPABILITIES with UNKNOWN_COMMAND (OA-CAP-2)
    reply_delay_s: float = 0.0  # slow
    delay_replies_to: str = ""  # slow: only replies to requests of this type pattern ("" = all)
    cut_reply_to: str = ""  # close-mid-frame: a type pattern
    malform_reply_to: str = ""  # malformed-frame: a type pattern
    drop_push_after: int = 0  # drop-push: close a push connection after this many DATASAMPLEs


@dataclass(slots=True)
class WireFrame:
    """One frame on a tapped connection; `from_library` tells the direction."""

    conn: TapConn
    from_library: bool
    frame: Frame
    wall_ns: int
    trace_index: int
    message: Message | None = None
    error: str = ""
    injected: bool = False  # written by the kit, not by the server


@dataclass(slots=True)
class AckRecord:
    """A request the library had to answer, and what it answered (None: nothing yet)."""

    conn: TapConn
    request: WireFrame
    origin: str  # "server" or "kit"
    answer: WireFrame | None = None
    future: asyncio.Future[WireFrame] | None = None

    @property
    def expected_type(self) -> str:
        msg = self.request.message
        if msg is None:
            return "RECEIVE_ERROR"  # OA-SESS-11: a request it cannot parse
        return answer_type(msg.type)


@dataclass(slots=True)
class Capture:
    """Everything seen on the tapped connections of one scenario."""

    trace: Trace
    frames: list[WireFrame] = field(default_factory=list)
    conns: list[TapConn] = field(default_factory=list)
    acks: list[AckRecord] = field(default_factory=list)
    problems: list[tuple[str, int]] = field(default_factory=list)  # (text, trace index)
    changed: asyncio.Event = field(default_factory=asyncio.Event)

    def record(
        self, conn: TapConn, frame: Frame, *, from_library: bool, injected: bool
    ) -> WireFrame:
        """Record a frame (decoding it if it carries XML) and trace it."""
        index = self.trace.frame(
            conn.label, "in" if from_library else "out", frame.tag.value, frame.xml,
            len(frame.chunks),
        )  # fmt: skip
        wire = WireFrame(
            conn=conn, from_library=from_library, frame=frame, wall_ns=time.time_ns(),
            trace_index=index, injected=injected,
        )  # fmt: skip
        if frame.tag is not FrameTag.BINARY:
            try:
                wire.message = from_frame(frame)
            except OpenAIRError as exc:
                wire.error = str(exc)
        self.frames.append(wire)
        return wire

    def problem(self, text: str, conn: TapConn | None = None) -> None:
        """Note something the library did wrong that is seen while forwarding."""
        index = self.trace.note(text, conn.label if conn is not None else "tap")
        self.problems.append((text, index))

    def library_frames(self) -> list[WireFrame]:
        """The frames the library sent, in order."""
        return [f for f in self.frames if f.from_library]

    def outstanding(self) -> list[AckRecord]:
        """Requests still unanswered on connections that are open."""
        return [a for a in self.acks if a.answer is None and not a.conn.closed]

    async def settled(self, timeout: float) -> bool:
        """Wait (at most `timeout` s) until no request to the library is unanswered."""
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        while self.outstanding():
            remaining = end - loop.time()
            if remaining <= 0:
                return False
            self.changed.clear()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self.changed.wait(), remaining)
        return True

    def poke(self) -> None:
        self.changed.set()


class TapConn:
    """One tapped connection: the library's side and, unless the kit opened it, the server's."""

    def __init__(
        self,
        tap: Tap,
        lib: tuple[asyncio.StreamReader, asyncio.StreamWriter],
        peer: tuple[asyncio.StreamReader, asyncio.StreamWriter] | None,
        *,
        kind: ConnKind,
        opened_by: str,
    ) -> None:
        self.tap = tap
        self.number = tap.next_number()
        self.kind = kind
        self.opened_by = opened_by
        self._lib_reader, self._lib_writer = lib
        self._peer = peer
        self.requests: deque[WireFrame] = deque()  # the library's requests awaiting replies
        self.to_answer: deque[AckRecord] = deque()  # requests the library must answer, in order
        self.max_in_flight = 0
        self.pipelined_at: int | None = None  # trace index of the first pipelined request
        self.closed = False
        self.closed_by = ""
        self.kept_receive = False
        self.pushed = 0  # DATASAMPLE requests the server sent here (drop-push)
        self._tasks: list[asyncio.Task[None]] = []

    @property
    def label(self) -> str:
        """`primary#1`, `callback#2`, `listener#3 (server)` …"""
        who = "" if self.opened_by == "library" else f" ({self.opened_by})"
        return f"{self.kind.value}#{self.number}{who}"

    @property
    def capture(self) -> Capture:
        return self.tap.capture

    def start(self) -> None:
        """Start forwarding in both directions."""
        self._tasks.append(asyncio.create_task(self._pump_library()))
        if self._peer is not None:
            self._tasks.append(asyncio.create_task(self._pump_peer(self._peer[0])))

    # -- frames from the library -----------------------------------------------------------------

    async def _pump_library(self) -> None:
        reader = FrameReader(FrameLimits())
        try:
            while True:
                data = await self._lib_reader.read(_READ)
                if not data:
                    reader.feed_eof()
                    self._closed("library")
                    return
                reader.feed(data)
                while (frame := reader.next_frame()) is not None:
                    await self._from_library(frame)
        except OpenAIRError as exc:
            self.capture.problem(f"framing error in what the library sent: {exc}", self)
            self._closed("library")
        except (ConnectionError, OSError):
            self._closed("library")

    async def _from_library(self, frame: Frame) -> None:
        first = self.kind is ConnKind.UNKNOWN
        if first:
            self.kind = ConnKind.CALLBACK if frame.tag is FrameTag.RECEIVE else ConnKind.PRIMARY
            self.capture.poke()
        wire = self.capture.record(self, frame, from_library=True, injected=False)
        self._note_declaration(wire.message)
        if first and self.kind is ConnKind.CALLBACK:
            if self.tap.behaviour.keep_receive:
                self.kept_receive = True
                self.capture.trace.note(
                    "the kit keeps this Receive frame from the server", self.label
                )
                return
            await self._to_peer(frame)
            return
        if self.kind is ConnKind.PRIMARY:
            await self._library_request(wire)
        else:
            await self._library_answer(wire)

    def _note_declaration(self, msg: Message | None) -> None:
        """Remember the extensions the module declared (OA-SESS-19)."""
        if msg is None or msg.type not in _DECLARING:
            return
        slot = msg.extra("extensions")
        if slot is not None:
            self.tap.declared = frozenset(slot.value.split())

    async def _library_request(self, wire: WireFrame) -> None:
        msg = wire.message
        legacy = self.tap.behaviour.legacy
        # Answered in turn only when nothing is in flight (OA-SESS-2).
        if legacy and msg is not None and msg.type == "GET_CAPABILITIES" and not self.requests:
            self.capture.trace.note("the kit answers as a legacy server (OA-CAP-2)", self.label)
            reply = Message(
                type="UNKNOWN_COMMAND",
                sender="CNS",
                to=msg.sender,
                isresponse=msg.id,
                content="Offending cmd: GET_CAPABILITIES",
            )
            await self._write_library(_stamped(reply), injected=True)
            return
        if msg is None or not (msg.noreply and "noreply" in self.tap.advertised):
            self.requests.append(wire)  # a noreply post gets no reply (OA-MSG-15)
            if len(self.requests) > 1 and self.pipelined_at is None:
                self.pipelined_at = wire.trace_index
            self.max_in_flight = max(self.max_in_flight, len(self.requests))
        await self._to_peer(wire.frame)

    async def _library_answer(self, wire: WireFrame) -> None:
        if not self.to_answer:
            self.capture.problem(
                "the library sent a frame on a connection where it may only answer, with no "
                "request to answer (OA-SESS-28)",
                self,
            )
            await self._to_peer(wire.frame)
            return
        record = self.to_answer.popleft()
        record.answer = wire
        self.capture.poke()
        if record.future is not None and not record.future.done():
            record.future.set_result(wire)
        if record.origin == "server":
            await self._to_peer(wire.frame)

    async def _to_peer(self, frame: Frame) -> None:
        if self._peer is None:
            return
        writer = self._peer[1]
        with contextlib.suppress(ConnectionError, OSError):
            writer.write(encode_frame(frame))
            await writer.drain()

    # -- frames from the server ------------------------------------------------------------------

    async def _pump_peer(self, peer_reader: asyncio.StreamReader) -> None:
        reader = FrameReader(FrameLimits())
        try:
            while True:
                data = await peer_reader.read(_READ)
                if not data:
                    self._closed("server")
                    return
                reader.feed(data)
                while (frame := reader.next_frame()) is not None:
                    await self._from_peer(frame)
        except (OpenAIRError, ConnectionError, OSError):
            self._closed("server")

    async def _from_peer(self, frame: Frame) -> None:
        if self.kind is ConnKind.PRIMARY:
            request = self.requests[0] if self.requests else None
            handled = await self._misbehave(frame, request)
            if self.requests:  # in flight until the reply reaches the library (after a delay)
                self.requests.popleft()
            if not handled:
                await self._write_frame(frame, injected=False)
            return
        wire = self._write_frame_now(frame, injected=False)
        if self.kind in (ConnKind.CALLBACK, ConnKind.LISTENER):
            self._expect_answer(wire, "server")
        await self._drain_library()
        if wire.message is not None and wire.message.type == "DATASAMPLE":
            await self._maybe_drop_push()

    async def _maybe_drop_push(self) -> None:
        """drop-push: close a push connection once it has carried its last sample."""
        self.pushed += 1
        limit = self.tap.behaviour.drop_push_after
        if self.kind is ConnKind.CALLBACK and limit and self.pushed >= limit:
            self.capture.trace.note(
                f"the kit closes this push connection after {self.pushed} sample(s)", self.label
            )
            await self.close("kit")

    async def _misbehave(self, frame: Frame, request: WireFrame | None) -> bool:
        """Apply the behaviour to the reply to `request`; True when the reply was handled."""
        behaviour = self.tap.behaviour
        kind = request.message.type if request is not None and request.message else ""
        slow = not behaviour.delay_replies_to or (
            kind and matches(behaviour.delay_replies_to, kind)
        )
        if behaviour.reply_delay_s and slow:
            await asyncio.sleep(behaviour.reply_delay_s)  # the slow peer: delay, never lose
        if behaviour.cut_reply_to and kind and matches(behaviour.cut_reply_to, kind):
            data = encode_frame(frame)
            half = data[: max(1, len(data) // 2)]
            self.capture.trace.raw(self.label, "out", half)
            self.capture.trace.note(
                f"the kit sends {len(half)} of the {len(data)} bytes of the reply and closes",
                self.label,
            )
            with contextlib.suppress(ConnectionError, OSError):
                self._lib_writer.write(half)
                await self._lib_writer.drain()
            await self.close("kit")
            return True
        if behaviour.malform_reply_to and kind and matches(behaviour.malform_reply_to, kind):
            self.capture.trace.note("the kit replaces this reply with malformed XML", self.label)
            await self._write_frame(_malformed_like(frame), injected=True)
            return True
        return False

    def _expect_answer(self, wire: WireFrame, origin: str) -> AckRecord | None:
        msg = wire.message
        if msg is not None and msg.noreply and "noreply" in self.tap.declared & self.tap.advertised:
            return None  # OA-MSG-15: never acknowledged
        record = AckRecord(conn=self, request=wire, origin=origin)
        self.to_answer.append(record)
        self.capture.acks.append(record)
        return record

    def _write_frame_now(self, frame: Frame, *, injected: bool) -> WireFrame:
        wire = self.capture.record(self, frame, from_library=False, injected=injected)
        with contextlib.suppress(ConnectionError, OSError):
            self._lib_writer.write(encode_frame(frame))
        return wire

    async def _write_frame(self, frame: Frame, *, injected: bool) -> WireFrame:
        wire = self._write_frame_now(frame, injected=injected)
        await self._drain_library()
        return wire

    async def _write_library(self, msg: Message, *, injected: bool) -> WireFrame:
        return await self._write_frame(to_frame(msg), injected=injected)

    async def _drain_library(self) -> None:
        with contextlib.suppress(ConnectionError, OSError):
            await self._lib_writer.drain()

    # -- the kit as a server component -------------------------------------------------------------

    def inject(self, frame: Frame) -> asyncio.Future[WireFrame]:
        """Send a request to the library; the future gets its answer (the server never sees it).

        Only on a connection where the library answers (callback or listener). The future fails
        with ConnectionError when the connection closes first.
        """
        if self.kind not in (ConnKind.CALLBACK, ConnKind.LISTENER):
            raise ValueError(f"{self.label}: the library does not answer requests here")
        future: asyncio.Future[WireFrame] = asyncio.get_running_loop().create_future()
        if self.closed:
            future.set_exception(ConnectionError(f"{self.label} is closed"))
            return future
        wire = self._write_frame_now(frame, injected=True)
        record = self._expect_answer(wire, "kit")
        if record is None:
            future.set_exception(ValueError("a noreply request gets no answer"))
        else:
            record.future = future
        self._spawn_drain()
        return future

    def _spawn_drain(self) -> None:
        self._tasks.append(asyncio.create_task(self._drain_library()))

    # -- closing ---------------------------------------------------------------------------------

    def _closed(self, by: str) -> None:
        if self.closed:
            return
        self.closed = True
        self.closed_by = by
        self.capture.trace.note(f"connection closed by the {by}", self.label)
        for record in self.to_answer:
            if record.future is not None and not record.future.done():
                record.future.set_exception(ConnectionError(f"{self.label} closed by the {by}"))
        self.capture.poke()
        self._lib_writer.close()
        if self._peer is not None:
            self._peer[1].close()

    async def close(self, by: str = "kit") -> None:
        """Close both sides and stop forwarding."""
        self._closed(by)
        current = asyncio.current_task()
        for task in self._tasks:
            if task is not current:
                task.cancel()
        await asyncio.gather(*(t for t in self._tasks if t is not current), return_exceptions=True)


def _stamped(msg: Message) -> Message:
    return replace(msg, posted=AirTime.from_ns(time.time_ns()))  # OA-TIME-2


def _malformed_like(frame: Frame) -> Frame:
    """A well-framed Message frame whose XML is cut short (XML_MALFORMED)."""
    xml = frame.xml[: max(8, len(frame.xml) // 2)]
    if xml.endswith(b">"):
        xml = xml[:-1]
    return Frame(tag=FrameTag.MESSAGE, xml=xml)


class Tap:
    """The proxy: listens for the library, forwards to `upstream`, records into `capture`."""

    def __init__(
        self,
        upstream: tuple[str, int],
        capture: Capture,
        *,
        behaviour: Behaviour | None = None,
        advertised: frozenset[str] = frozenset(),
    ) -> None:
        self.upstream = upstream
        self.capture = capture
        self.behaviour = behaviour or Behaviour()
        self.advertised = advertised  # what the server advertised (OA-GEN-2)
        self.declared: frozenset[str] = frozenset()  # what the module declared (OA-SESS-19)
        self.port = 0
        self._servers: list[asyncio.Server] = []
        self._reverse: dict[tuple[str, int], int] = {}
        self._count = 0
        self._closing = False

    def next_number(self) -> int:
        self._count += 1
        return self._count

    async def start(self, host: str = "127.0.0.1") -> int:
        """Listen for the library; return the port it is to connect to."""
        server = await asyncio.start_server(self._accept_library, host, 0)
        self._servers.append(server)
        self.port = int(server.sockets[0].getsockname()[1])
        return self.port

    async def _accept_library(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter
    ) -> None:
        await self._bridge((reader, writer), self.upstream, ConnKind.UNKNOWN, "library")

    async def _bridge(
        self,
        lib: tuple[asyncio.StreamReader, asyncio.StreamWriter],
        target: tuple[str, int],
        kind: ConnKind,
        opened_by: str,
    ) -> None:
        """Connect the accepted side to `target` and forward between them."""
        if self._closing:
            lib[1].close()
            return
        try:
            peer = await asyncio.wait_for(asyncio.open_connection(*target), 5.0)
        except (OSError, TimeoutError) as exc:
            self.capture.trace.note(f"cannot reach {target[0]}:{target[1]}: {exc}", "tap")
            lib[1].close()
            return
        if kind is ConnKind.LISTENER:  # the server connected: the library is the accepted side
            lib, peer = peer, lib
        conn = TapConn(self, lib, peer, kind=kind, opened_by=opened_by)
        self.capture.conns.append(conn)
        self.capture.trace.note(f"connection #{conn.number} opened by the {opened_by}", "tap")
        conn.start()

    async def reverse_port(self, address: str, port: int) -> int:
        """A port that forwards the server's connections to the module at `address:port`."""
        if (address, port) not in self._reverse:

            async def accept(r: asyncio.StreamReader, w: asyncio.StreamWriter) -> None:
                await self._bridge((r, w), (address, port), ConnKind.LISTENER, "server")

            server = await asyncio.start_server(accept, "127.0.0.1", 0)
            self._servers.append(server)
            self._reverse[(address, port)] = int(server.sockets[0].getsockname()[1])
        return self._reverse[(address, port)]

    async def open_listener(self, host: str, port: int, timeout: float) -> TapConn:
        """Open a kit connection to the module's bound port (the kit plays a server component)."""
        reader, writer = await asyncio.wait_for(asyncio.open_connection(host, port), timeout)
        conn = TapConn(self, (reader, writer), None, kind=ConnKind.LISTENER, opened_by="kit")
        self.capture.conns.append(conn)
        self.capture.trace.note(f"the kit connected to the bound port {port}", conn.label)
        conn.start()
        return conn

    def callback(self) -> TapConn | None:
        """The newest open callback connection of the library."""
        found = [c for c in self.capture.conns if c.kind is ConnKind.CALLBACK and not c.closed]
        return found[-1] if found else None

    async def wait_callback(self, timeout: float) -> TapConn | None:
        """The newest open callback connection, waiting up to `timeout` s for one to open.

        A library may return from connecting before its Receive frame has crossed the tap.
        """
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        while (conn := self.callback()) is None and loop.time() < end:
            self.capture.changed.clear()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self.capture.changed.wait(), end - loop.time())
        return conn

    async def close(self) -> None:
        """Stop listening and close every tapped connection."""
        self._closing = True
        for server in self._servers:
            server.close()
        await asyncio.gather(*(c.close("kit") for c in self.capture.conns), return_exceptions=True)
        for server in self._servers:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(server.wait_closed(), 1.0)
