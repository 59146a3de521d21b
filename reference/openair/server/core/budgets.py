"""Budgets shared by every connection of a server: how many, from whom, how many bytes unfinished.

Issue #19: a limit per connection does not bound a server that takes any number of connections.
`Budget` counts open inbound connections, in total and per peer address (OA-LIM-11), and the
bytes of unfinished frames held across all connections (OA-LIM-12); the adapter asks it before
it keeps a connection or buffers more of a frame. The asyncio parts (accept errors, the
off-loop worker, glibc's buffer threshold) are in `openair.server.aio.budgets`.

Sans-I/O apart from the log: time comes in as seconds from the caller's clock.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from openair.server.core.config import ServerLimits

__all__ = [
    "Budget",
    "RateLimitedLog",
]

log = logging.getLogger("openair.server")

_LOG_INTERVAL_S = 10.0  # at most one line per kind of refusal in this time


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
