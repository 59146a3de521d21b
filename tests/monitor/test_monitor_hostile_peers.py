"""The monitor against a shared lab's fears (issue #19): DNS rebinding and one greedy peer."""

from __future__ import annotations

import asyncio

from monitor_helpers import HttpClient, get, run, serving

from openair_monitor import HttpLimits, MonitorOptions
from openair_monitor.hostcheck import allowed_names, host_allowed, origin_allowed


def test_only_allowed_names_and_ip_literals_pass_the_host_check() -> None:
    names = allowed_names("0.0.0.0", ("lab-server.local",))
    assert host_allowed("localhost:10000", names) and host_allowed("LOCALHOST", names)
    assert host_allowed("127.0.0.1:8080", names) and host_allowed("[::1]:10000", names)
    assert host_allowed("lab-server.local", names)
    assert not host_allowed("evil.example:10000", names)  # a rebound name
    assert not host_allowed("localhost.evil.example", names)
    assert not host_allowed(None, names)
    assert origin_allowed(None, names) and origin_allowed("http://localhost:10000", names)
    assert not origin_allowed("https://evil.example", names)
    assert not origin_allowed("null", names)
    assert "myhost" in allowed_names("myhost")  # the listen address


def test_a_rebound_host_or_a_foreign_origin_is_refused() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            client = await HttpClient.open(server.port)
            ok = await client.request("GET", "/api/whiteboards", headers={"Host": "localhost"})
            assert ok.status == 200
            evil = await get(server.port, "/api/whiteboards", headers={"Host": "evil.example"})
            assert evil.status == 403
            origin = {"Origin": "http://evil.example"}
            foreign = await get(server.port, "/api/overview", headers=origin)
            assert foreign.status == 403
            await client.close()

    run(go)


def test_one_peer_cannot_take_every_monitor_connection() -> None:
    async def go() -> None:
        options = MonitorOptions(limits=HttpLimits(max_connections=128, max_per_peer=2))
        async with serving(monitor=options) as (server, _):
            half = [await HttpClient.open(server.port) for _ in range(2)]
            for client in half:
                client.write(b"GET / HTTP/1.1\r\nHost: localhost\r\n")  # never finished
            refused = await get(server.port, "/api/whiteboards")
            assert refused.status == 503
            half[1].write(b"\r\n")  # an admitted connection is served when it finishes
            assert (await half[1].response()).status == 200
            for client in half[1:]:
                await client.close()

    run(go)


def test_a_request_trickling_in_is_cut_at_its_whole_deadline_not_per_gap() -> None:
    """A byte every 50 ms never leaves a gap, yet the request must end 0.3 s after it began."""

    async def go() -> None:
        options = MonitorOptions(limits=HttpLimits(head_deadline_s=0.3, idle_s=30.0))
        async with serving(monitor=options) as (server, _):
            client = await HttpClient.open(server.port)
            client.write(b"GET / HTTP/1.1\r\nHost: localhost\r\nX-Slow: ")

            async def trickle() -> None:
                for _ in range(200):  # 10 s of header if nobody stops it
                    client.write(b"a")
                    await asyncio.sleep(0.05)

            dripping = asyncio.create_task(trickle())
            reply = await client.response()
            assert reply.status == 408
            assert not dripping.done()  # cut while it was still arriving
            dripping.cancel()

    run(go)
