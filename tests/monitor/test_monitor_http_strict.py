"""The monitor's HTTP connection (h11 plus its own limits): what it accepts, what it refuses.

Bytes go into an `HttpConnection` over a fake transport, without sockets; the answers are read
back from what it wrote.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass, field
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from openair_monitor.http import HttpConnection, HttpLimits, Request, Response

GET = b"GET /api/overview?x=1 HTTP/1.1\r\nHost: h\r\nAccept: */*\r\n\r\n"


class FakeTransport(asyncio.Transport):
    """Collects what the connection writes; remembers that it was closed."""

    def __init__(self) -> None:
        super().__init__()
        self.data = bytearray()
        self.closed = False

    def write(self, data: bytes | bytearray | memoryview) -> None:
        self.data += data

    def close(self) -> None:
        self.closed = True

    def is_closing(self) -> bool:
        return self.closed

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return ("127.0.0.1", 1) if name == "peername" else default

    def get_write_buffer_size(self) -> int:
        return 0

    def pause_reading(self) -> None:
        pass

    def resume_reading(self) -> None:
        pass


@dataclass
class EchoApp:
    """Answers every request with its method, path, query and body; records the requests."""

    limits: HttpLimits = field(default_factory=HttpLimits)
    requests: list[Request] = field(default_factory=list)

    def respond(self, request: Request, peer: str) -> Response:
        self.requests.append(request)
        return Response(body=f"{request.method} {request.target}".encode() + request.body)

    def opened(self, conn: HttpConnection) -> bool:
        return True

    def closed(self, conn: HttpConnection) -> None:
        pass


@dataclass
class Outcome:
    statuses: list[int]
    bodies: list[bytes]
    closed: bool
    requests: list[Request]


def _responses(data: bytes) -> tuple[list[int], list[bytes]]:
    """Split what the server wrote into (statuses, bodies); every response has a length."""
    statuses: list[int] = []
    bodies: list[bytes] = []
    while data:
        head, sep, data = data.partition(b"\r\n\r\n")
        assert sep, "a response head is incomplete"
        lines = head.decode("latin-1").split("\r\n")
        version, status, reason = lines[0].split(" ", 2)
        assert version == "HTTP/1.1" and reason  # a reason phrase is always given
        fields = {k.lower(): v.strip() for k, _, v in (line.partition(":") for line in lines[1:])}
        length = int(fields["content-length"])
        statuses.append(int(status))
        bodies.append(data[:length])
        data = data[length:]
    return statuses, bodies


def exchange(chunks: list[bytes], limits: HttpLimits | None = None) -> Outcome:
    """Feed `chunks` to one connection; return the responses and whether it was closed."""

    async def go() -> Outcome:
        app = EchoApp(limits or HttpLimits())
        transport = FakeTransport()
        conn = HttpConnection(app)
        conn.connection_made(transport)
        for chunk in chunks:
            conn.data_received(chunk)
        statuses, bodies = _responses(bytes(transport.data))
        return Outcome(statuses, bodies, transport.closed, app.requests)

    return asyncio.run(go())


def refused(data: bytes, limits: HttpLimits | None = None) -> int:
    outcome = exchange([data], limits)
    assert outcome.requests == [] and outcome.closed
    (status,) = outcome.statuses
    return status


def test_a_plain_get_is_read_with_lower_case_header_names() -> None:
    outcome = exchange([GET])
    (request,) = outcome.requests
    assert (request.method, request.path, request.query) == ("GET", "/api/overview", "x=1")
    assert request.header("host") == "h"
    assert request.header("accept") == "*/*"
    assert outcome.statuses == [200]


def test_byte_at_a_time_gives_the_same_requests_as_one_feed() -> None:
    data = GET + b"POST /api/post HTTP/1.1\r\nHost: h\r\nContent-Length: 5\r\n\r\nhello" + GET
    whole = exchange([data])
    split = exchange([data[i : i + 1] for i in range(len(data))])
    assert split.requests == whole.requests
    assert [r.method for r in split.requests] == ["GET", "POST", "GET"]
    assert split.requests[1].body == b"hello"
    assert split.bodies == whole.bodies and split.statuses == [200, 200, 200]


def test_leading_empty_lines_and_bare_lf_line_ends_are_accepted() -> None:
    outcome = exchange([b"\r\n\nGET / HTTP/1.0\nConnection: keep-alive\n\n"])
    (request,) = outcome.requests
    assert request.version == "HTTP/1.0"
    assert outcome.statuses == [200]


def test_connection_close_and_http10_end_the_connection() -> None:
    closing = exchange([b"GET / HTTP/1.1\r\nHost: h\r\nConnection: close\r\n\r\n" + GET])
    assert closing.statuses == [200] and len(closing.requests) == 1  # nothing after close
    old = exchange([b"GET / HTTP/1.0\r\n\r\n" + GET])
    assert old.statuses == [200] and len(old.requests) == 1


@pytest.mark.parametrize(
    "data",
    [
        b"\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03\r\n\r\n",  # a TLS hello
        b"GET\r\n\r\n",
        b"GET /  HTTP/1.1\r\nHost: h\r\n\r\n",
        b"GET / HTTP/1.1 extra\r\nHost: h\r\n\r\n",
        b"GET http://x/ HTTP/1.1\r\nHost: h\r\n\r\n",  # absolute-form is not served
        b"G\x00T / HTTP/1.1\r\nHost: h\r\n\r\n",
        b"GET /\xff HTTP/1.1\r\nHost: h\r\n\r\n",
    ],
)
def test_a_garbage_request_line_is_400(data: bytes) -> None:
    assert refused(data) == 400


def test_a_garbage_request_line_is_refused_before_the_headers_end() -> None:
    assert refused(b"HELLO THERE\r\nHost: h\r\n") == 400  # no empty line yet


@pytest.mark.parametrize(
    ("data", "status"),
    [
        (b"GET / HTTP/1.1\r\n Host: h\r\n\r\n", 400),  # obs-fold
        (b"GET / HTTP/1.1\r\nX: a\r\n b\r\nHost: h\r\n\r\n", 400),  # obs-fold, not unfolded
        (b"GET / HTTP/1.1\r\nHost : h\r\n\r\n", 400),  # whitespace before the colon
        (b"GET / HTTP/1.1\r\nHost h\r\n\r\n", 400),
        (b"GET / HTTP/1.1\r\nHost: h\x01\r\n\r\n", 400),
        (b"GET / HTTP/1.1\r\n\r\n", 400),  # no Host
        (b"GET / HTTP/1.1\r\nHost: a\r\nHost: b\r\n\r\n", 400),
        (b"POST / HTTP/1.1\r\nHost: h\r\nContent-Length: -1\r\n\r\n", 400),
        (b"POST / HTTP/1.1\r\nHost: h\r\nContent-Length: 1\r\nContent-Length: 2\r\n\r\n", 400),
        (b"POST / HTTP/1.1\r\nHost: h\r\nTransfer-Encoding: chunked\r\n\r\n", 501),
        (b"GET / HTTP/2.0\r\nHost: h\r\n\r\n", 505),
    ],
)
def test_bad_heads_are_refused_with_their_status(data: bytes, status: int) -> None:
    assert refused(data) == status


def test_size_limits_give_414_431_and_413() -> None:
    limits = HttpLimits(max_request_line=64, max_header_bytes=128, max_headers=4, max_body=10)
    assert refused(b"GET /" + b"a" * 100, limits) == 414  # no line end needed to know
    assert refused(b"GET / HTTP/1.1\r\nHost: h\r\nX: " + b"v" * 300, limits) == 431
    whole = b"GET / HTTP/1.1\r\nHost: h\r\nX: " + b"v" * 300 + b"\r\n\r\n"
    assert refused(whole, limits) == 431  # also when the head arrives whole
    many = b"".join(b"X%d: v\r\n" % i for i in range(5))
    assert refused(b"GET / HTTP/1.1\r\nHost: h\r\n" + many + b"\r\n", limits) == 431
    big = b"POST / HTTP/1.1\r\nHost: h\r\nContent-Length: 11\r\n\r\n"
    assert refused(big, limits) == 413  # before a byte of the body arrives


def test_a_partial_request_waits_for_more() -> None:
    head = b"POST / HTTP/1.1\r\nHost: h\r\nContent-Length: 4\r\n\r\nab"
    assert exchange([head]).requests == []
    (request,) = exchange([head, b"cd"]).requests
    assert request.body == b"abcd"


def test_responses_carry_a_reason_phrase_and_a_length() -> None:
    outcome = exchange([b"GET / HTTP/1.1\r\nHost: h\r\n\r\n"])
    assert outcome.bodies == [b"GET /"]


@given(st.binary(max_size=300))
def test_arbitrary_bytes_give_answers_or_a_refusal_only(data: bytes) -> None:
    outcome = exchange([data], HttpLimits(max_request_line=128, max_header_bytes=256))
    assert all(200 <= s < 600 for s in outcome.statuses)
    assert len(outcome.statuses) >= len(outcome.requests)
