"""Internal modules: Python code named in the psySpec, run inside the server (spec 12.1, OA-CONF-8).

The paper's fix for a slow robot: move modules into the server, where "all communication with
whiteboards is reduced to pointer arithmetic". A psySpec entry names the code:

    <module name="Tracker" internal="mypkg.tracker:Tracker">
      <trigger from="WB1" type="Vision.Face.*"/>
    </module>

The code is a callable `handler(module, msg)` (a function, or a class whose instances are such
callables; a class is instantiated once, with no argument). It receives every delivery of the
module as a `Message` (wakeups, phase updates, forwarded messages;
`openair.protocol.wakeup.parse_wakeup` takes a wakeup apart) and answers by returning; it posts with
`module.post(...)`, which routes the message through the router and returns the server's reply,
without TCP or XML; `module.trigger(msg)` hands over a wakeup's stored trigger message itself,
unparsed.

- An `async def` handler runs on the server's event loop: it must never block.
- A plain handler runs on a worker thread of its own (blocking code is fine there); its posts
  hop to the loop and wait for the reply.

An internal module is an ordinary bound module (BIND_NOLISTEN on a session of its own, negative
connection id): the same registration (its psySpec entry, or `module.subscribe(...)`), cc,
history, priorities (its queue is a `DeliveryQueue` and it asks `TurnGate` for turns, OA-PRIO-5),
`max-queue`, counters in STATUS and the monitor. One delivery at a time, in queue order, as a
legacy module. A handler that raises is logged with its traceback and counted as `failed` in
the module's queue counters; the next delivery goes on. A BIND of its name is refused.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import importlib
import inspect
import logging
import threading
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.wakeup import WAKEUP_TYPE, parse_wakeup
from openair.server.aio.delivery import ModuleDelivery
from openair.server.aio.dispatcher import Dispatcher
from openair.server.core.config import ConfigError
from openair.server.core.queues import QueueItem
from openair.server.core.router import Delivery

if TYPE_CHECKING:
    from openair.server.aio.app import Server

__all__ = ["Handler", "InternalModule", "InternalModules", "load_handler", "start_internal"]

log = logging.getLogger("openair.server")

#: The longest a worker thread's `send` waits for the loop (it answers at once unless stopped).
_SEND_WAIT_S = 30.0

Handler = Callable[["InternalModule", Message], Awaitable[None] | None]


def load_handler(target: str) -> Handler:
    """Import `package.module:attr.path`; instantiate a class; ConfigError when it fails."""
    module_path, _, attr_path = target.strip().partition(":")
    try:
        obj: object = importlib.import_module(module_path)
        for attr in attr_path.split("."):
            obj = getattr(obj, attr)
        if inspect.isclass(obj):
            obj = obj()
    except Exception as exc:  # any failure of the operator's code refuses the start (OA-CONF-3)
        raise ConfigError(f"internal module code {target!r} cannot be loaded: {exc!r}") from None
    if not callable(obj):
        raise ConfigError(f"internal module code {target!r} is not callable")
    return cast(Handler, obj)


def _is_async(handler: Handler) -> bool:
    """Whether the handler is an `async def` function, or an instance of a class with one."""
    return inspect.iscoroutinefunction(handler) or inspect.iscoroutinefunction(
        type(handler).__call__
    )


class InternalModule:
    """What an internal module's code gets: its name, `post`, `send` and `subscribe`."""

    def __init__(self, name: str, server: Server, conn_id: int) -> None:
        self.name = name
        self._server = server
        self._conn_id = conn_id
        self._loop = asyncio.get_running_loop()
        self._loop_thread = threading.get_ident()
        self._stored: dict[str, Message] = {}  # wakeup id -> its stored trigger message

    def trigger(self, msg: Message) -> Message | None:
        """Return the stored trigger message of a wakeup (None: a phase update, not a wakeup).

        The object the whiteboard stored, handed over as is: no XML to parse (it must not be
        changed). `parse_wakeup(msg)` gives the same message and the rest of the wakeup.
        """
        stored = self._stored.get(msg.id)
        if stored is not None or msg.type != WAKEUP_TYPE:
            return stored
        return parse_wakeup(msg).trigger

    def post(
        self,
        to: str,
        type: str,
        content: str = "",
        *,
        cc: str = "",
        priority: float | None = None,
        xml: bool = False,
    ) -> Message | None:
        """Post to a whiteboard as this module; return the reply (RECEIVE_ACCEPT, an error)."""
        msg = Message(
            type=type,
            sender=self.name,
            to=to,
            cc=cc,
            priority=priority,
            posted=AirTime.from_ns(time.time_ns()),
            content=content,
            content_is_xml=xml,
            language="xml" if xml else "",
        )
        return self.send(msg)

    def subscribe(self, registration_xml: str) -> Message | None:
        """Replace this module's registration (AIR.Subscribe, OA-REG-1); return the reply."""
        return self.post("AIRCentral", "AIR.Subscribe", registration_xml, xml=True)

    def send(self, msg: Message) -> Message | None:
        """Route any request from this module and return its first reply (None: no reply).

        From the loop's thread it is routed at once; from a worker thread it waits until the
        loop has routed it (the router answers every request at once, so the wait is short).
        """
        if threading.get_ident() == self._loop_thread:
            return self._route(msg)
        done: concurrent.futures.Future[Message | None] = concurrent.futures.Future()

        def route() -> None:
            try:
                done.set_result(self._route(msg))
            except Exception as exc:
                done.set_exception(exc)

        self._loop.call_soon_threadsafe(route)
        return done.result(timeout=_SEND_WAIT_S)  # a stopped loop never answers

    def _route(self, msg: Message) -> Message | None:
        outcome = self._server.inject(msg, received_ns=time.time_ns(), conn_id=self._conn_id)
        return outcome.replies[0] if outcome.replies else None


class InternalDelivery(ModuleDelivery):
    """An internal module's queue and task: items go to the handler instead of a socket."""

    may_send_now = False  # its task calls the handler: every delivery goes through the queue

    def __init__(
        self, module: InternalModule, dispatcher: Dispatcher, handler: Handler, *, threaded: bool
    ) -> None:
        self.module = module
        self._handler = handler
        self._worker = (
            concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix=f"internal-{module.name}")
            if threaded
            else None
        )
        super().__init__(module.name, dispatcher)  # starts self._run() below

    def push(self, delivery: Delivery) -> list[QueueItem]:
        """Queue a delivery and keep its stored trigger message for `InternalModule.trigger`."""
        if delivery.trigger is not None:
            self.module._stored[delivery.message.id] = delivery.trigger
        victims = super().push(delivery)
        for victim in victims:
            self.module._stored.pop(victim.message.id, None)  # OA-DELIV-9: dropped
        return victims

    def _window(self) -> int:
        """Deliveries it may take per turn: nothing is in flight, the handler runs them in turn."""
        return self._d.max_in_flight

    def _has_path(self) -> bool:
        return True  # always reachable: no connection to wait for

    async def _run(self) -> None:
        while True:
            attempt = self._take()
            if attempt is None:
                attempt = await self._next()
                self._grant = 0
            self._sending = 1
            try:
                if self._grant <= 0:
                    self._grant = await self._turn(attempt.item)  # OA-PRIO-5, as over TCP
                self._grant -= 1
                item = attempt.item
                if item.expires_ns and time.time_ns() >= item.expires_ns:
                    self.module._stored.pop(item.message.id, None)
                    self._expire_unsent(item)  # OA-DELIV-14, as over TCP
                    continue
                await self._call(item)
            finally:
                self._sending = 0
                self._d.idle_check()

    async def _call(self, item: QueueItem) -> None:
        """Give one delivery to the handler; log and count it when the handler raises."""
        msg = item.message
        try:
            if self._worker is None:
                await cast(Awaitable[None], self._handler(self.module, msg))
            else:
                loop = asyncio.get_running_loop()
                await loop.run_in_executor(self._worker, self._handler, self.module, msg)
        except asyncio.CancelledError:
            raise
        except Exception:
            self.counters.failed += 1
            log.exception("event=internal_error module=%s type=%s", self.name, msg.type)
            return
        finally:
            self.module._stored.pop(msg.id, None)
        self.counters.delivered += 1
        self._d.host.delivered(self.name, 1)
        hook = self._d.on_delivered
        if hook is not None:
            hook(self.name, item)

    async def stop(self) -> int:
        """Stop the task; let a running worker call finish on its own (it cannot be killed)."""
        left = await super().stop()
        if self._worker is not None:
            self._worker.shutdown(wait=False, cancel_futures=True)
        return left


@dataclass(frozen=True, slots=True, kw_only=True)
class InternalModules:
    """The internal modules a server runs, by name."""

    modules: dict[str, InternalDelivery]

    def counters(self) -> dict[str, dict[str, object]]:
        """Per module: how its code runs and what it did (for STATUS and the monitor)."""
        return {
            name: {
                "runs": "thread" if d._worker is not None else "loop",
                "delivered": d.counters.delivered,
                "failed": d.counters.failed,
            }
            for name, d in self.modules.items()
        }


def start_internal(server: Server) -> InternalModules:
    """Load, bind and start every internal module of the configuration (OA-CONF-8).

    Raise ConfigError when code cannot be loaded or a BIND is refused (the server does not
    start, OA-CONF-3); the modules already started are stopped first.
    """
    found: dict[str, InternalDelivery] = {}
    try:
        for i, config in enumerate(m for m in server.config.modules if m.internal):
            found[config.name] = _start_one(server, config.name, config.internal, -(i + 1))
    except ConfigError:
        for delivery in found.values():
            if delivery.task is not None:
                delivery.task.cancel()
            if delivery._worker is not None:
                delivery._worker.shutdown(wait=False)
        raise
    return InternalModules(modules=found)


def _start_one(server: Server, name: str, code: str, conn_id: int) -> InternalDelivery:
    """Load one module's code, give it a queue and a task, bind its name (OA-CONF-8).

    `conn_id` is negative: a session of its own that no socket can have.
    """
    handler = load_handler(code)
    module = InternalModule(name, server, conn_id)
    delivery = InternalDelivery(module, server.dispatcher, handler, threaded=not _is_async(handler))
    server.dispatcher.modules[name] = delivery  # before anything can wake it
    bind = Message(type="BIND_NOLISTEN", sender=name, to="CNS")
    reply = server.inject(bind, received_ns=time.time_ns(), conn_id=conn_id)
    if not reply.replies or reply.replies[0].type != "BIND_ACCEPT":
        if delivery.task is not None:
            delivery.task.cancel()
        detail = reply.replies[0].content if reply.replies else "no reply"
        raise ConfigError(f"internal module {name!r} cannot bind: {detail}")
    server.router.hold(name)  # OA-CONF-8: no TCP module takes the name over
    runs = "thread" if delivery._worker is not None else "loop"
    log.info("event=internal_module module=%s code=%s runs=%s", name, code, runs)
    return delivery
