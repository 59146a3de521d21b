"""Streams of the reference server (issue #5), as ratios to the minimal relay.

Workloads (targets in brackets, reported, never asserted; server on CPU 0, load on the others):
- video: one writer, 640×480 RGB samples (921 600 bytes) at 30 Hz for ~10 s, 3 push subscribers
  [sustained without loss; server < 25 % of one core; p99 write → delivery < 15 ms];
- audio: 3 200-byte samples at 100 Hz for ~5 s, 10 push subscribers (same metrics);
- 1 KiB max: 1 KiB samples as BinaryM frames (after GET_NAME made the stream the connection's
  current stream, OA-STREAM-11), pipelined with at most 256 unacknowledged, one push subscriber;
  acknowledged and delivered samples/s over ~5 s.
The writer stamps each sample with `bench:n` (its sequence number) and `bench:t` (`time.time_ns()`
just before the send); a subscriber takes now − t when the whole frame has arrived. Push
subscribers acknowledge every DATASAMPLE (the server sends the next only then, OA-STREAM-12).
The baseline is `bench.relay` under the same workloads: it cannot delimit chunks that follow
XML, so there the writer sends each sample as one BinaryM frame (the same chunk bytes) and the
relay copies it to every subscriber, unacknowledged. `BENCH_STREAMS_SCALE` scales the durations.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import queue
import socket
import struct
import tempfile
import threading
import time
from dataclasses import dataclass, replace
from multiprocessing.synchronize import Event
from typing import Any

from bench import Result
from bench.bench_server import _cpu_seconds, _pin_load, _process, _relay_argv, _server_argv
from bench.loadgen import _ack, connect, first_text, frame, message, read_frames, request

BENCH = "streams"
_SCALE = float(os.environ.get("BENCH_STREAMS_SCALE", "1"))
_CTX = mp.get_context("fork")
_HEADER = struct.Struct("<7sxI")
_GRACE_S = 10.0  # how long subscribers may take to catch up after the writer's last sample
_BATCH = 64  # pipelined samples per send
_CONFIG = """<?xml version="1.0" encoding="UTF-8"?>
<psySpec name="BenchStreams" version="1.2">
  <whiteboard name="AIRCentral"/>
  <whiteboard name="WB1"><streams><stream name="Video" maxsize="64"/>
    <stream name="Audio" maxsize="16"/><stream name="Fast" maxsize="16"/></streams></whiteboard>
</psySpec>
"""


@dataclass(frozen=True, slots=True, kw_only=True)
class Workload:
    """One writer and its push subscribers on one stream."""

    case: str
    stream: str
    size: int  # payload bytes per sample
    rate: float | None  # samples/s; None = pipelined as fast as acknowledged
    seconds: float
    subscribers: int
    window: int = 256  # unacknowledged samples at most (pipelined only)


WORKLOADS = (
    Workload(case="video", stream="Video", size=640 * 480 * 3, rate=30, seconds=10, subscribers=3),
    Workload(case="audio", stream="Audio", size=3200, rate=100, seconds=5, subscribers=10),
    Workload(case="1 KiB max", stream="Fast", size=1024, rate=None, seconds=5, subscribers=1),
)


@dataclass(frozen=True, slots=True, kw_only=True)
class SubReport:
    """What one subscriber saw."""

    received: int
    missing: int  # sequence numbers below the writer's last that never arrived
    dropped: int  # the sum of the `dropped` slots (samples the server announced as dropped)
    bad: int  # samples with a wrong payload length or a builtin:id that is not bench:n + 1
    latencies_ns: tuple[int, ...]
    last_ns: int  # time.time_ns() of the last delivery
    cpu_s: float
    wait_s: float  # runnable but waiting for a CPU
    wall_s: float


@dataclass(frozen=True, slots=True, kw_only=True)
class WriterReport:
    """What the writer sent and had acknowledged."""

    sent: int
    acked: int
    start_ns: int
    last_ack_ns: int
    cpu_s: float
    wall_s: float
    errors: tuple[str, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class Run:
    """One workload measured against one server (or the relay)."""

    writer: WriterReport
    subs: tuple[SubReport, ...]
    seconds: float  # writer start → last subscriber report
    server_cpu_s: float
    server_wait_s: float  # runnable but waiting for a CPU (other processes had it)

    @property
    def cpu_percent(self) -> float:
        return 100 * self.server_cpu_s / self.seconds

    @property
    def wait_percent(self) -> float:
        return 100 * self.server_wait_s / self.seconds

    @property
    def missing(self) -> int:
        return sum(s.missing for s in self.subs)

    @property
    def dropped(self) -> int:
        return sum(s.dropped for s in self.subs)

    @property
    def bad(self) -> int:
        return sum(s.bad for s in self.subs)

    def percentile(self, q: float) -> float:
        """Return the q-quantile write → delivery latency over every subscriber, in ms."""
        ordered = sorted(ns for s in self.subs for ns in s.latencies_ns)
        if not ordered:
            return float("nan")
        return ordered[min(len(ordered) - 1, int(q * len(ordered)))] / 1e6

    def delivered_per_s(self) -> float:
        """Return the samples/s that reached each subscriber (their mean)."""
        rates = [
            s.received / max((s.last_ns - self.writer.start_ns) / 1e9, 1e-9) for s in self.subs
        ]
        return sum(rates) / len(rates)

    def acked_per_s(self) -> float:
        return self.writer.acked / max((self.writer.last_ack_ns - self.writer.start_ns) / 1e9, 1e-9)

    def sub_cpu_percent(self) -> float:
        """Return the busiest subscriber's CPU as % of one core."""
        return max(100 * s.cpu_s / max(s.wall_s, 1e-9) for s in self.subs)

    def sub_wait_percent(self) -> float:
        """Return the longest a subscriber waited for a CPU, as % of its run."""
        return max(100 * s.wait_s / max(s.wall_s, 1e-9) for s in self.subs)


# --- subscribers ------------------------------------------------------------------------------


def _runqueue_seconds(pid: int | str = "self") -> float:
    """Return how long the process's main thread has waited for a CPU while runnable."""
    try:
        with open(f"/proc/{pid}/schedstat") as f:
            return int(f.read().split()[1]) / 1e9
    except OSError:  # no schedstat (kernel without CONFIG_SCHEDSTATS): report 0
        return 0.0


def _take_frames(buf: bytearray) -> list[tuple[bytes, bytes, bytes, int]]:
    """Remove the complete frames from `buf`; return (tag, xml, params, payload length) each.

    A frame is a 12-byte header, the body, and for a message the chunk its `binarysizes`
    announces (one here); the payload is skipped, not copied.
    """
    out = []
    pos = 0
    while len(buf) - pos >= 12:
        tag, length = _HEADER.unpack_from(buf, pos)
        if tag.rstrip(b"\0") == b"BinaryM":
            xml, start, total = b"", pos + 12, length
        else:
            xml = bytes(buf[pos + 12 : pos + 12 + length])
            sizes = first_text(xml, b"binarysizes")
            start, total = pos + 12 + length, sum(int(s) for s in sizes.split(b",") if s)
        if len(buf) < start + total:
            break
        payload = int.from_bytes(buf[start : start + 4], "little") if total >= 4 else 0
        params = bytes(buf[start + 4 + payload : start + total - 1]) if total else b""
        out.append((tag.rstrip(b"\0"), xml, params, payload))
        pos = start + total
    del buf[:pos]
    return out


def _params(data: bytes) -> dict[bytes, bytes]:
    pairs = (p.split(b"%equals%", 1) for p in data.split(b"%sep%") if p)
    return {p[0]: p[1] for p in pairs if len(p) == 2}


@dataclass(slots=True)
class _Tally:
    """A subscriber's running counts."""

    size: int
    seen: set[int]
    latencies: list[int]
    dropped: int = 0
    bad: int = 0
    top: int = -1
    last_ns: int = 0

    def note(self, xml: bytes, params: bytes, payload: int, now: int) -> None:
        """Count one DATASAMPLE (or relayed BinaryM) received at `now`."""
        found = _params(params)
        n, t = int(found.get(b"bench:n", b"-1")), int(found.get(b"bench:t", b"0"))
        builtin = found.get(b"builtin:id")
        if payload != self.size or n < 0 or (builtin is not None and int(builtin) != n + 1):
            self.bad += 1
        self.dropped += int(first_text(xml, b"dropped") or b"0")
        self.seen.add(n)
        self.top = max(self.top, n)
        self.latencies.append(now - t)
        self.last_ns = now


def _open_subscriber(port: int, stream: str, name: str, relay: bool) -> socket.socket:
    """Connect and make the connection a push subscriber (the relay: one that receives)."""
    sock = connect(port)
    # The reader declares `pipelining` (OA-SESS-19), as the kit's client can: the server may
    # then push up to max-in-flight samples before their acknowledgements (OA-STREAM-8).
    extra = "<extensions>pipelining</extensions>"
    note = message("RECEIVE_NAME_NOTIFICATION", sender=name, to=stream, extra=extra)
    sock.sendall(frame(note, b"Receive"))
    if relay:  # the PING answer proves that the relay has taken the Receive frame
        request(sock, bytearray(), message("PING", sender=name, to="CNS"))
    return sock


def _subscriber_main(
    spec: Workload,
    port: int,
    name: str,
    relay: bool,
    shared: tuple[Any, Any, Any],
    stop: Event,
    out: mp.Queue[SubReport],
) -> None:
    """Receive pushed samples until the writer's last one (or `stop`); report a SubReport."""
    _pin_load()
    ready, delivered, last_seq = shared
    sock = _open_subscriber(port, spec.stream, name, relay)
    sock.settimeout(0.2)
    with ready.get_lock():
        ready.value += 1
    tally = _Tally(size=spec.size, seen=set(), latencies=[])
    cpu0, wait0, wall0 = time.process_time(), _runqueue_seconds(), time.perf_counter()
    buf = bytearray()
    while not stop.is_set() and not (0 <= last_seq.value <= tally.top):
        try:
            data = sock.recv(1 << 20)
        except TimeoutError:
            continue
        if not data:
            break
        buf += data
        frames = _take_frames(buf)
        now = time.time_ns()
        for _, xml, params, payload in frames:
            tally.note(xml, params, payload, now)
        if frames and not relay:
            sock.sendall(b"".join(_ack(xml, name) for _, xml, _, _ in frames))
        if frames:
            with delivered.get_lock():
                delivered.value += len(frames)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    wait = _runqueue_seconds() - wait0
    sock.close()
    top = max(last_seq.value, tally.top)
    out.put(
        SubReport(
            received=len(tally.seen),
            missing=top + 1 - len(tally.seen),
            dropped=tally.dropped,
            bad=tally.bad,
            latencies_ns=tuple(tally.latencies),
            last_ns=tally.last_ns,
            cpu_s=cpu,
            wait_s=wait,
            wall_s=wall,
        )
    )


# --- the writer -------------------------------------------------------------------------------


class _Acks(threading.Thread):
    """Read the writer's replies: count them and the DATA_ACCEPTED, keep a few others."""

    def __init__(self, sock: socket.socket) -> None:
        super().__init__(daemon=True)
        self.sock = sock
        self.count = 0  # every reply (the pipelining window counts these)
        self.accepted = 0
        self.last_ns = 0
        self.errors: list[str] = []
        self.cond = threading.Condition()

    def run(self) -> None:
        buf = bytearray()
        try:
            while True:
                frames = read_frames(self.sock, buf)
                now = time.time_ns()
                accepted = 0
                for xml in frames:
                    if first_text(xml, b"type") == b"DATA_ACCEPTED":
                        accepted += 1
                    elif len(self.errors) < 5:
                        self.errors.append(xml[:300].decode(errors="replace"))
                with self.cond:
                    self.accepted += accepted
                    self.count += len(frames)
                    self.last_ns = now
                    self.cond.notify_all()
        except OSError:
            return

    def wait_until(self, count: int, timeout: float) -> None:
        """Wait until `count` replies have come (or `timeout` seconds have passed)."""
        with self.cond:
            self.cond.wait_for(lambda: self.count >= count, timeout)


class _Sampler:
    """Build the frames of one writer: ADD_SAMPLE messages or BinaryM chunks."""

    def __init__(self, spec: Workload, *, binary: bool) -> None:
        self.spec = spec
        self.binary = binary
        self.head = struct.pack("<I", spec.size) + b"\x5a" * spec.size

    def frame(self, n: int) -> bytes:
        """Return the frame of sample `n`, stamped with the send time (`bench:t`)."""
        params = f"bench:n%equals%{n}%sep%bench:t%equals%{time.time_ns()}".encode() + b"\0"
        length = len(self.head) + len(params)
        if self.binary:
            return b"".join((_HEADER.pack(b"BinaryM", length), self.head, params))
        xml = message(
            "ADD_SAMPLE",
            sender="BenchWriter",
            to=self.spec.stream,
            content="<datasample/>",
            xml_content=True,
            extra=f"<binarysizes>{length}</binarysizes>",
        )
        return b"".join((_HEADER.pack(b"Message", len(xml)), xml, self.head, params))


def _paced(sock: socket.socket, sampler: _Sampler, rate: float, seconds: float) -> int:
    """Send `rate` × `seconds` samples, each at its absolute due time (no drift)."""
    count = round(rate * seconds)
    start = time.perf_counter()
    for n in range(count):
        while (delay := start + n / rate - time.perf_counter()) > 0:
            time.sleep(delay)
        sock.sendall(sampler.frame(n))
    return count


def _pipelined(
    sock: socket.socket, sampler: _Sampler, seconds: float, window: int, done: Any
) -> int:
    """Send for `seconds`, keeping at most `window` samples beyond `done()` (acked/delivered)."""
    end = time.perf_counter() + seconds
    n = 0
    while time.perf_counter() < end:
        room = window - (n - done())
        if room <= 0:
            time.sleep(0.0001)
            continue
        batch = min(room, _BATCH)
        sock.sendall(b"".join(sampler.frame(n + i) for i in range(batch)))
        n += batch
    return n


def _writer_main(
    spec: Workload,
    port: int,
    relay: bool,
    shared: tuple[Any, Any, Any],
    out: mp.Queue[WriterReport],
) -> None:
    """Write the workload's samples, then report what was sent and acknowledged."""
    _pin_load()
    _, delivered, last_seq = shared
    sock = connect(port)
    binary = relay or spec.rate is None
    if binary and not relay:  # OA-STREAM-11: GET_NAME makes the stream the current one
        reply = request(
            sock, bytearray(), message("GET_NAME", sender="BenchWriter", to=spec.stream)
        )
        if first_text(reply, b"type") != b"NAME":
            raise RuntimeError(f"GET_NAME answered {reply[:300]!r}")
    acks = _Acks(sock)
    if not relay:
        acks.start()
    sampler = _Sampler(spec, binary=binary)
    cpu0, wall0, start_ns = time.process_time(), time.perf_counter(), time.time_ns()
    if spec.rate is not None:
        sent = _paced(sock, sampler, spec.rate, spec.seconds)
    else:
        done = (lambda: delivered.value) if relay else (lambda: acks.count)
        sent = _pipelined(sock, sampler, spec.seconds, spec.window, done)
    last_seq.value = sent - 1
    if not relay:
        acks.wait_until(sent, _GRACE_S)
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    out.put(
        WriterReport(
            sent=sent,
            acked=acks.accepted,
            start_ns=start_ns,
            last_ack_ns=acks.last_ns,
            cpu_s=cpu,
            wall_s=wall,
            errors=tuple(acks.errors),
        )
    )
    sock.close()


# --- one run ----------------------------------------------------------------------------------


def _await_subscribers(port: int, spec: Workload, ready: Any, relay: bool) -> None:
    """Wait until every subscriber is connected and (server) counted by GET_INFO."""
    deadline = time.monotonic() + 30
    while ready.value < spec.subscribers:
        if time.monotonic() > deadline:
            raise RuntimeError("subscribers did not start")
        time.sleep(0.01)
    if relay:
        return
    sock, buf = connect(port), bytearray()
    try:
        while True:
            info = request(sock, buf, message("GET_INFO", sender="BenchMain", to=spec.stream))
            if f'subscribers="{spec.subscribers}"'.encode() in info:
                return
            if time.monotonic() > deadline:
                raise RuntimeError(f"the server did not count the subscribers: {info[:300]!r}")
            time.sleep(0.01)
    finally:
        sock.close()


def _collect(out: mp.Queue[SubReport], count: int, stop: Event) -> list[SubReport]:
    """Gather `count` subscriber reports; after the grace period, tell the rest to stop.

    Called when the writer has finished: samples not delivered `_GRACE_S` later are missing.
    """
    reports: list[SubReport] = []
    deadline = time.monotonic() + _GRACE_S
    while len(reports) < count:
        try:
            reports.append(out.get(timeout=0.2))
        except queue.Empty:
            if time.monotonic() > deadline:
                stop.set()
            if time.monotonic() > deadline + 30:
                raise RuntimeError("subscribers did not report") from None
    return reports


def _measure(port: int, pid: int, spec: Workload, *, relay: bool) -> Run:
    """Run one workload against the server (or relay) at `port` whose process is `pid`."""
    shared = (_CTX.Value("i", 0), _CTX.Value("q", 0), _CTX.Value("q", -1))
    stop = _CTX.Event()
    sub_out: mp.Queue[SubReport] = _CTX.Queue()
    writer_out: mp.Queue[WriterReport] = _CTX.Queue()
    subs = [
        _CTX.Process(
            target=_subscriber_main,
            args=(spec, port, f"BenchReader{i}", relay, shared, stop, sub_out),
        )
        for i in range(spec.subscribers)
    ]
    writer = _CTX.Process(target=_writer_main, args=(spec, port, relay, shared, writer_out))
    try:
        for proc in subs:
            proc.start()
        _await_subscribers(port, spec, shared[0], relay)
        cpu0, wait0, t0 = _cpu_seconds(pid), _runqueue_seconds(pid), time.perf_counter()
        writer.start()
        report = writer_out.get(timeout=spec.seconds + _GRACE_S + 60)
        reports = _collect(sub_out, spec.subscribers, stop)
        seconds, cpu = time.perf_counter() - t0, _cpu_seconds(pid) - cpu0
        wait = _runqueue_seconds(pid) - wait0
    finally:
        stop.set()  # on failure too: no subscriber may outlive the run
        for proc in (*subs, writer):
            if proc.pid is not None:
                proc.join(5)
                if proc.is_alive():
                    proc.terminate()
    return Run(
        writer=report, subs=tuple(reports), seconds=seconds, server_cpu_s=cpu, server_wait_s=wait
    )


# --- results ----------------------------------------------------------------------------------


def _loss_note(run: Run, verdict: bool) -> str:
    """Describe what was sent, acknowledged, missed and announced as dropped."""
    unannounced = run.missing - run.dropped
    note = (
        f"sent {run.writer.sent}, acked {run.writer.acked}; missing {run.missing} "
        f"(announced dropped {run.dropped}, unannounced {unannounced}); bad {run.bad}"
    )
    if verdict:
        ok = run.missing == 0 and run.dropped == 0 and run.bad == 0 and not run.writer.errors
        note += "; sustained" if ok else "; NOT sustained"
    if run.writer.errors:
        note += f"; first error reply: {run.writer.errors[0][:120]}"
    return note


def _result(
    case: str, value: float, unit: str, ratio: float | None = None, note: str = ""
) -> Result:
    return Result(bench=BENCH, case=case, value=value, unit=unit, ratio=ratio, note=note)


def _paced_results(spec: Workload, run: Run, base: Run) -> list[Result]:
    """Loss, p50/p99 latency and server CPU of a paced workload, against the relay's."""
    shape = f"{spec.size} B × {spec.rate:g} Hz → {spec.subscribers} subscribers"
    results = [
        _result(
            f"{spec.case} {shape}: missing", run.missing, "samples", None, _loss_note(run, True)
        )
    ]
    for q in (0.5, 0.99):
        value, baseline = run.percentile(q), base.percentile(q)
        note = f"relay {baseline:.3f} ms" + ("; target < 15 ms" if q > 0.9 else "")
        ratio = value / max(baseline, 1e-6)
        results.append(_result(f"{spec.case}: latency p{int(q * 100)}", value, "ms", ratio, note))
    results.append(_cpu_result(spec, run, base, "target < 25 %"))
    return results


def _cpu_result(spec: Workload, run: Run, base: Run, target: str) -> Result:
    per = run.server_cpu_s * 1e6 / max(run.writer.sent, 1)
    writer = 100 * run.writer.cpu_s / max(run.writer.wall_s, 1e-9)
    note = (
        f"relay {base.cpu_percent:.1f} %; {per:.0f} µs/sample written; server waited for a "
        f"CPU {run.wait_percent:.0f} % of the run; busiest subscriber "
        f"{run.sub_cpu_percent():.1f} % (waited ≤ {run.sub_wait_percent():.0f} %), "
        f"writer {writer:.1f} %"
    )
    ratio = run.cpu_percent / max(base.cpu_percent, 1e-6)
    note = f"{note}; {target}" if target else note
    return _result(f"{spec.case}: server CPU", run.cpu_percent, "% of a core", ratio, note)


def _rate_results(spec: Workload, run: Run, base: Run) -> list[Result]:
    """Acknowledged and delivered samples/s of the pipelined workload, against the relay's."""
    relay = max(base.delivered_per_s(), 1e-9)
    acked, delivered = run.acked_per_s(), run.delivered_per_s()
    note = f"relay delivered {relay:.0f}/s; window {spec.window}, BinaryM after GET_NAME"
    return [
        _result(f"{spec.case}: acked", acked, "samples/s", acked / relay, note),
        _result(
            f"{spec.case}: delivered",
            delivered,
            "samples/s",
            delivered / relay,
            _loss_note(run, False),
        ),
        _cpu_result(spec, run, base, ""),
    ]


def _relay_result(spec: Workload, base: Run) -> Result:
    note = (
        f"baseline; relay CPU {base.cpu_percent:.1f} % (waited {base.wait_percent:.0f} %), "
        f"busiest subscriber {base.sub_cpu_percent():.1f} % (waited ≤ "
        f"{base.sub_wait_percent():.0f} %); missing {base.missing}"
    )
    if spec.rate is None:
        return _result(
            f"relay {spec.case}: delivered", base.delivered_per_s(), "samples/s", 1.0, note
        )
    note += f"; p50 {base.percentile(0.5):.3f} ms"
    return _result(f"relay {spec.case}: latency p99", base.percentile(0.99), "ms", 1.0, note)


def _loadavg() -> float:
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def run() -> list[Result]:
    """Measure every workload through the relay, then through the reference server."""
    load0 = _loadavg()
    specs = [replace(w, seconds=w.seconds * _SCALE) for w in WORKLOADS]
    with _process(_relay_argv()) as (rpid, rport):
        bases = [_measure(rport, rpid, spec, relay=True) for spec in specs]
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "streams.psySpec.xml")
        with open(path, "w") as f:
            f.write(_CONFIG)
        with _process([*_server_argv(), "--config", path]) as (pid, port):
            runs = [_measure(port, pid, spec, relay=False) for spec in specs]
    results = [_relay_result(spec, base) for spec, base in zip(specs, bases, strict=True)]
    for spec, one, base in zip(specs, runs, bases, strict=True):
        pick = _paced_results if spec.rate is not None else _rate_results
        results += pick(spec, one, base)
    note = f"at start; {_loadavg():.2f} at the end, on {os.cpu_count()} CPUs"
    results.append(_result("load average (1 min)", load0, "", None, note))
    return results
