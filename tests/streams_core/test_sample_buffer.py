"""The per-subscriber push buffer (OA-STREAM-8): bounded, drop-oldest, drops counted per take."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from openair.protocol.datasample import DataSample
from openair.protocol.errors import ApiMisuseError
from openair.server.core.samplebuffer import SampleBuffer
from openair.server.core.streams import Stream
from openair.server.core.streamspec import StoredSample, StreamSpec


def stored(n: int) -> list[StoredSample]:
    s = Stream(StreamSpec(name="S", whiteboard="W", hardsize=100))
    return list(s.add([DataSample(payload=b"p")] * n, writer="w", received_ns=0).stored)


def test_take_in_order_without_drops() -> None:
    buf = SampleBuffer(3)
    samples = stored(3)
    assert buf.take() is None and len(buf) == 0
    assert [buf.offer(x) for x in samples] == [0, 0, 0] and len(buf) == 3
    assert [buf.take() for _ in range(4)] == [
        (samples[0], 0),
        (samples[1], 0),
        (samples[2], 0),
        None,
    ]


def test_full_buffer_drops_oldest_and_reports_once() -> None:
    buf = SampleBuffer(2)
    samples = stored(6)
    assert [buf.offer(x) for x in samples[:5]] == [0, 0, 1, 1, 1]
    assert len(buf) == 2 and buf.dropped_total == 3
    assert buf.take() == (samples[3], 3)  # dropped since the previous take
    assert buf.take() == (samples[4], 0)
    buf.offer(samples[5])
    assert buf.take() == (samples[5], 0) and buf.take() is None
    assert buf.dropped_total == 3 and buf.capacity == 2


@pytest.mark.parametrize("capacity", [0, -1])
def test_capacity_must_be_positive(capacity: int) -> None:
    with pytest.raises(ApiMisuseError):
        SampleBuffer(capacity)


@settings(max_examples=60)
@given(capacity=st.integers(1, 5), ops=st.lists(st.booleans(), max_size=40))
def test_against_model(capacity: int, ops: list[bool]) -> None:
    """Offer (True) / take (False) in any order: every sample is taken or counted as dropped."""
    samples = iter(stored(len(ops)))
    buf = SampleBuffer(capacity)
    offered: list[int] = []
    taken: list[int] = []
    dropped_seen = 0
    for offer in ops:
        if offer:
            x = next(samples)
            offered.append(x.id)
            buf.offer(x)
        elif (got := buf.take()) is not None:
            sample, dropped = got
            # The drops reported are exactly the ids skipped since the previous take.
            previous = taken[-1] if taken else 0
            assert sample.id - previous - 1 == dropped
            taken.append(sample.id)
            dropped_seen += dropped
        assert len(buf) <= capacity
    rest = []
    while (got := buf.take()) is not None:
        rest.append(got[0].id)
        dropped_seen += got[1]
    assert taken + rest == sorted(taken + rest)
    assert len(taken) + len(rest) + buf.dropped_total == len(offered)
    assert dropped_seen == buf.dropped_total
