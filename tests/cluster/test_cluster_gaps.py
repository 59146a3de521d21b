"""A cluster node's consumer that skips copies (OA-CLU-1, OA-CLU-4, issue #22), without NATS.

A fake JetStream stands in for the stream; the node's receiver gets copies as an ordered
consumer would hand them over, with a gap. The node must not adopt a later copy while an
earlier one is missing: it fetches the gap from the stream, or takes nothing and reads again.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache
from types import SimpleNamespace
from typing import Any

import pytest

pytest.importorskip("nats")

from nats.js.errors import NotFoundError, ServiceUnavailableError

from openair.cluster.reading import CHECK_FIRST
from openair.cluster.store import ClusterStore, _Board, encode_copy, parse_spec
from openair.protocol.message import Message


@cache  # one payload per post, as the stream holds one copy of it
def _payload(n: int) -> bytes:
    return encode_copy(Message(type="T.P", sender="s", to="WB", content=f"post-{n}"))


@dataclass
class _FakeStream:
    """What `stream_info` and `get_msg` of nats-py return, for sequences first..last."""

    first: int
    last: int
    reachable: bool = True
    gets: int = 0
    unavailable: int = 0  # gets answered 503 first (JetStream electing a leader)

    async def stream_info(self, name: str) -> Any:
        if not self.reachable:
            raise TimeoutError("no responders")
        return SimpleNamespace(state=SimpleNamespace(first_seq=self.first, last_seq=self.last))

    async def get_msg(self, name: str, seq: int) -> Any:
        self.gets += 1
        if not self.reachable:
            raise TimeoutError("no responders")
        if self.unavailable:
            self.unavailable -= 1
            raise ServiceUnavailableError()
        if not self.first <= seq <= self.last:
            raise NotFoundError()
        return SimpleNamespace(data=_payload(seq), headers=None)


def _delivered(seq: int, consumer: int | None = None) -> Any:
    """A message as the ordered consumer hands it over; `consumer` is its delivery sequence
    (by default one of a consumer past its first copies, which are checked: reading.py)."""
    sequence = SimpleNamespace(stream=seq, consumer=consumer or seq + CHECK_FIRST)
    return SimpleNamespace(
        metadata=SimpleNamespace(sequence=sequence), data=_payload(seq), headers=None
    )


def _node(stream: _FakeStream) -> tuple[ClusterStore, _Board]:
    store = ClusterStore(parse_spec("n1@nats://127.0.0.1:1"))
    store._js = stream
    board = store._boards["WB"] = _Board("WB")
    return store, board


@contextlib.contextmanager
def _client_thread(store: ClusterStore) -> Iterator[None]:
    """Run the store's client loop on a thread of its own, as `connect` does."""
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    store._loop = loop
    try:
        yield
    finally:
        loop.call_soon_threadsafe(loop.stop)
        thread.join(5.0)


async def _deliver(store: ClusterStore, board: _Board, seqs: list[int]) -> None:
    received = store._receiver(board, board.generation)
    for seq in seqs:
        await received(_delivered(seq))


def test_a_copy_the_consumer_skipped_is_fetched_before_later_ones() -> None:
    stream = _FakeStream(first=1, last=6)
    store, board = _node(stream)
    asyncio.run(_deliver(store, board, [1, 2, 4, 5, 5, 3, 6]))
    taken = store.take("WB")
    assert [(m.wbid, m.content) for m in taken] == [(n, f"post-{n}") for n in range(1, 7)]
    assert board.through == 6 and board.filled == 1 and stream.gets == 1


def test_copies_the_stream_discarded_are_not_missing() -> None:
    stream = _FakeStream(first=40, last=42)  # maxcount 3: 1..39 are gone (OA-WB-6)
    store, board = _node(stream)
    asyncio.run(_deliver(store, board, [40, 41, 42]))
    assert [m.wbid for m in store.take("WB")] == [40, 41, 42]
    assert stream.gets == 0 and board.filled == 0


def test_a_gap_that_cannot_be_read_takes_nothing_and_reads_again() -> None:
    stream = _FakeStream(first=1, last=5, reachable=False)
    store, board = _node(stream)
    first = board.generation
    asyncio.run(_deliver(store, board, [1, 2, 4, 5]))
    assert [m.wbid for m in store.take("WB")] == [1, 2]
    assert board.through == 2  # the watchdog subscribes again from 3
    assert board.generation != first  # the skipping consumer's later copies are ignored
    stream.reachable = True
    asyncio.run(_deliver(store, board, [3, 4, 5]))  # the new consumer, from the gap
    assert [m.wbid for m in store.take("WB")] == [3, 4, 5]


class _Misnumbering:
    """A store that acknowledges a post at `acked` although the post is stored at `stored`,
    after another node's post that holds `acked` (seen once the store re-elected leaders)."""

    def __init__(self, store: ClusterStore, board: _Board, acked: int, stored: int) -> None:
        self.store, self.board, self.acked, self.stored = store, board, acked, stored

    async def publish_async(
        self, subject: str, payload: bytes, *, stream: str, headers: dict[str, str]
    ) -> Any:
        received = self.store._receiver(self.board, self.board.generation)
        for seq in range(self.board.through + 1, self.stored):  # others' posts
            await received(_delivered(seq))
        own = _delivered(self.stored)
        own.data, own.headers = payload, headers
        await received(own)
        ack: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        ack.set_result(SimpleNamespace(seq=self.acked))
        return ack


def test_the_own_copy_is_adopted_where_it_came_back_not_where_it_was_acknowledged() -> None:
    store, board = _node(_FakeStream(first=1, last=8))
    store._js = _Misnumbering(store, board, acked=7, stored=8)
    with _client_thread(store):
        mine = Message(type="T.Mine", sender="n1", to="WB", content="mine")
        wbid = store.publish("WB", mine)
        earlier = store.take("WB", wbid)
    assert wbid == 8 and store.misnumbered == 1
    assert [(m.wbid, m.content) for m in earlier] == [(n, f"post-{n}") for n in range(1, 8)]
    assert store.take("WB") == []  # the own copy came back and is not adopted twice


class _NeverBack(_Misnumbering):
    """The post is acknowledged at `acked`, its copy does not come back through the consumer
    (no consumer could be made while the store elected leaders); `get_msg` tells what the
    stream holds at `acked`: this copy (`holds`) or another node's."""

    def __init__(self, store: ClusterStore, board: _Board, *, holds: bool) -> None:
        super().__init__(store, board, acked=3, stored=3)
        self.holds = holds
        self.ident = ""

    async def publish_async(
        self, subject: str, payload: bytes, *, stream: str, headers: dict[str, str]
    ) -> Any:
        self.ident = headers["Nats-Msg-Id"] if self.holds else "another-node-1"
        ack: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        ack.set_result(SimpleNamespace(seq=self.acked))
        return ack

    async def get_msg(self, name: str, seq: int) -> Any:
        return SimpleNamespace(data=_payload(seq), headers={"Nats-Msg-Id": self.ident})


@pytest.mark.parametrize("holds", [True, False])
def test_a_copy_that_does_not_come_back_is_checked_in_the_stream(holds: bool) -> None:
    store, board = _node(_FakeStream(first=1, last=3))
    store._js = _NeverBack(store, board, holds=holds)
    store.timeout_s = 0.2
    with _client_thread(store):
        mine = Message(type="T.Mine", sender="n1", to="WB", content="mine")
        if holds:
            assert store.publish("WB", mine) == 3  # adopted there, the earlier copies later
        else:  # STORE_FAILED (OA-CLU-2): adopted from the stream when it comes back
            with pytest.raises(TimeoutError):
                store.publish("WB", mine)
    assert store.late == 1


# -- a new consumer on a replica that holds what its side never committed --------------------


def _stale(seq: int, consumer: int, content: str) -> Any:
    """A copy a cut-off replica accepted at `seq` (its poster was answered STORE_FAILED)."""
    msg = _delivered(seq, consumer)
    msg.data = encode_copy(Message(type="T.P", sender="s", to="WB", content=content))
    msg.headers = {"Nats-Msg-Id": "cut-off-node-1"}
    return msg


def test_a_new_consumer_s_copy_the_leader_holds_otherwise_is_replaced_by_the_leader_s() -> None:
    stream = _FakeStream(first=1, last=6)
    store, board = _node(stream)

    async def body() -> None:
        await _deliver(store, board, [1, 2, 3, 4])
        received = store._receiver(board, board.generation)
        await received(_stale(5, 1, "cut-0"))  # the first copy of a consumer made after a heal
        await received(_delivered(6, 2))

    asyncio.run(body())
    assert [(m.wbid, m.content) for m in store.take("WB")] == [
        (n, f"post-{n}") for n in range(1, 7)
    ]
    assert board.replaced == 1 and stream.gets == 2  # both of the new consumer's copies asked
    assert store.counters()["replaced"] == 1


def test_a_new_consumer_s_copy_the_leader_does_not_hold_is_not_taken() -> None:
    stream = _FakeStream(first=1, last=4)
    store, board = _node(stream)
    asyncio.run(_deliver(store, board, [1, 2, 3, 4]))
    first = board.generation

    async def stale() -> None:
        await store._receiver(board, board.generation)(_stale(5, 1, "cut-0"))

    asyncio.run(stale())
    assert [m.wbid for m in store.take("WB")] == [1, 2, 3, 4]
    assert board.through == 4 and board.generation != first  # the watchdog reads from 5 again
    stream.last = 5  # the majority stores another post at 5; a new consumer reads it
    asyncio.run(_deliver_new(store, board, [5]))
    assert [(m.wbid, m.content) for m in store.take("WB")] == [(5, "post-5")]


async def _deliver_new(store: ClusterStore, board: _Board, seqs: list[int]) -> None:
    received = store._receiver(board, board.generation)
    for n, seq in enumerate(seqs, 1):
        await received(_delivered(seq, n))


def test_a_new_consumer_s_copy_discarded_since_by_the_limit_is_taken() -> None:
    stream = _FakeStream(first=10, last=12)  # 1..9 gone (OA-WB-6) since the consumer read 9
    store, board = _node(stream)
    board.through = 8
    asyncio.run(_deliver_new(store, board, [9, 10]))
    assert [m.wbid for m in store.take("WB")] == [9, 10]
    assert board.replaced == 0


def test_an_established_consumer_s_copies_are_not_asked_of_the_leader() -> None:
    stream = _FakeStream(first=1, last=3)
    store, board = _node(stream)
    received = [_delivered(n, CHECK_FIRST + n) for n in (1, 2, 3)]

    async def body() -> None:
        for msg in received:
            await store._receiver(board, board.generation)(msg)

    asyncio.run(body())
    assert [m.wbid for m in store.take("WB")] == [1, 2, 3] and stream.gets == 0


@pytest.mark.parametrize("unavailable", [2, 3])
def test_a_leader_that_cannot_answer_is_asked_again_then_not_waited_for(unavailable: int) -> None:
    stream = _FakeStream(first=1, last=6, unavailable=unavailable)
    store, board = _node(stream)
    board.through = 4
    asyncio.run(_deliver_new(store, board, [5, 6]))
    assert [m.wbid for m in store.take("WB")] == [5, 6]  # taken either way, nothing waits
    if unavailable < 3:  # answered on the last try; the next copy is checked too
        assert stream.gets == unavailable + 2 and board.unchecked == -1
    else:  # unchecked from here on for this consumer (an election must not stall reading)
        assert stream.gets == 3 and board.unchecked == board.generation


def test_a_retrieve_whose_consumer_stalls_reads_the_rest_from_the_stream() -> None:
    """OA-CLU-3: after an election JetStream refused consumers for 15 s; the stream's leader
    still answered, so a retrieve must not answer from a read model that stopped short."""
    stream = _FakeStream(first=1, last=6)
    store, board = _node(stream)
    asyncio.run(_deliver(store, board, [1, 2, 3]))  # then the consumer stops
    store.timeout_s = 0.2
    with _client_thread(store):
        store.sync("WB")
        stream.unavailable, stream.last = 10, 7  # the leader cannot answer either: it says so
        with pytest.raises(TimeoutError):
            store.sync("WB")
    assert [m.wbid for m in store.take("WB")] == [1, 2, 3, 4, 5, 6]
    assert board.through == 6 and stream.gets == 4  # 4, 5, 6, then 7 refused
