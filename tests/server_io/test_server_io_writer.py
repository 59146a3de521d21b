"""`writer.FrameWriter`: replies counted until flushed (OA-LIM-5), requests batched per turn."""

from __future__ import annotations

import asyncio

from openair.protocol.codec import from_frame
from openair.protocol.framing import FrameReader, FrameTag
from openair.protocol.message import Message
from openair.server.aio.writer import FrameWriter, encode_parts


class _Transport(asyncio.Transport):
    """Records each write; `buffered` is what the test says the kernel has not taken yet."""

    def __init__(self) -> None:
        super().__init__()
        self.writes: list[bytes] = []
        self.buffered = 0

    def write(self, data: bytes | bytearray | memoryview) -> None:
        self.writes.append(data)  # type: ignore[arg-type]  # kept as given: identity is checked

    def get_write_buffer_size(self) -> int:
        return self.buffered


def _writer() -> tuple[FrameWriter, _Transport]:
    writer, transport = FrameWriter(), _Transport()
    writer.transport = transport
    return writer, transport


def test_a_reply_is_written_at_once_and_in_flight_until_flushed() -> None:
    writer, transport = _writer()
    transport.buffered = 30
    assert writer.write_reply(transport, [b"a" * 10, b"b" * 10], 20) == 30
    assert transport.writes == [b"a" * 10, b"b" * 10]
    writer.write_reply(transport, [b"c" * 10], 10)
    transport.buffered = 25  # the first reply's bytes are not all gone yet
    assert writer.replies_in_flight() == 2
    transport.buffered = 10  # the first reply left the buffer, the second did not
    assert writer.replies_in_flight() == 1
    transport.buffered = 0
    assert writer.replies_in_flight() == 0


def test_requests_of_one_turn_go_out_in_one_write_big_parts_alone() -> None:
    async def body() -> tuple[_Transport, bytes, int]:
        writer, transport = _writer()
        big = b"x" * (64 * 1024)
        transport.buffered = 7
        assert writer.write_request(transport, [b"h1", b"s1"], 4) == 7 + 4
        writer.write_request(transport, [b"h2", big], 2 + len(big))
        writer.write_request(transport, [b"s3"], 2)
        before = len(transport.writes)
        assert writer.batched
        await asyncio.sleep(0)  # the end of the turn
        return transport, big, before

    transport, big, before = asyncio.run(body())
    assert before == 0
    assert transport.writes == [b"h1s1h2", big, b"s3"]
    assert transport.writes[1] is big  # a large chunk is never copied (spec 11.2)


def test_a_dropped_writer_writes_nothing_more() -> None:
    async def body() -> _Transport:
        writer, transport = _writer()
        writer.write_request(transport, [b"lost"], 4)
        writer.drop()
        await asyncio.sleep(0)
        writer.flush()
        assert not writer.batched
        assert writer.replies_in_flight() == 0
        return transport

    assert asyncio.run(body()).writes == []


def test_a_reply_xml_cannot_carry_becomes_an_empty_receive_error() -> None:
    """OA-MSG-14: still an answer to the same request, so the peer's pairing holds."""
    bad = Message(type="T", id="m1", isresponse="r7", content="\x01 not XML text")
    parts = encode_parts(bad, FrameTag.MESSAGE, sender="CNS", conn_id=3)
    reader = FrameReader()
    reader.feed(b"".join(parts))
    frame = reader.next_frame()
    assert frame is not None
    reply = from_frame(frame)
    assert (reply.type, reply.isresponse, reply.sender, reply.content) == (
        "RECEIVE_ERROR",
        "r7",
        "CNS",
        "",
    )
