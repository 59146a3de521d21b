"""The server's side of a cluster's store (spec 17, issue #22).

The store's client runs on its own thread; what it hands over comes to the server's loop here:
copies other nodes stored (adopted, their wakeups decided, OA-CLU-4), modules of dead nodes
(their Lost notices, OA-CLU-7) and messages other nodes send to this node's modules (OA-CLU-8).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from openair.protocol.message import Message
from openair.server.core.store import HistoryStore, SequencedStore

if TYPE_CHECKING:
    from openair.server.core.config import ServerConfig
    from openair.server.core.outcome import Outcome
    from openair.server.core.router import Router

__all__ = ["ClusterNode", "join_cluster"]

log = logging.getLogger("openair.server")


class ClusterNode:
    """Hands what the cluster's store received over to the router, on the server's loop."""

    def __init__(
        self,
        store: SequencedStore,
        router: Callable[[], Router | None],
        apply: Callable[[Outcome, int], None],
    ) -> None:
        self.store = store
        self._router = router  # None before the router exists and once the server stopped
        self._apply = apply

    def announce(self) -> None:
        """Tell the other nodes which modules are bound here (OA-CLU-7)."""
        router = self._router()
        if router is not None:
            self.store.announce(router.bound_names())

    def adopt_stored(self) -> None:
        """Route the posts other cluster nodes stored to this node's modules (OA-CLU-4)."""
        self.store.notified()
        router = self._router()
        if router is None:
            return
        self._apply(router.adopt_stored(time.time_ns()), 0)
        self.store.announce(router.bound_names())
        lost = self.store.take_lost()  # OA-CLU-7: a dead node's modules
        if lost:
            outcome, failed = router.others_lost(lost, time.time_ns())
            self._apply(outcome, 0)
            self.store.lost_again(failed)  # the store was electing leaders: next beat

    def take_forwarded(self, msg: Message, taken: concurrent.futures.Future[bool]) -> None:
        """Queue a message another node sent to a module bound here (OA-CLU-8)."""
        router = self._router()
        outcome = router.forwarded(msg, time.time_ns()) if router is not None else None
        if outcome is not None:
            self._apply(outcome, 0)
        taken.set_result(outcome is not None)


def join_cluster(
    store: HistoryStore,
    config: ServerConfig,
    loop: asyncio.AbstractEventLoop,
    router: Callable[[], Router | None],
    apply: Callable[[Outcome, int], None],
) -> ClusterNode | None:
    """Join the cluster when `store` is a cluster's (before the whiteboards load from it);
    None for a lone server, which hosts placed whiteboards itself and says so (OA-CLU-6)."""
    if not isinstance(store, SequencedStore):
        for wb in config.whiteboards:
            if wb.host:
                log.warning("event=placement_ignored whiteboard=%s host=%s", wb.name, wb.host)
        return None
    node = ClusterNode(store, router, apply)

    def notify() -> None:  # called on the cluster client's thread
        loop.call_soon_threadsafe(node.adopt_stored)

    def accept(msg: Message) -> concurrent.futures.Future[bool]:  # the client's thread
        taken: concurrent.futures.Future[bool] = concurrent.futures.Future()
        loop.call_soon_threadsafe(node.take_forwarded, msg, taken)
        return taken

    store.accept_forwarded(accept)  # OA-CLU-8
    store.connect(config, notify)
    return node
