"""Delivery of queued messages to modules: one task per module (spec 6.6, section 10).

Each module has a bounded `DeliveryQueue` (OA-DELIV-8/9) and a task that takes eligible items in
priority order (OA-PRIO-1/2) and sends them over the module's callback connection when it has
one, else over a connection the server opens to the module's listening port and reuses
(OA-DELIV-1, OA-DELIV-13), one connection at a time (OA-DELIV-12). A legacy module gets one
delivery at a time, the next only after the acknowledgement of the previous one; a module that
declared `pipelining` gets up to `max-in-flight` (OA-DELIV-5). A delivery that fails (no
connection, a closed connection, no acknowledgement within the delivery deadline) is retried at
most twice and then abandoned and counted (OA-DELIV-7, OA-DELIV-11); a reply other than the
acknowledgement is counted and not retried. Every module has its own task, queue and
connection, so a slow or dead module never delays another module or the acknowledgement of a
post (OA-DELIV-6).
"""

from __future__ import annotations

import asyncio
import contextlib
import heapq
import logging
import time
from collections import deque
from collections.abc import Coroutine
from dataclasses import dataclass, field, replace
from functools import partial
from typing import TYPE_CHECKING

from openair.protocol.connection import answer_type
from openair.protocol.errors import ConnectionClosedError, OpenAIRError
from openair.protocol.message import Message
from openair.server.aio.pairing import Wire
from openair.server.aio.protocol import ServerConnection
from openair.server.core.queues import DeliveryQueue, QueueItem
from openair.server.core.router import Delivery, ModuleInfo
from openair.server.core.samplebuffer import SampleBuffer
from openair.server.core.streamspec import StoredSample
from openair.server.core.streamwire import push_frame, push_message

if TYPE_CHECKING:
    from openair.server.aio.dispatcher import Dispatcher

__all__ = ["ModuleCounters", "ModuleDelivery"]

log = logging.getLogger("openair.server")

#: The longest stop() waits for a module's cancelled tasks to end (shutdown must finish).
_STOP_WAIT_S = 1.0


@dataclass(slots=True)
class ModuleCounters:
    """What one module's delivery task did."""

    delivered: int = 0
    failed: int = 0  # DELIVERY_FAILED: abandoned after the retries (or at shutdown)
    refused: int = 0  # answered with something other than the acknowledgement
    retried: int = 0
    expired: int = 0  # OA-DELIV-14: dropped unsent after the message's timetolive
    direct: int = 0  # sent by `send_now`, without the queue (issue #20)


@dataclass(slots=True, eq=False)
class _Sent:
    """A delivery on the wire, waiting for its acknowledgement (OA-DELIV-4) until `deadline`."""

    attempt: _Attempt
    conn: ServerConnection
    msg: Message
    deadline: float  # loop time (OA-DELIV-11)
    settled: bool = False


@dataclass(order=True, slots=True)
class _Attempt:
    """A queue item on its way out; ordered by arrival so retries keep their order."""

    seq: int
    item: QueueItem = field(compare=False)
    tries: int = field(default=0, compare=False)


class ModuleDelivery:
    """The queue and delivery task of one module."""

    #: Whether `send_now` may send past the queue (a subclass with its own task says no).
    may_send_now = True

    def __init__(self, name: str, dispatcher: Dispatcher) -> None:
        self.name = name
        self._d = dispatcher
        self.queue = DeliveryQueue(
            capacity=dispatcher.capacity,
            max_bytes=dispatcher.max_queue_bytes,
            tally=dispatcher.tally,
        )
        self.counters = ModuleCounters()
        self._retry: list[_Attempt] = []
        # Deliveries awaiting their acknowledgement, and retries sleeping their back-off: each
        # holds a slot of the window until it ends.
        self._in_flight: set[_Sent | asyncio.Task[None]] = set()
        self._sent: deque[_Sent] = deque()  # in send order: the oldest deadline first
        # Unsettled deliveries per connection (at most the two paths of OA-DELIV-1): what
        # `_busy_elsewhere` reads instead of scanning the window for every delivery (that scan
        # was a tenth of the server's CPU at fan-out 1).
        self._unsettled_on: dict[ServerConnection, int] = {}
        self._timer: asyncio.TimerHandle | None = None
        self._last_conn: ServerConnection | None = None  # written to since the last flush
        self._loop = asyncio.get_running_loop()
        self._wake = asyncio.Event()
        self._room = asyncio.Event()
        self._outbound: ServerConnection | None = None
        self._outbound_at = ("", 0)
        self._sending = 0  # 1 while an attempt is between the queue and the connection
        self._grant = 0  # deliveries this module may still start in its turn (OA-PRIO-5)
        self._parked = False  # the task waits in `_next` with nothing to send (`send_now`)
        # Samples of the streams the module subscribed to (OA-STREAM-14): one bounded buffer per
        # stream (OA-STREAM-8); they go before queued messages ("streams outrank messages").
        self.samples: dict[str, SampleBuffer] = {}
        self.task: asyncio.Task[None] | None = asyncio.get_running_loop().create_task(
            self._run(), name=f"deliver {name}"
        )

    @property
    def pending(self) -> int:
        """Items queued, waiting for a retry or in flight."""
        buffered = sum(len(b) for b in self.samples.values()) if self.samples else 0
        return len(self.queue) + buffered + len(self._retry) + len(self._in_flight) + self._sending

    def push(self, delivery: Delivery) -> list[QueueItem]:
        """Queue one delivery; return the items dropped for room (OA-DELIV-9, OA-LIM-8)."""
        victims = self.queue.push_all(
            delivery.message,
            priority=delivery.priority,
            wb_priority=delivery.wb_priority,
            due_ns=delivery.due_ns,
            wire=delivery.wire,
            expires_ns=delivery.expires_ns,
            now_ns=time.time_ns(),
        )
        self._wake.set()
        return victims

    def send_now(self, delivery: Delivery) -> bool:
        """Send a delivery at once, without the queue and a task switch (issue #20).

        Only what the task would send first, in this same loop turn, were it queued: the task
        waits with nothing eligible queued (delayed items may wait: this one is due), no retry,
        no stream sample and no large wakeup being written; the delivery is due and not
        expired (OA-TRIG-3, OA-DELIV-14), its frame is written, the window has room
        (OA-DELIV-5), the callback connection is open and nothing is unanswered on another path
        (OA-DELIV-1, OA-DELIV-12), and no module waits for a turn (OA-PRIO-5: with work waiting,
        whiteboard priority decides, so it queues). False: queue it as before. Counted as
        pushed and popped, as the queue would have.
        """
        if (
            not self.may_send_now
            or not self._parked
            or self._wake.is_set()
            or self._retry
            or self.samples
            or delivery.wire is None
            or delivery.build is not None
            or self._d.gate.waiting
        ):
            return False
        now = time.time_ns()
        if delivery.due_ns > now or (delivery.expires_ns and now >= delivery.expires_ns):
            return False
        if len(self._in_flight) >= self._window():
            return False
        conn = self._callback_path()
        if conn is None or self._busy_elsewhere(conn):
            return False
        item = QueueItem(
            message=delivery.message,
            priority=delivery.priority,
            wb_priority=delivery.wb_priority,
            due_ns=delivery.due_ns,
            seq=self.queue.passed(),
            wire=delivery.wire,
            expires_ns=delivery.expires_ns,
        )
        self.counters.direct += 1
        sent = self._wire_form(item.message)
        self._watch(
            _Attempt(seq=item.seq, item=item),
            conn,
            sent,
            item.wire if sent is item.message else None,
        )
        return True

    def poke(self) -> None:
        """Look again for a path (the module bound or opened a callback connection)."""
        self._wake.set()

    def push_sample(self, stream: str, sample: StoredSample, capacity: int) -> int:
        """Buffer a sample of a subscribed stream; return how many were dropped for room."""
        buffer = self.samples.get(stream)
        if buffer is None:
            buffer = self.samples[stream] = SampleBuffer(capacity, self._d.push_buffer_bytes)
        dropped = buffer.offer(sample)
        self._wake.set()
        return dropped

    def _take_sample(self) -> _Attempt | None:
        """Return the next buffered sample as a DATASAMPLE delivery (OA-STREAM-14), if any."""
        for stream, buffer in self.samples.items():
            taken = buffer.take()
            if taken is None:
                continue
            sample, dropped = taken
            # Round robin: the stream served goes to the back of the order.
            self.samples[stream] = self.samples.pop(stream)
            msg = push_message(
                sample, stream=stream, to=self.name, dropped=dropped, now_ns=time.time_ns()
            )
            item = QueueItem(message=msg, priority=0.0, wb_priority=0.0, wire=push_frame(msg))
            return _Attempt(seq=0, item=item)
        return None

    # -- the task -----------------------------------------------------------------------------

    async def _run(self) -> None:
        # The loop runs without suspending while items are ready and the window has room, so a
        # burst of wakeups goes out in one event-loop turn.
        while True:
            if len(self._in_flight) >= self._window():
                self._flush()
                await self._wait_for_room()
            attempt = self._take()
            if attempt is None:
                self._flush()  # the burst is over: send it before waiting
                attempt = await self._next()
                self._grant = 0  # it waited: it asks for a turn again (OA-PRIO-5)
            self._sending = 1
            try:
                if self._grant <= 0:
                    self._flush()
                    self._grant = await self._turn(attempt.item)
                self._grant -= 1
                conn = await self._choose()
                while conn is not None and len(self._in_flight) >= self._window():
                    # The window shrank while the task waited (the module bound again without
                    # `pipelining`, OA-SESS-35): the attempt waits for room (OA-DELIV-5).
                    self._flush()
                    await self._wait_for_room()
                    conn = await self._choose()
                if conn is None:
                    self._failed(attempt, "no connection to the module")
                    continue
                item = attempt.item
                if item.expires_ns and time.time_ns() >= item.expires_ns:
                    self._expire_unsent(item)  # OA-DELIV-14: not sent within timetolive
                    continue
                sent = self._wire_form(item.message)
                wire = item.wire if sent is item.message else None  # written by the router
                self._watch(attempt, conn, sent, wire)
            finally:
                self._sending = 0
                self._d.idle_check()

    async def _turn(self, item: QueueItem) -> int:
        """Wait for a turn for a burst that starts with `item` (OA-PRIO-5, OA-PRIO-6)."""
        ready = 1 + len(self.queue) - self.queue.delayed + len(self._retry)
        room = self._window() - len(self._in_flight)
        return await self._d.gate.turn(
            wb_priority=item.wb_priority, priority=item.priority, want=min(ready, room)
        )

    def _spawn(self, coro: Coroutine[object, object, None]) -> None:
        """Run one attempt's follow-up; it holds a slot of the window until it ends."""
        task = self._loop.create_task(coro)
        self._in_flight.add(task)
        task.add_done_callback(self._finished)

    def _flush(self) -> None:
        conn = self._last_conn
        if conn is not None:
            self._last_conn = None
            conn.flush()

    def _watch(
        self, attempt: _Attempt, conn: ServerConnection, msg: Message, wire: Wire | None
    ) -> None:
        """Send, then wait for the acknowledgement (OA-DELIV-4) within the deadline (OA-DELIV-11).

        A callback and one timer per module, not a task per delivery: replies are paired in
        order (OA-SESS-33), so the oldest delivery in flight always has the earliest deadline.
        """
        entry = _Sent(
            attempt=attempt,
            conn=conn,
            msg=msg,
            deadline=self._loop.time() + self._d.options.deadline_s,
        )
        self._in_flight.add(entry)
        self._sent.append(entry)
        self._unsettled_on[conn] = self._unsettled_on.get(conn, 0) + 1
        if self._timer is None:
            self._timer = self._loop.call_at(entry.deadline, self._check_deadlines)
        self._last_conn = conn
        conn.send_request_cb(msg, wire, partial(self._acked, entry))

    def _acked(self, entry: _Sent, reply: Message | None, error: BaseException | None) -> None:
        """Judge the reply to one delivery: delivered, refused, or retried (OA-DELIV-7)."""
        if not self._settle(entry):
            return  # timed out or stopped already
        while self._sent and self._sent[0].settled:
            self._sent.popleft()
        try:
            self._judge(entry, reply, error)
        finally:
            self._in_flight.discard(entry)
            self._room.set()
            self._d.idle_check()

    def _judge(self, entry: _Sent, reply: Message | None, error: BaseException | None) -> None:
        msg = entry.msg
        if isinstance(error, asyncio.CancelledError):
            return  # passed over as an unanswered KEEPALIVE would be (OA-KEEP-3)
        if isinstance(error, ConnectionClosedError):
            reason = "the connection closed before the acknowledgement"
            self._spawn(self._retry_later(entry.attempt, reason))
        elif isinstance(error, OpenAIRError):  # an unreadable reply: counted, not retried
            self._refused(msg, error.wire_text())
        elif error is not None or reply is None:
            log.error("event=delivery_error module=%s detail=%r", self.name, error)
        elif msg.noreply or reply.type == answer_type(msg.type):  # OA-DELIV-4
            self.counters.delivered += 1
            self._d.host.delivered(self.name, 1)
            hook = self._d.on_delivered
            if hook is not None:
                hook(self.name, entry.attempt.item)
        else:
            self._refused(msg, f"{reply.type}: {reply.content[:200]}")

    def _check_deadlines(self) -> None:
        """Retry every delivery whose acknowledgement is overdue (OA-DELIV-11)."""
        self._timer = None
        now = self._loop.time()
        while self._sent:
            entry = self._sent[0]
            if not entry.settled and entry.deadline > now:
                break
            self._sent.popleft()
            if not entry.settled:
                self._expire(entry)
        if self._sent:
            self._timer = self._loop.call_at(self._sent[0].deadline, self._check_deadlines)

    def _settle(self, entry: _Sent) -> bool:
        """Mark a delivery answered, expired or stopped; False when it was already."""
        if entry.settled:
            return False
        entry.settled = True
        left = self._unsettled_on[entry.conn] - 1
        if left:
            self._unsettled_on[entry.conn] = left
        else:
            del self._unsettled_on[entry.conn]
        return True

    def _expire(self, entry: _Sent) -> None:
        self._settle(entry)  # a late reply is ignored
        entry.conn.close()  # OA-DELIV-11: a late acknowledgement could no longer be paired
        self._spawn(self._retry_later(entry.attempt, "no acknowledgement before the deadline"))
        self._in_flight.discard(entry)
        self._room.set()
        self._d.idle_check()

    def _expire_unsent(self, item: QueueItem) -> None:
        """Drop a delivery whose message's timetolive has passed, and count it (OA-DELIV-14)."""
        self.counters.expired += 1
        self._d.host.dropped(self.name, 1, "EXPIRED")
        log.info("event=delivery_expired module=%s type=%s", self.name, item.message.type)

    def _wire_form(self, msg: Message) -> Message:
        """Drop `noreply` towards a module that did not declare it (OA-GEN-2, OA-MSG-15).

        A legacy module would acknowledge it anyway, and that reply would then be paired with
        the wrong delivery.
        """
        if msg.noreply:
            info = self._d.host.module_info(self.name)
            if info is None or "noreply" not in info.extensions:
                return replace(msg, noreply=False)
        return msg

    def _finished(self, task: asyncio.Task[None]) -> None:
        self._in_flight.discard(task)
        self._room.set()
        self._d.idle_check()

    def _window(self) -> int:
        """One delivery at a time for a legacy module, more under `pipelining` (OA-DELIV-5)."""
        info = self._d.host.module_info(self.name)
        if info is not None and "pipelining" in info.extensions:
            return self._d.max_in_flight
        return 1

    async def _wait_for_room(self) -> None:
        while len(self._in_flight) >= self._window():
            self._room.clear()
            await self._room.wait()

    def _take(self) -> _Attempt | None:
        """Return a retry first, else the first eligible queued item, else None."""
        if self._retry:
            return heapq.heappop(self._retry)
        if self._has_path():
            if self.samples:
                sample = self._take_sample()
                if sample is not None:
                    return sample
            item = self.queue.pop(time.time_ns())
            if item is not None:
                return _Attempt(seq=item.seq, item=item)
        return None

    async def _next(self) -> _Attempt:
        """Wait for the next attempt: a retry first, else the first eligible queued item.

        Nothing is taken while the window is full (a delivery sent by `send_now` fills it): an
        item taken would wait outside the queue, where no overflow can drop it (OA-DELIV-9).
        """
        while True:
            if len(self._in_flight) >= self._window():
                self._flush()
                await self._wait_for_room()
            self._wake.clear()
            attempt = self._take()
            if attempt is not None:
                return attempt
            due = self.queue.next_due()
            timeout = None if due is None else max(due - time.time_ns(), 0) / 1e9
            # asyncio.timeout, not wait_for: on 3.11 wait_for returns the wait's result when a
            # cancel arrives in the same turn as the wake-up, and the task (cancelled by stop())
            # would then wait here again for ever, holding the shutdown.
            self._parked = True
            try:
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(timeout):
                        await self._wake.wait()
            finally:
                self._parked = False

    def _has_path(self) -> bool:
        """Whether the module can be reached at all (else its deliveries wait, bounded)."""
        info = self._d.host.module_info(self.name)
        return info is not None and (info.callback is not None or info.port > 0)

    async def _choose(self) -> ServerConnection | None:
        """Pick the connection for the next delivery (OA-DELIV-1, OA-DELIV-12, OA-DELIV-13).

        The callback connection when the module has one, else the listening port (so a port that
        cannot be reached never stops deliveries a callback connection can take); and one
        connection at a time: a switch waits until the other connection has nothing unanswered.
        """
        while True:
            conn = self._callback_path()
            if conn is None:
                conn = await self._path()
            if conn is None or not self._busy_elsewhere(conn):
                return conn
            self._flush()
            while self._busy_elsewhere(conn):  # OA-DELIV-12: keep the order across paths
                self._room.clear()
                await self._room.wait()

    def _busy_elsewhere(self, conn: ServerConnection) -> bool:
        """Whether a delivery sent on another connection still awaits its acknowledgement."""
        return any(other is not conn for other in self._unsettled_on)

    def _callback_path(self) -> ServerConnection | None:
        """Return the module's open callback connection, if it has one (OA-DELIV-1)."""
        info = self._d.host.module_info(self.name)
        if info is None or info.callback is None:
            return None
        conn = self._d.host.connection(info.callback)
        return conn if conn is not None and not conn.is_closing else None

    async def _path(self) -> ServerConnection | None:
        """Return a connection to the module's listening port (OA-DELIV-1), or None."""
        info = self._d.host.module_info(self.name)
        if info is None:
            return None
        if info.port <= 0:
            return None
        address = info.address or self._primary_host(info)
        out = self._outbound
        if out is not None and not out.is_closing and self._outbound_at == (address, info.port):
            return out
        if out is not None:
            out.close()  # the module bound a new port (takeover, OA-SESS-6)
        try:
            async with asyncio.timeout(self._d.options.connect_timeout_s):  # cancels cleanly
                out = await self._d.host.connect(self.name, address, info.port)
        except (OSError, TimeoutError) as exc:
            log.info(
                "event=connect_failed module=%s address=%s port=%d detail=%r",
                self.name,
                address,
                info.port,
                str(exc),
            )
            return None
        self._outbound, self._outbound_at = out, (address, info.port)
        return out

    def _primary_host(self, info: ModuleInfo) -> str:
        """The address the module's primary connection came from (OA-DELIV-1)."""
        conn = self._d.host.connection(info.conn) if info.conn is not None else None
        return conn.peer[0] if conn is not None and conn.peer[0] else "127.0.0.1"

    def _refused(self, msg: Message, detail: str) -> None:
        self.counters.refused += 1
        log.info("event=delivery_refused module=%s type=%s detail=%r", self.name, msg.type, detail)

    async def _retry_later(self, attempt: _Attempt, reason: str) -> None:
        """Queue a retry after a back-off, or abandon the delivery (OA-DELIV-7)."""
        if attempt.tries >= self._d.options.retries:
            self._failed(attempt, reason)
            return
        backoff = self._d.options.backoff_s
        await asyncio.sleep(backoff[min(attempt.tries, len(backoff) - 1)] if backoff else 0)
        attempt.tries += 1
        self.counters.retried += 1
        heapq.heappush(self._retry, attempt)
        self._wake.set()

    def _failed(self, attempt: _Attempt, reason: str) -> None:
        """Retry a failed attempt, or abandon and count it after the last retry."""
        if attempt.tries < self._d.options.retries:
            self._spawn(self._retry_later(attempt, reason))
            return
        self.counters.failed += 1
        self._d.host.dropped(self.name, 1, "DELIVERY_FAILED")
        log.warning(
            "event=delivery_failed module=%s type=%s tries=%d detail=%r",
            self.name,
            attempt.item.message.type,
            attempt.tries + 1,
            reason,
        )

    # -- ending ---------------------------------------------------------------------------------

    async def stop(self) -> int:
        """Cancel the task and everything in flight; return how many deliveries were left."""
        left = self.pending
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        tasks = [self.task] if self.task is not None else []
        self.task = None  # see below
        for waiting in self._in_flight:
            if isinstance(waiting, _Sent):
                self._settle(waiting)  # its reply, if one comes, is ignored
            else:
                tasks.append(waiting)
        self._in_flight.clear()
        self._sent.clear()
        for task in tasks:
            task.cancel()
        # Bounded: a task that does not end on its cancel must not hold the shutdown.
        _, stuck = await asyncio.wait(tasks, timeout=_STOP_WAIT_S)
        for task in stuck:
            log.warning("event=task_stuck module=%s task=%s", self.name, task.get_name())
        self.queue.clear()
        self._retry.clear()
        if self._outbound is not None:
            self._outbound.close()
        # A cancelled task keeps the traceback of its cancellation, whose frames hold this
        # object: with `self.task` kept, the whole delivery state (the queue, the last wakeup,
        # its connection) was a cycle that only a late full collection freed, megabytes a
        # module under the server's rare collections (issue #19).
        for task in tasks:
            if task.done() and not task.cancelled():
                task.exception()  # retrieved: no "never retrieved" warning when it goes
        return left
