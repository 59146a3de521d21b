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

from markupsafe import Markup

from openair_conformance.model import CaseResult, Verdict
from openair_conformance.reporters._common import (
    first_line,
    format_time,
    section_key,
    write_atomic,
)
from openair_conformance.reporters._templating import render
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


def _report_rows(columns: Sequence[Column]) -> list[tuple[str, list[object]]]:
    def data(*keys: str) -> list[object]:
        values: list[object] = []
        for column in columns:
            value: Any = column.data
            for key in keys:
                value = value[key]
            values.append(value)
        return values

    no = Markup("<strong>no</strong>")
    return [
        ("report", [Markup("<code>{}</code>").format(c.path.name) for c in columns]),
        ("target", data("target")),
        ("server", data("server", "server")),
        ("protocol", data("server", "protocol")),
        ("legacy", ["yes" if c.data["server"]["legacy"] else "no" for c in columns]),
        ("started", [format_time(c.data["started"]) for c in columns]),
        ("complete", ["yes" if c.data["complete"] else no for c in columns]),
        ("cases", [len(c.results) for c in columns]),
    ]


def _verdict_rows(columns: Sequence[Column]) -> list[tuple[Verdict, list[int]]]:
    rows = []
    for verdict in Verdict:
        counts = [c.data["summary"]["counts"][verdict.value] for c in columns]
        if any(counts):
            rows.append((verdict, counts))
    return rows


def _case_rows(columns: Sequence[Column]) -> list[dict[str, Any]]:
    infos = {}
    for column in reversed(columns):  # the first report's title wins
        infos.update({cid: result.info for cid, result in column.results.items()})
    order = sorted(infos, key=lambda cid: (section_key(infos[cid].section), cid))
    rows = []
    for cid in order:
        info = infos[cid]
        found = [column.results.get(cid) for column in columns]
        values = {r.verdict.value if r is not None else "" for r in found}
        differs = len(values) > 1
        first = found[0].verdict.value if found[0] is not None else ""
        cells = [
            {
                "result": r,
                "delta": differs and (r is None or r.verdict.value != first),
                "tip": "" if r is None else first_line(r.message, 300) or r.verdict.value,
            }
            for r in found
        ]
        search = " ".join([cid, info.title, *info.requirements]).lower()
        rows.append({"info": info, "differs": differs, "cells": cells, "search": search})
    return rows


def comparison_page(columns: Sequence[Column]) -> str:
    """Render the comparison of the given reports."""
    rows = _case_rows(columns)
    return render(
        "compare.html",
        title="OpenAIR conformance comparison",
        columns=columns,
        labels=_labels(columns),
        report_rows=_report_rows(columns),
        verdict_rows=_verdict_rows(columns),
        rows=rows,
        differing=sum(row["differs"] for row in rows),
    )


def write_comparison(reports: Sequence[Path | str], output: Path | str) -> None:
    """Read the JSON reports and write their comparison as one HTML page to `output`.

    Raises ReportError (a ValueError) naming the report that cannot be read.
    """
    if not reports:
        raise ReportError("no report to compare")
    columns = [read_column(Path(path)) for path in reports]
    write_atomic(Path(output), comparison_page(columns).encode("utf-8"), "comparison page")
