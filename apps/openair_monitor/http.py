"""The monitor's HTTP/1.1 connections: h11 reads and writes, this module adds limits and deadlines.

One asyncio Protocol per connection drives an `h11.Connection` (RFC 9110/9112 parsing, framing,
keep-alive). h11 refuses malformed request lines and headers, a missing or repeated Host,
conflicting Content-Length values and an over-long head (431). On top of it, for a server that
faces any peer, the connection refuses: a request line over `max_request_line` (414) or one that
is not `METHOD target HTTP/x.y` (400) as soon as that line is complete, obsolete line folding
(400; h11 would unfold it), a target that is not an absolute path (400), control characters in
header values (400), more than `max_headers` fields (431), a body over `max_body` (413, before
it arrives), request bodies in chunked coding (501) and HTTP versions other than 1.0 and 1.1
(505). A refused request is answered with its status and the connection closed (RFC 9112 9.6).

A request whose head and body have not arrived `head_deadline_s` after its first byte is
answered 408 and closed (slowloris); an idle keep-alive connection is closed after `idle_s`.
Requests are answered in order as they complete (the app answers synchronously, from memory);
while the peer does not read its responses the connection stops reading. An `EventStream`
response keeps the response open (chunked) for server-sent events until either side closes;
bytes received after that are discarded.
"""

from __future__ import annotations

import asyncio
import contextlib
import email.utils
import http
import json
import logging
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import h11

import openair

__all__ = [
    "EventStream",
    "HttpApp",
    "HttpConnection",
    "HttpError",
    "HttpLimits",
    "Request",
    "Response",
    "error_response",
]

log = logging.getLogger("openair_monitor")

_SERVER = f"openair-kit/{openair.__version__}"
_DISCARD_LIMIT = 1 << 16  # bytes a streaming peer may send before it is cut off
_REQUEST_LINE = re.compile(rb"[!#$%&'*+\-.^_`|~0-9A-Za-z]+ [\x21-\x7e]+ HTTP/[0-9]\.[0-9]\r?")
_OBS_FOLD = re.compile(rb"\n[ \t]")
_BAD_VALUE = re.compile(rb"[\x00-\x08\x0a-\x1f\x7f]")  # HTAB, SP and obs-text are allowed
_VERSIONS = frozenset({b"1.0", b"1.1"})


@dataclass(frozen=True, slots=True, kw_only=True)
class HttpLimits:
    """Bounds on what one HTTP connection may send, and its deadlines (seconds)."""

    max_request_line: int = 8192
    max_header_bytes: int = 16384
    max_headers: int = 64
    max_body: int = 65536
    head_deadline_s: float = 10.0  # a request must be complete this long after its first byte
    idle_s: float = 30.0  # a keep-alive connection with no request in progress is closed
    max_connections: int = 128
    max_per_peer: int = 16  # connections from one address: half-sent requests cannot fill all
    max_streams: int = 32  # open event streams (SSE clients)

    def __post_init__(self) -> None:
        for name in self.__slots__:
            if getattr(self, name) <= 0:
                raise ValueError(f"HTTP limit {name} must be positive")


class HttpError(Exception):
    """A request the server refuses: answer `status` with `detail`."""

    def __init__(self, status: int, detail: str) -> None:
        super().__init__(f"{status} {detail}")
        self.status = status
        self.detail = detail


@dataclass(frozen=True, slots=True, kw_only=True)
class Request:
    """One request. Header names are lower-cased; `path` and `query` are still encoded."""

    method: str
    target: str
    version: str = "HTTP/1.1"
    headers: tuple[tuple[str, str], ...] = ()
    body: bytes = b""

    @property
    def path(self) -> str:
        return self.target.partition("?")[0]

    @property
    def query(self) -> str:
        return self.target.partition("?")[2]

    def header(self, name: str) -> str | None:
        """Return the value of header `name` (lower case), the first if repeated, or None."""
        return next((v for k, v in self.headers if k == name), None)


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


def screen_head(pending: bytes, limits: HttpLimits) -> None:
    """Refuse what h11 would only see once the whole head is in, and what it would accept.

    `pending` is the start of a request head not parsed yet: its request line is judged as
    soon as it is complete (a TLS hello or other garbage gets 400 at once, not 408 later), and
    obsolete line folding is refused rather than unfolded (RFC 9112 5.2), and a head over the
    limits is refused even when it arrived whole.
    """
    eol = pending.find(b"\n", 0, limits.max_request_line + 1)
    if eol < 0:
        if len(pending) > limits.max_request_line:
            raise HttpError(414, "the request line is too long")
        return
    if _REQUEST_LINE.fullmatch(pending[:eol]) is None:
        raise HttpError(400, "malformed request line")
    ends = [p for p in (pending.find(b"\n\r\n", eol), pending.find(b"\n\n", eol)) if p >= 0]
    head = pending[: min(ends) + 1] if ends else pending
    if len(head) > limits.max_request_line + limits.max_header_bytes:
        raise HttpError(431, "the header block is too large")  # h11 checks only what is partial
    if _OBS_FOLD.search(head, eol):
        raise HttpError(400, "obsolete line folding is not accepted")


def read_request(event: h11.Request, limits: HttpLimits) -> Request:
    """Check a request head h11 accepted against the monitor's rules; return it, body to come."""
    if event.http_version not in _VERSIONS:
        version = event.http_version.decode("ascii", "replace")
        raise HttpError(505, f"HTTP/{version} is not served (HTTP/1.0 and HTTP/1.1 are)")
    if not event.target.startswith(b"/"):
        raise HttpError(400, "the request target must be an absolute path")
    if len(event.headers) > limits.max_headers:
        raise HttpError(431, f"more than {limits.max_headers} header fields")
    if any(_BAD_VALUE.search(value) for _, value in event.headers):
        raise HttpError(400, "control character in a header value")
    headers = tuple((k.decode("ascii"), v.decode("latin-1")) for k, v in event.headers)
    request = Request(
        method=event.method.decode("ascii"),
        target=event.target.decode("ascii"),
        version="HTTP/" + event.http_version.decode("ascii"),
        headers=headers,
    )
    if request.header("transfer-encoding") is not None:
        raise HttpError(501, "Transfer-Encoding in requests is not supported")
    length = int(request.header("content-length") or 0)  # h11 checked it is one number
    if length > limits.max_body:
        raise HttpError(413, f"the body is larger than {limits.max_body} bytes")
    return request


def _head(status: int, headers: list[tuple[str, str]]) -> h11.Response:
    try:
        reason = http.HTTPStatus(status).phrase
    except ValueError:
        reason = ""
    return h11.Response(status_code=status, headers=headers, reason=reason)


class HttpConnection(asyncio.Protocol):
    """One HTTP connection of the monitor (on the main port or the HTTP port)."""

    def __init__(self, app: HttpApp) -> None:
        self.app = app
        self.limits = app.limits
        self.transport: asyncio.Transport | None = None
        self.peer = ""
        self.streaming = False
        self.on_close: Callable[[], None] | None = None  # set by the owner of an event stream
        self._h11 = h11.Connection(
            h11.SERVER,
            max_incomplete_event_size=self.limits.max_request_line + self.limits.max_header_bytes,
        )
        self._request: Request | None = None  # the head of the request being read
        self._body = bytearray()
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
        if self._waiting_for_head() and not self._h11.trailing_data[0]:
            data = data.lstrip(b"\r\n")  # RFC 9112 2.2: empty lines before a request
            if not data:
                return
        if self._request_started is None:
            self._request_started = self._loop.time()
        self._h11.receive_data(data)
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
        # asyncio (3.11) keeps a bound method of a socket transport on the transport: a cycle
        # that only the garbage collector frees, in pauses of the server's loop after many
        # connections (issue #19). Dropped here, the transport goes by reference counting.
        state = getattr(self.transport, "__dict__", None)
        if state is not None and state.get("_read_ready_cb") is not None:
            state["_read_ready_cb"] = None

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

    def _waiting_for_head(self) -> bool:
        return self._h11.their_state is h11.IDLE and self._request is None

    def _serve(self) -> None:
        """Answer every complete request received, in order, while the peer keeps reading."""
        while not self._closing and not self.streaming and not self._paused:
            try:
                if self._waiting_for_head():
                    screen_head(bytes(self._h11.trailing_data[0]), self.limits)
                event = self._h11.next_event()
                if not self._handle(event):
                    break
            except h11.RemoteProtocolError as exc:
                self._refuse(HttpError(exc.error_status_hint, str(exc) or "malformed request"))
            except HttpError as err:
                self._refuse(err)
        if not self._closing and not self.streaming:
            self._rearm()

    def _handle(self, event: object) -> bool:
        """Take one h11 event; False when there is nothing more to do until more data arrives."""
        if isinstance(event, h11.Request):
            self._request = read_request(event, self.limits)
            self._body.clear()
        elif isinstance(event, h11.Data):
            self._body += event.data
        elif isinstance(event, h11.EndOfMessage):
            request, self._request = self._request, None
            assert request is not None
            self._answer(
                Request(
                    method=request.method,
                    target=request.target,
                    version=request.version,
                    headers=request.headers,
                    body=bytes(self._body),
                )
            )
            self._next_cycle()
        elif isinstance(event, h11.ConnectionClosed):
            self.close()
            return False
        else:  # NEED_DATA, or PAUSED while a response is still open
            return False
        return True

    def _next_cycle(self) -> None:
        """After a response: the next request on this connection, or close (h11 decides)."""
        if self._closing or self.streaming:
            return
        if self._h11.our_state is h11.MUST_CLOSE or self._h11.their_state is h11.MUST_CLOSE:
            self.close()
            return
        self._h11.start_next_cycle()
        self._request_started = self._loop.time() if self._h11.trailing_data[0] else None

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
        """Write one response; HEAD gets the head only (RFC 9110 9.3.2, h11 frames it so)."""
        headers = [
            ("Server", _SERVER),
            ("Date", email.utils.formatdate(usegmt=True)),
            ("Content-Type", response.content_type),
            ("Content-Length", str(len(response.body))),
            *response.headers,
        ]
        if response.close:
            headers.append(("Connection", "close"))
        self._send(_head(response.status, headers))
        if request.method != "HEAD" and response.body:
            self._send(h11.Data(data=response.body))
        self._send(h11.EndOfMessage())

    def _open_stream(self, request: Request, stream: EventStream) -> None:
        headers = [
            ("Server", _SERVER),
            ("Content-Type", "text/event-stream; charset=utf-8"),
            ("Cache-Control", "no-store"),
            *stream.headers,
        ]
        if request.method == "HEAD":
            headers.append(("Content-Length", "0"))
            self._send(_head(200, headers))
            self._send(h11.EndOfMessage())
            self.close()
            return
        self._send(_head(200, headers))  # no length: chunked for 1.1, until close for 1.0
        self.streaming = True
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        stream.on_open(self)

    def _refuse(self, err: HttpError) -> None:
        """Answer a refused request and close (RFC 9112 9.6: the stream may be out of step)."""
        if self._h11.our_state in (h11.IDLE, h11.SEND_RESPONSE):
            response = error_response(err, close=True)
            headers = [
                ("Server", _SERVER),
                ("Content-Type", response.content_type),
                ("Content-Length", str(len(response.body))),
                ("Connection", "close"),
            ]
            with contextlib.suppress(h11.LocalProtocolError):
                self._send(_head(err.status, headers))
                self._send(h11.Data(data=response.body))
                self._send(h11.EndOfMessage())
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

    def _send(self, event: h11.Event) -> None:
        data = self._h11.send(event)
        if data and self.transport is not None and not self._closing:
            self.transport.write(data)

    def write(self, data: bytes) -> None:
        """Write bytes of an open event stream's body, unless the connection is closing."""
        if self.streaming and not self._closing:
            self._send(h11.Data(data=data))

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
        """Close after the written bytes are sent (an event stream's body is ended first)."""
        if self._closing:
            return
        if self.streaming and self._h11.our_state is h11.SEND_BODY:
            with contextlib.suppress(h11.LocalProtocolError):
                self._send(h11.EndOfMessage())
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
