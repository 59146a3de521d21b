"""A delivery the module cannot read is never lost silently: counted and logged (OA-MSG-20).

The module's delivery side is driven over a real loopback connection to its listening port, as
a legacy server would: each frame is answered before the next is sent, so the answers are the
synchronisation. The wakeups are in Psyclone's layout (spec/vectors/legacy), and the one whose
stored copy carries Psyclone's `priority="7.00"` must be delivered, not dropped (OA-MSG-19).
"""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path

import pytest

from openair.client import Module
from openair.protocol.codec import from_frame
from openair.protocol.framing import Frame as WireFrame
from openair.protocol.framing import FrameLimits, FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message

LEGACY = Path(__file__).resolve().parents[2] / "spec" / "vectors" / "legacy"
BARRIER = (LEGACY / "psy2-cc003-barrier-wakeup.xml").read_bytes()


def _frame(xml: bytes) -> bytes:
    return encode_frame(WireFrame(tag=FrameTag.MESSAGE, xml=xml))


async def _answer(reader: asyncio.StreamReader, frames: FrameReader) -> Message:
    while (frame := frames.next_frame()) is None:
        data = await reader.read(65536)
        assert data, "the module closed the connection without answering"
        frames.feed(data)
    return from_frame(frame)


async def _deliver(mod: Module, payloads: list[bytes]) -> list[str]:
    """Connect to the module's listening port, send each frame, return the answer types."""
    port = await mod._listener.listen("127.0.0.1", 0)
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    frames = FrameReader(FrameLimits())
    answers = []
    try:
        for payload in payloads:
            writer.write(_frame(payload))
            await writer.drain()
            answers.append((await _answer(reader, frames)).type)
    finally:
        writer.close()
        await mod._listener.close()
    return answers


def test_a_psyclone_barrier_wakeup_is_delivered() -> None:
    async def run() -> tuple[Module, list[str]]:
        mod = Module("C6e5f_CC003_A", keepalive=None)
        return mod, await _deliver(mod, [BARRIER])

    mod, answers = asyncio.run(run())
    assert answers == ["RECEIVE_ACCEPT"]
    assert mod.dropped_messages == mod.undecodable_deliveries == 0
    event = mod._wakeups.get_nowait()
    assert event is not None and event.wakeup.trigger is not None
    assert event.wakeup.trigger.priority == 6.999  # Psyclone's 7.00, clamped


@pytest.mark.parametrize(
    ("payload", "reason"),
    [
        (BARRIER.replace(b'priority="7.00"', b'priority="high"'), "priority"),
        (BARRIER.replace(b"<type>Conf.R6e5f", b"<type></type><type>Conf.R6e5f"), "type"),
        (b"<message><type>AIR.Instruct.Wakeup</type><to>M</to", "XML_MALFORMED"),
        (b'<message priority="x"><type>Direct</type></message>', "priority"),
    ],
    ids=["bad-trigger-priority", "bad-trigger-slots", "malformed-xml", "bad-envelope"],
)
def test_an_unreadable_delivery_is_counted_and_logged(
    payload: bytes, reason: str, caplog: pytest.LogCaptureFixture
) -> None:
    async def run() -> tuple[Module, list[str]]:
        mod = Module("M", keepalive=None)
        return mod, await _deliver(mod, [payload, BARRIER])

    with caplog.at_level(logging.WARNING, logger="openair.client"):
        mod, answers = asyncio.run(run())
    assert answers == ["RECEIVE_ERROR", "RECEIVE_ACCEPT"]  # the connection stays usable
    assert mod.undecodable_deliveries == 1
    assert mod.dropped_messages == 1
    dropped = [r.getMessage() for r in caplog.records if "delivery dropped" in r.getMessage()]
    assert len(dropped) == 1 and reason in dropped[0], dropped


def test_a_broken_frame_is_counted_and_logged(caplog: pytest.LogCaptureFixture) -> None:
    async def run() -> Module:
        mod = Module("M", keepalive=None)
        port = await mod._listener.listen("127.0.0.1", 0)
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        writer.write(b"Garbage\x00\x05\x00\x00\x00hello")  # an unknown frame tag closes
        await writer.drain()
        assert await reader.read() == b""  # the module closed the connection
        writer.close()
        await mod._listener.close()
        return mod

    with caplog.at_level(logging.WARNING, logger="openair.client"):
        mod = asyncio.run(run())
    assert mod.undecodable_deliveries == mod.dropped_messages == 1
    assert any("delivery dropped" in r.getMessage() for r in caplog.records)
