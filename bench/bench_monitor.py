"""Does watching slow routing? Throughput on a busy whiteboard with 5 live views open vs none.

The reference server runs as `openair serve` (monitor on, its default) pinned to CPU 0; the load
is bench_server's: one poster sending ~256-byte `noreply` posts to WB1 as fast as a window of
2 000 undelivered posts allows, one subscriber woken by every post. The "5 views" case adds five
event streams (`/api/events?topics=messages,overview,graph&wb=WB1`, more than one browser page
asks for) read by a separate process on the load CPUs; they are connected and have had their
first events before the posts start, and stay connected until the run ends.

The runs alternate (none, views, none, views, …) so that drift in the machine's load hits both
cases alike; each case reports its best run. The ratio of the views case to the none case is
the figure (goal ≥ 0.95; no assertion). The server's CPU per post is reported too: it is less
sensitive to other jobs on the machine than posts per second.

Two in-process figures explain the end-to-end one and do not depend on the machine's other
load: the cost of a post through `Router.handle` with the tap installed against without it,
and the share of one CPU that five live views of a saturated whiteboard take (every batch
finds the whole ring new; the overview and graph rebuilt at their intervals), which bounds the
throughput a saturated server can lose to them.
"""

from __future__ import annotations

import asyncio
import os
import select
import socket
import time
from multiprocessing.sharedctypes import Synchronized
from multiprocessing.synchronize import Event

from bench import Result, per_call
from bench.bench_server import _CTX, Flow, _flow, _pin_load, _process, _server_argv
from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair.server.aio.app import ServerOptions, start_server
from openair.server.core.router import Router
from openair_monitor import Monitor
from openair_monitor.messages import MessageFilter

BENCH = "monitor"
_COUNT = int(os.environ.get("BENCH_MONITOR_COUNT", "20000"))
_ROUNDS = int(os.environ.get("BENCH_MONITOR_ROUNDS", "3"))
_VIEWS = 5
_QUERY = "topics=messages,overview,graph&wb=WB1"


def _views_main(
    port: int, n: int, ready: Synchronized[int], stop: Event, out: object
) -> None:  # pragma: no cover - runs in a child process
    """Open `n` event streams, read them until `stop`; report (bytes, message batches)."""
    _pin_load()
    socks = []
    for _ in range(n):
        sock = socket.create_connection(("127.0.0.1", port))
        sock.sendall(f"GET /api/events?{_QUERY} HTTP/1.1\r\nHost: bench\r\n\r\n".encode())
        socks.append(sock)
    greeted: set[socket.socket] = set()
    total = batches = 0
    while not stop.is_set():
        readable, _, _ = select.select(socks, [], [], 0.05)
        for sock in readable:
            data = sock.recv(1 << 16)
            if not data:
                raise RuntimeError("the server closed an event stream")
            total += len(data)
            batches += data.count(b"event: messages")
            if b"event: hello" in data:
                greeted.add(sock)
        if len(greeted) == n and not ready.value:
            ready.value = 1
    for sock in socks:
        sock.close()
    out.put((total, batches))  # type: ignore[attr-defined]


def _with_views(port: int, pid: int) -> tuple[Flow, int, int]:
    ready, stop = _CTX.Value("i", 0), _CTX.Event()
    out = _CTX.Queue()
    proc = _CTX.Process(target=_views_main, args=(port, _VIEWS, ready, stop, out))
    proc.start()
    while not ready.value:
        if not proc.is_alive():
            raise RuntimeError("the event-stream readers failed")
        stop.wait(0.01)
    flow = _flow(port, pid, fanout=1, count=_COUNT)
    stop.set()
    total, batches = out.get(timeout=60)
    proc.join(30)
    return flow, total, batches


def _best(flows: list[Flow]) -> Flow:
    return max(flows, key=lambda f: f.posts_per_s)


class _NullConn:
    """An event-stream connection that takes every write and is never behind."""

    buffered = 0
    closing = False
    on_close: object = None

    def write(self, data: bytes) -> None:
        pass

    def close(self) -> None:
        pass


def _handle(router: Router, msg: Message) -> None:
    now = time.time_ns()
    router.handle(1000, msg, tag=FrameTag.MESSAGE, received_ns=now, now_ns=now)


def _bind_subscriber(router: Router) -> None:
    """Bind a module woken by every bench post, through the router alone (no sockets)."""
    router.connection_opened(999, address="127.0.0.1")
    for msg in (
        Message(type="BIND_NOLISTEN", sender="BenchSub", to="CNS"),
        Message(
            type="AIR.Subscribe",
            sender="BenchSub",
            to="AIRCentral",
            content='<module name="BenchSub"><trigger type="Bench.*"/></module>',
            content_is_xml=True,
            language="xml",
        ),
    ):
        now = time.time_ns()
        router.handle(999, msg, tag=FrameTag.MESSAGE, received_ns=now, now_ns=now)


async def _in_process() -> list[Result]:
    server = await start_server(ServerOptions(port=0, grace_s=0.1))
    mon = server.monitor
    assert isinstance(mon, Monitor)
    try:
        _bind_subscriber(server.router)
        post = Message(type="Bench.Flow.Data", sender="Poster", to="WB1", content="x" * 200,
                       noreply=True)  # fmt: skip
        items = [post] * 200
        router = server.router
        off = on = float("inf")
        for _ in range(5):  # interleaved, so that the machine's other load hits both alike
            router.observer = None
            off = min(off, per_call(lambda m: _handle(router, m), items, repeat=2))
            router.observer = mon.tap.observe
            on = min(on, per_call(lambda m: _handle(router, m), items, repeat=2))
        share = _views_share(mon)
    finally:
        await server.stop()
    return [
        Result(bench=BENCH, case="post, tap off (in process)", value=off * 1e6, unit="µs",
               ratio=1.0, note="Router.handle of a post that wakes one module"),
        Result(bench=BENCH, case="post, tap on (in process)", value=on * 1e6, unit="µs",
               ratio=on / off, note="the observer appends to the ring"),
        Result(bench=BENCH, case=f"{_VIEWS} views, saturated: CPU share", value=share,
               unit="of 1 CPU", note=f"a saturated server keeps ≈ {1 / (1 + share):.3f} of its "
               "rate"),
    ]  # fmt: skip


def _views_share(mon: Monitor) -> float:
    """Return the CPU share five live views of a saturated whiteboard take."""
    b, opts = mon.broadcaster, mon.options
    for _ in range(_VIEWS):
        b.open(_NullConn(), frozenset({"messages"}), MessageFilter(whiteboard="WB1"))  # type: ignore[arg-type]

    def tick(_: int) -> None:
        for stream in b.streams:
            stream.cursor = mon.tap.oldest  # the whole ring is new, as under full load
        b._next_overview = b._next_graph = float("inf")  # timed on their own below
        b._tick()
        if b._timer is not None:
            b._timer.cancel()

    batch = per_call(tick, [0], repeat=5, min_time=0.1)
    overview = per_call(lambda _: mon.overview(), [0], repeat=5, min_time=0.1)
    graph = per_call(lambda _: mon.graph(), [0], repeat=5, min_time=0.1)
    b.close()
    return batch / opts.tick_s + overview / opts.overview_s + graph / opts.graph_s


def run() -> list[Result]:
    """Measure routing with no live view and with five, alternating, `_ROUNDS` of each."""
    none: list[Flow] = []
    views: list[Flow] = []
    streamed = [0, 0]
    with _process(_server_argv()) as (pid, port):
        _flow(port, pid, fanout=1, count=_COUNT // 4)  # warm-up: caches, allocator, JIT-free
        for _ in range(_ROUNDS):
            none.append(_flow(port, pid, fanout=1, count=_COUNT))
            flow, total, batches = _with_views(port, pid)
            views.append(flow)
            streamed[0] += total
            streamed[1] += batches
    base, watched = _best(none), _best(views)
    cpu_none = min(f.cpu_s / f.posts for f in none) * 1e6
    cpu_views = min(f.cpu_s / f.posts for f in views) * 1e6
    ratio = watched.posts_per_s / base.posts_per_s
    pairs = sorted(v.posts_per_s / n.posts_per_s for n, v in zip(none, views, strict=True))
    median = pairs[len(pairs) // 2]
    return [
        *asyncio.run(_in_process()),
        Result(
            bench=BENCH,
            case="routing, no live view",
            value=base.posts_per_s,
            unit="msg/s",
            ratio=1.0,
            note=f"baseline; {cpu_none:.1f} µs server CPU/post",
        ),
        Result(
            bench=BENCH,
            case=f"routing, {_VIEWS} live views",
            value=watched.posts_per_s,
            unit="msg/s",
            ratio=ratio,
            note=(
                f"{cpu_views:.1f} µs server CPU/post; views read {streamed[0] // 1024} KiB, "
                f"{streamed[1]} message batches"
            ),
        ),
        Result(
            bench=BENCH,
            case=f"{_VIEWS} views vs none",
            value=ratio,
            unit="ratio",
            note=(
                f"goal ≥ 0.95; best vs best; median of {len(pairs)} adjacent pairs "
                f"{median:.2f}; CPU/post ratio {cpu_none / cpu_views:.2f}"
            ),
        ),
    ]
