"""The monitor's tap on the router: a ring of recent posts, and what is cheap to count on the way.

`Tap` is the monitor's `ServerObserver` (openair.observing): `Tap.observe` runs inside the post
path, so it does O(1) work and never raises: it appends (stored copy, deliveries) to a bounded
ring, counts the post and remembers the type each sender posted last. Everything else (JSON,
filters, rates, the graph) is computed later from the ring, and only when someone looks.

Events are numbered from 0 in arrival order (`seq`); the ring keeps the newest `capacity`, and
no more than `max_bytes` of messages and wakeup frames (issue #19: large posts must not make the
monitor hold hundreds of them; the newest event is always kept), so event `seq` is still there
while `seq >= count - len(ring)`.

`Tap.delivered` takes a completed delivery (module, queue item) when the dispatcher reports
them; it records the post → wakeup latency of the module in a fixed-bucket histogram.
"""

from __future__ import annotations

import bisect
import time
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field

from openair.observing import Acknowledged, Delivered, held_bytes, message_bytes
from openair.protocol.message import Message

__all__ = ["LATENCY_BOUNDS_US", "Event", "Histogram", "RateMeter", "Tap"]

#: Upper bounds (µs, exclusive) of the latency buckets; the last bucket is everything above.
LATENCY_BOUNDS_US: tuple[int, ...] = (
    100, 200, 500, 1_000, 2_000, 5_000, 10_000, 20_000, 50_000, 100_000, 200_000, 500_000,
    1_000_000,
)  # fmt: skip
_MAX_SENDERS = 10_000  # distinct `from` names remembered before the table starts afresh
_MAX_HISTOGRAMS = 10_000

Event = tuple[Message, tuple[Delivered, ...]]


@dataclass(slots=True)
class Histogram:
    """Counts of latencies in the buckets of LATENCY_BOUNDS_US, with their sum and maximum."""

    counts: list[int] = field(default_factory=lambda: [0] * (len(LATENCY_BOUNDS_US) + 1))
    total: int = 0
    sum_us: int = 0
    max_us: int = 0

    def add(self, us: int) -> None:
        self.counts[bisect.bisect_right(LATENCY_BOUNDS_US, us)] += 1
        self.total += 1
        self.sum_us += us
        self.max_us = max(self.max_us, us)

    def as_dict(self) -> dict[str, object]:
        labels = [f"<{_ms(b)}" for b in LATENCY_BOUNDS_US] + [f"≥{_ms(LATENCY_BOUNDS_US[-1])}"]
        return {
            "unit": "ms",
            "buckets": [
                {"label": label, "le_us": bound, "count": count}
                for label, bound, count in zip(
                    labels, [*LATENCY_BOUNDS_US, None], self.counts, strict=True
                )
            ],
            "count": self.total,
            "mean_ms": round(self.sum_us / self.total / 1000, 3) if self.total else None,
            "max_ms": round(self.max_us / 1000, 3) if self.total else None,
        }


def _ms(us: int) -> str:
    return f"{us / 1000:g} ms"


class Tap:
    """The monitor's observer of the server (`Server.observe`): posts, acknowledged deliveries."""

    def __init__(self, capacity: int = 512, max_bytes: int = 32 << 20) -> None:
        self.ring: deque[Event] = deque(maxlen=capacity)
        self.max_bytes = max_bytes
        self.bytes = 0  # what the ring's events hold
        self._sizes: deque[int] = deque()
        self.count = 0  # events observed since start; the next event's seq
        self.errors = 0
        self.last_type: dict[str, str] = {}  # sender -> the type it posted last
        self.latency: dict[str, Histogram] = {}

    def observe(self, whiteboard: str, stored: Message, deliveries: tuple[Delivered, ...]) -> None:
        """Record one stored post (the router's observer: O(1), never raises)."""
        try:
            size = message_bytes(stored, None)
            for delivery in deliveries:
                size += held_bytes(delivery.message, delivery.wire)
            if len(self.ring) == self.ring.maxlen:
                self.bytes -= self._sizes.popleft()  # the append below drops the oldest
            self.ring.append((stored, deliveries))
            self._sizes.append(size)
            self.bytes += size
            while self.bytes > self.max_bytes and len(self.ring) > 1:
                self.ring.popleft()
                self.bytes -= self._sizes.popleft()
            self.count += 1
            senders = self.last_type
            if len(senders) >= _MAX_SENDERS:
                senders.clear()  # hostile `from` names must not grow memory without bound
            senders[stored.sender] = stored.type
        except Exception:  # routing never waits on a monitor problem
            self.errors += 1

    def delivered(self, module: str, item: Acknowledged) -> None:
        """Record the latency of a delivery acknowledged now (post, or trigger `after`, → ack)."""
        try:
            if not item.due_ns:
                return
            us = max(0, (time.time_ns() - item.due_ns) // 1000)
            hist = self.latency.get(module)
            if hist is None:
                if len(self.latency) >= _MAX_HISTOGRAMS:
                    return
                hist = self.latency[module] = Histogram()
            hist.add(us)
        except Exception:
            self.errors += 1

    @property
    def oldest(self) -> int:
        """The seq of the oldest event still in the ring."""
        return self.count - len(self.ring)

    def newest_first(self, stop: int = 0, limit: int | None = None) -> Iterator[tuple[int, Event]]:
        """Yield (seq, event) from the newest back to `stop` (inclusive), at most `limit`."""
        seq = self.count
        for n, event in enumerate(reversed(self.ring)):
            seq -= 1
            if seq < stop or (limit is not None and n >= limit):
                return
            yield seq, event

    def find(self, whiteboard: str, wbid: int | None, msg_id: str) -> Event | None:
        """Return the event of the stored message (by wbid, else by id) if still in the ring."""
        for stored, deliveries in reversed(self.ring):
            if stored.stored != whiteboard:
                continue
            if (wbid is not None and stored.wbid == wbid) or (msg_id and stored.id == msg_id):
                return stored, deliveries
        return None


class RateMeter:
    """Rates of monotonic counters from samples taken about once a second (last `window_s`)."""

    def __init__(self, window_s: float = 5.0) -> None:
        self.window_s = window_s
        self._samples: deque[tuple[float, dict[str, int]]] = deque()

    def sample(self, now: float, values: dict[str, int]) -> None:
        """Add a sample of every counter at time `now` (seconds, monotonic)."""
        self._samples.append((now, values))
        while len(self._samples) > 2 and now - self._samples[1][0] >= self.window_s:
            self._samples.popleft()

    def rate(self, key: str, now: float, current: int) -> float | None:
        """Return the rate per second of counter `key` since the oldest sample that has it.

        None while no earlier sample has the counter (it appeared since, e.g. a new module).
        """
        for then, values in self._samples:
            if key in values:
                dt = now - then
                return max(0.0, (current - values[key]) / dt) if dt > 0 else None
        return None
