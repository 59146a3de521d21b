"""Which cluster nodes live and which modules each holds (spec 17, OA-CLU-7, issue #22).

Each node publishes (plain NATS, no JetStream) its bound module names every `BEAT_S` and at
once on a change; a node not heard for `DEAD_S` is dead, and the live node whose name sorts
first posts `Psyclone.Module.Lost.<name>` for its modules (retried at the next beat when the
store was electing leaders). Runs on the cluster client's loop; the server reads it from its
own thread (`take_lost`, `lost_again`, `announce`).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import threading
import time
from collections.abc import Callable, Coroutine
from typing import Any

__all__ = ["BEAT_S", "DEAD_S", "SUBJECT", "Liveness"]

SUBJECT = "openair.node."  # heartbeats: the node's name in hex, its bound modules as JSON
BEAT_S = 0.5
DEAD_S = 3.0  # a node not heard for this long is dead (OA-CLU-7)

log = logging.getLogger("openair.cluster")


class Liveness:
    """The heartbeats of one node and what it heard of the others."""

    def __init__(
        self,
        node: str,
        spawn: Callable[[Coroutine[Any, Any, None]], None],
        notify: Callable[[], Callable[[], None] | None],
    ) -> None:
        self.node = node
        self._spawn = spawn  # runs a coroutine on the client's loop
        self._notify = notify  # the server's "copies (or notices) to take" callback, if any
        self._lock = threading.Lock()
        self._nc: Any = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._announced: tuple[str, ...] = ()
        self._peers: dict[str, tuple[float, tuple[str, ...]]] = {}  # node -> (heard, modules)
        self._holders: dict[str, str] = {}  # module -> the other node it is bound to
        self._lost: list[str] = []
        self._retry: list[str] = []  # Lost notices that failed, taken again at the next beat

    async def start(self, nc: Any) -> None:
        """Listen to the other nodes and start beating (on the client's loop)."""
        self._nc = nc
        self._loop = asyncio.get_running_loop()
        await nc.subscribe(SUBJECT + ">", cb=self._heard)
        self._spawn(self._heartbeat())

    def announce(self, modules: tuple[str, ...]) -> None:
        """Say which modules are bound to this node (called by the server, any thread).

        A change is published at once, not only with the next heartbeat.
        """
        if modules == self._announced:
            return
        self._announced = modules
        loop = self._loop
        if loop is not None and self._nc is not None:
            payload = json.dumps(list(modules)).encode()
            loop.call_soon_threadsafe(self._spawn, self._publish_beat(payload))

    def holder(self, module: str) -> str | None:
        """The other live node `module` is bound to, as last heard (None: none)."""
        return self._holders.get(module)

    def others(self) -> list[str]:
        """The other nodes heard from and not declared dead, by name."""
        return sorted(self._peers)

    def take_lost(self) -> list[str]:
        """The modules of nodes found dead since the last call, for this node to post Lost."""
        with self._lock:
            lost, self._lost = self._lost, []
        return lost

    def lost_again(self, modules: list[str]) -> None:
        if modules:
            with self._lock:
                self._retry.extend(modules)

    async def _publish_beat(self, payload: bytes) -> None:
        with contextlib.suppress(Exception):
            await self._nc.publish(SUBJECT + self.node.encode().hex(), payload)

    async def _heartbeat(self) -> None:
        """Every `BEAT_S`, tell the other nodes this one lives and which modules it holds;
        declare dead a node not heard for `DEAD_S` (its modules' Lost is posted once, by the
        live node whose name sorts first)."""
        while True:
            await self._publish_beat(json.dumps(list(self._announced)).encode())
            with self._lock:
                retry, self._retry = self._retry, []
                self._lost.extend(retry)
            if retry:
                self._wake()
            now = time.monotonic()
            dead = [n for n, (seen, _) in self._peers.items() if now - seen > DEAD_S]
            alive = sorted([self.node, *(n for n in self._peers if n not in dead)])
            for node in dead:
                _, modules = self._peers.pop(node)
                self._index()
                log.warning("event=cluster_node_dead node=%s modules=%d", node, len(modules))
                if alive[0] == self.node and modules:
                    with self._lock:
                        self._lost.extend(modules)
                    self._wake()
            await asyncio.sleep(BEAT_S)

    def _wake(self) -> None:
        notify = self._notify()
        if notify is not None:
            notify()

    async def _heard(self, msg: Any) -> None:
        node = bytes.fromhex(msg.subject[len(SUBJECT) :]).decode(errors="replace")
        if node == self.node:
            return
        try:
            modules = tuple(str(m) for m in json.loads(msg.data))
        except ValueError:
            return
        known = self._peers.get(node)
        self._peers[node] = (time.monotonic(), modules)
        if known is None or known[1] != modules:
            self._index()

    def _index(self) -> None:
        # A name bound on several nodes: the node whose name sorts first (spec 17.2).
        peers = sorted(self._peers.items(), reverse=True)
        self._holders = {m: node for node, (_, ms) in peers for m in ms}
