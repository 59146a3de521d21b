"""The server's data paths side by side (issue #20): reference, Python, native, in one run.

Each path serves fan-out 1 and fan-out 10 (the flows of bench_server: one poster, subscribers
woken by every post); reported: posts/s in, the ratio to the reference path measured in the
same run, and the server's CPU per post. Set OPENAIR_DATAPATH for the server process only.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

from bench import Result
from bench.bench_server import _COUNT, Flow, _flow, _process, _server_argv

BENCH = "datapath"
MODES = ("reference", "python", "native")


@contextmanager
def _datapath(mode: str) -> Iterator[None]:
    before = os.environ.get("OPENAIR_DATAPATH")
    os.environ["OPENAIR_DATAPATH"] = mode
    try:
        yield
    finally:
        if before is None:
            del os.environ["OPENAIR_DATAPATH"]
        else:
            os.environ["OPENAIR_DATAPATH"] = before


def _measure(mode: str) -> tuple[Flow, Flow]:
    with _datapath(mode), _process(_server_argv()) as (pid, port):
        one = _flow(port, pid, fanout=1, count=_COUNT)
        ten = _flow(port, pid, fanout=10, count=_COUNT // 4)
    return one, ten


def run() -> list[Result]:
    """Measure every data path; ratios are to the reference path of the same run."""
    flows = {mode: _measure(mode) for mode in MODES}
    results: list[Result] = []
    for i, case in enumerate(("fan-out 1", "fan-out 10")):
        base = flows["reference"][i]
        for mode, pair in flows.items():
            flow = pair[i]
            results.append(
                Result(
                    bench=BENCH,
                    case=f"{case}, {mode}",
                    value=flow.posts_per_s,
                    unit="msg/s in",
                    ratio=flow.posts_per_s / base.posts_per_s,
                    note=f"{flow.cpu_s * 1e6 / flow.posts:.1f} µs server CPU/post; "
                    f"{flow.delivered} delivered; ratio to reference",
                )
            )
    return results
