"""Messages to a module bound on another node (spec 17, OA-CLU-8, issue #22).

A message addressed to a module (OA-SESS-22) that is bound to another node of the cluster is
sent to that node as a NATS request on `openair.fwd.<hex of the node's name>`; the node queues
it for its module as it would one sent to it, and answers `1`, or `0` when the module is not
bound there. The node the heartbeats (liveness.py) name as the holder is asked first; the other
live nodes are asked in turn when it says `0` or does not answer (a module that bound a moment
ago is not in the heartbeats yet), so the message is queued once, by the first node holding the
module. The sending node then answers its requester RECEIVE_ACCEPT, or FORWARD_FAILED when no
node took it.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
from collections.abc import Callable
from typing import Any

from openair.cluster.wire import decode_payload, encode_copy
from openair.protocol.message import Message

__all__ = ["SUBJECT", "ForwardRefusedError", "Forwarding"]

SUBJECT = "openair.fwd."
_ASK_S = 2.0  # how long one node may take to say whether it holds a module
log = logging.getLogger("openair.cluster")

#: The server's side: queue a forwarded message for a module bound to it; the future says
#: whether one was (set on the server's loop).
Accept = Callable[[Message], "concurrent.futures.Future[bool]"]


class ForwardRefusedError(Exception):
    """The other node did not take the message: the module is not bound there."""


class Forwarding:
    """Sends messages to other nodes' modules and takes theirs for this node's (client loop)."""

    def __init__(self, node: str, timeout_s: float) -> None:
        self.node = node
        self.timeout_s = timeout_s
        self.accept: Accept | None = None  # set by the server before the cluster is joined
        self.sent = 0
        self.received = 0
        self._nc: Any = None

    async def start(self, nc: Any) -> None:
        self._nc = nc
        await nc.subscribe(SUBJECT + self.node.encode().hex(), cb=self._serve)

    async def send(self, nodes: list[str], msg: Message) -> int:
        """Have the first of `nodes` that holds `msg.to` queue it; raise when none does."""
        payload = encode_copy(msg)
        for node in nodes:
            try:
                reply = await self._nc.request(
                    SUBJECT + node.encode().hex(), payload, timeout=min(self.timeout_s, _ASK_S)
                )
            except Exception:  # a node dying or too busy to answer: ask the next
                continue
            if reply.data == b"1":
                self.sent += 1
                return 1
        raise ForwardRefusedError(f"no node holds {msg.to}")

    async def _serve(self, request: Any) -> None:
        msg = decode_payload(request.data)
        taken = False
        accept = self.accept
        if msg is not None and accept is not None:
            try:
                taken = await asyncio.wait_for(asyncio.wrap_future(accept(msg)), self.timeout_s)
            except Exception as exc:  # the server is shutting down, or too slow to say
                log.warning("event=cluster_forward_failed to=%s detail=%r", msg.to, str(exc))
        if taken:
            self.received += 1
        await request.respond(b"1" if taken else b"0")
