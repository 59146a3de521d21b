"""Whiteboard history stores: in memory, or durable in SQLite (OA-WB-3, OA-WB-9).

A store holds the stored copies of every whiteboard, keyed by (whiteboard, wbid). The whiteboard
keeps its own copy in memory for routing and retrieves; the store is what survives a restart.
`append` returns only once the copy is written (for SQLite, committed), so a post is never
acknowledged before it is stored (OA-WB-3, OA-ERR-5).

SQLite runs in WAL mode with `synchronous=NORMAL`: a commit survives a crash of the process
(kill -9) at once, and a power loss once the WAL is checkpointed. The store is used from one
thread at a time.
"""

from __future__ import annotations

import sqlite3
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from openair.codec import decode_message, to_frame
from openair.framing import binary_sizes
from openair.message import Message

if TYPE_CHECKING:
    from openair.server.config import ServerConfig

__all__ = [
    "HistoryStore",
    "MemoryStore",
    "SequencedStore",
    "SqliteStore",
    "StoreSpecError",
    "open_store",
]


@runtime_checkable
class HistoryStore(Protocol):
    """Where whiteboards keep their stored copies."""

    durable: bool

    def load(self, whiteboard: str) -> list[Message]:
        """Return the stored copies of `whiteboard`, oldest first (by wbid)."""
        ...

    def append(self, whiteboard: str, msg: Message) -> None:
        """Store one copy (its `wbid` set); durable on return when `durable`."""
        ...

    def evict(self, whiteboard: str, through_wbid: int) -> None:
        """Forget every copy of `whiteboard` whose wbid is at most `through_wbid`."""
        ...

    def close(self) -> None:
        """Release the store; later calls are errors."""
        ...


@runtime_checkable
class SequencedStore(HistoryStore, Protocol):
    """A store that numbers the posts itself, shared by several servers (a cluster, spec 17).

    `publish` stores one copy and returns the wbid the store gave it (durable, and replicated,
    on return: OA-CLU-2); `take` hands over, in wbid order, the copies of `whiteboard` that
    other servers stored and this one has not adopted yet (up to `through` when given);
    `sync` waits until every copy stored before the call can be taken (OA-CLU-3).
    """

    def publish(self, whiteboard: str, msg: Message) -> int:
        """Store one copy (its wbid is ignored) and return the wbid it was stored under."""
        ...

    def publish_later(self, whiteboard: str, msg: Message) -> None:
        """Store one copy without waiting: it comes back through `take` (a noreply post)."""
        ...

    def take(self, whiteboard: str, through: int | None = None) -> list[Message]:
        """Return the copies stored since the last take, oldest first, their wbid set."""
        ...

    def sync(self, whiteboard: str) -> None:
        """Wait until every copy of `whiteboard` stored so far can be taken."""
        ...

    def connect(self, config: ServerConfig, notify: Callable[[], None] | None = None) -> None:
        """Join the shared store; `notify` (from any thread) says copies can be taken."""
        ...

    def notified(self) -> None:
        """The server took the notice: the next copies that arrive notify again."""
        ...

    def announce(self, modules: tuple[str, ...]) -> None:
        """Tell the other servers which modules are bound to this one."""
        ...

    def take_lost(self) -> list[str]:
        """Modules of servers found dead, whose Lost notices this server posts (OA-CLU-7)."""
        ...

    def lost_again(self, modules: list[str]) -> None:
        """Hand back modules whose Lost notice could not be stored, to be taken again later."""
        ...


class StoreSpecError(ValueError):
    """A store specification that `open_store` does not understand, or a store it cannot open."""


class MemoryStore:
    """A store that lives as long as the process (no `durable` extension)."""

    durable = False

    def __init__(self) -> None:
        self._boards: dict[str, deque[Message]] = {}
        self._closed = False

    def __repr__(self) -> str:
        return f"<MemoryStore: {sum(map(len, self._boards.values()))} messages>"

    def load(self, whiteboard: str) -> list[Message]:
        self._check()
        return list(self._boards.get(whiteboard, ()))

    def append(self, whiteboard: str, msg: Message) -> None:
        self._check()
        _check_wbid(msg)
        board = self._boards.get(whiteboard)
        if board is None:
            board = self._boards[whiteboard] = deque()
        board.append(msg)

    def evict(self, whiteboard: str, through_wbid: int) -> None:
        self._check()
        board = self._boards.get(whiteboard)
        while board and (board[0].wbid or 0) <= through_wbid:
            board.popleft()

    def close(self) -> None:
        self._closed = True

    def _check(self) -> None:
        if self._closed:
            raise RuntimeError("the store is closed")


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


def _check_wbid(msg: Message) -> int:
    if msg.wbid is None:
        raise ValueError("a stored copy must carry its wbid")
    return msg.wbid


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
