"""What run_demo.py measures: counters from the monitor's JSON API, /proc CPU, history rates.

No clock reads here beyond what the caller passes; HTTP through urllib (the caller runs these
on a worker thread).
"""

from __future__ import annotations

import json
import os
import urllib.request
from dataclasses import dataclass, field

from skundar_common import kv

CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """User + system CPU time a process has used (Linux /proc)."""
    with open(f"/proc/{pid}/stat", encoding="ascii") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


def get_json(base: str, path: str) -> dict[str, object]:
    """GET one monitor endpoint."""
    with urllib.request.urlopen(base + path, timeout=10) as reply:
        data: dict[str, object] = json.load(reply)
    return data


@dataclass(slots=True, kw_only=True)
class Snapshot:
    """Cumulative counters at one moment."""

    histograms: dict[str, list[tuple[int | None, int]]] = field(default_factory=dict)
    received: dict[str, int] = field(default_factory=dict)
    samples_added: dict[str, int] = field(default_factory=dict)


def snapshot(base: str, modules: list[str]) -> Snapshot:
    """Read each module's post→wakeup histogram and the whiteboards' and streams' counters."""
    snap = Snapshot()
    for name in modules:
        detail = get_json(base, f"/api/modules/{name}")
        latency = detail.get("latency")
        if isinstance(latency, dict):
            snap.histograms[name] = [(b["le_us"], int(b["count"])) for b in latency["buckets"]]
    overview = get_json(base, "/api/overview")
    for wb in overview["whiteboards"]:  # type: ignore[attr-defined]
        snap.received[str(wb["name"])] = int(wb["received"])
    for stream in overview["streams"]:  # type: ignore[attr-defined]
        snap.samples_added[str(stream["name"])] = int(stream["added"])
    return snap


def histogram_delta(before: Snapshot, after: Snapshot) -> list[tuple[int | None, int]]:
    """Sum every module's histogram over the window (after − before)."""
    total: dict[int | None, int] = {}
    for name, buckets in after.histograms.items():
        old = dict(before.histograms.get(name, []))
        for bound, count in buckets:
            total[bound] = total.get(bound, 0) + count - old.get(bound, 0)
    finite = sorted((b, c) for b, c in total.items() if b is not None)
    return [*finite, (None, total.get(None, 0))]


def histogram_quantile(buckets: list[tuple[int | None, int]], q: float) -> float | None:
    """The q-quantile in ms, interpolated linearly inside its bucket (None: no data)."""
    n = sum(c for _, c in buckets)
    if n == 0:
        return None
    rank, seen, lower = q * n, 0, 0
    for bound, count in buckets:
        if count and seen + count >= rank:
            upper = bound if bound is not None else lower * 2
            return (lower + (upper - lower) * (rank - seen) / count) / 1000
        seen += count
        lower = bound if bound is not None else lower
    return lower / 1000


def quantile(values: list[float], q: float) -> float | None:
    """The q-quantile of raw values (nearest rank)."""
    if not values:
        return None
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, int(q * len(ordered) + 0.5) - 1))]


def loop_latencies(contents: list[str]) -> tuple[list[float], int]:
    """The controller's loop latencies (ms) and its deadline misses, from DiffMotion contents."""
    lats, late = [], 0
    for content in contents:
        values = kv(content)
        if "lat" in values:
            lats.append(float(values["lat"]))
            late += values.get("late") == "1"
    return lats, late
