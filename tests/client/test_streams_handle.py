"""StreamHandle against the reference server: write, read, wait, search, lock (spec 11)."""

from __future__ import annotations

import asyncio

import pytest
from streams_support import module, run, server

from openair.client.streams import StreamHandle
from openair.protocol.datasample import DataSample
from openair.protocol.errors import (
    ApiMisuseError,
    ConnectionClosedError,
    LockUnknownError,
    SampleInvalidError,
    SampleUnknownError,
    StreamUnknownError,
)
from openair.protocol.times import AirTime
from openair.server.aio.app import DEFAULT_EXTENSIONS, ServerOptions, start_server


def payloads(samples: list[DataSample]) -> list[bytes]:
    return [bytes(s.payload) for s in samples]


def test_add_then_read_back_by_id_newest_and_oldest() -> None:
    async def scenario() -> None:
        async with server() as port, module("Writer", port) as writer:
            stream = writer.stream("Stream1")
            first = await stream.add(b"one", {"k": "v"}, timestamp_ms=5000, seq=1)
            second = await stream.add(memoryview(b"two"))
            assert (first, second) == (1, 2)  # OA-STREAM-4: ids from 1, one up per sample
            got = await stream.get(1)
            assert bytes(got.payload) == b"one" and got.param("k") == "v"
            assert (got.id, got.timestamp_ms, got.seq) == (1, 5000, 1)
            assert (await stream.newest()).id == 2 and (await stream.oldest()).id == 1
            assert (await stream.count(), await stream.size()) == (2, 6)
            assert await stream.name() == "Stream1" == stream.stream_name
            info = await stream.info()
            assert (info.name, info.whiteboard, info.count, info.newest) == ("Stream1", "WB1", 2, 2)
            assert writer.stream("Stream1") is stream  # one handle per target

    run(scenario)


def test_add_many_and_all_or_none() -> None:
    async def scenario() -> None:
        async with server() as port, module("Writer", port) as writer:
            stream = writer.stream("Stream1")
            ids = await stream.add_many([b"a", b"bb", DataSample(payload=b"ccc")], seq=10)
            assert ids == [1, 2, 3]
            assert [(await stream.get(i)).seq for i in ids] == [10, 11, 12]
            tiny = writer.stream("Tiny")  # maxsize 0.0001 MiB = 104 bytes
            with pytest.raises(SampleInvalidError):
                await tiny.add_many([b"ok", b"x" * 200])  # OA-STREAM-5: none is added
            assert await tiny.count() == 0
            with pytest.raises(SampleInvalidError):
                await tiny.add(b"x" * 200)
            assert await tiny.add(b"fits") == 1

    run(scenario)


def test_binary_frames_and_noreply_writes() -> None:
    async def scenario() -> None:
        async with server() as port, module("Writer", port) as writer:
            assert "noreply" in writer.extensions
            stream = writer.stream("Stream2")
            # The first request of a fresh handle is BinaryM: its connection names the stream
            # first (GET_NAME), so the frame has a current stream (OA-STREAM-11).
            assert await stream.add_binary(b"raw", {"who": "me"}, seq=1) == 1
            assert await stream.add(b"quiet", noreply=True) is None
            assert await stream.add_many([b"q1", b"q2"], noreply=True) == []
            # Same connection, so processed in order: the noreply samples are there.
            assert await stream.count() == 4
            raw = await stream.get(1)
            assert bytes(raw.payload) == b"raw" and raw.param("who") == "me"
            assert payloads([await stream.get(i) for i in (2, 3, 4)]) == [
                b"quiet",
                b"q1",
                b"q2",
            ]

    run(scenario)


def test_time_queries() -> None:
    async def scenario() -> None:
        async with server() as port, module("Writer", port) as writer:
            stream = writer.stream("Stream1")
            for ms in (1000, 2000, 3000):
                await stream.add(str(ms).encode(), timestamp_ms=ms)
            assert bytes((await stream.at(2500)).payload) == b"2000"
            assert bytes((await stream.at(AirTime(sec=3))).payload) == b"3000"
            between = await stream.between(1500, 3000)  # inclusive bounds
            assert payloads(between) == [b"2000", b"3000"]
            assert await stream.between(4000, 5000) == []
            assert (await stream.oldest_timestamp(), await stream.newest_timestamp()) == (
                1000,
                3000,
            )
            with pytest.raises(SampleUnknownError):
                await stream.at(999)

    run(scenario)


def test_failures_raise_the_named_condition() -> None:
    async def scenario() -> None:
        async with server() as port, module("Reader", port) as reader:
            with pytest.raises(SampleUnknownError):
                await reader.stream("Stream1").get(99)
            with pytest.raises(SampleUnknownError):
                await reader.stream("Stream1").newest()
            with pytest.raises(StreamUnknownError):
                await reader.stream("NoSuchStream").count()
            with pytest.raises(ApiMisuseError):
                StreamHandle(reader, "")

    run(scenario)


def test_waits_answer_at_once_later_or_time_out() -> None:
    async def scenario() -> None:
        async with server() as port, module("Writer", port) as writer:
            stream = writer.stream("Stream1")
            for ms in (1000, 2000, 3000):
                await stream.add(str(ms).encode(), timestamp_ms=ms)
            assert (await stream.wait_after_id(1, 100)).id == 2  # type: ignore[union-attr]
            assert (await stream.wait_after_id(1, 100, last=True)).id == 3  # type: ignore[union-attr]
            assert (await stream.wait_sample(1500, 100)).id == 2  # type: ignore[union-attr]
            assert (await stream.wait_sample(1500, 100, last=True)).id == 3  # type: ignore[union-attr]
            assert await stream.wait_after_id(3, 0) is None  # OA-STREAM-7: the timeout passed
            assert await stream.wait_sample(AirTime(sec=9), 1) is None

    run(scenario)


def test_a_pending_wait_does_not_block_the_handle() -> None:
    async def scenario() -> None:
        async with server() as port, module("Writer", port) as writer:
            stream = writer.stream("Stream1")
            waiting = asyncio.ensure_future(stream.wait_after_id(0, 20_000))
            assert await stream.count() == 0  # answered while the wait is pending
            assert not waiting.done()
            new_id = await stream.add(b"wake")
            woken = await waiting
            assert woken is not None and woken.id == new_id and bytes(woken.payload) == b"wake"
            # Waits run in parallel, each on its own connection.
            both = [stream.wait_after_id(1, 20_000) for _ in range(2)]
            pending = asyncio.gather(*both)
            await stream.add(b"second")
            assert [s.id for s in await pending if s is not None] == [2, 2]

    run(scenario)


@pytest.mark.parametrize("turns", [0, 1, 50])
def test_closing_the_module_ends_a_pending_wait(turns: int) -> None:
    async def scenario() -> None:
        async with server() as port:
            writer = module("Writer", port)
            await writer.connect()
            waiting = asyncio.ensure_future(writer.stream("Stream1").wait_after_id(0, 30_000))
            for _ in range(turns):  # close at different points of the wait's start
                await asyncio.sleep(0)
            await writer.close()
            with pytest.raises(ConnectionClosedError):
                await waiting

    run(scenario)


def test_typed_stream_by_type_search_and_list() -> None:
    async def scenario() -> None:
        async with server() as port, module("Writer", port) as writer:
            audio = writer.stream("Input.Audio.Perception")  # OA-XSTREAM-1: by type
            assert await audio.name() == "Audio"
            for i in range(1, 6):
                await audio.add(bytes([i]), {"speaker": f"p{i % 2}"}, timestamp_ms=i * 1000)
            found = await audio.search(params={"speaker": "p1"})
            assert payloads(found) == [b"\x01", b"\x03", b"\x05"]
            assert payloads(await audio.search(params={"speaker": "p*"}, latest=2)) == [
                b"\x04",
                b"\x05",
            ]
            ranged = await audio.search(after=2000, until=AirTime(sec=4))
            assert [s.timestamp_ms for s in ranged] == [2000, 3000, 4000]
            listed = await writer.list_streams()
            assert [(i.name, i.type) for i in listed] == [
                ("Stream1", ""),
                ("Audio", "Input.Audio.Perception"),
                ("Ring", "Test.Stream.Ring"),
                ("Tiny", ""),
                ("Stream2", ""),
            ]  # OA-STREAM-16: configuration order
            assert listed[1].count == 5

    run(scenario)


def test_locked_samples_survive_the_soft_limit() -> None:
    async def scenario() -> None:
        async with server() as port, module("Writer", port) as a, module("Other", port) as b:
            ring = a.stream("Ring")  # softcount 3, hardcount 5
            for i in range(1, 4):
                await ring.add(bytes([i]))
            async with ring.lock(1, 3) as lock:
                assert (await ring.info()).locked == 3
                with pytest.raises(LockUnknownError):
                    await b.stream("Ring").unlock(lock.lock_id)  # a foreign lock (OA-XSTREAM-5)
                await ring.add(b"\x04")  # above the soft limit: only unlocked samples go
                assert [(await ring.get(i)).id for i in (1, 2, 3)] == [1, 2, 3]
            assert lock.released and (await ring.info()).locked == 0
            await ring.add(b"\x05")
            with pytest.raises(SampleUnknownError):
                await ring.get(1)  # unlocked, so the oldest went
            lock2 = await ring.lock(0, 0)  # an empty range still gets a lock id
            await lock2.unlock()
            await lock2.unlock()  # released once; a second call does nothing
            with pytest.raises(LockUnknownError):
                await ring.unlock(lock2.lock_id)

    run(scenario)


def test_typed_commands_need_the_extension() -> None:
    async def scenario() -> None:
        options = ServerOptions(
            host="127.0.0.1",
            port=0,
            monitor=False,
            extensions=DEFAULT_EXTENSIONS - {"typed-streams"},
        )
        srv = await start_server(options)
        try:
            async with module("Writer", srv.port) as writer:
                stream = writer.stream("Stream1")
                with pytest.raises(ApiMisuseError):
                    await stream.search()  # OA-GEN-2: never sent to this server
                with pytest.raises(ApiMisuseError):
                    await stream.lock(1, 2)
                assert await stream.add(b"core") == 1
        finally:
            await srv.stop()

    run(scenario)


def test_received_payload_is_relayed_without_copy() -> None:
    async def scenario() -> None:
        async with server() as port, module("Relay", port) as relay:
            source, sink = relay.stream("Stream1"), relay.stream("Stream2")
            await source.add(bytes(range(256)) * 64, {"builtin:type": "raw"})
            got = await source.get(1)
            assert isinstance(got.payload, memoryview)
            await sink.add(got)  # the view itself is written, its params kept
            copied = await sink.get(1)
            assert copied.payload == got.payload and copied.param("builtin:type") == "raw"

    run(scenario)
