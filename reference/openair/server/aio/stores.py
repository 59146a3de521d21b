"""Durable history in SQLite, and `open_store`: the store a `--store` spec names (OA-WB-9).

SQLite runs in WAL mode with `synchronous=NORMAL`: a commit survives a crash of the process
(kill -9) at once, and a power loss once the WAL is checkpointed. The store is used from one
thread at a time. `open_store` lives here, not in the sans-I/O core, because it opens files and
imports the optional cluster store (issue #17: no core -> cluster import).
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

from openair.protocol.codec import decode_message, to_frame
from openair.protocol.framing import binary_sizes
from openair.protocol.message import Message
from openair.server.core.store import (
    HistoryStore,
    MemoryStore,
    SequencedStore,
    StoreSpecError,
    _check_wbid,
)

__all__ = ["SqliteStore", "open_store"]


_SCHEMA = """
CREATE TABLE IF NOT EXISTS messages (
    whiteboard TEXT NOT NULL,
    wbid INTEGER NOT NULL,
    xml BLOB NOT NULL,
    binary BLOB NOT NULL DEFAULT x'',
    PRIMARY KEY (whiteboard, wbid)
) WITHOUT ROWID
"""


class SqliteStore:
    """A durable store in one SQLite file (extension `durable`, OA-WB-9).

    One table keyed by (whiteboard, wbid) holds each copy's canonical XML (`codec`) and its
    binary chunks. Rows that no longer decode (a damaged file) are dropped when loaded, so the
    whiteboard can continue the wbid sequence of what remains.
    """

    durable = True

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.dropped_on_load = 0
        # isolation_level=None: explicit transactions, so each append is exactly one commit.
        self._db = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False)
        try:
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._db.execute(_SCHEMA)
            # A file that has a `messages` table of another shape fails here, not at load.
            self._db.execute("SELECT whiteboard, wbid, xml, binary FROM messages LIMIT 1")
        except sqlite3.DatabaseError:
            self._db.close()
            raise

    def __repr__(self) -> str:
        return f"SqliteStore({str(self.path)!r})"

    def load(self, whiteboard: str) -> list[Message]:
        rows = self._db.execute(
            "SELECT wbid, xml, binary FROM messages WHERE whiteboard = ? ORDER BY wbid",
            (whiteboard,),
        ).fetchall()
        loaded: list[Message] = []
        broken: list[int] = []
        for wbid, xml, binary in rows:
            msg = _decode(bytes(xml), bytes(binary))
            if msg is None or msg.wbid != wbid:
                broken.append(wbid)
            else:
                loaded.append(msg)
        if broken:
            self._delete(whiteboard, broken)
        return loaded

    def append(self, whiteboard: str, msg: Message) -> None:
        wbid = _check_wbid(msg)
        frame = to_frame(msg)
        # The implicit transaction of one INSERT in autocommit mode is committed on return.
        self._db.execute(
            "INSERT INTO messages (whiteboard, wbid, xml, binary) VALUES (?, ?, ?, ?)",
            (whiteboard, wbid, frame.xml, b"".join(frame.chunks)),
        )

    def evict(self, whiteboard: str, through_wbid: int) -> None:
        self._db.execute(
            "DELETE FROM messages WHERE whiteboard = ? AND wbid <= ?", (whiteboard, through_wbid)
        )

    def close(self) -> None:
        self._db.close()

    def _delete(self, whiteboard: str, wbids: list[int]) -> None:
        self.dropped_on_load += len(wbids)
        self._db.executemany(
            "DELETE FROM messages WHERE whiteboard = ? AND wbid = ?",
            [(whiteboard, w) for w in wbids],
        )


def _decode(xml: bytes, binary: bytes) -> Message | None:
    """Decode one stored row, or return None when it no longer decodes."""
    try:
        sizes = binary_sizes(xml)
        if sum(sizes) != len(binary):
            return None
        chunks: list[bytes] = []
        pos = 0
        for size in sizes:
            chunks.append(binary[pos : pos + size])
            pos += size
        return decode_message(xml, tuple(chunks))
    except Exception:  # a damaged row: any decoding failure means "drop it"
        return None


def open_store(spec: str) -> HistoryStore:
    """Open the store named by `spec`: `memory`, or `sqlite:PATH` (durable)."""
    if spec == "memory":
        return MemoryStore()
    kind, sep, path = spec.partition(":")
    if kind == "sqlite" and sep and path:
        return _open_sqlite(Path(path))
    if kind == "cluster" and sep and path:  # `cluster:NODE@nats://HOST:PORT[,...]` (spec 17)
        from openair.cluster import open_cluster_store  # optional: nats-py is an extra

        store = open_cluster_store(path)
        assert isinstance(store, SequencedStore)
        return store
    raise StoreSpecError(f"unknown store {spec!r}: use 'memory' or 'sqlite:PATH'")


def _open_sqlite(path: Path) -> SqliteStore:
    """Open a SQLite store, saying in one line why it cannot be opened (StoreSpecError)."""
    if path.is_dir():
        raise StoreSpecError(f"cannot open the store {str(path)!r}: it is a directory")
    if not path.parent.is_dir():
        where = str(path.parent)
        raise StoreSpecError(f"cannot open the store {str(path)!r}: no directory {where!r}")
    try:
        return SqliteStore(path)
    except sqlite3.Error as exc:  # not a database, a locked or unreadable file, …
        raise StoreSpecError(f"cannot open the store {str(path)!r}: {exc}") from None
