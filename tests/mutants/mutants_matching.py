"""Mutants of type matching (spec section 5): a matcher with one switchable fault each.

`spec_match` with no fault is OA-MATCH-1..6 (test_mutants.py checks it against the wildcard
vectors); each `Fault` switch breaks one rule. A mutant puts the faulty matcher into both places
the server matches: the router's trigger index (`openair.server.core.router.PatternIndex`, replaced
by a scanning index) and the whiteboard's retrieve criteria
(`openair.server.core.whiteboard.matches`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import pytest
from mutants_core import mutant

from openair.server.core import router, whiteboard

__all__ = ["NO_FAULT", "Fault", "compile_pattern", "spec_match"]

_FOLD = str.maketrans("ABCDEFGHIJKLMNOPQRSTUVWXYZ", "abcdefghijklmnopqrstuvwxyz")


@dataclass(frozen=True, slots=True, kw_only=True)
class Fault:
    """Switches of `spec_match`; the defaults are OA-MATCH-1..6, each other value one fault.

    `fold=False`: case-sensitive. `dots=False`: `*` stops at dots. `root`: "literal" (the
    subtree root compared literally), "none" (`P.*` never matches `P`), "glob" (the root is a
    glob). `literal_prefix`: a pattern without `*` also matches its dotted extensions.
    `overlap`: a two-part glob's prefix and suffix may overlap in the type.
    """

    fold: bool = True
    dots: bool = True
    root: str = "literal"
    literal_prefix: bool = False
    overlap: bool = False


NO_FAULT = Fault()


def _glob(parts: list[str], t: str, fault: Fault) -> bool:
    """Match `t` against literal parts joined by `*` (leftmost placement, as matching.py)."""
    if len(parts) == 1:
        return t == parts[0] or (fault.literal_prefix and t.startswith(parts[0] + "."))
    pre, post = parts[0], parts[-1]
    end = len(t) - len(post)
    if not t.startswith(pre) or not t.endswith(post):
        return False
    if end < len(pre):
        return fault.overlap and len(parts) == 2
    pos = len(pre)
    for middle in parts[1:-1]:
        found = t.find(middle, pos, end)
        if found < 0 or (not fault.dots and "." in t[pos:found]):
            return False
        pos = found + len(middle)
    return fault.dots or "." not in t[pos:end]


@functools.cache
def compile_pattern(pattern: str, fault: Fault = NO_FAULT) -> Callable[[str], bool]:
    """Return a test of types (already folded when `fault.fold`) against `pattern`."""
    p = pattern.translate(_FOLD) if fault.fold else pattern
    parts = p.split("*")
    root: list[str] | None = None
    if p.endswith(".*") and fault.root == "literal":
        root = [p[:-2]]
    elif p.endswith(".*") and fault.root == "glob":
        root = p[:-2].split("*")
    no_prefix = replace(fault, literal_prefix=False)
    return lambda t: _glob(parts, t, fault) or (root is not None and _glob(root, t, no_prefix))


def spec_match(pattern: str, type_: str, fault: Fault = NO_FAULT) -> bool:
    """Match `pattern` against `type_` as OA-MATCH-1..6 say, but for `fault`."""
    return compile_pattern(pattern, fault)(type_.translate(_FOLD) if fault.fold else type_)


class _ScanIndex:
    """A PatternIndex stand-in that tries every pattern (compiled once) on each type."""

    fault: Fault = NO_FAULT

    def __init__(self) -> None:
        self._pairs: dict[tuple[str, Any], Callable[[str], bool]] = {}

    def __len__(self) -> int:
        return len(self._pairs)

    def add(self, pattern: str, key: Any) -> None:
        self._pairs[pattern, key] = compile_pattern(pattern, self.fault)

    def remove(self, pattern: str, key: Any) -> None:
        del self._pairs[pattern, key]

    def clear(self) -> None:
        self._pairs.clear()

    def match(self, type_: str) -> set[Any]:
        t = type_.translate(_FOLD) if self.fault.fold else type_
        return {key for (_, key), test in self._pairs.items() if test(t)}


def _matcher(mp: pytest.MonkeyPatch, **switches: Any) -> None:
    """Make triggers (the router's index) and retrieves (the whiteboard) use a faulty matcher."""
    fault = Fault(**switches)
    mp.setattr(router, "PatternIndex", type("FaultyIndex", (_ScanIndex,), {"fault": fault}))
    mp.setattr(
        whiteboard, "matcher", lambda pattern: functools.partial(spec_match, pattern, fault=fault)
    )


@mutant("match-star-stops-at-dots", "`*` matches no dot", "OA-MATCH-3")
def _star_no_dots(mp: pytest.MonkeyPatch) -> None:
    _matcher(mp, dots=False)


@mutant("match-case-sensitive", "patterns compare case-sensitively", "OA-MATCH-1")
def _case_sensitive(mp: pytest.MonkeyPatch) -> None:
    _matcher(mp, fold=False)


@mutant("match-literal-prefix", "`A.B` also matches `A.B.C`", "OA-MATCH-2")
def _literal_prefix(mp: pytest.MonkeyPatch) -> None:
    _matcher(mp, literal_prefix=True)


@mutant("match-no-subtree-root", "`P.*` does not match `P`", "OA-MATCH-4")
def _no_root(mp: pytest.MonkeyPatch) -> None:
    _matcher(mp, root="none")


@mutant("match-root-as-glob", "the subtree root is a glob: `*.*` matches `A`", "OA-MATCH-4")
def _root_glob(mp: pytest.MonkeyPatch) -> None:
    _matcher(mp, root="glob")


@mutant("match-overlap", "prefix and suffix may overlap: `A*A` matches `A`", "OA-MATCH-6")
def _overlap(mp: pytest.MonkeyPatch) -> None:
    _matcher(mp, overlap=True)
