"""Whiteboard storage and retrieve criteria (spec 7.4, 9.2, 9.3)."""

from __future__ import annotations

from typing import Any

import pytest

from openair.protocol.content import ContentMatch, RetrieveSpec
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.server.core.store import MemoryStore
from openair.server.core.whiteboard import Whiteboard, content_glob, text_of

SEC = 1_000_000_000
MS = 1_000_000
T0 = 1_795_328_371 * SEC

# The WB1 of spec 9.2 (psyclone-wire/05-retrieve.txt), oldest first: type, content, sender.
EXAMPLE = [
    ("Ret.A.1", "c1"),
    ("Ret.A.2", "c2"),
    ("Ret.B.1", "green tomato"),
    ("Ret.A.3", "c3"),
    ("Other.X", "x1"),
    ("Ret.A.5", "red tomato"),
    ("Ret.A.6", "c6"),
    ("Ret.a.7", "c7 lower"),
    ("Ret.A.8", "c8"),
]


def _board(maxcount: int = 10_000) -> Whiteboard:
    board = Whiteboard("WB1", maxcount=maxcount)
    for i, (type_, content) in enumerate(EXAMPLE):
        msg = Message(type=type_, sender="Poster", to="WB1", content=content)
        board.store_post(msg, T0 + i * 100 * MS)  # one post every 100 ms
    return board


def _types(board: Whiteboard, now_ns: int = T0 + 10 * SEC, **criteria: Any) -> list[str]:
    spec = RetrieveSpec(**criteria)
    return [m.type for m in board.retrieve(spec, now_ns=now_ns)]


@pytest.mark.parametrize(
    ("criteria", "expected"),
    [
        ({"pattern": "Ret.A.*", "latest": 3}, ["Ret.A.8", "Ret.a.7", "Ret.A.6"]),
        ({"pattern": "Ret.A.*"}, ["Ret.A.8"]),  # OA-RET-4: latest defaults to 1
        ({"pattern": "Ret.*", "latest": 0}, [t for t, _ in reversed(EXAMPLE) if t != "Other.X"]),
        ({"pattern": "Ret.*", "latest": 2}, ["Ret.A.8", "Ret.a.7"]),
        ({"latest": 3}, ["Ret.A.8", "Ret.a.7", "Ret.A.6"]),  # every type
        ({"pattern": "Ret.A", "latest": 3}, []),  # OA-MATCH-2: no prefix matching
        ({"pattern": "*.1", "latest": 5}, ["Ret.B.1", "Ret.A.1"]),
        ({"pattern": "Ret.*", "content": "*tomato*", "latest": 10}, ["Ret.A.5", "Ret.B.1"]),
        ({"pattern": "Ret.*", "content": "green*", "latest": 10}, ["Ret.B.1"]),
        ({"pattern": "Ret.*", "sender": "Poster", "latest": 2}, ["Ret.A.8", "Ret.a.7"]),
        ({"pattern": "Ret.*", "sender": "poster", "latest": 2}, []),  # sender is exact
        ({"pattern": "Ret.A.*", "latest": 2, "lastmsec": 100_000}, ["Ret.A.8", "Ret.a.7"]),
    ],
)
def test_spec_examples(criteria: dict[str, Any], expected: list[str]) -> None:
    assert _types(_board(), **criteria) == expected  # OA-RET-3, OA-RET-6


def test_lastmsec_uses_received_time() -> None:
    board = _board()
    last = T0 + 8 * 100 * MS
    # OA-RET-5: 1.1 s after the last post, a 250 ms window holds nothing.
    assert _types(board, now_ns=last + 1100 * MS, pattern="Ret.*", lastmsec=250) == []
    # A window of 250 ms right after the last post holds the last three (0, 100, 200 ms ago).
    got = _types(board, now_ns=last, pattern="*", lastmsec=250, latest=0)
    assert got == ["Ret.A.8", "Ret.a.7", "Ret.A.6"]
    # The bound is inclusive: exactly 200 ms before is in, 201 ms is out.
    assert len(_types(board, now_ns=last, lastmsec=200, latest=0)) == 3
    assert len(_types(board, now_ns=last + MS, lastmsec=200, latest=0)) == 2
    # 0 means no window (OA-RET-5).
    assert len(_types(board, now_ns=last + 10**6 * SEC, lastmsec=0, latest=0)) == len(EXAMPLE)


def test_lastmsec_ignores_posted_time() -> None:
    board = Whiteboard("WB1")
    old = AirTime(sec=1_000, msec=0)  # posted long ago, received now
    board.store_post(Message(type="A", posted=old), T0)
    assert len(board.retrieve(RetrieveSpec(lastmsec=5000), now_ns=T0 + SEC)) == 1


def test_after_and_until_time_are_inclusive() -> None:
    board = _board()
    at = AirTime.from_ns(T0 + 300 * MS)  # Ret.A.3
    until = AirTime.from_ns(T0 + 500 * MS)  # Ret.A.5
    got = _types(board, after_time=at, until_time=until, latest=0)  # OA-RET-9
    assert got == ["Ret.A.5", "Other.X", "Ret.A.3"]
    assert _types(board, after_time=AirTime.from_ns(T0 + 801 * MS), latest=0) == []
    assert _types(board, until_time=AirTime.from_ns(T0), latest=0) == ["Ret.A.1"]


def test_id_criterion() -> None:
    board = _board()
    target = list(board.newest_first())[4]
    found = board.retrieve(RetrieveSpec(id=target.id, latest=0), now_ns=T0)
    assert found == [target]
    assert board.retrieve(RetrieveSpec(id=target.id.upper(), latest=0), now_ns=T0) == []


def test_content_match_xml_and_text() -> None:
    board = Whiteboard("WB1")
    xml = Message(type="X", content='<a k="v">hello <b>world</b></a>', content_is_xml=True)
    board.store_post(xml, T0)
    board.store_post(Message(type="T", content="a < b"), T0 + MS)

    def got(**criteria: Any) -> list[str]:
        spec = RetrieveSpec(latest=0, **criteria)
        return [m.type for m in board.retrieve(spec, now_ns=T0)]

    assert got(content="hello world") == ["X"]  # OA-RET-13: text of the elements
    assert got(content="*<b>*") == []
    assert got(content="*<b>world</b>*", contentmatch=ContentMatch.XML) == ["X"]
    assert got(content='<a k="v">*', contentmatch=ContentMatch.XML) == ["X"]
    assert got(content="a < b") == ["T"]


@pytest.mark.parametrize(
    ("glob", "text", "hit"),
    [
        ("*tomato*", "green tomato", True),
        ("green*", "green tomato", True),
        ("Green*", "green tomato", False),  # case-sensitive
        ("gr?en*", "green tomato", False),  # `?` is literal (OA-RET-8)
        ("gr?en*", "gr?en tomato", True),
        ("a*b*c", "abc", True),
        ("ab*bc", "abc", False),  # prefix and suffix must not overlap
        ("*", "", True),
        ("", "", True),
        ("", "x", False),
        ("x", "x", True),
        ("[ab]", "a", False),
    ],
)
def test_content_glob(glob: str, text: str, hit: bool) -> None:
    assert content_glob(glob)(text) is hit


def test_text_of_plain_and_xml() -> None:
    assert text_of(Message(type="A", content="a&b")) == "a&b"
    xml = Message(type="A", content="<a>x<b>y</b>z</a><c>w</c>", content_is_xml=True)
    assert text_of(xml) == "xyzw"


def test_stored_copy_and_wbid() -> None:
    board = Whiteboard("WB1")
    posted = Message(type="A.B", sender="P", to="WB1", content="x", priority=3.0)
    copy = board.store_post(posted, T0 + 7 * MS)
    assert copy.stored == "WB1" and copy.wbid == 1  # OA-WB-4, OA-WB-5
    assert copy.received == AirTime.from_ns(T0 + 7 * MS)  # OA-TIME-3
    assert (copy.id, copy.type, copy.sender, copy.priority) == (
        posted.id,
        posted.type,
        posted.sender,
        posted.priority,
    )
    assert board.store_post(posted, T0 + 8 * MS).wbid == 2


def test_received_time_never_goes_back() -> None:
    board = Whiteboard("WB1")
    first = board.store_post(Message(type="A"), T0 + SEC)
    second = board.store_post(Message(type="A"), T0)  # the clock stepped back
    assert first.received is not None and second.received is not None
    assert second.received >= first.received  # OA-WB-12


def test_maxcount_evicts_oldest() -> None:
    board = _board(maxcount=4)  # OA-WB-6
    assert len(board) == 4
    assert [m.type for m in board.newest_first()] == ["Ret.A.8", "Ret.a.7", "Ret.A.6", "Ret.A.5"]
    assert board.evicted == len(EXAMPLE) - 4
    assert _types(board, pattern="Ret.A.1") == []
    assert board.next_wbid == len(EXAMPLE) + 1


def test_maxcount_evicts_from_store_in_batches() -> None:
    store = MemoryStore()
    board = Whiteboard("WB1", maxcount=100, store=store)
    for i in range(1000):
        board.store_post(Message(type="A"), T0 + i)
    kept = store.load("WB1")
    assert len(board) == 100
    # The store lags by less than one batch (maxcount // 8) and keeps the newest.
    assert 100 <= len(kept) < 100 + 100 // 8
    assert kept[-1].wbid == 1000


def test_latest_one_on_a_full_board_stops_early() -> None:
    board = Whiteboard("WB1", maxcount=10_000)
    for i in range(10_000):
        board.store_post(Message(type=f"Big.T{i % 50}"), T0 + i)
    found = board.retrieve(RetrieveSpec(pattern="Big.T7"), now_ns=T0)
    assert [m.wbid for m in found] == [9958]  # the newest T7: (10000 - 43) + 1
    # A lastmsec window below every receivedTime ends the scan at once and finds nothing.
    assert board.retrieve(RetrieveSpec(lastmsec=1, latest=0), now_ns=T0 + 10 * SEC) == []


def test_bad_maxcount() -> None:
    with pytest.raises(ValueError):
        Whiteboard("WB1", maxcount=0)
