"""Write the ontology docs as Markdown for wikis (`openair ontology docs --format md`).

The same pages as the HTML site, as plain CommonMark with GitHub-style tables:

    index.md             overview: description, type tree, namespaces, whiteboards, modules,
                         checks, and the diagram (diagram.svg beside it)
    types/<name>.md      one page per type node
    modules/<name>.md    one page per module

Links are relative and end in `.md`, which GitHub, GitLab and most wiki engines follow.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from pathlib import Path

from openair.protocol.matching import matches, psyclone_matches
from openair_ontology.lint import Level
from openair_ontology.model import TypeEntry
from openair_ontology.overview import module_names
from openair_ontology.pages import DocContext, pretty_content
from openair_ontology.relations import deviation, subtree_patterns
from openair_ontology.usage import Source, iso_time

__all__ = ["write_markdown"]

_SPECIAL = re.compile(r"([\\`*_\[\]<>|#])")


def text(value: str) -> str:
    """Escape Markdown syntax in plain text (one line)."""
    return _SPECIAL.sub(r"\\\1", " ".join(value.split()))


def code(value: str) -> str:
    """Return `value` as inline code, with enough backticks to hold any inside it."""
    ticks = "`" * (max((len(m) for m in re.findall(r"`+", value)), default=0) + 1)
    pad = " " if value.startswith("`") or value.endswith("`") else ""
    return f"{ticks}{pad}{value}{pad}{ticks}"


def mlink(label_md: str, href: str) -> str:
    return f"[{label_md}]({href.replace(' ', '%20').replace(')', '%29')})"


def table(headers: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """Return a GitHub table (cells are Markdown already; pipes must be escaped by callers)."""
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines.extend("| " + " | ".join(cell.replace("\n", " ") for cell in row) + " |" for row in rows)
    return "\n".join(lines)


def paragraphs(value: str) -> str:
    return "\n\n".join(text(p) for p in re.split(r"\n\s*\n", value) if p.strip())


class _Writer:
    """Renders the pages of one context."""

    def __init__(self, ctx: DocContext) -> None:
        self.ctx = ctx

    def type_ref(self, root: str, name: str) -> str:
        href = self.ctx.type_href(root, name)
        return code(name) if href is None else mlink(code(name), href)

    def module_ref(self, root: str, name: str) -> str:
        return mlink(text(name), root + self.ctx.paths.module(name)) if name else "?"

    def board(self, name: str) -> str:
        return text(name) if name else "any whiteboard"

    # -- type pages ------------------------------------------------------------------------

    def type_page(self, entry: TypeEntry) -> str:
        ctx, root = self.ctx, "../"
        crumbs = [mlink("Overview", root + ctx.paths.index)]
        crumbs += [
            mlink(text(a.node.segment), root + ctx.paths.type(a.name))
            for a in ctx.index.ancestors(entry)
        ]
        badges = [entry.kind.value] + (["deprecated"] if entry.deprecated else [])
        out = [
            " › ".join(crumbs),
            f"# {text(entry.node.segment)}",
            f"**Full name:** {code(entry.display_name)} · {', '.join(badges)}",
        ]
        dep = entry.node.deprecated
        if dep is not None:
            use = f" Use {self.type_ref(root, dep.replaced_by)} instead." if dep.replaced_by else ""
            since = f" since {text(dep.since)}" if dep.since else ""
            out.append(f"> **Deprecated{since}.** {text(dep.reason)}{use}")
        out.append(paragraphs(entry.node.description) or "_No description yet._")
        out.append(self.facts(entry))
        sections = [
            ("Who posts it", self.posters(entry, root)),
            ("Who receives it", self.subscribers(entry, root)),
            ("Patterns that match it", self.patterns(entry)),
            ("Psyclone 1.1.7 would also deliver it", self.psyclone_only(entry, root)),
            ("Seen in the recorded history", self.observed(entry, root)),
            ("Examples", self.examples(entry)),
            ("Types below it", self.subtypes(entry, root)),
        ]
        out.extend(f"## {title}\n\n{body}" for title, body in sections if body)
        return "\n\n".join(p for p in out if p) + "\n"

    def facts(self, entry: TypeEntry) -> str:
        rows = [["Kind", entry.kind.value]]
        ns = self.ctx.index.namespace_of(entry.name)
        if ns is not None:
            rows.append(["Namespace", f"{code(ns.prefix)} — {text(ns.owner)} {text(ns.version)}"])
        content = entry.node.content
        if content is not None:
            parts = [f"language {code(content.language)}" if content.language else "no language"]
            parts += [f"root {code(content.root)}"] if content.root else []
            parts += [f"schema {code(content.schema)}"] if content.schema else []
            rows.append(["Content", ", ".join(parts) + ". " + text(content.description)])
        return table(["", ""], rows)

    def posters(self, entry: TypeEntry, root: str) -> str:
        names = {Source.PSYSPEC: "psySpec", Source.HISTORY: "history", Source.ONTOLOGY: "ontology"}
        rows = [
            [
                self.module_ref(root, p.module),
                self.board(p.whiteboard),
                names[p.source] + (f" ({p.count}×)" if p.count else ""),
            ]
            for p in self.ctx.rel.postings(entry)
        ]
        return table(["Module", "Whiteboard", "Known from"], rows) if rows else ""

    def subscribers(self, entry: TypeEntry, root: str) -> str:
        rows = [
            [self.module_ref(root, module), self.board(wb), kind + (f" {code(p)}" if p else "")]
            for module, wb, kind, p in self.ctx.rel.subscribers(entry)
        ]
        return table(["Module", "Whiteboard", "Through"], rows) if rows else ""

    def patterns(self, entry: TypeEntry) -> str:
        used = list(dict.fromkeys(s.pattern for s in self.ctx.rel.subscriptions(entry)))
        out = [table(["Pattern in this system"], [[code(p)] for p in used])] if used else []
        if entry.is_concrete:
            options = ([] if entry.is_family else [entry.name]) + subtree_patterns(entry.name)
            out.append("Patterns you could use: " + ", ".join(code(p) for p in options))
        return "\n\n".join(out)

    def psyclone_only(self, entry: TypeEntry, root: str) -> str:
        if not entry.is_concrete or entry.is_family:
            return ""
        rows = [
            [code(s.pattern), self.module_ref(root, s.module), deviation(s.pattern, entry.name)]
            for s in self.ctx.rel.usage.subscriptions
            if psyclone_matches(s.pattern, entry.name) and not matches(s.pattern, entry.name)
        ]
        return table(["Pattern", "Module", "Deviation"], rows) if rows else ""

    def observed(self, entry: TypeEntry, root: str) -> str:
        rows = [
            [
                code(o.type),
                str(o.count),
                iso_time(o.first) if o.first else "—",
                iso_time(o.last) if o.last else "—",
                ", ".join(f"{self.module_ref(root, m)} ({n}×)" for m, _, n in o.posters),
            ]
            for o in self.ctx.rel.observations(entry)
        ]
        return table(["Type", "Messages", "First", "Last", "Posted by"], rows) if rows else ""

    def examples(self, entry: TypeEntry) -> str:
        out = []
        for x in entry.node.examples:
            head = f"**{text(x.title)}** — " if x.title else ""
            where = f"from {code(x.sender or '?')} to {code(x.to or '?')}"
            body = pretty_content(x.content, x.is_xml)
            fence = "```" + ("xml" if x.is_xml else "text")
            block = f"\n\n{fence}\n{body}\n```" if body else " (no content)"
            out.append(f"{head}{where}{block}")
        return "\n\n".join(out)

    def subtypes(self, entry: TypeEntry, root: str) -> str:
        rows = [
            [
                mlink(code(c.display_name), root + self.ctx.paths.type(c.name)),
                c.kind.value,
                text(c.node.description.split(". ")[0]),
            ]
            for c in self.ctx.index.children(entry.name)
        ]
        return table(["Type", "Kind", "Description"], rows) if rows else ""

    # -- overview and modules --------------------------------------------------------------

    def tree(self) -> str:
        lines = []
        for e in self.ctx.index.entries:
            segment = e.node.segment
            if e.is_family:
                segment += f"{e.node.separator}{{{e.node.parameter}}}"
            label = mlink(code(segment), self.ctx.paths.type(e.name))
            mark = " _(deprecated)_" if e.deprecated else ""
            lines.append("  " * e.depth + f"- {label}{mark}")
        return "\n".join(lines)

    def index_page(self) -> str:
        ctx = self.ctx
        onto = ctx.index.ontology
        out = [f"# {text(ctx.title)}", paragraphs(onto.description)]
        if ctx.diagram is not None and ctx.diagram.svg is not None:
            out.append(
                "## The system at a glance\n\n![Modules, whiteboards and types](diagram.svg)"
            )
        if onto.namespaces:
            rows = [
                [code(n.prefix), text(n.owner), text(n.version), text(n.description)]
                for n in onto.namespaces
            ]
            out.append("## Namespaces\n\n" + table(["Prefix", "Owner", "Version", "About"], rows))
        out.append("## Types\n\n" + self.tree())
        names = module_names(ctx)
        if names:
            rows = [[self.module_ref("", n), text(self.about(n))] for n in names]
            out.append("## Modules\n\n" + table(["Module", "What it does"], rows))
        serious = [f for f in ctx.findings if f.level >= Level.WARNING]
        if serious:
            out.append(
                "## Consistency checks\n\n" + "\n".join(f"- {text(str(f))}" for f in serious)
            )
        return "\n\n".join(p for p in out if p) + "\n"

    def about(self, name: str) -> str:
        info = self.ctx.rel.usage.module(name)
        return info.description if info is not None else "not in the psySpec"

    def module_page(self, name: str) -> str:
        usage = self.ctx.rel.usage
        info = usage.module(name)
        out = [
            mlink("Overview", "../" + self.ctx.paths.index),
            f"# {text(name)}",
            text(info.description) if info else "_Not declared in the psySpec._",
        ]
        posts = [
            [self.type_ref("../", p.type), self.board(p.whiteboard), p.source.value]
            for p in usage.postings
            if p.module == name
        ]
        if posts:
            out.append("## Posts\n\n" + table(["Type", "Whiteboard", "Known from"], posts))
        subs = [
            [s.kind, code(s.pattern), self.board(s.whiteboard)]
            for s in usage.subscriptions
            if s.module == name
        ]
        if subs:
            out.append("## Woken by and reads\n\n" + table(["Kind", "Pattern", "Whiteboard"], subs))
        return "\n\n".join(out) + "\n"


def _write(path: Path, content: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(content, encoding="utf-8")


def write_markdown(ctx: DocContext, out: Path) -> int:
    """Write the Markdown pages into `out`; return the number of pages written."""
    writer = _Writer(ctx)
    out.mkdir(parents=True, exist_ok=True)
    _write(out / ctx.paths.index, writer.index_page())
    if ctx.diagram is not None and ctx.diagram.svg is not None:
        _write(out / "diagram.svg", '<?xml version="1.0" encoding="UTF-8"?>\n' + ctx.diagram.svg)
    for entry in ctx.index.entries:
        _write(out / ctx.paths.type(entry.name), writer.type_page(entry))
    names = module_names(ctx)
    for name in names:
        _write(out / ctx.paths.module(name), writer.module_page(name))
    return 1 + len(ctx.index.entries) + len(names)
