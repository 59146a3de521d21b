"""Budgets shared by every connection of a server: how many, from whom, how many bytes unfinished.

Issue #19: a limit per connection does not bound a server that takes any number of connections.
`Budget` counts open inbound connections, in total and per peer address (OA-LIM-11), and the
bytes of unfinished frames held across all connections (OA-LIM-12); the adapter asks it before
it keeps a connection or buffers more of a frame. `quiet_accept_errors` turns asyncio's
traceback per failed accept (EMFILE, ENFILE: out of file descriptors) into one log line per
interval; asyncio already waits a second before it accepts again.

Sans-I/O apart from the log: time comes in as seconds from the caller's clock.
"""

from __future__ import annotations

import asyncio
import errno
import logging
import sys
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

from openair.server.config import ServerLimits

__all__ = [
    "Budget",
    "RateLimitedLog",
    "off_loop_executor",
    "quiet_accept_errors",
    "return_large_buffers",
]

log = logging.getLogger("openair.server")

_LOG_INTERVAL_S = 10.0  # at most one line per kind of refusal in this time
_FD_ERRNOS = frozenset({errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM})


@dataclass(slots=True)
class RateLimitedLog:
    """One warning per `interval_s` for a repeated event, with the count since the last line."""

    event: str
    interval_s: float = _LOG_INTERVAL_S
    _last: float = field(default=-1e18)
    _since: int = 0

    def note(self, now_s: float, detail: str = "") -> bool:
        """Count one occurrence; log it when the interval has passed. Return whether it logged."""
        self._since += 1
        if now_s - self._last < self.interval_s:
            return False
        log.warning("event=%s count=%d %s", self.event, self._since, detail)
        self._last, self._since = now_s, 0
        return True


@dataclass(slots=True)
class Budget:
    """The server-wide counts of OA-LIM-11 and OA-LIM-12."""

    limits: ServerLimits
    connections: int = 0
    partial_bytes: int = 0
    refused_connections: int = 0
    refused_partial: int = 0
    _peers: dict[str, int] = field(default_factory=dict)
    _conn_log: RateLimitedLog = field(default_factory=lambda: RateLimitedLog("conn_refused"))

    def admit(self, peer: str, now_s: float) -> bool:
        """Count a new inbound connection from `peer`; False when it is one too many (OA-LIM-11).

        A refused connection is not counted: the caller closes it at once without `release`.
        """
        held = self._peers.get(peer, 0)
        limits = self.limits
        if self.connections >= limits.max_connections or held >= limits.max_connections_per_peer:
            self.refused_connections += 1
            why = "total" if self.connections >= limits.max_connections else "per_peer"
            self._conn_log.note(now_s, f"peer={peer} limit={why}")
            return False
        self.connections += 1
        self._peers[peer] = held + 1
        return True

    def release(self, peer: str) -> None:
        """Forget an admitted connection that ended (or was handed to the monitor)."""
        held = self._peers.get(peer, 0)
        if held <= 0:
            return
        self.connections -= 1
        if held == 1:
            del self._peers[peer]  # names of peers gone are not kept (issue #19, item 7)
        else:
            self._peers[peer] = held - 1

    def peers(self) -> int:
        """How many distinct peer addresses hold connections."""
        return len(self._peers)

    def hold_partial(self, delta: int) -> bool:
        """Change the unfinished-frame bytes by `delta`; False when growth passes OA-LIM-12.

        A refused growth is not counted: the caller drops the connection and releases what it
        held before.
        """
        if delta > 0 and self.partial_bytes + delta > self.limits.max_partial_bytes:
            self.refused_partial += 1
            return False
        self.partial_bytes = max(self.partial_bytes + delta, 0)
        return True

    def counters(self) -> dict[str, int]:
        """The budget's state for STATUS and the monitor."""
        return {
            "connections": self.connections,
            "peers": len(self._peers),
            "partial_bytes": self.partial_bytes,
            "refused_connections": self.refused_connections,
            "refused_partial": self.refused_partial,
        }


def quiet_accept_errors(
    loop: asyncio.AbstractEventLoop, clock: Callable[[], float]
) -> RateLimitedLog:
    """Log failed accepts for lack of descriptors once per interval, not as a traceback each.

    asyncio reports them through the loop's exception handler ("socket.accept() out of system
    resource") and retries after a second; other reports go to the handler in place before.
    """
    previous = loop.get_exception_handler()
    note = RateLimitedLog("accept_failed")

    def handler(lp: asyncio.AbstractEventLoop, context: dict[str, object]) -> None:
        exc = context.get("exception")
        if isinstance(exc, OSError) and exc.errno in _FD_ERRNOS:
            note.note(clock(), f"errno={errno.errorcode.get(exc.errno or 0, '?')}")
            return
        if previous is not None:
            previous(lp, context)
        else:
            lp.default_exception_handler(context)

    loop.set_exception_handler(handler)
    return note


_M_TRIM_THRESHOLD = -1  # glibc mallopt parameters (malloc.h)
_M_MMAP_THRESHOLD = -3
_MMAP_FROM = 256 * 1024


def return_large_buffers() -> bool:
    """Make glibc give large buffers back to the system when they are freed (issue #19).

    glibc raises its mmap threshold each time a large block is freed, after which frames and
    contents of a megabyte come from the heap and the heap's top cannot shrink past the live
    blocks above them: a burst of large posts kept the server's RSS high long after it was
    gone. A fixed threshold serves every buffer of 256 KiB or more by mmap, unmapped on free.
    Returns False where this is not glibc (nothing changes).
    """
    try:
        import ctypes  # only here: the rest of the server has no use for it

        libc = ctypes.CDLL("libc.so.6")
        ok = int(libc.mallopt(_M_MMAP_THRESHOLD, _MMAP_FROM)) == 1
        return ok and int(libc.mallopt(_M_TRIM_THRESHOLD, 4 * _MMAP_FROM)) == 1
    except (OSError, AttributeError):
        return False


_OFF_LOOP: list[ThreadPoolExecutor] = []
_SWITCH_S = 0.0005


def off_loop_executor() -> ThreadPoolExecutor:
    """The one worker thread that decodes large requests and writes large replies (issue #19).

    One, not one per core: the writing holds the interpreter lock most of the time, and the
    event loop waits for that lock behind every thread that wants it (up to the 5 ms switch
    interval each), so each more worker lengthens every other client's turn; one also bounds
    the memory of the large requests and replies in progress to one at a time.
    """
    if not _OFF_LOOP:
        # The loop waits for the lock at most this long after asking (5 ms by default): the
        # worker's share of a second barely changes, every other client's wait falls.
        sys.setswitchinterval(_SWITCH_S)
        # Not at a lower scheduling priority: a worker preempted while it holds the lock would
        # keep the loop waiting for as long as the system leaves it off the processor.
        _OFF_LOOP.append(ThreadPoolExecutor(max_workers=1, thread_name_prefix="openair-large"))
    return _OFF_LOOP[0]
