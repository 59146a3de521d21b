"""The monitor's HTTP connections: one asyncio Protocol per connection, keep-alive, deadlines.

A connection reads requests with the sans-I/O `RequestParser`, asks its `HttpApp` for a
`Response` (synchronously: every answer is built from the server's memory at once) and writes
it. Requests are answered in order; while the peer does not read its responses (the write
buffer is over the transport's high mark) the connection stops reading. A request whose head
and body have not arrived `head_deadline_s` after its first byte is answered 408 and closed
(slowloris); an idle keep-alive connection is closed after `idle_s`. A refused request is
answered with its status and the connection closed. An `EventStream` response turns the
connection into a server-sent event stream (text/event-stream) that the app writes to until
either side closes it; bytes received after that are discarded.
"""

from __future__ import annotations

import asyncio
import contextlib
import email.utils
import json
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import openair
from openair.monitor.httpwire import HttpError, HttpLimits, Request, RequestParser, encode_head

__all__ = ["EventStream", "HttpApp", "HttpConnection", "Response", "error_response"]

log = logging.getLogger("openair.monitor")

_SERVER = f"openair-kit/{openair.__version__}"
_DISCARD_LIMIT = 1 << 16  # bytes a streaming peer may send before it is cut off


@dataclass(frozen=True, slots=True, kw_only=True)
class Response:
    """A whole response: status, content type, body and extra headers."""

    status: int = 200
    content_type: str = "application/json"
    body: bytes = b""
    headers: tuple[tuple[str, str], ...] = ()
    close: bool = False  # close the connection after it


@dataclass(slots=True, kw_only=True)
class EventStream:
    """A response that stays open: `on_open(conn)` is called once its head is written."""

    on_open: Callable[[HttpConnection], None]
    headers: tuple[tuple[str, str], ...] = field(default_factory=tuple)


class HttpApp(Protocol):
    """What a connection asks of the monitor."""

    limits: HttpLimits

    def respond(self, request: Request, peer: str) -> Response | EventStream:
        """Answer one request from the peer address `peer`."""

    def opened(self, conn: HttpConnection) -> bool:
        """Count a new connection; False refuses it (too many)."""

    def closed(self, conn: HttpConnection) -> None:
        """Forget a connection."""


def _peer_host(transport: asyncio.BaseTransport) -> str:
    """Return the peer's address, an IPv4-mapped IPv6 address as plain IPv4."""
    peer = transport.get_extra_info("peername")
    host = str(peer[0]) if peer else ""
    return host.removeprefix("::ffff:") if host.startswith("::ffff:") and "." in host else host


class HttpConnection(asyncio.Protocol):
    """One HTTP connection of the monitor (on the main port or the HTTP port)."""

    def __init__(self, app: HttpApp) -> None:
        self.app = app
        self.limits = app.limits
        self.transport: asyncio.Transport | None = None
        self.peer = ""
        self.streaming = False
        self.on_close: Callable[[], None] | None = None  # set by the owner of an event stream
        self._parser = RequestParser(self.limits)
        self._loop = asyncio.get_running_loop()
        self._timer: asyncio.TimerHandle | None = None
        self._request_started: float | None = None
        self._closing = False
        self._paused = False
        self._discarded = 0

    # -- transport callbacks ------------------------------------------------------------------

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        self.peer = _peer_host(transport)
        if not self.app.opened(self):
            self._refuse(HttpError(503, "too many monitor connections"))
            return
        self._arm(self.limits.idle_s)

    def data_received(self, data: bytes) -> None:
        if self._closing:
            return
        if self.streaming:
            self._discarded += len(data)  # an event stream reads nothing more
            if self._discarded > _DISCARD_LIMIT:
                self.close()
            return
        if self._parser.buffered == 0 and self._request_started is None:
            self._request_started = self._loop.time()
        self._parser.feed(data)
        self._serve()

    def eof_received(self) -> bool | None:
        return None  # close: a half-closed peer gets no more answers

    def connection_lost(self, exc: Exception | None) -> None:
        self._closing = True
        if self._timer is not None:
            self._timer.cancel()
        if self.on_close is not None:
            self.on_close()
        self.app.closed(self)

    def pause_writing(self) -> None:
        self._paused = True
        if self.transport is not None and not self.streaming:
            self.transport.pause_reading()  # the peer is not reading its answers

    def resume_writing(self) -> None:
        self._paused = False
        if self.transport is not None and not self._closing and not self.streaming:
            self.transport.resume_reading()
            self._serve()

    # -- requests -------------------------------------------------------------------------------

    def _serve(self) -> None:
        """Answer every complete request buffered, in order, while the peer keeps reading."""
        while not self._closing and not self.streaming and not self._paused:
            try:
                request = self._parser.next_request()
            except HttpError as err:
                self._refuse(err)
                return
            if request is None:
                break
            self._request_started = self._loop.time() if self._parser.buffered else None
            self._answer(request)
        if not self._closing and not self.streaming:
            self._rearm()

    def _answer(self, request: Request) -> None:
        try:
            result = self.app.respond(request, self.peer)
        except HttpError as err:
            result = error_response(err, close=False)
        except Exception:  # a bug must not take the server down: answer 500, keep serving
            log.exception("event=monitor_error target=%r", request.target[:200])
            result = error_response(HttpError(500, "internal error"), close=True)
        if isinstance(result, EventStream):
            self._open_stream(request, result)
        else:
            self.send(request, result)

    def send(self, request: Request, response: Response) -> None:
        """Write one response; HEAD gets the head only (RFC 9110 9.3.2)."""
        keep = request.keep_alive and not response.close
        headers = [
            ("Server", _SERVER),
            ("Date", email.utils.formatdate(usegmt=True)),
            ("Content-Type", response.content_type),
            ("Content-Length", str(len(response.body))),
            *response.headers,
            ("Connection", "keep-alive" if keep else "close"),
        ]
        body = b"" if request.method == "HEAD" else response.body
        self.write(encode_head(response.status, headers) + body)
        if not keep:
            self.close()

    def _open_stream(self, request: Request, stream: EventStream) -> None:
        headers = [
            ("Server", _SERVER),
            ("Content-Type", "text/event-stream; charset=utf-8"),
            ("Cache-Control", "no-store"),
            *stream.headers,
            ("Connection", "close"),  # the body ends when the connection does
        ]
        self.write(encode_head(200, headers))
        if request.method == "HEAD":
            self.close()
            return
        self.streaming = True
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        stream.on_open(self)

    def _refuse(self, err: HttpError) -> None:
        """Answer a refused request and close (RFC 9112 9.6: the stream may be out of step)."""
        response = error_response(err, close=True)
        head = [
            ("Server", _SERVER),
            ("Content-Type", response.content_type),
            ("Content-Length", str(len(response.body))),
            ("Connection", "close"),
        ]
        self.write(encode_head(err.status, head) + response.body)
        self.close()

    # -- deadlines --------------------------------------------------------------------------------

    def _arm(self, delay: float) -> None:
        if self._timer is not None:
            self._timer.cancel()
        self._timer = self._loop.call_later(delay, self._expired)

    def _rearm(self) -> None:
        """Idle deadline between requests; the request deadline while one is arriving."""
        started = self._request_started
        if started is None:
            self._arm(self.limits.idle_s)
        else:
            self._arm(max(0.0, started + self.limits.head_deadline_s - self._loop.time()))

    def _expired(self) -> None:
        self._timer = None
        if self._closing or self.streaming:
            return
        if self._request_started is None:
            self.close()  # an idle keep-alive connection: close quietly
        else:
            self._refuse(HttpError(408, "the request did not arrive in time"))

    # -- output -----------------------------------------------------------------------------------

    def write(self, data: bytes) -> None:
        """Write bytes unless the connection is closing."""
        if self.transport is not None and not self._closing:
            self.transport.write(data)

    @property
    def closing(self) -> bool:
        """True once the connection is closing or closed."""
        return self._closing

    @property
    def buffered(self) -> int:
        """Bytes written and not yet sent to the peer."""
        if self.transport is None or self._closing:
            return 0
        return self.transport.get_write_buffer_size()

    def close(self) -> None:
        """Close after the written bytes are sent."""
        if self._closing:
            return
        self._closing = True
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if self.transport is not None:
            with contextlib.suppress(Exception):
                self.transport.close()


def error_response(err: HttpError, *, close: bool) -> Response:
    """Return a JSON error answer (`{"error": detail, "status": n}`)."""
    body = json.dumps({"error": err.detail, "status": err.status}, ensure_ascii=False).encode()
    return Response(status=err.status, body=body, close=close)
