"""The module's receiving side: its listening port and its callback connection (spec 6.5, 6.6).

A server delivers to a module either by connecting to the port of its BIND_ACCEPT or over the
callback connection the module opened with a `Receive` frame (OA-DELIV-1); a module accepts both
(OA-DELIV-2). On every such connection the server is the requester and the module answers each
request in arrival order (OA-SESS-2, OA-SESS-11): `serve_responder` runs that loop over one
asyncio stream pair, `Listener` owns the listening socket and every connection it accepted.

The handler sees each request with the time it arrived (read from the clock right after the bytes
arrived, before any parsing: OA-TIME-3 applied to the module) and returns the reply type, or None
for the default answer. A handler that raises an `OpenAIRError` gets RECEIVE_ERROR with
`NAME: detail` sent back (OA-SESS-11, OA-ERR-2).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import ssl
import time
from collections.abc import Awaitable, Callable, Coroutine, Iterable

from openair.client.session import ClientConnection, Closed, Invalid, Reply, Request, Role
from openair.protocol.errors import OpenAIRError, RemoteProtocolError
from openair.protocol.message import Message

log = logging.getLogger("openair.client")

#: Called for each delivered request with its arrival time (ns); returns the reply type or None.
Handler = Callable[[Message, int], Awaitable[str | None]]
#: Called with the reason when a delivery is lost because it cannot be read (OA-MSG-20).
DropHandler = Callable[[str], None]
#: Proves the module's name on a fresh connection before its Receive frame (spec 14.3).
Prover = Callable[[asyncio.StreamReader, asyncio.StreamWriter, ClientConnection], Awaitable[None]]

_READ_SIZE = 65536


def _dropped(on_drop: DropHandler | None, reason: str) -> None:
    """Log and count a delivery that cannot be read: never lose one silently (OA-MSG-20)."""
    log.warning("delivery dropped: %s", reason)
    if on_drop is not None:
        on_drop(reason)


async def _answer(
    conn: ClientConnection,
    event: Request | Invalid,
    handler: Handler,
    received_ns: int,
    on_drop: DropHandler | None = None,
) -> bytes | None:
    """Run the handler for one request and return the answer frame (None for noreply)."""
    if isinstance(event, Invalid):
        _dropped(on_drop, event.error.wire_text())
        return conn.answer(event)  # OA-ERR-3: RECEIVE_ERROR, the connection stays usable
    try:
        kind = await handler(event.message, received_ns)
    except OpenAIRError as exc:
        _dropped(on_drop, f"{event.message.type!r} {event.message.id!r}: {exc.wire_text()}")
        if not event.needs_answer:
            return None
        return conn.answer(event, "RECEIVE_ERROR", content=exc.wire_text())  # OA-ERR-2
    if not event.needs_answer:
        return None  # OA-MSG-15: a noreply delivery is never acknowledged
    return conn.answer(event, kind)


async def serve_responder(
    reader: asyncio.StreamReader,
    writer: asyncio.StreamWriter,
    conn: ClientConnection,
    handler: Handler,
    on_drop: DropHandler | None = None,
) -> None:
    """Answer the requests arriving on one connection until it closes.

    Returns when the peer closes; a remote protocol error closes the connection (OA-FRAME-9)
    and is logged, never raised: an error on one connection does not affect others (OA-ERR-4).
    Every delivery that cannot be read is logged and reported to `on_drop` (OA-MSG-20).
    """
    try:
        while True:
            data = await reader.read(_READ_SIZE)
            received_ns = time.time_ns()  # the first act on arrival
            for event in conn.receive_data(data):
                if isinstance(event, Closed):
                    return
                if isinstance(event, Reply):
                    continue  # a responder session never pairs replies (OA-SESS-28)
                frame = await _answer(conn, event, handler, received_ns, on_drop)
                if frame is not None:
                    writer.write(frame)
            await writer.drain()
    except RemoteProtocolError as exc:
        _dropped(on_drop, f"delivery connection closed: {exc.wire_text()}")
    except OSError as exc:
        log.debug("delivery connection lost: %s", exc)
    except Exception:
        log.exception("delivery connection failed")
    finally:
        writer.close()
        with contextlib.suppress(Exception):
            await writer.wait_closed()


class Listener:
    """The module's delivery side: a listening socket and an optional callback connection.

    `extensions` are those the module declared and the server advertised; they apply to every
    delivery (OA-SESS-19). `now` is the clock used to stamp answers.
    """

    def __init__(
        self,
        handler: Handler,
        *,
        name: str,
        extensions: Iterable[str] = (),
        now: Callable[[], int] = time.time_ns,
        on_drop: DropHandler | None = None,
    ) -> None:
        self._handler = handler
        self._on_drop = on_drop
        self._name = name
        self.extensions = frozenset(extensions)
        self._now = now
        self._server: asyncio.Server | None = None
        self._tasks: set[asyncio.Task[None]] = set()
        self._callback: asyncio.Task[None] | None = None
        self.port: int | None = None
        self.accepted = 0

    def _session(self, role: Role) -> ClientConnection:
        """Build the session of one delivery connection."""
        # Several deliveries may be in flight under `pipelining`; answers still follow order.
        return ClientConnection(role, now=self._now, extensions=self.extensions, name=self._name)

    def _spawn(self, coro: Coroutine[object, object, None]) -> asyncio.Task[None]:
        """Run one connection loop as a task owned by this listener."""
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    async def _accepted(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        """Serve one connection the server opened to the listening port (OA-DELIV-2)."""
        self.accepted += 1
        task = asyncio.current_task()
        if task is not None:
            self._tasks.add(task)
            task.add_done_callback(self._tasks.discard)
        session = self._session(Role.RESPONDER)
        await serve_responder(reader, writer, session, self._handler, self._on_drop)

    async def listen(self, host: str, port: int) -> int:
        """Listen on `host:port` (the BIND_ACCEPT port, OA-DELIV-10) and return the port."""
        self._server = await asyncio.start_server(self._accepted, host, port)
        self.port = self._server.sockets[0].getsockname()[1]
        return self.port

    @property
    def has_callback(self) -> bool:
        """True while the callback connection is open."""
        return self._callback is not None and not self._callback.done()

    async def open_callback(
        self,
        host: str,
        port: int,
        notification: Message,
        *,
        tls: ssl.SSLContext | None = None,
        prove: Prover | None = None,
    ) -> None:
        """Open the callback connection: one `Receive` frame, then serve (OA-SESS-7).

        A callback connection opened earlier is closed first: the newer one replaces it. In
        secure mode `prove` proves the module's name first (OA-AUTH-6).
        """
        await self.close_callback()
        reader, writer = await asyncio.open_connection(host, port, ssl=tls)
        conn = self._session(Role.REQUESTER)
        if prove is not None:
            try:
                await prove(reader, writer, conn)
            except BaseException:
                writer.close()
                raise
        writer.write(conn.send_notification(notification))
        await writer.drain()
        serve = serve_responder(reader, writer, conn, self._handler, self._on_drop)
        self._callback = self._spawn(serve)

    async def close_callback(self) -> None:
        """Close the callback connection, if one is open."""
        task, self._callback = self._callback, None
        if task is not None and not task.done():
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)

    async def stop_listening(self) -> None:
        """Close the listening socket; connections already accepted keep being served."""
        if self._server is not None:
            self._server.close()
            await self._server.wait_closed()
            self._server = None
            self.port = None

    async def close(self) -> None:
        """Close the listening socket and every delivery connection."""
        server, self._server = self._server, None
        if server is not None:
            server.close()
        for task in list(self._tasks):
            task.cancel()
        if self._tasks:
            await asyncio.gather(*self._tasks, return_exceptions=True)
        if server is not None:
            await server.wait_closed()
        self.port = None
