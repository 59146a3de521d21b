"""Record a reference server, replay into another, retrieve: the same messages and samples."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

from openair.client import Module
from openair.protocol.content import RetrieveSpec
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.server.aio.app import DEFAULT_EXTENSIONS, ServerOptions, start_server
from openair.server.core.config import parse_config
from openair_recording import (
    Header,
    MessageRecord,
    Recorder,
    RecordingReader,
    RecordOptions,
    Replayer,
    ReplayOptions,
    SampleRecord,
    plan,
    read_index,
)
from openair_recording.replay import ORIGINAL_POSTED_SLOT, ORIGINAL_TIMESTAMP_PARAM

TIMEOUT = 30.0
NO_STREAMS = b"""<psySpec name="Target" version="1.2">
  <whiteboard name="AIRCentral"/><whiteboard name="WB1"/><whiteboard name="WB2"/>
</psySpec>"""


def run(test: Callable[[], Awaitable[None]]) -> None:
    async def bounded() -> None:
        await asyncio.wait_for(test(), TIMEOUT)

    asyncio.run(bounded())


@asynccontextmanager
async def server(**options: Any) -> AsyncIterator[int]:
    srv = await start_server(ServerOptions(host="127.0.0.1", port=0, **options))
    try:
        yield srv.port
    finally:
        await srv.stop()


def target_config() -> Any:
    return parse_config(NO_STREAMS, source="test")


async def post_traffic(port: int) -> list[Message]:
    """Post messages with every kind of slot, and one stream sample; return the posts."""
    async with Module("Writer", port=port, keepalive=None, announce=False) as w:
        sent = [
            await w.post("WB1", "Rec.A", "first", priority=0.5, binary=[b"\x00\x01", b""]),
            await w.post("WB2", "Rec.B", "<x a='1'>y</x>", content_is_xml=True, cc="Nobody"),
            await w.post("WB1", "Rec.C", "(lisp)", language="LISP", version="CL", priority=6.5),
            await w.post("WB1", "Rec.D", "", binary=[bytes(range(256)) * 40]),
            await w.post("WB1", "Other.E", "not recorded"),
        ]
        await w.stream("Stream1").add(b"\xff\xd8payload\x00", {"rate": "16000"})
        return sent


async def record_source(path: Path) -> tuple[list[Message], list[Message]]:
    """Record the traffic; return the posts and the source's stored copies, oldest first."""
    async with server() as port:
        recorder = Recorder("127.0.0.1", port, path, RecordOptions(types="Rec.*"))
        await recorder.start()
        try:
            sent = await post_traffic(port)
            await recorder.wait_for(messages=4, samples=1)
        finally:
            await recorder.stop()
        stored = await retrieve_all(port)
    return sent, stored


async def retrieve_all(port: int) -> list[Message]:
    async with Module("Reader", port=port, bind=False, keepalive=None) as r:
        out: list[Message] = []
        for wb in ("WB1", "WB2"):
            out += await r.retrieve(RetrieveSpec(whiteboard=wb, pattern="Rec.*", latest=0))
    return sorted(out, key=lambda m: (m.stored, m.wbid or 0))


def same(m: Message) -> tuple[object, ...]:
    return (
        m.stored, m.type, m.sender, m.cc, m.priority, m.content, m.content_is_xml,
        m.language, m.content_version, m.binary,
    )  # fmt: skip


def test_record_replay_retrieve_gives_the_same_messages(tmp_path: Path) -> None:
    path = tmp_path / "rec.oair"

    async def body() -> None:
        sent, stored = await record_source(path)
        reader = RecordingReader.open(path)
        records = list(reader.records())
        assert reader.complete and reader.warnings == []
        assert reader.header.types == "Rec.*" and "WB1" in reader.header.whiteboards
        messages = [r.message for r in records if isinstance(r, MessageRecord)]
        assert sorted(map(same, messages)) == sorted(map(same, stored))
        assert all(m.posted is not None and m.received is not None for m in messages)
        index = read_index(path)
        assert index is not None and [e.offset for e in index[1:]] == [r.offset for r in records]
        async with server(config=target_config()) as port:
            async with Module("Replayer", port=port, bind=False, keepalive=None) as m:
                replayer = Replayer(m, reader.header)
                await replayer.run(plan(records, ReplayOptions(speed=0)))
                assert replayer.posted == 4 and replayer.added == 1, replayer.notes
                got = list(await m.stream("Stream1").between(0, 2**62))
            replayed = await retrieve_all(port)
        assert [same(m) for m in replayed] == [same(m) for m in stored]
        originals = {m.type: str(m.posted) for m in sent}
        for copy in replayed:
            slot = copy.extra(ORIGINAL_POSTED_SLOT)
            assert slot is not None and slot.value == originals[copy.type]  # OA-MSG-5, OA-WB-4
        assert len(got) == 1 and bytes(got[0].payload) == b"\xff\xd8payload\x00"
        assert got[0].param("rate") == "16000"
        sample = next(r for r in records if isinstance(r, SampleRecord))
        assert got[0].param(ORIGINAL_TIMESTAMP_PARAM) == str(sample.sample.timestamp_ms)

    run(body)


def test_samples_are_skipped_with_a_note_when_the_server_cannot_create_streams(
    tmp_path: Path,
) -> None:
    path = tmp_path / "rec.oair"

    async def body() -> None:
        await record_source(path)
        reader = RecordingReader.open(path)
        records = list(reader.records())
        legacy = DEFAULT_EXTENSIONS - {"typed-streams"}
        async with (
            server(config=target_config(), extensions=legacy) as port,
            Module("Replayer", port=port, bind=False, keepalive=None) as m,
        ):
            replayer = Replayer(m, reader.header)
            await replayer.run(plan(records, ReplayOptions(speed=0)))
        assert replayer.posted == 4 and replayer.added == 0
        assert any("Stream1" in n and "skipped" in n for n in replayer.notes)

    run(body)


def stored_copy(wb: str, wbid: int, type_: str, at_ms: int, priority: float) -> MessageRecord:
    msg = Message(
        type=type_, sender="Orig", to=wb, stored=wb, wbid=wbid, priority=priority,
        posted=AirTime.from_ms(at_ms - 1), received=AirTime.from_ms(at_ms), content=type_,
    )  # fmt: skip
    return MessageRecord(message=msg, captured_ns=at_ms * 1_000_000)


def test_replay_sleeps_the_scaled_gaps_in_order() -> None:
    """The fake sleep gets the gaps / speed; the target stores the posts in replay order."""
    base = 1_800_000_000_000
    records = [  # file order differs from time order on WB1 (a priority overtook)
        stored_copy("WB1", 2, "Gap.B", base + 1000, 0.5),
        stored_copy("WB1", 1, "Gap.A", base, 3.0),
        stored_copy("WB2", 1, "Gap.C", base + 1500, 2.0),
        stored_copy("WB1", 3, "Gap.D", base + 3500, 2.0),
    ]
    slept: list[float] = []

    async def fake_sleep(seconds: float) -> None:
        slept.append(seconds)

    async def body() -> None:
        steps = plan(records, ReplayOptions(speed=2.0))
        assert [s.record.message.type for s in steps if isinstance(s.record, MessageRecord)] == [
            "Gap.A", "Gap.B", "Gap.C", "Gap.D"
        ]  # fmt: skip
        async with (
            server(config=target_config()) as port,
            Module("Replayer", port=port, bind=False, keepalive=None) as m,
        ):
            await Replayer(m, Header(), sleep=fake_sleep).run(steps)
            found = await m.retrieve(RetrieveSpec(whiteboard="WB1", pattern="Gap.*", latest=0))
        assert [f.type for f in found] == ["Gap.D", "Gap.B", "Gap.A"]  # newest first
        assert [f.priority for f in found] == [2.0, 0.5, 3.0]

    run(body)
    assert slept == [0.5, 0.25, 1.0]  # gaps 1 s, 0.5 s, 2 s at speed 2
