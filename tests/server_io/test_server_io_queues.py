"""The per-module delivery queue against a small list model (OA-PRIO-1/2, OA-DELIV-8/9)."""

from __future__ import annotations

from dataclasses import dataclass

import pytest
from hypothesis import given
from hypothesis import strategies as st

from openair.protocol.message import Message
from openair.server.core.queues import DeliveryQueue

PRIORITIES = st.sampled_from([0.0, 1.0, 2.0, 2.5, 6.999])
WB_PRIORITIES = st.sampled_from([0.0, 1.0, 3.0])


@dataclass
class _Model:
    """The spec's rules written the slow, obvious way."""

    capacity: int
    items: list[tuple[float, float, int, int]]  # (priority, wb priority, due, seq)
    seq: int = 0

    def push(self, prio: float, wbp: float, due: int) -> int | None:
        self.seq += 1
        self.items.append((prio, wbp, due, self.seq))
        if len(self.items) <= self.capacity:
            return None
        # OA-DELIV-9: the oldest among those of the lowest priority (highest number).
        worst = max(p for p, _, _, _ in self.items)
        victim = min((i for i in self.items if i[0] == worst), key=lambda i: i[3])
        self.items.remove(victim)
        return victim[3]

    def pop(self, now: int) -> int | None:
        eligible = [i for i in self.items if i[2] <= now]
        if not eligible:
            return None
        first = min(eligible, key=lambda i: (i[0], i[1], i[3]))  # OA-PRIO-1, OA-PRIO-2
        self.items.remove(first)
        return first[3]


def _msg(n: int) -> Message:
    return Message(type=f"Test.Item.{n}", id=str(n))


@given(st.lists(st.tuples(PRIORITIES, WB_PRIORITIES), max_size=60))
def test_pops_follow_priority_then_whiteboard_priority_then_arrival(
    pushes: list[tuple[float, float]],
) -> None:
    queue = DeliveryQueue(capacity=1000)
    for n, (prio, wbp) in enumerate(pushes):
        queue.push(_msg(n), priority=prio, wb_priority=wbp)
    popped = []
    while (item := queue.pop(0)) is not None:
        popped.append((item.priority, item.wb_priority, item.seq))
    assert popped == sorted(popped)
    assert len(popped) == len(pushes)
    assert len(queue) == 0


@given(
    st.integers(min_value=1, max_value=8),
    st.lists(
        st.one_of(
            st.tuples(st.just("push"), PRIORITIES, WB_PRIORITIES, st.sampled_from([0, 5, 10, 20])),
            st.tuples(st.just("pop"), st.integers(min_value=0, max_value=4)),
        ),
        max_size=80,
    ),
)
def test_queue_matches_the_model(capacity: int, ops: list[tuple[object, ...]]) -> None:
    queue = DeliveryQueue(capacity=capacity)
    model = _Model(capacity=capacity, items=[])
    n = now = 0
    for op in ops:
        if op[0] == "push":
            _, prio, wbp, due = op
            assert isinstance(prio, float) and isinstance(wbp, float) and isinstance(due, int)
            n += 1
            victim = queue.push(_msg(n), priority=prio, wb_priority=wbp, due_ns=due)
            expected = model.push(prio, wbp, due)
            assert (victim.seq if victim else None) == expected
        else:
            step = op[1]
            assert isinstance(step, int)
            now += step  # the clock never goes back
            item = queue.pop(now)
            assert (item.seq if item else None) == model.pop(now)
        assert len(queue) == len(model.items) <= capacity
    assert queue.counters.dropped == queue.counters.pushed - len(queue) - queue.counters.popped


def test_overflow_drops_the_oldest_of_the_lowest_priority() -> None:
    queue = DeliveryQueue(capacity=3)
    queue.push(_msg(1), priority=2.0)
    queue.push(_msg(2), priority=5.0)
    queue.push(_msg(3), priority=5.0)
    victim = queue.push(_msg(4), priority=1.0)
    assert victim is not None and victim.message.id == "2"
    assert queue.counters.dropped == 1
    order = [queue.pop(0) for _ in range(3)]
    assert [i.message.id for i in order if i] == ["4", "1", "3"]


def test_a_new_message_of_strictly_lowest_priority_is_itself_the_victim() -> None:
    queue = DeliveryQueue(capacity=2)
    queue.push(_msg(1), priority=0.0)
    queue.push(_msg(2), priority=1.0)
    victim = queue.push(_msg(3), priority=6.0)
    assert victim is not None and victim.message.id == "3"
    assert len(queue) == 2


def test_delayed_items_wait_for_their_due_time_then_join_in_priority_order() -> None:
    queue = DeliveryQueue(capacity=10)
    queue.push(_msg(1), priority=3.0)
    queue.push(_msg(2), priority=0.0, due_ns=1_000)
    assert queue.next_due() == 1_000
    assert queue.delayed == 1
    first = queue.pop(999)
    assert first is not None and first.message.id == "1"
    assert queue.pop(999) is None
    assert not queue.has_ready(999)
    assert queue.has_ready(1_000)
    second = queue.pop(1_000)
    assert second is not None and second.message.id == "2"
    assert queue.next_due() is None


def test_clear_returns_everything_in_order_and_counts_it() -> None:
    queue = DeliveryQueue(capacity=10)
    queue.push(_msg(1), priority=4.0)
    queue.push(_msg(2), priority=1.0, due_ns=50)
    queue.push(_msg(3), priority=1.0)
    assert [i.message.id for i in queue.clear()] == ["2", "3", "1"]
    assert queue.counters.discarded == 3
    assert len(queue) == 0 and queue.pop(100) is None and queue.next_due() is None


def test_many_overflows_keep_memory_bounded() -> None:
    queue = DeliveryQueue(capacity=50)
    for n in range(5_000):
        queue.push(_msg(n), priority=float(n % 7))
    assert len(queue) == 50
    assert queue.counters.dropped == 4_950
    internal = len(queue._victims) + len(queue._ready) + len(queue._delayed)
    assert internal <= 3 * (2 * 50 + 64)
    kept = [item.priority for item in iter(lambda: queue.pop(0), None)]
    assert max(kept) <= 0.0


def test_capacity_must_be_positive() -> None:
    with pytest.raises(ValueError):
        DeliveryQueue(capacity=0)
