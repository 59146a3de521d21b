"""Run the reference server in a background event loop and the suite against it in-process.

The same arrangement as tests/server_thread.py (the suite's deadlines must not share a loop
with the server). Imports of `openair` happen inside the functions, so that the control and
the judge import the server of the copy they run in (PYTHONPATH), after coverage started.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Iterator, Sequence
from typing import Any

from openair_conformance.engine import RunOptions, run
from openair_conformance.model import Reporter, RunSummary
from openair_conformance.registry import RegisteredCase

__all__ = [
    "CASE_LIMITS",
    "FUZZ_EXAMPLES",
    "FUZZ_SEED",
    "by_limits",
    "limits_of",
    "run_cases",
    "serving",
]

#: FUZZ-001 runs a fixed seed and few examples, so a verdict depends on the server only.
FUZZ_EXAMPLES = 10
FUZZ_SEED = "20261122"
_GRACE_S = 0.2
#: Cases not applicable at the default limits, with the limits that make them run (as
#: LIMITED in tests/conformance/test_suite_reference.py): they run on a server of their own.
CASE_LIMITS: dict[str, tuple[tuple[str, int], ...]] = {
    "DELIV-003": (("max_queue", 300),),
    "FRAME-018": (("frame_deadline_ms", 400),),
}


def limits_of(case_id: str) -> tuple[tuple[str, int], ...]:
    """Return the server limits a case runs under (empty: the defaults)."""
    return CASE_LIMITS.get(case_id, ())


async def _cancel_the_rest() -> None:
    me = asyncio.current_task()
    rest = [task for task in asyncio.all_tasks() if task is not me]
    for task in rest:
        task.cancel()
    await asyncio.gather(*rest, return_exceptions=True)


@contextlib.contextmanager
def serving(limits: tuple[tuple[str, int], ...] = ()) -> Iterator[tuple[str, int]]:
    """Start the reference server with these limits (others default) on 127.0.0.1; yield
    where it listens."""
    from openair.server.aio.app import ServerOptions, start_server
    from openair.server.core.config import ServerLimits

    server_limits = ServerLimits(**dict(limits))
    options = ServerOptions(host="127.0.0.1", port=0, limits=server_limits, grace_s=_GRACE_S)
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        server: Any = asyncio.run_coroutine_threadsafe(start_server(options), loop).result(30)
        server.datapath = None  # the mutants change the reference code: no data path (#20)
        yield ("127.0.0.1", int(server.port))
        with contextlib.suppress(Exception):
            asyncio.run_coroutine_threadsafe(server.stop(), loop).result(10)
    finally:
        with contextlib.suppress(Exception):  # a broken server may leave tasks behind
            asyncio.run_coroutine_threadsafe(_cancel_the_rest(), loop).result(10)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(timeout=10)


def by_limits(case_ids: Sequence[str]) -> list[tuple[tuple[tuple[str, int], ...], list[str]]]:
    """Group case IDs by the limits they run under, the defaults first, order kept."""
    groups: dict[tuple[tuple[str, int], ...], list[str]] = {(): []}
    for case_id in case_ids:
        groups.setdefault(limits_of(case_id), []).append(case_id)
    return [(limits, ids) for limits, ids in groups.items() if ids]


def run_cases(
    target: tuple[str, int],
    cases: Sequence[RegisteredCase],
    reporters: Sequence[Reporter],
    *,
    jobs: int,
    timeout_scale: float,
) -> RunSummary:
    """Run `cases` against `target` in the registry order given, with the kit's engine."""
    options = RunOptions(
        target=target,
        jobs=jobs,
        timeout_scale=timeout_scale,
        fuzz_examples=FUZZ_EXAMPLES,
        replay=FUZZ_SEED,
    )
    return asyncio.run(run(options, reporters, cases=cases))
