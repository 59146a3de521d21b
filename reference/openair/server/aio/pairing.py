"""What waits for a reply on a server connection, and how a reply reaches it (OA-SESS-33).

The pairing rules themselves are the shared sans-I/O machine
(`openair.protocol.connection.Connection` with `SERVER_RULES`); this module holds the asyncio
side of it: the waiter types a delivery hands the connection (a future, or the dispatcher's
cheaper callback), ending a wait, and handing a paired reply to its waiter. It also reads the
`id` and `from` of a request that failed to decode, for the error reply (OA-SESS-1), and the
`Requester`: the requester side of a connection (deliveries sent, replies paired).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import weakref
from collections.abc import Callable
from typing import TYPE_CHECKING

from openair.protocol.codec import from_frame
from openair.protocol.connection import Connection, Pending, Role, answer_type
from openair.protocol.errors import (
    ApiMisuseError,
    ConnectionClosedError,
    OpenAIRError,
    RemoteProtocolError,
)
from openair.protocol.framing import Frame, Wire
from openair.protocol.message import Message
from openair.protocol.xmlsafe import XmlLimits, local_name, parse_xml

if TYPE_CHECKING:
    from openair.server.aio.protocol import ServerConnection

__all__ = [
    "ReplyCallback",
    "Requester",
    "Waiter",
    "Wire",
    "consume",
    "fail_waiter",
    "is_callback",
    "resolve",
    "salvage",
]

log = logging.getLogger("openair.server")

#: Called with the reply, or with the error that ends the wait (a decode error, the connection
#: closing, CancelledError when an unanswered KEEPALIVE is passed over).
ReplyCallback = Callable[[Message | None, BaseException | None], None]


#: What waits for a delivery's reply: its future, or the dispatcher's cheaper callback (None: it
#: keeps its place in the pairing but says nothing).
Waiter = asyncio.Future[Message] | ReplyCallback | None


def fail_waiter(waiter: Waiter, error: BaseException) -> None:
    """End the wait of `waiter` with `error` (CancelledError: a KEEPALIVE passed over)."""
    if isinstance(waiter, asyncio.Future):
        if not waiter.done():
            if isinstance(error, asyncio.CancelledError):
                waiter.cancel()
            else:
                waiter.set_exception(error)
    elif waiter is not None:
        waiter(None, error)


def is_callback(pending: Pending[Waiter]) -> bool:
    """Whether a delivery awaiting its reply was sent with a callback (the dispatcher's path)."""
    return pending.token is not None and not isinstance(pending.token, asyncio.Future)


def resolve(
    machine: Connection[Waiter],
    msg: Message | None,
    error: Exception | None,
    *,
    conn_id: int,
    module: str,
) -> None:
    """Hand a reply (or its decode error) to the delivery it answers (`SERVER_RULES`)."""
    paired = machine.pair(msg)
    for passed in paired.passed_over:  # OA-KEEP-3: never blocks the pairing of later replies
        fail_waiter(passed.token, asyncio.CancelledError())
    if paired.pending is None:
        log.warning(
            "event=protocol_error conn=%d module=%s detail=%s", conn_id, module, paired.note
        )
        return
    waiter = paired.pending.token
    if isinstance(waiter, asyncio.Future):
        if waiter.done():
            return
        if error is not None:
            waiter.set_exception(error)
        elif msg is not None:
            waiter.set_result(msg)
    elif waiter is not None:
        waiter(msg, error)


def consume(future: asyncio.Future[Message]) -> None:
    """Retrieve a KEEPALIVE's outcome so that asyncio never reports it as unretrieved."""
    if not future.cancelled():
        future.exception()


def salvage(xml: bytes | bytearray, limits: XmlLimits) -> tuple[str, str]:
    """Return the `id` and `from` of a message that failed to decode, when they can be read.

    OA-SESS-1: the error reply's `isresponse` is the request's id, empty when unreadable.
    """
    with contextlib.suppress(OpenAIRError, ValueError):
        root = parse_xml(xml, limits)
        found = {local_name(el): (el.text or "").strip() for el in root}
        return found.get("id", ""), found.get("from", "")
    return "", ""


class Requester:
    """The requester side of a CALLBACK, OUTBOUND or PUSH connection (OA-SESS-28, OA-SESS-33).

    Sends deliveries (and KEEPALIVE, pushed samples) and pairs each reply with the oldest request
    awaiting one; answers a PING or KEEPALIVE the peer sends out of turn (OA-SESS-10, OA-KEEP-2).
    """

    __slots__ = ("_conn",)

    def __init__(self, conn: ServerConnection) -> None:
        self._conn = weakref.ref(conn)  # weak: no cycle with the connection (see Responder)

    @property
    def conn(self) -> ServerConnection:
        """The connection these requests go out on."""
        conn = self._conn()
        assert conn is not None, "a caller outlived the connection"
        return conn

    def send_request(self, msg: Message, wire: Wire | None = None) -> asyncio.Future[Message]:
        """Send a request; return its reply's future.

        `wire`, when given, is the Message frame of `msg` already written (sent as it is).
        A `noreply` message (only sent to a module that declared `noreply`) expects no reply:
        its future is already resolved with the message itself (OA-MSG-15).
        """
        conn = self.conn
        if conn.role is Role.RESPONDER:
            raise ApiMisuseError("the server is not the requester on this connection")
        future: asyncio.Future[Message] = asyncio.get_running_loop().create_future()
        if conn.is_closing:
            future.set_exception(ConnectionClosedError("the connection is closed"))
            return future
        conn.machine.send_request(msg.id, msg.type, future, expects_reply=not msg.noreply)
        if not conn.send(msg, wire=wire):
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
        conn = self.conn
        if conn.role is Role.RESPONDER:
            raise ApiMisuseError("the server is not the requester on this connection")
        if conn.is_closing:
            callback(None, ConnectionClosedError("the connection is closed"))
            return
        pending = conn.machine.send_request(
            msg.id, msg.type, callback, expects_reply=not msg.noreply
        )
        if not conn.send(msg, wire=wire):
            if pending is not None:
                pending.token = None  # it keeps its place in the pairing, but says nothing
            callback(None, ConnectionClosedError("the connection was cut off"))
        elif msg.noreply:
            callback(msg, None)

    def on_reply(self, frame: Frame) -> None:
        """Pair a reply with the oldest delivery awaiting one (OA-SESS-33)."""
        conn = self.conn
        try:
            msg = from_frame(frame, conn.xml_limits)
        except RemoteProtocolError as exc:
            conn.log_error(exc)
            self.resolve(None, exc)  # an unreadable reply is still the reply (OA-SESS-33)
            return
        if conn.machine.is_out_of_turn(msg):
            conn.send(msg.reply(answer_type(msg.type), sender=conn.name))  # OA-SESS-10, KEEP-2
            return
        self.resolve(msg, None)

    def resolve(self, msg: Message | None, error: Exception | None) -> None:
        """Hand a reply (or its decode error) to the delivery it answers (`SERVER_RULES`)."""
        conn = self.conn
        resolve(conn.machine, msg, error, conn_id=conn.conn_id, module=conn.module)
