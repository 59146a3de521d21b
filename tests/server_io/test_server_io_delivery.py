"""Deliveries to modules over real sockets: both paths, retries, slow consumers, shutdown."""

from __future__ import annotations

import asyncio
from pathlib import Path

from server_io_helpers import BOUND, Raw, TestModule, post, run, serving

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair.protocol.wakeup import parse_wakeup
from openair.server.aio.app import ServerOptions
from openair.server.aio.connhost import FlowLimits
from openair.server.aio.dispatcher import DeliveryOptions
from openair.server.aio.stores import SqliteStore
from openair.server.core.config import ServerLimits

FAST = DeliveryOptions(backoff_s=(0.01, 0.01))
#: A delivery unanswered for 0.3 s has failed (OA-DELIV-11).
QUICK = ServerLimits(ack_deadline_ms=300)


def _trigger_ids(module: TestModule) -> list[str]:
    ids = []
    for wakeup in module.wakeups():
        trigger = parse_wakeup(wakeup).trigger
        assert trigger is not None
        ids.append(trigger.id)
    return ids


def test_delivery_over_the_callback_connection() -> None:
    async def body() -> None:
        server = await serving()
        module = TestModule("CallbackReader", server.port)
        await module.bind(listen=False)  # BIND_NOLISTEN + Receive frame (OA-SESS-5, OA-SESS-7)
        await module.subscribe()
        poster = await Raw.open(server.port)
        sent = [post("Poster", n) for n in range(5)]
        for msg in sent:
            assert (await poster.request(msg)).type == "RECEIVE_ACCEPT"
        await module.wait_for(5)
        assert _trigger_ids(module) == [m.id for m in sent]  # FIFO at equal priority
        queues = server.counters()["queues"]
        assert isinstance(queues, dict)
        await module.close()
        await server.stop()

    run(body)


def test_delivery_over_a_connection_to_the_bound_port() -> None:
    async def body() -> None:
        server = await serving()
        module = TestModule("PortReader", server.port)
        reply = await module.bind(listen=True)  # BIND with a tcplocation (OA-SESS-4)
        assert module.listener is not None
        assert int(reply.content) == module.listener.sockets[0].getsockname()[1]
        await module.subscribe()
        poster = await Raw.open(server.port)
        for n in range(5):
            assert (await poster.request(post("Poster", n))).type == "RECEIVE_ACCEPT"
        await module.wait_for(5)
        assert len(_trigger_ids(module)) == 5
        await module.close()
        await server.stop()

    run(body)


def test_a_delivery_that_is_never_acknowledged_is_retried_twice_then_abandoned() -> None:
    async def body() -> None:
        server = await serving(ServerOptions(limits=QUICK, delivery=FAST))
        module = TestModule("Silent", server.port)
        await module.bind(listen=True)
        await module.subscribe()
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)  # the phase update went out
        module.answer = False
        poster = await Raw.open(server.port)
        msg = post("Poster", 1)
        assert (await poster.request(msg)).type == "RECEIVE_ACCEPT"
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        assert _trigger_ids(module) == [msg.id] * 3  # OA-DELIV-7: one try and two retries
        queue = server.dispatcher.counters()["Silent"]
        assert (queue["failed"], queue["retried"], queue["delivered"]) == (1, 2, 1)
        assert server.dropped_total["DELIVERY_FAILED"] == 1
        await module.close()
        await server.stop()

    run(body)


def test_a_module_whose_port_refuses_is_abandoned_after_three_attempts() -> None:
    async def body() -> None:
        server = await serving(ServerOptions(limits=QUICK, delivery=FAST))
        module = TestModule("Gone", server.port)
        await module.bind(listen=True)
        await module.subscribe()
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        assert module.listener is not None
        module.listener.close()
        await module.listener.wait_closed()
        for task in list(module.tasks):  # drop the server's open delivery connection too
            task.cancel()
        poster = await Raw.open(server.port)
        assert (await poster.request(post("Poster", 1))).type == "RECEIVE_ACCEPT"
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        assert server.dispatcher.counters()["Gone"]["failed"] == 1
        await poster.ping()  # a dead module never delays the acknowledgement of posts
        await module.close()
        await server.stop()

    run(body)


def test_a_stalled_module_loses_its_own_deliveries_only() -> None:
    async def body() -> None:
        limits = ServerLimits(max_queue=20, ack_deadline_ms=int(BOUND * 2000))
        options = ServerOptions(limits=limits)
        server = await serving(options)
        live = [TestModule(f"Live{n}", server.port) for n in range(9)]
        stalled = TestModule("Stalled", server.port)
        for module in [*live, stalled]:
            await module.bind(listen=False)
            await module.subscribe()
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        stalled.answer = False  # it keeps its connection open and never acknowledges again
        poster = await Raw.open(server.port)
        n_posts, batch = 120, 10  # batches smaller than the queue: the live ones keep up
        for n in range(n_posts):
            assert (await poster.request(post("Poster", n))).type == "RECEIVE_ACCEPT"
            if (n + 1) % batch == 0:
                for module in live:
                    await module.wait_for(n + 1)
        assert all(len(_trigger_ids(m)) == n_posts for m in live)
        counters = server.dispatcher.counters()
        assert all(counters[m.name]["dropped"] == 0 for m in live)
        stuck = counters["Stalled"]
        assert stuck["depth"] == 20  # OA-DELIV-8: bounded
        assert stuck["dropped"] == n_posts - 20 - 1  # one in flight, 20 queued, the rest dropped
        assert server.dropped_total["QUEUE_OVERFLOW"] == stuck["dropped"]
        for module in [*live, stalled]:
            await module.close()
        await server.stop()

    run(body)


def test_overflow_keeps_the_higher_priority_messages() -> None:
    async def body() -> None:
        limits = ServerLimits(max_queue=5, ack_deadline_ms=int(BOUND * 2000))
        options = ServerOptions(limits=limits)
        server = await serving(options)
        module = TestModule("Choosy", server.port)
        await module.bind(listen=False)
        await module.subscribe()
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        module.answer = False
        poster = await Raw.open(server.port)
        blocker = post("Poster", 0)
        await poster.request(blocker)
        await module.wait_for(1)  # in flight, unanswered: the rest must queue
        low = [post("Poster", n, priority=5.0) for n in range(1, 6)]
        high = [post("Poster", n, priority=1.0) for n in range(6, 9)]
        for msg in [*low, *high]:
            await poster.request(msg)
        module.answer = True
        assert module.primary is not None
        # Unblock: a new callback connection replaces the stalled one (OA-SESS-7); the
        # in-flight delivery is retried on it, then the queue drains in priority order.
        await module.open_callback()
        await module.wait_for(2 + 5)  # the blocker twice (sent, then retried), then the queue
        ids = _trigger_ids(module)
        assert ids[:2] == [blocker.id, blocker.id]
        rest = [i for i in ids[1:] if i != blocker.id]
        assert rest == [m.id for m in high] + [m.id for m in low[3:]]  # OA-DELIV-9, OA-PRIO-1
        await module.close()
        await server.stop()

    run(body)


def test_pipelining_module_gets_several_deliveries_in_flight() -> None:
    async def body() -> None:
        options = ServerOptions(limits=ServerLimits(ack_deadline_ms=int(BOUND * 2000)))
        server = await serving(options)
        module = TestModule("Piped", server.port)
        await module.bind(listen=False, extensions="pipelining")
        await module.subscribe()
        await asyncio.wait_for(server.dispatcher.drained(), BOUND)
        module.answer = False  # OA-DELIV-5: without acknowledgements, more still arrive
        poster = await Raw.open(server.port)
        for n in range(10):
            await poster.request(post("Poster", n))
        await module.wait_for(10)
        await module.close()
        await server.stop()

    run(body)


def test_keepalive_is_sent_on_an_idle_delivery_connection_and_answered() -> None:
    async def body() -> None:
        server = await serving(ServerOptions(flow=FlowLimits(keepalive_s=0.05)))
        module = TestModule("Idle", server.port)
        await module.bind(listen=True)
        await module.subscribe()  # the phase update opens the delivery connection
        await module.wait_for(2, "KEEPALIVE")  # OA-KEEP-1
        keepalive = next(m for m in module.received if m.type == "KEEPALIVE")
        assert (keepalive.sender, keepalive.to) == ("", "")
        poster = await Raw.open(server.port)
        await poster.request(post("Poster", 1))
        await module.wait_for(1)  # deliveries continue after keepalives
        await module.close()
        await server.stop()

    run(body)


def test_a_ping_from_the_module_on_its_callback_connection_is_answered() -> None:
    async def body() -> None:
        server = await serving()
        primary = await Raw.open(server.port)
        bound = await primary.request(Message(type="BIND_NOLISTEN", to="CNS", sender="Asker"))
        assert bound.type == "BIND_ACCEPT"
        callback = await Raw.open(server.port)
        note = Message(type="RECEIVE_NAME_NOTIFICATION", to="CNS", sender="Asker")
        callback.send(note, FrameTag.RECEIVE)
        await primary.ping()  # the callback connection is registered by now
        reply = await callback.request(Message(type="PING", to="CNS", sender="Asker"))
        assert reply.type == "PING_SUCCESS"
        assert server.router.module("Asker") is not None
        await server.stop()

    run(body)


def test_graceful_stop_loses_nothing_it_acknowledged(tmp_path: Path) -> None:
    db = tmp_path / "history.sqlite"
    acked: list[str] = []

    async def body() -> None:
        server = await serving(ServerOptions(store=f"sqlite:{db}"))
        assert "durable" in server.extensions
        module = TestModule("Keeper", server.port)
        await module.bind(listen=True)
        await module.subscribe()
        poster = await Raw.open(server.port)
        refused = 0
        stopping: asyncio.Task[None] | None = None
        for n in range(400):
            msg = post("Poster", n)
            poster.send(msg)
            reply = await poster.recv()
            if reply is None:
                break
            if reply.type == "RECEIVE_ACCEPT":
                acked.append(msg.id)
            else:
                assert reply.content.startswith("SHUTTING_DOWN")  # OA-SESS-24
                refused += 1
            if n == 100:
                stopping = asyncio.get_running_loop().create_task(server.stop())
        assert stopping is not None
        await stopping
        assert refused <= 1 and len(acked) >= 100
        assert set(acked) <= set(_trigger_ids(module))  # OA-ERR-5: every delivery attempted
        assert server.dropped_total["DELIVERY_FAILED"] == 0
        await module.close()

    run(body)
    store = SqliteStore(db)  # OA-ERR-5: every acknowledged post is still stored
    stored = {m.id for m in store.load("WB1")}
    store.close()
    assert set(acked) <= stored
