"""The HTML pages' templates: one Jinja2 environment with autoescaping, and the page frame.

Pages are single files with no network access (a Content-Security-Policy forbids loading
anything); the stylesheet and the script (`templates/report.css`, `report.js`) are inlined.
Every value a template prints is escaped by Jinja2's autoescape after `safe_text` has
neutralised control characters, surrogates and bidi overrides (the environment's `finalize`),
so hostile trace text stays text. Attribute values are always double-quoted. The script reads
its data from `data-` attributes, never from text interpolated into JavaScript, so no server
text ever reaches a script context.
"""

from __future__ import annotations

import importlib.resources
from functools import cache
from typing import Any

import jinja2
from markupsafe import Markup

from openair_conformance.model import Verdict
from openair_conformance.reporters._common import direction_arrow, entry_head, safe_text

__all__ = ["CSP", "render"]

CSP = "default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; img-src data:"
_PREVIEW_CHARS = 160


def _finalize(value: object) -> object:
    """Neutralise control characters in every printed string (Markup is ours: left alone)."""
    if isinstance(value, str) and not isinstance(value, Markup):
        return safe_text(value)
    return value


def _preview(text: str) -> str:
    line = next((part.strip() for part in text.splitlines() if part.strip()), "")
    return line if len(line) <= _PREVIEW_CHARS else line[: _PREVIEW_CHARS - 1] + "…"


def _asset(name: str) -> Markup:
    """Return one of our own static files (CSS, JavaScript) to inline as it is."""
    files = importlib.resources.files("openair_conformance.reporters").joinpath("templates")
    return Markup(files.joinpath(name).read_text(encoding="utf-8"))  # our own file, not text


@cache
def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("openair_conformance.reporters", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        finalize=_finalize,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters["preview"] = _preview
    env.globals.update(
        verdicts=list(Verdict),
        entry_head=entry_head,
        arrow=direction_arrow,
        csp=CSP,
        css=_asset("report.css"),
        js=_asset("report.js"),
    )
    return env


def render(template: str, **context: Any) -> str:
    """Render one of the templates with `context`."""
    return _environment().get_template(template).render(**context)
