"""Fairness under large work (issue #19, item 6): a large retrieve is written off the loop.

Choosing the results reads the whiteboard on the event loop; writing the reply of thousands of
messages is done on a worker thread while the loop serves everyone else, and the reply is the
one the lxml writer would send. Nothing sleeps: the worker waits for the test to say so.
"""

from __future__ import annotations

import asyncio
import threading
from typing import Any

import pytest
from server_io_helpers import BOUND, Raw, run, serving

from openair.protocol import wakeup as wakeup_module
from openair.protocol.codec import to_frame
from openair.protocol.framing import encode_frame
from openair.protocol.message import Message
from openair.protocol.objects import encode_message_collection, parse_message_collection
from openair.server.aio import protocol as protocol_module
from openair.server.aio.writer import Sliced
from openair.server.core import commands as commands_module
from openair.server.core import retrieve as retrieve_module
from openair.server.core import router_commands as router_module
from openair.server.core.retrieve import PreparedRetrieve, answer_retrieve, prepare_retrieve
from openair.server.core.store import MemoryStore
from openair.server.core.whiteboard import Whiteboard

KIB = 1024
LARGE = retrieve_module._LARGE_SCAN + 100  # copies enough for a retrieve off the loop
NAMES = router_module._LARGE_STATUS + 52  # names enough for a STATUS off the loop
_ALL = '<retrieve type="Test.*"><latest>0</latest></retrieve>'


def _board(n: int, size: int) -> Whiteboard:
    board = Whiteboard("WB1", store=MemoryStore(), maxcount=10_000)
    for i in range(n):
        board.store_post(Message(type=f"Test.{i}", to="WB1", sender="P", content="x" * size), i)
    return board


def _retrieve(content: str = _ALL) -> Message:
    return Message(type="AIR.Retrieve", to="WB1", sender="R", content=content, content_is_xml=True)


def test_the_prepared_reply_is_the_one_the_lxml_writer_sends() -> None:
    board = _board(LARGE, KIB)
    prepared = prepare_retrieve(_retrieve(), board, {"WB1": board}, now_ns=5, max_xml=1 << 24)
    assert prepared.large and len(prepared.results()) == LARGE
    reply, wire = prepared.build()
    assert reply.type == "AIR.Retrieve.Success"
    assert reply.content == encode_message_collection(prepared.results())  # OA-RET-7
    assert wire is not None and not isinstance(wire, bytes)  # parts of ~256 KiB
    assert b"".join(wire) == encode_frame(to_frame(reply))  # the spliced frame is the written one
    assert [m.type for m in parse_message_collection(reply.content)][:2] == [
        f"Test.{LARGE - 1}",
        f"Test.{LARGE - 2}",
    ]


def test_off_the_loop_the_reply_is_its_frame_without_joining_its_text() -> None:
    # Joining a 10 MiB collection into the reply's content held the lock ~3 ms on the worker
    # while the loop waited (issue #19); the frame is what is sent.
    board = _board(LARGE, KIB)
    prepared = prepare_retrieve(_retrieve(), board, {"WB1": board}, now_ns=5, max_xml=1 << 24)
    full, wire = prepared.build()
    bare, bare_wire = prepared.build(text=False)
    assert wire is not None and bare_wire is not None and bare.content == ""
    renamed = b"".join(wire).replace(full.id.encode(), bare.id.encode())  # each reply its id
    assert b"".join(bare_wire) == renamed
    assert bare.type == full.type and bare.isresponse == full.isresponse
    assert max(map(len, bare_wire or ())) <= 512 * KIB  # no part of megabytes either


@pytest.mark.parametrize(
    ("content", "code"),
    [("<nonsense/>", "RETRIEVE_INVALID"), (_ALL.replace("<latest>0", "<latest>1"), "")],
)
def test_small_and_failing_retrieves_are_not_deferred(content: str, code: str) -> None:
    board = _board(3, KIB)
    prepared = prepare_retrieve(_retrieve(content), board, {"WB1": board}, now_ns=5, max_xml=9999)
    assert not prepared.large
    direct = answer_retrieve(_retrieve(content), board, {"WB1": board}, now_ns=5, max_xml=9999)
    assert prepared.build()[0].type == direct.type
    assert code in direct.content


def test_the_scan_reads_the_copies_of_when_the_request_came() -> None:
    board = _board(600, 10)
    prepared = prepare_retrieve(_retrieve(), board, {"WB1": board}, now_ns=5, max_xml=1 << 24)
    for i in range(600, 700):  # stored (and the oldest evicted) before the worker scans
        board.store_post(Message(type=f"Test.{i}", to="WB1", sender="P"), i)
    assert [m.type for m in prepared.results()][:1] == ["Test.599"]  # the loop's snapshot
    assert len(prepared.results()) == 600


def test_a_reply_past_max_frame_xml_is_limit_exceeded_when_written() -> None:
    board = _board(600, KIB)
    prepared = prepare_retrieve(_retrieve(), board, {"WB1": board}, now_ns=5, max_xml=200 * KIB)
    reply, wire = prepared.build()
    assert reply.type == "AIR.Retrieve.Failed" and "LIMIT_EXCEEDED" in reply.content
    assert wire is None  # OA-RET-15


def test_other_clients_are_served_while_a_large_retrieve_reply_is_written(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    released = threading.Event()
    threads: list[str] = []
    original = PreparedRetrieve.build

    def held(self: PreparedRetrieve, **kwargs: Any) -> Any:
        threads.append(threading.current_thread().name)
        released.wait(BOUND)  # on the loop this would stop every client until it timed out
        return original(self, **kwargs)

    monkeypatch.setattr(retrieve_module.PreparedRetrieve, "build", held)

    async def body() -> None:
        server = await serving()
        poster, reader, other = [await Raw.open(server.port) for _ in range(3)]
        for i in range(LARGE):  # copies enough to scan: a reply chosen and written off the loop
            poster.send(Message(type=f"Test.{i}", to="WB1", sender="P", content="x" * KIB))
        for _ in range(LARGE):
            assert (await poster.recv()) is not None
        retrieve = _retrieve()
        reader.send(retrieve)
        reader.send(Message(type="PING", to="CNS", sender="R"))  # answered after, in order
        await other.ping()  # served while the retrieve's reply is being written
        released.set()
        first, second = await reader.recv(), await reader.recv()
        assert first is not None and first.type == "AIR.Retrieve.Success"
        assert (
            first.isresponse == retrieve.id
            and len(parse_message_collection(first.content)) == LARGE
        )
        assert second is not None and second.type == "PING_SUCCESS"  # OA-SESS-2
        for raw in (poster, reader, other):
            await raw.close()
        await server.stop()

    run(body)
    assert len(threads) == 1 and threads[0] != threading.current_thread().name


def test_a_status_of_many_names_is_written_off_the_loop(monkeypatch: pytest.MonkeyPatch) -> None:
    """Item 7: a STATUS naming thousands of modules does not stop the other clients."""
    released = threading.Event()
    threads: list[str] = []
    original = commands_module.status_reply

    def held(*args: Any, **kwargs: Any) -> Message:
        threads.append(threading.current_thread().name)
        released.wait(BOUND)
        return original(*args, **kwargs)

    monkeypatch.setattr(commands_module, "status_reply", held)
    encoders: list[str] = []
    encode = router_module.encode_frame

    def encoding(*args: Any, **kwargs: Any) -> bytes:
        encoders.append(threading.current_thread().name)
        return encode(*args, **kwargs)

    monkeypatch.setattr(router_module, "encode_frame", encoding)  # encoded there too

    async def body() -> None:
        server = await serving()
        names = [await Raw.open(server.port) for _ in range(100)]
        for i in range(NAMES):  # names with counters (a request each), spread on 100 connections
            names[i % 100].send(Message(type="BIND_NOLISTEN", to="CNS", sender=f"Name{i}"))
            names[i % 100].send(Message(type="PING", to="CNS", sender=f"Name{i}"))
        for i in range(NAMES):
            bound, ping = await names[i % 100].recv(), await names[i % 100].recv()
            assert bound is not None and ping is not None and ping.type == "PING_SUCCESS"
        asker, other = await Raw.open(server.port), await Raw.open(server.port)
        asker.send(Message(type="STATUS", to="CNS", sender="Asker"))
        asker.send(Message(type="PING", to="CNS", sender="Asker"))  # in the same read, after
        await other.ping()  # served while the STATUS is being written
        released.set()
        reply, ping = await asker.recv(), await asker.recv()
        assert reply is not None and f"modules.Name{NAMES - 1}.requests" in reply.content
        assert ping is not None and ping.type == "PING_SUCCESS"  # OA-SESS-2: in order
        for raw in [*names, asker, other]:
            await raw.close()
        await server.stop()

    run(body)
    assert len(threads) == 1 and threads[0] != threading.current_thread().name
    assert encoders == threads


def test_a_large_reply_is_written_a_slice_at_a_time_as_the_peer_reads() -> None:
    """Issue #19: a 12 MiB retrieve reply to a peer that does not read is not handed to the
    transport at once (a copy of all of it in one callback, and all of it buffered): the
    server's write buffer stays near its high-water mark until the peer reads, and then the
    whole reply comes, followed by the answer to the request sent after it (OA-SESS-2)."""
    posts, size = 6000, 2 * KIB

    async def body() -> None:
        server = await serving()
        poster, reader = await Raw.open(server.port), await Raw.open(server.port)
        for start in range(0, posts, 500):
            for i in range(start, start + 500):
                poster.send(Message(type=f"Test.{i}", to="WB1", sender="P", content="x" * size))
            for _ in range(500):
                assert (await poster.recv()) is not None
        transport = reader.writer.transport
        transport.pause_reading()  # the peer reads nothing for now
        reader.send(_retrieve())
        reader.send(Message(type="PING", to="CNS", sender="R"))
        local = reader.writer.get_extra_info("sockname")[1]
        conn = next(c for c in server._conns.values() if c.peer[1] == local)
        for _ in range(int(BOUND / 0.01)):  # until the reply waits for the peer to read
            if conn._sliced is not None and conn._reading_paused:
                break
            await asyncio.sleep(0.01)
        assert conn._sliced is not None, "the reply was not written in slices"
        high = server.options.flow.high_water
        assert conn.transport is not None
        assert conn.transport.get_write_buffer_size() <= high + protocol_module._SLICE
        transport.resume_reading()
        first, second = await reader.recv(), await reader.recv()
        assert first is not None and first.type == "AIR.Retrieve.Success"
        found = parse_message_collection(first.content)
        assert len(found) == posts and found[0].type == f"Test.{posts - 1}"
        assert second is not None and second.type == "PING_SUCCESS"
        assert conn._sliced is None
        for raw in (poster, reader):
            await raw.close()
        await server.stop()

    run(body, bound=120.0)


def test_the_collection_pieces_and_their_groups_are_the_collection() -> None:
    board = _board(300, 3000)
    results = list(board.snapshot())
    pieces = wakeup_module.collection_parts(results)
    assert "".join(pieces) == wakeup_module.collection_xml(results)
    groups = wakeup_module.encoded_groups([*pieces, "é"], size=64 * KIB)
    assert b"".join(groups) == "".join([*pieces, "é"]).encode("utf-8")
    assert all(len(g) < 64 * KIB + 4 * KIB for g in groups) and len(groups) > 10
    assert wakeup_module.collection_parts([]) == [wakeup_module.collection_xml([])]


def test_a_sliced_reply_takes_its_parts_in_order_never_across_two() -> None:
    done: list[str] = []
    sliced = Sliced(parts=(b"abcde", b"", b"fg"), done=lambda: done.append("done"))
    taken = []
    while not sliced.finished:
        taken.append(bytes(sliced.take(2)))
    assert taken == [b"ab", b"cd", b"e", b"", b"fg"]
