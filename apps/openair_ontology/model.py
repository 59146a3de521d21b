"""The ontology as values: namespaces and a tree of type nodes, and an index over full names.

A `TypeNode` is one segment; the full dotted name of a node is the segments from its root down,
joined by dots (spec 5.1). `TypeIndex` flattens the tree into `TypeEntry` values in document
order and answers the questions the docs and the linter ask: which entry defines a type, which
entries a pattern matches (with the spec matcher, OA-MATCH-1..6), which namespace owns a name.

A node with a `parameter` stands for a family of types (`Psyclone.Module.Lost.{module}`): every
type that is the node's full name, its separator and a non-empty value. Whether a pattern can
match some member of a family is decided on a few witness members built from the pattern.
"""

from __future__ import annotations

import enum
from collections.abc import Iterator
from dataclasses import dataclass

from openair.protocol.matching import ascii_fold, matches
from openair.protocol.types import is_valid_type

__all__ = [
    "ContentSpec",
    "Deprecation",
    "Example",
    "Kind",
    "Link",
    "Namespace",
    "Observed",
    "Ontology",
    "TypeEntry",
    "TypeIndex",
    "TypeNode",
    "entry_matches",
]


class Kind(enum.Enum):
    """What a type node stands for (schemas/ontology.xsd `OntologyKindType`)."""

    MESSAGE = "message"
    STREAM = "stream"
    GROUP = "group"


@dataclass(frozen=True, slots=True, kw_only=True)
class Namespace:
    """A dotted prefix, who owns the names under it, and what it is for."""

    prefix: str
    owner: str = ""
    version: str = ""
    url: str = ""
    description: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class ContentSpec:
    """The content a type carries: its language, XML root element, schema, and a description."""

    language: str = ""
    root: str = ""
    schema: str = ""
    description: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class Deprecation:
    """Why a type is deprecated, since when, and the type that replaces it ("" if none)."""

    replaced_by: str = ""
    since: str = ""
    reason: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class Example:
    """An example message: poster, whiteboard, and its content (text, or XML when `is_xml`)."""

    title: str = ""
    sender: str = ""
    to: str = ""
    language: str = ""
    content: str = ""
    is_xml: bool = False


@dataclass(frozen=True, slots=True, kw_only=True)
class Link:
    """A module that posts or subscribes to a type, on one whiteboard ("" = any)."""

    module: str
    whiteboard: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class Observed:
    """What a recorded history showed: a count, first/last times (xs:dateTime), whiteboards."""

    count: int
    first: str = ""
    last: str = ""
    whiteboards: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True, kw_only=True)
class TypeNode:
    """One segment of the type tree and what the ontology says about the type it ends."""

    segment: str
    kind: Kind | None = None  # None: GROUP with children, MESSAGE without
    description: str = ""
    content: ContentSpec | None = None
    deprecated: Deprecation | None = None
    examples: tuple[Example, ...] = ()
    posters: tuple[Link, ...] = ()
    subscribers: tuple[Link, ...] = ()
    observed: Observed | None = None
    parameter: str = ""
    separator: str = "."
    children: tuple[TypeNode, ...] = ()

    @property
    def effective_kind(self) -> Kind:
        """The kind, defaulted: a group when the node has children, else a message type."""
        if self.kind is not None:
            return self.kind
        return Kind.GROUP if self.children else Kind.MESSAGE


@dataclass(frozen=True, slots=True, kw_only=True)
class Ontology:
    """A whole ontology file."""

    name: str
    version: str = ""
    description: str = ""
    namespaces: tuple[Namespace, ...] = ()
    types: tuple[TypeNode, ...] = ()


@dataclass(frozen=True, slots=True, kw_only=True)
class TypeEntry:
    """One node of the tree with its full dotted name, its parent's name and its depth."""

    name: str
    node: TypeNode
    parent: str = ""
    depth: int = 0

    @property
    def kind(self) -> Kind:
        return self.node.effective_kind

    @property
    def is_family(self) -> bool:
        """Whether the entry stands for the family `name` + separator + value."""
        return bool(self.node.parameter)

    @property
    def display_name(self) -> str:
        """The name as people read it: `Psyclone.Module.Lost.{module}` for a family."""
        if not self.is_family:
            return self.name
        return f"{self.name}{self.node.separator}{{{self.node.parameter}}}"

    @property
    def is_concrete(self) -> bool:
        """Whether messages (or streams) carry this type: not a group."""
        return self.kind is not Kind.GROUP

    @property
    def deprecated(self) -> bool:
        return self.node.deprecated is not None


def _family_prefix(entry: TypeEntry) -> str:
    return ascii_fold(entry.name + entry.node.separator)


def _witnesses(pattern: str, prefix: str) -> Iterator[str]:
    """Yield candidate family members that `pattern` may match (folded text)."""
    if "*" not in pattern:
        yield pattern
        return
    parts = pattern.split("*")
    rest = "".join(parts[1:])
    yield "".join(parts)  # every `*` empty
    yield parts[0] + "x" + rest  # the first `*` takes one character
    if prefix.startswith(parts[0]):
        yield prefix + "x" + rest  # the first `*` takes the rest of the prefix and more
    yield "".join(parts[:-1]) + "x" + parts[-1]


def entry_matches(pattern: str, entry: TypeEntry) -> bool:
    """Return whether `pattern` matches the entry's type, or some member of its family.

    Groups match nothing: they are not posted. For a family the answer is decided on witness
    members built from the pattern (exact for patterns without `*` and for the usual shapes).
    """
    if not entry.is_concrete:
        return False
    if not entry.is_family:
        return matches(pattern, entry.name)
    prefix = _family_prefix(entry)
    folded = ascii_fold(pattern)
    return any(
        len(w) > len(prefix) and w.startswith(prefix) and is_valid_type(w) and matches(folded, w)
        for w in _witnesses(folded, prefix)
    )


class TypeIndex:
    """The entries of an ontology by full name (ASCII case ignored, OA-MATCH-1)."""

    def __init__(self, ontology: Ontology) -> None:
        self.ontology = ontology
        self.entries: tuple[TypeEntry, ...] = tuple(_flatten(ontology.types, "", 0))
        self._by_name = {ascii_fold(e.name): e for e in self.entries}
        self._families = sorted(
            (e for e in self.entries if e.is_family),
            key=lambda e: len(e.name),
            reverse=True,
        )
        self._children: dict[str, list[TypeEntry]] = {}
        for entry in self.entries:
            self._children.setdefault(ascii_fold(entry.parent), []).append(entry)

    def __len__(self) -> int:
        return len(self.entries)

    def __repr__(self) -> str:
        return f"<TypeIndex of {self.ontology.name!r}: {len(self.entries)} entries>"

    def get(self, name: str) -> TypeEntry | None:
        """Return the entry whose full name is `name`, if the ontology defines it."""
        return self._by_name.get(ascii_fold(name))

    def resolve(self, type_: str) -> TypeEntry | None:
        """Return the entry that defines the concrete type `type_`: its own, or its family's."""
        entry = self.get(type_)
        if entry is not None and not entry.is_family:  # a family's own name is no member
            return entry
        folded = ascii_fold(type_)
        for family in self._families:
            prefix = _family_prefix(family)
            if folded.startswith(prefix) and len(folded) > len(prefix):
                return family
        return None

    def children(self, name: str) -> list[TypeEntry]:
        """Return the entries directly below `name` ("" for the roots), in document order."""
        return list(self._children.get(ascii_fold(name), ()))

    def ancestors(self, entry: TypeEntry) -> list[TypeEntry]:
        """Return the entries above `entry`, root first."""
        found: list[TypeEntry] = []
        parent = self.get(entry.parent) if entry.parent else None
        while parent is not None:
            found.append(parent)
            parent = self.get(parent.parent) if parent.parent else None
        return found[::-1]

    def subtree(self, entry: TypeEntry) -> list[TypeEntry]:
        """Return `entry` and every entry below it, in document order."""
        start = self.entries.index(entry)
        found = [entry]
        for other in self.entries[start + 1 :]:
            if other.depth <= entry.depth:
                break
            found.append(other)
        return found

    def concrete(self) -> list[TypeEntry]:
        """Return the message and stream types (not the groups), in document order."""
        return [e for e in self.entries if e.is_concrete]

    def matched_by(self, pattern: str) -> list[TypeEntry]:
        """Return the concrete entries that `pattern` matches (families by witness)."""
        return [e for e in self.entries if entry_matches(pattern, e)]

    def namespace_of(self, name: str) -> Namespace | None:
        """Return the namespace with the longest prefix that owns `name`, if any."""
        folded = ascii_fold(name)
        best: Namespace | None = None
        for ns in self.ontology.namespaces:
            prefix = ascii_fold(ns.prefix)
            owns = folded == prefix or folded.startswith(prefix + ".")
            if owns and (best is None or len(ns.prefix) > len(best.prefix)):
                best = ns
        return best


def _flatten(nodes: tuple[TypeNode, ...], parent: str, depth: int) -> Iterator[TypeEntry]:
    """Yield the entries of `nodes` and their descendants, depth first, in document order."""
    for node in nodes:
        name = f"{parent}.{node.segment}" if parent else node.segment
        yield TypeEntry(name=name, node=node, parent=parent, depth=depth)
        yield from _flatten(node.children, name, depth + 1)
