"""Reads land in one buffer the whole loop shares (`ServerConnection.get_buffer`, issue #20).

Each read is copied out before any other connection reads, so bytes a connection keeps — half a
frame waiting for the rest — are never overwritten by another connection's read. The rest of a
large frame is lent to the reader as a view (issue #19): the reader copies it into the frame,
and a read kept for the peer's next turn is a copy.
"""

from __future__ import annotations

import asyncio

from server_io_helpers import Raw, run, serving

from openair.protocol.codec import to_frame
from openair.protocol.framing import FrameReader, encode_frame
from openair.protocol.message import Message
from openair.server.aio import protocol
from openair.server.aio.app import ServerOptions


def _post(n: int, size: int) -> Message:
    return Message(type=f"Test.Read.{n}", to="WB1", sender=f"P{n}", content=chr(97 + n) * size)


def test_half_a_frame_survives_other_connections_reads() -> None:
    async def body() -> None:
        server = await serving()
        first, second = await Raw.open(server.port), await Raw.open(server.port)
        held = encode_frame(to_frame(_post(0, 5000)))
        first.write(held[:3000])  # the rest comes after the other connection's reads
        await first.writer.drain()
        await asyncio.sleep(0.05)
        for n in range(1, 4):  # each read overwrites the shared buffer
            assert (await second.request(_post(n, 20000))).type == "RECEIVE_ACCEPT"
        first.write(held[3000:])
        reply = await first.recv()
        assert reply is not None and reply.type == "RECEIVE_ACCEPT"
        board = server.router.whiteboard("WB1")
        assert board is not None
        stored = {m.type: m.content for m in board.newest_first()}
        assert stored["Test.Read.0"] == "a" * 5000
        assert [stored[f"Test.Read.{n}"] for n in range(1, 4)] == [c * 20000 for c in "bcd"]
        await first.close()
        await second.close()
        await server.stop()

    run(body)


def test_reads_use_the_shared_buffer() -> None:
    """What the transport reads into is the one buffer, and what is handed on is a copy."""
    taken: list[bytes] = []

    class Probe(protocol.ServerConnection):
        def data_received(self, data: bytes | memoryview) -> None:
            taken.append(bytes(data) if isinstance(data, memoryview) else data)
            kinds.append(type(data))

    kinds: list[type] = []
    conn = Probe.__new__(Probe)
    conn.reader = FrameReader()  # holding nothing: a copy
    buf = conn.get_buffer(-1)
    assert buf.obj is protocol._READ_BUFFER.obj and len(buf) >= 64 * 1024
    buf[:5] = b"hello"
    conn.buffer_updated(5)
    buf[:5] = b"xxxxx"
    assert taken == [b"hello"] and kinds == [bytes]
    conn.reader.feed(b"Message\0" + (1 << 20).to_bytes(4, "little") + b"x" * (128 * 1024))
    buf[:5] = b"rest!"  # the rest of a large frame: lent as a view
    conn.buffer_updated(5)
    assert taken[-1] == b"rest!" and kinds[-1] is memoryview


def test_large_frames_read_as_views_survive_other_peers_and_kept_reads() -> None:
    """Three connections of one address, a fourth from another: the second's and the third's
    reads in a turn are kept for the next (one read spends a slice of 50 µs), the third's read
    after the second's was kept."""

    async def body() -> None:
        server = await serving(ServerOptions(fair_slice_s=0.00005))
        other = await Raw.open(server.port, local="127.0.0.3")  # fairness applies: two addresses
        big = [await Raw.open(server.port, local="127.0.0.2") for n in range(3)]
        frames = [encode_frame(to_frame(_post(n, 3 << 20))) for n in range(3)]
        for at in range(0, len(frames[0]), 200_000):  # interleaved, a piece at a time
            for raw, frame in zip(big, frames, strict=True):
                raw.write(frame[at : at + 200_000])
            await asyncio.gather(*(raw.writer.drain() for raw in big))
        for raw in big:
            reply = await raw.recv()
            assert reply is not None and reply.type == "RECEIVE_ACCEPT"
        board = server.router.whiteboard("WB1")
        assert board is not None
        stored = {m.type: m.content for m in board.newest_first()}
        for n in range(3):
            assert stored[f"Test.Read.{n}"] == "abc"[n] * (3 << 20)
        await other.ping()
        for raw in (*big, other):
            await raw.close()
        await server.stop()

    run(body)
