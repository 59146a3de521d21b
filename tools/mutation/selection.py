"""Mutant keys, the lines coverage records for a mutation, and the cases to run against it.

Pure functions over source text and a coverage map, so they are tested without a server.

A mutant key is `module:linehash:operator:k`: the module's relative path, the first 10 hex
digits of the SHA-1 of the mutated line's stripped text, cosmic-ray's operator name and the
mutant's rank among those with the same module, line text and operator. Unlike cosmic-ray's
`occurrence` (a count over the whole module) it does not move when code is added elsewhere,
so explanations in equivalent.toml stay attached to their mutant.
"""

from __future__ import annotations

import ast
import hashlib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

__all__ = [
    "STARTUP",
    "TEARDOWN",
    "CoverageMap",
    "MutantSite",
    "Selection",
    "annotation_spans",
    "changed_lines",
    "in_spans",
    "mutant_keys",
    "recorded_lines",
    "select_cases_for",
]

#: Pseudo case IDs for code run while the server starts (and the engine probes) or stops.
STARTUP = "<startup>"
TEARDOWN = "<teardown>"

#: module path -> line -> the IDs of the cases (or STARTUP/TEARDOWN) that executed it.
CoverageMap = Mapping[str, Mapping[int, frozenset[str]]]


@dataclass(frozen=True, slots=True, kw_only=True)
class MutantSite:
    """Where cosmic-ray put one mutation: what `mutant_keys` needs to name it."""

    job_id: str
    module: str
    line: int
    column: int
    operator: str
    occurrence: int


def line_hash(text: str) -> str:
    """Return the hash of a source line that keys depend on (white space around it ignored)."""
    return hashlib.sha1(text.strip().encode("utf-8")).hexdigest()[:10]


def mutant_keys(sites: Iterable[MutantSite], sources: Mapping[str, str]) -> dict[str, str]:
    """Return job id -> stable key for each site; `sources` maps module path -> source text."""
    lines = {module: text.splitlines() for module, text in sources.items()}
    groups: dict[tuple[str, str, str], list[MutantSite]] = {}
    for site in sites:
        text = lines[site.module][site.line - 1] if site.line <= len(lines[site.module]) else ""
        groups.setdefault((site.module, line_hash(text), site.operator), []).append(site)
    keys: dict[str, str] = {}
    for (module, digest, operator), members in groups.items():
        members.sort(key=lambda s: (s.line, s.column, s.occurrence))
        for rank, site in enumerate(members):
            keys[site.job_id] = f"{module}:{digest}:{operator}:{rank}"
    return keys


def changed_lines(original: str, mutated: str) -> list[int]:
    """Return the 1-based lines of `original` that `mutated` changes (a pure insertion counts
    as a change of the line before it)."""
    import difflib

    a, b = original.splitlines(), mutated.splitlines()
    out: list[int] = []
    for tag, i1, i2, _, _ in difflib.SequenceMatcher(a=a, b=b, autojunk=False).get_opcodes():
        if tag != "equal":
            out += list(range(i1 + 1, i2 + 1)) if i2 > i1 else [max(i1, 1)]
    return sorted(set(out))


def _header_end(node: ast.stmt) -> int:
    """Return the last line of a statement's own text: the header of a compound statement."""
    body = getattr(node, "body", None)
    if isinstance(body, list) and body and isinstance(body[0], ast.stmt):
        return max(node.lineno, body[0].lineno - 1)
    return node.end_lineno or node.lineno


def _first_line(node: ast.stmt) -> int:
    decorators: list[ast.expr] = getattr(node, "decorator_list", [])
    return min([node.lineno, *(d.lineno for d in decorators)])


def recorded_lines(source: str, lines: Iterable[int]) -> set[int]:
    """Return the lines under which coverage records the statements that contain `lines`.

    coverage.py records a multi-line statement under its first line; a decorated definition
    under its decorator or `def` line. The lines themselves are included.
    """
    wanted = set(lines)
    out = set(wanted)
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.stmt):
            first, last = _first_line(node), _header_end(node)
            if any(first <= line <= last for line in wanted):
                out |= {first, node.lineno}
    return out


def _enclosing_function_lines(source: str, lines: Iterable[int]) -> set[int]:
    """Return the statement lines of the innermost function around `lines` (empty if none)."""
    wanted = set(lines)
    best: ast.FunctionDef | ast.AsyncFunctionDef | None = None
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            first, last = _first_line(node), node.end_lineno or node.lineno
            inside = any(first <= line <= last for line in wanted)
            if inside and (best is None or node.lineno > best.lineno):
                best = node
    if best is None:
        return set()
    return {n.lineno for stmt in best.body for n in ast.walk(stmt) if isinstance(n, ast.stmt)}


@dataclass(frozen=True, slots=True, kw_only=True)
class Selection:
    """What the judge runs against a mutant.

    `kind` is `cases` (the cases that executed the line), `startup` (the line runs only while
    the server starts: every passing case) or `not-executed` (no case runs it: a survivor).
    """

    kind: str
    cases: tuple[str, ...]
    lines: tuple[int, ...]


def _contexts(lines_map: Mapping[int, frozenset[str]], lines: Iterable[int]) -> set[str]:
    found: set[str] = set()
    for line in lines:
        found |= lines_map.get(line, frozenset())
    return found


def select_cases_for(
    cmap: CoverageMap,
    module: str,
    source: str,
    lines: Sequence[int],
    passing: Sequence[str],
) -> Selection:
    """Return the cases to run against a mutation of `lines` of `module` (original numbering).

    Only cases in `passing` (those that pass on the clean server) are ever chosen; the order of
    `passing` is kept (the judge puts the fastest first). A line run only at start-up (a
    `def` line, a default value, a module constant) stands for the function around it; when
    that is not executed by any case either, every passing case runs.
    """
    lines_map = cmap.get(module, {})
    recorded = recorded_lines(source, lines)
    contexts = _contexts(lines_map, recorded)
    if contexts <= {STARTUP, TEARDOWN} and STARTUP in contexts:
        contexts |= _contexts(lines_map, _enclosing_function_lines(source, lines))
    ok = set(passing)
    chosen = tuple(case for case in passing if case in contexts and case in ok)
    lines_t = tuple(sorted(recorded))
    if chosen:
        return Selection(kind="cases", cases=chosen, lines=lines_t)
    if STARTUP in contexts:
        return Selection(kind="startup", cases=tuple(passing), lines=lines_t)
    return Selection(kind="not-executed", cases=(), lines=lines_t)


Span = tuple[tuple[int, int], tuple[int, int]]


def annotation_spans(source: str) -> list[Span]:
    """Return the (start, end) (line, column) spans of the module's annotations.

    Only for a module with `from __future__ import annotations` (the house rule): there no
    annotation is evaluated at run time, so a mutant inside one is equivalent by construction.
    """
    tree = ast.parse(source)
    future = any(
        isinstance(n, ast.ImportFrom)
        and n.module == "__future__"
        and any(a.name == "annotations" for a in n.names)
        for n in tree.body
    )
    if not future:
        return []
    found: list[ast.expr] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.arg | ast.AnnAssign) and node.annotation is not None:
            found.append(node.annotation)
        elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and node.returns:
            found.append(node.returns)
    return [
        ((a.lineno, a.col_offset), (a.end_lineno or a.lineno, a.end_col_offset or 0)) for a in found
    ]


def in_spans(spans: Sequence[Span], start: tuple[int, int], end: tuple[int, int]) -> bool:
    """Return whether the source range start..end lies inside one of `spans`."""
    return any(lo <= tuple(start) and tuple(end) <= hi for lo, hi in spans)
