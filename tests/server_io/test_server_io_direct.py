"""Deliveries sent without the queue (`ModuleDelivery.send_now`, issue #20), over real sockets.

A wakeup for a module whose task waits with nothing to do goes out at once; everything else —
a full window, a queue with items, a trigger's `after`, modules waiting for a turn — queues as
before, and the order and counts are those of the queue (OA-DELIV-5, OA-DELIV-8, OA-TRIG-3,
OA-PRIO-5).
"""

from __future__ import annotations

import asyncio
import time

import pytest
from server_io_helpers import BOUND, TRIGGERS, Raw, TestModule, post, run, serving

from openair.protocol.message import Message
from openair.protocol.wakeup import parse_wakeup
from openair.server.aio.app import Server
from openair.server.aio.scheduling import TurnGate


def _ids(module: TestModule) -> list[str]:
    out = []
    for wakeup in module.wakeups():
        trigger = parse_wakeup(wakeup).trigger
        assert trigger is not None
        out.append(trigger.id)
    return out


def _queue(server: Server, name: str) -> dict[str, int]:
    return server.dispatcher.counters()[name]


async def _ready(server: Server, module: TestModule, triggers: str = TRIGGERS) -> Raw:
    """Bind `module` with a callback connection, subscribe it, return a poster's connection."""
    await module.bind(listen=False)
    await module.subscribe(triggers)
    await asyncio.wait_for(server.dispatcher.drained(), BOUND)
    return await Raw.open(server.port)


def test_an_idle_module_gets_its_wakeups_without_the_queue() -> None:
    async def body() -> None:
        server = await serving()
        module = TestModule("Idle", server.port)
        poster = await _ready(server, module)
        before = _queue(server, "Idle")  # the phase update of the subscription (OA-REG-15)
        sent = [post("Poster", n) for n in range(3)]
        for n, msg in enumerate(sent, 1):
            assert (await poster.request(msg)).type == "RECEIVE_ACCEPT"
            await module.wait_for(n)
            await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        assert _ids(module) == [m.id for m in sent]
        queue = _queue(server, "Idle")
        grew = [queue[k] - before[k] for k in ("direct", "in", "delivered", "popped", "depth")
                if k in queue]  # fmt: skip
        assert grew == [3, 3, 3, 0]
        await module.close()
        await server.stop()

    run(body)


def test_a_full_window_queues_and_the_order_is_kept() -> None:
    async def body() -> None:
        server = await serving()
        release = asyncio.Event()

        async def slow(msg: Message) -> str | None:
            if msg.sender == "WB1":  # not the subscription's phase update
                await release.wait()
            return None

        module = TestModule("Legacy", server.port, handler=slow)  # one at a time (OA-DELIV-5)
        poster = await _ready(server, module)
        first = post("Poster", 0)
        await poster.request(first)
        await module.wait_for(1)  # sent at once, unanswered: the window is full
        later = [post("Poster", n, priority=p) for n, p in ((1, 5.0), (2, 1.0), (3, 5.0))]
        for msg in later:
            await poster.request(msg)
        queue = _queue(server, "Legacy")
        assert (queue["direct"], queue["depth"]) == (1, 3)
        release.set()
        await module.wait_for(4)
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        # The queue's order, by priority (OA-PRIO-1): the high one overtakes the low ones.
        assert _ids(module) == [first.id, later[1].id, later[0].id, later[2].id]
        assert _queue(server, "Legacy")["delivered"] == 1 + 4  # and the phase update
        await module.close()
        await server.stop()

    run(body)


def test_a_triggers_after_is_waited_for() -> None:
    async def body() -> None:
        server = await serving()
        module = TestModule("Later", server.port)
        later = '<triggers><trigger from="WB1" type="Test.*" after="80"/></triggers>'
        poster = await _ready(server, module, later)
        started = time.monotonic()
        await poster.request(post("Poster", 0))
        await module.wait_for(1)
        assert time.monotonic() - started >= 0.075  # OA-TRIG-3
        assert _queue(server, "Later")["direct"] == 0
        await module.close()
        await server.stop()

    run(body)


def test_with_modules_waiting_for_a_turn_it_queues(monkeypatch: pytest.MonkeyPatch) -> None:
    """OA-PRIO-5: while work waits for a turn, whiteboard priority decides what goes first."""
    monkeypatch.setattr(TurnGate, "waiting", property(lambda self: True))

    async def body() -> None:
        server = await serving()
        module = TestModule("Ranked", server.port)
        poster = await _ready(server, module)
        await poster.request(post("Poster", 0))
        await module.wait_for(1)
        assert _queue(server, "Ranked")["direct"] == 0
        await module.close()
        await server.stop()

    run(body)


def test_a_due_wakeup_passes_one_that_waits_for_its_after() -> None:
    async def body() -> None:
        server = await serving()
        module = TestModule("Mixed", server.port)
        triggers = (
            '<triggers><trigger from="WB1" type="Test.Slow.*" after="150"/>'
            '<trigger from="WB1" type="Test.Fast.*"/></triggers>'
        )
        poster = await _ready(server, module, triggers)
        slow, fast = post("Poster", 0, kind="Test.Slow"), post("Poster", 1, kind="Test.Fast")
        await poster.request(slow)
        await poster.request(fast)
        await module.wait_for(2)
        assert _ids(module) == [fast.id, slow.id]  # OA-TRIG-3: the delayed one after its time
        assert _queue(server, "Mixed")["direct"] == 1
        await module.close()
        await server.stop()

    run(body)
