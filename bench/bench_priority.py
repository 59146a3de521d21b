"""Whiteboard priority under starvation (spec 10, OA-PRIO-5, OA-PRIO-6).

Two posters flood two whiteboards at once, `High` and `Low`, each read by its own internal
module (`bench.bench_priority:reader`, OA-CONF-8: readers that cost the server CPU and never
wait for an acknowledgement, so the server itself is the bottleneck). The server has more
deliveries ready than its turn budget lets it start in one loop iteration; OA-PRIO-5 says the
high whiteboard's deliveries go first. With `High` at priority 0.5 and `Low` at 4.0 the high
whiteboard's post → wakeup latency must stay well below the low one's (ratio Low / High); the
control run gives both priority 1.0 (ratio near 1). Each reader spends `BENCH_PRIORITY_WORK_US`
(default 100) µs of CPU per message, so the modules' work, not reading the posts, is what the
CPU cannot keep up with. Messages dropped at `max-queue` (OA-DELIV-9) show as a smaller count.
The turn budget is small (`BENCH_PRIORITY_BUDGET`, default 16); the note gives the load average.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import statistics
import time

from bench import Result
from bench.loadgen import (
    _MARK,
    SEQ_WIDTH,
    PosterSpec,
    SubscriberSpec,
    _ack,
    _setup_module,
    message,
    poster,
    read_frames,
    request,
)
from bench.serving import spawn
from openair.protocol.codec import decode_message
from openair.protocol.message import Message
from openair.protocol.wakeup import parse_wakeup
from openair.server.aio.internal import InternalModule

BENCH = "priority"
_COUNT = int(os.environ.get("BENCH_PRIORITY_COUNT", "20000"))
_BUDGET = int(os.environ.get("BENCH_PRIORITY_BUDGET", "16"))
#: CPU work per message of each reader, in microseconds: the module work that starves the CPU.
_WORK_US = int(os.environ.get("BENCH_PRIORITY_WORK_US", "100"))
#: Posts per second per poster (0: as fast as the server reads).
_RATE = float(os.environ.get("BENCH_PRIORITY_RATE", "0"))
_CTX = mp.get_context("fork")
_SPEC = """<psySpec name="BenchPriority" version="1.2">
  <whiteboard name="High" priority="{high}"/>
  <whiteboard name="Low" priority="{low}"/>
  <module name="HighReader" internal="bench.bench_priority:reader">
    <trigger from="High" type="Bench.High.*"/><trigger from="any" type="Bench.Collect"/>
  </module>
  <module name="LowReader" internal="bench.bench_priority:reader">
    <trigger from="Low" type="Bench.Low.*"/><trigger from="any" type="Bench.Collect"/>
  </module>
</psySpec>"""

#: Latencies (ns) seen by each reader, in the server process.
_SEEN: dict[str, list[int]] = {}


async def reader(module: InternalModule, msg: Message) -> None:
    """Record post → wakeup latency; on `Bench.Collect` post the median and the count."""
    trigger = module.trigger(msg)
    if trigger is None:
        return
    seen = _SEEN.setdefault(module.name, [])
    if trigger.type == "Bench.Collect":
        p50 = statistics.median(seen) / 1e6 if seen else 0.0
        module.post("AIRCentral", f"Bench.Latency.{module.name}", f"{p50:.3f} {len(seen)}")
        seen.clear()
        return
    pos = trigger.content.find(_MARK.decode())
    field = trigger.content[pos + len(_MARK) : pos + len(_MARK) + SEQ_WIDTH]
    seen.append(time.time_ns() - int(field.split(":")[1].rstrip("_")))
    until = time.perf_counter() + _WORK_US / 1e6
    while time.perf_counter() < until:  # the module's own work, on the server's CPU
        pass


def _flood(port: int) -> dict[str, tuple[float, int]]:
    """Post `_COUNT` messages to each board at once; return (p50 ms, delivered) per reader."""
    never = _CTX.Value("q", 0)  # no window: the posters send as fast as the server reads
    procs = [
        _CTX.Process(
            target=poster,
            args=(
                PosterSpec(
                    port=port,
                    count=_COUNT,
                    type_=f"Bench.{board}.Data",
                    whiteboard=board,
                    window=_COUNT,
                    rate=_RATE or None,
                ),
                never,
                _CTX.Value("q", 0),
            ),
        )
        for board in ("High", "Low")
    ]
    spec = SubscriberSpec(
        port=port, name="BenchCollector", patterns=("Bench.Latency.*",), expected=0
    )
    primary, callback = _setup_module(spec)
    for proc in procs:
        proc.start()
    for proc in procs:
        proc.join(600)  # each poster ends with a PING: the server has read all its posts
    # To Low, priority 2.0: after the data in both queues (OA-PRIO-1, OA-PRIO-2).
    request(primary, bytearray(), message("Bench.Collect", sender="BenchCollector", to="Low"))
    found: dict[str, tuple[float, int]] = {}
    buf = bytearray()
    while len(found) < 2:
        for xml in read_frames(callback, buf):
            callback.sendall(_ack(xml, "BenchCollector"))
            trigger = parse_wakeup(decode_message(xml, clamp_priority=True)).trigger
            if trigger is not None and trigger.type.startswith("Bench.Latency."):
                p50, count = trigger.content.split()
                found[trigger.sender.removesuffix("Reader")] = (float(p50), int(count))
    primary.close()
    callback.close()
    return found


def run() -> list[Result]:
    """Measure the prioritized and the equal-priority configuration under the same load."""
    results = []
    for label, high, low in (("prioritized", 0.5, 4.0), ("equal", 1.0, 1.0)):
        with spawn(_SPEC.format(high=high, low=low), turn_budget=_BUDGET) as (_, port):
            got = _flood(port)
        load = "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())
        note = f"High {high}, Low {low}; budget {_BUDGET}; ratio = Low / High; {load}"
        (hi_ms, hi_n), (lo_ms, lo_n) = got["High"], got["Low"]
        results += [
            Result(
                bench=BENCH,
                case=f"{label}: High p50",
                value=hi_ms,
                unit="ms",
                note=f"{hi_n} of {_COUNT} delivered",
            ),
            Result(
                bench=BENCH,
                case=f"{label}: Low p50",
                value=lo_ms,
                unit="ms",
                ratio=lo_ms / hi_ms if hi_ms else None,
                note=f"{lo_n} of {_COUNT} delivered; {note}",
            ),
        ]
    return results
