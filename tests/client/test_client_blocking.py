"""The blocking wrapper: a private loop in the calling thread, against the reference server."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator

import pytest
from client_helpers import ServerThread

from openair.client import BlockingModule
from openair.protocol.content import RetrieveSpec
from openair.protocol.errors import ApiMisuseError


@pytest.fixture(scope="module")
def srv() -> Iterator[ServerThread]:
    thread = ServerThread()
    try:
        yield thread
    finally:
        thread.stop()


def test_blocking_module_round_trip(srv: ServerThread) -> None:
    with (
        BlockingModule("BlockReader", port=srv.port, keepalive=None) as reader,
        BlockingModule("BlockWriter", port=srv.port, bind=False, keepalive=None) as writer,
    ):
        assert not reader.legacy and reader.capabilities is not None
        reader.subscribe("Blk.*")
        posted = writer.post("WB1", "Blk.One", "payload")
        event = reader.next_wakeup(timeout=20)
        while event is not None and event.wakeup.trigger is None:  # skip phase updates
            event = reader.next_wakeup(timeout=20)
        assert event is not None and event.wakeup.trigger is not None
        assert event.wakeup.trigger.id == posted.id
        assert reader.next_wakeup(timeout=0.01) is None  # nothing else is coming
        (found,) = reader.retrieve(RetrieveSpec(whiteboard="WB1", pattern="Blk.*"))
        assert found.id == posted.id and found.content == "payload"
        assert writer.ping() > 0
        assert reader.resolve("AIRCentral").port == srv.port


def test_blocking_module_refuses_a_running_loop(srv: ServerThread) -> None:
    mod = BlockingModule("Nested", port=srv.port, keepalive=None)

    async def inside() -> None:
        with pytest.raises(ApiMisuseError):
            mod.connect()

    asyncio.run(inside())
    mod.close()
