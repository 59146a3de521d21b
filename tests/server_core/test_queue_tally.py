"""`ByteTally`: the bytes a server's queues hold together, kept as they change (OA-LIM-14).

The held-bytes budget reads it for every post; it must always equal the sum of the queues'
own counts, whatever pushes, overflows (OA-DELIV-9, OA-LIM-8), pops and clears happened.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from openair.protocol.message import Message
from openair.server.core.queues import ByteTally, DeliveryQueue

_OPS = st.lists(
    st.tuples(
        st.sampled_from(["push", "push", "push", "pop", "clear"]),
        st.integers(0, 2),  # which queue
        st.integers(0, 3000),  # content size
        st.sampled_from([0.0, 2.0, 5.0]),  # priority
        st.sampled_from([0, 10**18]),  # due: at once, or far later (stays delayed)
    ),
    max_size=60,
)


@settings(max_examples=300, deadline=None)
@given(_OPS)
def test_the_tally_is_the_sum_of_the_queues(ops: list[tuple[str, int, int, float, int]]) -> None:
    tally = ByteTally()
    queues = [
        DeliveryQueue(capacity=4, tally=tally),
        DeliveryQueue(capacity=50, max_bytes=6000, tally=tally),
        DeliveryQueue(capacity=3, max_bytes=2500, tally=tally),
    ]
    for op, which, size, priority, due in ops:
        queue = queues[which]
        if op == "push":
            msg = Message(type="T.A", content="x" * size)
            queue.push_all(msg, priority=priority, due_ns=due, now_ns=1)
        elif op == "pop":
            queue.pop(2)
        else:
            queue.clear()
        assert tally.bytes == sum(q.held_bytes for q in queues)
        assert all(q.held_bytes >= 0 for q in queues)


def test_a_queue_alone_keeps_its_own_tally() -> None:
    queue = DeliveryQueue(capacity=2)
    queue.push_all(Message(type="T.A", content="abc"), priority=2.0)
    assert queue.tally.bytes == queue.held_bytes > 0
