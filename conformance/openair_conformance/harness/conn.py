"""Framed, traced TCP connections and the two connection roles the suite plays (OA-SESS-28).

`FramedStream` moves frames and raw bytes over one asyncio stream and writes each to the trace.
`RequesterChannel` is a connection the suite opened and sends requests on (a module's primary
connection): replies are paired with requests by `isresponse`, else with the oldest unanswered
request (OA-SESS-33). `ResponderChannel` is a connection on which the server sends requests
(a connection to a module's listening port, or its callback connection): it answers PING with
PING_SUCCESS, KEEPALIVE with KEEPALIVESUCCESS and anything else with RECEIVE_ACCEPT whose
`isresponse` is the request's id (OA-SESS-11, OA-DELIV-4), in arrival order (OA-SESS-2).
"""

from __future__ import annotations

import asyncio
import contextlib
import ssl
import time
from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass, replace

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.connection import ANSWER_FOR, HARNESS_RULES, Connection, Role
from openair.protocol.errors import OpenAIRError
from openair.protocol.framing import Frame, FrameLimits, FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair_conformance.harness.trace import Trace

__all__ = [
    "ANSWERS",
    "ConnectionLost",
    "DecodeProblem",
    "FramedStream",
    "RequesterChannel",
    "ResponderChannel",
    "open_stream",
]

#: The reply a responder sends for each server request type; anything else gets RECEIVE_ACCEPT
#: (the one table of `openair.protocol.connection`, OA-SESS-10, OA-KEEP-2).
ANSWERS = ANSWER_FOR
_READ_SIZE = 65_536


class ConnectionLost(Exception):
    """The server closed or reset the connection (or its framing broke: `framing` is set)."""

    def __init__(self, label: str, detail: str = "", *, framing: bool = False) -> None:
        super().__init__(f"{label}: {detail or 'closed by the server'}")
        self.label = label
        self.detail = detail
        self.framing = framing


class DecodeProblem(Exception):
    """A correctly framed message from the server could not be decoded."""


def _stamp(msg: Message) -> Message:
    # OA-TIME-2: the poster stamps postedTime as its last act before sending.
    return msg if msg.posted is not None else replace(msg, posted=AirTime.from_ns(time.time_ns()))


class FramedStream:
    """One TCP connection carrying frames; everything in and out goes to the trace."""

    def __init__(
        self,
        reader: asyncio.StreamReader,
        writer: asyncio.StreamWriter,
        *,
        label: str,
        trace: Trace,
    ) -> None:
        self.label = label
        self.trace = trace
        self._reader = reader
        self._writer = writer
        self._frames = FrameReader(FrameLimits())
        self._eof = False

    @property
    def local_host(self) -> str:
        """The local address of the connection (where the server sees the suite)."""
        sockname = self._writer.get_extra_info("sockname")
        return str(sockname[0]) if sockname else "127.0.0.1"

    async def send_message(self, msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> Message:
        """Stamp, encode, trace and send a message; return it as sent."""
        msg = _stamp(msg)
        frame = to_frame(msg, tag)
        self.trace.frame(self.label, "out", frame.tag.value, frame.xml, len(frame.chunks))
        await self._write(encode_frame(frame))
        return msg

    async def send_messages(
        self, msgs: list[Message], tag: FrameTag = FrameTag.MESSAGE
    ) -> list[Message]:
        """Send several messages in one write (pipelining); return them as sent."""
        sent = [_stamp(m) for m in msgs]
        data = b""
        for msg in sent:
            frame = to_frame(msg, tag)
            self.trace.frame(self.label, "out", frame.tag.value, frame.xml, len(frame.chunks))
            data += encode_frame(frame)
        await self._write(data)
        return sent

    async def send_frame(self, frame: Frame) -> None:
        """Send a frame as given (its XML need not be valid: hostile cases)."""
        self.trace.frame(self.label, "out", frame.tag.value, frame.xml, len(frame.chunks))
        await self._write(encode_frame(frame))

    async def send_bytes(self, data: bytes) -> None:
        """Send raw bytes (hostile cases), traced as a hex dump."""
        self.trace.raw(self.label, "out", data)
        await self._write(data)

    async def _write(self, data: bytes) -> None:
        try:
            self._writer.write(data)
            await self._writer.drain()
        except (ConnectionError, OSError) as exc:
            raise ConnectionLost(self.label, f"write failed: {exc}") from exc

    async def read_frame(self) -> Frame:
        """Return the next frame; ConnectionLost at end of stream or on a framing error."""
        while True:
            try:
                frame = self._frames.next_frame()
            except OpenAIRError as exc:
                self.trace.note(f"framing error in what the server sent: {exc}", self.label)
                raise ConnectionLost(self.label, str(exc), framing=True) from exc
            if frame is not None:
                self.trace.frame(self.label, "in", frame.tag.value, frame.xml, len(frame.chunks))
                return frame
            await self._fill()

    async def read_bytes(self) -> bytes:
        """Return the next bytes the server sends, raw (b"" at end of stream); traced."""
        try:
            data = await self._reader.read(_READ_SIZE)
        except (ConnectionError, OSError) as exc:
            raise ConnectionLost(self.label, f"reset: {exc}") from exc
        if data:
            self.trace.raw(self.label, "in", data)
        else:
            self._eof = True
        return data

    async def _fill(self) -> None:
        try:
            data = await self._reader.read(_READ_SIZE)
        except (ConnectionError, OSError) as exc:
            self._eof = True
            raise ConnectionLost(self.label, f"reset: {exc}") from exc
        if data:
            self._frames.feed(data)
            return
        self._eof = True
        try:
            self._frames.feed_eof()
        except OpenAIRError as exc:
            raise ConnectionLost(self.label, f"closed inside a frame: {exc}", framing=True) from exc
        raise ConnectionLost(self.label)

    def decode(self, frame: Frame) -> Message:
        """Decode a frame's message; DecodeProblem (noted in the trace) if it cannot be read."""
        try:
            return from_frame(frame)
        except OpenAIRError as exc:
            self.trace.note(f"the suite cannot decode this message: {exc}", self.label)
            raise DecodeProblem(str(exc)) from exc

    @property
    def at_eof(self) -> bool:
        """Whether the server has closed its side."""
        return self._eof

    async def close(self) -> None:
        """Close the connection (idempotent, never raises)."""
        if self._writer.is_closing():
            return
        self._writer.close()
        with contextlib.suppress(ConnectionError, OSError, asyncio.CancelledError):
            await asyncio.wait_for(self._writer.wait_closed(), 1.0)


#: The shortest connect timeout: one SYN retransmission (1 s on Linux) and a margin.
CONNECT_FLOOR_S = 3.5


#: TLS for the connections the checker opens to the target (spec 14.3, `--tls-ca`); the engine
#: sets it for one run (its tasks inherit it). None: plain TCP.
TARGET_TLS: ContextVar[ssl.SSLContext | None] = ContextVar("TARGET_TLS", default=None)


async def open_stream(
    host: str, port: int, *, label: str, trace: Trace, timeout: float
) -> FramedStream:
    """Connect to host:port; ConnectionLost (noted in the trace) when that fails.

    The timeout is at least `CONNECT_FLOOR_S`: a loaded host's listener may drop a SYN, and the
    client's first retransmission comes a second later; a case's reply deadline can be shorter.
    """
    timeout = max(timeout, CONNECT_FLOOR_S)
    try:
        tls = TARGET_TLS.get()
        reader, writer = await asyncio.wait_for(
            asyncio.open_connection(host, port, ssl=tls), timeout
        )
    except (OSError, TimeoutError) as exc:
        trace.note(f"cannot connect to {host}:{port}: {exc or 'timeout'}", label)
        raise ConnectionLost(label, f"cannot connect to {host}:{port}: {exc or 'timeout'}") from exc
    trace.note(f"connected to {host}:{port}", label)
    return FramedStream(reader, writer, label=label, trace=trace)


@dataclass(slots=True)
class _Pending:
    request: Message
    future: asyncio.Future[Message]
    sent_at: float


class RequesterChannel:
    """A connection the suite opened: it sends requests and the server only replies.

    Without the server's `pipelining` extension one request is in flight at a time (a legacy
    server is served one request, one reply, OA-SESS-18); with it, requests are pipelined.
    """

    def __init__(self, stream: FramedStream, *, name: str, pipelining: bool) -> None:
        self.stream = stream
        self.name = name
        #: The pairing rules shared with the server and the client (`HARNESS_RULES`: a reply
        #: naming a later request is paired with it and the overtaking noted, OA-SESS-33).
        self.machine: Connection[_Pending] = Connection(Role.REQUESTER, rules=HARNESS_RULES)
        self._window = asyncio.Semaphore(256 if pipelining else 1)
        self._task: asyncio.Task[None] | None = None
        self._lost: ConnectionLost | None = None
        #: (request, reply) pairs in the order the replies arrived.
        self.replies: list[tuple[Message, Message]] = []

    def start(self) -> None:
        """Start reading replies in the background."""
        self._task = asyncio.create_task(self._read_loop(), name=f"reader {self.stream.label}")

    async def send(self, msg: Message) -> tuple[Message, asyncio.Future[Message]]:
        """Send a request; return it as sent and a future for its reply.

        The future fails with ConnectionLost or DecodeProblem instead of a reply.
        """
        await self._window.acquire()
        if self._lost is not None:
            self._window.release()
            raise self._lost
        future: asyncio.Future[Message] = asyncio.get_running_loop().create_future()
        future.add_done_callback(lambda _: self._window.release())
        entry = _Pending(request=msg, future=future, sent_at=time.monotonic())
        pending = self.machine.send_request(msg.id, msg.type, entry)
        try:
            entry.request = await self.stream.send_message(msg)
        except ConnectionLost:
            if pending is not None:
                self.machine.withdraw(pending)
            future.cancel()
            raise
        return entry.request, future

    async def send_noreply(self, msg: Message) -> Message:
        """Send a message that gets no reply (noreply="yes", OA-MSG-15)."""
        return await self.stream.send_message(msg)

    async def _read_loop(self) -> None:
        try:
            while True:
                frame = await self.stream.read_frame()
                try:
                    msg = self.stream.decode(frame)
                except DecodeProblem as exc:
                    self._resolve_oldest(exc)
                    continue
                if self.machine.is_out_of_turn(msg):
                    await self._answer_misplaced(msg)
                    continue
                self._pair(msg)
        except ConnectionLost as exc:
            self._lost = exc
            for pending in self.machine.fail_pending():
                if not pending.token.future.done():
                    pending.token.future.set_exception(exc)

    async def _answer_misplaced(self, msg: Message) -> None:
        # A request from the server on a connection the suite opened breaks the fixed roles
        # (OA-SESS-28); answer it anyway so the server is not stalled, and say so.
        self.stream.trace.note(
            f"the server sent a {msg.type} request on a connection the suite opened (OA-SESS-28)",
            self.stream.label,
        )
        await self.stream.send_message(msg.reply(ANSWERS[msg.type], sender=self.name))

    def _pair(self, reply: Message) -> None:
        paired = self.machine.pair(reply)
        if paired.pending is None:
            self.stream.trace.note("a reply arrived with no request outstanding", self.stream.label)
            return
        if paired.note:
            self.stream.trace.note(paired.note, self.stream.label)
        entry = paired.pending.token
        self.replies.append((entry.request, reply))
        if not entry.future.done():
            entry.future.set_result(reply)

    def _resolve_oldest(self, exc: Exception) -> None:
        paired = self.machine.pair(None)
        if paired.pending is not None and not paired.pending.token.future.done():
            paired.pending.token.future.set_exception(exc)

    async def close(self) -> None:
        """Close the connection and stop reading."""
        await self.stream.close()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._task


DeliveryHandler = Callable[[Message, "ResponderChannel"], None]
ProblemHandler = Callable[[str], None]


class ResponderChannel:
    """A connection on which the server is the requester; the suite answers every request."""

    def __init__(
        self,
        stream: FramedStream,
        *,
        name: str,
        path: str,
        on_delivery: DeliveryHandler,
        on_problem: ProblemHandler,
        gate: asyncio.Event,
        own_request_id: str = "",
    ) -> None:
        self.stream = stream
        self._own_request_id = own_request_id
        self.name = name
        self.path = path  # "listener" or "callback"
        self._on_delivery = on_delivery
        self._on_problem = on_problem
        self._gate = gate
        self._task: asyncio.Task[None] | None = None

    def start(self) -> None:
        """Start answering requests in the background."""
        self._task = asyncio.create_task(self.serve(), name=f"responder {self.stream.label}")

    async def serve(self) -> None:
        """Answer requests until the server closes the connection."""
        with contextlib.suppress(ConnectionLost):
            while True:
                await self._answer(await self.stream.read_frame())

    async def _answer(self, frame: Frame) -> None:
        try:
            msg = self.stream.decode(frame)
        except DecodeProblem as exc:
            self._on_problem(f"the server sent a request the suite cannot decode: {exc}")
            error = Message(type="RECEIVE_ERROR", sender=self.name, content=f"XML_MALFORMED: {exc}")
            await self.stream.send_message(error)  # OA-SESS-11: RECEIVE_ERROR when unreadable
            return
        if self._own_request_id and msg.isresponse == self._own_request_id:
            # OA-SESS-7: the Receive frame gets no reply; never answer a reply.
            self.stream.trace.note("the server replied to the Receive frame", self.stream.label)
            return
        answer = ANSWERS.get(msg.type)
        if answer is None:
            self._on_delivery(msg, self)
            # Acknowledgements may be held by the case (TestModule.pause_acks); PINGs are not.
            await self._gate.wait()
            answer = "RECEIVE_ACCEPT"
        await self.stream.send_message(msg.reply(answer, sender=self.name))

    async def close(self) -> None:
        """Close the connection and stop answering."""
        await self.stream.close()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._task
