"""Byte and connection budgets of the server (issue #19, OA-LIM-8 to OA-LIM-13).

Each test is one attack of the issue in miniature: a stalled module, a whiteboard filled with
large posts, a registration retrieving everything, many connections from one peer, a frame that
never ends, a frame that trickles in. Nothing sleeps to synchronise.
"""

from __future__ import annotations

import asyncio
import dataclasses
import threading
import time
from typing import Any

import pytest
from server_io_helpers import BOUND, Raw, TestModule, run, serving
from test_server_io_flow import FakeTransport

from openair.protocol.codec import to_frame
from openair.protocol.content import RetrieveSpec
from openair.protocol.framing import encode_frame
from openair.protocol.message import Message
from openair.protocol.objects import parse_dictionary
from openair.server.aio import budgets
from openair.server.aio import responder as responder_module
from openair.server.aio.app import ServerOptions
from openair.server.aio.connhost import FlowLimits
from openair.server.aio.protocol import Role, ServerConnection
from openair.server.core.config import ServerLimits
from openair.server.core.queues import DeliveryQueue
from openair.server.core.retrieve import registration_results
from openair.server.core.router import Outcome
from openair.server.core.store import MemoryStore
from openair.server.core.whiteboard import Whiteboard

KIB = 1024


def _big(n: int, size: int, *, priority: float | None = None) -> Message:
    return Message(
        type=f"Test.Big.{n}", to="WB1", sender="Poster", content="x" * size, priority=priority
    )


# -- per-module queue bytes (OA-LIM-8) ------------------------------------------------------------


def test_queue_bytes_drop_the_lowest_priority_oldest_first() -> None:
    queue = DeliveryQueue(capacity=10_000, max_bytes=40 * KIB)
    victims = []
    for n in range(20):
        victims += queue.push_all(_big(n, 8 * KIB), priority=1.0 if n % 7 == 0 else 3.0)
    assert queue.held_bytes <= 40 * KIB  # OA-LIM-8: bounded by bytes, not by items
    assert len(queue) + len(victims) == 20
    assert {v.priority for v in victims} == {3.0}  # OA-DELIV-9: the lowest priority goes first
    kept = [queue.pop(0) for _ in range(len(queue))]
    assert [i.priority for i in kept if i is not None].count(1.0) == 3  # all three kept
    seqs = [v.seq for v in victims]
    assert seqs == sorted(seqs)  # the oldest of them first
    assert queue.counters.dropped == len(victims)
    assert queue.counters.dropped_bytes == sum(v.size for v in victims)


def test_one_delivery_larger_than_the_queue_bytes_is_still_queued() -> None:
    queue = DeliveryQueue(capacity=10, max_bytes=KIB)
    assert queue.push_all(_big(1, 4 * KIB), priority=1.0) == []
    victims = queue.push_all(_big(2, 4 * KIB), priority=1.0)
    assert [v.message.type for v in victims] == ["Test.Big.1"] and len(queue) == 1


def test_a_stalled_module_holds_no_more_than_its_queue_bytes() -> None:
    async def body() -> None:
        limits = ServerLimits(max_queue_bytes=256 * KIB, ack_deadline_ms=int(BOUND * 2000))
        server = await serving(ServerOptions(limits=limits))
        stalled = TestModule("Stalled", server.port)
        await stalled.bind(listen=False)
        await stalled.subscribe()
        stalled.answer = False  # it keeps its connection and never acknowledges
        poster = await Raw.open(server.port)
        for n in range(40):  # 40 x 32 KiB = 1.25 MiB of wakeups for a 256 KiB queue
            assert (await poster.request(_big(n, 32 * KIB))).type == "RECEIVE_ACCEPT"
        counters = server.dispatcher.counters()["Stalled"]
        assert 0 < counters["bytes"] <= 256 * KIB  # OA-LIM-8
        assert counters["dropped"] > 0 and counters["dropped_bytes"] > 0
        assert server.dropped_total["QUEUE_OVERFLOW"] == counters["dropped"]
        status = await poster.request(Message(type="STATUS", to="CNS", sender="Poster"))
        entries = dict(parse_dictionary(status.content).entries)
        assert entries["queues.Stalled.bytes"] == str(counters["bytes"])  # visible in STATUS
        await stalled.close()
        await poster.close()
        await server.stop()

    run(body)


# -- history bytes (OA-LIM-10) and wakeup results (OA-LIM-9) -------------------------------------


def test_history_is_bounded_by_bytes_as_well_as_by_count() -> None:
    board = Whiteboard("WB1", maxcount=1000, max_bytes=20 * KIB)
    for n in range(50):
        board.store_post(_big(n, 4 * KIB), received_ns=(n + 1) * 1_000_000)
    assert board.bytes <= 20 * KIB and len(board) < 50  # OA-LIM-10
    assert board.evicted == 50 - len(board)
    newest = next(board.newest_first())
    assert newest.type == "Test.Big.49"
    board.store_post(_big(99, 64 * KIB), received_ns=10**9)
    assert len(board) == 1  # the newest copy is kept whatever its size


def test_the_store_behind_a_whiteboard_lags_by_bounded_bytes() -> None:
    store = MemoryStore()
    board = Whiteboard("WB1", maxcount=1000, max_bytes=64 * KIB, store=store)
    for n in range(200):
        board.store_post(_big(n, 64 * KIB), received_ns=(n + 1) * 1_000_000)
    held = sum(len(m.content) for m in store.load("WB1"))
    assert held <= 64 * KIB + 2 * 1024 * KIB  # OA-LIM-10: not 256 copies behind (16 MiB)


def _full_board(n: int, size: int) -> Whiteboard:
    board = Whiteboard("WB1", maxcount=100_000)
    for i in range(n):
        board.store_post(_big(i, size), received_ns=(i + 1) * 1_000_000)
    return board


def test_the_retrieves_of_a_wakeup_are_capped_in_count() -> None:
    board = _full_board(500, 10)
    specs = [RetrieveSpec(pattern="Test.*", latest=0)] * 20  # 20 "everything" retrieves
    found = registration_results(
        specs, board, {"WB1": board}, now_ns=10**12, max_count=50, max_bytes=10**9
    )
    assert len(found) == 50  # OA-LIM-9
    assert [m.type for m in found[:2]] == ["Test.Big.499", "Test.Big.498"]  # newest first


def test_the_retrieves_of_a_wakeup_are_capped_in_bytes() -> None:
    board = _full_board(200, 4 * KIB)
    specs = [RetrieveSpec(pattern="Test.*", latest=0)] * 20
    found = registration_results(
        specs, board, {"WB1": board}, now_ns=10**12, max_count=10_000, max_bytes=64 * KIB
    )
    assert 0 < sum(len(m.content) for m in found) <= 64 * KIB  # OA-LIM-9
    assert len(found) == 16


# -- connections (OA-LIM-11), unfinished frames (OA-LIM-12), whole-frame deadline (OA-LIM-13) ---


def test_connections_beyond_the_per_peer_limit_are_closed_at_once() -> None:
    async def body() -> None:
        server = await serving(ServerOptions(limits=ServerLimits(max_connections_per_peer=2)))
        first, second = await Raw.open(server.port), await Raw.open(server.port)
        await first.ping()
        await second.ping()
        third = await Raw.open(server.port)
        assert await asyncio.wait_for(third.closed_by_server(), BOUND)  # OA-LIM-11
        assert server.budget.refused_connections == 1
        await second.close()
        await first.ping()  # the server saw `second` go: its slot is free again
        fourth = await Raw.open(server.port)
        await fourth.ping()
        assert server.budget.counters()["connections"] == 2
        for raw in (first, third, fourth):
            await raw.close()
        await server.stop()

    run(body)


def test_unfinished_frames_beyond_the_total_budget_are_refused() -> None:
    async def body() -> None:
        server = await serving(ServerOptions(limits=ServerLimits(max_partial_bytes=8 * KIB)))
        frame = encode_frame(to_frame(_big(1, 16 * KIB)))
        slow = await Raw.open(server.port)
        slow.write(frame[: 6 * KIB])  # within the budget: held
        await (await Raw.open(server.port)).ping()
        other = await Raw.open(server.port)
        other.write(frame[: 4 * KIB])  # 6 + 4 KiB unfinished: past the budget
        reply = await asyncio.wait_for(other.recv(), BOUND)
        assert reply is not None and reply.content.startswith("LIMIT_EXCEEDED")  # OA-LIM-12
        assert await asyncio.wait_for(other.closed_by_server(), BOUND)
        assert server.budget.partial_bytes == 6 * KIB
        slow.write(frame[6 * KIB :])  # the held frame completes and is served
        assert (await asyncio.wait_for(slow.recv(), BOUND)) is not None
        assert server.budget.partial_bytes == 0
        await slow.close()
        await server.stop()

    run(body)


def test_a_refused_connection_gives_its_unfinished_bytes_back_at_once() -> None:
    """Not when the connection is lost: its lingering close waits for the peer (issue #19)."""

    async def body() -> None:
        server = await serving(ServerOptions(limits=ServerLimits(max_partial_bytes=8 * KIB)))
        frame = encode_frame(to_frame(_big(1, 16 * KIB)))
        slow = await Raw.open(server.port)
        slow.write(frame[: 6 * KIB])
        other = await Raw.open(server.port)
        other.write(frame[: 1 * KIB])  # 7 KiB unfinished in all: within the budget
        for _ in range(int(BOUND / 0.01)):  # until the server has read both
            if server.budget.partial_bytes == 7 * KIB:
                break
            await asyncio.sleep(0.01)
        assert server.budget.partial_bytes == 7 * KIB
        other.write(frame[1 * KIB : 4 * KIB])  # 9 KiB: past the budget
        reply = await asyncio.wait_for(other.recv(), BOUND)
        assert reply is not None and reply.content.startswith("LIMIT_EXCEEDED")  # OA-LIM-12
        # `other` is still open (it has not closed its side): the server lingers, and yet
        assert server.budget.partial_bytes == 6 * KIB  # its kilobyte is given back
        port = other.writer.get_extra_info("sockname")[1]
        refused = [c for c in server._conns.values() if c.peer[1] == port]
        assert refused and refused[0].reader.buffered == 0  # and its bytes are gone
        await other.close()
        await slow.close()
        await server.stop()

    run(body)


class _Host:
    def __init__(self, limits: ServerLimits) -> None:
        self.limits = limits
        self.flow = FlowLimits()

    def connection_opened(self, conn: ServerConnection) -> int:
        return 1

    def handle(self, conn: ServerConnection, msg: Message, **_: object) -> Outcome:
        return Outcome()

    def connection_lost(self, conn: ServerConnection) -> None:
        pass


def test_a_frame_that_trickles_in_is_cut_at_its_whole_deadline(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    clock = [1000.0]
    monkeypatch.setattr(time, "monotonic", lambda: clock[0])  # the frame timers' clock

    async def body() -> None:
        limits = ServerLimits(frame_deadline_ms=30_000, frame_total_deadline_ms=60_000)
        conn = ServerConnection(_Host(limits), Role.RESPONDER)  # type: ignore[arg-type]
        transport = FakeTransport()
        conn.connection_made(transport)
        frame = encode_frame(to_frame(_big(1, 1000)))
        for i in range(10):  # a byte every 20 s: every gap is within the 30 s gap deadline
            conn.data_received(frame[i : i + 1])
            clock[0] += 20.0
            conn.timers.check_deadline()
            if transport.aborted:
                break
        assert transport.aborted  # OA-LIM-13: cut after 60 s of one frame
        assert clock[0] - 1000.0 <= 80.0

    run(body)


def test_the_whole_frame_deadline_restarts_with_each_frame(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    clock = [1000.0]
    monkeypatch.setattr(time, "monotonic", lambda: clock[0])  # the frame timers' clock

    async def body() -> None:
        limits = ServerLimits(frame_deadline_ms=30_000, frame_total_deadline_ms=60_000)
        conn = ServerConnection(_Host(limits), Role.RESPONDER)  # type: ignore[arg-type]
        transport = FakeTransport()
        conn.connection_made(transport)
        ping = encode_frame(to_frame(Message(type="PING", to="CNS")))
        for _ in range(6):  # whole frames, each in two halves 20 s apart
            conn.data_received(ping[:10])
            clock[0] += 20.0
            conn.data_received(ping[10:])
            conn.timers.check_deadline()
        assert not transport.aborted

    run(body)


# -- bytes held in all (OA-LIM-14): refused before acknowledged, never lost after ---------------


def test_a_post_past_the_held_bytes_is_refused_before_it_is_stored() -> None:
    async def body() -> None:
        limits = ServerLimits(max_held_bytes=1024 * KIB, ack_deadline_ms=int(BOUND * 2000))
        server = await serving(ServerOptions(limits=limits))
        stalled = TestModule("Stalled", server.port)
        await stalled.bind(listen=False)
        await stalled.subscribe()
        stalled.answer = False  # its queue grows with every post
        poster = await Raw.open(server.port)
        answers = [(await poster.request(_big(n, 64 * KIB))).type for n in range(20)]
        accepted = answers.count("RECEIVE_ACCEPT")
        assert 0 < accepted < 20 and set(answers) == {"RECEIVE_ACCEPT", "RECEIVE_ERROR"}
        assert answers.index("RECEIVE_ERROR") == accepted  # refused from then on: the queue stays
        spec = '<retrieve type="Test.*"><latest>0</latest></retrieve>'
        found = await poster.request(
            Message(type="AIR.Retrieve", to="WB1", content=spec, content_is_xml=True)
        )
        assert found.content.count("<type>Test.Big.") == accepted  # every acknowledged post kept
        await stalled.close()
        await poster.close()
        await server.stop()

    run(body)


def test_the_monitor_ring_is_bounded_by_bytes() -> None:
    from openair_monitor.tap import Tap

    tap = Tap(capacity=512, max_bytes=100 * KIB)
    for n in range(50):
        tap.observe("WB1", _big(n, 10 * KIB), ())
    assert tap.count == 50 and len(tap.ring) < 10 and tap.bytes <= 100 * KIB
    assert tap.ring[-1][0].type == "Test.Big.49"
    tap.observe("WB1", _big(99, 500 * KIB), ())
    assert len(tap.ring) == 1  # the newest event is kept whatever its size


# -- fairness: a large request is decoded off the event loop ------------------------------------


def test_a_large_request_is_decoded_off_the_loop_and_answered_in_order(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    threads: list[str] = []
    original, original_lxml = responder_module.from_frame, responder_module.decode_with_lxml

    def recording(frame: Any, limits: Any) -> Message:
        threads.append(threading.current_thread().name)
        return original(frame, limits)

    def recording_lxml(xml: bytes, chunks: Any, limits: Any, **kw: Any) -> Message:
        threads.append(threading.current_thread().name)  # off the loop: lxml lets the lock go
        assert kw == {"pause": budgets.pause_for_the_loop}  # between its steps (the loop gate)
        return original_lxml(xml, chunks, limits, **kw)

    monkeypatch.setattr(responder_module, "from_frame", recording)
    monkeypatch.setattr(responder_module, "decode_with_lxml", recording_lxml)

    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        refs = b"&#65;" * (responder_module.OFF_LOOP_XML // 5 + 1)  # sent as references
        big = Message(
            type="Test.Refs", to="WB1", sender="P", content="<r>R</r>", content_is_xml=True
        )
        frame = to_frame(big)
        frame = dataclasses.replace(
            frame, xml=frame.xml.replace(b"<r>R</r>", b"<r>" + refs + b"</r>")
        )
        ping = Message(type="PING", to="CNS", sender="P")
        raw.write(encode_frame(frame) + encode_frame(to_frame(ping)))
        first, second = await raw.recv(), await raw.recv()
        assert first is not None and first.type == "RECEIVE_ACCEPT" and first.isresponse == big.id
        assert second is not None and second.type == "PING_SUCCESS"  # OA-SESS-2: in order
        await raw.close()
        await server.stop()

    run(body)
    loop_thread = threading.current_thread().name
    assert len(threads) == 2 and threads[0] != loop_thread and threads[1] == loop_thread
