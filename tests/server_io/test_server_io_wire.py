"""The server adapter on real loopback sockets with raw frames (spec 2, 6.1, 13, 14)."""

from __future__ import annotations

import asyncio
import struct

from server_io_helpers import Raw, TestModule, post, run, serving

from openair.protocol.codec import encode_message
from openair.protocol.framing import Frame as RawFrame
from openair.protocol.framing import FrameTag, encode_frame
from openair.protocol.message import Message
from openair.server.aio.app import ServerOptions
from openair.server.core.config import ServerLimits


def header(tag: bytes, length: int) -> bytes:
    return tag + b"\x00" + struct.pack("<I", length)


def message_frame(xml: bytes) -> bytes:
    return header(b"Message", len(xml)) + xml


PING_XML = encode_message(Message(type="PING", id="p-1", to="CNS", sender="Tester"))


def test_malformed_xml_is_answered_and_the_connection_stays_usable() -> None:
    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        raw.write(message_frame(b"<message><type>PING</type><to>CNS</to"))
        reply = await raw.recv()
        assert reply is not None and reply.type == "RECEIVE_ERROR"
        assert reply.content.startswith("XML_MALFORMED: ")  # OA-ERR-2
        assert reply.isresponse == ""  # OA-SESS-1: the id could not be read
        await raw.ping()  # OA-ERR-3: the same connection still works
        await raw.close()
        await server.stop()

    run(body)


def test_doctype_is_xml_forbidden() -> None:
    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        xml = b'<!DOCTYPE m [<!ENTITY x "y">]><message><type>PING</type></message>'
        raw.write(message_frame(xml))
        reply = await raw.recv()
        assert reply is not None and reply.type == "RECEIVE_ERROR"
        assert reply.content.startswith("XML_FORBIDDEN")
        await raw.ping()
        await raw.close()
        await server.stop()

    run(body)


def test_invalid_message_is_answered_with_the_request_id() -> None:
    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        xml = b'<message priority="9.5"><type>PING</type><id>abc</id><from>Q</from></message>'
        raw.write(message_frame(xml))
        reply = await raw.recv()
        assert reply is not None and reply.type == "RECEIVE_ERROR"
        assert reply.content.startswith("MESSAGE_INVALID")
        assert (reply.isresponse, reply.to) == ("abc", "Q")
        await raw.ping()
        await server.stop()

    run(body)


def test_oversized_length_is_refused_and_closes_only_that_connection() -> None:
    async def body() -> None:
        limits = ServerLimits(max_frame_xml=4096)
        server = await serving(ServerOptions(limits=limits))
        other = await Raw.open(server.port)
        await other.ping()
        raw = await Raw.open(server.port)
        raw.write(header(b"Message", 4097))
        reply = await raw.recv()
        assert reply is not None and reply.type == "RECEIVE_ERROR"  # OA-FRAME-7
        assert reply.content.startswith("FRAME_TOO_LARGE")
        assert await raw.closed_by_server()
        await other.ping()  # OA-ERR-4
        await server.stop()

    run(body)


def test_unknown_tag_closes_without_a_reply() -> None:
    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        raw.write(header(b"message", len(PING_XML)) + PING_XML)  # OA-FRAME-2: case-sensitive
        assert await raw.closed_by_server()  # OA-FRAME-6
        again = await Raw.open(server.port)
        await again.ping()
        await server.stop()

    run(body)


def test_invalid_binary_sizes_are_answered_then_closed() -> None:
    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        xml = b"<message><type>Test.X</type><to>WB1</to><binarysizes>1,x</binarysizes></message>"
        raw.write(message_frame(xml))
        reply = await raw.recv()
        assert reply is not None and reply.content.startswith("BINARY_SIZES_INVALID")
        assert await raw.closed_by_server()
        await server.stop()

    run(body)


def test_a_frame_that_stops_arriving_is_dropped_at_the_deadline() -> None:
    async def body() -> None:
        server = await serving(ServerOptions(limits=ServerLimits(frame_deadline_ms=100)))
        raw = await Raw.open(server.port)
        raw.write(message_frame(PING_XML)[:20])
        assert await raw.closed_by_server()  # OA-FRAME-12: no reply, just closed
        await server.stop()

    run(body)


def test_binary_frame_on_the_main_port_is_an_unknown_command() -> None:
    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        raw.write(encode_frame(RawFrame(tag=FrameTag.BINARY, chunks=(b"\x00" * 5,))))
        reply = await raw.recv()
        assert reply is not None and reply.type == "UNKNOWN_COMMAND"
        assert reply.content == "Offending cmd: BinaryOnly"  # OA-STREAM-11
        await raw.ping()
        await server.stop()

    run(body)


def test_frames_split_and_joined_are_answered_in_order() -> None:
    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        msgs = [Message(type="PING", id=f"id-{n}", to="CNS", sender="T") for n in range(20)]
        data = b"".join(
            encode_frame(RawFrame(tag=FrameTag.MESSAGE, xml=encode_message(m))) for m in msgs
        )
        for i in range(0, len(data), 7):  # OA-FRAME-11
            raw.write(data[i : i + 7])
            await raw.writer.drain()
        replies = [await raw.recv() for _ in msgs]
        assert [r.isresponse for r in replies if r] == [m.id for m in msgs]  # OA-SESS-2
        await server.stop()

    run(body)


def test_garbage_on_200_connections_does_not_disturb_a_good_module() -> None:
    async def body() -> None:
        server = await serving()
        module = TestModule("Good", server.port)
        await module.bind(listen=False)
        await module.subscribe()
        poster = await Raw.open(server.port)
        garbage = [
            b"GET / HTTP/1.1\r\n\r\n",
            header(b"Message", 10) + b"<message>",
            header(b"Receive", 3) + b"<x>",
            bytes(range(256)),
            message_frame(b"<message><type>PING</type></message>") + b"\xff" * 40,
        ]

        async def hostile(n: int) -> None:
            raw = await Raw.open(server.port)
            raw.write(garbage[n % len(garbage)])
            await raw.writer.drain()
            await raw.close()

        n_posts = 40
        attack = asyncio.gather(*(hostile(n) for n in range(200)))
        for n in range(n_posts):
            reply = await poster.request(post("Poster", n))
            assert reply.type == "RECEIVE_ACCEPT"
        await attack
        await module.wait_for(n_posts)
        assert [m.content.count("Test.Item.") for m in module.wakeups()] == [1] * n_posts
        await module.close()
        await server.stop()

    run(body)


def test_2000_connections_opened_and_dropped_then_the_server_still_serves() -> None:
    async def body() -> None:
        server = await serving()

        async def churn(n: int) -> None:
            _, writer = await asyncio.open_connection("127.0.0.1", server.port)
            if n % 3 == 0:
                writer.write(message_frame(PING_XML)[:15])  # a partial frame, then gone
            writer.close()
            await writer.wait_closed()

        for start in range(0, 2000, 250):
            await asyncio.gather(*(churn(n) for n in range(start, start + 250)))
        raw = await Raw.open(server.port)
        await raw.ping()
        # Every dropped connection is forgotten: only the one still open remains.
        assert server.counters()["connections"] == 1
        await server.stop()

    run(body)
