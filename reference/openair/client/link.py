"""The requester side of a connection over asyncio streams (spec 6.1).

`Link` drives a `ClientConnection` in the REQUESTER role: it sends requests within the window
(OA-SESS-17/18), pairs each reply with the oldest waiting request (OA-SESS-33) and, when a reply
does not come in time, closes the connection (OA-SESS-27) so that its owner can reconnect.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import ssl
import time
from collections import deque
from collections.abc import Callable

from openair.client.session import Buffer, ClientConnection, Closed, Reply
from openair.protocol.errors import ConnectionClosedError, RemoteProtocolError, RequestTimeoutError
from openair.protocol.framing import coalesce
from openair.protocol.message import Message

_READ_SIZE = 65536
# Frame parts at least this large are written as they are (never copied); smaller neighbours are
# joined first, so that a small sample costs one write rather than one per part.
_JOIN_BELOW = 16384

log = logging.getLogger("openair.client")


class Link:
    """A requester connection: sends requests, pairs replies with waiting futures."""

    def __init__(
        self,
        reader: asyncio.StreamReader,
        writer: asyncio.StreamWriter,
        conn: ClientConnection,
        on_lost: Callable[[Link, BaseException | None], None],
    ) -> None:
        self.conn = conn
        self._reader = reader
        self._writer = writer
        self._on_lost = on_lost
        self._waiting: deque[asyncio.Future[Message]] = deque()
        self._slot_waiters: deque[asyncio.Future[None]] = deque()
        self.closed = False
        self._closing = False
        self.last_traffic = time.monotonic()
        self._task = asyncio.get_running_loop().create_task(self._read_loop())

    @classmethod
    async def open(
        cls,
        host: str,
        port: int,
        *,
        now: Callable[[], int],
        name: str,
        on_lost: Callable[[Link, BaseException | None], None],
        tls: ssl.SSLContext | None = None,
    ) -> Link:
        """Open a TCP (or TLS, OA-AUTH-10) connection and wrap it (window 1 for now)."""
        reader, writer = await asyncio.open_connection(host, port, ssl=tls)
        return cls(reader, writer, ClientConnection(now=now, name=name), on_lost)

    @property
    def local_host(self) -> str:
        """The local address of this connection (the interface that reaches the server)."""
        sockname = self._writer.get_extra_info("sockname")
        return str(sockname[0]) if sockname else "127.0.0.1"

    def set_window(self, window: int) -> None:
        """Change how many requests may be in flight (after capabilities are known)."""
        self.conn.window = window
        self._wake_slot(every=True)

    def _wake_slot(self, *, every: bool = False) -> None:
        """Wake the oldest task waiting for a free request slot (or every one)."""
        while self._slot_waiters:
            waiter = self._slot_waiters.popleft()
            if not waiter.done():
                waiter.set_result(None)
                if not every:
                    return

    async def _slot(self) -> None:
        """Wait until one more request fits in the window (OA-SESS-17/18)."""
        while not self.conn.can_send:
            if self.closed:
                raise ConnectionClosedError("the connection to the server is closed")
            waiter = asyncio.get_running_loop().create_future()
            self._slot_waiters.append(waiter)
            try:
                await waiter
            finally:
                with contextlib.suppress(ValueError):
                    self._slot_waiters.remove(waiter)

    def _check_open(self) -> None:
        if self.closed:
            raise ConnectionClosedError("the connection to the server is closed")

    async def _reserve(self, timeout: float | None, what: str = "") -> None:
        """Wait until the connection may send one more request, for at most `timeout` s."""
        self._check_open()
        try:
            async with asyncio.timeout(timeout):
                await self._slot()
        except TimeoutError:
            raise RequestTimeoutError(f"{what}no request slot within {timeout} s") from None

    async def _write(self, *parts: Buffer) -> None:
        """Write a frame (or its parts) and wait for the transport's flow control."""
        self.last_traffic = time.monotonic()
        for part in parts:
            self._writer.write(part)
        try:
            await self._writer.drain()
        except OSError as exc:
            raise ConnectionClosedError(f"write failed: {exc}") from exc

    async def submit(
        self, msg: Message, timeout: float | None
    ) -> tuple[Message, asyncio.Future[Message]]:
        """Send request `msg` once the window allows; return it as sent and its reply future."""
        await self._reserve(timeout, f"{msg.type}: ")
        data = self.conn.send_request(msg)
        sent = self.conn.last_sent or msg
        future: asyncio.Future[Message] = asyncio.get_running_loop().create_future()
        self._waiting.append(future)
        await self._write(data)
        return sent, future

    async def submit_parts(
        self, encode: Callable[[ClientConnection], list[Buffer]], timeout: float | None
    ) -> asyncio.Future[Message] | None:
        """Send a frame given as parts once the window allows; return its reply future.

        `encode` builds the parts (`ClientConnection.send_request_parts` or `send_binary`); it
        is called once a request slot is free. The parts are written one by one, so a large
        chunk is not joined into a new buffer first. None when the frame expects no reply
        (a `noreply` message, OA-MSG-15).
        """
        await self._reserve(timeout)
        before = self.conn.in_flight
        parts = encode(self.conn)
        future: asyncio.Future[Message] | None = None
        if self.conn.in_flight > before:
            future = asyncio.get_running_loop().create_future()
            self._waiting.append(future)
        await self._write(*coalesce(parts, _JOIN_BELOW))
        return future

    async def send_noreply(self, msg: Message) -> Message:
        """Send a `noreply` message: no acknowledgement follows (OA-MSG-15)."""
        self._check_open()
        data = self.conn.send_request(msg)
        await self._write(data)
        return self.conn.last_sent or msg

    async def result(self, future: asyncio.Future[Message], timeout: float | None) -> Message:
        """Wait for a reply; on timeout close the connection (OA-SESS-27)."""
        try:
            async with asyncio.timeout(timeout):
                return await future
        except TimeoutError:
            self.abort()
            raise RequestTimeoutError(f"no reply within {timeout} s") from None

    async def request(self, msg: Message, timeout: float | None) -> tuple[Message, Message]:
        """Send `msg` and return it as sent together with its reply."""
        sent, future = await self.submit(msg, timeout)
        return sent, await self.result(future, timeout)

    def _resolve(self, reply: Message) -> None:
        """Hand a reply to the oldest waiting request (OA-SESS-33)."""
        future = self._waiting.popleft()
        if not future.done():
            future.set_result(reply)
        self._wake_slot()

    async def _read_loop(self) -> None:
        """Read replies until the connection ends."""
        error: BaseException | None = None
        try:
            while True:
                data = await self._reader.read(_READ_SIZE)
                self.last_traffic = time.monotonic()
                for event in self.conn.receive_data(data):
                    if isinstance(event, Reply):
                        self._resolve(event.message)
                    elif isinstance(event, Closed):
                        return
        except (OSError, RemoteProtocolError) as exc:
            error = exc
        except Exception as exc:  # a defect must not leave requests waiting forever
            log.exception("reading replies failed")
            error = exc
        finally:
            self._shutdown(error)

    def _shutdown(self, error: BaseException | None) -> None:
        """Fail every waiting request and report the loss (unless closed on purpose)."""
        if self.closed:
            return
        self.closed = True
        reason = f"connection lost: {error}" if error else "connection closed by the server"
        while self._waiting:
            future = self._waiting.popleft()
            if not future.done():
                future.set_exception(ConnectionClosedError(reason))
        self._wake_slot(every=True)
        self._writer.close()
        if not self._closing:
            self._on_lost(self, error)

    def abort(self) -> None:
        """Close the connection as if it were lost (the owner reconnects)."""
        self._writer.close()
        self._task.cancel()
        self._shutdown(None)

    async def close(self) -> None:
        """Close the connection on purpose."""
        self._closing = True
        self._task.cancel()
        self._shutdown(None)
        with contextlib.suppress(Exception):
            await self._writer.wait_closed()
        await asyncio.gather(self._task, return_exceptions=True)
