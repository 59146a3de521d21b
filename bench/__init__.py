"""Benchmarks of the OpenAIR kit (`python -m bench`, `make bench`; never part of `make test`).

Every module `bench/bench_<name>.py` defines `run() -> list[Result]`; `python -m bench` finds,
runs and prints them. Results are measurements, never assertions. Use `per_call` to time a
function over a list of inputs, and report a baseline measured in the same run so that readers
can compare numbers taken on different machines.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

T = TypeVar("T")


@dataclass(frozen=True, slots=True, kw_only=True)
class Result:
    """One measured figure: `value` in `unit`, optionally as a multiple of a baseline."""

    bench: str
    case: str
    value: float
    unit: str
    ratio: float | None = None
    note: str = ""


def per_call(
    fn: Callable[[T], object],
    items: Sequence[T],
    *,
    repeat: int = 5,
    min_time: float = 0.05,
) -> float:
    """Return the best mean seconds per call of `fn` over `items` among `repeat` rounds.

    Each round runs the whole item list enough times to last at least `min_time` seconds; the
    best round is reported (the least disturbed by other processes).
    """
    if not items:
        raise ValueError("per_call needs at least one item")
    start = time.perf_counter()
    for item in items:
        fn(item)
    once = max(time.perf_counter() - start, 1e-9)
    loops = max(1, math.ceil(min_time / once))
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(loops):
            for item in items:
                fn(item)
        best = min(best, time.perf_counter() - start)
    return best / (loops * len(items))
