"""The HTML reporter: one self-contained page that opens on the verdict matrix.

The page (`templates/report.html`) starts with a one-line summary and the matrix of spec
sections × verdicts, whose cells filter the case table (as Autobahn's report opens on its
matrix); then the summary (latencies, vacuous passes, expectations matching no case), the run
(target, server, date, options), a filterable case table, and a detail section per case
(anchor `case-<ID>`). A case that is not a pass (`DETAILED` verdicts) shows the requirement
sentences, the allowed behaviours, the message, the repro line and the full frame trace, each
entry collapsible. With `traces="failing"` (what `openair conform` asks for unless given
`--html-traces all`) a passing case gets a short section without its trace, which keeps the page
of an all-pass run small (the JSON report keeps every trace); with `traces="all"` (the default
of the class: a program gets the whole evidence unless it asks otherwise) every trace is in.
Each death of the target (`RunSummary.target_deaths`) is a banner at the top, with the cases
never run after it; a result during which the target died, or that was run again after a
restart, is marked. The file is written when the reporter is closed; nothing is written when
no run started.
`write_comparison` (from `_compare`) renders several JSON reports side by side.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from openair_conformance.model import CaseResult, RunStarted, RunSummary, Verdict
from openair_conformance.registry import requirement_sentences
from openair_conformance.reporters._common import (
    DETAILED,
    FileReporter,
    RunRecord,
    by_section,
    first_line,
    format_time,
    section_label,
)
from openair_conformance.reporters._compare import write_comparison
from openair_conformance.reporters._templating import render

__all__ = ["TRACES", "HtmlReporter", "render_report", "write_comparison"]

#: What `traces` may be: the traces of the results that are not passes, or every trace.
TRACES = ("failing", "all")


def _run_rows(started: RunStarted, summary: RunSummary) -> list[tuple[str, str]]:
    server = started.server
    limits = ", ".join(f"{name} = {value}" for name, value in server.limits)
    return [
        ("target", started.target),
        ("server", server.server or "(not named)"),
        ("protocol", server.protocol or "—"),
        ("legacy server", "yes (core only, OA-CAP-2)" if server.legacy else "no"),
        ("extensions", ", ".join(server.capabilities) or "none"),
        ("limits", limits or "none advertised"),
        ("round-trip time", f"{server.rtt_ms:.3f} ms"),
        ("started", format_time(started.started)),
        ("duration", f"{summary.duration:.1f} s"),
        ("cases selected", str(started.cases)),
    ]


def _matrix(results: tuple[CaseResult, ...]) -> tuple[list[dict[str, Any]], dict[Verdict, int]]:
    rows = []
    totals = dict.fromkeys(Verdict, 0)
    for section, counts in by_section(results).items():
        for verdict, n in counts.items():
            totals[verdict] += n
        label = section_label(section)
        rows.append(
            {"section": section, "label": label, "counts": counts, "total": sum(counts.values())}
        )
    return rows, totals


def _case(result: CaseResult, traces: str) -> dict[str, Any]:
    """What the templates show of one result."""
    info = result.info
    search = " ".join([info.id, info.title, *info.requirements, result.message[:500]]).lower()
    return {
        "result": result,
        "brief": traces == "failing" and result.verdict not in DETAILED,
        "section": section_label(info.section),
        "requirements": requirement_sentences(info),
        "search": search,
        "headline": first_line(result.message, 160),
        "died": bool(getattr(result, "target_died", False)),
        "rerun": bool(getattr(result, "rerun_after_restart", False)),
    }


def render_report(record: RunRecord, traces: str = "all") -> str:
    """Render the HTML page of a run that started (`traces`: "failing" or "all")."""
    started = record.started
    if started is None:
        raise ValueError("no run started: there is nothing to report")
    if traces not in TRACES:
        raise ValueError(f"traces must be one of {', '.join(TRACES)}, not {traces!r}")
    summary = record.effective_summary()
    cases = [_case(r, traces) for r in summary.results]
    matrix, totals = _matrix(summary.results)
    return render(
        "report.html",
        title=f"OpenAIR conformance: {started.target}",
        started=started,
        summary=summary,
        complete=record.complete,
        matrix=matrix,
        totals=totals,
        cases=cases,
        deaths=getattr(summary, "target_deaths", ()),
        not_run=getattr(summary, "not_run", ()),
        messages={r.info.id: r.message for r in summary.results},
        run_rows=_run_rows(started, summary),
    )


class HtmlReporter(FileReporter):
    """Write the run as one HTML page to `path` when closed."""

    what = "HTML report"

    def __init__(self, path: Path | str, traces: str = "all") -> None:
        if traces not in TRACES:
            raise ValueError(f"traces must be one of {', '.join(TRACES)}, not {traces!r}")
        super().__init__(path)
        self.traces = traces

    def render(self) -> bytes:
        """Return the file's bytes for the recorded run."""
        return render_report(self.record, self.traces).encode("utf-8")
