"""Reads land in one buffer the whole loop shares (`ServerConnection.get_buffer`, issue #20).

Each read is copied out before any other connection reads, so bytes a connection keeps — half a
frame waiting for the rest — are never overwritten by another connection's read.
"""

from __future__ import annotations

import asyncio

from server_io_helpers import Raw, run, serving

from openair.protocol.codec import to_frame
from openair.protocol.framing import encode_frame
from openair.protocol.message import Message
from openair.server.aio import protocol


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
        def data_received(self, data: bytes) -> None:
            taken.append(data)

    conn = Probe.__new__(Probe)
    buf = conn.get_buffer(-1)
    assert buf.obj is protocol._READ_BUFFER.obj and len(buf) >= 64 * 1024
    buf[:5] = b"hello"
    conn.buffer_updated(5)
    buf[:5] = b"xxxxx"
    assert taken == [b"hello"] and isinstance(taken[0], bytes)
