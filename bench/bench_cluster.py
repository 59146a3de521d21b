"""A cluster of 1, 2 and 3 nodes against the single-process server (issue #22): `python -m bench
cluster`.

Every configuration gets the same load: three posters (one connection each, acknowledged posts
of ~100 bytes to WB1, spread over the nodes round-robin) and one watcher woken by every post.
Reported per configuration: posts/s, p50/p99 post→RECEIVE_ACCEPT, and p99 post→wakeup when the
watcher is on the poster's node (local) and on another node (remote), each as a ratio to the
single-process server (memory store) measured in the same run. The NATS servers run on
127.0.0.1 with distinct ports (a lab runs one per machine; the namespaces of tests/cluster are
for the fault tests), JetStream in a temporary directory, replicas = the number of nodes.
"""

from __future__ import annotations

import asyncio
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from bench import Result
from openair.client.module import Module

BENCH = "cluster"
_POSTS = int(os.environ.get("BENCH_CLUSTER_POSTS", "600"))  # per poster
_POSTERS = 3


@dataclass(frozen=True, slots=True)
class Measured:
    posts_per_s: float
    ack_p50_ms: float
    ack_p99_ms: float
    wake_p99_ms: float


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _quantile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float("nan")


@contextmanager
def _nats_cluster(count: int, work: Path) -> Iterator[list[str]]:
    """Start `count` clustered nats-servers on 127.0.0.1; yield their client URLs."""
    ports = [(_free_port(), _free_port()) for _ in range(count)]
    procs = []
    try:
        for i, (client, route) in enumerate(ports):
            routes = ", ".join(f"nats://127.0.0.1:{r}" for j, (_, r) in enumerate(ports) if j != i)
            cluster = (
                f"cluster {{ name: bench, listen: 127.0.0.1:{route}, routes: [{routes}] }}\n"
                if count > 1
                else ""
            )
            conf = work / f"nats{i}.conf"
            conf.write_text(
                f"server_name: b{i}\nlisten: 127.0.0.1:{client}\nmax_payload: 67108864\n"
                f'jetstream {{ store_dir: "{work / f"js{i}"}" }}\n{cluster}'
            )
            procs.append(
                subprocess.Popen(
                    ["nats-server", "-c", str(conf)],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )
        time.sleep(1.0 + count)  # routes connect and JetStream elects its meta leader
        yield [f"nats://127.0.0.1:{c}" for c, _ in ports]
    finally:
        for proc in procs:
            proc.terminate()
            proc.wait(10)


@contextmanager
def _servers(args: list[list[str]]) -> Iterator[list[int]]:
    """Start one `openair serve` per argument list; yield their ports."""
    procs: list[subprocess.Popen[bytes]] = []
    try:
        ports = []
        for extra in args:
            proc = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "openair.cli",
                    "serve",
                    "--port",
                    "0",
                    "--no-monitor",
                    "--log-level",
                    "warning",
                    *extra,
                ],
                stdout=subprocess.PIPE,
            )
            procs.append(proc)
            assert proc.stdout is not None
            line = proc.stdout.readline().decode()
            if "listening on" not in line:
                raise RuntimeError(f"the server did not start: {line!r}")
            ports.append(int(line.split()[2].rsplit(":", 1)[1].rstrip(")")))
        yield ports
    finally:
        for proc in procs:
            proc.terminate()
            proc.wait(30)


async def _load(ports: list[int], watcher_port: int) -> Measured:
    """Three posters over the nodes round-robin, one watcher; measure acks and wakeups."""
    sent: dict[str, float] = {}
    wakes: list[float] = []
    watcher = Module("BenchWatch", "127.0.0.1", watcher_port, listen=False)
    posters = [
        Module(f"BenchPost{i}", "127.0.0.1", ports[i % len(ports)], bind=False)
        for i in range(_POSTERS)
    ]
    for m in (watcher, *posters):
        await m.connect()
    await watcher.subscribe("Bench.*")
    done = asyncio.Event()

    async def watch() -> None:
        while len(wakes) < _POSTS * _POSTERS:
            event = await watcher.next_wakeup(timeout=30)
            if event is None:
                break
            trigger = event.wakeup.trigger
            if trigger is not None and trigger.content in sent:
                wakes.append(time.perf_counter() - sent[trigger.content])
        done.set()

    acks: list[float] = []

    async def post(i: int, m: Module) -> None:
        for n in range(_POSTS):
            key = f"{i}-{n}-" + "x" * 90
            started = sent[key] = time.perf_counter()
            await m.post("WB1", "Bench.Post", key)
            acks.append(time.perf_counter() - started)

    watching = asyncio.create_task(watch())
    started = time.perf_counter()
    await asyncio.gather(*(post(i, m) for i, m in enumerate(posters)))
    elapsed = time.perf_counter() - started
    await asyncio.wait_for(done.wait(), 60)
    await watching
    for m in (watcher, *posters):
        await m.close()
    return Measured(
        posts_per_s=len(acks) / elapsed,
        ack_p50_ms=_quantile(acks, 0.5) * 1000,
        ack_p99_ms=_quantile(acks, 0.99) * 1000,
        wake_p99_ms=_quantile(wakes, 0.99) * 1000,
    )


def _cluster_run(nodes: int, work: Path) -> tuple[Measured, Measured]:
    """Return (watcher on node 1, watcher on the last node) for a cluster of `nodes`."""
    with _nats_cluster(nodes, work / f"c{nodes}") as urls:
        spec = work / f"psyspec{nodes}.xml"
        spec.write_text(
            '<psySpec name="Bench" version="1.2">'
            + "".join(
                f'<whiteboard name="{b}" replicas="{nodes}"/>' for b in ("AIRCentral", "WB1", "WB2")
            )
            + "</psySpec>"
        )
        args = [
            ["--config", str(spec), "--cluster", ",".join([u, *(o for o in urls if o != u)]),
             "--node", f"b{i}"]
            for i, u in enumerate(urls)
        ]  # fmt: skip
        with _servers(args) as ports:
            local = asyncio.run(_load(ports[:1] * _POSTERS, ports[0]))
            spread = asyncio.run(_load(ports, ports[-1]))
    return local, spread


def run() -> list[Result]:
    if shutil.which("nats-server") is None:
        raise RuntimeError("nats-server is not installed (apt-get install nats-server)")
    load = os.getloadavg()[0]
    note = f"load {load:.2f}; {_POSTERS} posters x {_POSTS} acknowledged posts"
    work = Path(tempfile.mkdtemp(prefix="bench-cluster-"))
    (work / "c1").mkdir()
    (work / "c2").mkdir()
    (work / "c3").mkdir()
    results: list[Result] = []
    try:
        with _servers([[]]) as (port,):
            base = asyncio.run(_load([port], port))
        results += _rows("single process (baseline)", base, base, note)
        for nodes in (1, 2, 3):
            local, spread = _cluster_run(nodes, work)
            results += _rows(f"{nodes} node(s), all on node 1", local, base, note)
            if nodes > 1:
                results += _rows(f"{nodes} nodes, posters spread", spread, base, note)
                results.append(
                    Result(
                        bench=BENCH,
                        case=f"{nodes} nodes: remote/local wakeup p99",
                        value=spread.wake_p99_ms / local.wake_p99_ms,
                        unit="x",
                        note="watcher on another node than 2 of 3 posters vs on theirs",
                    )
                )
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return results


def _rows(case: str, m: Measured, base: Measured, note: str) -> list[Result]:
    return [
        Result(bench=BENCH, case=f"{case}: posts/s", value=m.posts_per_s, unit="posts/s",
               ratio=m.posts_per_s / base.posts_per_s, note=note),
        Result(bench=BENCH, case=f"{case}: ack p50", value=m.ack_p50_ms, unit="ms",
               ratio=m.ack_p50_ms / base.ack_p50_ms),
        Result(bench=BENCH, case=f"{case}: ack p99", value=m.ack_p99_ms, unit="ms",
               ratio=m.ack_p99_ms / base.ack_p99_ms),
        Result(bench=BENCH, case=f"{case}: post->wakeup p99", value=m.wake_p99_ms, unit="ms",
               ratio=m.wake_p99_ms / base.wake_p99_ms),
    ]  # fmt: skip
