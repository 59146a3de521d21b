"""Streams through the server adapter on loopback sockets (spec 11): waits, push, BinaryM,
subscriptions by registration, alarms, and what a connection's end releases.

The wire format and every command's answers are checked by the conformance suite (cases
STREAM-*); these tests cover what only the adapter does: deferred replies that hold a
connection, per-subscriber buffers, delivery through a module's path, timers.
"""

from __future__ import annotations

import asyncio

from server_io_helpers import BOUND, Raw, TestModule, run, serving

from openair.protocol.datasample import DataSample, decode_chunk, encode_chunk
from openair.protocol.framing import Frame, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.server.aio.app import ServerOptions
from openair.server.core.config import ServerLimits


def add(stream: str, payload: bytes, sender: str = "Writer", seq: int | None = None) -> Message:
    params = (("builtin:seq", str(seq)),) if seq is not None else ()
    sample = DataSample(payload=payload, params=params)
    return Message(
        type="ADD_SAMPLE",
        to=stream,
        sender=sender,
        content="<datasample/>",
        content_is_xml=True,
        language="xml",
        binary=(encode_chunk(sample),),
    )


def command(kind: str, stream: str = "Stream1", content: str = "", xml: bool = False) -> Message:
    return Message(
        type=kind,
        to=stream,
        sender="Reader",
        content=content,
        content_is_xml=xml,
        language="xml" if xml else "",
    )


def sample_of(msg: Message) -> DataSample:
    assert msg.type == "DATASAMPLE", msg
    assert len(msg.binary) == 1
    return decode_chunk(msg.binary[0])


async def newest_id(raw: Raw, stream: str = "Stream1") -> int:
    reply = await raw.request(command("GET_NEWEST_DATASAMPLE", stream))
    if reply.type != "DATASAMPLE":
        return 0
    ident = sample_of(reply).id
    assert ident is not None
    return ident


def test_a_wait_holds_later_requests_on_its_connection_until_a_sample_arrives() -> None:
    async def body() -> None:
        server = await serving()
        reader, writer = await Raw.open(server.port), await Raw.open(server.port)
        last = await newest_id(reader)
        reader.send(command("WAIT_FOR_FIRST_AFTERID 20000", content=str(last)))
        reader.send(Message(type="PING", to="CNS", sender="Reader"))
        await writer.ping()  # the wait and the PING have reached the server
        ack = await writer.request(add("Stream1", b"first", seq=1))
        assert ack.type == "DATA_ACCEPTED", ack
        first = await reader.recv()  # OA-SESS-2: the deferred reply comes before the PING's
        assert first is not None
        assert bytes(sample_of(first).payload) == b"first"
        assert sample_of(first).id == int(ack.content) == last + 1  # OA-STREAM-4
        second = await reader.recv()
        assert second is not None and second.type == "PING_SUCCESS"
        await reader.close()
        await writer.close()
        await server.stop()

    run(body)


def test_a_wait_times_out_with_sample_unknown_and_the_connection_goes_on() -> None:
    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        last = await newest_id(raw)
        reply = await raw.request(command("WAIT_FOR_LAST_AFTERID 30", content=str(last)))
        assert reply.type == "RECEIVE_ERROR" and reply.content.startswith("SAMPLE_UNKNOWN")
        await raw.ping()
        await raw.close()
        await server.stop()

    run(body)


def test_a_closed_connection_forgets_its_wait_and_shutdown_does_not_hang() -> None:
    async def body() -> None:
        server = await serving()
        raw, other = await Raw.open(server.port), await Raw.open(server.port)
        raw.send(command("WAIT_FOR_FIRST_AFTERID 60000", content="999999999"))
        await raw.close()
        await other.ping()
        ack = await other.request(add("Stream1", b"x"))  # no reply goes to the closed one
        assert ack.type == "DATA_ACCEPTED"
        waiter = await Raw.open(server.port)
        waiter.send(command("WAIT_FOR_FIRST_AFTERID 60000", content="999999999"))
        await other.ping()
        await asyncio.wait_for(server.stop(), BOUND)  # a pending wait does not hold shutdown
        await waiter.close()
        await other.close()

    run(body)


def test_binarym_adds_to_the_current_stream_only() -> None:
    async def body() -> None:
        server = await serving()
        fresh = await Raw.open(server.port)
        chunk = encode_chunk(DataSample(payload=b"\x00\xff" * 10, params=(("k", "v"),)))
        fresh.write(encode_frame(Frame(tag=FrameTag.BINARY, chunks=(chunk,))))
        refused = await fresh.recv()
        assert refused is not None and refused.type == "UNKNOWN_COMMAND"
        assert refused.content == "Offending cmd: BinaryOnly"
        named = await fresh.request(command("GET_NAME", "Stream2"))
        assert named.type == "NAME" and named.content == "Stream2"
        fresh.write(encode_frame(Frame(tag=FrameTag.BINARY, chunks=(chunk,))))
        accepted = await fresh.recv()
        assert accepted is not None and accepted.type == "DATA_ACCEPTED", accepted
        assert accepted.sender == "Stream2"
        got = await fresh.request(command("GET_SAMPLE_BY_ID", "Stream2", accepted.content))
        sample = sample_of(got)
        assert bytes(sample.payload) == b"\x00\xff" * 10 and sample.param("k") == "v"
        await fresh.close()
        await server.stop()

    run(body)


async def _push_reader(port: int, stream: str, name: str) -> Raw:
    raw = await Raw.open(port)
    note = Message(type="RECEIVE_NAME_NOTIFICATION", to=stream, sender=name)
    raw.send(note, FrameTag.RECEIVE)
    return raw


async def _take_push(raw: Raw, *, ack: bool = True) -> Message:
    msg = await raw.recv()
    assert msg is not None and msg.type == "DATASAMPLE", msg
    if ack:
        raw.send(msg.reply("RECEIVE_ACCEPT", sender="reader"))
    return msg


def test_a_slow_push_reader_loses_only_its_own_oldest_samples_and_is_told_how_many() -> None:
    async def body() -> None:
        limits = ServerLimits(stream_push_buffer=5)
        server = await serving(ServerOptions(limits=limits))
        slow = await _push_reader(server.port, "Stream1", "Slow")
        fast = await _push_reader(server.port, "Stream1", "Fast")
        writer = await Raw.open(server.port)
        await writer.ping()
        total = 40
        first = await _take_push_after(writer, slow, fast)
        for n in range(1, total):
            ack = await writer.request(add("Stream1", f"s{n}".encode()))
            assert ack.type == "DATA_ACCEPTED"  # OA-STREAM-12: the writer is never held up
            got = await _take_push(fast)  # the fast reader gets every one, in order
            assert bytes(sample_of(got).payload) == f"s{n}".encode()
            assert got.extra("dropped") is None
        # The slow reader held the first sample unacknowledged all along: 5 stayed buffered.
        slow.send(first.reply("RECEIVE_ACCEPT", sender="Slow"))
        resumed = await _take_push(slow)
        dropped = resumed.extra("dropped")
        assert dropped is not None and int(dropped.value) == total - 1 - 5  # OA-STREAM-8
        assert bytes(sample_of(resumed).payload) == f"s{total - 5}".encode()
        for n in range(total - 4, total):
            got = await _take_push(slow)
            assert bytes(sample_of(got).payload) == f"s{n}".encode()
            assert got.extra("dropped") is None
        for raw in (slow, fast, writer):
            await raw.close()
        await server.stop()

    run(body)


async def _take_push_after(writer: Raw, slow: Raw, fast: Raw) -> Message:
    """Add sample s0; the fast reader acknowledges it, the slow one does not."""
    ack = await writer.request(add("Stream1", b"s0"))
    assert ack.type == "DATA_ACCEPTED"
    await _take_push(fast)
    return await _take_push(slow, ack=False)


def test_push_to_an_unknown_stream_is_refused_and_the_connection_still_answers() -> None:
    async def body() -> None:
        server = await serving()
        raw = await _push_reader(server.port, "NoSuchStream", "Reader")
        refused = await raw.recv()
        assert refused is not None and refused.type == "RECEIVE_ERROR"
        assert refused.content.startswith("STREAM_UNKNOWN")
        await raw.ping()
        await raw.close()
        await server.stop()

    run(body)


REGISTRATION = (
    '<module name="Listener"><spec><context name="Psyclone.System.Ready">'
    '<phase name="Listen"><triggers><trigger from="WB1" type="Input.Perc.*"/></triggers>'
    '<inputstream alias="Ears" source="Input.Audio.*"/></phase></context></spec></module>'
)

AUDIO = '<stream name="Audio" whiteboard="WB1" type="Input.Audio.Perception" softcount="2"/>'


async def _create(raw: Raw, spec: str) -> None:
    msg = Message(
        type="Psyclone.System.Create.Stream",
        to="Psyclone",
        sender="Maker",
        content=spec,
        content_is_xml=True,
        language="xml",
    )
    reply = await raw.request(msg)
    assert reply.type == "RECEIVE_ACCEPT", reply


def test_a_module_receives_messages_and_samples_interleaved_by_its_registration() -> None:
    async def body() -> None:
        server = await serving()
        maker = await Raw.open(server.port)
        await _create(maker, AUDIO)
        module = TestModule("Listener", server.port)
        await module.bind(listen=False)
        await module.subscribe(REGISTRATION)
        for n in range(3):
            post = Message(type="Input.Perc.UniM.Hear.Voice.Speak.Sentence", to="WB1", sender="S")
            assert (await maker.request(post)).type == "RECEIVE_ACCEPT"
            ack = await maker.request(add("Input.Audio.Perception", f"pcm{n}".encode()))
            assert ack.type == "DATA_ACCEPTED" and ack.sender == "Audio"  # OA-XSTREAM-1
        await module.wait_for(3, "DATASAMPLE")
        await module.wait_for(3)
        samples = [m for m in module.received if m.type == "DATASAMPLE"]
        assert [bytes(sample_of(m).payload) for m in samples] == [b"pcm0", b"pcm1", b"pcm2"]
        assert all(m.sender == "Audio" and m.to == "Listener" for m in samples)  # OA-STREAM-14
        await module.close()
        await maker.close()
        await server.stop()

    run(body)


def test_alarms_are_posts_that_modules_subscribe_to() -> None:
    async def body() -> None:
        server = await serving()
        maker = await Raw.open(server.port)
        spec = (
            '<stream name="Cam" whiteboard="WB1" type="Input.Video.Cam" softcount="2" idle="150"/>'
        )
        await _create(maker, spec)
        module = TestModule("Watcher", server.port)
        await module.bind(listen=False)
        await module.subscribe(
            '<triggers><trigger from="WB1" type="AIR.Stream.Alarm.*"/></triggers>'
        )
        for n in (1, 2, 3, 5):
            assert (await maker.request(add("Cam", b"f", seq=n))).type == "DATA_ACCEPTED"
        await module.wait_for(4)  # Started, SoftLimit (once), Gap, then Idle after 150 ms
        kinds = {}
        for wakeup in module.wakeups():
            trigger = wakeup.content
            for kind in ("Started", "SoftLimit", "Gap", "Idle"):
                if f"AIR.Stream.Alarm.{kind}<" in trigger:
                    kinds[kind] = trigger
        assert set(kinds) == {"Started", "SoftLimit", "Gap", "Idle"}, module.wakeups()
        retrieved = await maker.request(
            Message(
                type="AIR.Retrieve",
                to="WB1",
                sender="Maker",
                content='<retrieve type="AIR.Stream.Alarm.Gap"/>',
                content_is_xml=True,
            )
        )
        assert "AIR.Stream.Alarm.Gap" in retrieved.content  # stored like any post (OA-XSTREAM-6)
        await module.close()
        await maker.close()
        await server.stop()

    run(body)


def test_locks_end_with_their_connection() -> None:
    async def body() -> None:
        server = await serving()
        maker = await Raw.open(server.port)
        spec = '<stream name="Held" whiteboard="WB1" type="Test.Held" softcount="1"/>'
        await _create(maker, spec)
        locker = await Raw.open(server.port)
        first = (await maker.request(add("Held", b"a"))).content
        locked = await locker.request(command("LOCK_SAMPLES", "Held", f"{first}-{first}"))
        assert locked.type == "LOCKED", locked
        await maker.request(add("Held", b"b"))  # soft limit 1: the oldest UNLOCKED one goes
        oldest = await maker.request(command("GET_OLDEST_DATASAMPLE", "Held"))
        assert sample_of(oldest).id == int(first)  # OA-XSTREAM-2: the locked one survived
        await locker.close()
        released = False
        for _ in range(200):  # the server sees the close in a later loop turn
            info = await maker.request(command("GET_INFO", "Held"))
            if ' locked="0"' in info.content:
                released = True
                break
            await maker.ping()
        assert released, info.content
        last = (await maker.request(add("Held", b"c"))).content
        oldest = await maker.request(command("GET_OLDEST_DATASAMPLE", "Held"))
        assert sample_of(oldest).id == int(last)  # the lock ended with its connection
        await maker.close()
        await server.stop()

    run(body)


def test_get_streams_lists_the_default_streams() -> None:
    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        reply = await raw.request(Message(type="GET_STREAMS", to="", sender="Lister"))
        assert reply.type == "STREAMS", reply
        assert 'name="Stream1"' in reply.content and 'name="Stream2"' in reply.content
        assert 'whiteboard="WB1"' in reply.content  # OA-STREAM-15, OA-STREAM-16
        await raw.close()
        await server.stop()

    run(body)


def test_a_reader_that_declares_pipelining_gets_samples_before_acknowledging() -> None:
    async def body() -> None:
        server = await serving()
        raw = await Raw.open(server.port)
        note = Message(type="RECEIVE_NAME_NOTIFICATION", to="Stream2", sender="Piped")
        raw.send(note.with_extra("extensions", "pipelining"), FrameTag.RECEIVE)
        legacy = await _push_reader(server.port, "Stream2", "OneByOne")
        writer = await Raw.open(server.port)
        await writer.ping()
        for n in range(5):
            assert (await writer.request(add("Stream2", f"p{n}".encode()))).type == "DATA_ACCEPTED"
        # OA-DELIV-5: with pipelining, all five arrive though none was acknowledged yet.
        got = [await _take_push(raw, ack=False) for _ in range(5)]
        assert [bytes(sample_of(m).payload) for m in got] == [f"p{n}".encode() for n in range(5)]
        first = await _take_push(legacy, ack=False)  # a legacy reader: one at a time
        assert bytes(sample_of(first).payload) == b"p0"
        legacy.send(first.reply("RECEIVE_ACCEPT", sender="OneByOne"))
        second = await _take_push(legacy, ack=False)
        assert bytes(sample_of(second).payload) == b"p1" and second.extra("dropped") is None
        for conn in (raw, legacy, writer):
            await conn.close()
        await server.stop()

    run(body)
