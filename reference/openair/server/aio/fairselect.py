"""At most a few sockets of each peer address per loop turn (issue #19, fairness).

`fairness.Turns` bounds the time a peer address's reads take in one loop turn. Much of a flood's
work happens before or after any read: the end of stream of 600 connections closed at once,
their transports closed and forgotten, are 600 callbacks of one turn (15 ms here) that no
`data_received` sees, and a client from another address waits behind all of them.

`FairSelector` is the event loop's selector with one change: while sockets of more than one peer
address are registered, it hands the loop at most `per_peer` ready sockets of each address
(and the listening socket and the loop's own wake-up pipe always). The rest are still ready (epoll
is level-triggered), so they come back in the next poll, the next turn, and go first then: an
address's sockets take their turns round robin, none starves behind others that stay ready.
Nothing is lost or reordered on a connection — a socket's events are only postponed whole.
While every open connection comes from one address there is no one to be fair to, and the poll
is handed over as it is (a benchmark on one machine pays nothing). While the worker thread has
a job, the selector also opens `loopgate.LOOP_GATE` for the duration of each poll that waits.
`openair serve` runs on it unless `--fair-slice-ms 0` turns fairness off.
"""

from __future__ import annotations

import asyncio
import selectors
import weakref
from typing import Any

from openair.server.aio.loopgate import LOOP_GATE

__all__ = ["PER_PEER", "FairSelector", "fair_event_loop", "peer_of", "postponed_on"]

#: Sockets of one peer address handed to the loop per poll while other addresses are connected
#: (chosen on `make stress`: 16 and 8 let a flood's reads and closes make turns of 2-4 ms).
PER_PEER = 4


def peer_of(key: selectors.SelectorKey) -> str | None:
    """Return the peer address of an asyncio transport's socket; None for any other socket.

    asyncio registers a socket with `(reader handle, writer handle)` as its data; a transport's
    handle calls a bound method of the transport. The listening socket's and the wake-up
    pipe's handles call the loop's own methods: None, never held back.
    """
    data: Any = key.data
    if not isinstance(data, tuple):
        return None
    for handle in data:
        transport = getattr(getattr(handle, "_callback", None), "__self__", None)
        if isinstance(transport, asyncio.Transport):
            peer = transport.get_extra_info("peername")
            return str(peer[0]) if isinstance(peer, tuple) and peer else None
    return None


class FairSelector(selectors.EpollSelector):
    """An epoll selector that hands over at most `per_peer` ready sockets of each address."""

    def __init__(self, per_peer: int = PER_PEER) -> None:
        super().__init__()
        LOOP_GATE.enabled = True  # this loop opens the gate for the worker when it idles
        self.per_peer = per_peer
        self.postponed = 0  # socket events held back for a later poll, in all
        self._peer_of_fd: dict[int, str] = {}  # transports' sockets registered now
        self._sockets_of: dict[str, int] = {}  # how many of them per address
        self._owed: dict[int, int] = {}  # sockets the last poll postponed: polls waited

    @property
    def shared(self) -> bool:
        """Whether sockets of more than one peer address are registered (fairness applies)."""
        return len(self._sockets_of) > 1

    def close(self) -> None:
        super().close()
        LOOP_GATE.enabled = False  # no loop opens it now: the worker must not wait for one

    def register(self, fileobj: Any, events: int, data: Any = None) -> selectors.SelectorKey:
        key = super().register(fileobj, events, data)
        self._forget(key.fd)  # a socket whose failed `modify` unregistered it past us
        peer = peer_of(key)
        if peer is not None:
            self._peer_of_fd[key.fd] = peer
            self._sockets_of[peer] = self._sockets_of.get(peer, 0) + 1
        return key

    def unregister(self, fileobj: Any) -> selectors.SelectorKey:
        key = super().unregister(fileobj)
        self._forget(key.fd)
        return key

    def _forget(self, fd: int) -> None:
        peer = self._peer_of_fd.pop(fd, None)
        if peer is not None:
            left = self._sockets_of[peer] - 1
            if left:
                self._sockets_of[peer] = left
            else:
                del self._sockets_of[peer]

    def select(self, timeout: float | None = None) -> list[tuple[selectors.SelectorKey, int]]:
        gate = LOOP_GATE
        if gate.busy and timeout != 0:  # nothing else to do: the worker may run (loopgate)
            gate.polling()
            try:
                ready = super().select(timeout)
            finally:
                gate.polled()
        else:
            ready = super().select(timeout)
        if len(ready) <= self.per_peer or len(self._sockets_of) <= 1:
            if self._owed:
                self._owed = {}
            return ready  # nobody can be over the cap, or no one to be fair to
        owed = self._owed
        if owed:  # the longest postponed go first: no socket of an address starves
            ready.sort(key=lambda item: -owed.get(item[0].fd, 0))
        peers = self._peer_of_fd
        counts: dict[str, int] = {}
        kept: list[tuple[selectors.SelectorKey, int]] = []
        postponed: dict[int, int] = {}
        for key, events in ready:
            peer = peers.get(key.fd)
            if peer is None:
                kept.append((key, events))  # the listener, the wake-up pipe
                continue
            seen = counts.get(peer, 0)
            if seen < self.per_peer:
                counts[peer] = seen + 1
                kept.append((key, events))
            else:
                postponed[key.fd] = owed.get(key.fd, 0) + 1  # polls it has waited
        self._owed = postponed
        self.postponed += len(postponed)
        return kept


_SELECTORS: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, FairSelector] = (
    weakref.WeakKeyDictionary()
)


def fair_event_loop() -> asyncio.AbstractEventLoop:
    """A new event loop polling with `FairSelector` (`asyncio.Runner`'s loop factory)."""
    selector = FairSelector()
    loop = asyncio.SelectorEventLoop(selector)
    _SELECTORS[loop] = selector
    return loop


def postponed_on(loop: asyncio.AbstractEventLoop) -> int:
    """The socket events `loop`'s `FairSelector` postponed so far (0 on any other loop)."""
    selector = _SELECTORS.get(loop)
    return 0 if selector is None else selector.postponed
