"""What the router decides: the deliveries to queue and the outcome of one event (spec 6.6).

`Outcome` is all the asyncio adapter learns from `Router`: replies in order (OA-SESS-2),
deliveries per module, connections to close, and the deferred replies and pushes of streams.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from openair.protocol.framing import Wire
from openair.protocol.message import Message
from openair.server.core.sessions import ConnId
from openair.server.core.streamservice import PendingWait, SamplePush, WaitReply

if TYPE_CHECKING:
    import concurrent.futures

__all__ = ["AwaitedReply", "Delivery", "Handler", "Outcome"]


@dataclass(frozen=True, slots=True, kw_only=True)
class Delivery:
    """A message to queue for one module (6.6): due at `due_ns`, ordered by priority (10)."""

    module: str
    message: Message
    due_ns: int
    priority: float  # the carried message's effective priority (OA-PRIO-1)
    wb_priority: float  # the sending whiteboard's priority (OA-PRIO-2)
    # The Message frame of `message` when the router already wrote it (a wakeup), else None.
    wire: Wire | None = field(default=None, compare=False, repr=False)
    expires_ns: int = 0  # OA-DELIV-14: dropped when still unsent at this time (0: never)
    # A wakeup's stored trigger message, for internal modules (OA-CONF-8: no XML to parse).
    trigger: Message | None = field(default=None, compare=False, repr=False)
    # A large wakeup still to be written (issue #19): `message` is then only its preview (the
    # envelope and PhaseSpec, `WakeupParts.preview`) and the adapter queues the delivery with
    # what `build()` returns, (message, wire), written off its event loop, in the module's order.
    build: Callable[[], tuple[Message, Wire | None]] | None = field(
        default=None, compare=False, repr=False
    )
    build_bytes: int = field(default=0, compare=False, repr=False)  # its text, at least


@dataclass(frozen=True, slots=True)
class AwaitedReply:
    """A reply that waits for a cluster node's store or another node (spec 17): a post until
    the store has it (OA-CLU-2), a message until the module's node queued it (OA-CLU-8).
    `reply(done, now_ns)` builds it, on the adapter's loop, once `done` is."""

    done: concurrent.futures.Future[int]
    reply: Callable[[concurrent.futures.Future[int], int], Message]


@dataclass(frozen=True, slots=True, kw_only=True)
class Outcome:
    """What the adapter does after one event.

    `discard_queues` names modules whose session ended (OA-SESS-15): drop their queued
    deliveries.
    """

    replies: tuple[Message, ...] = ()
    deliveries: tuple[Delivery, ...] = ()
    close_conns: tuple[ConnId, ...] = ()
    close_this: bool = False
    discard_queues: tuple[str, ...] = ()
    # Streams (spec 11): this request's reply is deferred (a WAIT_FOR_*, OA-STREAM-7); deferred
    # replies now ready, on any connection; samples to push (OA-STREAM-8, OA-STREAM-14); and the
    # stream this connection now receives pushes from (its Receive frame, 11.6).
    wait: PendingWait | None = None
    resolved: tuple[WaitReply, ...] = ()
    pushes: tuple[SamplePush, ...] = ()
    push_stream: str = ""
    # A reply too large to write on the event loop (issue #19, item 6): instead of `replies`,
    # a function that builds it and its frame on any thread. Only with `defer_large_replies`.
    later: Callable[[], tuple[Message, Wire | None]] | None = None
    # A cluster node's post or message to another node's module (spec 17): instead of
    # `replies`, the reply once the store or that node answered. Only with
    # `defer_store_replies`.
    awaited: AwaitedReply | None = None


#: A component command's handler: (connection, request, received_ns, now_ns) -> Outcome.
Handler = Callable[[ConnId, Message, int, int], Outcome]
