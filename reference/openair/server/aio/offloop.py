"""Large requests and replies of a server connection, handled on a worker thread (issue #19).

A request with at least `OFF_LOOP_XML` bytes of XML is decoded off the event loop, and a large
reply the router hands over as `Outcome.later` (a retrieve of thousands of messages) is written
off it: one client's 16 MiB post must not hold every other client for its parse. The connection
takes no further frame until that work is done (`ServerConnection._decoding` is non-zero), so
replies still go out in request order (OA-SESS-2).

These are steps of `ServerConnection` kept in a module of their own; they act on its state.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

from openair.protocol.codec import decode_with_lxml
from openair.protocol.errors import RemoteProtocolError
from openair.protocol.framing import Frame
from openair.protocol.message import Message
from openair.server.aio.budgets import off_loop_executor

if TYPE_CHECKING:
    from openair.server.aio.protocol import ServerConnection

__all__ = ["OFF_LOOP_XML", "decode_off_loop", "reply_off_loop"]

log = logging.getLogger("openair.server")

#: Requests with at least this much XML are decoded on a worker thread, and the connection waits
#: for them: one client's 16 MiB post must not hold every other client for its parse (issue #19).
#: They take the lxml path, which lets go of the interpreter lock while it parses; the regular
#: expressions of the fast path hold it (12 ms per MiB), which would stall the loop all the same.
OFF_LOOP_XML = 256 * 1024


def decode_off_loop(conn: ServerConnection, frame: Frame, received_ns: int) -> None:
    """Decode a large request on a worker thread; later frames wait for it (OA-SESS-2)."""
    conn._decoding = max(len(frame.xml), 1)
    loop = asyncio.get_running_loop()
    future = loop.run_in_executor(
        off_loop_executor(), decode_with_lxml, frame.xml, frame.chunks, conn._xml_limits
    )
    future.add_done_callback(lambda done: _decoded(conn, done, frame, received_ns))


def _decoded(
    conn: ServerConnection, done: asyncio.Future[Message], frame: Frame, received_ns: int
) -> None:
    """Route a request decoded off the loop, then take the frames behind it again."""
    conn._decoding = 0
    if conn.is_closing:
        return
    exc = done.exception()
    if isinstance(exc, RemoteProtocolError):
        conn._undecodable(frame, exc)
    elif exc is not None:
        log.warning("event=decode_failed conn=%d detail=%r", conn.conn_id, str(exc))
        conn.abort()
        return
    else:
        conn._route(frame, done.result(), received_ns)
    conn._resume()


def reply_off_loop(
    conn: ServerConnection, later: Callable[[], tuple[Message, bytes | None]]
) -> None:
    """Write a large reply on a worker thread; later requests wait for it (OA-SESS-2).

    A retrieve of thousands of messages takes a second to write (issue #19, item 6).
    """
    conn._decoding = 1
    future = asyncio.get_running_loop().run_in_executor(off_loop_executor(), later)
    future.add_done_callback(lambda done: _replied(conn, done))


def _replied(conn: ServerConnection, done: asyncio.Future[tuple[Message, bytes | None]]) -> None:
    conn._decoding = 0
    if conn.is_closing:
        return
    exc = done.exception()
    if exc is not None:
        log.warning("event=reply_failed conn=%d detail=%r", conn.conn_id, str(exc))
        conn.abort()
        return
    reply, wire = done.result()
    conn._send(reply, wire=wire)
    conn._resume()
