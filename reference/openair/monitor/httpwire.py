"""A strict HTTP/1.1 request reader and response writer, without I/O (RFC 9110, RFC 9112).

`RequestParser` takes bytes (`feed`) and returns whole requests (`next_request`); whatever it
refuses raises `HttpError` carrying the status to answer (400, 413, 414, 431, 501, 505), and the
connection is closed after that answer. It accepts only what the monitor needs: origin-form
targets, HTTP/1.0 and 1.1, bodies framed by Content-Length (no chunked request bodies), bounded
request line, header block, header count and body. Bare LF line ends are read as CRLF (RFC 9112
2.2 allows it); obs-fold, whitespace before a colon, control characters and conflicting
Content-Length values are refused (RFC 9112 5.1, 5.2, 6.3).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = [
    "REASONS",
    "HttpError",
    "HttpLimits",
    "Request",
    "RequestParser",
    "encode_head",
]

#: Reason phrases of the statuses the monitor sends.
REASONS = {
    200: "OK",
    204: "No Content",
    400: "Bad Request",
    403: "Forbidden",
    404: "Not Found",
    405: "Method Not Allowed",
    408: "Request Timeout",
    413: "Content Too Large",
    414: "URI Too Long",
    415: "Unsupported Media Type",
    422: "Unprocessable Content",
    431: "Request Header Fields Too Large",
    500: "Internal Server Error",
    501: "Not Implemented",
    503: "Service Unavailable",
    505: "HTTP Version Not Supported",
}

_REQUEST_LINE = re.compile(rb"([!#$%&'*+\-.^_`|~0-9A-Za-z]+) ([\x21-\x7e]+) (HTTP/[0-9]\.[0-9])")
_TOKEN = re.compile(rb"[!#$%&'*+\-.^_`|~0-9A-Za-z]+")
_BAD_VALUE = re.compile(rb"[\x00-\x08\x0a-\x1f\x7f]")  # HTAB, SP and obs-text are allowed
_VERSIONS = frozenset({"HTTP/1.0", "HTTP/1.1"})
_MAX_LEADING_EMPTY = 8  # RFC 9112 2.2: ignore at least one empty line before a request


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
    max_streams: int = 32  # open event streams (SSE clients)

    def __post_init__(self) -> None:
        for name in self.__slots__:
            if getattr(self, name) <= 0:
                raise ValueError(f"HTTP limit {name} must be positive")


class HttpError(Exception):
    """A request the server refuses: answer `status` with `detail`, then close."""

    def __init__(self, status: int, detail: str) -> None:
        super().__init__(f"{status} {detail}")
        self.status = status
        self.detail = detail


@dataclass(frozen=True, slots=True, kw_only=True)
class Request:
    """One parsed request. Header names are lower-cased; `path` and `query` are still encoded."""

    method: str
    target: str
    version: str
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

    @property
    def keep_alive(self) -> bool:
        """Whether the connection stays open after the response (RFC 9112 9.3)."""
        tokens = {t.strip().lower() for t in (self.header("connection") or "").split(",")}
        if self.version == "HTTP/1.0":
            return "keep-alive" in tokens
        return "close" not in tokens


def _head_end(buf: bytearray, start: int) -> tuple[int, int] | None:
    """Return (end of the header block, start of the body) past `start`, or None if incomplete."""
    crlf = buf.find(b"\n\r\n", start)
    lf = buf.find(b"\n\n", start)
    found = [(p, p + 3) for p in (crlf,) if p >= 0] + [(p, p + 2) for p in (lf,) if p >= 0]
    return min(found) if found else None


class RequestParser:
    """Read requests one after another from a byte stream (pipelining allowed)."""

    def __init__(self, limits: HttpLimits | None = None) -> None:
        self.limits = limits or HttpLimits()
        self._buf = bytearray()
        self._head: tuple[Request, int] | None = None  # a parsed head waiting for its body
        self._line_checked = False

    @property
    def buffered(self) -> int:
        """Bytes received and not yet returned as part of a request."""
        return len(self._buf)

    def feed(self, data: bytes) -> None:
        """Add received bytes."""
        self._buf += data

    def next_request(self) -> Request | None:
        """Return the next complete request, None when more bytes are needed; raise HttpError."""
        if self._head is None:
            self._skip_empty_lines()
            self._head = self._read_head()
            if self._head is None:
                return None
        request, length = self._head
        if len(self._buf) < length:
            return None
        body = bytes(self._buf[:length])
        del self._buf[:length]
        self._head = None
        self._line_checked = False
        return Request(
            method=request.method,
            target=request.target,
            version=request.version,
            headers=request.headers,
            body=body,
        )

    # -- the head -------------------------------------------------------------------------------

    def _skip_empty_lines(self) -> None:
        for _ in range(_MAX_LEADING_EMPTY):
            if self._buf.startswith(b"\r\n"):
                del self._buf[:2]
            elif self._buf.startswith(b"\n"):
                del self._buf[:1]
            else:
                return

    def _read_head(self) -> tuple[Request, int] | None:
        """Parse the request line and headers once they are complete; return (head, body length)."""
        limits = self.limits
        if not self._line_checked:
            eol = self._buf.find(b"\n", 0, limits.max_request_line + 1)
            if eol < 0:
                if len(self._buf) > limits.max_request_line:
                    raise HttpError(414, "the request line is too long")
                return None
            self._request_line(bytes(self._buf[:eol]).rstrip(b"\r"))  # refuse garbage at once
            self._line_checked = True
        end = _head_end(self._buf, 0)
        if end is None:
            if len(self._buf) > limits.max_request_line + limits.max_header_bytes:
                raise HttpError(431, "the header block is too large")
            return None
        head_end, body_start = end
        if head_end > limits.max_request_line + limits.max_header_bytes:
            raise HttpError(431, "the header block is too large")
        lines = [line.rstrip(b"\r") for line in bytes(self._buf[:head_end]).split(b"\n")]
        del self._buf[:body_start]
        method, target, version = self._request_line(lines[0])
        headers = self._headers(lines[1:])
        request = Request(method=method, target=target, version=version, headers=headers)
        return request, self._body_length(request)

    def _request_line(self, line: bytes) -> tuple[str, str, str]:
        match = _REQUEST_LINE.fullmatch(line)
        if match is None:
            raise HttpError(400, "malformed request line")
        method, target, version = (part.decode("ascii") for part in match.groups())
        if version not in _VERSIONS:
            raise HttpError(505, f"{version} is not served (HTTP/1.0 and HTTP/1.1 are)")
        if not target.startswith("/"):
            raise HttpError(400, "the request target must be an absolute path")
        return method, target, version

    def _headers(self, lines: list[bytes]) -> tuple[tuple[str, str], ...]:
        if len(lines) > self.limits.max_headers:
            raise HttpError(431, f"more than {self.limits.max_headers} header fields")
        headers: list[tuple[str, str]] = []
        for line in lines:
            if line[:1] in (b" ", b"\t"):
                raise HttpError(400, "obsolete line folding is not accepted")
            name, colon, value = line.partition(b":")
            if not colon or _TOKEN.fullmatch(name) is None:
                raise HttpError(400, "malformed header field")  # also: whitespace before `:`
            value = value.strip(b" \t")
            if _BAD_VALUE.search(value):
                raise HttpError(400, "control character in a header value")
            headers.append((name.decode("ascii").lower(), value.decode("latin-1")))
        return tuple(headers)

    def _body_length(self, request: Request) -> int:
        if request.version == "HTTP/1.1" and sum(k == "host" for k, _ in request.headers) != 1:
            raise HttpError(400, "an HTTP/1.1 request needs exactly one Host header")
        if request.header("transfer-encoding") is not None:
            raise HttpError(501, "Transfer-Encoding in requests is not supported")
        values = {v for k, v in request.headers if k == "content-length"}
        if not values:
            return 0
        if len(values) > 1:
            raise HttpError(400, "conflicting Content-Length values")
        (value,) = values
        if not value.isascii() or not value.isdigit():
            raise HttpError(400, "Content-Length is not a decimal number")
        length = int(value)
        if length > self.limits.max_body:
            raise HttpError(413, f"the body is larger than {self.limits.max_body} bytes")
        return length


def encode_head(status: int, headers: list[tuple[str, str]]) -> bytes:
    """Return a response's status line and header block, ending in the empty line."""
    lines = [f"HTTP/1.1 {status} {REASONS.get(status, 'Unknown')}"]
    lines.extend(f"{name}: {value}" for name, value in headers)
    return ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1")
