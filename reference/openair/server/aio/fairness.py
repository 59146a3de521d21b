"""Each peer address gets a bounded slice of every loop turn (issue #19, fairness).

The event loop runs every ready callback of a turn before it looks at the sockets again, so a
client that makes many callbacks ready at once — a hundred connections binding together, forty
connections each sending a quarter of a megabyte, a read of a thousand pipelined posts — keeps
everybody else waiting for all of them. `Turns` counts the processor time the connections of
each peer address spend in the current turn. Once a peer has spent its slice, its connections
stop taking frames: each pauses reading, keeps what it read, and waits in its peer's queue. At
the start of the next turn the waiting peers are served round robin, each again up to its
slice. A peer that has not spent its slice is served at once, so a client from another address
waits for at most about one slice of the busy peer's work, not for all of it. While every open
connection comes from one address there is no one to be fair to: nothing waits then.

Frames are still acted on in the order they arrived on each connection (OA-SESS-2): a waiting
connection reads nothing more until its turn comes. The slice is `openair serve
--fair-slice-ms` (0: off). The clock is the wall clock (`time.perf_counter`, tens of
nanoseconds a reading; the thread's CPU clock costs a microsecond, as much as a small post):
a peer is charged for the time the process was preempted while serving it, which only makes
its slice end sooner.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections import deque
from collections.abc import Callable

from openair.server.aio.fairselect import postponed_on

__all__ = ["READ_COST_S_PER_BYTE", "Turns"]

#: What reading a byte costs the loop before the protocol sees it (measured: 256 KiB ~0.2 ms).
READ_COST_S_PER_BYTE = 0.8e-9


class Turns:
    """Processor time spent per peer address in the current loop turn, and who waits."""

    def __init__(
        self,
        slice_s: float,
        call_soon: Callable[[Callable[[], None]], object],
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        self.slice = slice_s
        #: Seconds charged per byte read: the kernel's copy and the transport's work happen
        #: before `data_received` and cannot be timed there (~0.2 ms for a 256 KiB read here).
        self.read_cost = READ_COST_S_PER_BYTE
        self.clock = clock
        self._call_soon = call_soon
        self._spent: dict[str, float] = {}
        #: Waiting connections (their resume callbacks) by peer; insertion order: round robin.
        self._waiting: dict[str, deque[Callable[[], None]]] = {}
        self._turn_scheduled = False
        self.deferred = 0  # times a connection had to wait for a later turn (STATUS, monitor)
        #: Open connections per peer address: with one address there is no one to be fair to,
        #: and nothing is counted or deferred (a benchmark on one machine pays nothing).
        self._peers: dict[str, int] = {}

    def enter(self, peer: str) -> None:
        """Count a connection from `peer` opened."""
        self._peers[peer] = self._peers.get(peer, 0) + 1

    def leave(self, peer: str) -> None:
        """Count a connection from `peer` closed."""
        left = self._peers.get(peer, 0) - 1
        if left > 0:
            self._peers[peer] = left
        else:
            self._peers.pop(peer, None)

    @property
    def shared(self) -> bool:
        """Whether connections from more than one address are open (fairness applies)."""
        return len(self._peers) > 1

    def deadline(self, peer: str) -> float:
        """Return the `clock` time at which `peer`'s slice of this turn runs out."""
        if not self.shared:
            return math.inf
        return self.clock() + self.slice - self._spent.get(peer, 0.0)

    def may_run(self, peer: str) -> bool:
        """Whether `peer` may act now: nothing of it waits, and its slice is not spent."""
        if peer in self._waiting:
            return False
        return not self.shared or self._spent.get(peer, 0.0) < self.slice

    def charge(self, peer: str, seconds: float) -> None:
        """Count `seconds` of work for `peer` in this turn."""
        self._spent[peer] = self._spent.get(peer, 0.0) + seconds
        self._next_turn()

    def wait(self, peer: str, resume: Callable[[], None]) -> None:
        """Queue `resume` to run in a later turn, after what `peer` queued before it."""
        self.deferred += 1
        self._waiting.setdefault(peer, deque()).append(resume)
        self._next_turn()

    @staticmethod
    def counters_of(turns: Turns | None) -> dict[str, object]:
        """STATUS's `fairness` counters: the slice, the waits so far, the waiting now, and the
        socket events the loop's `FairSelector` postponed (0 when the loop has none)."""
        try:
            postponed = postponed_on(asyncio.get_running_loop())  # the selector's (fairselect)
        except RuntimeError:  # not on the server's loop
            postponed = 0
        if turns is None:
            return {"slice_ms": 0, "deferred": 0, "waiting": 0, "postponed": postponed}
        return {
            "slice_ms": turns.slice * 1000,
            "deferred": turns.deferred,
            "waiting": turns.waiting,
            "postponed": postponed,
        }

    @property
    def waiting(self) -> int:
        """How many connections wait for a turn."""
        return sum(map(len, self._waiting.values()))

    def _next_turn(self) -> None:
        # A callback scheduled now runs at the start of the next loop turn, before the events
        # of that turn's sockets: the right moment to start counting again.
        if not self._turn_scheduled:
            self._turn_scheduled = True
            self._call_soon(self._turn)

    def _turn(self) -> None:
        """A new turn: forget what was spent, then serve the waiting peers round robin."""
        self._turn_scheduled = False
        self._spent.clear()
        spent = self._spent
        for peer in list(self._waiting):
            queue = self._waiting[peer]
            while queue and spent.get(peer, 0.0) < self.slice:
                # Each resume charges itself (with the read it lets happen next) and may queue
                # itself again when the peer's slice ran out inside it: behind its peer's others.
                queue.popleft()()
            if not queue:
                del self._waiting[peer]
        if self._waiting:
            self._next_turn()
