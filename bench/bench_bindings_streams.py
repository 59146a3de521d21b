"""Stream flows written and received by the C++ and Java clients, as ratios to the Python client.

Cases (the baseline, measured in the same run, in brackets): a client subscribes to `Stream1`
(a push subscription, spec 11.6) and writes, on the same process and connection set, paced
samples with ADD_SAMPLE while it receives them back:
- video: 921 600-byte frames (640 × 480 × 3) at 30 Hz;
- audio: 3 200-byte chunks at 100 Hz.
Each sample carries its send time (`bench:ns`); the client reports the write-to-receive latency
(p50, p99), what the server dropped for it, and its own CPU time. The ratio is client / Python
for the p50 latency and for the CPU time (below 1: better than Python). C++ runs
`bindings/cpp/build/openair-bench stream`, Java `org.openair.shim.BenchMain stream` from
`bindings/java/target/openair-shim.jar`, Python this module's `stream` mode. Not part of
`make test`; `python -m bench bindings` runs it. BENCH_STREAM_SECONDS (default 3) sets each
flow's length.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import shutil
import statistics
import sys
import time
from dataclasses import dataclass

from bench import Result
from bench.bench_bindings import _CPP_BENCH, _JAVA_JAR, _run_client
from bench.bench_server import _process, _server_argv
from openair.client import Module

BENCH = "bindings"
_STREAM = "Stream1"
_SECONDS = float(os.environ.get("BENCH_STREAM_SECONDS", "3"))


@dataclass(frozen=True, slots=True, kw_only=True)
class Flow:
    """One paced stream flow: its name, sample size and rate."""

    name: str
    size: int
    rate: float

    @property
    def count(self) -> int:
        return max(1, int(self.rate * _SECONDS))


FLOWS = (
    Flow(name="video 921 600 B @ 30 Hz", size=921_600, rate=30.0),
    Flow(name="audio 3 200 B @ 100 Hz", size=3_200, rate=100.0),
)


# ----------------------------------------------------------------------- the Python client


async def _python_flow(
    host: str, port: int, size: int, rate: float, count: int
) -> dict[str, float]:
    """Subscribe, write `count` paced samples, receive them; return the JSON figures."""
    module = Module("BenchPyStream", host, port, listen=False, announce=False, reconnect=False)
    latencies: list[float] = []
    dropped = 0
    async with module:
        handle = module.stream(_STREAM)
        payload = b"\x5a" * size
        cpu0 = time.process_time()
        start = time.perf_counter()
        async with module.subscribe_stream(_STREAM) as sub:

            async def receive() -> None:
                nonlocal dropped
                async for got in sub:
                    dropped += got.dropped
                    sent = got.sample.param("bench:ns")
                    if sent is not None:
                        latencies.append((got.received_ns - int(sent)) / 1e6)
                    if len(latencies) + dropped >= count:
                        return

            reader = asyncio.create_task(receive())
            for i in range(count):
                delay = start + i / rate - time.perf_counter()
                if delay > 0:
                    await asyncio.sleep(delay)
                await handle.add(payload, {"bench:ns": str(time.time_ns())})
            with contextlib.suppress(TimeoutError):  # what did not come is reported as missing
                await asyncio.wait_for(reader, 5.0)
        seconds = time.perf_counter() - start
        cpu = time.process_time() - cpu0
    ordered = sorted(latencies) or [0.0]
    return {
        "sent": count,
        "received": len(latencies),
        "dropped": dropped,
        "p50_ms": statistics.median(ordered),
        "p99_ms": ordered[int(0.99 * (len(ordered) - 1))],
        "cpu_s": cpu,
        "seconds": seconds,
    }


# ----------------------------------------------------------------------- running the clients


def _argv(language: str, port: int, flow: Flow) -> list[str] | None:
    """The command that runs one client's stream mode, or None when it is not built."""
    sizes = [str(flow.size), str(flow.rate), str(flow.count)]
    if language == "Python":
        return [sys.executable, "-m", "bench.bench_bindings_streams", "stream", "127.0.0.1",
                str(port), *sizes]  # fmt: skip
    args = ["stream", "127.0.0.1", str(port), _STREAM, *sizes]
    if language == "C++":
        return [str(_CPP_BENCH), *args] if _CPP_BENCH.is_file() else None
    java = shutil.which("java")
    if java is None or not _JAVA_JAR.is_file():
        return None
    return [java, "-cp", str(_JAVA_JAR), "org.openair.shim.BenchMain", *args]


def _measure(language: str, flow: Flow) -> dict[str, float] | str:
    """One language's figures against a fresh server, or why there are none."""
    with _process(_server_argv()) as (_, port):
        argv = _argv(language, port, flow)
        if argv is None:
            return "not built"
        try:
            return _run_client(argv)
        except (RuntimeError, ValueError, IndexError) as exc:
            return f"not available: {str(exc)[:120]}"


def _note(f: dict[str, float]) -> str:
    got = f"{int(f['received'])}/{int(f['sent'])} received, {int(f['dropped'])} dropped"
    return f"p99 {f['p99_ms']:.1f} ms; {got}; CPU {f['cpu_s']:.2f} s in {f['seconds']:.1f} s"


def _flow_results(flow: Flow) -> list[Result]:
    base = _measure("Python", flow)
    if isinstance(base, str):
        raise RuntimeError(f"the Python baseline failed: {base}")
    results = [
        Result(bench=BENCH, case=f"Python {flow.name} p50 latency", value=base["p50_ms"],
               unit="ms", ratio=1.0, note=f"baseline; {_note(base)}"),
    ]  # fmt: skip
    for language in ("C++", "Java"):
        got = _measure(language, flow)
        case = f"{language} {flow.name} p50 latency"
        if isinstance(got, str):
            results.append(Result(bench=BENCH, case=case, value=0.0, unit="ms", note=got))
            continue
        cpu_ratio = got["cpu_s"] / max(base["cpu_s"], 1e-9)
        results.append(Result(bench=BENCH, case=case, value=got["p50_ms"], unit="ms",
                              ratio=got["p50_ms"] / max(base["p50_ms"], 1e-9),
                              note=f"{_note(got)}; CPU x{cpu_ratio:.2f} of Python"))  # fmt: skip
    return results


def run() -> list[Result]:
    """Measure every flow for every client against Python."""
    return [result for flow in FLOWS for result in _flow_results(flow)]


def _main(argv: list[str]) -> int:
    """Python's side: `stream HOST PORT SIZE RATE N`; print its JSON figures."""
    if len(argv) != 6 or argv[0] != "stream":
        print("usage: python -m bench.bench_bindings_streams stream HOST PORT SIZE RATE N",
              file=sys.stderr)  # fmt: skip
        return 2
    host, port, size, rate, count = (
        argv[1],
        int(argv[2]),
        int(argv[3]),
        float(argv[4]),
        int(argv[5]),
    )
    print(json.dumps(asyncio.run(_python_flow(host, port, size, rate, count))))
    return 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
