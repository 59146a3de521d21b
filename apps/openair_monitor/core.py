"""The monitor attached to one server: its tap, its HTTP connections and listener, its timers.

`Monitor.start()` attaches the tap through the server's observer interface (`Server.observe`,
openair.observing: stored posts, and acknowledged deliveries for post -> wakeup latency),
starts a once-a-second sampler for rates, and opens the `--http-port` listener when asked.
HTTP on the main port arrives through `adopt()` (the server hands over a connection whose
first bytes are an HTTP request line, OA-EXT-3).
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from openair_monitor import api, views
from openair_monitor.hostcheck import allowed_names, host_allowed, origin_allowed
from openair_monitor.http import (
    EventStream,
    HttpConnection,
    HttpError,
    HttpLimits,
    Request,
    Response,
    error_response,
)
from openair_monitor.sse import Broadcaster
from openair_monitor.tap import RateMeter, Tap

if TYPE_CHECKING:
    from openair.observing import ObservedServer

__all__ = ["Monitor", "MonitorOptions"]

_NS_PER_MS = 1_000_000


@dataclass(frozen=True, slots=True, kw_only=True)
class MonitorOptions:
    """How the monitor serves: HTTP limits, memory, and the timing of live updates (seconds)."""

    limits: HttpLimits = field(default_factory=HttpLimits)
    ring: int = 512  # recent posts kept with their wakeups (a longer ring costs routing cache)
    ring_bytes: int = 32 << 20  # and no more bytes of them than this (issue #19)
    sample_s: float = 1.0  # counter samples for rates
    rate_window_s: float = 5.0
    window_s: float = 10.0  # the type graph's window
    tick_s: float = 0.2  # event streams: batch interval
    overview_s: float = 1.0
    graph_s: float = 2.0
    heartbeat_s: float = 15.0
    retry_ms: int = 2000  # EventSource reconnect delay
    scan: int = 2000  # events a stream looks at per tick
    batch: int = 50  # messages a stream gets per tick (a page shows 200 at most)
    max_buffer: int = 256 * 1024  # unsent bytes before a stream's batches are dropped
    stall_s: float = 30.0  # a stream that cannot be written for this long is closed


class Monitor:
    """The web monitor of one server (implements the server's MonitorHook)."""

    def __init__(
        self,
        server: ObservedServer,
        options: MonitorOptions | None = None,
        *,
        post: bool = False,
        hosts: tuple[str, ...] = ("127.0.0.1", "::1"),
        http_port: int | None = None,
    ) -> None:
        self.server = server
        self.options = options or MonitorOptions()
        self.limits = self.options.limits
        self.post_enabled = post
        self.post_hosts = frozenset(hosts)
        # DNS rebinding (issue #19): names in Host/Origin that the monitor answers.
        self.host_names = allowed_names(server.options.host, hosts)
        self._per_peer: dict[str, int] = {}
        self.tap = Tap(self.options.ring, self.options.ring_bytes)
        self.rates = RateMeter(self.options.rate_window_s)
        self.broadcaster = Broadcaster(self)
        self.latency_hooked = False
        self.http_port: int | None = None
        self._wanted_port = http_port
        self._listener: asyncio.Server | None = None
        self._conns: set[HttpConnection] = set()
        self._since: dict[tuple[str, int | None], int] = {}
        self._loop = asyncio.get_running_loop()
        self._sampler: asyncio.TimerHandle | None = None
        self._closed = False
        self._detach: Callable[[], None] = lambda: None

    # -- life cycle -------------------------------------------------------------------------

    async def start(self) -> None:
        """Open the HTTP port when one was asked for (OSError if it cannot), tap, sample."""
        if self._wanted_port is not None:  # first: a failure leaves nothing running
            self._listener = await self._loop.create_server(
                lambda: HttpConnection(self),
                self.server.options.host,
                self._wanted_port,
                reuse_address=True,
            )
            self.http_port = int(self._listener.sockets[0].getsockname()[1])
        # Posts into the ring, acknowledged deliveries into the latency histograms.
        self._detach = self.server.observe(self.tap)
        self.latency_hooked = True
        self._sample()

    def adopt(self, transport: asyncio.Transport, data: bytes) -> None:
        """Serve HTTP on a main-port connection whose first bytes were `data` (OA-EXT-3)."""
        conn = HttpConnection(self)
        transport.set_protocol(conn)
        conn.connection_made(transport)
        if not conn.closing:
            conn.data_received(data)

    async def close(self) -> None:
        """Untap the router, stop the timers, close the listener and every HTTP connection."""
        if self._closed:
            return
        self._closed = True
        self._detach()
        if self._sampler is not None:
            self._sampler.cancel()
        self.broadcaster.close()
        if self._listener is not None:
            self._listener.close()
        for conn in list(self._conns):
            conn.close()
        if self._listener is not None:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._listener.wait_closed(), 1.0)

    # -- HttpApp ----------------------------------------------------------------------------

    def respond(self, request: Request, peer: str) -> Response | EventStream:
        """Answer one HTTP request (pages, static files, the JSON API).

        A request whose Host or Origin names a host the monitor does not answer is refused
        (403): a browser sent it for a page of another site (DNS rebinding).
        """
        names = self.host_names
        if not host_allowed(request.header("host"), names):
            return error_response(HttpError(403, "Host not allowed"), close=True)
        if not origin_allowed(request.header("origin"), names):
            return error_response(HttpError(403, "Origin not allowed"), close=True)
        return api.respond(self, request, peer)

    def opened(self, conn: HttpConnection) -> bool:
        held = self._per_peer.get(conn.peer, 0)
        if self._closed or len(self._conns) >= self.limits.max_connections:
            return False
        if held >= self.limits.max_per_peer:
            return False  # one peer cannot take every connection (issue #19)
        self._conns.add(conn)
        self._per_peer[conn.peer] = held + 1
        return True

    def closed(self, conn: HttpConnection) -> None:
        if conn not in self._conns:
            return  # refused in `opened`: never counted
        self._conns.discard(conn)
        held = self._per_peer.pop(conn.peer, 1) - 1
        if held > 0:
            self._per_peer[conn.peer] = held

    # -- what the views read ----------------------------------------------------------------

    def _sample(self) -> None:
        """Sample the counters that have rates, and note which modules are bound since when."""
        self._sampler = None
        if self._closed:
            return
        # The live modules only: every name the retention keeps (OA-LIM-15) would make each
        # sample cost milliseconds of the loop per thousand names (issue #19, item 7).
        tables = self.server.rate_counters()
        values: dict[str, int] = {}
        for table in tables.values():
            values.update(table)
        self.rates.sample(self._loop.time(), values)
        self._note_bound({name[4:] for name in tables.get("modules", {}) if name[:4] == "out:"})
        self._sampler = self._loop.call_later(self.options.sample_s, self._sample)

    def _note_bound(self, bound: set[str]) -> None:
        """Remember when each (module, connection) was first seen bound; forget the gone ones."""
        now_ms = time.time_ns() // _NS_PER_MS
        server = self.server
        seen: set[tuple[str, int | None]] = set()
        for name in bound:
            info = server.module(name)
            if info is not None:
                key = (name, info.conn)
                seen.add(key)
                self._since.setdefault(key, now_ms)
        for key in set(self._since) - seen:
            del self._since[key]

    def bound_names(self, counters: Mapping[str, object] | None = None) -> set[str]:
        """The names of the modules bound now, as far as the server's counters name them."""
        counters = counters or self.server.counters()
        names: set[str] = set(self.tap.last_type) if len(self.tap.last_type) < 5000 else set()
        for key in ("modules", "registrations", "queues"):
            table = counters.get(key)
            if isinstance(table, Mapping):
                names.update(str(n) for n in table)
        server = self.server
        return {n for n in names if server.module(n) is not None}

    def since_ms(self, name: str, conn: int | None) -> int | None:
        """When the monitor first saw `name` bound on `conn` (Unix ms), if it is bound."""
        if conn is None:
            return None
        key = (name, conn)
        if key not in self._since and self.server.module(name) is not None:
            self._since[key] = time.time_ns() // _NS_PER_MS
        return self._since.get(key)

    def streams(self, counters: Mapping[str, object] | None = None) -> dict[str, dict[str, str]]:
        """Each stream's `info()` and counters (added, dropped, subscribers) as text.

        Read from the server's counters (`streams`: name -> fields), defensively: a server
        without streams, or with fields this monitor does not know, still shows the rest.
        """
        table = (counters if counters is not None else self.server.counters()).get("streams")
        if not isinstance(table, Mapping):
            return {}
        out: dict[str, dict[str, str]] = {}
        for name, fields in table.items():
            row = {str(k): str(v) for k, v in fields.items()} if isinstance(fields, Mapping) else {}
            out[str(name)] = row
        return out

    def stats(self) -> dict[str, object]:
        """The monitor's own counters."""
        streams = self.broadcaster.streams
        return {
            "events": self.tap.count,
            "ring": len(self.tap.ring),
            "ring_capacity": self.tap.ring.maxlen,
            "tap_errors": self.tap.errors,
            "connections": len(self._conns),
            "streams": len(streams),
            "skipped": sum(s.skipped for s in streams),
            "dropped": sum(s.dropped for s in streams),
            "latency_measured": self.latency_hooked,
        }

    def overview(self) -> dict[str, object]:
        return views.overview(self, self._loop.time(), time.time_ns())

    def graph(self) -> dict[str, object]:
        return views.graph(self, time.time_ns())

    def now(self) -> float:
        """The loop's clock (for rates)."""
        return self._loop.time()
