"""Throughput and latency of the reference whiteboard server, as ratios to a minimal relay.

Cases (issue targets in brackets; the server pinned to CPU 0, the load generator to the others):
- fan-out 1: delivered wakeups/s, ~256-byte `noreply` posts, one subscriber [≥ 50 000/s];
- fan-out 10: posts/s in with ten subscribers each woken by every post [≥ 20 000/s];
- latency at 1 000 posts/s: p50 / p99 post → wakeup [p99 ≤ 1 ms];
- routing cost: fan-out 1 with 1, 100 and 10 000 registered patterns, all but one never matching
  [10 000 patterns ≥ 80 % of the 1-pattern rate].
The baseline is `bench.relay` (frames copied to subscribers, no parsing) under the same load; its
figure is measured in the same run, so the ratio column compares machines fairly. Server CPU is
read from /proc and reported as µs per post.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from bench import Result
from bench.loadgen import (
    PosterSpec,
    SubscriberSpec,
    connect,
    first_text,
    message,
    pin,
    poster,
    request,
    subscriber,
)

BENCH = "server"
_COUNT = int(os.environ.get("BENCH_SERVER_COUNT", "40000"))
_LAT_COUNT = 3000
_CTX = mp.get_context("fork")


@dataclass(frozen=True, slots=True, kw_only=True)
class Flow:
    """What one run of posts measured."""

    posts: int
    delivered: int
    seconds: float
    cpu_s: float
    latencies_ns: tuple[int, ...]

    @property
    def posts_per_s(self) -> float:
        return self.posts / self.seconds

    def percentile(self, q: float) -> float:
        """Return the q-quantile latency in milliseconds."""
        ordered = sorted(self.latencies_ns)
        return ordered[min(len(ordered) - 1, int(q * len(ordered)))] / 1e6


def _cpu_seconds(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@contextmanager
def _process(argv: list[str]) -> Iterator[tuple[int, int]]:
    """Start a server on CPU 0, wait for its "listening on HOST:PORT" line; yield (pid, port)."""
    proc = subprocess.Popen(
        argv,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        preexec_fn=lambda: pin(0),
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        if "listening on" not in line:
            raise RuntimeError(f"server did not start: {line!r}")
        port = int(line.split("listening on", 1)[1].split()[0].rsplit(":", 1)[1])
        yield proc.pid, port
    finally:
        proc.terminate()
        proc.wait(timeout=20)


def _server_argv() -> list[str]:
    code = "from openair.cli import main; main()"
    return [sys.executable, "-c", code, "serve", "--port", "0", "--log-level", "warning"]


def _relay_argv() -> list[str]:
    return [sys.executable, "-m", "bench.relay", "--port", "0"]


def _idle_modules(port: int, patterns: int) -> list[object]:
    """Bind modules holding `patterns` triggers that never match (≤ 1 000 per module)."""
    socks: list[object] = []
    for m in range(0, patterns, 1000):
        name = f"BenchIdle{m // 1000}"
        sock, buf = connect(port), bytearray()
        request(sock, buf, message("BIND_NOLISTEN", sender=name, to="CNS"))
        triggers = "".join(
            f'<trigger type="Bench.Idle{m + i}.*"/>'
            if i % 2
            else f'<trigger type="Bench.Flow.Other{m + i}"/>'
            for i in range(min(1000, patterns - m))
        )
        content = f'<module name="{name}">{triggers}</module>'
        sub = message(
            "AIR.Subscribe", sender=name, to="AIRCentral", content=content, xml_content=True
        )
        reply = request(sock, buf, sub)
        if first_text(reply, b"type") != b"RECEIVE_ACCEPT":
            raise RuntimeError(f"idle registration refused: {reply[:300]!r}")
        socks.append(sock)
    return socks


def _flow(
    port: int, pid: int, *, fanout: int, count: int, rate: float | None = None, relay: bool = False
) -> Flow:
    """Run one poster against `fanout` subscribers and measure it."""
    ready, received, start_ns = _CTX.Value("i", 0), _CTX.Value("q", 0), _CTX.Value("q", 0)
    out: mp.Queue[tuple[str, list[tuple[int, int]]]] = _CTX.Queue()
    subs = [
        _CTX.Process(
            target=_subscriber_main,
            args=(
                SubscriberSpec(
                    port=port,
                    name=f"BenchSub{i}",
                    patterns=("Bench.Flow.*",),
                    expected=count,
                    relay=relay,
                ),
                ready,
                received,
                None,
                out,
            ),
        )
        for i in range(fanout)
    ]
    for proc in subs:
        proc.start()
    while ready.value < fanout:
        time.sleep(0.01)
    spec = PosterSpec(port=port, count=count, type_="Bench.Flow.Data", rate=rate, fanout=fanout)
    cpu0, t0 = _cpu_seconds(pid), time.perf_counter()
    post = _CTX.Process(target=_poster_main, args=(spec, received, start_ns))
    post.start()
    results = [out.get(timeout=300) for _ in subs]
    seconds = time.perf_counter() - t0
    cpu = _cpu_seconds(pid) - cpu0
    post.join(60)
    for proc in subs:
        proc.join(60)
    lat = tuple(ns for _, pairs in results for _, ns in pairs)
    return Flow(posts=count, delivered=len(lat), seconds=seconds, cpu_s=cpu, latencies_ns=lat)


def _pin_load() -> None:
    """Pin a load-generator process to every CPU but the server's (CPU 0), when there are any.

    (Pinning each process to CPU 1 alone made ten subscribers and the poster share one CPU on
    machines that have more.)
    """
    others = set(range(1, os.cpu_count() or 1))
    if others and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, others)


def _subscriber_main(*args: object) -> None:
    _pin_load()
    subscriber(*args)  # type: ignore[arg-type]


def _poster_main(*args: object) -> None:
    _pin_load()
    poster(*args)  # type: ignore[arg-type]


def _throughput(name: str, flow: Flow, base: Flow, unit_per: str) -> list[Result]:
    note = f"{flow.cpu_s * 1e6 / flow.posts:.1f} µs server CPU/post; {flow.delivered} delivered"
    return [
        Result(
            bench=BENCH,
            case=name,
            value=flow.posts_per_s,
            unit=unit_per,
            ratio=flow.posts_per_s / base.posts_per_s,
            note=note,
        )
    ]


def run() -> list[Result]:
    """Measure every case against the relay and the reference server."""
    results: list[Result] = []
    with _process(_relay_argv()) as (rpid, rport):
        relay1 = _flow(rport, rpid, fanout=1, count=_COUNT, relay=True)
        relay10 = _flow(rport, rpid, fanout=10, count=_COUNT // 4, relay=True)
        relay_lat = _flow(rport, rpid, fanout=1, count=_LAT_COUNT, rate=1000, relay=True)
    results.append(
        Result(
            bench=BENCH,
            case="relay fan-out 1",
            value=relay1.posts_per_s,
            unit="msg/s",
            ratio=1.0,
            note="baseline",
        )
    )
    results.append(
        Result(
            bench=BENCH,
            case="relay fan-out 10",
            value=relay10.posts_per_s,
            unit="msg/s in",
            ratio=1.0,
            note="baseline",
        )
    )
    with _process(_server_argv()) as (pid, port):
        one = _flow(port, pid, fanout=1, count=_COUNT)
        results += _throughput("fan-out 1", one, relay1, "msg/s")
        ten = _flow(port, pid, fanout=10, count=_COUNT // 4)
        results += _throughput("fan-out 10", ten, relay10, "msg/s in")
        lat = _flow(port, pid, fanout=1, count=_LAT_COUNT, rate=1000)
        for q in (0.5, 0.99):
            results.append(
                Result(
                    bench=BENCH,
                    case=f"latency p{int(q * 100)} at 1000 msg/s",
                    value=lat.percentile(q),
                    unit="ms",
                    ratio=lat.percentile(q) / max(relay_lat.percentile(q), 1e-6),
                    note=f"relay {relay_lat.percentile(q):.3f} ms",
                )
            )
    for patterns in (1, 100, 10_000):
        with _process(_server_argv()) as (pid, port):
            idle = _idle_modules(port, patterns - 1)
            flow = _flow(port, pid, fanout=1, count=_COUNT)
            results += _throughput(f"routing, {patterns} patterns", flow, relay1, "msg/s")
            for sock in idle:
                sock.close()  # type: ignore[attr-defined]
    one_pattern = next(r for r in results if r.case == "routing, 1 patterns")
    many = next(r for r in results if r.case == "routing, 10000 patterns")
    results.append(
        Result(
            bench=BENCH,
            case="10 000 patterns vs 1",
            value=many.value / one_pattern.value,
            unit="ratio",
            note="target ≥ 0.80",
        )
    )
    return results
