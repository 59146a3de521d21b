"""The client side of one OpenAIR connection, without I/O (h11-style, spec section 6).

`ClientConnection` turns calls into bytes to send and received bytes into events. It never
touches a socket or a clock: the clock is passed in (`now`, nanoseconds since the epoch) and read
only as the last act before a message is encoded (OA-TIME-2).

A connection has a fixed role (OA-SESS-28). As REQUESTER (the primary connection, any connection
the module opened) it sends requests and every frame it receives is a reply, paired with the
oldest unanswered request (OA-SESS-33). As RESPONDER (a connection the server opened to the
module's listening port, or a callback connection after its `Receive` frame) every frame it
receives is a request, which the module answers in arrival order (OA-SESS-2, OA-SESS-11).

Events: `Reply` (a reply and the id of the request it answers), `Request` (a delivery: wakeup,
PING, KEEPALIVE, forwarded message), `Invalid` (a correctly framed request whose message could not
be read; answer it with RECEIVE_ERROR, OA-ERR-3) and `Closed` (the peer closed the connection).
A remote protocol error is raised from `receive_data` and is sticky: every later call raises it
again (OA-FRAME-9).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace

from lxml import etree

from openair.protocol.codec import encode_message, from_frame, message_to_element, to_frame
from openair.protocol.connection import (
    CLIENT_RULES,
    TRANSITIONS,
    Action,
    Connection,
    Role,
    State,
    answer_type,
)
from openair.protocol.errors import (
    ApiMisuseError,
    ConnectionClosedError,
    OpenAIRError,
    RemoteProtocolError,
)
from openair.protocol.framing import (
    MAX_LENGTH,
    Frame,
    FrameLimits,
    FrameReader,
    FrameTag,
    encode_frame,
)
from openair.protocol.message import CANONICAL_SLOTS, Message
from openair.protocol.times import AirTime

__all__ = [
    "CLIENT_EXTENSIONS",
    "DEFAULT_MAX_IN_FLIGHT",
    "Buffer",
    "ClientConnection",
    "Closed",
    "Event",
    "Invalid",
    "Reply",
    "Request",
    "Role",
    "State",
]

#: Extensions this client implements (OA-EXT-1); a module declares a subset (OA-SESS-19).
CLIENT_EXTENSIONS: frozenset[str] = frozenset({"noreply", "pipelining", "usec", "gettime"})

DEFAULT_MAX_IN_FLIGHT = 256  # OA-LIM-5

#: A byte buffer a frame part may be (written without copying it first).
Buffer = bytes | bytearray | memoryview

# The slots the codec writes before `binarysizes` (canonical order, spec 3.5).
_BEFORE_SIZES = frozenset(CANONICAL_SLOTS[: CANONICAL_SLOTS.index("binarysizes")])


@dataclass(frozen=True, slots=True, kw_only=True)
class Reply:
    """A reply, paired with the request it answers (OA-SESS-33)."""

    request_id: str
    message: Message


@dataclass(frozen=True, slots=True, kw_only=True)
class Request:
    """A request the server sent: a wakeup, PING, KEEPALIVE or forwarded message.

    `needs_answer` is false for a `noreply="yes"` delivery under the `noreply` extension
    (OA-MSG-15); every other request must be answered, in order, with `answer()`.
    """

    message: Message
    needs_answer: bool = True


@dataclass(frozen=True, slots=True, kw_only=True)
class Invalid:
    """A correctly framed request whose message could not be read; answer it (OA-ERR-3)."""

    error: OpenAIRError


@dataclass(frozen=True, slots=True, kw_only=True)
class Closed:
    """The peer closed the connection; `unanswered` lists the requests that got no reply."""

    unanswered: tuple[str, ...] = ()


Event = Reply | Request | Invalid | Closed


@dataclass(slots=True)
class _Counters:
    """What went over the connection (for tests and diagnostics)."""

    requests_sent: int = 0
    replies_received: int = 0
    requests_received: int = 0
    answers_sent: int = 0
    in_flight_peak: int = 0


class ClientConnection:
    """One connection of an OpenAIR module or client: the shared `Connection` rules plus bytes.

    `now` returns nanoseconds since the epoch; it is called once per outgoing message, as the
    last act before encoding (OA-TIME-2). `window` bounds the requests in flight: 1 for a legacy
    server (OA-SESS-18), up to the server's `max-in-flight` with `pipelining` (OA-SESS-17).
    `extensions` are the extensions in use on this connection (declared by the module and
    advertised by the server, OA-GEN-2). `name` is written as `from` on answers.
    """

    def __init__(
        self,
        role: Role = Role.REQUESTER,
        *,
        now: Callable[[], int],
        window: int = 1,
        extensions: Iterable[str] = (),
        name: str = "",
        limits: FrameLimits | None = None,
    ) -> None:
        if window < 1:
            raise ApiMisuseError(f"window must be at least 1, not {window}")
        #: The rules of the connection, shared with the server and the conformance suite.
        self.machine: Connection[None] = Connection(role, rules=CLIENT_RULES)
        self._now = now
        self.window = window
        self.extensions = frozenset(extensions)
        self.name = name
        self._reader = FrameReader(limits or FrameLimits())
        self._error: RemoteProtocolError | None = None
        self.counters = _Counters()
        #: The last message `send_request`/`send_notification` encoded (with its postedTime).
        self.last_sent: Message | None = None

    # -- state -------------------------------------------------------------------------------

    @property
    def state(self) -> State:
        """The current state."""
        return self.machine.state

    @property
    def in_flight(self) -> int:
        """How many requests were sent and not answered yet."""
        return self.machine.in_flight

    @property
    def can_send(self) -> bool:
        """True when a request may be sent now without exceeding the window."""
        return self.machine.state is State.REQUESTER and self.machine.in_flight < self.window

    @property
    def unanswered(self) -> int:
        """How many received requests still wait for `answer()`."""
        return self.machine.unanswered

    def _transition(self, action: Action) -> None:
        """Move to the next state, or raise when the table has no entry."""
        state = self.machine.state
        if (state, action) not in TRANSITIONS:
            if state is State.CLOSED:
                raise ConnectionClosedError(f"cannot {action.value}: the connection is closed")
            if state is State.ERROR and self._error is not None:
                raise ConnectionClosedError(f"cannot {action.value} after {self._error}")
        self.machine.transition(action)

    # -- sending -----------------------------------------------------------------------------

    def _stamp(self, msg: Message) -> Message:
        """Set postedTime from the clock: the last act before encoding (OA-TIME-2)."""
        posted = AirTime.from_ns(self._now(), with_usec="usec" in self.extensions)  # OA-TIME-5
        return replace(msg, posted=posted)

    def send_request(self, msg: Message) -> bytes:
        """Return the frame for request `msg`, stamped with postedTime (OA-TIME-2).

        A `noreply` message (allowed only under the `noreply` extension, OA-GEN-2) expects no
        reply and does not count against the window. Raises ApiMisuseError when the window is
        full (OA-SESS-18, OA-LIM-7) or on a responder connection (OA-SESS-28).
        """
        stamped = self._begin_request(msg)
        data = encode_frame(to_frame(stamped))
        self._track(stamped.id, stamped.type, expects_reply=not stamped.noreply)
        return data

    def send_request_parts(self, msg: Message, chunks: Sequence[Sequence[Buffer]]) -> list[Buffer]:
        """Return request `msg` as frame parts to write in order; the chunks are not copied.

        Like `send_request`, for a message whose binary chunks are given separately: chunk i
        is the concatenation of the byte buffers `chunks[i]` (e.g. `datasample.chunk_parts`),
        announced in `binarysizes` (OA-FRAME-4). `msg.binary` must be empty.
        """
        if msg.binary:
            raise ApiMisuseError("give the chunks either in msg.binary or as parts, not both")
        sizes = [sum(memoryview(part).nbytes for part in parts) for parts in chunks]
        stamped = self._begin_request(msg)
        head = encode_frame(Frame(tag=FrameTag.MESSAGE, xml=_xml_with_sizes(stamped, sizes)))
        self._track(stamped.id, stamped.type, expects_reply=not stamped.noreply)
        return [head, *(part for parts in chunks for part in parts)]

    def send_binary(self, parts: Sequence[Buffer]) -> list[Buffer]:
        """Return a `BinaryM` frame holding the concatenation of `parts` (OA-FRAME-5).

        The reply (a stream's DATA_ACCEPTED, or UNKNOWN_COMMAND) is paired like any other
        (its `isresponse` is empty, OA-SESS-33); the parts are not copied.
        """
        size = sum(memoryview(part).nbytes for part in parts)
        if size > MAX_LENGTH:
            raise ApiMisuseError(f"a BinaryM body of {size} bytes does not fit the uint32 length")
        if self.machine.state is State.REQUESTER and self.machine.in_flight >= self.window:
            raise ApiMisuseError(f"{self.window} request(s) already in flight")  # OA-SESS-18
        self._transition(Action.SEND_REQUEST)
        self._track("", FrameTag.BINARY.value, expects_reply=True)
        header = FrameTag.BINARY.value.encode("ascii") + b"\0" + size.to_bytes(4, "little")
        return [header, *parts]  # OA-FRAME-1: "BinaryM" is exactly 7 bytes

    def _begin_request(self, msg: Message) -> Message:
        """Check that request `msg` may be sent now and return it stamped (OA-TIME-2)."""
        if self.machine.state is State.REQUESTER:
            if msg.noreply and "noreply" not in self.extensions:
                raise ApiMisuseError("noreply needs the noreply extension")  # OA-GEN-2
            if not msg.noreply and self.machine.in_flight >= self.window:
                raise ApiMisuseError(f"{self.window} request(s) already in flight")  # OA-SESS-18
        self._transition(Action.SEND_REQUEST)
        stamped = self.last_sent = self._stamp(msg)
        return stamped

    def _track(self, request_id: str, type: str, *, expects_reply: bool) -> None:
        """Count a request sent; one that expects a reply waits for it in order (OA-SESS-33)."""
        self.machine.send_request(request_id, type, None, expects_reply=expects_reply)
        self.counters.in_flight_peak = self.machine.in_flight_peak
        self.counters.requests_sent += 1

    def send_notification(self, msg: Message) -> bytes:
        """Return the `Receive` frame that makes this a callback connection (OA-SESS-7).

        No reply follows; from then on the server is the requester (OA-SESS-28).
        """
        self.machine.send_notification()
        self.last_sent = self._stamp(msg)
        return encode_frame(to_frame(self.last_sent, FrameTag.RECEIVE))

    def answer(
        self,
        request: Request | Invalid,
        type: str | None = None,
        *,
        content: str = "",
    ) -> bytes:
        """Return the frame answering `request`, the oldest unanswered one (OA-SESS-2).

        The default type is PING_SUCCESS for PING, KEEPALIVESUCCESS for KEEPALIVE, RECEIVE_ACCEPT
        otherwise (`answer_type`: OA-SESS-11, OA-DELIV-4, OA-KEEP-2), and RECEIVE_ERROR with
        `NAME: detail` for an `Invalid` request (OA-ERR-2, OA-ERR-3). `isresponse` is the
        request's id (OA-SESS-1).
        """
        if self.machine.state is State.REQUESTER:  # a client answers only as the responder
            raise ApiMisuseError("cannot answer in state requester")
        if self.machine.state is not State.RESPONDER:
            self._transition(Action.ANSWER)  # raises ConnectionClosedError
        self.machine.answer(request)
        if isinstance(request, Invalid):
            reply = Message(
                type=type or "RECEIVE_ERROR",
                sender=self.name,
                content=content or request.error.wire_text(),
            )
        else:
            kind = type or answer_type(request.message.type)
            reply = request.message.reply(kind, sender=self.name, content=content)
        self.counters.answers_sent += 1
        return encode_frame(to_frame(self._stamp(reply)))

    def close(self) -> None:
        """Mark the connection closed by this side; later sends raise ConnectionClosedError."""
        self._transition(Action.CLOSE)

    # -- receiving ---------------------------------------------------------------------------

    def receive_data(self, data: bytes) -> list[Event]:
        """Feed received bytes (b"" = the peer closed) and return the events they complete.

        Frames may be split and joined arbitrarily (OA-FRAME-11). A remote protocol error is
        raised and becomes sticky (OA-FRAME-9); a connection that ends inside a frame raises
        FrameTruncatedError (OA-FRAME-8).
        """
        if self._error is not None:
            raise self._error
        if not data:
            return self._peer_closed()
        if self.machine.state is State.CLOSED:
            return []  # closed by this side: late bytes are dropped
        events: list[Event] = []
        try:
            self._reader.feed(data)
            while (frame := self._reader.next_frame()) is not None:
                events.append(self._event_for(frame))
        except RemoteProtocolError as exc:
            self._fail(exc)
            raise
        return events

    def _peer_closed(self) -> list[Event]:
        """Handle end of stream: a partial frame is FRAME_TRUNCATED (OA-FRAME-8)."""
        if self.machine.state is State.CLOSED:
            return []
        try:
            self._reader.feed_eof()
        except RemoteProtocolError as exc:
            self._fail(exc)
            raise
        unanswered = tuple(p.id for p in self.machine.peer_closed())
        return [Closed(unanswered=unanswered)]

    def _fail(self, exc: RemoteProtocolError) -> None:
        """Enter the sticky error state (OA-FRAME-9)."""
        self.machine.protocol_error()
        self._error = exc

    def _event_for(self, frame: Frame) -> Event:
        """Turn one complete frame into an event."""
        # OA-MSG-19: a client reads what a legacy server writes; a priority out of range is
        # clamped, not refused (a server validating a post is stricter, OA-MSG-6).
        if self.machine.state is State.REQUESTER:
            return self._reply_for(from_frame(frame, clamp_priority=True))
        try:
            msg = from_frame(frame, clamp_priority=True)
        except RemoteProtocolError as exc:
            if exc.closes:
                raise
            event: Request | Invalid = Invalid(error=exc)  # OA-ERR-3: the connection stays usable
        else:
            noreply = msg.noreply and "noreply" in self.extensions  # OA-MSG-15
            event = Request(message=msg, needs_answer=not noreply)
        self.counters.requests_received += 1
        needs = not isinstance(event, Request) or event.needs_answer
        self.machine.receive_request(event, needs_answer=needs)
        return event

    def _reply_for(self, msg: Message) -> Reply:
        """Pair a reply with the oldest unanswered request (OA-SESS-33, `CLIENT_RULES`)."""
        paired = self.machine.pair(msg)
        assert paired.pending is not None  # CLIENT_RULES raise instead
        self.counters.replies_received += 1
        return Reply(request_id=paired.pending.id, message=msg)


def _xml_with_sizes(msg: Message, sizes: Sequence[int]) -> bytes:
    """Encode `msg` announcing chunks of `sizes` (OA-FRAME-4) without having the chunks.

    The slots go where the codec writes them for a message that holds its chunks: after
    `netprotocol`, before `content` and the extension slots (canonical order, spec 3.5).
    """
    if not sizes:
        return encode_message(msg)
    root = message_to_element(msg)
    at = next((i for i, el in enumerate(root) if el.tag not in _BEFORE_SIZES), len(root))
    total = etree.Element("totalbinarysize")
    total.text = str(sum(sizes))
    listed = etree.Element("binarysizes")
    listed.text = ",".join(map(str, sizes))
    root.insert(at, total)
    root.insert(at, listed)
    return bytes(etree.tostring(root, encoding="UTF-8"))
