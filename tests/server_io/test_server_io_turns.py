"""Each peer address gets a bounded slice of every loop turn (issue #19, `fairness.Turns`).

The unit tests drive `Turns` with a hand-moved clock. The server tests are about order, not
time: a burst of posts from one address, and a STATUS sent from another address once the
server has begun the burst; the STATUS reports how many posts were stored before it was
answered. With the fairness slice the burst yields to the other address after a few posts;
without it (`fair_slice_s=0`) one socket read of the burst — hundreds of posts — goes first.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable

import pytest
from server_io_helpers import Raw, run, serving

from openair.protocol.codec import to_frame
from openair.protocol.framing import encode_frame
from openair.protocol.message import Message
from openair.protocol.objects import parse_dictionary
from openair.server.aio.fairness import Turns
from openair.server.aio.options import ServerOptions


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def _turns(slice_s: float = 1.0) -> tuple[Turns, _Clock, list[Callable[[], None]]]:
    clock, soon = _Clock(), []
    turns = Turns(slice_s, soon.append, clock)
    turns.enter("a")
    turns.enter("b")  # two addresses: someone to be fair to
    return turns, clock, soon


def _next_turn(soon: list[Callable[[], None]]) -> None:
    due, soon[:] = list(soon), []
    for call in due:
        call()


def test_a_peer_runs_until_its_slice_of_the_turn_is_spent() -> None:
    turns, _, soon = _turns()
    assert turns.may_run("a")
    turns.charge("a", 0.6)
    assert turns.may_run("a") and turns.may_run("b")
    turns.charge("a", 0.6)
    assert not turns.may_run("a")
    assert turns.may_run("b")  # another address is not held by a's work
    _next_turn(soon)  # a new turn: every slice is whole again
    assert turns.may_run("a")


def test_with_one_address_open_nothing_is_counted_or_deferred() -> None:
    turns, _, _ = _turns()
    turns.leave("b")
    turns.charge("a", 5.0)
    assert turns.may_run("a") and turns.deadline("a") == math.inf
    turns.enter("b")
    assert not turns.may_run("a")  # shared again: a's slice is spent
    turns.leave("b")
    turns.leave("a")
    assert not turns.shared


def test_the_deadline_is_what_is_left_of_the_slice() -> None:
    turns, clock, _ = _turns()
    clock.now = 10.0
    turns.charge("a", 0.25)
    assert turns.deadline("a") == pytest.approx(10.75)
    assert turns.deadline("b") == pytest.approx(11.0)


def test_waiting_peers_are_served_round_robin_each_up_to_its_slice() -> None:
    turns, clock, soon = _turns()
    served: list[str] = []

    def job(peer: str, name: str) -> Callable[[], None]:
        def run() -> None:
            served.append(name)
            clock.now += 0.6
            turns.charge(peer, 0.6)

        return run

    for i in range(3):
        turns.wait("a", job("a", f"a{i}"))
    turns.wait("b", job("b", "b0"))
    assert not turns.may_run("a") and not turns.may_run("b")  # something of theirs waits
    assert turns.waiting == 4 and turns.deferred == 4
    _next_turn(soon)
    assert served == ["a0", "a1", "b0"]  # a: two jobs (0.6 + 0.6 passes 1.0), then b
    assert turns.waiting == 1 and soon  # the rest in the next turn
    _next_turn(soon)
    assert served == ["a0", "a1", "b0", "a2"]
    assert turns.waiting == 0 and turns.may_run("a")


def test_a_job_that_waits_again_goes_behind_its_peer() -> None:
    turns, _, soon = _turns()
    order: list[str] = []

    def again() -> None:
        order.append("again")
        turns.charge("a", 2.0)  # spent the whole slice, and waits for the next turn
        if order.count("again") == 1:
            turns.wait("a", again)

    turns.wait("a", again)
    turns.wait("a", lambda: order.append("second"))
    _next_turn(soon)
    assert order == ["again"]
    _next_turn(soon)
    assert order == ["again", "second", "again"]


_POSTS = 4000


def _stored_when_another_address_asks(slice_s: float) -> tuple[int, int]:
    """Post a burst from 127.0.0.1; once the first is acknowledged, ask STATUS from 127.0.0.2.

    Returns (posts stored when the STATUS was answered, posts acknowledged in all).
    """
    result: list[int] = []

    async def body() -> None:
        server = await serving(ServerOptions(fair_slice_s=slice_s))
        flood = await Raw.open(server.port)
        other = await Raw.open(server.port, local="127.0.0.2")
        await other.ping()
        burst = b"".join(
            encode_frame(to_frame(Message(type=f"Test.F{i}", to="WB1", sender="F", content="x")))
            for i in range(_POSTS)
        )
        flood.write(burst)
        first = await flood.recv()  # the server has begun the burst
        assert first is not None and first.type == "RECEIVE_ACCEPT"
        status = await other.request(Message(type="STATUS", to="CNS", sender="Other"))
        entries = dict(parse_dictionary(status.content).entries)
        result.append(int(entries["whiteboards.WB1.count"]))
        acked = 1
        while acked < _POSTS:
            reply = await flood.recv()
            assert reply is not None and reply.type == "RECEIVE_ACCEPT"
            acked += 1
        result.append(acked)
        await flood.close()
        await other.close()
        await server.stop()

    run(body)
    return result[0], result[1]


def test_another_address_is_served_a_few_posts_into_a_burst() -> None:
    stored, acked = _stored_when_another_address_asks(0.00005)
    assert acked == _POSTS  # nothing of the burst is lost or reordered by waiting
    assert stored < 100, stored


def test_without_fairness_a_whole_read_of_the_burst_goes_first() -> None:
    """The measurement above can tell: one read of the burst is many hundreds of posts."""
    stored, acked = _stored_when_another_address_asks(0.0)
    assert acked == _POSTS
    assert stored >= 300, stored


def test_modules_that_leave_together_are_all_forgotten_in_their_turns() -> None:
    """What the server does when a module goes is its peer's work, done in later turns when the
    peer's slice is spent: every module is unbound in the end, none is forgotten twice."""
    names = [f"Leaver{i}" for i in range(60)]

    async def body() -> None:
        server = await serving(ServerOptions(fair_slice_s=0.00005))
        assert server.turns is not None
        raws = [await Raw.open(server.port) for _ in names]
        for raw, name in zip(raws, names, strict=True):
            reply = await raw.request(Message(type="BIND_NOLISTEN", to="CNS", sender=name))
            assert reply.type == "BIND_ACCEPT", reply
        other = await Raw.open(server.port, local="127.0.0.2")  # someone to be fair to
        await other.ping()
        before = server.turns.deferred
        for raw in raws:
            raw.writer.close()  # all at once
        for _ in range(500):
            if len(server._conns) == 1 and all(server.router.module(n) is None for n in names):
                break
            await asyncio.sleep(0.01)
        assert all(server.router.module(n) is None for n in names)
        assert len(server._conns) == 1  # the other address's
        assert server.turns.deferred > before  # some waited for a later turn
        await other.ping()
        await other.close()
        await server.stop()

    run(body)


def test_with_every_connection_from_one_address_a_burst_never_waits() -> None:
    async def body() -> None:
        server = await serving(ServerOptions(fair_slice_s=0.00005))
        assert server.turns is not None
        flood = await Raw.open(server.port)
        flood.write(
            b"".join(
                encode_frame(to_frame(Message(type=f"Test.F{i}", to="WB1", sender="F")))
                for i in range(500)
            )
        )
        for _ in range(500):
            reply = await flood.recv()
            assert reply is not None and reply.type == "RECEIVE_ACCEPT"
        assert server.turns.deferred == 0
        await flood.close()
        await server.stop()

    run(body)


def test_an_http_request_kept_for_a_later_turn_still_reaches_the_monitor() -> None:
    """A read kept while its address waits is replayed as it came: the first bytes of an HTTP
    request are still handed to the monitor, not to the frame reader (which would refuse them)."""

    async def body() -> None:
        server = await serving(ServerOptions(fair_slice_s=0.00005))
        assert server.turns is not None
        other = await Raw.open(server.port, local="127.0.0.2")
        await other.ping()
        flood = await Raw.open(server.port)
        flood.write(
            b"".join(
                encode_frame(to_frame(Message(type=f"Test.F{i}", to="WB1", sender="F")))
                for i in range(_POSTS)
            )
        )
        assert (await flood.recv()) is not None  # the burst has begun: its address waits
        reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
        writer.write(b"GET /api/overview HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n")
        status = await asyncio.wait_for(reader.readline(), 30)
        assert status.startswith(b"HTTP/1.1 200"), status
        writer.close()
        for _ in range(_POSTS - 1):
            assert (await flood.recv()) is not None
        assert server.turns.deferred > 0
        await flood.close()
        await other.close()
        await server.stop()

    run(body)
