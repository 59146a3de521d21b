"""Large wakeups are written on the worker thread, in each module's order (issue #19).

A wakeup of more than `LARGE_WAKEUP` bytes of text (a large post, many retrieved messages) held
every client's turn while it was written on the event loop. The server now writes it on the
worker (`Dispatcher.builds`); the module still gets its wakeups in the order of the posts, and
a build in progress neither outlives the module's session nor stalls the server's stop.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field

import pytest
from server_io_helpers import BOUND, TRIGGERS, Raw, TestModule, run, serving

from openair.protocol.message import Message
from openair.protocol.wakeup import parse_wakeup
from openair.server.aio.app import ServerOptions
from openair.server.core.wakeups import LARGE_WAKEUP, WakeupParts

BIG = "b" * (LARGE_WAKEUP + 1)


@dataclass
class HeldWorker:
    """Builds on the worker thread wait for `release`; `threads` names where each build ran."""

    release: threading.Event = field(default_factory=threading.Event)
    threads: list[str] = field(default_factory=list)


@pytest.fixture
def held(monkeypatch: pytest.MonkeyPatch) -> Iterator[HeldWorker]:
    state = HeldWorker()
    original = WakeupParts.build

    def build(self: WakeupParts) -> tuple[Message, bytes | None]:
        state.threads.append(threading.current_thread().name)
        if threading.current_thread() is not threading.main_thread():
            state.release.wait(BOUND)  # the worker is stuck (or just behind)
        return original(self)

    monkeypatch.setattr(WakeupParts, "build", build)
    yield state
    state.release.set()


async def _subscribed(port: int, name: str, registration: str = TRIGGERS) -> TestModule:
    """A module bound without a port (a callback connection), subscribed to `registration`."""
    module = TestModule(name, port)
    await module.bind(listen=False)
    await module.subscribe(registration)
    return module


def _post(n: int, content: str) -> Message:
    return Message(type=f"Test.Item.{n}", to="WB1", sender="Poster", content=content, id=f"p{n}")


def test_large_wakeups_are_built_on_the_worker_and_arrive_in_order(held: HeldWorker) -> None:
    held.release.set()  # the worker is free

    async def body() -> None:
        server = await serving()
        module = await _subscribed(server.port, "Reader")
        poster = await Raw.open(server.port)
        contents = [BIG, "s", "s", BIG, "s", BIG, BIG, "s"]
        for n, content in enumerate(contents):
            poster.send(_post(n, content))  # pipelined: the small ones overtake nothing
        for _ in contents:
            assert (await poster.recv()).type == "RECEIVE_ACCEPT"
        await module.wait_for(len(contents))
        triggers = [parse_wakeup(w).trigger for w in module.wakeups()]
        assert [t.id if t else None for t in triggers] == [f"p{n}" for n in range(len(contents))]
        assert [t.content if t else None for t in triggers] == contents
        assert len(held.threads) == 4
        assert all(name.startswith("openair-large") for name in held.threads), held.threads
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        assert server.dispatcher.pending == 0
        await poster.close()
        await module.close()
        await server.stop()

    run(body)


def test_a_build_in_progress_when_the_module_leaves_is_forgotten(held: HeldWorker) -> None:
    async def body() -> None:
        server = await serving()
        module = await _subscribed(server.port, "Leaver")
        poster = await Raw.open(server.port)
        assert (await poster.request(_post(0, BIG))).type == "RECEIVE_ACCEPT"
        assert (await poster.request(_post(1, "s"))).type == "RECEIVE_ACCEPT"
        assert server.dispatcher.pending == 2  # one being written, one behind it
        await module.close()  # the session ends: its deliveries are discarded (OA-SESS-15)
        while server.router.module("Leaver") is not None:
            await asyncio.sleep(0.01)
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        held.release.set()
        await asyncio.sleep(0.05)  # the build finishes: nothing is queued for a gone module
        assert server.dispatcher.pending == 0
        assert "Leaver" not in server.dispatcher.modules
        assert (await poster.request(_post(2, "s"))).type == "RECEIVE_ACCEPT"  # still serving
        await poster.close()
        await server.stop()

    run(body)


def test_the_server_stops_with_a_build_that_never_ends(held: HeldWorker) -> None:
    async def body() -> None:
        server = await serving(ServerOptions(grace_s=0.2))
        module = await _subscribed(server.port, "Waiting")
        poster = await Raw.open(server.port)
        assert (await poster.request(_post(0, BIG))).type == "RECEIVE_ACCEPT"
        assert (await poster.request(_post(1, "s"))).type == "RECEIVE_ACCEPT"
        await poster.close()
        assert server.dispatcher.pending == 2
        try:
            await asyncio.wait_for(server.stop(), BOUND)  # OA-SESS-24: the grace, then stop
        finally:
            held.release.set()
        assert server.dropped_total.get("DELIVERY_FAILED") == 2  # both counted, not lost silently
        assert server.dispatcher.pending == 0
        await module.close()

    run(body)


def test_past_the_waiting_budget_a_wakeup_is_written_at_once_still_in_order(
    held: HeldWorker,
) -> None:
    # Small posts (decoded on the loop, not behind the stuck worker) waking with 300 KiB of
    # retrieved messages: large wakeups.
    registration = (
        '<module name="Reader"><triggers from="WB1"><trigger type="Test.Go.*"/></triggers>'
        '<retrieves><retrieve type="Test.Fill.*"><latest>0</latest></retrieve></retrieves>'
        "</module>"
    )

    async def body() -> None:
        server = await serving()
        builds = server.dispatcher.builds
        poster = await Raw.open(server.port)
        for n in range(300):
            poster.send(
                Message(type=f"Test.Fill.{n}", to="WB1", sender="Poster", content="f" * 1024)
            )
        for _ in range(300):
            assert (await poster.recv()).type == "RECEIVE_ACCEPT"
        module = await _subscribed(server.port, "Reader", registration)
        builds.max_bytes = 400 * 1024  # room for one waiting wakeup
        for n in range(3):
            go = Message(type=f"Test.Go.{n}", to="WB1", sender="Poster", id=f"p{n}")
            assert (await poster.request(go)).type == "RECEIVE_ACCEPT"
        assert builds.written_at_once == 2 and 0 < builds.bytes <= builds.max_bytes
        held.release.set()
        await module.wait_for(3)
        triggers = [parse_wakeup(w).trigger for w in module.wakeups()]
        assert [t.id if t else None for t in triggers] == ["p0", "p1", "p2"]
        # The worker may start its build after the loop wrote the other two.
        assert sorted(held.threads) == ["MainThread", "MainThread", "openair-large_0"]
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        assert builds.bytes == 0
        await poster.close()
        await module.close()
        await server.stop()

    run(body)
