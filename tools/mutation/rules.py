"""Mutants unobservable by construction, classified by rule, each with its one-line argument.

A rule looks at the mutated source position only (pure functions over the original source),
and says one of two things:

- `PRE_JUDGE`: the argument holds without running anything, so the mutant is recorded as
  explained and not judged (it would cost a whole-suite run, since such lines run at import);
- `IF_SURVIVES`: the argument needs the judge's evidence (the cases that ran the line passed),
  so the mutant is judged like any other and only a survivor gets the argument. A mutant a
  case kills stays killed: a rule never hides one.

The rules (each checked in tests/mutation/test_mutation_driver.py):

- `@dataclass(slots=...)`, `kw_only=True -> False` when the field order still allows
  positional fields, `__all__`, docstrings: PRE_JUDGE.
- `@dataclass(frozen=...)`, `@dataclass(repr=...)`, `field(repr=...)`, the arguments of a
  logging call, the keyword-only marker `*` of a parameter list turned into `/`: IF_SURVIVES
  (a frozen class made mutable loses its hash, a log argument may raise, a caller may name a
  parameter that became positional-only; a survivor showed none of that on the cases that
  ran it).
"""

from __future__ import annotations

import ast
import functools
from collections.abc import Iterator
from dataclasses import dataclass

__all__ = ["IF_SURVIVES", "PRE_JUDGE", "RuleHit", "classify", "enclosing_function"]

PRE_JUDGE = "pre-judge"
IF_SURVIVES = "if-survives"

_LOG_NAMES = frozenset({"log", "_log", "logger", "_logger", "LOG", "LOGGER"})
_LOG_METHODS = frozenset({"debug", "info", "warning", "error", "exception", "critical"})

_SLOTS = (
    "unobservable over TCP: dataclass slots=False only adds a per-instance __dict__ (memory); "
    "mypy --strict rejects every assignment of an undeclared attribute"
)
_KW_ONLY = (
    "equivalent: kw_only=False only also allows positional construction; mypy --strict checks "
    "that every call site names its fields, and the field order still compiles"
)
_FROZEN = (
    "equivalent: frozen=False only allows assignment (mypy --strict rejects every one) and "
    "drops the hash; the cases that built and used these instances passed, so none is hashed"
)
_REPR = "unobservable over TCP: a dataclass repr only reaches log lines, never the wire"
_ALL = "equivalent: __all__ only changes `from module import *`, which nothing in the tree uses"
_DOC = "equivalent: a docstring is never read at run time"
_POSITIONAL = (
    "equivalent: `/` for the keyword-only `*` makes the parameters before it positional-only "
    "and those after it accept positions too; the cases that ran the callers passed, so none "
    "names an earlier parameter"
)
_LOG = (
    "unobservable over TCP: the expression only feeds a log line; the cases that ran it "
    "passed, so it did not raise"
)


@dataclass(frozen=True, slots=True, kw_only=True)
class RuleHit:
    """A rule that applies to a mutant: when it applies and the argument."""

    when: str  # PRE_JUDGE or IF_SURVIVES
    reason: str


Pos = tuple[int, int]


def _span(node: ast.AST) -> tuple[Pos, Pos]:
    start = (getattr(node, "lineno", 0), getattr(node, "col_offset", 0))
    end = (getattr(node, "end_lineno", 0) or start[0], getattr(node, "end_col_offset", 0) or 0)
    return start, end


def _inside(node: ast.AST, start: Pos, end: Pos) -> bool:
    lo, hi = _span(node)
    return lo <= start and end <= hi


def _is_dataclass_call(node: ast.expr) -> bool:
    if not isinstance(node, ast.Call):
        return False
    func = node.func
    name = func.id if isinstance(func, ast.Name) else getattr(func, "attr", "")
    return name == "dataclass"


def _is_field_call(node: ast.AST) -> bool:
    if not isinstance(node, ast.Call):
        return False
    func = node.func
    return (func.id if isinstance(func, ast.Name) else getattr(func, "attr", "")) == "field"


def _positional_order_ok(cls: ast.ClassDef) -> bool:
    """Whether the class's fields compile as positional fields (no required field after one
    with a default), so kw_only=False does not break the class at import."""
    seen_default = False
    for stmt in cls.body:
        if not isinstance(stmt, ast.AnnAssign) or not isinstance(stmt.target, ast.Name):
            continue
        if "ClassVar" in ast.unparse(stmt.annotation):
            continue
        value = stmt.value
        has_default = value is not None
        if isinstance(value, ast.Call) and _is_field_call(value):
            has_default = any(k.arg in ("default", "default_factory") for k in value.keywords)
        if seen_default and not has_default:
            return False
        seen_default |= has_default
    return True


def _dataclass_hits(tree: ast.Module, start: Pos, end: Pos) -> Iterator[RuleHit]:
    for cls in ast.walk(tree):
        if not isinstance(cls, ast.ClassDef):
            continue
        for deco in cls.decorator_list:
            if not (_is_dataclass_call(deco) and _inside(deco, start, end)):
                continue
            assert isinstance(deco, ast.Call)
            for kw in deco.keywords:
                if kw.value is None or not _inside(kw.value, start, end):
                    continue
                if kw.arg == "slots":
                    yield RuleHit(when=PRE_JUDGE, reason=_SLOTS)
                elif kw.arg == "kw_only" and _positional_order_ok(cls):
                    yield RuleHit(when=PRE_JUDGE, reason=_KW_ONLY)
                elif kw.arg == "frozen":
                    yield RuleHit(when=IF_SURVIVES, reason=_FROZEN)
                elif kw.arg == "repr":
                    yield RuleHit(when=IF_SURVIVES, reason=_REPR)


def _field_repr_hits(tree: ast.Module, start: Pos, end: Pos) -> Iterator[RuleHit]:
    for node in ast.walk(tree):
        if _is_field_call(node) and _inside(node, start, end):
            assert isinstance(node, ast.Call)
            for kw in node.keywords:
                if kw.arg == "repr" and _inside(kw.value, start, end):
                    yield RuleHit(when=IF_SURVIVES, reason=_REPR)


def _is_log_call(node: ast.AST) -> bool:
    if not isinstance(node, ast.Call) or not isinstance(node.func, ast.Attribute):
        return False
    owner = node.func.value
    return isinstance(owner, ast.Name) and owner.id in _LOG_NAMES and node.func.attr in _LOG_METHODS


def _other_hits(tree: ast.Module, start: Pos, end: Pos) -> Iterator[RuleHit]:
    for stmt in tree.body:
        if isinstance(stmt, ast.Assign | ast.AnnAssign) and _inside(stmt, start, end):
            targets = stmt.targets if isinstance(stmt, ast.Assign) else [stmt.target]
            if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                yield RuleHit(when=PRE_JUDGE, reason=_ALL)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr):
            value = body[0].value
            is_doc = isinstance(value, ast.Constant) and isinstance(value.value, str)
            if is_doc and _inside(value, start, end):
                yield RuleHit(when=PRE_JUDGE, reason=_DOC)
        if _is_log_call(node) and _inside(node, start, end):
            assert isinstance(node, ast.Call)
            if not _inside(node.func, start, end):  # the arguments, not `log.info` itself
                yield RuleHit(when=IF_SURVIVES, reason=_LOG)


@functools.lru_cache(maxsize=16)
def _parse(source: str) -> ast.Module:
    return ast.parse(source)


def _marker_hits(tree: ast.Module, source: str, start: Pos, end: Pos) -> Iterator[RuleHit]:
    """The keyword-only marker `*` of a parameter list (a mutation there turns it into `/`)."""
    line = source.splitlines()[start[0] - 1] if 0 < start[0] <= source.count("\n") + 1 else ""
    before, after = line[: start[1]].rstrip(), line[start[1] + 1 :].lstrip()
    bare = (before == "" or before.endswith(("(", ","))) and (after == "" or after[0] in ",)")
    if line[start[1] : start[1] + 1] != "*" or not bare:
        return  # a multiplication in a default value, or `*args`/`**kwargs`
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            args = node.args
            if not args.kwonlyargs or args.vararg is not None:
                continue
            header_end = node.body[0].lineno if node.body else node.lineno
            if node.lineno <= start[0] < header_end and _inside(node, start, end):
                yield RuleHit(when=IF_SURVIVES, reason=_POSITIONAL)
                return


def classify(source: str, start: Pos, end: Pos) -> RuleHit | None:
    """Return the rule that explains a mutation of `source` between `start` and `end`
    ((line, column), cosmic-ray's positions in the original source), or None."""
    tree = _parse(source)
    for hits in (_dataclass_hits, _field_repr_hits, _other_hits):
        for hit in hits(tree, start, end):
            return hit
    for hit in _marker_hits(tree, source, start, end):
        return hit
    return None


def enclosing_function(source: str, line: int) -> str:
    """Return the qualified name (`Class.method`) of the innermost function around `line`
    ("" at module level); explanations may name a whole function (report.explain)."""
    best = ""

    def visit(node: ast.AST, prefix: str) -> None:
        nonlocal best
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{prefix}{child.name}"
                first = min([child.lineno, *(d.lineno for d in child.decorator_list)])
                if first <= line <= (child.end_lineno or child.lineno):
                    if not isinstance(child, ast.ClassDef):
                        best = name
                    visit(child, name + ".")

    visit(_parse(source), "")
    return best
