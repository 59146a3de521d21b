"""A bounded buffer of the samples pushed to one subscriber (OA-STREAM-8, OA-LIM-16). Sans-I/O."""

from __future__ import annotations

from collections import deque

from openair.protocol.errors import ApiMisuseError
from openair.server.core.streamspec import StoredSample

__all__ = ["SampleBuffer"]


class SampleBuffer:
    """Bounded per-subscriber buffer (OA-STREAM-8): drops the oldest, counts drops per take.

    Bounded by `capacity` samples and, unless 0, by `max_bytes` of payload (OA-LIM-16): a
    buffer keeps samples the stream itself may have evicted alive; one sample is always kept.
    """

    __slots__ = ("_dropped", "_items", "bytes", "capacity", "dropped_total", "max_bytes")

    def __init__(self, capacity: int, max_bytes: int = 0) -> None:
        if capacity < 1:
            raise ApiMisuseError(f"sample buffer capacity {capacity} is less than 1")
        self.capacity = capacity
        self.max_bytes = max_bytes
        self.bytes = 0
        self.dropped_total = 0
        self._dropped = 0
        self._items: deque[StoredSample] = deque()

    def __len__(self) -> int:
        return len(self._items)

    def __repr__(self) -> str:
        return f"<SampleBuffer {len(self._items)}/{self.capacity} dropped={self.dropped_total}>"

    def offer(self, s: StoredSample) -> int:
        """Queue `s`; return how many samples this dropped (the oldest unsent ones)."""
        items = self._items
        items.append(s)
        self.bytes += s.size
        dropped = 0
        # OA-STREAM-8: the slow subscriber loses, alone; OA-LIM-16: by bytes as well
        while len(items) > 1 and (
            len(items) > self.capacity or (self.max_bytes and self.bytes > self.max_bytes)
        ):
            self.bytes -= items.popleft().size
            dropped += 1
        self._dropped += dropped
        self.dropped_total += dropped
        return dropped

    def take(self) -> tuple[StoredSample, int] | None:
        """Return the next sample and the samples dropped since the previous take, or None."""
        if not self._items:
            return None
        dropped, self._dropped = self._dropped, 0
        taken = self._items.popleft()
        self.bytes -= taken.size
        return taken, dropped
