"""Check an ontology against what a system does (its psySpec and a recorded history).

Each check yields `Finding`s with a level (error, warning, info) and a stable code:

| code | level | what |
|---|---|---|
| `unmatched-pattern` | error | a trigger or retrieve pattern matches no defined type (typo?) |
| `undefined-type` | error | a posted or observed type is not in the ontology |
| `invalid-type` | error | the history holds a type that is not a valid type (OA-TYPE-1) |
| `undefined-stream-type` | error | a stream's type (OA-XSTREAM-1) is not in the ontology |
| `dangling-replacement` | error | `deprecated replacedBy` names a type the ontology lacks |
| `deprecated-in-use` | warning | a deprecated type is posted, observed or named by a pattern |
| `psyclone-differs` | warning | Psyclone 1.1.7 would match a pattern differently (DEV-1..4) |
| `kind-mismatch` | warning | a group is posted, a stream type posted as a message, or back |
| `unknown-module` | warning | an ontology poster/subscriber link names no psySpec module |
| `unused-type` | info | a defined type nobody posts, observes or subscribes to |
| `non-portable-pattern` | info | not exact, `*` or `Prefix.*` (appendix A's advice) |

Suggestions for typos walk the pattern segment by segment down the type tree and replace each
unknown segment by the closest sibling (difflib ratio, ASCII case ignored), then fall back to the
nearest full names.
"""

from __future__ import annotations

import difflib
import enum
from collections.abc import Iterator
from dataclasses import dataclass

from openair.protocol.matching import ascii_fold
from openair.protocol.psyspec import SYSTEM_COMPONENTS
from openair_ontology.model import Kind, TypeEntry, TypeIndex
from openair_ontology.relations import Difference, Relations
from openair_ontology.usage import Source, Usage

__all__ = ["Finding", "Level", "lint", "nearest_names", "suggest"]

_SEGMENT_CUTOFF = 0.6
_NAME_CUTOFF = 0.5


class Level(enum.IntEnum):
    """How serious a finding is; `--fail-on` compares against it."""

    INFO = 0
    WARNING = 1
    ERROR = 2

    @property
    def label(self) -> str:
        return self.name.lower()


@dataclass(frozen=True, slots=True, kw_only=True)
class Finding:
    """One problem: its level, code, the type or pattern concerned, a message, suggestions."""

    level: Level
    code: str
    subject: str
    message: str
    suggestions: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, object]:
        return {
            "level": self.level.label,
            "code": self.code,
            "subject": self.subject,
            "message": self.message,
            "suggestions": list(self.suggestions),
        }

    def __str__(self) -> str:
        hint = f" (did you mean: {', '.join(self.suggestions)}?)" if self.suggestions else ""
        return f"{self.level.label}: {self.code}: {self.message}{hint}"


# --------------------------------------------------------------------------------------------
# Typo suggestions
# --------------------------------------------------------------------------------------------


def _closest(segment: str, entries: list[TypeEntry]) -> TypeEntry | None:
    """Return the sibling whose segment is closest to `segment`, if any is close enough."""
    by_fold = {ascii_fold(e.node.segment): e for e in entries}
    close = difflib.get_close_matches(ascii_fold(segment), by_fold, n=1, cutoff=_SEGMENT_CUTOFF)
    return by_fold[close[0]] if close else None


def _corrected(index: TypeIndex, text: str) -> str:
    """Replace each unknown segment of `text` by its closest sibling, down to the first `*`."""
    out: list[str] = []
    parent = ""
    segments = text.split(".")
    for i, segment in enumerate(segments):
        if "*" in segment:
            return ".".join(out + segments[i:])
        siblings = index.children(parent)
        entry = next(
            (e for e in siblings if ascii_fold(e.node.segment) == ascii_fold(segment)), None
        )
        entry = entry or _closest(segment, siblings)
        if entry is None:
            return ".".join(out + segments[i:])
        out.append(entry.node.segment)
        parent = entry.name
    return ".".join(out)


def nearest_names(index: TypeIndex, text: str, n: int = 3) -> list[str]:
    """Return up to `n` defined names (families as `Name.{param}`) closest to `text`."""
    names = {ascii_fold(e.name): e.display_name for e in index.entries}
    wanted = ascii_fold(text.replace("*", "")).strip(".")
    return [names[k] for k in difflib.get_close_matches(wanted, names, n=n, cutoff=_NAME_CUTOFF)]


def suggest(index: TypeIndex, text: str, *, pattern: bool) -> tuple[str, ...]:
    """Suggest corrections of a pattern (or type) that matches (or names) nothing defined."""
    fixed = _corrected(index, text)
    if ascii_fold(fixed) != ascii_fold(text):
        works = index.matched_by(fixed) if pattern else index.resolve(fixed) is not None
        if works:
            return (fixed,)
    return tuple(nearest_names(index, text))


# --------------------------------------------------------------------------------------------
# Checks
# --------------------------------------------------------------------------------------------


def _where(subs: list[tuple[str, str, str]]) -> str:
    """Describe (module, kind, whiteboard) users of a pattern in words."""
    parts = [f"{kind} of {module}" + (f" on {wb}" if wb else "") for module, kind, wb in subs]
    return ", ".join(dict.fromkeys(parts))


def _check_patterns(rel: Relations) -> Iterator[Finding]:
    users: dict[str, list[tuple[str, str, str]]] = {}
    for sub in rel.usage.subscriptions:
        users.setdefault(sub.pattern, []).append((sub.module, sub.kind, sub.whiteboard))
    for pattern, subs in users.items():
        if not rel.index.matched_by(pattern):
            yield Finding(
                level=Level.ERROR,
                code="unmatched-pattern",
                subject=pattern,
                message=f"pattern {pattern!r} ({_where(subs)}) matches no type in the ontology",
                suggestions=suggest(rel.index, pattern, pattern=True),
            )
        if not _portable(pattern):
            yield Finding(
                level=Level.INFO,
                code="non-portable-pattern",
                subject=pattern,
                message=f"pattern {pattern!r} is not exact, '*' or 'Prefix.*'; Psyclone 1.1.7 "
                "matches such patterns in surprising ways (spec appendix A)",
            )


def _portable(pattern: str) -> bool:
    stars = pattern.count("*")
    return stars == 0 or pattern == "*" or (stars == 1 and pattern.endswith(".*"))


def _check_differences(rel: Relations) -> Iterator[Finding]:
    universe = rel.universe()
    for pattern in rel.usage.patterns():
        diffs = rel.differences(pattern, universe)
        if diffs:
            yield Finding(
                level=Level.WARNING,
                code="psyclone-differs",
                subject=pattern,
                message=f"pattern {pattern!r}: " + "; ".join(_difference(d) for d in diffs),
            )


def _difference(d: Difference) -> str:
    if d.psyclone:
        return f"Psyclone 1.1.7 also matches {d.type} ({d.deviation}), OpenAIR 1.0 does not"
    return f"OpenAIR 1.0 matches {d.type}, Psyclone 1.1.7 does not ({d.deviation})"


def _posting_sources(rel: Relations) -> dict[str, list[str]]:
    """Map each posted type to phrases saying who posted it and where that is known from."""
    found: dict[str, list[str]] = {}
    for p in rel.usage.postings:
        origin = "psySpec" if p.source is Source.PSYSPEC else f"history, {p.count}x"
        where = f"{p.module or '?'}" + (f" to {p.whiteboard}" if p.whiteboard else "")
        found.setdefault(p.type, []).append(f"{where} ({origin})")
    return found


def _check_posted(rel: Relations) -> Iterator[Finding]:
    for type_, who in _posting_sources(rel).items():
        entry = rel.index.resolve(type_)
        posted_by = ", ".join(dict.fromkeys(who))
        if entry is None:
            yield Finding(
                level=Level.ERROR,
                code="undefined-type",
                subject=type_,
                message=f"type {type_!r} is posted by {posted_by} but not defined",
                suggestions=suggest(rel.index, type_, pattern=False),
            )
        elif entry.kind is not Kind.MESSAGE:
            yield Finding(
                level=Level.WARNING,
                code="kind-mismatch",
                subject=type_,
                message=f"type {type_!r} is posted by {posted_by} but defined as a "
                f"{entry.kind.value}, not a message type",
            )
    for bad, count in rel.usage.invalid_types:
        yield Finding(
            level=Level.ERROR,
            code="invalid-type",
            subject=bad,
            message=f"the history holds {count} message(s) of type {bad!r}, which is not a "
            "valid type (OA-TYPE-1; Psyclone 1.1.7 stores such posts, DEV-5)",
        )


def _check_streams(rel: Relations) -> Iterator[Finding]:
    for stream in rel.usage.streams:
        if not stream.type:
            continue
        entry = rel.index.resolve(stream.type)
        if entry is None:
            yield Finding(
                level=Level.ERROR,
                code="undefined-stream-type",
                subject=stream.type,
                message=f"stream {stream.name} on {stream.whiteboard} has type "
                f"{stream.type!r}, which is not defined",
                suggestions=suggest(rel.index, stream.type, pattern=False),
            )
        elif entry.kind is not Kind.STREAM:
            yield Finding(
                level=Level.WARNING,
                code="kind-mismatch",
                subject=stream.type,
                message=f"stream {stream.name} has type {stream.type!r}, defined as a "
                f"{entry.kind.value}, not a stream type",
            )


def _check_deprecated(rel: Relations) -> Iterator[Finding]:
    for entry in rel.index.entries:
        dep = entry.node.deprecated
        if dep is None:
            continue
        if dep.replaced_by and rel.index.get(dep.replaced_by) is None:
            yield Finding(
                level=Level.ERROR,
                code="dangling-replacement",
                subject=entry.name,
                message=f"type {entry.name!r} is replaced by {dep.replaced_by!r}, "
                "which is not defined",
                suggestions=suggest(rel.index, dep.replaced_by, pattern=False),
            )
        uses = _deprecated_uses(rel, entry)
        if uses:
            instead = f"; use {dep.replaced_by} instead" if dep.replaced_by else ""
            yield Finding(
                level=Level.WARNING,
                code="deprecated-in-use",
                subject=entry.name,
                message=f"deprecated type {entry.display_name!r} is still "
                f"{', '.join(uses)}{instead}",
            )


def _deprecated_uses(rel: Relations, entry: TypeEntry) -> list[str]:
    """Describe how the system still uses a deprecated type (empty when it does not)."""
    uses = [
        f"posted by {p.module} ({p.source.value})"
        for p in rel.postings(entry)
        if p.source is not Source.ONTOLOGY
    ]
    uses.extend(
        f"named by the {s.kind} {s.pattern!r} of {s.module}"
        for s in rel.usage.subscriptions
        if "*" not in s.pattern and rel.index.resolve(s.pattern) is entry
    )
    return list(dict.fromkeys(uses))


def _check_links(rel: Relations) -> Iterator[Finding]:
    if not rel.usage.has_psyspec:
        return
    known = {m.name for m in rel.usage.modules} | set(SYSTEM_COMPONENTS)  # spec 6.2
    for entry in rel.index.entries:
        for role, links in (("poster", entry.node.posters), ("subscriber", entry.node.subscribers)):
            for link in links:
                if link.module not in known:
                    yield Finding(
                        level=Level.WARNING,
                        code="unknown-module",
                        subject=entry.name,
                        message=f"type {entry.name!r} names {role} {link.module!r}, "
                        "which the psySpec does not declare",
                    )


def _check_unused(rel: Relations) -> Iterator[Finding]:
    if not (rel.usage.has_psyspec or rel.usage.has_history):
        return  # nothing to compare with
    for entry in rel.index.concrete():
        if not rel.used(entry):
            yield Finding(
                level=Level.INFO,
                code="unused-type",
                subject=entry.name,
                message=f"type {entry.display_name!r} is defined but nobody posts, "
                "observes or subscribes to it",
            )


_CHECKS = (
    _check_patterns,
    _check_posted,
    _check_streams,
    _check_deprecated,
    _check_differences,
    _check_links,
    _check_unused,
)


def lint(index: TypeIndex, usage: Usage) -> list[Finding]:
    """Return every finding, most serious first (stable within a level)."""
    rel = Relations(index, usage)
    findings = [f for check in _CHECKS for f in check(rel)]
    return sorted(findings, key=lambda f: -f.level)
