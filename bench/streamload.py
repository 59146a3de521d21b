"""The load of the stream benchmark (bench_streams.py): subscriber and writer processes.

Each subscriber (`subscriber_main`) reads DATASAMPLE frames, acknowledges them and reports what
it saw (`SubReport`); the writer (`writer_main`) sends paced or pipelined samples and reports
what was acknowledged (`WriterReport`). Both run in processes of their own, pinned off the
server's CPU by the benchmark.
"""

from __future__ import annotations

import multiprocessing as mp
import queue
import socket
import struct
import threading
import time
from dataclasses import dataclass
from multiprocessing.synchronize import Event
from typing import Any

from bench.bench_server import _pin_load
from bench.loadgen import _ack, connect, first_text, frame, message, read_frames, request

_HEADER = struct.Struct("<7sxI")


GRACE_S = 10.0  # how long subscribers may take to catch up after the writer's last sample


_BATCH = 64  # pipelined samples per send


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


def runqueue_seconds(pid: int | str = "self") -> float:
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


def subscriber_main(
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
    cpu0, wait0, wall0 = time.process_time(), runqueue_seconds(), time.perf_counter()
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
    wait = runqueue_seconds() - wait0
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


def writer_main(
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
        acks.wait_until(sent, GRACE_S)
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


def await_subscribers(port: int, spec: Workload, ready: Any, relay: bool) -> None:
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


def collect(out: mp.Queue[SubReport], count: int, stop: Event) -> list[SubReport]:
    """Gather `count` subscriber reports; after the grace period, tell the rest to stop.

    Called when the writer has finished: samples not delivered `GRACE_S` later are missing.
    """
    reports: list[SubReport] = []
    deadline = time.monotonic() + GRACE_S
    while len(reports) < count:
        try:
            reports.append(out.get(timeout=0.2))
        except queue.Empty:
            if time.monotonic() > deadline:
                stop.set()
            if time.monotonic() > deadline + 30:
                raise RuntimeError("subscribers did not report") from None
    return reports
