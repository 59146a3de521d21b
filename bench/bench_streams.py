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
import tempfile
import time
from dataclasses import dataclass, replace

from bench import Result
from bench.bench_server import _cpu_seconds, _process, _relay_argv, _server_argv
from bench.streamload import (
    GRACE_S,
    SubReport,
    Workload,
    WriterReport,
    await_subscribers,
    collect,
    runqueue_seconds,
    subscriber_main,
    writer_main,
)

BENCH = "streams"
_SCALE = float(os.environ.get("BENCH_STREAMS_SCALE", "1"))
_CTX = mp.get_context("fork")
_CONFIG = """<?xml version="1.0" encoding="UTF-8"?>
<psySpec name="BenchStreams" version="1.2">
  <whiteboard name="AIRCentral"/>
  <whiteboard name="WB1"><streams><stream name="Video" maxsize="64"/>
    <stream name="Audio" maxsize="16"/><stream name="Fast" maxsize="16"/></streams></whiteboard>
</psySpec>
"""


WORKLOADS = (
    Workload(case="video", stream="Video", size=640 * 480 * 3, rate=30, seconds=10, subscribers=3),
    Workload(case="audio", stream="Audio", size=3200, rate=100, seconds=5, subscribers=10),
    Workload(case="1 KiB max", stream="Fast", size=1024, rate=None, seconds=5, subscribers=1),
)


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


# --- the writer -------------------------------------------------------------------------------


# --- one run ----------------------------------------------------------------------------------


def _measure(port: int, pid: int, spec: Workload, *, relay: bool) -> Run:
    """Run one workload against the server (or relay) at `port` whose process is `pid`."""
    shared = (_CTX.Value("i", 0), _CTX.Value("q", 0), _CTX.Value("q", -1))
    stop = _CTX.Event()
    sub_out: mp.Queue[SubReport] = _CTX.Queue()
    writer_out: mp.Queue[WriterReport] = _CTX.Queue()
    subs = [
        _CTX.Process(
            target=subscriber_main,
            args=(spec, port, f"BenchReader{i}", relay, shared, stop, sub_out),
        )
        for i in range(spec.subscribers)
    ]
    writer = _CTX.Process(target=writer_main, args=(spec, port, relay, shared, writer_out))
    try:
        for proc in subs:
            proc.start()
        await_subscribers(port, spec, shared[0], relay)
        cpu0, wait0, t0 = _cpu_seconds(pid), runqueue_seconds(pid), time.perf_counter()
        writer.start()
        report = writer_out.get(timeout=spec.seconds + GRACE_S + 60)
        reports = collect(sub_out, spec.subscribers, stop)
        seconds, cpu = time.perf_counter() - t0, _cpu_seconds(pid) - cpu0
        wait = runqueue_seconds(pid) - wait0
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
