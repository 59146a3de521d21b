"""Building blocks of the HTML pages: escaping, the page frame, inline CSS and JavaScript.

Pages are single files with no network access (a Content-Security-Policy forbids loading
anything); all styling and behaviour is inline. Every piece of text goes through `esc`, which
first neutralises control characters (`safe_text`) and then escapes `& < > " '`; attribute values
are always double-quoted. The scripts read their data from `data-` attributes, never from text
interpolated into JavaScript, so no server text ever reaches a script context.
"""

from __future__ import annotations

import html

from openair_conformance.model import TraceEntry, Verdict
from openair_conformance.reporters._common import entry_head, safe_text

__all__ = ["esc", "page", "trace_list", "verdict_badge"]

_PREVIEW_CHARS = 160

_CSS = """
:root { --fg:#1d232a; --muted:#5c6670; --line:#d6dbe0; --bg:#fff; --soft:#f4f6f8; }
* { box-sizing: border-box; }
body { font: 14px/1.45 system-ui, -apple-system, "Segoe UI", sans-serif; color: var(--fg);
  background: var(--bg); margin: 0 auto; padding: 1rem 2rem 4rem; max-width: 1400px; }
h1 { font-size: 1.5rem; margin: .5rem 0 1rem; } h2 { margin-top: 2rem; border-bottom:
  1px solid var(--line); padding-bottom: .25rem; } h3 { margin: 0 0 .5rem; }
code, pre, .mono { font-family: ui-monospace, "SF Mono", Menlo, Consolas, monospace;
  font-size: 12.5px; }
pre { white-space: pre-wrap; overflow-wrap: anywhere; background: var(--soft);
  padding: .5rem .75rem; border-radius: 4px; margin: .25rem 0; }
table { border-collapse: collapse; } th, td { border: 1px solid var(--line);
  padding: .25rem .5rem; text-align: left; vertical-align: top; }
thead th { background: var(--soft); position: sticky; top: 0; }
table.kv th { background: var(--soft); font-weight: 600; white-space: nowrap; }
table.matrix td { text-align: center; min-width: 3.5rem; }
table.matrix td a, table.matrix th a { display: block; color: inherit; text-decoration: none; }
table.matrix td.zero { color: #c3c9cf; }
.badge { display: inline-block; padding: 0 .45rem; border-radius: 3px; font-weight: 600;
  font-size: 12px; white-space: nowrap; }
.v-pass { background: #d9f2dd; color: #155724; }
.v-pass-nonstrict { background: #fff3cd; color: #6b5200; }
.v-informational { background: #dbe9ff; color: #163d7a; }
.v-not-applicable { background: #eceff1; color: #5c6670; }
.v-expected-failure { background: #d7f0f4; color: #0c5460; }
.v-unexpected-pass { background: #f8d0d4; color: #7a0f1c; }
.v-fail { background: #f5c2c7; color: #7a0f1c; }
.v-timing { background: #ffe5b4; color: #7a4300; }
.v-inconclusive { background: #ead9f5; color: #4b2266; }
.v-error { background: #7a0f1c; color: #fff; }
.missing { color: var(--muted); text-align: center; }
.filters { display: flex; gap: .75rem; align-items: center; margin: .5rem 0; flex-wrap: wrap; }
.filters input[type=search] { min-width: 22rem; padding: .25rem .5rem; }
tr.differs td:first-child { box-shadow: inset 4px 0 0 #d9480f; }
tr.differs { background: #fff8e6; } td.delta { outline: 2px solid #d9480f; outline-offset: -2px; }
article.case { border: 1px solid var(--line); border-radius: 6px; padding: .75rem 1rem;
  margin: 1rem 0; } article.case:target { box-shadow: 0 0 0 3px #4c8bf5; }
article.case dl { display: grid; grid-template-columns: max-content 1fr; gap: .15rem 1rem;
  margin: .5rem 0; } article.case dt { color: var(--muted); } article.case dd { margin: 0; }
ol.trace { list-style: none; padding: 0; margin: .25rem 0; }
ol.trace li { border-left: 3px solid var(--line); padding-left: .5rem; margin: 2px 0; }
ol.trace li.d-out { border-color: #4c8bf5; } ol.trace li.d-in { border-color: #2f9e44; }
ol.trace li.d-note { border-color: #adb5bd; } ol.trace li.divergence { border-color: #d9480f;
  background: #fff0e6; }
ol.trace summary { cursor: pointer; } ol.trace summary code { color: var(--muted); }
.muted { color: var(--muted); } .small { font-size: 12px; }
"""

_JS = """
(function () {
  "use strict";
  function byId(id) { return document.getElementById(id); }
  var text = byId("f-text"), verdict = byId("f-verdict"), section = byId("f-section"),
      diff = byId("f-diff"), count = byId("f-count");
  var rows = Array.prototype.slice.call(document.querySelectorAll("table.filterable tbody tr"));
  function apply() {
    var q = text ? text.value.trim().toLowerCase() : "", shown = 0;
    rows.forEach(function (row) {
      var d = row.dataset, ok = true;
      if (verdict && verdict.value && d.verdict !== verdict.value) { ok = false; }
      if (section && section.value && d.section !== section.value) { ok = false; }
      if (diff && diff.checked && !row.classList.contains("differs")) { ok = false; }
      if (q && (d.search || "").indexOf(q) < 0) { ok = false; }
      row.hidden = !ok;
      if (ok) { shown += 1; }
    });
    if (count) { count.textContent = shown + " of " + rows.length + " cases shown"; }
  }
  [text, verdict, section, diff].forEach(function (el) {
    if (el) { el.addEventListener("input", apply); el.addEventListener("change", apply); }
  });
  Array.prototype.forEach.call(document.querySelectorAll("[data-filter]"), function (a) {
    a.addEventListener("click", function () {
      if (section) { section.value = a.dataset.filterSection || ""; }
      if (verdict) { verdict.value = a.dataset.filterVerdict || ""; }
      if (text) { text.value = ""; }
      apply();
    });
  });
  Array.prototype.forEach.call(document.querySelectorAll("button[data-open]"), function (b) {
    b.addEventListener("click", function () {
      var open = b.dataset.open === "1", scope = b.closest("article") || document;
      Array.prototype.forEach.call(scope.querySelectorAll("ol.trace details"), function (d) {
        d.open = open;
      });
    });
  });
  apply();
}());
"""

_CSP = "default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; img-src data:"


def esc(text: object) -> str:
    """Escape any value for HTML text or a double-quoted attribute."""
    return html.escape(safe_text(str(text)), quote=True)


def verdict_badge(verdict: Verdict | str, text: str | None = None) -> str:
    """A coloured badge for a verdict (given as a Verdict or its value)."""
    value = verdict.value if isinstance(verdict, Verdict) else verdict
    return f'<span class="badge v-{esc(value)}">{esc(value if text is None else text)}</span>'


def page(title: str, body: str) -> str:
    """Wrap `body` in a complete, self-contained HTML document."""
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f'<meta http-equiv="Content-Security-Policy" content="{_CSP}">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{esc(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
        f"{body}\n<script>{_JS}</script>\n</body>\n</html>\n"
    )


def _preview(text: str) -> str:
    line = next((part.strip() for part in text.splitlines() if part.strip()), "")
    return line if len(line) <= _PREVIEW_CHARS else line[: _PREVIEW_CHARS - 1] + "…"


def trace_list(entries: tuple[TraceEntry, ...], divergence: int | None, prefix: str) -> str:
    """Render a whole trace: one collapsible entry per frame or note, the divergence open.

    Entry `i` gets the anchor `<prefix>-t<i>`.
    """
    if not entries:
        return '<p class="muted">The trace is empty.</p>'
    items = []
    for index, entry in enumerate(entries):
        marked = index == divergence
        classes = f"d-{esc(entry.direction)}" + (" divergence" if marked else "")
        head = esc(entry_head(index, entry)) + (" <strong>◀ divergence</strong>" if marked else "")
        items.append(
            f'<li class="{classes}" id="{esc(prefix)}-t{index}">'
            f"<details{' open' if marked else ''}>"
            f"<summary>{head} <code>{esc(_preview(entry.text))}</code></summary>"
            f"<pre>{esc(entry.text)}</pre></details></li>"
        )
    return '<ol class="trace">' + "".join(items) + "</ol>"
