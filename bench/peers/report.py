"""Render the peers run: bench/results/peers.md (tables, goals, profile) and PNG plots.

Every figure is also given as a ratio to mosquitto measured in the same run, so runs on
different machines compare; each row carries the load average at its start, because the
development machine is shared.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bench.peers.workloads import Flow

BROKERS = ("openair", "mosquitto", "nats", "redis", "amqtt", "relay")
REF = "mosquitto"
THROUGHPUT_CASES = (
    "fan-out 1",
    "fan-out 10",
    "routing 1",
    "routing 100",
    "routing 10000",
    "stalled 1 of 10",
    "921600 B at 30 Hz",
)
LATENCY_CASES = ("rate 1000/s", "rate 10000/s")


_READING = """\
- Throughput cases run the publisher as fast as the slowest subscriber allows (at most 2 000
  messages ahead), so a broker's rate is its own limit unless the generator's ceiling (through
  the relay, above) is lower. Rates under load from other jobs vary by 2× between runs; compare
  ratios taken in the same run, and check the "waited for CPU 0" table.
- The reference server's cost is per message and per delivery, not per pattern: its routing rate
  is flat from 1 to 10 000 patterns, while Redis PSUBSCRIBE (a scan of every pattern) and amqtt
  collapse. What it pays per post: decode the post (`fast_decode`), route it, assemble and escape
  one wakeup per subscriber, queue it (`DeliveryQueue`), write it, then decode the subscriber's
  RECEIVE_ACCEPT in full (`_on_reply` → `from_frame`) to pair it with the delivery (OA-DELIV-4).
  mosquitto, NATS and Redis do none of the XML work and no per-delivery acknowledgement.
- The stalled OpenAIR subscriber stops receiving once its pipelining window is full (it never
  acknowledges); what the server then does with further deliveries is in the table above.
- The 921 600-byte case for OpenAIR goes through a stream push subscription (DATASAMPLE frames,
  acknowledged); the others get plain publishes of the same size."""


@dataclass(frozen=True, slots=True, kw_only=True)
class Meta:
    """Where and when the run happened."""

    date: str
    machine: str
    load_start: float
    load_end: float
    versions: dict[str, str]
    unavailable: dict[str, str]
    ceiling: str  # the generator's calibration against the relay
    quick: bool


def _fmt(value: float) -> str:
    if math.isnan(value):
        return "–"
    if value >= 100:
        return f"{value:,.0f}".replace(",", " ")
    return f"{value:.3g}"


def _index(flows: Sequence[Flow]) -> dict[tuple[str, str], Flow]:
    return {(f.broker, f.case): f for f in flows}


def _cell(flows: dict[tuple[str, str], Flow], broker: str, case: str, metric: str) -> str:
    flow = flows.get((broker, case))
    if flow is None:
        return ""
    if flow.error:
        return "error¹"
    value = metric_value(flow, metric)
    ref = flows.get((REF, case))
    ratio = ""
    if metric != "wait" and ref is not None and not ref.error and broker != REF:
        base = metric_value(ref, metric)
        if base and not math.isnan(base) and not math.isnan(value):
            ratio = f" ({value / base:.2f}×)"
    return _fmt(value) + ratio


def metric_value(flow: Flow, metric: str) -> float:
    """Return one metric of a flow: in_rate, p50, p99, p999, cpu, rss (MiB), wait (%)."""
    if metric == "in_rate":
        return flow.in_rate
    if metric in ("p50", "p99", "p999"):
        return flow.latencies_ms[("p50", "p99", "p999").index(metric)]
    if metric == "cpu":
        return flow.cpu_us_per_msg
    if metric == "rss":
        return flow.peak_rss_kib / 1024
    if metric == "wait":
        return 100 * flow.wait_s / flow.seconds if flow.seconds else float("nan")
    raise ValueError(metric)


def _table(flows: Sequence[Flow], cases: Sequence[str], metric: str, title: str) -> list[str]:
    idx = _index(flows)
    present = [b for b in BROKERS if any(f.broker == b for f in flows)]
    lines = [
        f"| {title} | " + " | ".join(present) + " | load |",
        "|---|" + "---|" * (len(present) + 1),
    ]
    for case in cases:
        row = [_cell(idx, b, case, metric) for b in present]
        if not any(row):
            continue
        loads = [f.load for f in flows if f.case == case]
        load = f"{min(loads):.1f}–{max(loads):.1f}" if loads else ""
        lines.append(f"| {case} | " + " | ".join(row) + f" | {load} |")
    return lines


def _goals(flows: Sequence[Flow]) -> list[str]:
    idx = _index(flows)

    def rate(broker: str, case: str) -> float:
        flow = idx.get((broker, case))
        return flow.in_rate if flow and not flow.error else float("nan")

    checks = [
        (
            "≥ 0.5× mosquitto at 1 subscription (routing 1)",
            rate("openair", "routing 1") / rate(REF, "routing 1"),
            0.5,
            "×",
        ),
        (
            "ahead of mosquitto at 10 000 subscriptions (routing 10000)",
            rate("openair", "routing 10000") / rate(REF, "routing 10000"),
            1.0,
            "×",
        ),
        (
            "≥ 20× amqtt at 100 patterns (routing 100)",
            rate("openair", "routing 100") / rate("amqtt", "routing 100"),
            20.0,
            "×",
        ),
        ("fan-out 1 ≥ 150 000 msg/s", rate("openair", "fan-out 1"), 150_000, " msg/s"),
        ("fan-out 10 ≥ 60 000 msg/s in", rate("openair", "fan-out 10"), 60_000, " msg/s"),
    ]
    lines = ["| goal (reference server) | measured | met |", "|---|---|---|"]
    for text, value, target, unit in checks:
        met = "–" if math.isnan(value) else ("yes" if value >= target else "no")
        shown = "–" if math.isnan(value) else f"{_fmt(value)}{unit}"
        lines.append(f"| {text} | {shown} | {met} |")
    return lines


def markdown(flows: Sequence[Flow], meta: Meta, profile: str) -> str:
    """Return the whole peers.md."""
    out = [
        "# OpenAIR reference server against mosquitto, NATS, Redis and amqtt",
        "",
        f"`make bench-peers`{' (BENCH_PEERS_QUICK=1: short smoke run)' if meta.quick else ''}, "
        f"{meta.date}, {meta.machine}; load average (1 min) {meta.load_start:.2f} at the start, "
        f"{meta.load_end:.2f} at the end. Broker pinned to CPU 0, load generator on the others. "
        "Cells: value (× mosquitto in the same run); load = 1-minute load average at the start "
        "of the rows' runs.",
        "",
        "Versions: " + "; ".join(f"{k}: {v}" for k, v in meta.versions.items()) + ".",
        "",
        f"Generator ceiling: {meta.ceiling}",
        "",
    ]
    if meta.unavailable:
        out += ["Not measured: " + "; ".join(f"{k}: {v}" for k, v in meta.unavailable.items())]
        out.append("")
    sections = [
        (THROUGHPUT_CASES, "in_rate", "messages in/s delivered to every subscriber"),
        (LATENCY_CASES, "p50", "latency p50, ms"),
        (LATENCY_CASES, "p99", "latency p99, ms"),
        (LATENCY_CASES, "p999", "latency p99.9, ms"),
        ((*THROUGHPUT_CASES, *LATENCY_CASES), "cpu", "broker CPU µs per message in"),
        ((*THROUGHPUT_CASES, *LATENCY_CASES), "rss", "peak RSS (VmHWM), MiB"),
        ((*THROUGHPUT_CASES, *LATENCY_CASES), "wait", "broker waited for CPU 0, % of run"),
    ]
    for cases, metric, title in sections:
        out += [*_table(flows, cases, metric, title), ""]
    out += ["## The subscriber that stops reading (one of ten)", ""]
    out += ["| broker | nine readers, msgs in/s | stalled subscriber | RSS growth |"]
    out += ["|---|---|---|---|"]
    for f in flows:
        if f.case == "stalled 1 of 10" and not f.error:
            growth = f"{f.rss_growth_kib / 1024:+.1f} MiB"
            out.append(f"| {f.broker} | {_fmt(f.in_rate)} | {f.stalled} | {growth} |")
    out += ["", "## Goals (reported, not asserted)", "", *_goals(flows), ""]
    errors = [f for f in flows if f.error or f.notes]
    if errors:
        out += ["## Notes and errors", ""]
        out += [f"- {f.broker}, {f.case}: {f.error or '; '.join(f.notes)}" for f in errors]
        out.append("")
        if any(f.error for f in flows):
            out += ["¹ the workload failed; the error is listed above.", ""]
    out += ["## Reading the results", "", _READING, ""]
    if profile:
        out += ["## Where the reference server's time goes (py-spy, fan-out 1)", "", profile, ""]
    return "\n".join(out)


def plots(flows: Sequence[Flow], meta: Meta, folder: Path) -> list[Path]:
    """Write one PNG per metric (absolute and × mosquitto side by side); return their paths."""
    try:
        matplotlib: Any = importlib.import_module("matplotlib")
    except ImportError:
        return []
    matplotlib.use("Agg")
    plt: Any = importlib.import_module("matplotlib.pyplot")
    specs = [
        ("throughput.png", THROUGHPUT_CASES[:6], "in_rate", "messages in/s", True),
        ("latency.png", LATENCY_CASES, "p99", "latency p99 (ms)", True),
        ("cpu.png", THROUGHPUT_CASES[:6], "cpu", "broker CPU µs per message", True),
        ("rss.png", THROUGHPUT_CASES, "rss", "peak RSS (MiB)", False),
    ]
    written = []
    idx = _index(flows)
    brokers = [b for b in BROKERS if b != "relay" and any(f.broker == b for f in flows)]
    for name, cases, metric, label, log in specs:
        fig, axes = plt.subplots(1, 2, figsize=(13, 4.8))
        width = 0.8 / max(len(brokers), 1)
        for i, broker in enumerate(brokers):
            values, ratios = [], []
            for case in cases:
                flow, ref = idx.get((broker, case)), idx.get((REF, case))
                v = metric_value(flow, metric) if flow and not flow.error else math.nan
                r = metric_value(ref, metric) if ref and not ref.error else math.nan
                values.append(v)
                ratios.append(v / r if r else math.nan)
            xs = [x + i * width for x in range(len(cases))]
            axes[0].bar(xs, values, width, label=broker)
            axes[1].bar(xs, ratios, width, label=broker)
        for ax, ylabel in ((axes[0], label), (axes[1], f"{label}, × mosquitto")):
            ax.set_xticks([x + 0.4 - width / 2 for x in range(len(cases))], cases, fontsize=8)
            ax.set_ylabel(ylabel)
            if log:
                ax.set_yscale("log")
        axes[1].axhline(1.0, color="grey", linewidth=0.8)
        axes[0].legend(fontsize=8)
        fig.suptitle(
            f"{label} — {meta.date}, {meta.machine}, load {meta.load_start:.1f}–"
            f"{meta.load_end:.1f}",
            fontsize=9,
        )
        fig.tight_layout()
        path = folder / name
        fig.savefig(path, dpi=90)
        plt.close(fig)
        written.append(path)
    return written


def snippet(flows: Sequence[Flow], meta: Meta) -> str:
    """Return the README subsection: the key figures, each with its ratio to mosquitto."""
    cases = ("fan-out 1", "fan-out 10", "routing 1", "routing 100", "routing 10000")
    rows = [
        *_table(flows, cases, "in_rate", "msgs in/s to every subscriber"),
        *_table(flows, ("rate 1000/s", "rate 10000/s"), "p99", "latency p99, ms")[2:],
        *_table(flows, ("fan-out 1",), "cpu", "µs CPU per message")[2:],
        *_table(flows, ("fan-out 10",), "rss", "peak RSS MiB")[2:],
    ]
    rows = [r.replace("| rate ", "| p99 ms at ", 1) for r in rows]
    rows = [
        r.replace("| fan-out 1 |", "| µs CPU/msg, fan-out 1 |") if i == len(rows) - 2 else r
        for i, r in enumerate(rows)
    ]
    rows = [
        r.replace("| fan-out 10 |", "| peak RSS MiB, fan-out 10 |") if i == len(rows) - 1 else r
        for i, r in enumerate(rows)
    ]
    return "\n".join(
        [
            "### Against other brokers (`make bench-peers`)",
            "",
            f"The reference server beside mosquitto, NATS, Redis pub/sub and amqtt on the "
            f"same machine in one run ({meta.date}; {meta.machine}; load average "
            f"{meta.load_start:.1f} at the start, {meta.load_end:.1f} at the end, from other "
            "jobs). Each broker is pinned to CPU 0, the multi-process load generator to the "
            "other CPU; 64-byte payloads carrying a sequence number and send time, `noreply` "
            "posts for OpenAIR, QoS 0 for MQTT. Cells: value (× mosquitto in the same run). "
            "Full tables, the stalled-subscriber results, the goals and a py-spy profile: "
            "[bench/results/peers.md](bench/results/peers.md).",
            "",
            *rows,
            "",
            *_goals(flows),
            "",
            "![throughput](bench/results/throughput.png)",
            "",
            f"Versions: {'; '.join(f'{k}: {v}' for k, v in meta.versions.items())}.",
            "",
        ]
    )
