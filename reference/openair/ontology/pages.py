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

from openair.codec import encode_message
from openair.errors import OpenAIRError
from openair.matching import matches, psyclone_matches
from openair.message import Message
from openair.ontology.diagram import DiagramResult
from openair.ontology.htmlparts import badge, esc, first_sentence, link, paragraphs, table
from openair.ontology.lint import Finding
from openair.ontology.model import Example, TypeEntry, TypeIndex
from openair.ontology.parse import indent_xml
from openair.ontology.paths import Paths
from openair.ontology.relations import Relations, deviation, subtree_patterns
from openair.ontology.usage import Source, iso_time
from openair.xmlsafe import parse_xml

__all__ = ["DocContext", "pretty_content", "type_page_body"]

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

    def type_link(self, root: str, name: str) -> str:
        """Return `name` as code, linked to its type's page when the ontology defines it."""
        href = self.type_href(root, name)
        code = f"<code>{esc(name)}</code>"
        return code if href is None else f'<a href="{esc(href)}">{code}</a>'

    def module_link(self, root: str, name: str) -> str:
        return link(root + self.paths.module(name), name) if name else "?"

    def board_link(self, root: str, name: str) -> str:
        return link(root + self.paths.whiteboard(name), name) if name else "any whiteboard"


def _section(section_id: str, title: str, inner_html: str, intro: str = "") -> str:
    """Return a titled section, or "" when it has nothing to show."""
    if not inner_html:
        return ""
    intro_html = f'<p class="intro">{esc(intro)}</p>' if intro else ""
    return f'<section id="{section_id}"><h2>{esc(title)}</h2>{intro_html}{inner_html}</section>'


def _breadcrumb(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    crumbs = [link(root + ctx.paths.index, "Overview")]
    crumbs.extend(
        link(root + ctx.paths.type(a.name), a.node.segment) for a in ctx.index.ancestors(entry)
    )
    crumbs.append(f'<span aria-current="page">{esc(entry.node.segment)}</span>')
    return f'<nav class="breadcrumb" aria-label="Breadcrumb">{" › ".join(crumbs)}</nav>'


def _heading(entry: TypeEntry) -> str:
    return (
        f'<h1><span class="segment">{esc(entry.node.segment)}</span> {badge(entry)}</h1>'
        f'<p class="fullname-line">Full name: <code id="fullname" class="fullname">'
        f"{esc(entry.display_name)}</code></p>"
    )


def _deprecation(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    dep = entry.node.deprecated
    if dep is None:
        return ""
    since = f" since version {esc(dep.since)}" if dep.since else ""
    reason = f" {esc(dep.reason)}" if dep.reason else ""
    instead = ""
    if dep.replaced_by:
        instead = f" Use {ctx.type_link(root, dep.replaced_by)} instead."
    return (
        f'<div class="deprecated-banner" role="note"><strong>Deprecated{since}.</strong>'
        f"{reason}{instead}</div>"
    )


def _facts(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    rows: list[tuple[str, str]] = [("Kind", esc(_kind_words(entry)))]
    ns = ctx.index.namespace_of(entry.name)
    if ns is not None:
        owner = ", ".join(x for x in (ns.owner, f"version {ns.version}" if ns.version else "") if x)
        rows.append(("Namespace", f"<code>{esc(ns.prefix)}</code> — {esc(owner)}"))
    if entry.is_family:
        sample = f"{entry.name}{entry.node.separator}…"
        rows.append(
            (
                "Parameter",
                f"<code>{{{esc(entry.node.parameter)}}}</code>: the types are "
                f"<code>{esc(sample)}</code> with a {esc(entry.node.parameter)} name in place of …",
            )
        )
    content = entry.node.content
    if content is not None:
        rows.append(("Content", _content_words(content.language, content.root, content.schema)))
        if content.description:
            rows.append(("What it holds", esc(content.description)))
    cells = "".join(f"<dt>{esc(k)}</dt><dd>{v}</dd>" for k, v in rows)
    return f'<dl class="facts">{cells}</dl>'


def _kind_words(entry: TypeEntry) -> str:
    words = {
        "message": "message type: messages of this type are posted to whiteboards",
        "stream": "stream type: names a typed stream of data samples (spec 11.7)",
        "group": "group: only groups the types below it; nobody posts it",
    }
    return words[entry.kind.value]


def _content_words(language: str, root_el: str, schema: str) -> str:
    parts = [f"language <code>{esc(language)}</code>" if language else "no content language"]
    if root_el:
        parts.append(f"root element <code>&lt;{esc(root_el)}&gt;</code>")
    if schema:
        parts.append(f"schema <code>{esc(schema)}</code>")
    return ", ".join(parts)


def _posters(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    """One row per (module, type, whiteboard), saying every source that knows of it."""
    grouped: dict[tuple[str, str, str], list[str]] = {}
    for p in ctx.rel.postings(entry):
        origin = {
            Source.PSYSPEC: "psySpec",
            Source.HISTORY: f"history ({p.count}×)",
            Source.ONTOLOGY: "ontology",
        }[p.source]
        grouped.setdefault((p.module, p.type, p.whiteboard), []).append(origin)
    rows = []
    for (module, type_, board), origins in grouped.items():
        shown = "" if type_ == entry.name else f" as {ctx.type_link(root, type_)}"
        rows.append(
            [
                ctx.module_link(root, module) + shown,
                ctx.board_link(root, board),
                esc(", ".join(dict.fromkeys(origins))),
            ]
        )
    return table(("Module", "Whiteboard", "Known from"), rows) if rows else ""


def _subscribers(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    rows = []
    for module, board, kind, pattern in ctx.rel.subscribers(entry):
        via_html = esc(kind) + (f" <code>{esc(pattern)}</code>" if pattern else "")
        rows.append([ctx.module_link(root, module), ctx.board_link(root, board), via_html])
    return table(("Module", "Whiteboard", "Through"), rows) if rows else ""


def _patterns(ctx: DocContext, entry: TypeEntry) -> str:
    """The system's patterns that match the type, with Psyclone 1.1.7's answer beside them."""
    rows = []
    for pattern in dict.fromkeys(s.pattern for s in ctx.rel.subscriptions(entry)):
        users = sorted({s.module for s in ctx.rel.usage.subscriptions if s.pattern == pattern})
        verdict = "matches too"
        if entry.is_concrete and not entry.is_family and not psyclone_matches(pattern, entry.name):
            verdict = f"does not match ({deviation(pattern, entry.name)})"
        rows.append([f"<code>{esc(pattern)}</code>", esc(", ".join(users)), esc(verdict)])
    in_system = (
        table(("Pattern", "Used by", "Psyclone 1.1.7"), rows, cls="patterns") if rows else ""
    )
    if not entry.is_concrete:
        return in_system
    name = entry.display_name if entry.is_family else entry.name
    options = ([] if entry.is_family else [name]) + subtree_patterns(entry.name)
    items = "".join(f"<li><code>{esc(p)}</code></li>" for p in options)
    yours = (
        '<p class="intro">Patterns that match this type, most specific first '
        "(OpenAIR 1.0 matching, ASCII case ignored):</p>"
        f'<ul class="pattern-options">{items}</ul>'
    )
    return in_system + yours


def _psyclone_only(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    """Patterns that Psyclone 1.1.7 would match against this type but OpenAIR 1.0 does not."""
    if not entry.is_concrete or entry.is_family:
        return ""
    rows = []
    for sub in ctx.rel.usage.subscriptions:
        if psyclone_matches(sub.pattern, entry.name) and not matches(sub.pattern, entry.name):
            rows.append(
                [
                    f"<code>{esc(sub.pattern)}</code>",
                    ctx.module_link(root, sub.module),
                    esc(deviation(sub.pattern, entry.name)),
                ]
            )
    return table(("Pattern", "Module", "Deviation"), rows) if rows else ""


def _streams(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    rows = [
        [
            esc(s.name),
            ctx.board_link(root, s.whiteboard),
            ", ".join(ctx.module_link(root, m) for m in s.writers) or "—",
            ", ".join(ctx.module_link(root, m) for m in s.readers) or "—",
        ]
        for s in ctx.rel.streams(entry)
    ]
    return table(("Stream", "Whiteboard", "Written by", "Read by"), rows) if rows else ""


def _observed(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    rows = []
    for obs in ctx.rel.observations(entry):
        posters = ", ".join(
            f"{ctx.module_link(root, m)} → {esc(wb or '?')} ({n}×)" for m, wb, n in obs.posters
        )
        rows.append(
            [
                f"<code>{esc(obs.type)}</code>",
                str(obs.count),
                esc(iso_time(obs.first)) if obs.first else "—",
                esc(iso_time(obs.last)) if obs.last else "—",
                posters,
            ]
        )
    recorded = entry.node.observed
    if recorded is not None:
        rows.append(
            [
                "(recorded in the ontology)",
                str(recorded.count),
                esc(recorded.first or "—"),
                esc(recorded.last or "—"),
                esc(" ".join(recorded.whiteboards)),
            ]
        )
    headers = ("Type", "Messages", "First", "Last", "Posted by")
    return table(headers, rows) if rows else ""


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


def _example_card(example: Example, type_name: str) -> str:
    caption = f"<figcaption>{esc(example.title)}</figcaption>" if example.title else ""
    rows = [
        ("type", type_name),
        ("from", example.sender or "—"),
        ("to", example.to or "—"),
        ("language", example.language or "(none)"),
    ]
    envelope = "".join(f"<tr><th>{k}</th><td><code>{esc(v)}</code></td></tr>" for k, v in rows)
    content = pretty_content(example.content, example.is_xml)
    body = (
        f'<pre class="content"><code>{esc(content)}</code></pre>'
        if content
        else '<p class="muted">No content.</p>'
    )
    wire = _wire(example, type_name)
    wire_html = (
        f"<details><summary>As it travels on the wire</summary><pre><code>{esc(wire)}</code>"
        "</pre></details>"
        if wire
        else ""
    )
    return (
        f'<figure class="example">{caption}<table class="envelope">{envelope}</table>'
        f"{body}{wire_html}</figure>"
    )


def _examples(ctx: DocContext, entry: TypeEntry) -> str:
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
    return "".join(cards)


def _subtypes(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    rows = [
        [
            link(root + ctx.paths.type(c.name), c.display_name) + " " + badge(c),
            esc(first_sentence(c.node.description)),
        ]
        for c in ctx.index.children(entry.name)
    ]
    return table(("Type", "Description"), rows) if rows else ""


def type_page_body(ctx: DocContext, entry: TypeEntry, root: str) -> str:
    """Return the main content of the page of `entry`."""

    def to_type(name: str) -> str | None:
        return ctx.type_href(root, name)

    concrete = entry.is_concrete
    parts = [
        _breadcrumb(ctx, entry, root),
        _heading(entry),
        _deprecation(ctx, entry, root),
        paragraphs(entry.node.description, to_type, empty="No description yet."),
        _facts(ctx, entry, root),
        _section("posters", "Who posts it", _posters(ctx, entry, root)) if concrete else "",
        _section("subscribers", "Who receives it", _subscribers(ctx, entry, root)),
        _section(
            "patterns",
            "Patterns that match it" if concrete else "Patterns that select types in this group",
            _patterns(ctx, entry),
        ),
        _section(
            "psyclone",
            "Psyclone 1.1.7 would also deliver it",
            _psyclone_only(ctx, entry, root),
            "These patterns do not match under OpenAIR 1.0, but the old Psyclone matcher "
            "would wake their modules with this type (spec appendix A).",
        ),
        _section("streams", "Streams of this type", _streams(ctx, entry, root)),
        _section("observed", "Seen in the recorded history", _observed(ctx, entry, root)),
        _section("examples", "Examples", _examples(ctx, entry)),
        _section("subtypes", "Types below it", _subtypes(ctx, entry, root)),
    ]
    return "\n".join(p for p in parts if p)
