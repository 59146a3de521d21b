"""The tap (ring, counters, latency histogram), rates, filters and batching, without a server."""

from __future__ import annotations

import asyncio
import json
from dataclasses import dataclass, field
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from openair.protocol.errors import PatternInvalidError
from openair.protocol.matching import matches
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.wakeup import build_wakeup
from openair.server.core.queues import QueueItem
from openair.server.core.router import Delivery
from openair_monitor import MonitorOptions
from openair_monitor.messages import MessageFilter, detail, summary
from openair_monitor.sse import Broadcaster
from openair_monitor.tap import LATENCY_BOUNDS_US, Histogram, RateMeter, Tap


def stored(wbid: int, type_: str = "Test.A", sender: str = "P", content: str = "") -> Message:
    return Message(
        type=type_,
        sender=sender,
        to="WB1",
        stored="WB1",
        wbid=wbid,
        content=content,
        posted=AirTime(sec=100, msec=0),
        received=AirTime(sec=100, msec=7),
    )


def test_the_ring_keeps_the_newest_and_numbers_every_event() -> None:
    tap = Tap(capacity=3)
    for i in range(1, 6):
        tap.observe("WB1", stored(i), ())
    assert tap.count == 5
    assert tap.oldest == 2
    assert [(seq, m.wbid) for seq, (m, _) in tap.newest_first()] == [(4, 5), (3, 4), (2, 3)]
    assert [seq for seq, _ in tap.newest_first(stop=3)] == [4, 3]
    assert [seq for seq, _ in tap.newest_first(limit=1)] == [4]


def test_find_looks_up_by_wbid_or_id_on_the_right_whiteboard() -> None:
    tap = Tap()
    msg = stored(7)
    tap.observe("WB1", msg, ())
    assert tap.find("WB1", 7, "") == (msg, ())
    assert tap.find("WB1", None, msg.id) == (msg, ())
    assert tap.find("WB2", 7, "") is None
    assert tap.find("WB1", 8, "") is None


def test_last_type_per_sender_is_bounded() -> None:
    tap = Tap()
    tap.observe("WB1", stored(1, "A.B", "X"), ())
    tap.observe("WB1", stored(2, "A.C", "X"), ())
    assert tap.last_type == {"X": "A.C"}
    for i in range(10_001):
        tap.observe("WB1", stored(i + 3, sender=f"S{i}"), ())
    assert len(tap.last_type) <= 10_000


def test_observe_never_raises() -> None:
    tap = Tap()
    tap.observe("WB1", None, ())  # type: ignore[arg-type]  # a bug upstream must not break routing
    assert tap.errors == 1


def test_histogram_buckets_by_upper_bound() -> None:
    hist = Histogram()
    for us in (0, 99, 100, 1_500, 2_000_000):
        hist.add(us)
    counts = hist.counts
    assert counts[0] == 2  # < 100 µs
    assert counts[1] == 1  # 100 µs falls in [100, 200)
    assert counts[LATENCY_BOUNDS_US.index(2_000)] == 1
    assert counts[-1] == 1
    data = hist.as_dict()
    assert data["count"] == 5
    assert data["max_ms"] == 2000.0


def test_delivered_records_latency_from_the_due_time() -> None:
    tap = Tap()
    msg = stored(1)
    tap.delivered("M", QueueItem(message=msg, priority=2.0, wb_priority=1.0, due_ns=1))
    tap.delivered("M", QueueItem(message=msg, priority=2.0, wb_priority=1.0, due_ns=0))  # unknown
    assert tap.latency["M"].total == 1
    assert tap.latency["M"].counts[-1] == 1  # due at 1 ns past the epoch: very late


def test_rates_come_from_the_oldest_sample_in_the_window() -> None:
    meter = RateMeter(window_s=2.0)
    assert meter.rate("x", 0.0, 0) is None
    for t in range(6):
        meter.sample(float(t), {"x": t * 10})
    assert meter.rate("x", 5.0, 50) == pytest.approx(10.0)
    assert meter.rate("y", 5.0, 50) is None
    meter.sample(6.0, {"x": 60, "y": 0})  # a counter that appears later
    assert meter.rate("y", 7.0, 5) == pytest.approx(5.0)


TYPES = ["Test", "Test.A", "Test.A.B", "Other.Test", "test.a", "Input.Perc", "A.X.B"]
PATTERNS = ["Test.*", "*", "*.Test", "Test.A", "Input.Perc.*", "A.*.B.*", "t*.a"]


@pytest.mark.parametrize("pattern", PATTERNS)
def test_the_type_filter_is_the_trigger_matcher(pattern: str) -> None:
    accept = MessageFilter.checked(pattern=pattern).compile()
    for t in TYPES:
        assert accept(stored(1, t)) == matches(pattern, t), t


@given(st.sampled_from(PATTERNS), st.sampled_from(TYPES))
def test_filter_and_matcher_agree(pattern: str, type_: str) -> None:
    assert MessageFilter.checked(pattern=pattern).compile()(stored(1, type_)) == matches(
        pattern, type_
    )


def test_sender_and_content_filters_are_globs() -> None:
    accept = MessageFilter.checked(sender="Read*", content="*hello*").compile()
    assert accept(stored(1, sender="Reader", content="say hello now"))
    assert not accept(stored(1, sender="Writer", content="say hello now"))
    assert not accept(stored(1, sender="Reader", content="goodbye"))
    xml = Message(type="T", sender="Reader", content="<a>hello</a>", content_is_xml=True)
    assert accept(xml)  # the text of the elements (OA-RET-13)


def test_an_invalid_pattern_is_refused() -> None:
    with pytest.raises(PatternInvalidError):
        MessageFilter.checked(pattern="Test..A")


def test_summary_and_detail_show_times_latency_cc_and_wakeups() -> None:
    msg = Message(
        type="Test.A",
        sender="P",
        to="WB1",
        stored="WB1",
        cc="M1; M2",
        wbid=3,
        posted=AirTime(sec=100, msec=0),
        received=AirTime(sec=100, msec=7),
    )
    wake = Delivery(
        module="M1",
        message=build_wakeup(stored=msg, whiteboard="WB1", module="M1", lasttrigger="Test.*"),
        due_ns=100_007_000_000 + 50_000_000,
        priority=2.0,
        wb_priority=1.0,
    )
    by_cc = Delivery(
        module="M2",
        message=build_wakeup(stored=msg, whiteboard="WB1", module="M2"),
        due_ns=100_007_000_000,
        priority=2.0,
        wb_priority=1.0,
    )
    broken = Delivery(
        module="M3",
        message=Message(type="AIR.Instruct.Wakeup", content="<x", content_is_xml=True),
        due_ns=100_007_000_000,
        priority=2.0,
        wb_priority=1.0,
    )
    line = summary(msg, (wake,), 9)
    assert (line["seq"], line["wbid"], line["latency_ms"], line["wakeups"]) == (9, 3, 7.0, 1)
    full: dict[str, Any] = detail(msg, (wake, by_cc, broken))
    assert full["cc"] == ["M1", "M2"]
    assert full["slots"]["postedTime"]["text"] == "100.000"
    assert full["latency_ms"] == 7.0
    trigger, cc, unreadable = full["wakeups"]
    assert (trigger["module"], trigger["after_ms"], trigger["cause"]) == ("M1", 50, "trigger")
    assert trigger["lasttrigger"] == "Test.*"
    assert (cc["module"], cc["lasttrigger"], cc["cause"]) == ("M2", "", "cc")  # OA-CC-2
    assert unreadable["lasttrigger"] is None  # unknown, not a crash
    assert detail(msg, None)["wakeups_known"] is False


# -- batching: a stand-in monitor and connection -----------------------------------------------


@dataclass
class FakeConn:
    buffered: int = 0
    written: list[bytes] = field(default_factory=list)
    closing: bool = False
    on_close: Any = None

    def write(self, data: bytes) -> None:
        self.written.append(data)

    def close(self) -> None:
        self.closing = True
        if self.on_close is not None:
            self.on_close()

    def events(self) -> list[tuple[str, Any]]:
        out = []
        for block in b"".join(self.written).decode().split("\n\n"):
            lines = dict(line.split(": ", 1) for line in block.split("\n") if ": " in line)
            if "event" in lines:
                out.append((lines["event"], json.loads(lines["data"])))
        return out


@dataclass
class FakeMonitor:
    options: MonitorOptions
    tap: Tap = field(default_factory=Tap)

    def overview(self) -> dict[str, object]:
        return {"server": {}}

    def graph(self) -> dict[str, object]:
        return {"nodes": []}


def test_batches_are_capped_and_what_was_not_looked_at_is_reported() -> None:
    async def go() -> None:
        mon = FakeMonitor(MonitorOptions(scan=50, batch=5, tick_s=60))
        b = Broadcaster(mon)  # type: ignore[arg-type]
        conn = FakeConn()
        b.open(conn, frozenset({"messages"}), MessageFilter.checked(pattern="Test.*"))  # type: ignore[arg-type]
        for i in range(100):
            mon.tap.observe("WB1", stored(i + 1, "Test.A" if i % 2 else "Other.B"), ())
        b._tick()
        events = conn.events()
        names = [name for name, _ in events]
        assert names == ["hello", "gap", "messages"]
        gap, batch = events[1][1], events[2][1]
        assert [m["wbid"] for m in batch] == [92, 94, 96, 98, 100]  # the newest, oldest first
        assert gap["skipped"] == 100 - 9  # only seq 99 down to 91 were looked at
        b.close()

    asyncio.run(go())


def test_a_client_that_does_not_read_has_its_batches_dropped_then_is_closed() -> None:
    async def go() -> None:
        mon = FakeMonitor(MonitorOptions(max_buffer=10, stall_s=0.0, tick_s=60))
        b = Broadcaster(mon)  # type: ignore[arg-type]
        conn = FakeConn()
        b.open(conn, frozenset({"messages"}), MessageFilter())  # type: ignore[arg-type]
        conn.buffered = 1000  # the peer stopped reading
        mon.tap.observe("WB1", stored(1), ())
        b._tick()
        (stream,) = b.streams
        assert stream.dropped == 1
        assert [name for name, _ in conn.events()] == ["hello"]
        mon.tap.observe("WB1", stored(2), ())
        b._tick()  # still stalled past stall_s: closed and forgotten
        assert conn.closing and not b.streams
        b.close()

    asyncio.run(go())


def test_a_message_held_with_its_frame_counts_both() -> None:
    """Issue #19: a wakeup held with its frame holds its text twice (content and frame); the
    monitor's ring counted the frame only, and held twice its budget."""
    from openair.observing import ENVELOPE_BYTES, held_bytes, message_bytes
    from openair.protocol.message import Message

    msg = Message(type="AIR.Instruct.Wakeup", to="M", content="x" * 1000)
    assert held_bytes(msg, b"y" * 1100) == ENVELOPE_BYTES + 1000 + 1100
    assert held_bytes(msg, (b"y" * 100, b"z" * 50)) == ENVELOPE_BYTES + 1000 + 150
    assert message_bytes(msg, b"y" * 1100) == 1100  # a delivery's size (OA-LIM-8): its frame
    chunked = Message(type="T", content="", binary=(b"c" * 500,))
    assert held_bytes(chunked, None) == ENVELOPE_BYTES + 500  # chunks once, not per frame
