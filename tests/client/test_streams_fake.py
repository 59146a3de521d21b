"""A push subscription against a scripted fake server: what the client answers, frame by frame.

The fake accepts one connection, checks the `Receive` frame, then sends DATASAMPLE requests
(good, malformed, with a `dropped` slot) and records each answer, as the contract's server would
(STREAMS.md section 2, continuous push).
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from dataclasses import replace

from client_helpers import wire
from streams_support import run

from openair.client import Module
from openair.protocol.codec import from_frame
from openair.protocol.datasample import DataSample, encode_chunk
from openair.protocol.framing import Frame, FrameLimits, FrameReader, FrameTag
from openair.protocol.message import Message

Script = Callable[[asyncio.StreamReader, asyncio.StreamWriter], Awaitable[None]]


async def next_frame(reader: asyncio.StreamReader, frames: FrameReader) -> Frame:
    while (frame := frames.next_frame()) is None:
        data = await reader.read(65536)
        assert data, "the client closed the connection"
        frames.feed(data)
    return frame


def push(sample_chunk: bytes, *, dropped: int | None = None, id_: str = "") -> Message:
    msg = Message(
        type="DATASAMPLE",
        sender="Audio",
        to="Ears",
        content="<datasample/>",
        content_is_xml=True,
        language="xml",
        binary=(sample_chunk,),
    )
    msg = replace(msg, id=id_) if id_ else msg
    return msg if dropped is None else msg.with_extra("dropped", str(dropped))


class Fake:
    """A one-connection server running `script`; `done()` re-raises what the script raised."""

    def __init__(self, script: Script) -> None:
        self._script = script
        self._outcome: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self.server: asyncio.Server | None = None

    async def start(self) -> int:
        self.server = await asyncio.start_server(self._serve, "127.0.0.1", 0)
        return int(self.server.sockets[0].getsockname()[1])

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            await self._script(reader, writer)
        except BaseException as exc:
            self._outcome.set_exception(exc)
        else:
            self._outcome.set_result(None)

    async def done(self) -> None:
        await self._outcome
        assert self.server is not None
        self.server.close()
        await self.server.wait_closed()


def test_client_acknowledges_good_samples_and_refuses_bad_ones() -> None:
    answers: list[Message] = []
    notes: list[tuple[FrameTag, Message]] = []

    async def script(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        frames = FrameReader(FrameLimits())
        note = await next_frame(reader, frames)
        notes.append((note.tag, from_frame(note)))
        good = encode_chunk(DataSample(payload=b"pcm", params=(("builtin:id", "1"),)))
        later = encode_chunk(DataSample(payload=b"more", params=(("builtin:id", "5"),)))
        for msg in (push(good), push(b"\x09\x00\x00\x00ab\x00"), push(later, dropped=3)):
            writer.write(wire(msg))
            await writer.drain()
            answers.append(from_frame(await next_frame(reader, frames)))
        writer.close()

    async def scenario() -> None:
        fake = Fake(script)
        ears = Module("Ears", port=await fake.start())  # not connected: the push connection
        sub = ears.subscribe_stream("Input.Audio.Perception", confirm=False)
        try:
            got = [s async for s in sub]  # ends when the fake closes the connection
        finally:
            await ears.close()
        await fake.done()
        assert [(s.stream, s.sample.id, s.dropped) for s in got] == [
            ("Audio", 1, 0),
            ("Audio", 5, 3),
        ]
        assert (sub.received, sub.dropped) == (2, 3)

    run(scenario)
    ((tag, note),) = notes
    assert tag is FrameTag.RECEIVE and note.type == "RECEIVE_NAME_NOTIFICATION"
    assert (note.sender, note.to) == ("Ears", "Input.Audio.Perception")
    assert [a.type for a in answers] == ["RECEIVE_ACCEPT", "RECEIVE_ERROR", "RECEIVE_ACCEPT"]
    assert answers[1].content.startswith("SAMPLE_INVALID:")  # OA-STREAM-10


def test_acknowledgement_waits_for_room_in_the_buffer() -> None:
    acked: list[str] = []
    consumed, first_acked = asyncio.Event(), asyncio.Event()

    async def script(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        frames = FrameReader(FrameLimits())
        await next_frame(reader, frames)
        for i in (1, 2):  # both at once: the second finds the one-sample buffer full
            chunk = encode_chunk(DataSample(payload=bytes([i]), params=(("builtin:id", str(i)),)))
            writer.write(wire(push(chunk, id_=f"push-{i}")))
        await writer.drain()
        acked.append(from_frame(await next_frame(reader, frames)).isresponse)
        first_acked.set()
        acked.append(from_frame(await next_frame(reader, frames)).isresponse)
        assert consumed.is_set()  # the second was held back until the consumer made room
        writer.close()

    async def scenario() -> None:
        fake = Fake(script)
        ears = Module("Ears", port=await fake.start())
        sub = ears.subscribe_stream("Audio", buffer=1, confirm=False)
        try:
            await sub.open()
            await first_acked.wait()  # the first sample fits in the buffer: acknowledged
            consumed.set()  # set before taking: no acknowledgement can come earlier
            first = await sub.next()
            second = await sub.next()
        finally:
            await ears.close()
        await fake.done()
        assert [s.sample.id for s in (first, second) if s is not None] == [1, 2]

    run(scenario)
    assert acked == ["push-1", "push-2"]
