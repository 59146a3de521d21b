"""The type pages of the docs site: one page per type, readable by someone new to the system.

A message or stream type's page shows, in order: where it sits in the tree, whether it is
deprecated (and what replaces it), its description, full name, namespace and content, who posts
it, who is woken by it or reads it and through which pattern, the patterns one could use, where
Psyclone 1.1.7 would deliver it differently, its streams, what a history saw, its examples
(with the message as it travels on the wire) and its subtypes. A group's page shows its
description, the patterns that select types below it, and its subtypes.
"""

from __future__ import annotations

from dataclasses import dataclass

from lxml import etree

from openair.protocol.codec import encode_message
from openair.protocol.errors import OpenAIRError
from openair.protocol.matching import matches, psyclone_matches
from openair.protocol.message import Message
from openair.protocol.xmlsafe import parse_xml
from openair_ontology.diagram import DiagramResult
from openair_ontology.lint import Finding
from openair_ontology.model import Example, TypeEntry, TypeIndex
from openair_ontology.parse import indent_xml
from openair_ontology.paths import Paths
from openair_ontology.relations import Relations, deviation, subtree_patterns
from openair_ontology.templating import render
from openair_ontology.usage import Source, iso_time

__all__ = ["DocContext", "pretty_content", "type_page"]

EXAMPLE_ID = "00000000-0000-4000-8000-000000000000"  # a fixed id keeps the site reproducible


@dataclass(frozen=True, slots=True, kw_only=True)
class DocContext:
    """Everything the pages are made from."""

    index: TypeIndex
    rel: Relations
    paths: Paths
    findings: tuple[Finding, ...] = ()
    diagram: DiagramResult | None = None

    @property
    def title(self) -> str:
        return self.index.ontology.name or "Ontology"

    def type_href(self, root: str, name: str) -> str | None:
        """Return the link to the page of the entry defining `name`, if there is one."""
        entry = self.index.get(name) or self.index.resolve(name)
        return None if entry is None else root + self.paths.type(entry.name)


def _kind_words(entry: TypeEntry) -> str:
    words = {
        "message": "message type: messages of this type are posted to whiteboards",
        "stream": "stream type: names a typed stream of data samples (spec 11.7)",
        "group": "group: only groups the types below it; nobody posts it",
    }
    return words[entry.kind.value]


@dataclass(frozen=True, slots=True, kw_only=True)
class _Posting:
    module: str
    type: str | None  # None: the page's own type
    board: str
    origins: str


def _posters(ctx: DocContext, entry: TypeEntry) -> list[_Posting]:
    """One row per (module, type, whiteboard), saying every source that knows of it."""
    grouped: dict[tuple[str, str, str], list[str]] = {}
    for p in ctx.rel.postings(entry):
        origin = {
            Source.PSYSPEC: "psySpec",
            Source.HISTORY: f"history ({p.count}×)",
            Source.ONTOLOGY: "ontology",
        }[p.source]
        grouped.setdefault((p.module, p.type, p.whiteboard), []).append(origin)
    return [
        _Posting(
            module=module,
            type=None if type_ == entry.name else type_,
            board=board,
            origins=", ".join(dict.fromkeys(origins)),
        )
        for (module, type_, board), origins in grouped.items()
    ]


def _patterns(ctx: DocContext, entry: TypeEntry) -> list[tuple[str, str, str]]:
    """The system's patterns that match the type, with Psyclone 1.1.7's answer beside them."""
    rows = []
    for pattern in dict.fromkeys(s.pattern for s in ctx.rel.subscriptions(entry)):
        users = sorted({s.module for s in ctx.rel.usage.subscriptions if s.pattern == pattern})
        verdict = "matches too"
        if entry.is_concrete and not entry.is_family and not psyclone_matches(pattern, entry.name):
            verdict = f"does not match ({deviation(pattern, entry.name)})"
        rows.append((pattern, ", ".join(users), verdict))
    return rows


def _pattern_options(entry: TypeEntry) -> list[str]:
    """Patterns one could use for the type, most specific first."""
    if not entry.is_concrete:
        return []
    return ([] if entry.is_family else [entry.name]) + subtree_patterns(entry.name)


def _psyclone_only(ctx: DocContext, entry: TypeEntry) -> list[tuple[str, str, str]]:
    """Patterns that Psyclone 1.1.7 would match against this type but OpenAIR 1.0 does not."""
    if not entry.is_concrete or entry.is_family:
        return []
    return [
        (sub.pattern, sub.module, deviation(sub.pattern, entry.name))
        for sub in ctx.rel.usage.subscriptions
        if psyclone_matches(sub.pattern, entry.name) and not matches(sub.pattern, entry.name)
    ]


def pretty_content(content: str, is_xml: bool) -> str:
    """Return content for reading: XML re-indented, text as it is."""
    if not is_xml:
        return content
    try:
        return indent_xml(content)
    except OpenAIRError:
        return content


def _wire(example: Example, type_name: str) -> str:
    """Return the example as a canonical OpenAIR message (OA-MSG-4), indented for reading."""
    msg = Message(
        type=type_name,
        id=EXAMPLE_ID,
        sender=example.sender,
        to=example.to,
        language=example.language,
        content=example.content,
        content_is_xml=example.is_xml,
    )
    try:
        root = parse_xml(encode_message(msg))
    except (OpenAIRError, ValueError):
        return ""
    etree.indent(root, space="  ")
    return etree.tostring(root, encoding="unicode")


@dataclass(frozen=True, slots=True, kw_only=True)
class _Card:
    """One example as the page shows it: its envelope, readable content and wire form."""

    title: str
    envelope: tuple[tuple[str, str], ...]
    content: str
    wire: str


def _example_card(example: Example, type_name: str) -> _Card:
    envelope = (
        ("type", type_name),
        ("from", example.sender or "—"),
        ("to", example.to or "—"),
        ("language", example.language or "(none)"),
    )
    return _Card(
        title=example.title,
        envelope=envelope,
        content=pretty_content(example.content, example.is_xml),
        wire=_wire(example, type_name),
    )


def _examples(ctx: DocContext, entry: TypeEntry) -> list[_Card]:
    name = entry.display_name
    cards = [_example_card(x, name) for x in entry.node.examples]
    for obs in ctx.rel.observations(entry)[:3]:
        msg = obs.example
        if msg is not None:
            when = msg.received or msg.posted
            seen = Example(
                title=f"Seen in the history ({iso_time(when) if when else 'time unknown'})",
                sender=msg.sender,
                to=msg.stored or msg.to,
                language=msg.language,
                content=msg.content,
                is_xml=msg.content_is_xml,
            )
            cards.append(_example_card(seen, obs.type))
    return cards


def _namespace_owner(ctx: DocContext, entry: TypeEntry) -> str:
    ns = ctx.index.namespace_of(entry.name)
    if ns is None:
        return ""
    return ", ".join(x for x in (ns.owner, f"version {ns.version}" if ns.version else "") if x)


def type_page(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    """Return the whole page of `entry` (`root` leads from the page to the site's root)."""
    return render(
        "type.html",
        title=entry.display_name,
        site_title=ctx.title,
        root=root,
        current=entry.name,
        tree=None,
        paths=ctx.paths,
        type_href=lambda name: ctx.type_href(root, name),
        iso_time=iso_time,
        entry=entry,
        ancestors=ctx.index.ancestors(entry),
        kind_words=_kind_words(entry),
        namespace=ctx.index.namespace_of(entry.name),
        namespace_owner=_namespace_owner(ctx, entry),
        posters=_posters(ctx, entry),
        subscribers=ctx.rel.subscribers(entry),
        patterns=_patterns(ctx, entry),
        options=_pattern_options(entry),
        psyclone=_psyclone_only(ctx, entry),
        streams=ctx.rel.streams(entry),
        observed=ctx.rel.observations(entry),
        recorded=entry.node.observed,
        examples=_examples(ctx, entry),
        subtypes=ctx.index.children(entry.name),
    )
