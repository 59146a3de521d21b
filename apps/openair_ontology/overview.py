"""The overview page (index) and the module pages of the docs site.

The overview is where a newcomer starts: what the system is, how to read a type name and a
pattern, the diagram of modules, whiteboards and types, the namespaces, the whiteboards with
the types posted to each, the modules, the top of the type tree, and the consistency checks.
The pages are the templates `index.html` and `module.html`; this module gathers what they show.
"""

from __future__ import annotations

from dataclasses import dataclass

from markupsafe import Markup

from openair.protocol.psyspec import SYSTEM_COMPONENTS
from openair_ontology.lint import Finding, Level
from openair_ontology.model import Kind
from openair_ontology.pages import DocContext
from openair_ontology.templating import render
from openair_ontology.usage import Source, StreamDecl

__all__ = ["index_page", "module_names", "module_page"]

_MAX_MATCHED = 8


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
    return (f"Version {version} · " if version else "") + " · ".join(parts)


@dataclass(frozen=True, slots=True, kw_only=True)
class _Board:
    name: str
    description: str
    types: list[str]
    streams: list[StreamDecl]


def _whiteboards(ctx: DocContext) -> list[_Board]:
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
        out.append(
            _Board(
                name=name,
                description=info.description if info is not None else "",
                types=list(posted),
                streams=[s for s in usage.streams if s.whiteboard == name],
            )
        )
    return out


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


def _modules(ctx: DocContext) -> list[tuple[str, str, int, int]]:
    usage = ctx.rel.usage
    return [
        (
            name,
            _about(ctx, name),
            len({p.type for p in usage.postings if p.module == name}),
            len({s.pattern for s in usage.subscriptions if s.module == name}),
        )
        for name in module_names(ctx)
    ]


def _finding_text(finding: Finding) -> str:
    return str(finding).split(": ", 2)[-1]


def index_page(ctx: DocContext, tree: bool = True) -> str:
    """Return the overview page (with the whole type tree, which works without JavaScript)."""
    diagram = ctx.diagram
    svg = diagram.svg if diagram is not None else None
    return render(
        "index.html",
        title="Overview",
        site_title=ctx.title,
        root="",
        current="",
        tree=ctx.index if tree else None,
        paths=ctx.paths,
        type_href=lambda name: ctx.type_href("", name),
        counts=_counts(ctx),
        description=ctx.index.ontology.description,
        diagram=diagram,
        # Graphviz wrote this SVG from escaped labels: markup of our own making, kept as is.
        diagram_svg=Markup(svg) if svg is not None else "",
        namespaces=ctx.index.ontology.namespaces,
        boards=_whiteboards(ctx),
        modules=_modules(ctx),
        top=ctx.index.children(""),
        serious=[f for f in ctx.findings if f.level >= Level.WARNING],
        minor=[f for f in ctx.findings if f.level < Level.WARNING],
        finding_text=_finding_text,
    )


# --------------------------------------------------------------------------------------------
# Module pages
# --------------------------------------------------------------------------------------------


def module_page(ctx: DocContext, name: str, root: str) -> str:
    """Return the page of module `name`."""
    usage = ctx.rel.usage
    known: dict[tuple[str, str], list[str]] = {}
    for p in usage.postings:
        if p.module == name:
            origin = p.source.value + (f" ({p.count}×)" if p.count else "")
            known.setdefault((p.type, p.whiteboard), []).append(origin)
    return render(
        "module.html",
        title=name,
        site_title=ctx.title,
        root=root,
        current="",
        tree=None,
        paths=ctx.paths,
        type_href=lambda type_: ctx.type_href(root, type_),
        name=name,
        about=_about(ctx, name),
        posts=[(t, board, ", ".join(origins)) for (t, board), origins in known.items()],
        subs=[
            (s, ctx.index.matched_by(s.pattern)) for s in usage.subscriptions if s.module == name
        ],
        max_matched=_MAX_MATCHED,
        streams=[s for s in usage.streams if name in s.writers or name in s.readers],
    )
