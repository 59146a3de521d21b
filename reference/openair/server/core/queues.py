"""The bounded delivery queue of one module, without I/O (spec 6.6, section 10).

Items leave in the order (message priority, whiteboard priority, arrival) — lower numbers first,
first in, first out within a level (OA-PRIO-1, OA-PRIO-2). An item with a due time (a trigger's
`after`, OA-TRIG-3) is held back and joins the ordered queue when its time has passed (section
10: "a delayed wakeup joins the queue when its delay has passed").

The queue holds at most `capacity` items, delayed ones included (OA-DELIV-8). A push into a full
queue first adds the new item and then drops, for this module only, the oldest item among those
of the lowest message priority (the highest number) — which is the new item itself when it is
strictly the lowest (OA-DELIV-9). It also holds at most `max_bytes` bytes of frames
(`max-queue-bytes`, OA-LIM-8): past it the same victims go, oldest of the lowest priority first,
until the queue fits again; one item is always kept, whatever its size. Every operation is
O(log n): three heaps share the items and forget removed ones lazily; a heap is rebuilt when
most of it is stale.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass, field

# The size of a held message, shared with the server's observers (the monitor's ring).
from openair.observing import message_bytes as item_bytes
from openair.protocol.framing import Wire
from openair.protocol.message import Message

__all__ = ["ByteTally", "DeliveryQueue", "QueueCounters", "QueueItem", "item_bytes"]


@dataclass(frozen=True, slots=True, kw_only=True)
class QueueItem:
    """One pending delivery: the message and the keys that order it.

    `priority` is the message priority that orders it (for a wakeup the trigger's, OA-PRIO-1),
    `wb_priority` the priority of the whiteboard that caused it (OA-PRIO-2), `due_ns` the
    earliest time it may be sent (0 = at once), `seq` its arrival number in this queue.
    """

    message: Message
    priority: float
    wb_priority: float
    due_ns: int = 0
    seq: int = 0
    # The frame of `message` already written: bytes, or parts (header + XML, then chunks).
    wire: Wire | None = field(default=None, compare=False, repr=False)
    expires_ns: int = field(default=0, compare=False)  # OA-DELIV-14: 0 = never expires
    size: int = field(default=0, compare=False)  # bytes it holds (OA-LIM-8)

    @property
    def order(self) -> tuple[float, float, int]:
        """The sort key of the ready queue (OA-PRIO-1, OA-PRIO-2)."""
        return (self.priority, self.wb_priority, self.seq)


@dataclass(slots=True)
class QueueCounters:
    """What went through one queue: pushed in, popped out, dropped on overflow, discarded."""

    pushed: int = 0
    popped: int = 0
    dropped: int = 0
    discarded: int = 0
    peak: int = 0
    dropped_bytes: int = 0  # bytes of the items dropped on overflow (OA-LIM-8)


@dataclass(slots=True)
class ByteTally:
    """The bytes several queues hold together, kept as they change (OA-LIM-14 reads it per post:
    summing every module's queue there was O(modules) a post)."""

    bytes: int = 0


@dataclass(slots=True)
class DeliveryQueue:
    """The pending deliveries of one module, bounded by `capacity` and `max_bytes` (OA-DELIV-8).

    `max_bytes` 0 sets no byte bound.
    """

    capacity: int
    max_bytes: int = 0
    counters: QueueCounters = field(default_factory=QueueCounters)
    tally: ByteTally = field(default_factory=ByteTally)  # shared by a server's queues
    _ready: list[tuple[float, float, int]] = field(default_factory=list)
    _delayed: list[tuple[int, int]] = field(default_factory=list)
    _victims: list[tuple[float, int]] = field(default_factory=list)
    _items: dict[int, QueueItem] = field(default_factory=dict)
    _waiting: set[int] = field(default_factory=set)
    _seq: int = 0
    _bytes: int = 0

    def __post_init__(self) -> None:
        if self.capacity < 1:
            raise ValueError(f"capacity must be at least 1, not {self.capacity}")

    def __len__(self) -> int:
        return len(self._items)

    @property
    def held_bytes(self) -> int:
        """The bytes the queued items hold (OA-LIM-8)."""
        return self._bytes

    @property
    def delayed(self) -> int:
        """How many items wait for their due time."""
        return len(self._waiting)

    def push(
        self,
        message: Message,
        *,
        priority: float,
        wb_priority: float = 1.0,
        due_ns: int = 0,
        wire: Wire | None = None,
        expires_ns: int = 0,
    ) -> QueueItem | None:
        """Queue `message`; return the item dropped for lack of room, if any (OA-DELIV-9).

        `wire` is the message's frame when it was already written (sent as it is). Use
        `push_all` to learn of every item a byte bound drops.
        """
        victims = self.push_all(
            message,
            priority=priority,
            wb_priority=wb_priority,
            due_ns=due_ns,
            wire=wire,
            expires_ns=expires_ns,
        )
        return victims[0] if victims else None

    def push_all(
        self,
        message: Message,
        *,
        priority: float,
        wb_priority: float = 1.0,
        due_ns: int = 0,
        wire: Wire | None = None,
        expires_ns: int = 0,
        now_ns: int = 0,
    ) -> list[QueueItem]:
        """Queue `message`; return every item dropped for lack of room (OA-DELIV-9, OA-LIM-8).

        An item due at or before `now_ns` joins the ordered queue at once (as `pop(now_ns)`
        would move it there first), without passing through the delayed heap.
        """
        self._seq += 1
        item = QueueItem(
            message=message,
            priority=priority,
            wb_priority=wb_priority,
            due_ns=due_ns,
            seq=self._seq,
            wire=wire,
            expires_ns=expires_ns,
            size=item_bytes(message, wire),
        )
        self._items[item.seq] = item
        self._bytes += item.size
        self.tally.bytes += item.size
        heapq.heappush(self._victims, (-priority, item.seq))
        if due_ns > now_ns:
            self._waiting.add(item.seq)
            heapq.heappush(self._delayed, (due_ns, item.seq))
        else:
            heapq.heappush(self._ready, item.order)
        self.counters.pushed += 1
        victims: list[QueueItem] = []
        if len(self._items) > self.capacity:
            victims.append(self._drop_one())
        while self.max_bytes and self._bytes > self.max_bytes and len(self._items) > 1:
            victims.append(self._drop_one())  # OA-LIM-8: the same victims as OA-DELIV-9
        self.counters.peak = max(self.counters.peak, len(self._items))
        self._compact()
        return victims

    def passed(self) -> int:
        """Count an item sent without being queued (pushed and popped at once); return its seq."""
        self._seq += 1
        counters = self.counters
        counters.pushed += 1
        counters.popped += 1
        if counters.peak < 1:
            counters.peak = 1
        return self._seq

    def _drop_one(self) -> QueueItem:
        """Remove the oldest item of the lowest priority (OA-DELIV-9)."""
        while True:
            _, seq = heapq.heappop(self._victims)
            victim = self._items.pop(seq, None)
            if victim is not None:
                self._waiting.discard(seq)
                self._bytes -= victim.size
                self.tally.bytes -= victim.size
                self.counters.dropped += 1
                self.counters.dropped_bytes += victim.size
                return victim

    def _promote(self, now_ns: int) -> None:
        """Move items whose due time has passed into the ordered queue (section 10)."""
        while self._delayed and self._delayed[0][0] <= now_ns:
            _, seq = heapq.heappop(self._delayed)
            if seq in self._waiting:
                self._waiting.discard(seq)
                heapq.heappush(self._ready, self._items[seq].order)

    def pop(self, now_ns: int) -> QueueItem | None:
        """Remove and return the first eligible item, or None when none is due at `now_ns`."""
        self._promote(now_ns)
        while self._ready:
            seq = heapq.heappop(self._ready)[2]
            item = self._items.pop(seq, None)
            if item is not None:
                self._bytes -= item.size
                self.tally.bytes -= item.size
                self.counters.popped += 1
                return item
        return None

    def next_due(self) -> int | None:
        """Return the earliest due time among the delayed items (None when there is none)."""
        while self._delayed and self._delayed[0][1] not in self._waiting:
            heapq.heappop(self._delayed)
        return self._delayed[0][0] if self._delayed else None

    def has_ready(self, now_ns: int) -> bool:
        """Return whether `pop(now_ns)` would return an item."""
        self._promote(now_ns)
        while self._ready and self._ready[0][2] not in self._items:
            heapq.heappop(self._ready)
        return bool(self._ready)

    def clear(self) -> list[QueueItem]:
        """Remove every item (the module's session ended, OA-SESS-15) and return them in order."""
        items = sorted(self._items.values(), key=lambda i: i.order)
        self.counters.discarded += len(items)
        self.tally.bytes -= self._bytes
        self._bytes = 0
        self._items.clear()
        self._waiting.clear()
        self._ready.clear()
        self._delayed.clear()
        self._victims.clear()
        return items

    def _compact(self) -> None:
        """Rebuild a heap when stale entries outnumber live ones (keeps memory O(capacity))."""
        live = len(self._items)
        limit = 2 * live + 64
        if len(self._victims) > limit:
            self._victims = [(-i.priority, i.seq) for i in self._items.values()]
            heapq.heapify(self._victims)
        if len(self._ready) > limit:
            self._ready = [i.order for s, i in self._items.items() if s not in self._waiting]
            heapq.heapify(self._ready)
        if len(self._delayed) > limit:
            self._delayed = [(self._items[s].due_ns, s) for s in self._waiting]
            heapq.heapify(self._delayed)
