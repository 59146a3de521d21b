"""A cluster node's consumer that skips copies (OA-CLU-1, OA-CLU-4, issue #22), without NATS.

A fake JetStream stands in for the stream; the node's receiver gets copies as an ordered
consumer would hand them over, with a gap. The node must not adopt a later copy while an
earlier one is missing: it fetches the gap from the stream, or takes nothing and reads again.
"""

from __future__ import annotations

import asyncio
import threading
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import pytest

pytest.importorskip("nats")

from nats.js.errors import NotFoundError

from openair.cluster.store import ClusterStore, _Board, encode_copy, parse_spec
from openair.protocol.message import Message


def _payload(n: int) -> bytes:
    return encode_copy(Message(type="T.P", sender="s", to="WB", content=f"post-{n}"))


@dataclass
class _FakeStream:
    """What `stream_info` and `get_msg` of nats-py return, for sequences first..last."""

    first: int
    last: int
    reachable: bool = True
    gets: int = 0

    async def stream_info(self, name: str) -> Any:
        if not self.reachable:
            raise TimeoutError("no responders")
        return SimpleNamespace(state=SimpleNamespace(first_seq=self.first, last_seq=self.last))

    async def get_msg(self, name: str, seq: int) -> Any:
        self.gets += 1
        if not self.reachable:
            raise TimeoutError("no responders")
        if not self.first <= seq <= self.last:
            raise NotFoundError()
        return SimpleNamespace(data=_payload(seq), headers=None)


def _delivered(seq: int) -> Any:
    """A message as the ordered consumer hands it over."""
    sequence = SimpleNamespace(stream=seq)
    return SimpleNamespace(
        metadata=SimpleNamespace(sequence=sequence), data=_payload(seq), headers=None
    )


def _node(stream: _FakeStream) -> tuple[ClusterStore, _Board]:
    store = ClusterStore(parse_spec("n1@nats://127.0.0.1:1"))
    store._js = stream
    board = store._boards["WB"] = _Board("WB")
    return store, board


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
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    store._loop = loop
    try:
        mine = Message(type="T.Mine", sender="n1", to="WB", content="mine")
        wbid = store.publish("WB", mine)
        earlier = store.take("WB", wbid)
    finally:
        loop.call_soon_threadsafe(loop.stop)
        thread.join(5.0)
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
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    store._loop = loop
    try:
        mine = Message(type="T.Mine", sender="n1", to="WB", content="mine")
        if holds:
            assert store.publish("WB", mine) == 3  # adopted there, the earlier copies later
        else:  # STORE_FAILED (OA-CLU-2): adopted from the stream when it comes back
            with pytest.raises(TimeoutError):
                store.publish("WB", mine)
    finally:
        loop.call_soon_threadsafe(loop.stop)
        thread.join(5.0)
    assert store.late == 1
