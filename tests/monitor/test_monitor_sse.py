"""Live updates over /api/events: posts arrive, filters hold, heartbeats flow, limits apply."""

from __future__ import annotations

import asyncio

from monitor_helpers import BOUND, SseReader, get, run, serving

from openair.client import Module
from openair_monitor import HttpLimits, MonitorOptions


async def writer(port: int) -> Module:
    m = Module("Writer", port=port, listen=False)
    await m.connect()
    return m


def has_type(name: str) -> object:
    return lambda batch: any(m["type"] == name for m in batch)


def test_a_post_arrives_as_a_messages_event() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            sse = await SseReader.open(server.port, "topics=messages&wb=WB1")
            assert sse.head.status == 200
            assert sse.head.headers["content-type"].startswith("text/event-stream")
            hello = await sse.until("hello")
            w = await writer(server.port)
            await w.post("WB1", "Test.Live", "now")
            batch = await sse.until("messages", has_type("Test.Live"))  # type: ignore[arg-type]
            (line,) = [m for m in batch if m["type"] == "Test.Live"]
            assert (line["from"], line["preview"], line["whiteboard"]) == ("Writer", "now", "WB1")
            assert line["seq"] >= hello["seq"]
            await w.close()
            await sse.close()

    run(go)


def test_the_stream_filter_is_applied_on_the_server() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            sse = await SseReader.open(server.port, "topics=messages&wb=WB1&pattern=Test.Keep.*")
            await sse.until("hello")
            w = await writer(server.port)
            await w.post("WB1", "Test.Drop", "x")
            await w.post("WB2", "Test.Keep.Other", "x")  # another whiteboard
            await w.post("WB1", "Test.Keep", "x")  # OA-MATCH-4: the subtree root matches
            seen: list[str] = []
            while "Test.Keep" not in seen:
                seen += [m["type"] for m in await sse.until("messages")]
            assert seen == ["Test.Keep"]
            await w.close()
            await sse.close()

    run(go)


def test_since_replays_what_was_posted_after_a_list_was_fetched() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            listed = (await get(server.port, "/api/whiteboards/WB1/messages")).json()
            w = await writer(server.port)
            await w.post("WB1", "Test.Between", "x")  # before the stream opens
            sse = await SseReader.open(server.port, f"topics=messages&wb=WB1&since={listed['seq']}")
            batch = await sse.until("messages")
            assert [m["type"] for m in batch] == ["Test.Between"]
            await w.close()
            await sse.close()

    run(go)


def test_overview_events_show_a_module_connecting() -> None:
    async def go() -> None:
        async with serving(monitor=MonitorOptions(overview_s=0.05)) as (server, _):
            sse = await SseReader.open(server.port, "topics=overview")
            first = await sse.until("overview")
            assert "Watcher" not in [m["name"] for m in first["modules"]]
            m = Module("Watcher", port=server.port, listen=False)
            await m.connect()
            await m.subscribe("Test.*")

            def bound(data: dict[str, list[dict[str, object]]]) -> bool:
                return any(r["name"] == "Watcher" and r["bound"] for r in data["modules"])

            await sse.until("overview", bound)
            await m.close()
            await sse.close()

    run(go)


def test_an_idle_stream_gets_heartbeat_comments() -> None:
    async def go() -> None:
        async with serving(monitor=MonitorOptions(heartbeat_s=0.05, tick_s=0.02)) as (server, _):
            sse = await SseReader.open(server.port, "topics=messages")
            await sse.until("hello")
            line = await sse.block()  # the next event or comment, de-chunked
            assert line == b": keepalive\n\n"
            await sse.close()

    run(go)


def test_graph_topic_and_bad_topics() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            sse = await SseReader.open(server.port, "topics=graph")
            graph = await sse.until("graph")
            assert {n["id"] for n in graph["nodes"]} >= {"wb:WB1", "wb:WB2"}
            await sse.close()
            bad = await get(server.port, "/api/events?topics=everything")
            assert bad.status == 400
            assert (await get(server.port, "/api/events?wb=Nope")).status == 404
            assert (await get(server.port, "/api/events?pattern=a..b")).status == 400

    run(go)


def test_event_streams_are_limited_in_number() -> None:
    async def go() -> None:
        limits = HttpLimits(max_streams=1)
        async with serving(monitor=MonitorOptions(limits=limits)) as (server, mon):
            first = await SseReader.open(server.port, "topics=messages")
            await first.until("hello")
            refused = await get(server.port, "/api/events?topics=messages")
            assert refused.status == 503
            (stream,) = mon.broadcaster.streams
            gone = asyncio.Event()
            forget = stream.conn.on_close
            assert forget is not None

            def closed() -> None:
                forget()
                gone.set()

            stream.conn.on_close = closed
            await first.close()
            await asyncio.wait_for(gone.wait(), BOUND)
            second = await SseReader.open(server.port, "topics=messages")
            assert second.head.status == 200
            await second.close()

    run(go)
