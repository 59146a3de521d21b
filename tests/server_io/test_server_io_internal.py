"""Internal modules (spec 12.1, OA-CONF-8): code named in the psySpec, run inside the server.

An internal module woken by an external module's post answers with a post that an external
module receives; a blocking one runs on its own thread and the loop goes on serving; one that
raises is logged and counted and the server goes on. No sleeps: every wait is for a delivery,
a reply or an event the handler sets.
"""

from __future__ import annotations

import asyncio
import logging
import threading

import internal_handlers
import pytest
from server_io_helpers import BOUND, Raw, TestModule, run, serving

from openair.protocol.message import Message
from openair.protocol.wakeup import parse_wakeup
from openair.server.aio.app import Server, ServerOptions, start_server
from openair.server.core.config import ConfigError, parse_config


def _spec(name: str, code: str, trigger: str) -> bytes:
    return f"""<psySpec name="Internal" version="1.2">
  <whiteboard name="WB1"/>
  <module name="{name}" internal="{code}">
    <trigger from="WB1" type="{trigger}"/>
  </module>
</psySpec>""".encode()


async def _start(name: str, code: str, trigger: str) -> Server:
    config = parse_config(_spec(name, code, trigger), source="internal-test")
    return await serving(ServerOptions(config=config))


async def _listener(server: Server, pattern: str) -> TestModule:
    listener = TestModule("Listener", server.port)
    await listener.bind(listen=False)
    await listener.subscribe(f'<triggers><trigger from="WB1" type="{pattern}"/></triggers>')
    return listener


def _triggers(module: TestModule) -> list[Message]:
    found = [parse_wakeup(w).trigger for w in module.wakeups()]
    return [t for t in found if t is not None]


def test_an_internal_module_answers_an_external_post_that_an_external_module_receives() -> None:
    async def body() -> None:
        server = await _start("Echo", "internal_handlers:Echo", "Int.Ping")
        listener = await _listener(server, "Int.Pong")
        poster = await Raw.open(server.port)
        ping = Message(type="Int.Ping", to="WB1", sender="Poster", content="hello")
        assert (await poster.request(ping)).type == "RECEIVE_ACCEPT"
        await listener.wait_for(1)
        (pong,) = _triggers(listener)
        assert (pong.type, pong.sender, pong.content) == ("Int.Pong", "Echo", "hello")
        assert pong.wbid is not None  # stored in the history like any post
        assert internal_handlers.THREADS[-1] == threading.current_thread().name  # on the loop
        status = await poster.request(Message(type="STATUS", to="CNS", sender="Poster"))
        assert "modules.Echo.bound" in status.content and "queues.Echo.delivered" in status.content
        counters = server.counters()
        assert counters["modules"]["Echo"]["bound"] is True  # type: ignore[index]
        assert counters["queues"]["Echo"]["delivered"] == 1  # type: ignore[index]
        bind = Message(type="BIND_NOLISTEN", to="CNS", sender="Echo")
        refused = await poster.request(bind)
        assert (refused.type, refused.content.split(":")[0]) == ("BIND_ERROR", "BIND_REFUSED")
        await listener.close()
        await poster.close()
        await server.stop()

    run(body)


def test_a_blocking_internal_module_runs_on_its_own_thread_and_does_not_stall_the_loop() -> None:
    internal_handlers.RELEASE.clear()
    internal_handlers.BLOCKED.clear()

    async def body() -> None:
        server = await _start("Blocker", "internal_handlers:blocker", "Int.Work")
        listener = await _listener(server, "Int.*")
        poster = await Raw.open(server.port)
        work = Message(type="Int.Work", to="WB1", sender="Poster", content="job")
        assert (await poster.request(work)).type == "RECEIVE_ACCEPT"
        assert await asyncio.to_thread(internal_handlers.BLOCKED.wait, BOUND)
        # The handler is blocked: the loop still answers, stores and delivers.
        await poster.ping()
        other = Message(type="Int.Other", to="WB1", sender="Poster")
        assert (await poster.request(other)).type == "RECEIVE_ACCEPT"
        await listener.wait_for(2)  # Int.Work and Int.Other, while the handler waits
        internal_handlers.RELEASE.set()
        await listener.wait_for(3)
        assert [t.type for t in _triggers(listener)] == ["Int.Work", "Int.Other", "Int.Done"]
        assert internal_handlers.THREADS[-1].startswith("internal-Blocker")
        await listener.close()
        await poster.close()
        await server.stop()

    try:
        run(body)
    finally:
        internal_handlers.RELEASE.set()


def test_a_failing_internal_module_is_logged_and_counted_and_the_server_goes_on(
    caplog: pytest.LogCaptureFixture,
) -> None:
    async def body() -> None:
        server = await _start("Faulty", "internal_handlers:faulty", "Int.Job")
        listener = await _listener(server, "Int.Ok")
        poster = await Raw.open(server.port)
        for content in ("boom", "fine"):
            msg = Message(type="Int.Job", to="WB1", sender="Poster", content=content)
            assert (await poster.request(msg)).type == "RECEIVE_ACCEPT"
        await listener.wait_for(1)
        assert [t.content for t in _triggers(listener)] == ["fine"]
        queue = server.counters()["queues"]["Faulty"]  # type: ignore[index]
        assert (queue["failed"], queue["delivered"]) == (1, 1)
        await listener.close()
        await poster.close()
        await server.stop()

    with caplog.at_level(logging.ERROR, logger="openair.server"):
        run(body)
    errors = [r for r in caplog.records if "event=internal_error" in r.getMessage()]
    assert len(errors) == 1 and "module=Faulty" in errors[0].getMessage()
    assert errors[0].exc_info is not None  # the traceback is in the log


@pytest.mark.parametrize(
    "code", ["internal_handlers:missing", "no_such_package_xyz:run", "internal_handlers:THREADS"]
)
def test_code_that_cannot_be_loaded_refuses_the_start(code: str) -> None:
    config = parse_config(_spec("Bad", code, "Int.X"), source="bad")

    async def body() -> None:
        with pytest.raises(ConfigError, match=r"cannot be loaded|not callable"):
            await start_server(ServerOptions(port=0, config=config))

    run(body)


def test_the_psyspec_refuses_an_internal_attribute_that_names_no_code() -> None:
    with pytest.raises(ConfigError, match=":3:"):
        parse_config(_spec("Bad", "not code", "Int.X"), source="bad")
