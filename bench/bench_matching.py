"""Cost of finding the triggers that match a message type (`openair.protocol.matching`).

For 1, 100 and 10 000 registered patterns in a realistic mix (about 55 % `Prefix.*`, 44 % exact
types, 1 % general globs of which at most 3 have no literal segment before their first `*`), it
reports the cost of `PatternIndex.match` per message, and the cost of scanning every pattern
with `matches()` for comparison. The baseline is one dict lookup of the ASCII-folded type, the
least any matcher has to do.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable

from bench import Result, per_call
from openair.protocol.matching import PatternIndex, ascii_fold, matches

_SEED = 20261122
_SIZES = (1, 100, 10_000)
_MESSAGES = 2_000
_SCAN_MESSAGES = 20  # a full scan of 10 000 patterns is slow; fewer messages suffice
_LOOSE_GLOBS = ("*.Error", "*Debug*", "Sys*.Log.*")
BENCH = "matching"

Key = tuple[str, int]


def _segment(rng: random.Random, stem: str, count: int) -> str:
    return f"{stem}{rng.randrange(count)}"


def _random_type(rng: random.Random) -> str:
    """Draw a type like `App17.Comp3.Event41` or `App17.Comp3.Event41.Detail2`."""
    parts = [_segment(rng, "App", 300), _segment(rng, "Comp", 20), _segment(rng, "Event", 50)]
    if rng.random() < 0.3:
        parts.append(_segment(rng, "Detail", 5))
    return ".".join(parts)


def _pattern(rng: random.Random, i: int, n: int) -> str:
    """Draw the i-th of n patterns following the mix in the module docstring."""
    general = max(1, n // 100) if n >= 100 else 0
    if i < min(general, len(_LOOSE_GLOBS)):
        return _LOOSE_GLOBS[i]
    if i < general:
        app, comp = _segment(rng, "App", 300), _segment(rng, "Comp", 20)
        return rng.choice([f"{app}.*.Event{rng.randrange(50)}", f"{app}.{comp}*"])
    if rng.random() < 0.55 or n == 1:
        depth = rng.choice((1, 2, 2, 3))
        return ".".join(_random_type(rng).split(".")[:depth]) + ".*"
    return _random_type(rng)


def _registrations(n: int) -> list[tuple[str, Key]]:
    rng = random.Random(_SEED + n)
    return [(_pattern(rng, i, n), (f"Module{i // 4}", i % 4)) for i in range(n)]


def _messages(pairs: list[tuple[str, Key]]) -> list[str]:
    """Draw messages: 20 % equal a pattern's literal part, 40 % lie below it, 40 % are random."""
    rng = random.Random(_SEED)
    out = []
    for _ in range(_MESSAGES):
        literal = rng.choice(pairs)[0].split("*", 1)[0].rstrip(".")
        draw = rng.random()
        if draw < 0.2 and literal:
            out.append(literal)
        elif draw < 0.6 and literal:
            out.append(f"{literal}.{_segment(rng, 'Event', 50)}.{_segment(rng, 'Detail', 5)}")
        else:
            out.append(_random_type(rng))
    return out


def _baseline(messages: list[str]) -> float:
    table = {ascii_fold(t): 1 for t in messages[::2]}

    def lookup(type_: str) -> object:
        return table.get(ascii_fold(type_))

    return per_call(lookup, messages)


def _scan(pairs: list[tuple[str, Key]]) -> Callable[[str], set[Key]]:
    def scan(type_: str) -> set[Key]:
        return {key for pattern, key in pairs if matches(pattern, type_)}

    return scan


def _build(pairs: list[tuple[str, Key]]) -> tuple[PatternIndex[Key], float]:
    start = time.perf_counter()
    index: PatternIndex[Key] = PatternIndex()
    for pattern, key in pairs:
        index.add(pattern, key)
    return index, (time.perf_counter() - start) / len(pairs)


def _result(case: str, seconds: float, base: float, note: str) -> Result:
    return Result(
        bench=BENCH, case=case, value=seconds * 1e6, unit="us/msg", ratio=seconds / base, note=note
    )


def _results_for(n: int, base: float) -> list[Result]:
    pairs = _registrations(n)
    messages = _messages(pairs)
    index, build = _build(pairs)
    hits = sum(len(index.match(t)) for t in messages) / len(messages)
    cost = per_call(index.match, messages)
    scan = per_call(_scan(pairs), messages[:_SCAN_MESSAGES], repeat=3, min_time=0.02)
    label = f"{n} patterns"
    matched = f"{hits:.1f} keys matched per message on average"
    results = [
        _result(f"index.match, {label}", cost, base, matched),
        _result(f"scan of matches(), {label}", scan, base, "for comparison: no index"),
    ]
    if n >= 100:  # one add is too short to time on its own
        results.append(
            Result(bench=BENCH, case=f"index.add, {label}", value=build * 1e6, unit="us/pattern")
        )
    return results


def run() -> list[Result]:
    """Measure match cost per message at 1, 100 and 10 000 registered patterns."""
    base = _baseline(_messages(_registrations(100)))
    results = [_result("baseline: dict lookup of folded type", base, base, "least work possible")]
    for n in _SIZES:
        results.extend(_results_for(n, base))
    return results
