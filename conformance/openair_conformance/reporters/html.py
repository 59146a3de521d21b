"""The HTML reporter: one self-contained page holding the whole run, evidence included.

The page has a header (target, server, date, run options), the summary (counts, latencies,
vacuous passes, expectations matching no case), a matrix of spec sections × verdicts whose
cells filter the case table, a filterable case table, and a detail section per case (anchor
`case-<ID>`) with the requirement sentences, the allowed behaviours, the message, the repro line
and the full frame trace, each entry collapsible. The file is written when the reporter is
closed; nothing is written when no run started. `write_comparison` (from `_compare`) renders
several JSON reports side by side.
"""

from __future__ import annotations

from openair_conformance.model import CaseResult, RunStarted, RunSummary, Verdict
from openair_conformance.registry import requirement_sentences
from openair_conformance.reporters._common import (
    FileReporter,
    RunRecord,
    by_section,
    first_line,
    format_time,
    section_key,
    section_label,
)
from openair_conformance.reporters._compare import write_comparison
from openair_conformance.reporters._htmlkit import esc, page, trace_list, verdict_badge

__all__ = ["HtmlReporter", "render_report", "write_comparison"]


def _kv_table(rows: list[tuple[str, str]]) -> str:
    """A two-column table; values are HTML already."""
    body = "".join(f"<tr><th>{esc(key)}</th><td>{value}</td></tr>" for key, value in rows)
    return f'<table class="kv">{body}</table>'


def _header(started: RunStarted, summary: RunSummary, complete: bool) -> str:
    server = started.server
    limits = ", ".join(f"{name} = {value}" for name, value in server.limits)
    rows = [
        ("target", esc(started.target)),
        ("server", esc(server.server or "(not named)")),
        ("protocol", esc(server.protocol or "—")),
        ("legacy server", "yes (core only, OA-CAP-2)" if server.legacy else "no"),
        ("extensions", esc(", ".join(server.capabilities) or "none")),
        ("limits", esc(limits or "none advertised")),
        ("round-trip time", f"{server.rtt_ms:.3f} ms"),
        ("started", esc(format_time(started.started))),
        ("duration", f"{summary.duration:.1f} s"),
        ("cases selected", str(started.cases)),
    ]
    if not complete:
        rows.append(("status", "<strong>the run stopped before every case was judged</strong>"))
    options = [(key, esc(value)) for key, value in sorted(started.options.items())]
    return (
        f"<header><h1>OpenAIR conformance report: {esc(started.target)}</h1>"
        f"{_kv_table(rows)}<h2>Run options</h2>{_kv_table(options)}</header>"
    )


def _summary(summary: RunSummary) -> str:
    badges = " ".join(verdict_badge(v, f"{v.value} {n}") for v, n in summary.counts)
    latencies = "".join(
        f"<li><code>{esc(name)}</code> {value:g}</li>" for name, value in summary.latencies
    )
    parts = [
        '<section id="summary"><h2>Summary</h2>',
        f"<p>{summary.total} case(s) in {summary.duration:.1f} s: {badges or 'no results'}</p>",
        f"<h3>Latencies</h3><ul>{latencies}</ul>",
    ]
    if summary.vacuous:
        messages = {r.info.id: r.message for r in summary.results}
        items = "".join(
            f'<li><a href="#case-{esc(cid)}">{esc(cid)}</a> {esc(messages.get(cid, ""))}</li>'
            for cid in summary.vacuous
        )
        parts.append(f"<h3>Vacuous passes (they prove nothing)</h3><ul>{items}</ul>")
    if summary.unknown_expectations:
        items = "".join(f"<li><code>{esc(e)}</code></li>" for e in summary.unknown_expectations)
        parts.append(f"<h3>Expectations that match no case</h3><ul>{items}</ul>")
    parts.append("</section>")
    return "".join(parts)


def _matrix(results: tuple[CaseResult, ...]) -> str:
    head = "".join(f"<th>{verdict_badge(v)}</th>" for v in Verdict)
    rows = []
    totals = dict.fromkeys(Verdict, 0)
    for section, counts in by_section(results).items():
        cells = []
        for verdict in Verdict:
            n = counts.get(verdict, 0)
            totals[verdict] += n
            link = (
                f'<a href="#cases" data-filter="1" data-filter-section="{esc(section)}" '
                f'data-filter-verdict="{verdict.value}">{n}</a>'
            )
            cells.append(
                f'<td class="v-{verdict.value}">{link}</td>' if n else '<td class="zero">0</td>'
            )
        label = (
            f'<a href="#cases" data-filter="1" data-filter-section="{esc(section)}">'
            f"{esc(section_label(section))}</a>"
        )
        rows.append(
            f'<tr data-section="{esc(section)}"><th>{label}</th>{"".join(cells)}'
            f"<td>{sum(counts.values())}</td></tr>"
        )
    foot = "".join(f"<td>{totals[v]}</td>" for v in Verdict)
    return (
        '<section id="matrix"><h2>Spec sections × verdicts</h2>'
        f'<table class="matrix"><thead><tr><th>section</th>{head}<th>total</th></tr></thead>'
        f"<tbody>{''.join(rows)}</tbody>"
        f"<tfoot><tr><th>total</th>{foot}<td>{len(results)}</td></tr></tfoot></table></section>"
    )


def _filters(results: tuple[CaseResult, ...]) -> str:
    verdicts = "".join(f'<option value="{v.value}">{v.value}</option>' for v in Verdict)
    sections = sorted({r.info.section for r in results}, key=section_key)
    options = "".join(
        f'<option value="{esc(s)}">{esc(section_label(s))}</option>' for s in sections
    )
    return (
        '<div class="filters"><input type="search" id="f-text" '
        'placeholder="filter by ID, title, requirement, message" aria-label="filter">'
        f'<select id="f-verdict" aria-label="verdict"><option value="">every verdict</option>'
        f"{verdicts}</select>"
        f'<select id="f-section" aria-label="section"><option value="">every section</option>'
        f'{options}</select><span id="f-count" class="muted"></span></div>'
    )


def _case_row(result: CaseResult) -> str:
    info = result.info
    search = " ".join([info.id, info.title, *info.requirements, result.message[:500]]).lower()
    return (
        f'<tr data-verdict="{result.verdict.value}" data-section="{esc(info.section)}" '
        f'data-search="{esc(search)}">'
        f'<td class="mono"><a href="#case-{esc(info.id)}">{esc(info.id)}</a></td>'
        f"<td>{esc(info.section)}</td><td>{info.level.value}</td>"
        f"<td>{verdict_badge(result.verdict)}</td><td>{esc(info.title)}</td>"
        f'<td class="mono small">{esc(" ".join(info.requirements))}</td>'
        f"<td>{result.duration:.3f}</td>"
        f'<td class="small">{esc(first_line(result.message, 160))}</td></tr>'
    )


def _case_table(results: tuple[CaseResult, ...]) -> str:
    head = "".join(
        f"<th>{name}</th>"
        for name in ("ID", "section", "level", "verdict", "title", "requirements", "s", "message")
    )
    rows = "".join(_case_row(r) for r in results)
    return (
        f'<section id="cases"><h2>Cases</h2>{_filters(results)}'
        f'<table class="filterable" id="case-table"><thead><tr>{head}</tr></thead>'
        f"<tbody>{rows}</tbody></table></section>"
    )


def _facts(result: CaseResult) -> str:
    """The definition list heading a case's details; values are HTML already."""
    info = result.info
    facts = [
        ("verdict", verdict_badge(result.verdict)),
        ("section", esc(section_label(info.section))),
        ("level", info.level.value),
        ("needs", esc(", ".join(sorted(info.needs)) or "—")),
        ("runs", "alone (serial)" if info.serial else "in parallel"),
        ("duration", f"{result.duration:.3f} s"),
    ]
    if result.expectation_reason:
        facts.append(("expectation", esc(result.expectation_reason)))
    facts += [(f"measured {name}", f"{value:g}") for name, value in result.measurements]
    return "<dl>" + "".join(f"<dt>{esc(k)}</dt><dd>{v}</dd>" for k, v in facts) + "</dl>"


def _detail(result: CaseResult) -> str:
    info = result.info
    reqs = "".join(
        f"<li><strong>{esc(rid)}</strong> ({esc(level)}) {esc(text)}</li>"
        for rid, level, text in requirement_sentences(info)
    )
    allowed = "".join(f"<li>{esc(text)}</li>" for text in info.allowed) or "<li>(not stated)</li>"
    parts = [
        f'<article class="case" id="case-{esc(info.id)}">',
        f"<h3>{verdict_badge(result.verdict)} {esc(info.id)} — {esc(info.title)}</h3>",
        f"{_facts(result)}<h4>Requirements</h4><ul>{reqs}</ul>",
        f"<h4>Allowed behaviours</h4><ul>{allowed}</ul>",
    ]
    if result.expected and result.expected != "\n".join(info.allowed):
        parts.append(f"<h4>Expected</h4><pre>{esc(result.expected)}</pre>")
    if result.message:
        parts.append(f"<h4>What happened</h4><pre>{esc(result.message)}</pre>")
    where = f", divergence at #{result.divergence}" if result.divergence is not None else ""
    parts += [
        f"<h4>Repro</h4><pre>{esc(result.repro)}</pre>",
        f"<h4>Trace ({len(result.trace)} entries{where})</h4>",
        '<p><button type="button" data-open="1">expand all</button> '
        '<button type="button" data-open="0">collapse all</button> '
        '<a href="#cases" class="small">back to the table</a></p>',
        trace_list(result.trace, result.divergence, f"case-{info.id}"),
        "</article>",
    ]
    return "".join(parts)


def render_report(record: RunRecord) -> str:
    """Render the HTML page of a run that started."""
    started = record.started
    if started is None:
        raise ValueError("no run started: there is nothing to report")
    summary = record.effective_summary()
    results = summary.results
    body = [
        _header(started, summary, record.complete),
        _summary(summary),
        _matrix(results),
        _case_table(results),
        '<section id="details"><h2>Details</h2>',
        *(_detail(r) for r in results),
        "</section>",
    ]
    return page(f"OpenAIR conformance: {started.target}", "\n".join(body))


class HtmlReporter(FileReporter):
    """Write the run as one HTML page to `path` when closed."""

    what = "HTML report"

    def render(self) -> bytes:
        """Return the file's bytes for the recorded run."""
        return render_report(self.record).encode("utf-8")
