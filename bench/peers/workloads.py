"""One workload against one broker: subscriber processes, a publisher process, the measurement.

Subscribers and the publisher are forked processes on every CPU but the broker's (CPU 0). The
publisher patches the stamp of a pre-encoded publish in place and sends batches of 64; without a
rate it stays at most `window` messages ahead of the slowest tracked subscriber (so a broker's
queues, not the generator, set the pace); with a rate it sends at absolute due times. After the
last publish it makes a round trip (PING), so the broker has read everything. The run ends when
every tracked subscriber has every message, or when deliveries stop for `_IDLE_S` seconds.
"""

from __future__ import annotations

import array
import multiprocessing as mp
import os
import socket
import time
from dataclasses import dataclass, field
from multiprocessing.sharedctypes import Synchronized
from multiprocessing.synchronize import Event
from typing import Any

from bench.peers import clients
from bench.peers.brokers import Broker, cpu_seconds, memory_kib, reset_peak, wait_seconds
from bench.peers.protocols import scan_stamps

_CTX = mp.get_context("fork")
_IDLE_S = 1.5  # no delivery for this long after the last publish ends a run
_DRAIN_CAP_S = 15.0


@dataclass(frozen=True, slots=True, kw_only=True)
class Workload:
    """What to run: a fan-out, a rate (None = as fast as possible), a payload size."""

    case: str
    fanout: int = 1
    rate: float | None = None
    seconds: float = 3.0
    size: int = 64
    idle: int = 0  # extra subscriptions that never match, held by one more connection
    stall: bool = False  # one more subscriber that never reads
    window: int = 2000


@dataclass(frozen=True, slots=True, kw_only=True)
class SubReport:
    """What one subscriber saw."""

    received: int
    max_seq: int
    last_ns: int
    latencies: bytes  # array('q') of ns
    cpu_s: float
    closed: bool  # the broker closed the connection
    stalled: bool = False


@dataclass(frozen=True, slots=True, kw_only=True)
class PubReport:
    sent: int
    start_ns: int
    end_ns: int
    cpu_s: float


@dataclass(frozen=True, slots=True, kw_only=True)
class Flow:
    """One workload measured against one broker."""

    broker: str
    case: str
    fanout: int = 1
    sent: int = 0
    delivered: int = 0  # to the tracked (reading) subscribers
    seconds: float = 0.0
    cpu_s: float = 0.0
    wait_s: float = 0.0  # the broker was runnable but another process held its CPU
    gen_cpu_s: float = 0.0
    peak_rss_kib: int = 0
    rss_growth_kib: int = 0
    latencies_ms: tuple[float, float, float] = (float("nan"),) * 3  # p50, p99, p99.9
    stalled: str = ""  # what happened to the subscriber that stopped reading
    load: float = 0.0
    error: str = ""
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def in_rate(self) -> float:
        """Messages in per second that reached every tracked subscriber."""
        return self.delivered / self.fanout / self.seconds if self.seconds else 0.0

    @property
    def cpu_us_per_msg(self) -> float:
        return self.cpu_s * 1e6 / self.sent if self.sent else float("nan")


def load_average() -> float:
    return os.getloadavg()[0]


def _pin_load() -> None:
    others = set(range(1, os.cpu_count() or 1))
    if others:
        os.sched_setaffinity(0, others)


# --- subscriber process -------------------------------------------------------------------------


def _subscriber_main(
    proto: str,
    port: int,
    name: str,
    stall: bool,
    shared: tuple[Synchronized[int], Synchronized[int]],
    stop: Event,
    out: mp.Queue[SubReport],
) -> None:
    _pin_load()
    ready, delivered = shared
    socks = clients.open_subscriber(proto, port, name, [clients.flow_pattern(proto)])
    with ready.get_lock():
        ready.value += 1
    sock = socks[0]
    if stall:
        stop.wait()
        out.put(_drain_stalled(proto, sock))
        return
    sock.settimeout(0.1)
    stamps: list[tuple[int, int]] = []
    lat, tail, buf, acked = array.array("q"), b"", bytearray(), 0
    last_ns, max_seq, count, closed = 0, -1, 0, False
    while not stop.is_set():
        try:
            if proto == "openair":
                frames = clients.take_frames(sock, buf)
                sock.sendall(clients.openair_acks(frames, name, acked))
                acked += len(frames)
                for xml in frames:
                    scan_stamps(xml, stamps)
            else:
                data = sock.recv(1 << 20)
                if not data:
                    raise ConnectionError("closed")
                tail = scan_stamps(tail + data if tail else data, stamps)
        except TimeoutError:
            continue
        except (ConnectionError, OSError):
            closed = True
            break
        if stamps:
            now = time.time_ns()
            lat.extend(now - ns for _, ns in stamps)
            max_seq = max(max_seq, stamps[-1][0])
            count += len(stamps)
            last_ns = now
            with delivered.get_lock():
                delivered.value += len(stamps)
            stamps.clear()
    out.put(
        SubReport(
            received=count,
            max_seq=max_seq,
            last_ns=last_ns,
            latencies=lat.tobytes(),
            cpu_s=time.process_time(),
            closed=closed,
        )
    )


def _drain_stalled(proto: str, sock: socket.socket) -> SubReport:
    """Read what the broker still holds for the stalled subscriber (0.5 s of silence ends it)."""
    sock.settimeout(0.5)
    stamps: list[tuple[int, int]] = []
    tail, closed = b"", False
    while True:
        try:
            data = sock.recv(1 << 20)
        except TimeoutError:
            break
        except OSError:
            closed = True
            break
        if not data:
            closed = True
            break
        tail = scan_stamps(tail + data, stamps)
    seqs = [s for s, _ in stamps]
    return SubReport(
        received=len(set(seqs)),
        max_seq=max(seqs, default=-1),
        last_ns=0,
        latencies=b"",
        cpu_s=time.process_time(),
        closed=closed,
        stalled=True,
    )


# --- publisher process --------------------------------------------------------------------------


def _publisher_main(
    proto: str, port: int, spec: Workload, delivered: Synchronized[int], out: mp.Queue[PubReport]
) -> None:
    _pin_load()
    sock = clients.open_publisher(proto, port)
    sock.setblocking(False)
    one, offset = clients.template(proto, spec.size)
    batch = 1 if spec.size > 65536 else 64
    buf = bytearray(one * batch)
    starts = [i * len(one) + offset for i in range(batch)]
    sent, start = 0, time.perf_counter()
    start_ns = time.time_ns()
    last_seen, last_change = 0, start
    while (now := time.perf_counter()) - start < spec.seconds:
        if spec.rate:
            n = min(batch, int((now - start) * spec.rate) + 1 - sent)
            if n <= 0:
                time.sleep(0.0002)
                continue
        else:
            seen = delivered.value
            if seen != last_seen:
                last_seen, last_change = seen, now
            if sent - seen // spec.fanout > spec.window and now - last_change < 1.0:
                time.sleep(0.0002)
                continue
            n = batch
        for i in range(n):
            at = starts[i]
            buf[at : at + 32] = f"{sent + i}:{time.time_ns()}".encode().ljust(32, b"_")
        _send_all(sock, memoryview(buf)[: n * len(one)], proto)
        sent += n
    clients.round_trip(proto, sock)
    out.put(
        PubReport(sent=sent, start_ns=start_ns, end_ns=time.time_ns(), cpu_s=time.process_time())
    )
    sock.close()


def _send_all(sock: socket.socket, data: memoryview, proto: str) -> None:
    """Send everything, discarding replies meanwhile (redis answers every PUBLISH)."""
    while data:
        try:
            data = data[sock.send(data) :]
        except BlockingIOError:
            time.sleep(0.0001)
        if proto == "redis":
            try:
                while sock.recv(1 << 20, socket.MSG_DONTWAIT):
                    pass
            except BlockingIOError:
                pass


# --- orchestration ------------------------------------------------------------------------------


def _percentiles(reports: list[SubReport]) -> tuple[float, float, float]:
    lat = array.array("q")
    for r in reports:
        lat.frombytes(r.latencies)
    if not lat:
        return (float("nan"),) * 3
    ordered = sorted(lat)
    pick = [ordered[min(len(ordered) - 1, int(q * len(ordered)))] / 1e6 for q in (0.5, 0.99, 0.999)]
    return pick[0], pick[1], pick[2]


def _wait_ready(ready: Synchronized[int], count: int, procs: list[Any]) -> None:
    deadline = time.monotonic() + clients.SETUP_TIMEOUT
    while ready.value < count:
        if any(p.exitcode is not None for p in procs) or time.monotonic() > deadline:
            raise RuntimeError(f"only {ready.value}/{count} subscribers came up")
        time.sleep(0.01)


def _drain(delivered: Synchronized[int], expected: int) -> None:
    """Wait until `expected` deliveries, or until none arrived for `_IDLE_S` seconds."""
    last, since, cap = -1, time.monotonic(), time.monotonic() + _DRAIN_CAP_S
    while delivered.value < expected and time.monotonic() < cap:
        if delivered.value != last:
            last, since = delivered.value, time.monotonic()
        elif time.monotonic() - since > _IDLE_S:
            return
        time.sleep(0.02)


def measure(broker: Broker, spec: Workload) -> Flow:
    """Run `spec` against `broker`; failures come back as a Flow with `error` set."""
    load = load_average()
    try:
        return _measure(broker, spec, load)
    except Exception as exc:  # one broker failing a workload must not end the run
        return Flow(
            broker=broker.name, case=spec.case, error=f"{type(exc).__name__}: {exc}", load=load
        )


def _measure(broker: Broker, spec: Workload, load: float) -> Flow:
    proto, port = broker.protocol, broker.port
    idle = []
    if spec.idle:
        patterns = [clients.idle_pattern(proto, i) for i in range(spec.idle)]
        idle = clients.open_subscriber(proto, port, "BenchIdle", patterns)
    ready, delivered = _CTX.Value("i", 0), _CTX.Value("q", 0)
    stop = _CTX.Event()
    sub_out: mp.Queue[SubReport] = _CTX.Queue()
    pub_out: mp.Queue[PubReport] = _CTX.Queue()
    stalls = [False] * spec.fanout + [True] * spec.stall
    subs = [
        _CTX.Process(
            target=_subscriber_main,
            args=(proto, port, f"BenchSub{i}", st, (ready, delivered), stop, sub_out),
        )
        for i, st in enumerate(stalls)
    ]
    pub = _CTX.Process(target=_publisher_main, args=(proto, port, spec, delivered, pub_out))
    try:
        for proc in subs:
            proc.start()
        _wait_ready(ready, len(subs), subs)
        reset_peak(broker.pid)
        rss0, cpu0 = memory_kib(broker.pid, "VmRSS"), cpu_seconds(broker.pid)
        wait0 = wait_seconds(broker.pid)
        pub.start()
        pubr = pub_out.get(timeout=spec.seconds + 120)
        rss1 = memory_kib(broker.pid, "VmRSS")
        _drain(delivered, pubr.sent * spec.fanout)
        cpu = cpu_seconds(broker.pid) - cpu0
        wait = wait_seconds(broker.pid) - wait0
        peak = memory_kib(broker.pid, "VmHWM")
        stop.set()
        reports = [sub_out.get(timeout=30) for _ in subs]
    finally:
        stop.set()
        for proc in (*subs, pub):
            if proc.pid is not None:
                proc.join(5)
                if proc.is_alive():
                    proc.terminate()
        for sock in idle:
            sock.close()
    reading = [r for r in reports if not r.stalled]
    stalled = [r for r in reports if r.stalled]
    last = max((r.last_ns for r in reading), default=pubr.end_ns)
    return Flow(
        broker=broker.name,
        case=spec.case,
        fanout=spec.fanout,
        sent=pubr.sent,
        delivered=sum(r.received for r in reading),
        seconds=max(last - pubr.start_ns, 1) / 1e9,
        cpu_s=cpu,
        wait_s=wait,
        gen_cpu_s=pubr.cpu_s + sum(r.cpu_s for r in reports),
        peak_rss_kib=peak,
        rss_growth_kib=rss1 - rss0,
        latencies_ms=_percentiles(reading),
        stalled=_describe_stalled(stalled[0], pubr.sent) if spec.stall and stalled else "",
        load=load,
    )


def _describe_stalled(r: SubReport, sent: int) -> str:
    fate = "disconnected by the broker" if r.closed else "still connected"
    return f"{fate}; {r.received} of {sent} delivered when it read again ({sent - r.received} lost)"
