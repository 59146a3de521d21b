"""The asyncio reference server: listening socket, connections, delivery, shutdown (spec 6).

`start_server(options)` returns a `Server` that is already listening (port 0 picks a free port;
`Server.port` is the real one). The sans-I/O `Router` decides everything; this module only moves
bytes and time: `ServerConnection` (protocol.py) frames and decodes, `Dispatcher` (delivery.py)
queues and sends deliveries, and `Server` ties connection ids to transports, which the router
never holds.
`ServerOptions` and what is derived from them (port, configuration, extensions) are
`openair.server.aio.options`; this module re-exports `ServerOptions`, `DEFAULT_EXTENSIONS` and
`DEFAULT_PORT` beside `start_server`, the names a caller starting a server needs.

`Server.stop()` shuts down as OA-SESS-24 says: stop accepting, answer new requests
`SHUTTING_DOWN` (the router does, after `shutting_down()`), attempt the deliveries already
decided within the grace period, count the rest DELIVERY_FAILED, close every connection, close
the store. Log lines go to the logger `openair.server` as `event=NAME key=value …`.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable, Coroutine
from dataclasses import replace

import openair
from openair.observing import ServerObserver
from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair.server.aio.attachments import MonitorHook, load_attachment
from openair.server.aio.budgets import (
    ACCEPT_BATCH,
    full_backlog,
    pause_for_the_loop,
    quiet_accept_errors,
)
from openair.server.aio.clusternode import ClusterNode, join_cluster
from openair.server.aio.dispatcher import Dispatcher
from openair.server.aio.fairness import Turns
from openair.server.aio.internal import InternalModules, start_internal
from openair.server.aio.observed import ObservedView
from openair.server.aio.options import (
    DEFAULT_EXTENSIONS,
    DEFAULT_PORT,
    ServerOptions,
    advertised_extensions,
    auth_gate,
    config_of,
    delivery_options,
    free_port,
    main_port,
)
from openair.server.aio.protocol import Role, ServerConnection
from openair.server.aio.pusher import Pusher
from openair.server.aio.stores import open_store
from openair.server.core.budgets import Budget
from openair.server.core.commands import declared_extensions
from openair.server.core.config import ServerConfig
from openair.server.core.router import ModuleInfo, Outcome, Router, SamplePush
from openair.server.core.store import HistoryStore

__all__ = [
    "DEFAULT_EXTENSIONS",
    "DEFAULT_PORT",
    "MonitorHook",
    "Server",
    "ServerOptions",
    "start_server",
]

log = logging.getLogger("openair.server")

_TICK_S = 0.1  # OA-XSTREAM-7: Idle alarms are checked at least this often
_BINDS = frozenset({"BIND", "BIND_NOLISTEN"})
_WILDCARD_HOSTS = frozenset({"", "0.0.0.0", "::"})
_STAGE_S = 2.0  # the longest one shutdown stage after the grace period may take
_STORE_WAIT_S = 20.0  # an injected post to a cluster whiteboard: its store's answer (spec 17)


class Server:
    """A running OpenAIR server; build it with `start_server`."""

    #: Its connections write the frames the router made (a subclass that re-encodes every reply
    #: says False: a large reply then carries its text too, issue #19).
    sends_frames = True

    def __init__(self, options: ServerOptions, config: ServerConfig, store: HistoryStore) -> None:
        self.options = options
        self.config = config
        self.store = store
        self.host = options.host
        self.port = main_port(options.port, config)
        self.limits = options.limits
        self.flow = options.flow
        wanted = options.extensions | {"monitor"} if options.monitor else options.extensions
        if options.auth_secrets is not None:  # OA-AUTH-1, OA-AUTH-11: `auth`, no monitor
            wanted = (wanted - {"monitor"}) | {"auth"}
        # OA-EXT-1: `monitor` only with a web monitor installed (the `monitor` extra, issue #17)
        monitor = options.monitor and "monitor" in wanted
        self._attach_monitor = load_attachment("monitor") if monitor else None
        if monitor and self._attach_monitor is None:
            wanted = wanted - {"monitor"}
        self.extensions = advertised_extensions(wanted, store)
        self.router: Router
        self.internal: InternalModules | None = None  # the modules run inside (OA-CONF-8)
        self._listener: asyncio.Server | None = None
        self._conns: dict[int, ServerConnection] = {}
        self._outbound: set[ServerConnection] = set()
        self._next_id = 0
        self._stopping = False
        self._final = False
        self.cluster: ClusterNode | None = None  # a cluster node's side of its store (spec 17)
        self._done: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._tasks: set[asyncio.Task[int]] = set()
        self.dispatcher = Dispatcher(
            self,
            capacity=options.limits.max_queue,
            max_in_flight=options.limits.max_in_flight,
            options=delivery_options(options),
            max_queue_bytes=options.limits.max_queue_bytes,  # OA-LIM-8
            push_buffer_bytes=options.limits.stream_push_buffer_bytes,  # OA-LIM-16
        )
        self.budget = Budget(options.limits)  # OA-LIM-11, OA-LIM-12
        loop = asyncio.get_running_loop()
        #: Each peer address's slice of a loop turn (issue #19); None: no fairness.
        self.turns = Turns(options.fair_slice_s, loop.call_soon) if options.fair_slice_s else None
        self.delivered_total = 0
        self.dropped_total: dict[str, int] = {
            "QUEUE_OVERFLOW": 0,
            "DELIVERY_FAILED": 0,
            "EXPIRED": 0,  # OA-DELIV-14
        }
        #: The web monitor attached by `openair_monitor.attach` (None: no HTTP served).
        self.monitor: MonitorHook | None = None
        self._pushers: dict[int, Pusher] = {}  # push connections by id (11.6)
        self._wait_timers: dict[int, tuple[int, asyncio.TimerHandle]] = {}  # ticket -> conn, timer
        self._ticker: asyncio.TimerHandle | None = None
        self._sweeper: asyncio.TimerHandle | None = None  # OA-LIM-15

    # -- ConnectionHost -------------------------------------------------------------------------

    def connection_opened(self, conn: ServerConnection) -> int:
        self._next_id += 1
        if not self.budget.admit(conn.peer[0], time.monotonic()):  # OA-LIM-11
            conn.abort()  # never registered: it ends before a byte of it is read
            return self._next_id
        self._conns[self._next_id] = conn
        self.router.connection_opened(self._next_id, address=conn.peer[0])
        log.info("event=connect conn=%d peer=%s:%d", self._next_id, *conn.peer)
        return self._next_id

    def handle(
        self, conn: ServerConnection, msg: Message, *, tag: FrameTag, received_ns: int
    ) -> Outcome:
        outcome = self.router.handle(
            conn.conn_id, msg, tag=tag, received_ns=received_ns, now_ns=time.time_ns()
        )
        if msg.type in _BINDS:
            self._note_bind(conn, msg, outcome)
        if outcome.push_stream:
            self._open_push(conn, msg, outcome.push_stream)
        self._apply(outcome, conn.conn_id)
        return outcome

    def _open_push(self, conn: ServerConnection, msg: Message, stream: str) -> None:
        """Start pushing a stream's samples on `conn` (11.6).

        One sample at a time (OA-DELIV-5), or up to max-in-flight when the reader declared
        `pipelining` in its notification (OA-SESS-19).
        """
        declared = declared_extensions(msg) or frozenset()
        window = self.limits.max_in_flight if "pipelining" in declared else 1
        self._pushers[conn.conn_id] = Pusher(
            conn,
            stream=stream,
            capacity=self.limits.stream_push_buffer,
            window=window,
            max_bytes=self.limits.stream_push_buffer_bytes,  # OA-LIM-16
        )
        log.info("event=push_subscribe conn=%d stream=%s window=%d", conn.conn_id, stream, window)

    def handle_binary(self, conn: ServerConnection, chunk: bytes, *, received_ns: int) -> Outcome:
        outcome = self.router.handle_binary(
            conn.conn_id, chunk, received_ns=received_ns, now_ns=time.time_ns()
        )
        self._apply(outcome, conn.conn_id)
        return outcome

    def observe(self, observer: ServerObserver) -> Callable[[], None]:
        """Show every stored post and every acknowledged delivery to `observer` (one at a
        time); return the function that detaches it (openair.observing)."""
        self.router.observer = observer.observe
        self.dispatcher.on_delivered = observer.delivered

        def detach() -> None:
            if self.router.observer == observer.observe:
                self.router.observer = None
            if self.dispatcher.on_delivered == observer.delivered:
                self.dispatcher.on_delivered = None

        return detach

    def inject(self, msg: Message, *, received_ns: int, conn_id: int = 0) -> Outcome:
        """Route a message that came from no connection (the monitor's post form) as a post.

        Its deliveries are queued as for any request; its replies are the caller's to read.
        Internal modules pass their own negative `conn_id` (their session, OA-CONF-8).
        """
        outcome = self.router.handle(
            conn_id, msg, tag=FrameTag.MESSAGE, received_ns=received_ns, now_ns=received_ns
        )
        if outcome.later is not None:  # the caller reads the reply now
            outcome = replace(outcome, replies=(outcome.later()[0],), later=None)
        if outcome.awaited is not None:  # the caller reads the reply now (the loop waits)
            pending = outcome.awaited
            with contextlib.suppress(Exception):
                pending.done.result(_STORE_WAIT_S)
            reply = pending.reply(pending.done, time.time_ns())
            outcome = replace(outcome, replies=(reply,), awaited=None)
        self._apply(outcome, conn_id)
        return outcome

    def http_takeover(self, conn: ServerConnection, data: bytes) -> bool:
        """Hand a connection that began with an HTTP method to the monitor (as Psyclone did).

        Returns False (the connection stays an OpenAIR one) when no monitor is attached.
        """
        monitor = self.monitor
        if monitor is None or conn.transport is None:
            return False
        if self._conns.pop(conn.conn_id, None) is not None:
            self.budget.release(conn.peer[0])  # the monitor counts its own (OA-LIM-11)
        self.router.connection_closed(conn.conn_id, now_ns=time.time_ns())  # nothing bound yet
        monitor.adopt(conn.transport, data)
        return True

    def callback_opened(self, conn: ServerConnection, module: str) -> None:
        log.info("event=callback conn=%d module=%s", conn.conn_id, module)
        self.dispatcher.poke(module)

    def connection_lost(self, conn: ServerConnection) -> None:
        if self._conns.pop(conn.conn_id, None) is None:
            return  # refused by the budget (OA-LIM-11) or handed to the monitor: never served
        self.budget.release(conn.peer[0])
        self._pushers.pop(conn.conn_id, None)
        if conn.waiting is not None:
            timer = self._wait_timers.pop(conn.waiting, None)
            if timer is not None:
                timer[1].cancel()
        if self._final:
            return  # the server is going away: no Lost notices into a closed store
        outcome = self.router.connection_closed(conn.conn_id, now_ns=time.time_ns())
        self._apply(outcome, conn.conn_id)
        if conn.role is Role.CALLBACK:
            self.dispatcher.poke(conn.module)

    def _note_bind(self, conn: ServerConnection, msg: Message, outcome: Outcome) -> None:
        """Log binds and takeovers (OA-SESS-6), and wake the module's delivery task."""
        info = self.router.module(msg.sender)
        if info is None or info.conn != conn.conn_id:
            return
        for old in outcome.close_conns:
            log.info("event=takeover module=%s old_conn=%d conn=%d", msg.sender, old, conn.conn_id)
        log.info(
            "event=bind module=%s conn=%d port=%d extensions=%s",
            msg.sender,
            conn.conn_id,
            info.port,
            ",".join(sorted(info.extensions)) or "-",
        )
        self.dispatcher.poke(msg.sender)
        if self.cluster is not None:
            self.cluster.announce()  # OA-CLU-7

    def _apply(self, outcome: Outcome, this: int) -> None:
        """Queue the outcome's deliveries and close the connections it names (not `this`)."""
        if not self._final:
            for delivery in outcome.deliveries:
                self.dispatcher.push(delivery)
        if outcome.wait is not None or outcome.resolved or outcome.pushes:
            self._apply_streams(outcome, this)
        for conn_id in outcome.close_conns:
            other = self._conns.get(conn_id)
            if other is not None and conn_id != this:
                other.close()
        for name in outcome.discard_queues:
            log.info("event=lost module=%s conn=%d", name, this)
            self._spawn(self.dispatcher.discard(name))  # OA-SESS-15

    def _apply_streams(self, outcome: Outcome, this: int) -> None:
        """Arm a wait's timeout, send ready deferred replies, push samples (spec 11)."""
        wait = outcome.wait
        if wait is not None:
            delay = max(wait.deadline_ns - time.time_ns(), 0) / 1e9
            timer = asyncio.get_running_loop().call_later(delay, self._wait_over, wait.ticket)
            self._wait_timers[wait.ticket] = (this, timer)
        for ready in outcome.resolved:
            armed = self._wait_timers.pop(ready.ticket, None)
            if armed is not None:
                armed[1].cancel()
            conn = self._conns.get(ready.conn)
            if conn is not None:
                conn.finish_wait(ready.ticket, ready.reply)
        for push in outcome.pushes:
            self._push(push)

    def _push(self, push: SamplePush) -> None:
        for conn_id in push.conns:
            pusher = self._pushers.get(conn_id)
            if pusher is not None:
                dropped = pusher.offer(push.sample)
                if dropped:
                    self._count_dropped("SAMPLE_DROPPED", dropped)
        if not self._final:
            for module in push.modules:
                self.dispatcher.push_sample(
                    module, push.stream, push.sample, self.limits.stream_push_buffer
                )

    def _wait_over(self, ticket: int) -> None:
        """A WAIT_FOR_*'s timeout passed (OA-STREAM-7)."""
        self._wait_timers.pop(ticket, None)
        self._apply(self.router.wait_expired(ticket, time.time_ns()), 0)

    def _tick(self) -> None:
        """Post due Idle alarms (OA-XSTREAM-7), then check again in `_TICK_S`."""
        self._ticker = None
        if self._stopping:
            return
        self._apply(self.router.tick(time.time_ns()), 0)
        self._ticker = asyncio.get_running_loop().call_later(_TICK_S, self._tick)

    def _sweep(self) -> None:
        """Forget modules gone longer than module-retention-ms (OA-LIM-15); look again later."""
        retention_ms = self.limits.module_retention_ms
        if self.cluster is not None:
            self.cluster.announce()  # OA-CLU-7: heartbeats carry them
        forgotten = self.router.forget_gone(time.time_ns(), retention_ms * 1_000_000)
        if forgotten:
            log.info("event=forgotten modules=%d", forgotten)
        delay = max(0.05, min(retention_ms / 4000, 60.0))  # a name goes at most 25 % late
        self._sweeper = asyncio.get_running_loop().call_later(delay, self._sweep)

    def _spawn(self, coro: Coroutine[object, object, int]) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # -- DeliveryHost ---------------------------------------------------------------------------

    def module_info(self, name: str) -> ModuleInfo | None:
        return self.router.module(name)

    def connection(self, conn_id: int) -> ServerConnection | None:
        return self._conns.get(conn_id)

    async def connect(self, module: str, address: str, port: int) -> ServerConnection:
        loop = asyncio.get_running_loop()
        _, conn = await loop.create_connection(
            lambda: ServerConnection(self, Role.OUTBOUND), address, port
        )
        conn.module = module
        self._outbound.add(conn)
        conn.closed.add_done_callback(lambda _: self._outbound.discard(conn))
        log.info("event=deliver_connect module=%s address=%s port=%d", module, address, port)
        return conn

    def delivered(self, module: str, count: int) -> None:
        self.delivered_total += count
        for _ in range(count):
            self.router.note_delivered(module)

    def dropped(self, module: str, count: int, reason: str) -> None:
        self._count_dropped(reason, count)
        self.router.note_dropped(module, count)

    def _count_dropped(self, reason: str, count: int) -> None:
        self.dropped_total[reason] = self.dropped_total.get(reason, 0) + count

    # -- life cycle -----------------------------------------------------------------------------

    def _protocol(self) -> ServerConnection:
        return ServerConnection(self, Role.RESPONDER)

    async def _listen(self) -> None:
        """Bind the listening socket, build the router with the real port, start serving."""
        loop = asyncio.get_running_loop()
        self._listener = await loop.create_server(
            self._protocol,
            self.options.host,
            self.port,
            start_serving=False,
            backlog=ACCEPT_BATCH,  # the listen backlog is set after (`full_backlog`)
            reuse_address=True,
            ssl=self.options.tls,  # OA-AUTH-10
        )
        self.port = int(self._listener.sockets[0].getsockname()[1])
        quiet_accept_errors(loop, time.monotonic)  # EMFILE: one line per interval, no traceback
        address = "127.0.0.1" if self.host in _WILDCARD_HOSTS else self.host
        self.cluster = join_cluster(
            self.store, self.config, loop, self._running_router, self._apply
        )
        self.router = Router(
            self.config,
            self.store,
            server_name=f"openair-kit/{openair.__version__}",  # OA-CAP-1: implementation/version
            address=address,
            port=self.port,
            limits=self.limits,
            extensions=self.extensions,
            port_allocator=free_port,
            auth=auth_gate(self.options.auth_secrets),  # 14.3; None in legacy mode
        )
        self.router.status_extra = self._status_counters
        self.router.queued_bytes = self.dispatcher.queued_bytes  # OA-LIM-14
        self.router.defer_large_replies = True  # written on a worker thread (issue #19)
        self.router.frames_only = self.sends_frames
        self.router.defer_large_wakeups = True  # so are large wakeups (Dispatcher.builds)
        self.router.pause_builds(pause_for_the_loop)  # their writer lets the lock go (#19)
        self.router.defer_store_replies = True  # a cluster's acknowledgements (spec 17)
        if self.cluster is not None:
            self.router.elsewhere = self.cluster.store.forward_soon  # OA-CLU-8
        self._apply(self.router.start(time.time_ns()), 0)  # OA-SESS-31: System.Ready
        self.internal = start_internal(self)  # OA-CONF-8; ConfigError refuses the start
        if "typed-streams" in self.extensions:
            self._ticker = asyncio.get_running_loop().call_later(_TICK_S, self._tick)
        self._sweep()
        if self._attach_monitor is not None and "monitor" in self.extensions:  # OA-AUTH-11
            self.monitor = await self._attach_monitor(ObservedView(self))
        await self._listener.start_serving()
        full_backlog(self._listener, self.options.backlog)  # accepted ACCEPT_BATCH a turn
        log.info(
            "event=listening host=%s port=%d whiteboards=%s extensions=%s",
            self.host,
            self.port,
            ",".join(self.whiteboards),
            ",".join(sorted(self.extensions)),
        )

    def _running_router(self) -> Router | None:
        """The router while the server runs (a cluster's store hands over to it)."""
        return None if self._final or not hasattr(self, "router") else self.router

    @property
    def whiteboards(self) -> tuple[str, ...]:
        """The names of the configured whiteboards."""
        return tuple(wb.name for wb in self.config.whiteboards)

    def counters(self) -> dict[str, object]:
        """The router's counters plus every module's queue and delivery counters."""
        counters = dict(self.router.counters())
        counters["queues"] = self.dispatcher.counters()
        counters["connections"] = len(self._conns)
        counters["delivered"] = self.delivered_total
        counters["dropped"] = dict(self.dropped_total)
        counters["budget"] = self.budget.counters()  # OA-LIM-11, OA-LIM-12
        counters["fairness"] = self._fairness()
        return counters

    def rate_counters(self) -> dict[str, dict[str, int]]:
        """What a monitor samples for rates, in time of the live modules only (issue #19)."""
        return self.router.rate_counters()

    def _fairness(self) -> dict[str, object]:
        """How often a peer's connection waited for a later loop turn (issue #19)."""
        return Turns.counters_of(self.turns)

    def _status_counters(self) -> dict[str, object]:
        """The adapter's counters that STATUS adds to the router's (for monitors)."""
        return {
            "queues": self.dispatcher.counters(),
            "connections": len(self._conns),
            "delivered": self.delivered_total,
            "dropped": dict(self.dropped_total),
            "budget": self.budget.counters(),  # OA-LIM-11, OA-LIM-12
            "fairness": self._fairness(),
        }

    async def serve_forever(self) -> None:
        """Wait until the server has stopped."""
        await asyncio.shield(self._done)

    async def stop(self) -> None:
        """Shut down gracefully (OA-SESS-24); a second call waits for the first."""
        if self._stopping:
            await asyncio.shield(self._done)
            return
        self._stopping = True
        if self._ticker is not None:
            self._ticker.cancel()
        if self._sweeper is not None:
            self._sweeper.cancel()
        for _, timer in self._wait_timers.values():
            timer.cancel()
        log.info("event=shutdown phase=begin pending=%d", self.dispatcher.pending)
        if self._listener is not None:
            self._listener.close()  # stop accepting
        self.router.shutting_down()  # OA-SESS-24: later requests get SHUTTING_DOWN
        try:
            await asyncio.wait_for(self.dispatcher.drained(), self.options.grace_s)
        except TimeoutError:
            log.warning("event=shutdown phase=grace_over pending=%d", self.dispatcher.pending)
        self._final = True
        # Every stage below is bounded, so that stop() always finishes (issue #18).
        abandoned = await self.dispatcher.stop()  # counted DELIVERY_FAILED
        if self.monitor is not None:
            await _bounded("monitor", self.monitor.close(), _STAGE_S)
        await self._close_connections()
        if self._tasks:
            _, stuck = await asyncio.wait(list(self._tasks), timeout=_STAGE_S)
            for task in stuck:
                task.cancel()
                log.warning("event=shutdown phase=task_stuck task=%s", task.get_name())
        self.store.close()
        log.info("event=shutdown phase=done abandoned=%d", abandoned)
        if not self._done.done():
            self._done.set_result(None)

    async def _close_connections(self) -> None:
        """Close every connection, flushing replies; abort what does not close in time."""
        conns = [*self._conns.values(), *self._outbound]
        for conn in conns:
            conn.close(linger=False)
        waits = [conn.closed for conn in conns]
        if waits:
            _, late = await asyncio.wait(waits, timeout=self.flow.linger_s)
            for conn in conns:
                if not conn.closed.done():
                    conn.abort()
            if late:
                await asyncio.wait(late, timeout=1.0)
        if self._listener is not None:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._listener.wait_closed(), 1.0)


async def _bounded(stage: str, coro: Coroutine[object, object, None], limit: float) -> None:
    """Await one shutdown stage for at most `limit` seconds; log it when it overruns or fails."""
    try:
        async with asyncio.timeout(limit):
            await coro
    except TimeoutError:
        log.warning("event=shutdown phase=%s_timeout", stage)
    except Exception as exc:  # a failing stage must not stop the rest of the shutdown
        log.warning("event=shutdown phase=%s_error detail=%r", stage, str(exc))


async def start_server(options: ServerOptions | None = None) -> Server:
    """Start a server and return it listening (raises ConfigError, StoreSpecError, OSError)."""
    options = options or ServerOptions()
    config = config_of(options)
    options = replace(options, port=main_port(options.port, config))
    store = open_store(options.store)
    server = Server(options, config, store)
    try:
        await server._listen()
    except BaseException:
        if server._listener is not None:
            server._listener.close()
        store.close()
        raise
    return server
