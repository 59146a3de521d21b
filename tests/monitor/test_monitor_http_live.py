"""HTTP on a live server: keep-alive, HEAD, errors, hostile clients, the main-port sniffing."""

from __future__ import annotations

import asyncio

from monitor_helpers import BOUND, HttpClient, get, run, serving

from openair.client import Module
from openair_monitor import HttpLimits, MonitorOptions


def test_pages_and_static_files_are_served_with_a_strict_policy() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            page = await get(server.port, "/")
            assert page.status == 200
            assert page.headers["content-type"] == "text/html; charset=utf-8"
            assert b"OpenAIR monitor" in page.body
            assert "script-src 'self'" in page.headers["content-security-policy"]
            for path in ("/whiteboard", "/module", "/graph", "/post", "/static/common.js"):
                assert (await get(server.port, path)).status == 200, path
            css = await get(server.port, "/static/style.css")
            assert css.headers["content-type"].startswith("text/css")
            assert (await get(server.port, "/static/../core.py")).status == 404
            assert (await get(server.port, "/nosuchpage")).status == 404

    run(go)


def test_keep_alive_head_and_method_not_allowed_on_one_connection() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            client = await HttpClient.open(server.port)
            first = await client.request("GET", "/api/overview")
            head = await client.request("HEAD", "/api/overview")
            assert first.status == head.status == 200
            assert head.body == b"" and int(head.headers["content-length"]) > 0
            put = await client.request("PUT", "/")
            assert put.status == 405 and put.headers["allow"] == "GET, HEAD"
            last = await client.request("GET", "/api/whiteboards", headers={"Connection": "close"})
            assert last.status == 200 and last.headers["connection"] == "close"
            assert await client.closed()

    run(go)


def test_pipelined_requests_are_answered_in_order() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            client = await HttpClient.open(server.port)
            one = b"GET /api/whiteboards HTTP/1.1\r\nHost: localhost\r\n\r\n"
            two = b"GET /nope HTTP/1.1\r\nHost: localhost\r\n\r\n"
            client.write(one + two + one)
            statuses = [(await client.response()).status for _ in range(3)]
            assert statuses == [200, 404, 200]
            await client.close()

    run(go)


def test_garbage_gets_400_and_the_connection_is_closed() -> None:
    async def go() -> None:
        async with serving(http_port=0) as (server, mon):
            assert mon.http_port is not None and mon.http_port != server.port
            client = await HttpClient.open(mon.http_port)
            client.write(b"\x16\x03\x01garbage\r\n\r\n")
            reply = await client.response()
            assert reply.status == 400 and reply.headers["connection"] == "close"
            assert await client.closed()

    run(go)


def test_oversized_headers_get_431_and_a_huge_body_413() -> None:
    async def go() -> None:
        async with serving(http_port=0) as (_, mon):
            assert mon.http_port is not None
            client = await HttpClient.open(mon.http_port)
            client.write(b"GET / HTTP/1.1\r\nHost: x\r\nX-Big: " + b"a" * 40_000 + b"\r\n\r\n")
            assert (await client.response()).status == 431
            assert await client.closed()
            client = await HttpClient.open(mon.http_port)
            client.write(b"POST /api/post HTTP/1.1\r\nHost: x\r\nContent-Length: 999999\r\n\r\n")
            assert (await client.response()).status == 413
            assert await client.closed()

    run(go)


def test_a_slowloris_request_is_cut_off_at_its_deadline() -> None:
    async def go() -> None:
        options = MonitorOptions(limits=HttpLimits(head_deadline_s=0.2))
        async with serving(monitor=options) as (server, _):
            client = await HttpClient.open(server.port)
            client.write(b"GET / HTTP/1.1\r\nHost: localhost\r\n")  # and never the empty line
            reply = await client.response()
            assert reply.status == 408
            assert await client.closed()

    run(go)


def test_an_idle_keep_alive_connection_is_closed_quietly() -> None:
    async def go() -> None:
        options = MonitorOptions(limits=HttpLimits(idle_s=0.1))
        async with serving(monitor=options) as (server, _):
            client = await HttpClient.open(server.port)
            assert (await client.request("GET", "/api/whiteboards")).status == 200
            assert await client.closed()  # no second response: EOF only

    run(go)


def test_too_many_connections_get_503() -> None:
    async def go() -> None:
        options = MonitorOptions(limits=HttpLimits(max_connections=1))
        async with serving(monitor=options) as (server, _):
            first = await HttpClient.open(server.port)
            assert (await first.request("GET", "/api/whiteboards")).status == 200
            second = await get(server.port, "/api/whiteboards")
            assert second.status == 503
            await first.close()

    run(go)


def test_http_and_openair_share_the_main_port() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            reader = Module("Reader", port=server.port, listen=False)
            await reader.connect()
            await reader.subscribe("Test.*")
            page = await get(server.port, "/")  # psyProbe's way: HTTP on port 10000 too
            assert page.status == 200 and b"<title>OpenAIR monitor" in page.body
            writer = Module("Writer", port=server.port, listen=False)
            await writer.connect()
            await writer.post("WB1", "Test.Shared", "x")
            while True:
                event = await reader.next_wakeup(timeout=BOUND)
                assert event is not None
                if event.wakeup.trigger is not None:
                    assert event.wakeup.trigger.type == "Test.Shared"
                    break
            overview = (await get(server.port, "/api/overview")).json()
            assert {"Reader", "Writer"} <= {m["name"] for m in overview["modules"]}
            await reader.close()
            await writer.close()

    run(go)


def test_without_the_monitor_the_main_port_answers_no_http() -> None:
    async def go() -> None:
        async with serving(monitor=MonitorOptions()) as (server, mon):
            await mon.close()
            server.monitor = None  # as `openair serve --no-monitor` leaves it
            reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
            writer.write(b"GET / HTTP/1.1\r\nHost: localhost\r\n\r\n")
            data = await asyncio.wait_for(reader.read(), BOUND)  # until the server closes
            assert not data.startswith(b"HTTP/")  # an unknown frame tag, not a page
            writer.close()

    run(go)
