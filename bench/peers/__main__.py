"""Run the side-by-side benchmark: `python -m bench.peers` (`make bench-peers`).

Brokers, one at a time, each pinned to CPU 0 and fresh for the run: the minimal relay
(calibration of the generator, framed protocol), mosquitto, the reference server, NATS, Redis,
amqtt. Workloads (payload 64 bytes with the stamp unless said): fan-out 1 and 10 at maximum
throughput; fixed rates 1 000 and 10 000 msg/s; routing with 1, 100 and 10 000 subscriptions
that never match plus the one that does; one of ten subscribers stops reading; 921 600-byte
frames at 30 Hz to 3 subscribers. Writes bench/results/peers.md, peers.json and *.png.
`BENCH_PEERS_QUICK=1` shortens every run and skips the 10 000-subscription case;
`BENCH_PEERS_BROKERS=a,b` keeps only some brokers.
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import subprocess
import sys
import time
from dataclasses import asdict
from pathlib import Path

from bench.peers import report
from bench.peers.brokers import missing_reason, running, version
from bench.peers.video import FRAME_BYTES, openair_video
from bench.peers.workloads import Flow, Workload, load_average, measure

RESULTS = Path(__file__).resolve().parents[1] / "results"
QUICK = os.environ.get("BENCH_PEERS_QUICK", "") not in ("", "0")
_S = 0.8 if QUICK else 3.0
ORDER = ("relay", "mosquitto", "openair", "nats", "redis", "amqtt")


def workloads() -> list[Workload]:
    """Return the workloads of this run (shorter and fewer when quick)."""
    routing = (1, 100) if QUICK else (1, 100, 10_000)
    return [
        Workload(case="fan-out 1", seconds=_S),
        Workload(case="fan-out 10", fanout=10, seconds=_S),
        Workload(case="rate 1000/s", rate=1000, seconds=_S),
        Workload(case="rate 10000/s", rate=10_000, seconds=_S),
        *(Workload(case=f"routing {n}", idle=n, seconds=_S) for n in routing),
        Workload(case="stalled 1 of 10", fanout=9, stall=True, seconds=_S + 1),
        Workload(case="921600 B at 30 Hz", fanout=3, rate=30, size=FRAME_BYTES, seconds=_S),
    ]


def _run_broker(name: str, specs: list[Workload]) -> list[Flow]:
    flows = []
    if name == "relay":  # the relay only forwards: it calibrates the generator's ceiling
        specs = [s for s in specs if s.case in ("fan-out 1", "fan-out 10", "rate 10000/s")]
    for spec in specs:
        with running(name) as broker:  # fresh per workload: VmHWM and queues start clean
            if name == "openair" and spec.size == FRAME_BYTES:
                flow = openair_video(broker, spec.seconds, spec.case)
            else:
                flow = measure(broker, spec)
        print(f"  {name:9} {spec.case:18} {_summary(flow)}", file=sys.stderr, flush=True)
        flows.append(flow)
    return flows


def _summary(flow: Flow) -> str:
    if flow.error:
        return "ERROR " + flow.error
    p50, p99, _ = flow.latencies_ms
    return (
        f"{flow.in_rate:10.0f} msg/s in, {flow.cpu_us_per_msg:6.1f} µs CPU/msg, "
        f"p50 {p50:.2f} p99 {p99:.2f} ms, load {flow.load:.1f}"
    )


def machine() -> str:
    """Return "CPU model, N cores, kernel"."""
    model = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            model = next(line.split(":", 1)[1].strip() for line in f if "model name" in line)
    except (OSError, StopIteration):
        pass
    python = platform.python_version()
    return f"{model}, {os.cpu_count()} cores, Linux {platform.release()}, Python {python}"


def profile_openair(seconds: float) -> str:
    """Profile the reference server under fan-out 1 with py-spy; return a Markdown summary."""
    spy = shutil.which("py-spy", path=str(Path(sys.executable).parent)) or shutil.which("py-spy")
    if spy is None:
        return "py-spy is not installed (`.venv/bin/pip install py-spy`)."
    out = RESULTS / "openair-profile.txt"
    with running("openair") as broker:
        rec = subprocess.Popen(
            [
                spy,
                "record",
                "--pid",
                str(broker.pid),
                "--duration",
                str(int(seconds) + 1),
                "--format",
                "raw",
                "--rate",
                "250",
                "--output",
                str(out),
                "--nonblocking",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        time.sleep(0.5)
        measure(broker, Workload(case="fan-out 1", seconds=seconds))
        _, err = rec.communicate(timeout=60)
    if rec.returncode != 0 or not out.exists():
        return f"py-spy failed: {err.strip()[:300]}"
    return summarize_profile(out.read_text())


_PLUMBING = (
    "(base_events.py)",
    "(events.py)",
    "(runners.py)",
    "(core.py)",
    "(cli_serve.py)",
    "(<string>)",
    "(cli.py)",
)


def summarize_profile(raw: str, top: int = 15) -> str:
    """Turn py-spy's collapsed stacks into two tables: own time and inclusive time."""
    own: dict[str, int] = {}
    incl: dict[str, int] = {}
    total = 0
    for line in raw.splitlines():
        stack, _, count = line.rpartition(" ")
        if not count.isdigit():
            continue
        n = int(count)
        total += n
        frames = [
            fr.split(" (")[0] + " (" + fr.split(" (")[-1].split(":")[0].split("/")[-1] + ")"
            for fr in stack.split(";")
            if fr
        ]
        if frames:
            own[frames[-1]] = own.get(frames[-1], 0) + n
        for fr in set(frames):
            if not fr.endswith(_PLUMBING):
                incl[fr] = incl.get(fr, 0) + n
    if not total:
        return "py-spy recorded no samples."

    def table(data: dict[str, int], title: str) -> list[str]:
        rows = sorted(data.items(), key=lambda kv: -kv[1])[:top]
        return [
            f"| {title} | % of samples |",
            "|---|---|",
            *(f"| `{k}` | {100 * v / total:.1f} |" for k, v in rows),
        ]

    return "\n".join(
        [
            f"{total} samples (raw stacks in bench/results/openair-profile.txt).",
            "",
            *table(own, "own time (leaf function)"),
            "",
            *table(incl, "inclusive time (asyncio and CLI frames left out)"),
        ]
    )


def _ceiling(flows: list[Flow]) -> str:
    parts = []
    for f in flows:
        if f.broker == "relay" and not f.error:
            gen = 100 * f.gen_cpu_s / f.seconds / max((os.cpu_count() or 2) - 1, 1)
            parts.append(
                f"{f.case}: {f.in_rate:,.0f} msg/s in through the relay "
                f"(generator CPU {gen:.0f} % of its cores)"
            )
    return (
        (
            "; ".join(parts) + ". The relay copies whole reads, so these bound what the "
            "generator can send and receive."
        )
        if parts
        else "relay not measured."
    )


def main(argv: list[str]) -> int:
    """Run every broker and write the results (`--render`: rewrite them from peers.json)."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    if argv == ["--render"]:
        flows, meta = _load()
        raw = RESULTS / "openair-profile.txt"
        profile = summarize_profile(raw.read_text()) if raw.exists() else ""
        _write(flows, meta, profile)
        return 0
    keep = [b for b in os.environ.get("BENCH_PEERS_BROKERS", "").split(",") if b]
    names = [n for n in ORDER if not keep or n in keep]
    load0, flows, unavailable = load_average(), [], {}
    specs = workloads()
    for name in names:
        reason = missing_reason(name)
        if reason:
            unavailable[name] = reason
            continue
        print(f"{name}:", file=sys.stderr, flush=True)
        flows += _run_broker(name, specs)
    profile = profile_openair(_S + 1) if "openair" in names else ""
    meta = report.Meta(
        date=time.strftime("%Y-%m-%d %H:%M %Z"),
        machine=machine(),
        load_start=load0,
        load_end=load_average(),
        versions={n: version(n) for n in names if n not in unavailable},
        unavailable=unavailable,
        ceiling=_ceiling(flows),
        quick=QUICK,
    )
    (RESULTS / "peers.json").write_text(
        json.dumps({"meta": asdict(meta), "flows": [asdict(f) for f in flows]}, indent=1)
    )
    _write(flows, meta, profile)
    return 0


def _load() -> tuple[list[Flow], report.Meta]:
    data = json.loads((RESULTS / "peers.json").read_text())
    flows = [
        Flow(**{**f, "latencies_ms": tuple(f["latencies_ms"]), "notes": tuple(f["notes"])})
        for f in data["flows"]
    ]
    return flows, report.Meta(**data["meta"])


def _write(flows: list[Flow], meta: report.Meta, profile: str) -> None:
    (RESULTS / "peers.md").write_text(report.markdown(flows, meta, profile))
    (RESULTS / "README-snippet.md").write_text(report.snippet(flows, meta))
    for path in report.plots(flows, meta, RESULTS):
        print(f"wrote {path}", file=sys.stderr)
    print((RESULTS / "peers.md").read_text())


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
