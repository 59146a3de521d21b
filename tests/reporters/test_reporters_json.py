"""The JSON report: valid against its schema, round-trips the run exactly, refuses bad reports."""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from reporters_support import FAILING_ID, HOSTILE_TEXT, Artifacts

from openair_conformance.model import CaseFinished, Event, RunFinished, TraceEntry
from openair_conformance.reporters.jsonreport import (
    REPORT_FORMAT,
    JsonReporter,
    ReportError,
    decode_started,
    decode_summary,
    load_report,
    report_schema,
    schema_errors,
)


def _data(artifacts: Artifacts) -> dict[str, Any]:
    data: dict[str, Any] = json.loads(artifacts.json.read_text(encoding="utf-8"))
    return data


def test_the_report_follows_the_schema(artifacts: Artifacts) -> None:
    data = _data(artifacts)
    assert data["format"] == REPORT_FORMAT == "openair-conformance-report/1"
    assert schema_errors(data) == []
    jsonschema.Draft202012Validator.check_schema(report_schema())


def test_every_schema_violation_is_listed_with_its_path(artifacts: Artifacts) -> None:
    data = _data(artifacts)
    data["results"][0]["verdict"] = "maybe"
    data["results"][0]["surprise"] = 1
    del data["summary"]["counts"]
    problems = schema_errors(data)
    assert len(problems) == 3, problems
    assert any(p.startswith("/results/0/verdict: 'maybe' is not one of") for p in problems)
    assert any(p.startswith("/results/0: ") and "surprise" in p for p in problems)
    assert any(p.startswith("/summary: 'counts' is a required property") for p in problems)


def test_the_report_round_trips_the_run(artifacts: Artifacts) -> None:
    data = load_report(artifacts.json)
    assert decode_started(data) == artifacts.events[0]
    assert decode_summary(data) == artifacts.summary  # every result, trace included
    assert data["complete"] is True and data["summary"]["unfinished"] == []
    assert data["cases_selected"] == data["summary"]["total"] == len(data["results"])


def test_the_summary_holds_everything_the_console_shows(artifacts: Artifacts) -> None:
    summary = _data(artifacts)["summary"]
    assert summary["counts"]["fail"] == 1 and sum(summary["counts"].values()) == summary["total"]
    assert summary["vacuous"] == ["SYN-011"]
    assert [e.endswith("GONE-*") for e in summary["unknown_expectations"]] == [True]
    latencies = {item["name"]: item["value"] for item in summary["latencies"]}
    assert latencies["post_to_wakeup_p50_ms"] == 3.0 and "rtt_ms" in latencies
    sections = {row["section"]: row for row in summary["by_section"]}
    assert sections["6.7"]["title"].startswith("PING") and sections["9.1"]["counts"]["fail"] == 0


def test_text_is_kept_exactly_and_requirements_are_quoted(artifacts: Artifacts) -> None:
    failing = next(r for r in _data(artifacts)["results"] if r["id"] == FAILING_ID)
    assert failing["trace"][-1]["text"] == HOSTILE_TEXT
    assert failing["divergence"] == len(failing["trace"]) - 1
    assert failing["requirements"][0]["id"] == "OA-SESS-10"
    assert failing["requirements"][0]["text"].startswith("A PING MUST be answered")


def _with_finished(artifacts: Artifacts, change: Any) -> list[Event]:
    """The run's events with the failing case's result changed by `change(result)`."""
    events: list[Event] = []
    for event in artifacts.events:
        if isinstance(event, CaseFinished) and event.result.info.id == FAILING_ID:
            event = CaseFinished(result=change(event.result))
        elif isinstance(event, RunFinished):
            continue  # the run "stopped": the report is built from the CaseFinished events
        events.append(event)
    return events


def _write(events: list[Event], path: Path) -> dict[str, Any]:
    reporter = JsonReporter(path)
    for event in events:
        reporter.handle(event)
    reporter.close()
    return load_report(path)


def test_lone_surrogates_and_controls_survive(artifacts: Artifacts, tmp_path: Path) -> None:
    odd = "\ud800 \x00 \\ud800 \u2028 \U0001f600"
    entry = TraceEntry(t=0.5, conn="c", direction="in", tag="Message", text=odd)

    def change(result: Any) -> Any:
        return dataclasses.replace(result, trace=(*result.trace, entry), message=odd)

    data = _write(_with_finished(artifacts, change), tmp_path / "r.json")
    failing = decode_summary(data).results
    found = next(r for r in failing if r.info.id == FAILING_ID)
    assert found.trace[-1] == entry and found.message == odd


def test_non_finite_numbers_become_null(artifacts: Artifacts, tmp_path: Path) -> None:
    def change(result: Any) -> Any:
        return dataclasses.replace(result, measurements=(("x", math.inf), ("y", math.nan)))

    data = _write(_with_finished(artifacts, change), tmp_path / "r.json")
    failing = next(r for r in data["results"] if r["id"] == FAILING_ID)
    assert failing["measurements"] == [{"name": "x", "value": None}, {"name": "y", "value": None}]


@pytest.mark.parametrize(
    ("content", "complaint"),
    [
        (b"\xff\xfe", "not a JSON document"),
        (b"{", "not a JSON document"),
        (b"[]", "not an openair-conformance-report/1 report"),
        (b'{"format": "junit"}', "format 'junit'"),
        (b'{"format": "openair-conformance-report/1"}', "does not follow the report schema"),
    ],
)
def test_bad_reports_are_refused_clearly(tmp_path: Path, content: bytes, complaint: str) -> None:
    path = tmp_path / "bad.json"
    path.write_bytes(content)
    with pytest.raises(ReportError, match=complaint):
        load_report(path)


def test_schema_violations_and_nan_are_refused(artifacts: Artifacts, tmp_path: Path) -> None:
    data = _data(artifacts)
    data["results"][0]["verdict"] = "maybe"
    data["results"][1]["trace"][0]["direction"] = "sideways"
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ReportError) as caught:
        load_report(path)
    assert "/results/0/verdict" in str(caught.value)
    assert "/results/1/trace/0/direction" in str(caught.value)
    text = re.sub(r'"duration_s": [-+.0-9eE]+', '"duration_s": NaN', artifacts.json.read_text())
    path.write_text(text)
    with pytest.raises(ReportError, match="NaN"):
        load_report(path)
    with pytest.raises(ReportError, match="cannot read"):
        load_report(tmp_path / "missing.json")
