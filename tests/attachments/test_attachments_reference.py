"""Attachments end to end: post, store (memory and SQLite), wakeup and retrieve (OA-WB-13)."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import pytest

from openair.client import FailedReplyError, Module, WakeupEvent
from openair.protocol.content import RetrieveSpec, Trigger
from openair.server.aio.app import ServerOptions, start_server
from openair.server.core.config import ServerLimits

TIMEOUT = 20.0


def run(test: Callable[[], Awaitable[None]]) -> None:
    async def bounded() -> None:
        await asyncio.wait_for(test(), TIMEOUT)

    asyncio.run(bounded())


@asynccontextmanager
async def server(**options: Any) -> AsyncIterator[int]:
    srv = await start_server(ServerOptions(host="127.0.0.1", port=0, **options))
    try:
        yield srv.port
    finally:
        await srv.stop()


def module(name: str, port: int) -> Module:
    return Module(name, port=port, keepalive=None)


async def next_trigger(mod: Module) -> WakeupEvent:
    while True:
        event = await mod.next_wakeup()
        assert event is not None, "module closed"
        if event.wakeup.trigger is not None:
            return event


async def wake_and_retrieve(port: int) -> None:
    async with module("Reader", port) as reader, module("Writer", port) as writer:
        await reader.subscribe(
            Trigger(pattern="Att.Go", whiteboard="WB1"),
            [RetrieveSpec(whiteboard="WB1", pattern="Att.Data.*", latest=0)],
        )
        await writer.post("WB1", "Att.Data.1", "one", binary=[b"\x01\x02", b""])
        await writer.post("WB1", "Att.Data.2", "two")
        await writer.post("WB1", "Att.Data.3", "three", binary=[b"\x00" * 5])
        await writer.post(
            "WB1", "Att.Go", "go", binary=[b"\x01\x02\x03\x04"], language="LISP", version="CL"
        )
        event = await next_trigger(reader)
        trigger = event.wakeup.trigger
        assert trigger is not None and trigger.binary == (b"\x01\x02\x03\x04",)  # OA-WAKE-10
        assert (trigger.language, trigger.content_version) == ("LISP", "CL")  # OA-MSG-22
        got = [(m.type, m.binary) for m in event.wakeup.retrieved]
        assert got == [
            ("Att.Data.3", (b"\x00" * 5,)),
            ("Att.Data.2", ()),
            ("Att.Data.1", (b"\x01\x02", b"")),
        ]
        assert event.message.binary == (b"\x01\x02\x03\x04", b"\x00" * 5, b"\x01\x02", b"")
        found = await writer.retrieve(RetrieveSpec(whiteboard="WB1", pattern="Att.*", latest=0))
        assert [m.binary for m in found] == [
            (b"\x01\x02\x03\x04",),
            (b"\x00" * 5,),
            (),
            (b"\x01\x02", b""),
        ]  # OA-RET-19
        assert found[0].content_version == "CL"


def test_attachments_reach_wakeups_and_retrieves_memory() -> None:
    async def scenario() -> None:
        async with server() as port:
            await wake_and_retrieve(port)

    run(scenario)


def test_attachments_survive_a_restart_with_sqlite(tmp_path: Path) -> None:
    db = f"sqlite:{tmp_path / 'history.sqlite'}"

    async def scenario() -> None:
        async with server(store=db) as port, module("Writer", port) as writer:
            await writer.post("WB1", "Att.Kept", "k", binary=[b"kept", b"\xff"])
        async with server(store=db) as port, module("Reader", port) as reader:
            found = await reader.retrieve(RetrieveSpec(whiteboard="WB1", pattern="Att.Kept"))
            assert [m.binary for m in found] == [(b"kept", b"\xff")]  # OA-WB-13, OA-WB-9

    run(scenario)


def test_retrieve_over_the_binary_limit_fails_and_wakeup_omits() -> None:
    limits = ServerLimits(max_frame_binary=10)

    async def scenario() -> None:
        async with (
            server(limits=limits) as port,
            module("Reader", port) as reader,
            module("Writer", port) as writer,
        ):
            await reader.subscribe(
                Trigger(pattern="Big.Go", whiteboard="WB1"),
                [RetrieveSpec(whiteboard="WB1", pattern="Big.Data", latest=0)],
            )
            await writer.post("WB1", "Big.Data", "a", binary=[b"a" * 4])
            await writer.post("WB1", "Big.Data", "b", binary=[b"b" * 4])
            await writer.post("WB1", "Big.Go", "go", binary=[b"g" * 3])
            event = await next_trigger(reader)
            # 3 + 4 fit in 10, the older 4 bytes do not: one retrieved message left out.
            assert [m.content for m in event.wakeup.retrieved] == ["b"]
            assert event.wakeup.omitted == 1  # OA-WAKE-11
            one = await reader.retrieve(RetrieveSpec(whiteboard="WB1", pattern="Big.Data"))
            assert one[0].binary == (b"b" * 4,)
            with pytest.raises(FailedReplyError) as info:  # OA-RET-15
                await reader.retrieve(RetrieveSpec(whiteboard="WB1", pattern="Big.*", latest=0))
            assert info.value.response.type == "AIR.Retrieve.Failed"
            assert info.value.response.content.startswith("LIMIT_EXCEEDED:")

    run(scenario)
