"""Push subscriptions and alarm subscriptions against the reference server (spec 11.6, 11.7)."""

from __future__ import annotations

import itertools

import pytest
from streams_support import module, run, server

from openair.client.stream_wire import ReceivedSample
from openair.protocol.errors import ApiMisuseError, StreamUnknownError


def test_push_subscriber_gets_every_new_sample_in_order() -> None:
    async def scenario() -> None:
        async with server() as port, module("Reader", port) as reader, module("W", port) as w:
            stream = w.stream("Stream1")
            await stream.add(b"before")  # added before the subscription: not pushed
            async with reader.subscribe_stream("Stream1") as sub:
                assert (await stream.info()).subscribers == 1
                for i in range(5):
                    await stream.add(bytes([i]), {"n": str(i)})
                got = [await sub.next() for _ in range(5)]
            assert [g.sample.id for g in got if g is not None] == [2, 3, 4, 5, 6]
            assert all(g is not None and g.stream == "Stream1" and g.dropped == 0 for g in got)
            assert [bytes(g.sample.payload) for g in got if g is not None] == [
                bytes([i]) for i in range(5)
            ]
            assert (sub.received, sub.dropped) == (5, 0)

    run(scenario)


def test_subscribe_by_type_names_the_stream() -> None:
    async def scenario() -> None:
        async with server() as port, module("Reader", port) as reader, module("W", port) as w:
            async with reader.subscribe_stream("Input.Audio.Perception") as sub:
                await w.stream("Audio").add(b"pcm")
                got = await sub.next()
            assert got is not None and got.stream == "Audio" and bytes(got.sample.payload) == b"pcm"

    run(scenario)


def test_unknown_stream_is_refused() -> None:
    async def scenario() -> None:
        async with server() as port, module("Reader", port) as reader:
            refused = reader.subscribe_stream("NoSuchStream")
            with pytest.raises(StreamUnknownError):
                await refused.open()
            assert [s async for s in refused] == []  # ended, not waiting forever
            # Without confirmation the refusal arrives on the push connection itself.
            sub = reader.subscribe_stream("NoSuchStream", confirm=False)
            with pytest.raises(StreamUnknownError):
                async for _ in sub:
                    pass
            with pytest.raises(ApiMisuseError):
                reader.subscribe_stream("Stream1", buffer=0)

    run(scenario)


def test_a_slow_subscriber_loses_the_oldest_and_is_told() -> None:
    async def scenario() -> None:
        limits = {"stream_push_buffer": 2}
        async with (
            server(**limits) as port,
            module("Slow", port) as slow,
            module("Fast", port) as fast,
            module("W", port) as w,
        ):
            stream = w.stream("Stream1")
            async with (
                slow.subscribe_stream("Stream1", buffer=1) as lagging,
                fast.subscribe_stream("Stream1") as keeping_up,
            ):
                for i in range(1, 13):
                    await stream.add(bytes([i]))
                # OA-STREAM-12: the slow reader does not hold the other one back.
                fast_got = [await keeping_up.next() for _ in range(12)]
                assert [g.sample.id for g in fast_got if g is not None] == list(range(1, 13))
                slow_got: list[ReceivedSample] = []
                while not slow_got or slow_got[-1].sample.id != 12:
                    got = await lagging.next()
                    assert got is not None
                    slow_got.append(got)
            ids = [g.sample.id or 0 for g in slow_got]
            assert ids == sorted(ids) and len(set(ids)) == len(ids)  # OA-STREAM-8: in id order
            dropped = sum(g.dropped for g in slow_got)
            assert dropped > 0 and len(slow_got) + dropped == 12  # every sample accounted for
            assert lagging.dropped == dropped
            for before, after in itertools.pairwise(slow_got):
                assert (after.sample.id or 0) - (before.sample.id or 0) == 1 + after.dropped

    run(scenario)


def test_a_pipelined_subscription_gets_every_sample() -> None:
    async def scenario() -> None:
        async with server() as port, module("Reader", port) as reader, module("W", port) as w:
            stream = w.stream("Stream1")
            async with reader.subscribe_stream("Stream1", pipelining=True) as sub:
                ids = [await stream.submit(bytes([i])) for i in range(50)]  # pipelined writes
                written = [await f for f in ids]
                got = [await sub.next() for _ in range(50)]
            assert [g.sample.id for g in got if g is not None] == written

    run(scenario)


def test_closing_ends_the_iteration_after_buffered_samples() -> None:
    async def scenario() -> None:
        async with server() as port, module("Reader", port) as reader, module("W", port) as w:
            sub = reader.subscribe_stream("Stream2")
            await sub.open()
            await w.stream("Stream2").add(b"last")
            first = await sub.next()
            await sub.close()
            assert first is not None and bytes(first.sample.payload) == b"last"
            assert [s async for s in sub] == []
            assert await sub.next() is None

    run(scenario)


def test_module_close_closes_its_subscriptions() -> None:
    async def scenario() -> None:
        async with server() as port, module("W", port) as w:
            reader = module("Reader", port)
            await reader.connect()
            sub = reader.subscribe_stream("Stream1")
            await sub.open()
            assert sub.active
            await reader.close()
            assert not sub.active
            assert [s async for s in sub] == []
            assert (await w.stream("Stream1").count()) == 0

    run(scenario)


def test_alarms_yield_parsed_alarms() -> None:
    async def scenario() -> None:
        async with server() as port, module("Watcher", port) as watcher, module("W", port) as w:
            await watcher.subscribe("Some.Other.Type")
            ring = w.stream("Test.Stream.Ring")  # softcount 3
            async with watcher.alarms() as alarms:
                for seq in (1, 2, 3, 4, 7):
                    await ring.add(b"s", seq=seq)
                seen = [await alarms.next() for _ in range(3)]
            kinds = [a.kind for a in seen if a is not None]
            assert kinds == ["Started", "SoftLimit", "Gap"]  # OA-XSTREAM-7, -2, -8
            started, soft, gap = (a for a in seen if a is not None)
            assert started.stream == "Ring" and started.entries["streamtype"] == "Test.Stream.Ring"
            assert (soft.entries["count"], soft.entries["dropped"]) == ("3", "1")
            assert (gap.entries["expected"], gap.entries["received"]) == ("5", "7")
            assert gap.message is not None and gap.message.sender == "Ring"
            # The companion module registered the trigger; the caller's own is unchanged.
            assert watcher.registration is not None
            assert [t.pattern for t in watcher.registration.triggers] == ["Some.Other.Type"]

    run(scenario)


def test_alarm_pattern_selects_kinds() -> None:
    async def scenario() -> None:
        async with server() as port, module("Watcher", port) as watcher, module("W", port) as w:
            async with watcher.alarms("AIR.Stream.Alarm.Gap") as gaps:
                ring = w.stream("Ring")
                for seq in (1, 3):
                    await ring.add(b"s", seq=seq)
                gap = await gaps.next()
            assert gap is not None and gap.kind == "Gap" and gap.entries["writer"] == "W"

    run(scenario)
