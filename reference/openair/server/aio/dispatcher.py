"""Every module's delivery queue and task, and the timing they share (spec 6.6, section 10).

`Dispatcher` holds one `ModuleDelivery` (delivery.py) per module: it queues the router's
deliveries and stream samples, drops per OA-DELIV-9 when a queue is full, waits for the queues
to drain at shutdown (OA-SESS-24) and counts per module. `DeliveryOptions` is the delivery
timing; `DeliveryHost` what the dispatcher needs from the server.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Protocol

from openair.server.aio.delivery import ModuleDelivery
from openair.server.aio.protocol import ServerConnection
from openair.server.aio.scheduling import DEFAULT_TURN_BUDGET, TurnGate
from openair.server.aio.wakeupbuilds import Builds
from openair.server.core.queues import ByteTally, QueueItem
from openair.server.core.router import Delivery, ModuleInfo
from openair.server.core.streamspec import StoredSample

__all__ = ["DeliveryHost", "DeliveryOptions", "Dispatcher"]

log = logging.getLogger("openair.server")


@dataclass(frozen=True, slots=True, kw_only=True)
class DeliveryOptions:
    """Timing of deliveries: acknowledgement deadline, retries and their back-off (seconds)."""

    deadline_s: float = 10.0  # OA-DELIV-11
    retries: int = 2  # OA-DELIV-7
    backoff_s: tuple[float, ...] = (0.05, 0.25)
    connect_timeout_s: float = 5.0
    turn_budget: int = DEFAULT_TURN_BUDGET  # OA-PRIO-5: deliveries started per loop turn


class DeliveryHost(Protocol):
    """What the dispatcher needs from the server."""

    def module_info(self, name: str) -> ModuleInfo | None:
        """The router's view of a module (None when it is unknown)."""

    def connection(self, conn_id: int) -> ServerConnection | None:
        """The open connection with this id, if any."""

    def connect(self, module: str, address: str, port: int) -> Awaitable[ServerConnection]:
        """Open an OUTBOUND connection to a module's listening port."""

    def delivered(self, module: str, count: int) -> None:
        """Report acknowledged deliveries (for the router's counters)."""

    def dropped(self, module: str, count: int, reason: str) -> None:
        """Report deliveries dropped (QUEUE_OVERFLOW) or abandoned (DELIVERY_FAILED)."""


class Dispatcher:
    """Every module's delivery queue and task."""

    def __init__(
        self,
        host: DeliveryHost,
        *,
        capacity: int,
        max_in_flight: int,
        options: DeliveryOptions | None = None,
        max_queue_bytes: int = 0,
        push_buffer_bytes: int = 0,
    ) -> None:
        self.host = host
        self.capacity = capacity
        self.max_queue_bytes = max_queue_bytes  # OA-LIM-8: 0 = no byte bound
        self.push_buffer_bytes = push_buffer_bytes  # OA-LIM-16: per subscribed stream
        self.max_in_flight = max_in_flight
        self.options = options or DeliveryOptions()
        self.modules: dict[str, ModuleDelivery] = {}
        self.tally = ByteTally()  # what every module's queue holds (OA-LIM-14)
        self.gate = TurnGate(self.options.turn_budget)  # whiteboard priority across modules
        self._idle_waiters: list[asyncio.Future[None]] = []
        self.on_drop: Callable[[str, QueueItem], None] | None = None
        #: Called with (module, item) for each acknowledged delivery: the monitor's latency tap.
        self.on_delivered: Callable[[str, QueueItem], None] | None = None
        self.builds = Builds(self._queue, self._build_failed)  # large wakeups (issue #19)

    def push(self, delivery: Delivery) -> None:
        """Queue a delivery for its module, dropping per OA-DELIV-9 when the queue is full.

        A large wakeup is written on the worker first, and the module's later deliveries wait
        behind it (`wakeupbuilds.Builds`, issue #19). One the module's task would send at once
        goes out without the queue (`ModuleDelivery.send_now`, issue #20).
        """
        if self.builds.offer(delivery):
            return
        md = self.modules.get(delivery.module)
        if md is None or not md.send_now(delivery):  # issue #20: straight out when it can
            self._queue(delivery)

    def _queue(self, delivery: Delivery) -> None:
        md = self.modules.get(delivery.module)
        if md is None:
            md = self.modules[delivery.module] = ModuleDelivery(delivery.module, self)
        victims = md.push(delivery)
        if victims:
            self.host.dropped(delivery.module, len(victims), "QUEUE_OVERFLOW")
            dropped = md.queue.counters.dropped
            if dropped == len(victims) or dropped // 1000 != (dropped - len(victims)) // 1000:
                log.warning(
                    "event=overflow_drop module=%s dropped_total=%d priority=%g queue_bytes=%d",
                    delivery.module,
                    dropped,
                    victims[-1].priority,
                    md.queue.held_bytes,
                )

    def _build_failed(self, module: str) -> None:
        self.host.dropped(module, 1, "DELIVERY_FAILED")
        self.idle_check()

    def push_sample(self, module: str, stream: str, sample: StoredSample, capacity: int) -> None:
        """Buffer a stream sample for a subscribed module (OA-STREAM-8, OA-STREAM-14)."""
        md = self.modules.get(module)
        if md is None:
            md = self.modules[module] = ModuleDelivery(module, self)
        dropped = md.push_sample(stream, sample, capacity)
        if dropped:
            self.host.dropped(module, dropped, "SAMPLE_DROPPED")

    def poke(self, module: str) -> None:
        """Tell a module's task that its paths may have changed."""
        md = self.modules.get(module)
        if md is not None:
            md.poke()

    async def discard(self, module: str) -> int:
        """Drop a module's queue and task (its session ended, OA-SESS-15); return the count."""
        waited = self.builds.discard(module)
        md = self.modules.pop(module, None)
        if md is None:
            self.idle_check()
            return waited
        left = waited + await md.stop()
        log.info("event=queue_discarded module=%s count=%d", module, left)
        self.idle_check()
        return left

    @property
    def pending(self) -> int:
        """Deliveries not yet finished, over all modules (those still being written too)."""
        return len(self.builds) + sum(md.pending for md in self.modules.values())

    def idle_check(self) -> None:
        """Wake `drained()` waiters when nothing is eligible or in flight any more."""
        if not self._idle_waiters or self._busy():
            return
        for waiter in self._idle_waiters:
            if not waiter.done():
                waiter.set_result(None)
        self._idle_waiters.clear()

    def _busy(self) -> bool:
        return bool(len(self.builds)) or any(md.pending for md in self.modules.values())

    async def drained(self) -> None:
        """Return once every queue is empty and nothing is in flight (OA-SESS-24's flush)."""
        while self._busy():
            waiter = asyncio.get_running_loop().create_future()
            self._idle_waiters.append(waiter)
            await waiter

    async def stop(self) -> int:
        """Stop every task; count what was left as DELIVERY_FAILED (OA-SESS-24)."""
        left = 0
        for name, n in self.builds.clear().items():
            self.host.dropped(name, n, "DELIVERY_FAILED")
            left += n
        modules = list(self.modules.items())
        counts = await asyncio.gather(*(md.stop() for _, md in modules))  # each one bounded
        for (name, md), n in zip(modules, counts, strict=True):
            if n:
                md.counters.failed += n
                self.host.dropped(name, n, "DELIVERY_FAILED")
            left += n
        self.modules.clear()
        return left

    def queued_bytes(self) -> int:
        """The bytes every module's queue holds together (OA-LIM-14), kept as they change."""
        return self.tally.bytes

    def counters(self) -> dict[str, dict[str, int]]:
        """Per module: queue depth, items in, delivered, dropped, failed, refused, retried."""
        return {
            name: {
                "depth": len(md.queue),
                "in": md.queue.counters.pushed,
                "delivered": md.counters.delivered,
                "dropped": md.queue.counters.dropped,
                "failed": md.counters.failed,
                "refused": md.counters.refused,
                "retried": md.counters.retried,
                "expired": md.counters.expired,
                "direct": md.counters.direct,  # of `in`: sent without the queue (issue #20)
                "discarded": md.queue.counters.discarded,
                "bytes": md.queue.held_bytes,  # OA-LIM-8
                "dropped_bytes": md.queue.counters.dropped_bytes,
            }
            for name, md in self.modules.items()
        }
