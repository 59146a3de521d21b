"""The Module against the real reference server, in-process on 127.0.0.1 (port 0)."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import pytest
from streams_support import module, run

from openair.client import FailedReplyError, Module, WakeupEvent
from openair.protocol.content import RetrieveSpec, Trigger
from openair.protocol.errors import ConnectionClosedError, WhiteboardUnknownError
from openair.server.aio.app import ServerOptions, start_server


@asynccontextmanager
async def server(port: int = 0) -> AsyncIterator[int]:
    srv = await start_server(ServerOptions(host="127.0.0.1", port=port))
    try:
        yield srv.port
    finally:
        await srv.stop()


async def next_trigger(mod: Module) -> WakeupEvent:
    """The next wakeup that carries a trigger message (phase updates skipped)."""
    while True:
        event = await mod.next_wakeup()
        assert event is not None, "module closed"
        if event.wakeup.trigger is not None:
            return event


def test_two_modules_trigger_cc_and_retrieve() -> None:
    async def scenario() -> None:
        async with (
            server() as port,
            module("Reader", port) as reader,
            module("Writer", port) as writer,
        ):
            assert not reader.legacy and reader.capabilities is not None
            assert {"pipelining", "noreply"} <= reader.extensions
            await reader.subscribe(
                Trigger(pattern="Ref.Ping.*", whiteboard="WB1"),
                [RetrieveSpec(whiteboard="WB1", pattern="Ref.Data.*", latest=2)],
            )
            for n in (1, 2, 3):
                await writer.post("WB1", f"Ref.Data.{n}", f"data {n}")
            ping = await writer.post("WB1", "Ref.Ping.A", "hello")
            event = await next_trigger(reader)
            trigger = event.wakeup.trigger
            assert trigger is not None
            assert (trigger.id, trigger.sender, trigger.stored) == (ping.id, "Writer", "WB1")
            assert trigger.wbid is not None and trigger.received is not None  # OA-WB-4
            assert event.wakeup.lasttrigger == "Ref.Ping.*"  # OA-WAKE-4
            assert [m.type for m in event.wakeup.retrieved] == ["Ref.Data.3", "Ref.Data.2"]

            # cc wakes Writer although it registered nothing (OA-CC-2); lasttrigger is empty.
            pong = await reader.post("WB2", "Ref.Pong", "back", cc=["Writer"])
            back = await next_trigger(writer)
            assert back.wakeup.trigger is not None and back.wakeup.trigger.id == pong.id
            assert back.wakeup.lasttrigger == ""

            found = await writer.retrieve(RetrieveSpec(whiteboard="WB1", pattern="Ref.*", latest=0))
            assert [m.type for m in found] == [
                "Ref.Ping.A",
                "Ref.Data.3",
                "Ref.Data.2",
                "Ref.Data.1",
            ]
            both = await writer.retrieve(
                [
                    RetrieveSpec(whiteboard="WB1", pattern="Ref.Ping.*"),
                    RetrieveSpec(whiteboard="WB2"),
                ]
            )
            assert [m.id for m in both] == [ping.id, pong.id]  # OA-RET-12: in spec order

    run(scenario)


def test_pipelined_and_noreply_posts() -> None:
    async def scenario() -> None:
        async with server() as port, module("Sink", port) as sink, module("Fast", port) as fast:
            await sink.subscribe("Ref.Many.*")
            batch = [fast.message("WB1", f"Ref.Many.{n}", str(n)) for n in range(20)]
            sent = await fast.post_many(batch)
            assert [m.id for m in sent] == [m.id for m in batch]
            assert fast.session is not None and fast.session.counters.in_flight_peak > 1
            quiet = [await fast.post("WB1", f"Ref.Many.Quiet{n}", noreply=True) for n in range(5)]
            assert all(m.noreply for m in quiet)  # OA-MSG-15: sent with noreply="yes"
            await fast.ping()
            expected = [m.id for m in sent] + [m.id for m in quiet]
            woken = [(await next_trigger(sink)).wakeup.trigger for _ in expected]
            assert [m.id for m in woken if m is not None] == expected  # OA-PRIO-1: FIFO
            stored = await fast.retrieve(RetrieveSpec(whiteboard="WB1", latest=0))
            assert [m.id for m in stored] == expected[::-1]  # OA-RET-6: newest first

    run(scenario)


def test_reconnect_re_registers_after_the_server_drops_the_connection() -> None:
    async def scenario() -> None:
        first = await start_server(ServerOptions(host="127.0.0.1", port=0))
        port = first.port
        mod = module("Phoenix", port, reconnect_delay=0.02, reconnect_max_delay=0.2)
        try:
            await mod.connect()
            await mod.subscribe("Ref.Again.*")
            assert mod.generation == 1
            await first.stop()  # the server drops the primary connection
            # A new server on the same port knows nothing of Phoenix: only the module's own
            # re-registration after reconnecting can make this post wake it.
            async with server(port) as again:
                await mod.wait_connected(2)
                async with module("Poster", again, bind=False) as poster:
                    posted = await poster.post("WB1", "Ref.Again.1", "after reconnect")
                event = await next_trigger(mod)
                assert event.wakeup.trigger is not None and event.wakeup.trigger.id == posted.id
        finally:
            await mod.close()

    run(scenario)


def test_without_reconnect_requests_fail_after_loss() -> None:
    async def scenario() -> None:
        async with server() as port:
            mod = module("Once", port, reconnect=False)
            await mod.connect()
            await mod.ping()
        with pytest.raises(ConnectionClosedError):
            await mod.ping()
        await mod.close()

    run(scenario)


def test_failure_replies_raise_with_the_reply() -> None:
    async def scenario() -> None:
        async with server() as port, module("Asker", port, bind=False) as asker:
            with pytest.raises(FailedReplyError) as forward:
                await asker.post("NoSuchWB", "Ref.Lost")
            assert forward.value.response.type == "FORWARD_FAILED"  # OA-SESS-21
            with pytest.raises(FailedReplyError) as unknown:
                await asker.retrieve(RetrieveSpec(whiteboard="NoSuchWB"))
            assert unknown.value.response.type == "AIR.Retrieve.Failed"
            assert unknown.value.condition is WhiteboardUnknownError  # OA-RET-11
            with pytest.raises(FailedReplyError):
                await asker.resolve("nobody")
            where = await asker.resolve("WB1")
            assert where.name == "WB1" and where.port > 0

    run(scenario)


def test_forwarded_message_and_wakeup_callback() -> None:
    async def scenario() -> None:
        seen: list[WakeupEvent] = []
        got = asyncio.Event()

        async def on_wakeup(event: WakeupEvent) -> None:
            if event.wakeup.trigger is not None:
                seen.append(event)
                got.set()

        async with (
            server() as port,
            module("Target", port, on_wakeup=on_wakeup, listen=False) as target,
            module("Sender", port, bind=False) as sender,
        ):
            assert target.bound_port == -1 and target.listen_port is None  # OA-SESS-5
            direct = await sender.post("Target", "Ref.Direct", "for you")  # OA-SESS-22
            event = await target.next_message()
            assert event is not None and event.message.id == direct.id
            await target.subscribe("Ref.Callback.*")
            posted = await sender.post("WB1", "Ref.Callback.1")
            await got.wait()
            assert seen[0].wakeup.trigger is not None and seen[0].wakeup.trigger.id == posted.id

    run(scenario)
