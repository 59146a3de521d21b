"""Whiteboard history stores: the interface and the memory store (OA-WB-3, OA-WB-9).

A store holds the stored copies of every whiteboard, keyed by (whiteboard, wbid). The whiteboard
keeps its own copy in memory for routing and retrieves; the store is what survives a restart.
`append` returns only once the copy is written (for SQLite, committed), so a post is never
acknowledged before it is stored (OA-WB-3, OA-ERR-5).

The durable SQLite store and `open_store`, which picks memory, SQLite or a cluster store from
a `--store` spec, are in `openair.server.aio.stores`: they open files and other packages.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from openair.protocol.message import Message

if TYPE_CHECKING:
    import concurrent.futures

    from openair.server.core.config import ServerConfig

__all__ = [
    "HistoryStore",
    "MemoryStore",
    "SequencedStore",
    "StoreSpecError",
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

    def publish_soon(self, whiteboard: str, msg: Message) -> concurrent.futures.Future[int]:
        """Store one copy without blocking: it comes back through `take`, and the future gets
        the wbid once it is stored (durable and replicated) and back, or the failure."""
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

    def accept_forwarded(
        self, accept: Callable[[Message], concurrent.futures.Future[bool]]
    ) -> None:
        """How this server queues a message another server sends to one of its modules."""
        ...

    def forward_soon(self, msg: Message) -> concurrent.futures.Future[int] | None:
        """Send a message to the server its addressee module is bound to (the future fails
        when that server does not take it); None when no other server holds the module."""
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


def _check_wbid(msg: Message) -> int:
    if msg.wbid is None:
        raise ValueError("a stored copy must carry its wbid")
    return msg.wbid
