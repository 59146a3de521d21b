"""The monitor's sans-I/O HTTP request reader: what it accepts, and how it refuses hostile input."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from openair.monitor.httpwire import HttpError, HttpLimits, Request, RequestParser, encode_head

GET = b"GET /api/overview?x=1 HTTP/1.1\r\nHost: h\r\nAccept: */*\r\n\r\n"


def parse(data: bytes, limits: HttpLimits | None = None) -> list[Request]:
    parser = RequestParser(limits)
    parser.feed(data)
    out = []
    while (request := parser.next_request()) is not None:
        out.append(request)
    return out


def refused(data: bytes, limits: HttpLimits | None = None) -> int:
    with pytest.raises(HttpError) as info:
        parse(data, limits)
    return info.value.status


def test_a_plain_get_is_read_with_lower_case_header_names() -> None:
    (request,) = parse(GET)
    assert (request.method, request.path, request.query) == ("GET", "/api/overview", "x=1")
    assert request.header("host") == "h"
    assert request.header("accept") == "*/*"
    assert request.keep_alive


def test_byte_at_a_time_gives_the_same_requests_as_one_feed() -> None:
    data = GET + b"POST /api/post HTTP/1.1\r\nHost: h\r\nContent-Length: 5\r\n\r\nhello" + GET
    parser = RequestParser()
    got = []
    for i in range(len(data)):
        parser.feed(data[i : i + 1])
        while (request := parser.next_request()) is not None:
            got.append(request)
    assert got == parse(data)
    assert [r.method for r in got] == ["GET", "POST", "GET"]
    assert got[1].body == b"hello"


def test_leading_empty_lines_and_bare_lf_line_ends_are_accepted() -> None:
    (request,) = parse(b"\r\n\nGET / HTTP/1.0\nConnection: keep-alive\n\n")
    assert request.version == "HTTP/1.0"
    assert request.keep_alive


def test_connection_close_and_http10_default_end_the_connection() -> None:
    assert not parse(b"GET / HTTP/1.1\r\nHost: h\r\nConnection: close\r\n\r\n")[0].keep_alive
    assert not parse(b"GET / HTTP/1.0\r\n\r\n")[0].keep_alive


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
    parser = RequestParser()
    parser.feed(b"HELLO THERE\r\nHost: h\r\n")  # no empty line yet
    with pytest.raises(HttpError) as info:
        parser.next_request()
    assert info.value.status == 400


@pytest.mark.parametrize(
    ("data", "status"),
    [
        (b"GET / HTTP/1.1\r\n Host: h\r\n\r\n", 400),  # obs-fold
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
    many = b"".join(b"X%d: v\r\n" % i for i in range(5))
    assert refused(b"GET / HTTP/1.1\r\nHost: h\r\n" + many + b"\r\n", limits) == 431
    big = b"POST / HTTP/1.1\r\nHost: h\r\nContent-Length: 11\r\n\r\n"
    assert refused(big, limits) == 413  # before a byte of the body arrives


def test_a_partial_request_waits_for_more() -> None:
    parser = RequestParser()
    parser.feed(b"POST / HTTP/1.1\r\nHost: h\r\nContent-Length: 4\r\n\r\nab")
    assert parser.next_request() is None
    parser.feed(b"cd")
    request = parser.next_request()
    assert request is not None and request.body == b"abcd"


def test_encode_head_writes_status_line_headers_and_the_empty_line() -> None:
    head = encode_head(404, [("Content-Length", "0")])
    assert head == b"HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\n\r\n"


@given(st.binary(max_size=300))
def test_arbitrary_bytes_give_requests_or_an_http_error_only(data: bytes) -> None:
    parser = RequestParser(HttpLimits(max_request_line=128, max_header_bytes=256))
    parser.feed(data)
    try:
        while parser.next_request() is not None:
            pass
    except HttpError as err:
        assert 400 <= err.status < 600
