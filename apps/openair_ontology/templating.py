"""The docs site's templates: one Jinja2 environment with autoescaping, and text helpers.

The pages are `templates/*.html` (package data). Autoescape puts every name,
description and example through HTML escaping where it meets markup, attribute values
included, so an ontology or a history cannot inject markup; the Python side hands the
templates values, never HTML. The only markup passed in is the diagram's SVG, which Graphviz
wrote from escaped labels (`diagram.render_svg`).
"""

from __future__ import annotations

import re
import urllib.parse
from collections.abc import Callable
from functools import cache
from typing import Any

import jinja2

from openair_ontology.model import TypeEntry

__all__ = [
    "first_sentence",
    "linkify",
    "render",
    "split_paragraphs",
    "tree_label",
    "web_url",
]

# A dotted name inside prose: letters first, at least one dot, no trailing punctuation.
_DOTTED = re.compile(r"[A-Za-z][\w:]*(?:\.[\w:]+)+")
_LINKABLE = frozenset({"http", "https", "mailto"})


def first_sentence(text: str) -> str:
    """Return the first sentence of a description (for tooltips and summaries)."""
    flat = " ".join(text.split())
    end = flat.find(". ")
    return flat if end < 0 else flat[: end + 1]


def split_paragraphs(text: str) -> list[str]:
    """Split a description into paragraphs (blank lines between them), whitespace folded."""
    return [" ".join(p.split()) for p in re.split(r"\n\s*\n", text) if p.strip()]


def linkify(text: str, to_type: Callable[[str], str | None]) -> list[tuple[str, str | None]]:
    """Split `text` into (text, href) runs: the dotted names `to_type` knows get their link."""
    out: list[tuple[str, str | None]] = []
    pos = 0
    for found in _DOTTED.finditer(text):
        href = to_type(found.group())
        if href is None:
            continue
        out += [(text[pos : found.start()], None), (found.group(), href)]
        pos = found.end()
    out.append((text[pos:], None))
    return [(run, href) for run, href in out if run]


def web_url(url: str) -> str | None:
    """Return an authored URL fit for a link (http, https, mailto), else None (javascript:…)."""
    scheme = urllib.parse.urlsplit(url.strip()).scheme.lower()
    return url if scheme in _LINKABLE else None


def tree_label(entry: TypeEntry) -> str:
    """Return an entry's label in the tree: its segment, and `{parameter}` for a family."""
    if entry.is_family:
        return f"{entry.node.segment}{entry.node.separator}{{{entry.node.parameter}}}"
    return entry.node.segment


@cache
def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("openair_ontology", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )
    env.globals.update(
        first_sentence=first_sentence,
        split_paragraphs=split_paragraphs,
        linkify=linkify,
        tree_label=tree_label,
        web_url=web_url,
    )
    return env


def render(template: str, **context: Any) -> str:
    """Render one of the site's templates."""
    return _environment().get_template(template).render(**context)
