"""What every reporter shares: safe text, excerpts, sections, closing without events."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from lxml import etree
from reporters_support import FAILING_ID, SYNTHETIC, Artifacts

from openair_conformance.model import (
    CaseFinished,
    CaseResult,
    CaseStarted,
    Reporter,
    RunFinished,
    RunStarted,
    TraceEntry,
    Verdict,
)
from openair_conformance.reporters._common import (
    RunRecord,
    excerpt,
    safe_text,
    section_label,
    write_atomic,
)
from openair_conformance.reporters.console import ConsoleReporter
from openair_conformance.reporters.html import HtmlReporter
from openair_conformance.reporters.jsonreport import JsonReporter, load_report
from openair_conformance.reporters.junit import JUnitReporter


def test_every_reporter_was_closed_once_and_saw_the_whole_run(artifacts: Artifacts) -> None:
    assert artifacts.closes == 1
    assert isinstance(artifacts.events[0], RunStarted)
    assert isinstance(artifacts.events[-1], RunFinished)
    assert artifacts.summary.total == len(SYNTHETIC)
    assert all(path.exists() for path in (artifacts.junit, artifacts.json, artifacts.html))


def test_close_without_events_writes_nothing_and_says_nothing(tmp_path: Path) -> None:
    stream = io.StringIO()
    files = [tmp_path / "a.xml", tmp_path / "b.json", tmp_path / "c.html"]
    reporters: list[Reporter] = [
        ConsoleReporter(stream, True),
        JUnitReporter(files[0]),
        JsonReporter(files[1]),
        HtmlReporter(files[2]),
    ]
    for reporter in reporters:
        reporter.close()
        reporter.close()  # a second close is harmless
    assert stream.getvalue() == ""
    assert [path.exists() for path in files] == [False, False, False]


def test_a_run_that_stops_early_is_reported_as_incomplete(
    artifacts: Artifacts, tmp_path: Path
) -> None:
    # Everything up to the third CaseFinished, then close(): the run was interrupted.
    cut = [i for i, e in enumerate(artifacts.events) if isinstance(e, CaseFinished)][2]
    events = artifacts.events[: cut + 1]
    json_reporter, stream = JsonReporter(tmp_path / "r.json"), io.StringIO()
    console = ConsoleReporter(stream, False)
    for event in events:
        json_reporter.handle(event)
        console.handle(event)
    json_reporter.close()
    console.close()
    data = load_report(tmp_path / "r.json")
    assert data["complete"] is False
    assert len(data["results"]) == data["summary"]["total"] == 3
    started = {e.info.id for e in events if isinstance(e, CaseStarted)}
    finished = {e.result.info.id for e in events if isinstance(e, CaseFinished)}
    assert data["summary"]["unfinished"] == sorted(started - finished)
    assert "stopped before every case was judged" in stream.getvalue()


def test_an_unwritable_path_is_reported_not_raised(
    artifacts: Artifacts, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    reporter = JUnitReporter(blocker / "sub" / "junit.xml")  # a file is in the way
    for event in artifacts.events:
        reporter.handle(event)
    reporter.close()
    assert not reporter.written and reporter.failed
    assert "could not write the JUnit report" in capsys.readouterr().err


def test_write_atomic_replaces_and_leaves_no_temporary_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "deep" / "out.txt"
    write_atomic(target, b"one", "test file")
    assert (
        capsys.readouterr().err == f"note: created the folder {target.parent} for the test file\n"
    )
    write_atomic(target, b"two")
    assert capsys.readouterr().err == ""  # the folder exists now: nothing to say
    assert target.read_bytes() == b"two"
    assert sorted(p.name for p in target.parent.iterdir()) == ["out.txt"]


def test_safe_text_neutralises_controls_and_keeps_the_rest() -> None:
    assert safe_text("a\tb\nc") == "a\tb\nc"
    assert safe_text("\x1b[31m\x00\r\x7f\x85") == "\\x1b[31m\\x00\\x0d\\x7f\\x85"
    assert safe_text("\u202eevil\ud800") == "\\u202eevil\\ud800"
    assert safe_text("Grüße → ü") == "Grüße → ü"


@given(st.text())
def test_safe_text_is_always_valid_xml_text(text: str) -> None:
    element = etree.Element("x")
    element.text = safe_text(text)  # lxml refuses text XML cannot hold
    assert "\x1b" not in etree.tostring(element, encoding="unicode")


def _result(n: int, divergence: int | None) -> CaseResult:
    entries = tuple(
        TraceEntry(t=i / 10, conn="c", direction="note", tag="", text=str(i)) for i in range(n)
    )
    info = SYNTHETIC[0].info
    return CaseResult(info=info, verdict=Verdict.FAIL, trace=entries, divergence=divergence)


def test_excerpt_ends_at_the_divergence() -> None:
    start, entries = excerpt(_result(30, 14))
    assert (start, [e.text for e in entries]) == (5, [str(i) for i in range(5, 15)])
    start, entries = excerpt(_result(30, 2))
    assert (start, len(entries)) == (0, 3)


def test_excerpt_without_a_usable_divergence_is_the_end_of_the_trace() -> None:
    for divergence in (None, 99, -1):
        start, entries = excerpt(_result(25, divergence))
        assert (start, entries[-1].text) == (15, "24")
    assert excerpt(_result(0, None)) == (0, ())


def test_sections_are_labelled_with_the_spec_headings() -> None:
    assert section_label("6.7").startswith("6.7 PING")
    assert section_label("99.1") == "99.1"


def test_run_record_prefers_the_summary_and_orders_results(artifacts: Artifacts) -> None:
    record = RunRecord()
    for event in reversed(artifacts.events[1:-1]):
        record.handle(event)
    ids = [r.info.id for r in record.results()]
    assert ids == sorted(ids) and FAILING_ID in ids and not record.complete
    record.handle(artifacts.events[-1])
    assert record.complete and record.effective_summary() == artifacts.summary
