"""The 921 600-byte frames at 30 Hz workload on the reference server, through a stream.

The reference server gets the frames as samples of a stream (`Video` in WB1) with three push
subscribers, the way a lab would send video, using bench/bench_streams.py's writer and
subscribers (each sample stamped with `bench:n` and `bench:t`); the other brokers get plain
publishes of the same size through the generic workload.
"""

from __future__ import annotations

from bench import bench_streams
from bench.peers.brokers import Broker, memory_kib, reset_peak
from bench.peers.workloads import Flow, load_average
from bench.streamload import Workload

FRAME_BYTES = 640 * 480 * 3


def openair_video(broker: Broker, seconds: float, case: str) -> Flow:
    """Push 921 600-byte samples at 30 Hz to 3 stream subscribers; failures set `error`."""
    load = load_average()
    spec = Workload(
        case="video", stream="Video", size=FRAME_BYTES, rate=30, seconds=seconds, subscribers=3
    )
    try:
        reset_peak(broker.pid)
        rss0 = memory_kib(broker.pid, "VmRSS")
        run = bench_streams._measure(broker.port, broker.pid, spec, relay=False)
    except Exception as exc:  # reported in the table, never fatal
        return Flow(broker=broker.name, case=case, error=f"{type(exc).__name__}: {exc}", load=load)
    notes = (f"stream push; missing {run.missing}, announced dropped {run.dropped}, bad {run.bad}",)
    return Flow(
        broker=broker.name,
        case=case,
        fanout=3,
        sent=run.writer.sent,
        delivered=sum(s.received for s in run.subs),
        seconds=run.seconds,
        cpu_s=run.server_cpu_s,
        wait_s=run.server_wait_s,
        peak_rss_kib=memory_kib(broker.pid, "VmHWM"),
        rss_growth_kib=memory_kib(broker.pid, "VmRSS") - rss0,
        latencies_ms=(run.percentile(0.5), run.percentile(0.99), run.percentile(0.999)),
        load=load,
        notes=notes,
    )
