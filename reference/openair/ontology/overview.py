"""The overview page (index) and the module pages of the docs site.

The overview is where a newcomer starts: what the system is, how to read a type name and a
pattern, the diagram of modules, whiteboards and types, the namespaces, the whiteboards with
the types posted to each, the modules, the top of the type tree, and the consistency checks.
"""

from __future__ import annotations

from openair.ontology.htmlparts import esc, first_sentence, link, paragraphs, table
from openair.ontology.lint import Finding, Level
from openair.ontology.model import Kind
from openair.ontology.pages import DocContext
from openair.ontology.usage import Source, Subscription
from openair.server.config import SYSTEM_COMPONENTS

__all__ = ["index_body", "module_names", "module_page_body"]

_MAX_MATCHED = 8

_GUIDE = """
<section id="reading" class="guide">
<h2>How to read this</h2>
<ul>
<li>Modules never call each other. A module <strong>posts</strong> a message of some
<strong>type</strong> to a <strong>whiteboard</strong>; the whiteboard wakes every module whose
<strong>trigger</strong> pattern matches the type. The types are therefore the modules' APIs.</li>
<li>A type is a dot-delimited name, most general part first:
<code>Input.Perc.UniM.Hear.Voice.Speak.Sentence</code> reads “input, perception, unimodal,
hearing, voice, speaking, a sentence”. The tree on the left follows those parts.</li>
<li>In a pattern, <code>*</code> stands for any run of characters, dots included:
<code>Input.Perc.*</code> matches every type below <code>Input.Perc</code> and
<code>Input.Perc</code> itself. Case is ignored.</li>
<li>Type a word, a name or a pattern such as <code>*.Track</code> in the search box to filter the
tree. Every type page says who posts the type, who receives it and through which pattern.</li>
</ul>
</section>
"""


def _counts(ctx: DocContext) -> str:
    entries = ctx.index.entries
    kinds = [e.kind for e in entries]
    deprecated = sum(1 for e in entries if e.deprecated)
    parts = [
        f"{kinds.count(Kind.MESSAGE)} message types",
        f"{kinds.count(Kind.STREAM)} stream types",
        f"{kinds.count(Kind.GROUP)} groups",
        f"{deprecated} deprecated",
    ]
    version = ctx.index.ontology.version
    return esc((f"Version {version} · " if version else "") + " · ".join(parts))


def _diagram(ctx: DocContext) -> str:
    result = ctx.diagram
    if result is None:
        return ""
    if result.svg is None:
        return f'<p class="muted">No diagram: {esc(result.problem)}.</p>'
    legend = (
        '<p class="legend"><span class="swatch module"></span> module '
        '<span class="swatch board"></span> whiteboard '
        '<span class="swatch stream"></span> stream · '
        '<span class="line post"></span> posts (message types) '
        '<span class="line trigger"></span> wakes (trigger patterns) '
        '<span class="line retrieve"></span> retrieves · dashed modules were only seen in the '
        'history. <a href="diagram.svg">Open the diagram on its own</a>.</p>'
    )
    return f'{legend}<div class="diagram">{result.svg}</div>'


def _namespaces(ctx: DocContext) -> str:
    rows = [
        [
            ctx.type_link("", ns.prefix),
            esc(ns.owner),
            esc(ns.version),
            esc(ns.description) + (" " + link(ns.url, "more") if ns.url else ""),
        ]
        for ns in ctx.index.ontology.namespaces
    ]
    return table(("Prefix", "Owner", "Version", "Description"), rows) if rows else ""


def _whiteboards(ctx: DocContext) -> str:
    usage = ctx.rel.usage
    names = list(
        dict.fromkeys(
            [w.name for w in usage.whiteboards]
            + [p.whiteboard for p in usage.postings if p.whiteboard]
        )
    )
    out = []
    for name in names:
        info = next((w for w in usage.whiteboards if w.name == name), None)
        posted = dict.fromkeys(
            p.type
            for p in usage.postings
            if p.whiteboard == name and p.source is not Source.ONTOLOGY
        )
        types = ", ".join(ctx.type_link("", t) for t in posted) or "none known"
        streams = [s for s in usage.streams if s.whiteboard == name]
        stream_html = ""
        if streams:
            listed = ", ".join(
                esc(s.name) + (f" ({ctx.type_link('', s.type)})" if s.type else "") for s in streams
            )
            stream_html = f"<p>Streams: {listed}</p>"
        description = esc(info.description) if info and info.description else ""
        out.append(
            f'<div class="board" id="{ctx.paths.anchor(name)}"><h3>{esc(name)}</h3>'
            f"<p>{description}</p><p>Types posted here: {types}</p>{stream_html}</div>"
        )
    return "".join(out)


def module_names(ctx: DocContext) -> list[str]:
    """Return every module the psySpec declares or a history or the ontology names."""
    usage = ctx.rel.usage
    names = [m.name for m in usage.modules]
    names.extend(p.module for p in usage.postings if p.module)
    names.extend(s.module for s in usage.subscriptions)
    for entry in ctx.index.entries:
        names.extend(link_.module for link_ in entry.node.posters + entry.node.subscribers)
    return list(dict.fromkeys(names))


def _about(ctx: DocContext, name: str) -> str:
    """Say what a module is: its psySpec description, or where it is known from."""
    info = ctx.rel.usage.module(name)
    if info is not None:
        return info.description or "No description in the psySpec."
    if name in SYSTEM_COMPONENTS:
        return "A component of the server itself (spec 6.2)."
    return "Not declared in the psySpec: known from the recorded history or the ontology."


def _modules(ctx: DocContext) -> str:
    usage = ctx.rel.usage
    rows = []
    for name in module_names(ctx):
        note = _about(ctx, name)
        posts = len({p.type for p in usage.postings if p.module == name})
        subs = len({s.pattern for s in usage.subscriptions if s.module == name})
        rows.append([link(ctx.paths.module(name), name), esc(note), str(posts), str(subs)])
    return table(("Module", "What it does", "Types posted", "Patterns"), rows) if rows else ""


def _top_level(ctx: DocContext) -> str:
    rows = [
        [link(ctx.paths.type(e.name), e.name), esc(first_sentence(e.node.description))]
        for e in ctx.index.children("")
    ]
    return table(("Type", "Description"), rows) if rows else ""


def _checks(ctx: DocContext) -> str:
    if not ctx.findings:
        return ""
    serious = [f for f in ctx.findings if f.level >= Level.WARNING]
    minor = [f for f in ctx.findings if f.level < Level.WARNING]

    def items(findings: list[Finding]) -> str:
        return "".join(
            f'<li class="finding {f.level.label}"><span class="level">{f.level.label}</span> '
            f"{esc(str(f).split(': ', 2)[-1])}</li>"
            for f in findings
        )

    out = f'<ul class="findings">{items(serious)}</ul>' if serious else "<p>No problems.</p>"
    if minor:
        out += (
            f"<details><summary>{len(minor)} notes</summary>"
            f'<ul class="findings">{items(minor)}</ul></details>'
        )
    return out + '<p class="muted">Run <code>openair ontology lint</code> to check in CI.</p>'


def _section(section_id: str, title: str, inner_html: str) -> str:
    if not inner_html:
        return ""
    return f'<section id="{section_id}"><h2>{esc(title)}</h2>{inner_html}</section>'


def index_body(ctx: DocContext) -> str:
    """Return the main content of the overview page."""
    ontology = ctx.index.ontology

    def to_type(name: str) -> str | None:
        return ctx.type_href("", name)

    parts = [
        f"<h1>{esc(ctx.title)}</h1>",
        f'<p class="counts">{_counts(ctx)}</p>',
        paragraphs(ontology.description, to_type),
        _GUIDE,
        _section("diagram-section", "The system at a glance", _diagram(ctx)),
        _section("namespaces", "Namespaces", _namespaces(ctx)),
        _section("whiteboards", "Whiteboards", _whiteboards(ctx)),
        _section("modules", "Modules", _modules(ctx)),
        _section("types", "Types, top level", _top_level(ctx)),
        _section("checks", "Consistency checks", _checks(ctx)),
    ]
    return "\n".join(p for p in parts if p)


# --------------------------------------------------------------------------------------------
# Module pages
# --------------------------------------------------------------------------------------------


def _matched(ctx: DocContext, sub: Subscription, root: str) -> str:
    found = ctx.index.matched_by(sub.pattern)
    shown = ", ".join(ctx.type_link(root, e.display_name) for e in found[:_MAX_MATCHED])
    more = f" and {len(found) - _MAX_MATCHED} more" if len(found) > _MAX_MATCHED else ""
    return shown + more if found else '<span class="problem">no defined type</span>'


def module_page_body(ctx: DocContext, name: str, root: str) -> str:
    """Return the main content of the page of module `name`."""
    usage = ctx.rel.usage
    description = esc(_about(ctx, name))
    known: dict[tuple[str, str], list[str]] = {}
    for p in usage.postings:
        if p.module == name:
            origin = p.source.value + (f" ({p.count}×)" if p.count else "")
            known.setdefault((p.type, p.whiteboard), []).append(origin)
    posts = [
        [ctx.type_link(root, type_), ctx.board_link(root, board), esc(", ".join(origins))]
        for (type_, board), origins in known.items()
    ]
    subs = [
        [
            esc(s.kind),
            f"<code>{esc(s.pattern)}</code>",
            ctx.board_link(root, s.whiteboard),
            esc(f"{s.context} / {s.phase}"),
            _matched(ctx, s, root),
        ]
        for s in usage.subscriptions
        if s.module == name
    ]
    streams = [
        [
            esc("writes" if name in s.writers else "reads"),
            esc(s.name),
            ctx.type_link(root, s.type) if s.type else "untyped",
        ]
        for s in usage.streams
        if name in s.writers or name in s.readers
    ]
    crumbs = f'<nav class="breadcrumb">{link(root + ctx.paths.index, "Overview")} › Modules</nav>'
    parts = [
        crumbs,
        f'<h1>{esc(name)} <span class="badge module">module</span></h1>',
        f"<p>{description}</p>",
        _section(
            "posts", "Posts", table(("Type", "Whiteboard", "Known from"), posts) if posts else ""
        ),
        _section(
            "triggers",
            "Woken by and reads",
            table(("Kind", "Pattern", "Whiteboard", "Context / phase", "Matches"), subs)
            if subs
            else "",
        ),
        _section("streams", "Streams", table(("", "Stream", "Type"), streams) if streams else ""),
    ]
    return "\n".join(p for p in parts if p)
