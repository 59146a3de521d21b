"""Streams bounded by bytes and in number (issue #19, OA-LIM-16, OA-LIM-17)."""

from __future__ import annotations

import pytest

from openair.protocol.datasample import DataSample
from openair.protocol.errors import LimitExceededError
from openair.server.core.samplebuffer import SampleBuffer
from openair.server.core.streams import Stream
from openair.server.core.streamservice import StreamService
from openair.server.core.streamspec import StoredSample, StreamSpec

KIB = 1024


def stored(n: int, size: int) -> list[StoredSample]:
    s = Stream(StreamSpec(name="S", whiteboard="W", hardsize=10**9))
    samples = [DataSample(payload=bytes(size))] * n
    return list(s.add(samples, writer="w", received_ns=0).stored)


def test_a_push_buffer_is_bounded_by_payload_bytes() -> None:
    buf = SampleBuffer(100, max_bytes=40 * KIB)
    samples = stored(20, 8 * KIB)
    dropped = sum(buf.offer(x) for x in samples)
    assert buf.bytes <= 40 * KIB and len(buf) == 5  # OA-LIM-16: not 20 of 100
    assert dropped == 15 and buf.dropped_total == 15
    taken = buf.take()
    assert taken == (samples[15], 15)  # the oldest went; the drops are reported once
    assert buf.bytes == 4 * 8 * KIB


def test_a_sample_larger_than_the_push_buffer_bytes_is_still_kept() -> None:
    buf = SampleBuffer(100, max_bytes=KIB)
    big = stored(2, 4 * KIB)
    assert buf.offer(big[0]) == 0 and buf.offer(big[1]) == 1 and len(buf) == 1


def _free(name: str) -> bool:
    return False


def _service(**bounds: int) -> StreamService:
    return StreamService((), typed=True, noreply=True, max_wait_ms=1000, **bounds)


def test_streams_created_at_run_time_are_bounded_in_number() -> None:
    service = _service(max_created=2, max_created_bytes=64 << 20)
    for name in ("A", "B"):
        service.create(
            f'<stream name="{name}" whiteboard="WB1"/>', whiteboards=["WB1"], taken=_free
        )
    with pytest.raises(LimitExceededError, match="max-created-streams is 2"):  # OA-LIM-17
        service.create('<stream name="C" whiteboard="WB1"/>', whiteboards=["WB1"], taken=_free)
    assert set(service.names()) == {"A", "B"}


def test_a_stream_created_at_run_time_is_bounded_in_size() -> None:
    service = _service(max_created=10, max_created_bytes=64 << 20)
    huge = '<stream name="Huge" whiteboard="WB1" maxsize="100000"/>'  # 100 000 MiB
    with pytest.raises(LimitExceededError, match="max-created-stream-bytes"):  # OA-LIM-17
        service.create(huge, whiteboards=["WB1"], taken=_free)
    fits = '<stream name="Fits" whiteboard="WB1" maxsize="64"/>'
    assert service.create(fits, whiteboards=["WB1"], taken=_free) == "Fits"
