"""One OpenAIR connection's rules, for either end, without I/O (spec section 6, h11-style).

`Connection` is the state machine every end of an OpenAIR connection holds: the server's asyncio
Protocol, the client's `ClientConnection` (which adds framing and the codec), the conformance
harness's channels and the client-mode tap. It never touches a socket or a clock; it decides:

* which end sends requests (`Role`, OA-SESS-28) and when that turns around (a module's `Receive`
  frame, OA-SESS-7; a stream's push connection, spec 11.6) — the transition table `TRANSITIONS`;
* the pending-reply pairing: a request sent that expects a reply waits in order, and a reply is
  paired with the oldest one (OA-SESS-33) by the `PairingRules` of that end (`pair`);
* the requests received that are still owed an answer, answered in arrival order (OA-SESS-2);
* the answer each kind of request gets by default (`ANSWER_FOR`, `answer_type`: one table for
  PING and KEEPALIVE, OA-SESS-10, OA-SESS-11, OA-KEEP-2, OA-DELIV-4).

Each request carries a `token` of the caller's choosing (a future, a callback, the request
itself); `pair` hands it back with the reply, so the machine never knows what an I/O layer waits
with. Misuse (a request on a connection whose peer is the requester, answering out of order)
raises ApiMisuseError; anything after `close` raises ConnectionClosedError.
"""

from __future__ import annotations

import enum
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from openair.protocol.errors import ApiMisuseError, ConnectionClosedError, MessageInvalidError
from openair.protocol.message import Message

__all__ = [
    "ANSWER_FOR",
    "CLIENT_RULES",
    "HARNESS_RULES",
    "SERVER_RULES",
    "TRANSITIONS",
    "Action",
    "Connection",
    "Paired",
    "PairingRules",
    "Pending",
    "Role",
    "State",
    "answer_type",
]

#: The answer each session request gets (OA-SESS-10, OA-KEEP-2); every other request — a
#: delivery, a forwarded message — is acknowledged RECEIVE_ACCEPT (OA-SESS-11, OA-DELIV-4).
#: The one table: server, router, delivery, client, harness and tap all read it.
ANSWER_FOR: dict[str, str] = {"PING": "PING_SUCCESS", "KEEPALIVE": "KEEPALIVESUCCESS"}


def answer_type(request_type: str, default: str = "RECEIVE_ACCEPT") -> str:
    """The reply type a request of `request_type` gets by default (OA-SESS-11, OA-DELIV-4)."""
    return ANSWER_FOR.get(request_type, default)


class Role(enum.Enum):
    """Which end sends requests on a connection, and how it came to (OA-SESS-28).

    Five roles; only `RESPONDER` receives requests, the other four send them:

    * REQUESTER — this end opened the connection to send requests (a module's primary one).
    * RESPONDER — the peer sends requests: a server's inbound connection; a module's callback
      connection after its `Receive` frame, or one the server opened to its listening port.
    * CALLBACK — (server) a module turned its connection with a `Receive` frame (OA-SESS-7).
    * OUTBOUND — (server) opened to a module's listening port to deliver (OA-DELIV-1).
    * PUSH — (server) a stream's push connection: the server sends DATASAMPLEs (spec 11.6).
    """

    REQUESTER = "requester"
    RESPONDER = "responder"
    CALLBACK = "callback"
    OUTBOUND = "outbound"
    PUSH = "push"

    @property
    def sends_requests(self) -> bool:
        """True when this end is the requester in this role."""
        return self is not Role.RESPONDER


class State(enum.Enum):
    """The state of a `Connection`: which end requests, or that it ended."""

    REQUESTER = "requester"
    RESPONDER = "responder"
    CLOSED = "closed"
    ERROR = "error"


class Action(enum.Enum):
    """What this end or the peer does to a connection (the columns of the state table)."""

    SEND_REQUEST = "send_request"
    SEND_NOTIFICATION = "send_notification"  # this end's Receive frame (OA-SESS-7)
    TURN = "turn"  # the peer's Receive frame was accepted, or a push stream began (11.6)
    RECEIVE = "receive_data"
    ANSWER = "answer"
    PEER_CLOSED = "peer_closed"
    CLOSE = "close"
    PROTOCOL_ERROR = "protocol_error"


#: (state, action) -> next state. A missing key is misuse (house style: state machines are tables).
TRANSITIONS: dict[tuple[State, Action], State] = {
    (State.REQUESTER, Action.SEND_REQUEST): State.REQUESTER,
    (State.REQUESTER, Action.SEND_NOTIFICATION): State.RESPONDER,  # OA-SESS-7, OA-SESS-28
    (State.REQUESTER, Action.RECEIVE): State.REQUESTER,
    # A requester may answer the session requests a peer sends out of turn (OA-SESS-10/KEEP-2).
    (State.REQUESTER, Action.ANSWER): State.REQUESTER,
    (State.REQUESTER, Action.PEER_CLOSED): State.CLOSED,
    (State.REQUESTER, Action.CLOSE): State.CLOSED,
    (State.REQUESTER, Action.PROTOCOL_ERROR): State.ERROR,
    (State.RESPONDER, Action.TURN): State.REQUESTER,  # OA-SESS-7, OA-SESS-28, spec 11.6
    (State.RESPONDER, Action.RECEIVE): State.RESPONDER,
    (State.RESPONDER, Action.ANSWER): State.RESPONDER,
    (State.RESPONDER, Action.PEER_CLOSED): State.CLOSED,
    (State.RESPONDER, Action.CLOSE): State.CLOSED,
    (State.RESPONDER, Action.PROTOCOL_ERROR): State.ERROR,
    (State.CLOSED, Action.RECEIVE): State.CLOSED,
    (State.CLOSED, Action.PEER_CLOSED): State.CLOSED,
    (State.CLOSED, Action.CLOSE): State.CLOSED,
    (State.CLOSED, Action.PROTOCOL_ERROR): State.CLOSED,
    (State.ERROR, Action.CLOSE): State.ERROR,
    (State.ERROR, Action.PEER_CLOSED): State.ERROR,
    (State.ERROR, Action.PROTOCOL_ERROR): State.ERROR,
}


@dataclass(frozen=True, slots=True, kw_only=True)
class PairingRules:
    """How one end pairs replies with its requests (OA-SESS-33).

    `isresponse`: "strict" — a non-empty `isresponse` must name the oldest request, else
    MessageInvalidError (a client checks the server, OA-SESS-2); "ignore" — replies pair in
    order whatever they name (the server, tolerant of legacy modules); "search" — a reply naming
    a later request pairs with it and the overtaking is noted (the conformance suite observes).
    `pass_over_keepalive`: an unanswered KEEPALIVE never blocks later replies (OA-KEEP-3).
    `answer_out_of_turn`: a PING or KEEPALIVE with empty `isresponse` received by a requester is
    a request to answer, not a reply (a tolerance: OA-SESS-28 forbids it, OA-SESS-10/KEEP-2).
    `orphan_error`: a reply with no request in flight is MessageInvalidError (else noted).
    """

    isresponse: str = "strict"
    pass_over_keepalive: bool = False
    answer_out_of_turn: bool = False
    orphan_error: bool = True


CLIENT_RULES = PairingRules()
SERVER_RULES = PairingRules(
    isresponse="ignore", pass_over_keepalive=True, answer_out_of_turn=True, orphan_error=False
)
HARNESS_RULES = PairingRules(isresponse="search", answer_out_of_turn=True, orphan_error=False)

T = TypeVar("T")


@dataclass(slots=True)
class Pending(Generic[T]):
    """A request sent and not yet answered, with the caller's token."""

    id: str
    type: str
    token: T


@dataclass(slots=True)
class Paired(Generic[T]):
    """What `pair` found for a reply.

    `pending` is the request it answers (None: no request in flight, or a request received out
    of turn: see `out_of_turn`). `passed_over` are KEEPALIVEs left unanswered (OA-KEEP-3);
    `note` says what was tolerated, for a trace or a log.
    """

    pending: Pending[T] | None
    passed_over: tuple[Pending[T], ...] = ()
    out_of_turn: bool = False
    note: str = ""


class Connection(Generic[T]):
    """The sans-I/O rules of one OpenAIR connection: role, state, pairing, answer order."""

    def __init__(self, role: Role = Role.RESPONDER, *, rules: PairingRules = CLIENT_RULES) -> None:
        self.role = role
        self.rules = rules
        self._state = State.REQUESTER if role.sends_requests else State.RESPONDER
        self._in_flight: deque[Pending[T]] = deque()
        self._to_answer: deque[Any] = deque()
        self.in_flight_peak = 0

    # -- state -----------------------------------------------------------------------------

    @property
    def state(self) -> State:
        """The current state."""
        return self._state

    @property
    def in_flight(self) -> int:
        """How many requests were sent and not answered yet."""
        return len(self._in_flight)

    @property
    def unanswered(self) -> int:
        """How many received requests still wait for their answer."""
        return len(self._to_answer)

    def pending(self) -> Iterator[Pending[T]]:
        """The requests awaiting replies, oldest first."""
        return iter(self._in_flight)

    def transition(self, action: Action) -> State:
        """Move to the next state by the table, or raise (ConnectionClosedError when ended)."""
        nxt = TRANSITIONS.get((self._state, action))
        if nxt is None:
            if self._state in (State.CLOSED, State.ERROR):
                raise ConnectionClosedError(f"cannot {action.value}: the connection has ended")
            raise ApiMisuseError(f"cannot {action.value} in state {self._state.value}")
        self._state = nxt
        return nxt

    def assume(self, role: Role) -> None:
        """Give an open connection `role` (an adapter that learns a role after building it)."""
        if self._state in (State.CLOSED, State.ERROR):
            raise ConnectionClosedError(f"cannot become {role.value}: the connection has ended")
        self.role = role
        self._state = State.REQUESTER if role.sends_requests else State.RESPONDER

    # -- requests this end sends --------------------------------------------------------------

    def send_request(
        self, request_id: str, type: str, token: T, *, expects_reply: bool = True
    ) -> Pending[T] | None:
        """Record a request sent; one that expects a reply waits for it in order (OA-SESS-33).

        Returns what waits (its `token` may be replaced), None when no reply is expected.
        """
        if self._state is not State.REQUESTER:  # the table's self-loop is the hot path
            self.transition(Action.SEND_REQUEST)
        if not expects_reply:
            return None
        pending = Pending(request_id, type, token)
        self._in_flight.append(pending)
        self.in_flight_peak = max(self.in_flight_peak, len(self._in_flight))
        return pending

    def send_notification(self) -> None:
        """This end sent its `Receive` frame: the peer requests from now on (OA-SESS-7)."""
        if self._state is State.REQUESTER and self._in_flight:
            raise ApiMisuseError("cannot turn a connection with requests in flight around")
        self.transition(Action.SEND_NOTIFICATION)
        self.role = Role.RESPONDER

    def turn(self, role: Role) -> None:
        """The peer's `Receive` was accepted (CALLBACK) or a push stream began (PUSH)."""
        if not role.sends_requests:
            raise ApiMisuseError(f"a connection turns to a requesting role, not {role.value}")
        self.transition(Action.TURN)
        self.role = role

    # -- replies this end receives -----------------------------------------------------------

    def is_out_of_turn(self, msg: Message) -> bool:
        """Whether `msg`, received by a requester, is a session request to answer (OA-SESS-10)."""
        return self.rules.answer_out_of_turn and msg.type in ANSWER_FOR and not msg.isresponse

    def pair(self, msg: Message | None) -> Paired[T]:
        """Pair a reply (None: one that could not be read) with its request (OA-SESS-33)."""
        if self._state is not State.REQUESTER:  # the table's self-loop is the hot path
            self.transition(Action.RECEIVE)
        rules = self.rules
        if msg is not None and rules.answer_out_of_turn and self.is_out_of_turn(msg):
            return Paired(None, (), True)
        in_flight = self._in_flight
        passed: tuple[Pending[T], ...] = ()
        if (
            rules.pass_over_keepalive
            and in_flight
            and in_flight[0].type == "KEEPALIVE"
            and (msg is None or msg.type != "KEEPALIVESUCCESS")
        ):
            passed = self._pass_over_keepalives()  # OA-KEEP-3
        if not in_flight:
            kind = "?" if msg is None else msg.type
            if rules.orphan_error:
                raise MessageInvalidError(f"reply {kind!r} with no request in flight")
            return Paired(None, passed, False, "reply with no request in flight")
        named = "" if msg is None else msg.isresponse
        # OA-SESS-33: an empty isresponse is accepted (Psyclone's KEEPALIVESUCCESS).
        if not named or rules.isresponse == "ignore" or named == in_flight[0].id:
            return Paired(in_flight.popleft(), passed)
        index, note = self._match(msg)
        head = in_flight[index]
        del in_flight[index]
        return Paired(head, passed, False, note)

    def _pass_over_keepalives(self) -> tuple[Pending[T], ...]:
        passed: list[Pending[T]] = []
        while self._in_flight and self._in_flight[0].type == "KEEPALIVE":
            passed.append(self._in_flight.popleft())
        return tuple(passed)

    def _match(self, msg: Message | None) -> tuple[int, str]:
        """The index of the request `msg` answers, and a note on what was tolerated."""
        named = "" if msg is None else msg.isresponse
        head = self._in_flight[0]
        mode = self.rules.isresponse
        # OA-SESS-33: an empty isresponse is accepted (Psyclone's KEEPALIVESUCCESS).
        if not named or named == head.id or mode == "ignore":
            return 0, ""
        if mode == "strict":  # a non-empty one naming another request: out of order (OA-SESS-2)
            assert msg is not None
            raise MessageInvalidError(f"reply {msg.type!r} answers {named!r}, expected {head.id!r}")
        for index, pending in enumerate(self._in_flight):
            if pending.id == named:
                return index, "a reply overtook an earlier request"
        return 0, (
            f"isresponse {named!r} names no outstanding request; "
            "paired with the oldest one (OA-SESS-33)"
        )

    def withdraw(self, pending: Pending[T]) -> None:
        """Forget a request that could not be sent after all (its write failed)."""
        for index, waiting in enumerate(self._in_flight):
            if waiting is pending:
                del self._in_flight[index]
                return

    def fail_pending(self) -> tuple[Pending[T], ...]:
        """Take every request still awaiting a reply (the connection ended without them)."""
        taken = tuple(self._in_flight)
        self._in_flight.clear()
        return taken

    # -- requests this end receives -----------------------------------------------------------

    def receive_request(self, request: Any, *, needs_answer: bool = True) -> None:
        """Record a request received; one that needs an answer waits in order (OA-SESS-2)."""
        if self._state is not State.RESPONDER:  # the table's self-loop is the hot path
            self.transition(Action.RECEIVE)
        if needs_answer:
            self._to_answer.append(request)

    def answer(self, request: Any) -> None:
        """Record that `request`, the oldest unanswered one, is answered now (OA-SESS-2)."""
        if self._state is State.RESPONDER:
            oldest = self._to_answer[0] if self._to_answer else None
            if oldest is not request:
                raise ApiMisuseError("answer the oldest unanswered request first (OA-SESS-2)")
        self.transition(Action.ANSWER)
        if self._to_answer and self._to_answer[0] is request:
            self._to_answer.popleft()

    # -- ending ------------------------------------------------------------------------------

    def close(self) -> None:
        """This end closes; later sends raise ConnectionClosedError."""
        self.transition(Action.CLOSE)

    def peer_closed(self) -> tuple[Pending[T], ...]:
        """The peer closed: return the requests that got no reply."""
        if self._state is State.CLOSED:
            return ()
        unanswered = self.fail_pending()
        self.transition(Action.PEER_CLOSED)
        return unanswered

    def protocol_error(self) -> None:
        """A remote protocol error ended the connection (OA-FRAME-9): sticky."""
        self.transition(Action.PROTOCOL_ERROR)
