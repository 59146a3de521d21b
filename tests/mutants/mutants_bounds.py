"""Mutants of issue #15 found by the mutation campaign: faults the suite did not see until the
cases of this session — the byte and result bounds of 14.1 (OA-LIM-8, OA-LIM-9, OA-LIM-10),
the triggers the PhaseSpec echoes (OA-WAKE-4) and the largest valid `after` (OA-REG-8).

Each is a one-line fault of the reference server that a mutant of the campaign (cosmic-ray,
test-artifacts/mutation.md) made survive; the bounds need a server advertising small limits
(`_BOUNDS`, as the 14.1 cases' entry in tests/conformance/test_suite_reference.py's LIMITED).
"""

from __future__ import annotations

from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.protocol import registration
from openair.server.core import router_routes
from openair.server.core.queues import DeliveryQueue
from openair.server.core.whiteboard import Whiteboard

_BOUNDS = {
    "max_queue_bytes": 65_536,
    "max_wakeup_results": 8,
    "max_wakeup_result_bytes": 5,
    "max_history_bytes": 60_000,
}


def _unbounded(original: Fn) -> Fn:
    """Run `original(self, ...)` with the object's `max_bytes` set to 0 (no byte bound)."""

    def call(self: Any, *args: Any, **kwargs: Any) -> Any:
        bound, self.max_bytes = self.max_bytes, 0
        try:
            return original(self, *args, **kwargs)
        finally:
            self.max_bytes = bound

    return call


@mutant(
    "queue-bytes-ignored",
    "a module's queue is bounded by max-queue only; max-queue-bytes is advertised, not applied",
    "OA-LIM-8",
    limits=_BOUNDS,
    cases=("LIM-004",),
)
def _queue_bytes_ignored(mp: pytest.MonkeyPatch) -> None:
    wrap(mp, DeliveryQueue, "push_all", _unbounded)


@mutant(
    "history-bytes-ignored",
    "a whiteboard evicts by maxcount only; max-history-bytes is advertised, not applied",
    "OA-LIM-10",
    limits=_BOUNDS,
    cases=("LIM-003",),
)
def _history_bytes_ignored(mp: pytest.MonkeyPatch) -> None:
    wrap(mp, Whiteboard, "store_post", _unbounded)


def _results(change: Any) -> Any:
    """Patch the wakeup retrieves the router evaluates (OA-WAKE-7) with `change(original)`."""

    def patch(mp: pytest.MonkeyPatch) -> None:
        wrap(mp, router_routes, "registration_results", change)

    return patch


def _per_retrieve(original: Fn) -> Fn:
    def results(retrieves: Any, *args: Any, **kwargs: Any) -> list[Any]:
        return [m for spec in retrieves for m in original([spec], *args, **kwargs)]

    return results


def _one_byte_short(original: Fn) -> Fn:
    def results(*args: Any, max_bytes: int = 0, **kwargs: Any) -> Any:
        return original(*args, max_bytes=max(0, max_bytes - 1), **kwargs)

    return results


mutant(
    "wakeup-results-per-retrieve",
    "max-wakeup-results and max-wakeup-result-bytes bound each retrieve, not all together",
    "OA-LIM-9",
    limits=_BOUNDS,
    cases=("LIM-001", "LIM-002"),
)(_results(_per_retrieve))

mutant(
    "wakeup-result-bytes-one-short",
    "a wakeup's results stop one byte short of max-wakeup-result-bytes",
    "OA-LIM-9",
    limits=_BOUNDS,
    cases=("LIM-002",),
)(_results(_one_byte_short))


@mutant(
    "phasespec-trigger-type-only",
    "the PhaseSpec writes its triggers as registered (type, from only when given, no after=0)",
    "OA-WAKE-4",
)
def _phasespec_type_only(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def trigger_element(t: Any, *, echo: bool = False) -> Any:
            return original(t, echo=False)

        return trigger_element

    wrap(mp, registration, "_trigger_element", make)


@mutant(
    "after-int64-max-refused",
    "a trigger's after of 2^63 - 1 is refused REGISTRATION_INVALID (a bound one short)",
    "OA-REG-8",
)
def _after_max_refused(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(registration, "MAX_INT64", registration.MAX_INT64 - 1)
