"""History stores: memory and SQLite round trips, reopen, eviction, damage (OA-WB-3, OA-WB-9)."""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Any

import pytest

from openair.protocol.message import Message, Slot
from openair.protocol.times import AirTime
from openair.server.aio.stores import SqliteStore, open_store
from openair.server.core.store import HistoryStore, MemoryStore, StoreSpecError
from openair.server.core.whiteboard import Whiteboard


def _copy(wbid: int, *, board: str = "WB1", **fields: Any) -> Message:
    base: dict[str, Any] = {
        "type": f"Test.M{wbid}",
        "sender": "Poster",
        "to": board,
        "stored": board,
        "posted": AirTime(sec=1795328371, msec=wbid % 1000),
        "received": AirTime(sec=1795328372, msec=wbid % 1000),
        "wbid": wbid,
        "content": f"c{wbid}",
    }
    base.update(fields)
    return Message(**base)


def _stores(tmp_path: Path) -> list[HistoryStore]:
    return [MemoryStore(), SqliteStore(tmp_path / "h.db")]


@pytest.mark.parametrize("kind", ["memory", "sqlite"])
def test_round_trip_keeps_every_slot(tmp_path: Path, kind: str) -> None:
    store = MemoryStore() if kind == "memory" else SqliteStore(tmp_path / "h.db")
    rich = _copy(
        1,
        priority=0.5,
        cc="A;B",
        content="<x a='1'>t</x>",
        content_is_xml=True,
        language="xml",
        extras=(Slot(name="custom", value="v"),),
        binary=(b"\x00\x01", b"", b"zz"),
    )
    store.append("WB1", rich)
    store.append("WB1", _copy(2))
    store.append("WB2", _copy(1, board="WB2"))
    loaded = store.load("WB1")
    assert [m.wbid for m in loaded] == [1, 2]  # oldest first
    first = loaded[0]
    assert first.id == rich.id and first.cc == "A;B" and first.priority == 0.5
    assert first.binary == rich.binary
    assert first.extra("custom") == Slot(name="custom", value="v")
    assert first.received == rich.received and first.stored == "WB1"
    assert [m.wbid for m in store.load("WB2")] == [1]
    assert store.load("Nothing") == []
    store.close()


@pytest.mark.parametrize("kind", ["memory", "sqlite"])
def test_evict_deletes_through_wbid(tmp_path: Path, kind: str) -> None:
    store = MemoryStore() if kind == "memory" else SqliteStore(tmp_path / "h.db")
    for wbid in range(1, 6):
        store.append("WB1", _copy(wbid))
    store.append("WB2", _copy(1, board="WB2"))
    store.evict("WB1", 3)
    assert [m.wbid for m in store.load("WB1")] == [4, 5]
    assert [m.wbid for m in store.load("WB2")] == [1]  # other boards untouched
    store.close()


def test_sqlite_survives_reopen_and_is_durable(tmp_path: Path) -> None:
    path = tmp_path / "h.db"
    store = SqliteStore(path)
    assert store.durable
    store.append("WB1", _copy(1))
    # Without close(): as after a kill -9, a second connection sees the committed row.
    again = SqliteStore(path)
    assert [m.wbid for m in again.load("WB1")] == [1]
    again.close()
    store.close()
    assert not MemoryStore.durable


def test_sqlite_drops_damaged_rows(tmp_path: Path) -> None:
    path = tmp_path / "h.db"
    store = SqliteStore(path)
    store.append("WB1", _copy(1))
    store.append("WB1", _copy(2))
    store.close()
    with sqlite3.connect(path) as db:
        db.execute("UPDATE messages SET xml = x'3c6d65' WHERE wbid = 2")
    reopened = SqliteStore(path)
    assert [m.wbid for m in reopened.load("WB1")] == [1]
    assert reopened.dropped_on_load == 1
    assert [m.wbid for m in reopened.load("WB1")] == [1]  # the damaged row is gone
    reopened.close()


def test_sqlite_refuses_a_duplicate_wbid(tmp_path: Path) -> None:
    store = SqliteStore(tmp_path / "h.db")
    store.append("WB1", _copy(1))
    with pytest.raises(sqlite3.IntegrityError):
        store.append("WB1", _copy(1))
    store.close()


def test_not_a_database_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "garbage.db"
    path.write_bytes(b"this is not sqlite" * 100)
    with pytest.raises(sqlite3.DatabaseError):
        SqliteStore(path)


def test_append_needs_a_wbid(tmp_path: Path) -> None:
    for store in _stores(tmp_path):
        with pytest.raises(ValueError):
            store.append("WB1", Message(type="A"))


def test_open_store() -> None:
    assert isinstance(open_store("memory"), MemoryStore)
    for bad in ("", "sqlite", "sqlite:", "redis:x", "Memory"):
        with pytest.raises(StoreSpecError):
            open_store(bad)


def test_open_store_sqlite(tmp_path: Path) -> None:
    store = open_store(f"sqlite:{tmp_path / 'x.db'}")
    assert isinstance(store, SqliteStore) and store.durable
    store.close()


def test_whiteboard_continues_wbid_after_reopen(tmp_path: Path) -> None:
    path = tmp_path / "h.db"
    store = SqliteStore(path)
    board = Whiteboard("WB1", maxcount=3, store=store)
    for i in range(5):
        board.store_post(Message(type=f"T.{i}", to="WB1"), 1_000_000_000 * (i + 1))
    store.close()
    reopened = SqliteStore(path)
    again = Whiteboard("WB1", maxcount=3, store=reopened)  # OA-WB-9
    assert [m.wbid for m in again.newest_first()] == [5, 4, 3]  # trimmed to maxcount
    copy = again.store_post(Message(type="T.new", to="WB1"), 9_000_000_000)
    assert copy.wbid == 6  # OA-WB-5: the sequence continues
    assert [m.wbid for m in reopened.load("WB1")][-3:] == [4, 5, 6]
    reopened.close()


def test_whiteboard_refuses_when_the_store_fails() -> None:
    class Failing(MemoryStore):
        def append(self, whiteboard: str, msg: Message) -> None:
            raise OSError("disk full")

    from openair.protocol.errors import StoreFailedError

    board = Whiteboard("WB1", store=Failing())
    with pytest.raises(StoreFailedError, match="disk full"):
        board.store_post(Message(type="A", to="WB1"), 1)
    assert len(board) == 0 and board.next_wbid == 1  # nothing kept, wbid not used
