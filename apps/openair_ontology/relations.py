"""The ontology joined with a system's usage: who posts and subscribes to each defined type.

`Relations` answers, for one defined type, which subscription patterns match it (the spec
matcher, OA-MATCH-1..6, with OA-MATCH-8: triggers and retrieves alike), who posts it (from the
psySpec, a history, and the ontology's own `<poster>` links), which streams carry it, and what a
history observed. It also answers, for one pattern, where Psyclone 1.1.7 would decide otherwise
(`openair.protocol.matching.psyclone_matches`, appendix A, DEV-1 to DEV-4).
"""

from __future__ import annotations

from dataclasses import dataclass

from openair.protocol.matching import ascii_fold, matches, psyclone_matches
from openair.protocol.types import is_valid_type
from openair_ontology.model import TypeEntry, TypeIndex
from openair_ontology.usage import Observation, Posting, Source, StreamDecl, Subscription, Usage

__all__ = [
    "Difference",
    "Relations",
    "deviation",
    "subtree_patterns",
]


@dataclass(frozen=True, slots=True, kw_only=True)
class Difference:
    """A type that a pattern matches under one matcher and not under the other."""

    pattern: str
    type: str
    openair: bool  # the spec matcher's answer
    psyclone: bool  # the Psyclone 1.1.7 model's answer
    deviation: str  # "DEV-1" … "DEV-4" (spec appendix A)


def deviation(pattern: str, type_: str) -> str:
    """Name the appendix A deviation behind a disagreement of the two matchers."""
    p, t = ascii_fold(pattern), ascii_fold(type_)
    if matches(p, t):
        return "DEV-4"  # the suffix occurs earlier in the type
    head = p[: p.index("*")] if "*" in p else p
    if len(t) <= len(head) and head.startswith(t):
        return "DEV-1"  # the type is a prefix of the text before the first `*`
    if p.startswith("*"):
        return "DEV-2"
    return "DEV-3"  # prefix and suffix overlap


def subtree_patterns(name: str) -> list[str]:
    """Return the `Prefix.*` patterns that match `name`, most specific first, then `*`."""
    segments = name.split(".")
    found = [".".join(segments[:i]) + ".*" for i in range(len(segments), 0, -1)]
    return [*found, "*"]


class Relations:
    """Answers about defined types given the usage of one system."""

    def __init__(self, index: TypeIndex, usage: Usage) -> None:
        self.index = index
        self.usage = usage
        self._matched: dict[str, frozenset[str]] = {}
        # Resolve each posted and observed type once: pages ask about every entry.
        self._posted: dict[str, list[Posting]] = {}
        for posting in usage.postings:
            entry = index.resolve(posting.type)
            if entry is not None:
                self._posted.setdefault(entry.name, []).append(posting)
        self._observed: dict[str, list[Observation]] = {}
        for obs in usage.observations:
            entry = index.resolve(obs.type)
            if entry is not None:
                self._observed.setdefault(entry.name, []).append(obs)

    def __repr__(self) -> str:
        return f"<Relations: {len(self.index)} types, {len(self.usage.subscriptions)} patterns>"

    def matched(self, pattern: str) -> frozenset[str]:
        """Return the names of the concrete entries `pattern` matches (computed once each)."""
        found = self._matched.get(pattern)
        if found is None:
            found = self._matched[pattern] = frozenset(
                e.name for e in self.index.matched_by(pattern)
            )
        return found

    def subscriptions(self, entry: TypeEntry) -> list[Subscription]:
        """Return the triggers and retrieves whose pattern matches the entry's type(s); for a
        group, those that match some type below it."""
        if entry.is_concrete:
            names = {entry.name}
        else:
            names = {e.name for e in self.index.subtree(entry) if e.is_concrete}
        return [s for s in self.usage.subscriptions if names & self.matched(s.pattern)]

    def subscribers(self, entry: TypeEntry) -> list[tuple[str, str, str, str]]:
        """Return (module, whiteboard, kind, pattern) for each module woken by or reading the
        type; kind is `trigger`, `retrieve` or `ontology` (a `<subscriber>` link, no pattern)."""
        found: dict[tuple[str, str], tuple[str, str]] = {}
        for sub in self.subscriptions(entry):
            found.setdefault((sub.module, sub.whiteboard), (sub.kind, sub.pattern))
        for link in entry.node.subscribers:
            found.setdefault((link.module, link.whiteboard), ("ontology", ""))
        return [(module, wb, kind, pattern) for (module, wb), (kind, pattern) in found.items()]

    def postings(self, entry: TypeEntry) -> list[Posting]:
        """Return who posts the type: psySpec posts, history posters, ontology links."""
        found = list(self._posted.get(entry.name, ()))
        found.extend(
            Posting(
                module=link.module,
                type=entry.name,
                whiteboard=link.whiteboard,
                source=Source.ONTOLOGY,
            )
            for link in entry.node.posters
        )
        return found

    def observations(self, entry: TypeEntry) -> list[Observation]:
        """Return the history's observations of the type (several for a family)."""
        return list(self._observed.get(entry.name, ()))

    def streams(self, entry: TypeEntry) -> list[StreamDecl]:
        """Return the declared streams whose type is this entry (OA-XSTREAM-1)."""
        return [s for s in self.usage.streams if s.type and self.index.resolve(s.type) is entry]

    def universe(self) -> list[str]:
        """Return the concrete types to compare matchers on: defined, posted and observed."""
        names = [e.name for e in self.index.concrete() if not e.is_family]
        names.extend(self.usage.posted_types())
        names.extend(s.type for s in self.usage.streams if s.type)
        unique = {ascii_fold(n): n for n in reversed(names) if is_valid_type(n)}
        return list(reversed(unique.values()))

    def differences(self, pattern: str, universe: list[str] | None = None) -> list[Difference]:
        """Return the types of the universe on which Psyclone 1.1.7 decides `pattern` otherwise."""
        found: list[Difference] = []
        for type_ in self.universe() if universe is None else universe:
            ours, theirs = matches(pattern, type_), psyclone_matches(pattern, type_)
            if ours != theirs:
                found.append(
                    Difference(
                        pattern=pattern,
                        type=type_,
                        openair=ours,
                        psyclone=theirs,
                        deviation=deviation(pattern, type_),
                    )
                )
        return found

    def used(self, entry: TypeEntry) -> bool:
        """Whether the system uses the type: posted, observed, a stream's type, or subscribed to
        by a pattern other than the catch-all `*` (which would make every type look used)."""
        if entry.name in self._posted:
            return True
        if self.observations(entry) or self.streams(entry):
            return True
        return any(
            s.pattern != "*" and entry.name in self.matched(s.pattern)
            for s in self.usage.subscriptions
        )
