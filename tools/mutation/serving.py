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
    "SECRETS",
    "SECURE",
    "by_limits",
    "limits_of",
    "run_cases",
    "serving",
]

#: FUZZ-001 runs a fixed seed and few examples, so a verdict depends on the server only.
FUZZ_EXAMPLES = 10
FUZZ_SEED = "20261122"
_GRACE_S = 0.2
Limits = tuple[tuple[str, int], ...]

#: The small limits of the 14.1 cases (OA-LIM-8, -9, -10): one server for the four of them.
_BYTE_BOUNDS: Limits = (
    ("max_history_bytes", 60_000),
    ("max_queue_bytes", 65_536),
    ("max_wakeup_result_bytes", 5),
    ("max_wakeup_results", 8),
)
#: OA-LIM-14 and OA-LIM-15 at bounds a case reaches in a second (LIM-014, LIM-015).
_HELD_AND_RETENTION: Limits = (("max_held_bytes", 262_144), ("module_retention_ms", 200))
#: Retries beyond the default two (OA-DELIV-15): the back-off table's last entry is reused.
_MORE_RETRIES: Limits = (("delivery_retries", 4), ("retry_deadline_ms", 100))

#: Cases that run at other limits than the defaults (as LIMITED in
#: tests/conformance/test_suite_reference.py): case -> every set of limits it runs under, `()`
#: being the defaults; each set gets a server of its own. Those not applicable at the defaults
#: run only at their small limits.
CASE_LIMITS: dict[str, tuple[Limits, ...]] = {
    "DELIV-003": ((("max_queue", 300),),),
    "DELIV-013": ((), _MORE_RETRIES),
    "FRAME-018": ((("frame_deadline_ms", 400),),),
    **{case_id: ((("max_frame_binary", 4096),),) for case_id in ("ATT-005", "LIM-051")},
    "LIM-050": ((("max_created_streams", 4),),),
    "DELIV-018": ((("ack_deadline_ms", 500),),),
    "LIM-016": ((("max_held_bytes", 262_144),),),
    "LIM-041": ((("max_held_bytes", 262_144), ("max_history_bytes", 131_072)),),
    **{case_id: (_HELD_AND_RETENTION,) for case_id in ("LIM-014", "LIM-015")},
    **{
        case_id: (_BYTE_BOUNDS,)
        for case_id in ("LIM-001", "LIM-002", "LIM-003", "LIM-004", "LIM-005")
    },
}


#: Not a limit: the server runs in secure mode (extension `auth`, spec 14.3) with `SECRETS`,
#: and the suite gets the same secrets, as `openair conform --auth-secrets FILE` would.
SECURE: tuple[str, int] = ("secure", 1)
SECRETS = {"AuthCaseA": "secret-of-case-module-a-0123", "AuthCaseB": "secret-of-case-module-b-4567"}


def limits_of(case_id: str) -> tuple[Limits, ...]:
    """Return every set of server limits a case runs under (`((),)`: the defaults only); the
    secure-mode cases (AUTH-*) run only against a server in secure mode."""
    if case_id.startswith("AUTH-"):
        return ((SECURE,),)
    return CASE_LIMITS.get(case_id, ((),))


async def _cancel_the_rest() -> None:
    me = asyncio.current_task()
    rest = [task for task in asyncio.all_tasks() if task is not me]
    for task in rest:
        task.cancel()
    await asyncio.gather(*rest, return_exceptions=True)


@contextlib.contextmanager
def serving(limits: Limits = ()) -> Iterator[tuple[str, int]]:
    """Start the reference server with these limits (others default) on 127.0.0.1; yield
    where it listens."""
    from openair.server.aio.app import ServerOptions, start_server
    from openair.server.core.config import ServerLimits

    server_limits = ServerLimits(**{k: v for k, v in limits if (k, v) != SECURE})
    options = ServerOptions(
        host="127.0.0.1",
        port=0,
        limits=server_limits,
        grace_s=_GRACE_S,
        auth_secrets=SECRETS if SECURE in limits else None,
    )
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


def by_limits(case_ids: Sequence[str]) -> list[tuple[Limits, list[str]]]:
    """Group case IDs by the limits they run under, the defaults first, order kept; a case
    with several sets of limits is in each of their groups."""
    groups: dict[Limits, list[str]] = {(): []}
    for case_id in case_ids:
        for limits in limits_of(case_id):
            groups.setdefault(limits, []).append(case_id)
    return [(limits, ids) for limits, ids in groups.items() if ids]


def run_cases(
    target: tuple[str, int],
    cases: Sequence[RegisteredCase],
    reporters: Sequence[Reporter],
    *,
    jobs: int,
    timeout_scale: float,
    limits: Limits = (),
) -> RunSummary:
    """Run `cases` against `target` (a server started with `limits`) in the registry order
    given, with the kit's engine."""
    options = RunOptions(
        target=target,
        auth_secrets=SECRETS if SECURE in limits else {},
        jobs=jobs,
        timeout_scale=timeout_scale,
        fuzz_examples=FUZZ_EXAMPLES,
        replay=FUZZ_SEED,
    )
    return asyncio.run(run(options, reporters, cases=cases))
