"""Small HTML building blocks of the docs site: escaping, tables, the type tree, the layout.

Everything is escaped at the point where text meets markup (`esc`); functions that take HTML
say so in their parameter names (`*_html`). No page loads anything from the network: the
stylesheet and scripts are files of the site itself.
"""

from __future__ import annotations

import html
import re
from collections.abc import Callable, Sequence

from openair.ontology.model import Kind, TypeEntry, TypeIndex
from openair.ontology.paths import Paths

__all__ = [
    "EMPTY_TREE",
    "badge",
    "esc",
    "first_sentence",
    "layout",
    "link",
    "paragraphs",
    "table",
    "tree_html",
    "tree_label",
]

# A dotted name inside prose: letters first, at least one dot, no trailing punctuation.
_DOTTED = re.compile(r"[A-Za-z][\w:]*(?:\.[\w:]+)+")


def esc(text: str) -> str:
    """Escape text for HTML content and attribute values."""
    return html.escape(text, quote=True)


def link(href: str, text: str, cls: str = "") -> str:
    """Return `<a href>text</a>` (both escaped)."""
    cls_attr = f' class="{esc(cls)}"' if cls else ""
    return f'<a href="{esc(href)}"{cls_attr}>{esc(text)}</a>'


def first_sentence(text: str) -> str:
    """Return the first sentence of a description (for tooltips and summaries)."""
    flat = " ".join(text.split())
    end = flat.find(". ")
    return flat if end < 0 else flat[: end + 1]


def linkify(text: str, to_type: Callable[[str], str | None]) -> str:
    """Escape `text`, turning the dotted names that `to_type` knows into links."""
    out: list[str] = []
    pos = 0
    for found in _DOTTED.finditer(text):
        href = to_type(found.group())
        if href is None:
            continue
        out.append(esc(text[pos : found.start()]))
        out.append(f'<a href="{esc(href)}"><code>{esc(found.group())}</code></a>')
        pos = found.end()
    out.append(esc(text[pos:]))
    return "".join(out)


def paragraphs(text: str, to_type: Callable[[str], str | None], empty: str = "") -> str:
    """Render a description: blank lines separate paragraphs; type names become links."""
    parts = [" ".join(p.split()) for p in re.split(r"\n\s*\n", text) if p.strip()]
    if not parts:
        return f'<p class="muted">{esc(empty)}</p>' if empty else ""
    return "".join(f"<p>{linkify(p, to_type)}</p>" for p in parts)


def table(headers: Sequence[str], rows_html: Sequence[Sequence[str]], cls: str = "") -> str:
    """Return a table; headers are text, the cells are HTML already."""
    head = "".join(f"<th>{esc(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows_html)
    cls_attr = f' class="{esc(cls)}"' if cls else ""
    return f"<table{cls_attr}><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def badge(entry: TypeEntry) -> str:
    """Return the kind badge of an entry (and `deprecated` when it is)."""
    out = f'<span class="badge kind-{entry.kind.value}">{entry.kind.value}</span>'
    if entry.is_family:
        out += '<span class="badge family">family</span>'
    if entry.deprecated:
        out += '<span class="badge deprecated">deprecated</span>'
    return out


def tree_label(entry: TypeEntry) -> str:
    """Return an entry's label in the tree: its segment, and `{parameter}` for a family."""
    if entry.is_family:
        return f"{entry.node.segment}{entry.node.separator}{{{entry.node.parameter}}}"
    return entry.node.segment


def _tree_node(index: TypeIndex, entry: TypeEntry, paths: Paths, root: str) -> str:
    children = index.children(entry.name)
    classes = ["node", f"kind-{entry.kind.value}"] + (["deprecated"] if entry.deprecated else [])
    label = tree_label(entry)
    toggle = (
        '<button type="button" class="toggle" aria-expanded="true" '
        f'aria-label="Collapse {esc(entry.name)}">&#9662;</button>'
        if children
        else '<span class="toggle-spacer"></span>'
    )
    title = first_sentence(entry.node.description)
    anchor = f'<a href="{esc(root + paths.type(entry.name))}" title="{esc(title)}">{esc(label)}</a>'
    kind = ' <span class="mini">stream</span>' if entry.kind is Kind.STREAM else ""
    sub = ""
    if children:
        items = "".join(_tree_node(index, c, paths, root) for c in children)
        sub = f'<ul role="group">{items}</ul>'
    return (
        f'<li class="{" ".join(classes)}" data-type="{esc(entry.name)}" role="treeitem" '
        f'data-depth="{entry.depth}"><div class="row">{toggle}{anchor}{kind}</div>{sub}</li>'
    )


#: The tree of a page other than the overview: site.js fills it from the search index.
EMPTY_TREE = (
    '<ul id="tree" class="tree" role="tree" aria-label="Message types"></ul>'
    '<noscript><p class="muted">The type tree needs JavaScript; the overview lists every '
    "type without it.</p></noscript>"
)


def tree_html(index: TypeIndex, paths: Paths, root: str) -> str:
    """Return the collapsible type tree (every node expanded; site.js collapses it)."""
    items = "".join(_tree_node(index, e, paths, root) for e in index.children(""))
    return f'<ul id="tree" class="tree" role="tree" aria-label="Message types">{items}</ul>'


def layout(
    *,
    title: str,
    site_title: str,
    root: str,
    body_html: str,
    tree: str,
    current: str = "",
) -> str:
    """Return a whole page: header, the searchable tree beside the content, the scripts."""
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{esc(title)} — {esc(site_title)}</title>
<link rel="stylesheet" href="{root}assets/site.css">
</head>
<body data-root="{root}" data-current="{esc(current)}">
<header class="top">
<a class="home" href="{root}index.html">{esc(site_title)}</a>
<span class="tagline">message types, who posts them and who listens</span>
</header>
<div class="layout">
<nav class="sidebar" aria-label="Type tree">
<label class="search-label" for="search">Find a type</label>
<input id="search" type="search" autocomplete="off" spellcheck="false"
 placeholder="Name, word, or pattern like Input.*">
<p id="search-status" class="muted" aria-live="polite"></p>
<div class="tree-actions">
<button type="button" id="expand-all">Expand all</button>
<button type="button" id="collapse-all">Collapse all</button>
</div>
{tree}
</nav>
<main id="main">
{body_html}
</main>
</div>
<footer>Generated by <code>openair ontology docs</code> (OpenAIR kit). Works offline.</footer>
<script src="{root}assets/search-index.js"></script>
<script src="{root}assets/site.js"></script>
</body>
</html>
"""
