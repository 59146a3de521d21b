"""The comparison page: several JSON reports side by side, implementations as columns.

`write_comparison(reports, output)` reads each report (checked against the schema), then writes
one self-contained HTML page: what each report is (server, target, date, counts), a table of
verdict counts, and a row per case with one coloured verdict cell per implementation. A row
whose verdicts differ (a case missing from a report counts as different) is highlighted, and so
is each cell that differs from the first report's; a checkbox shows only those rows.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from openair_conformance.model import CaseResult, Verdict
from openair_conformance.reporters._common import (
    first_line,
    format_time,
    section_key,
    write_atomic,
)
from openair_conformance.reporters._htmlkit import esc, page, verdict_badge
from openair_conformance.reporters.jsonreport import ReportError, decode_result, load_report

__all__ = ["Column", "comparison_page", "read_column", "write_comparison"]


@dataclass(frozen=True, slots=True, kw_only=True)
class Column:
    """One report of the comparison."""

    label: str
    path: Path
    data: dict[str, Any]
    results: dict[str, CaseResult]


def read_column(path: Path) -> Column:
    """Read one report; ReportError if it cannot be read or does not follow the schema."""
    data = load_report(path)
    try:
        results = {item["id"]: decode_result(item) for item in data["results"]}
    except ValueError as exc:  # schema-valid but not a valid case (e.g. a two-line title)
        raise ReportError(f"{path}: {exc}") from exc
    label = data["server"]["server"] or data["target"]
    return Column(label=label, path=path, data=data, results=results)


def _labels(columns: Sequence[Column]) -> list[str]:
    """The column labels, numbered where two reports name the same implementation."""
    seen: dict[str, int] = {}
    for column in columns:
        seen[column.label] = seen.get(column.label, 0) + 1
    counter: dict[str, int] = {}
    labels = []
    for column in columns:
        if seen[column.label] > 1:
            counter[column.label] = counter.get(column.label, 0) + 1
            labels.append(f"{column.label} #{counter[column.label]}")
        else:
            labels.append(column.label)
    return labels


def _reports_table(columns: Sequence[Column], labels: list[str]) -> str:
    def row(name: str, cells: list[str]) -> str:
        return f"<tr><th>{esc(name)}</th>{''.join(f'<td>{c}</td>' for c in cells)}</tr>"

    def data(*keys: str) -> list[str]:
        values = []
        for column in columns:
            value: Any = column.data
            for key in keys:
                value = value[key]
            values.append(esc(value))
        return values

    head = "".join(f"<th>{esc(label)}</th>" for label in labels)
    rows = [
        row("report", [f"<code>{esc(c.path.name)}</code>" for c in columns]),
        row("target", data("target")),
        row("server", data("server", "server")),
        row("protocol", data("server", "protocol")),
        row("legacy", ["yes" if c.data["server"]["legacy"] else "no" for c in columns]),
        row("started", [esc(format_time(c.data["started"])) for c in columns]),
        row("complete", ["yes" if c.data["complete"] else "<strong>no</strong>" for c in columns]),
        row("cases", [str(len(c.results)) for c in columns]),
    ]
    for verdict in Verdict:
        counts = [c.data["summary"]["counts"][verdict.value] for c in columns]
        if any(counts):
            row_cells = [verdict_badge(verdict, str(n)) if n else "0" for n in counts]
            rows.append(row(verdict.value, row_cells))
    return (
        '<section id="reports"><h2>Reports</h2><table class="kv">'
        f"<thead><tr><th></th>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table></section>"
    )


def _cell(result: CaseResult | None, reference: str | None) -> str:
    if result is None:
        delta = " delta" if reference is not None else ""
        return f'<td class="missing{delta}" title="not in this report">—</td>'
    value = result.verdict.value
    delta = " delta" if reference is not None and value != reference else ""
    tip = esc(first_line(result.message, 300) or value)
    return f'<td class="v-{value}{delta}" title="{tip}">{verdict_badge(result.verdict)}</td>'


def _case_rows(columns: Sequence[Column]) -> tuple[str, int]:
    infos = {}
    for column in reversed(columns):  # the first report's title wins
        infos.update({cid: result.info for cid, result in column.results.items()})
    order = sorted(infos, key=lambda cid: (section_key(infos[cid].section), cid))
    rows, differing = [], 0
    for cid in order:
        info = infos[cid]
        found = [column.results.get(cid) for column in columns]
        values = {r.verdict.value if r is not None else "" for r in found}
        differs = len(values) > 1
        differing += differs
        first = found[0].verdict.value if found[0] is not None else ""
        cells = "".join(_cell(r, first if differs else None) for r in found)
        search = " ".join([cid, info.title, *info.requirements]).lower()
        rows.append(
            f'<tr class="{"differs" if differs else "same"}" data-section="{esc(info.section)}" '
            f'data-search="{esc(search)}"><td class="mono">{esc(cid)}</td>'
            f"<td>{esc(info.section)}</td><td>{esc(info.title)}</td>{cells}</tr>"
        )
    return "".join(rows), differing


def comparison_page(columns: Sequence[Column]) -> str:
    """Render the comparison of the given reports."""
    labels = _labels(columns)
    rows, differing = _case_rows(columns)
    head = "".join(f"<th>{esc(label)}</th>" for label in labels)
    body = (
        "<header><h1>OpenAIR conformance: comparison of "
        f"{len(columns)} report(s)</h1></header>"
        f"{_reports_table(columns, labels)}"
        f'<section id="cases"><h2>Cases</h2><p>{differing} case(s) with differing verdicts.</p>'
        '<div class="filters"><input type="search" id="f-text" aria-label="filter" '
        'placeholder="filter by ID, title, requirement">'
        '<label><input type="checkbox" id="f-diff"> only cases whose verdicts differ</label>'
        '<span id="f-count" class="muted"></span></div>'
        '<table class="filterable" id="compare-table"><thead><tr><th>ID</th><th>section</th>'
        f"<th>title</th>{head}</tr></thead><tbody>{rows}</tbody></table></section>"
    )
    return page("OpenAIR conformance comparison", body)


def write_comparison(reports: Sequence[Path | str], output: Path | str) -> None:
    """Read the JSON reports and write their comparison as one HTML page to `output`.

    Raises ReportError (a ValueError) naming the report that cannot be read.
    """
    if not reports:
        raise ReportError("no report to compare")
    columns = [read_column(Path(path)) for path in reports]
    write_atomic(Path(output), comparison_page(columns).encode("utf-8"))
