"""Issue #5's scenario: one module posts sentences and pushes audio, another receives both.

The poster posts `Input.Perc.UniM.Hear.Voice.Speak.Sentence` messages to WB1 and adds audio
samples to the stream typed `Input.Audio.Perception` (declared in the psySpec of
streams_support.py). The listener's registration holds a trigger on the sentence type and an
`<inputstream>` on the audio stream's type (OA-STREAM-14), so both arrive through its normal
delivery path, as wakeups and as DATASAMPLE messages, interleaved.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

import pytest
from streams_support import module, run, server

from openair.client import Module, WakeupEvent
from openair.client.stream_wire import ReceivedSample
from openair.protocol.content import StreamRef, Trigger

SENTENCE = "Input.Perc.UniM.Hear.Voice.Speak.Sentence"
AUDIO = "Input.Audio.Perception"
CHUNK = 3200  # 100 ms of 16 kHz 16-bit mono audio


@dataclass
class Log:
    """What the listener received, in arrival order, and a way to wait for a total."""

    entries: list[tuple[str, str]]
    changed: asyncio.Event

    def add(self, kind: str, value: str) -> None:
        self.entries.append((kind, value))
        self.changed.set()

    async def until(self, total: int) -> None:
        while len(self.entries) < total:
            self.changed.clear()
            await self.changed.wait()

    def of(self, kind: str) -> list[str]:
        return [value for k, value in self.entries if k == kind]


def listener(port: int, log: Log, **options: object) -> Module:
    async def on_wakeup(event: WakeupEvent) -> None:
        if event.wakeup.trigger is not None:  # phase updates carry no trigger
            log.add("sentence", event.wakeup.trigger.content)

    async def on_sample(got: ReceivedSample) -> None:
        head = bytes(got.sample.payload[:8]).decode()
        log.add("audio", f"{got.stream}/{got.dropped}/{head}")  # stream name, dropped, payload

    return module("Listener", port, on_wakeup=on_wakeup, on_sample=on_sample, **options)


def audio(i: int) -> bytes:
    return f"chunk{i:03d}".encode().ljust(CHUNK, b"\0")


@pytest.mark.parametrize("listen", [True, False], ids=["listening-port", "callback-only"])
def test_sentences_and_audio_arrive_interleaved(listen: bool) -> None:
    async def scenario() -> None:
        log = Log([], asyncio.Event())
        async with (
            server() as port,
            listener(port, log, listen=listen) as ears,
            module("Speaker", port) as speaker,
        ):
            await ears.subscribe(Trigger(pattern=SENTENCE, whiteboard="WB1"), streams=[AUDIO])
            mic = speaker.stream(AUDIO)
            for i in range(5):  # lock step: each arrival before the next send
                await speaker.post("WB1", SENTENCE, f"sentence {i}")
                await log.until(2 * i + 1)
                await mic.add(audio(i), {"builtin:type": "audio/L16"}, seq=i + 1)
                await log.until(2 * i + 2)
            expected = [
                entry for i in range(5) for entry in (("sentence", f"sentence {i}"),
                                                      ("audio", f"Audio/0/chunk{i:03d}"))
            ]  # fmt: skip
            assert log.entries == expected

    run(scenario)


def test_a_burst_of_both_arrives_complete_and_in_order_per_kind() -> None:
    async def scenario() -> None:
        log = Log([], asyncio.Event())
        async with server() as port, listener(port, log) as ears, module("Speaker", port) as spk:
            # A type pattern selects the stream too (OA-STREAM-14, same matcher as triggers).
            sub = StreamRef(kind="inputstream", alias="ears", source="Input.Audio.*")
            await ears.subscribe(SENTENCE, streams=sub)
            mic = spk.stream(AUDIO)
            for i in range(20):
                await spk.post("WB1", SENTENCE, f"sentence {i}", noreply=True)
                await mic.add(audio(i), noreply=True)
            await log.until(40)
            assert log.of("sentence") == [f"sentence {i}" for i in range(20)]
            assert log.of("audio") == [f"Audio/0/chunk{i:03d}" for i in range(20)]

    run(scenario)


def test_samples_iterator_by_stream_name() -> None:
    async def scenario() -> None:
        async with server() as port, module("Ears", port) as ears, module("Spk", port) as spk:
            await ears.subscribe((), streams="Audio")
            assert ears.registration is not None
            assert ears.registration.phases[0].streams == (
                StreamRef(kind="inputstream", alias="Audio", source="Audio"),
            )
            for i in range(3):
                await spk.stream("Audio").add(audio(i), timestamp_ms=1000 + i)
            got = [await ears.next_sample(timeout=None) for _ in range(3)]
            assert [g.sample.timestamp_ms for g in got if g is not None] == [1000, 1001, 1002]
            assert all(g is not None and len(g.sample.payload) == CHUNK for g in got)

    run(scenario)
