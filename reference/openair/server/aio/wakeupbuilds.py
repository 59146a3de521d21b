"""Large wakeups written on the worker thread, queued in each module's order (issue #19).

The router hands over a delivery whose wakeup is larger than `core.wakeups.LARGE_WAKEUP` with
`Delivery.build` instead of its text (the writing of a megabyte held every client's turn for
5-11 ms). `Builds` runs each build on `budgets.off_loop_executor()` and queues the built
delivery; until then every later delivery to the same module waits behind it, so a module's
deliveries reach its queue in the order the router decided them (OA-DELIV-5, spec 10). Other
modules' deliveries are not held. A build holds only references to stored copies; what it
writes goes into the module's queue, whose byte budget (OA-LIM-8) applies as to any delivery;
one worker writes one wakeup at a time.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
from collections import deque
from collections.abc import Callable

from openair.protocol.framing import Wire
from openair.protocol.message import Message
from openair.server.aio.budgets import off_loop_executor
from openair.server.core.outcome import Delivery

__all__ = ["Builds"]

log = logging.getLogger("openair.server")


#: The text (`Delivery.build_bytes`) of the wakeups waiting for the worker, in all, at most: past
#: it a wakeup is written at once on the loop. A waiting build keeps its trigger and retrieved
#: messages alive, evicted from the history or not; when posts come faster than the worker
#: writes, writing on the loop bounds that memory and slows the posters down.
MAX_WAITING_BYTES = 16 << 20


class Builds:
    """The deliveries waiting for a build, per module, in the router's order."""

    def __init__(
        self,
        queue: Callable[[Delivery], None],
        failed: Callable[[str], None],
        max_bytes: int = MAX_WAITING_BYTES,
    ) -> None:
        self._queue = queue  # queues a ready delivery (the dispatcher's own push)
        self._failed = failed  # a build raised: counted as a delivery that failed
        self._behind: dict[str, deque[Delivery]] = {}
        self.max_bytes = max_bytes
        self.bytes = 0  # `build_bytes` of the deliveries waiting for a build
        self.written_at_once = 0  # builds run on the loop because `max_bytes` was reached

    def __len__(self) -> int:
        """Deliveries waiting here (a build in progress and those behind it)."""
        return sum(map(len, self._behind.values())) if self._behind else 0

    def offer(self, delivery: Delivery) -> bool:
        """Take `delivery` when it must wait (a build, or behind one); False: queue it now."""
        if delivery.build is not None and self.bytes + delivery.build_bytes > self.max_bytes:
            self.written_at_once += 1
            ready = self._run(delivery, delivery.build)
            if ready is None:
                return True  # it failed: counted, nothing to queue
            delivery = ready
        held = self._behind.get(delivery.module)
        if held is not None:
            held.append(delivery)
            self.bytes += delivery.build_bytes if delivery.build is not None else 0
            return True
        if delivery.build is None:
            return False
        self._behind[delivery.module] = deque((delivery,))
        self.bytes += delivery.build_bytes
        self._start(delivery)
        return True

    def discard(self, module: str) -> int:
        """Forget what waits for `module` (its session ended); return how many."""
        held = self._behind.pop(module, ())
        self.bytes -= sum(d.build_bytes for d in held if d.build is not None)
        return len(held)

    def clear(self) -> dict[str, int]:
        """Forget everything (the server stops); return how many waited, per module."""
        left = {module: len(held) for module, held in self._behind.items()}
        self._behind.clear()
        self.bytes = 0
        return left

    def _run(
        self,
        delivery: Delivery,
        build: Callable[[], tuple[Message, Wire | None]],
    ) -> Delivery | None:
        """Write `delivery` here and now; None (logged, counted) when the build raised."""
        try:
            message, wire = build()
        except Exception as exc:  # a bug in writing: the delivery fails, the server goes on
            self._log_failure(delivery, exc)
            return None
        return dataclasses.replace(delivery, message=message, wire=wire, build=None)

    def _log_failure(self, delivery: Delivery, error: BaseException | None) -> None:
        log.error(
            "event=wakeup_build_failed module=%s id=%s error=%r",
            delivery.module,
            delivery.message.id,
            error,
        )
        self._failed(delivery.module)

    def _start(self, delivery: Delivery) -> None:
        build = delivery.build
        assert build is not None
        future = asyncio.get_running_loop().run_in_executor(off_loop_executor(), build)
        future.add_done_callback(lambda done: self._built(delivery, done))

    def _built(
        self,
        delivery: Delivery,
        done: asyncio.Future[tuple[Message, Wire | None]],
    ) -> None:
        held = self._behind.get(delivery.module)
        if held is None or held[0] is not delivery:
            return  # discarded while it was written
        held.popleft()
        self.bytes -= delivery.build_bytes
        if done.cancelled() or done.exception() is not None:
            self._log_failure(delivery, None if done.cancelled() else done.exception())
        else:
            message, wire = done.result()
            self._queue(dataclasses.replace(delivery, message=message, wire=wire, build=None))
        while held and held[0].build is None:
            self._queue(held.popleft())
        if held:
            self._start(held[0])
        else:
            del self._behind[delivery.module]
