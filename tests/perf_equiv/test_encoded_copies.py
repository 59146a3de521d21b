"""The cache of encoded stored copies shared with the worker thread (issue #19).

`EncodedCopies` belongs to the router's thread; a wakeup written on the worker reads it through
`PeekedCopies`, offers back what it had to encode, and lets the interpreter lock go now and
then. The router keeps what was offered at its next decision (`settle`).
"""

from __future__ import annotations

from openair.protocol.message import Message
from openair.protocol.wakeup import EncodedCopies, PeekedCopies, stored_xml


def _copies(n: int) -> list[Message]:
    return [Message(type=f"Test.{i}", id=f"m{i}", sender="S", content="x" * i) for i in range(n)]


def test_a_copy_encoded_by_a_reader_is_kept_at_the_owners_next_settle() -> None:
    copies = EncodedCopies(size=8)
    (msg,) = _copies(1)
    assert PeekedCopies(copies).xml(msg) == stored_xml(msg)
    assert copies.peek(msg) is None  # the reader's thread never changes the cache
    copies.settle()
    assert copies.peek(msg) == stored_xml(msg)


def test_a_cached_copy_is_read_not_offered_again() -> None:
    copies = EncodedCopies(size=8)
    (msg,) = _copies(1)
    copies.xml(msg)
    reader = PeekedCopies(copies)
    assert reader.xml(msg) == stored_xml(msg)
    assert not copies._offered


def test_what_waits_for_settle_is_bounded_by_the_cache_size() -> None:
    copies = EncodedCopies(size=4)
    reader = PeekedCopies(copies)
    msgs = _copies(10)
    for msg in msgs:
        reader.xml(msg)
    assert len(copies._offered) == 4
    copies.settle()
    assert not copies._offered
    assert [copies.peek(m) is not None for m in msgs] == [True] * 4 + [False] * 6


def test_what_waits_for_settle_is_bounded_by_the_cache_bytes() -> None:
    msgs = _copies(8)
    budget = sum(2 * len(stored_xml(m)) for m in msgs[:5])
    copies = EncodedCopies(size=64, max_bytes=budget)
    reader = PeekedCopies(copies)
    for msg in msgs:
        reader.xml(msg)
    assert [m for m, _ in copies._offered] == msgs[:5]  # the next would pass the bytes
    copies.settle()
    reader.xml(msgs[7])  # what was taken no longer counts
    assert [m for m, _ in copies._offered] == [msgs[7]]


def test_settle_keeps_the_size_and_byte_bounds() -> None:
    copies = EncodedCopies(size=3)
    reader = PeekedCopies(copies)
    msgs = _copies(3)
    for msg in msgs:
        copies.xml(msg)
    newer = _copies(5)[3:]
    for msg in newer:
        reader.xml(msg)
    copies.settle()
    assert len(copies._xml) == 3  # the oldest went, as for a copy the owner encoded
    assert copies.peek(msgs[0]) is None and all(copies.peek(m) for m in newer)
    assert copies._bytes == sum(2 * len(stored_xml(m)) for m in (msgs[2], *newer))


def test_settle_keeps_an_entry_the_owner_made_in_the_meantime() -> None:
    copies = EncodedCopies(size=8)
    (msg,) = _copies(1)
    PeekedCopies(copies).xml(msg)
    copies.xml(msg)  # the owner encoded it too before settling
    copies.settle()
    assert len(copies._xml) == 1
    assert copies._bytes == 2 * len(stored_xml(msg))


def test_a_reader_calls_the_caches_pause_before_each_copy() -> None:
    copies = EncodedCopies(size=64)
    msgs = _copies(6)
    for msg in msgs[:3]:
        copies.xml(msg)
    calls: list[int] = []
    copies.pause = lambda: calls.append(len(copies._offered))
    reader = PeekedCopies(copies)
    for msg in msgs:  # three hits, three misses: a pause before each
        reader.xml(msg)
    assert calls == [0, 0, 0, 0, 1, 2]
    copies.xml(msgs[0])  # the owner's own encoding never pauses
    assert len(calls) == 6
