"""The console reporter: lines per case, the summary, failure details, progress and colour rules."""

from __future__ import annotations

import io
import re

import pytest
from reporters_support import FAILING_EXPECTED, FAILING_ID, SYNTHETIC, Artifacts

from openair_conformance.model import CaseFinished, Event, RunStarted
from openair_conformance.reporters.console import ConsoleReporter

_SGR = re.compile(r"\x1b\[[0-9;]*m")


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def _feed(reporter: ConsoleReporter, events: tuple[Event, ...]) -> None:
    for event in events:
        reporter.handle(event)
    reporter.close()


def _failure_block(text: str) -> str:
    start = text.index(f"FAIL  {FAILING_ID}")
    return text[start : text.index("repro:", start) + 200]


def test_plain_output_has_a_line_per_case_and_no_escapes(artifacts: Artifacts) -> None:
    text = artifacts.console
    assert "\x1b" not in text and "\r" not in text
    for result in artifacts.summary.results:
        line = f"{result.verdict.value:<16} {result.info.id:<10} {result.info.title}"
        assert sum(1 for row in text.splitlines() if row.startswith(line)) == 1


def test_the_summary_by_section_totals_and_latencies(artifacts: Artifacts) -> None:
    text = artifacts.console
    sections = text[text.index("Results by spec section") :].splitlines()[1:4]
    assert [row.split()[0] for row in sections] == ["6.7", "8.5", "9.1"]
    assert "pass 1 · fail 1 · timing 1 · inconclusive 1 · error 1" in sections[0]
    assert "post→wakeup p50 3.00 ms, p99 3.00 ms (2 samples)" in text
    assert "SYN-011  vacuous: nothing to compare" in text  # inconclusive (OA-GEN-7)
    assert "fail threshold" in text  # the legend of timing (OA-GEN-6)
    assert "GONE-*" in text.split("expectations that match no case (1):")[1]
    assert text.rstrip().splitlines()[-1].startswith(f"{len(SYNTHETIC)} case(s) in ")


def test_a_failure_shows_requirements_expectation_trace_and_repro(artifacts: Artifacts) -> None:
    block = _failure_block(artifacts.console)
    assert "OA-SESS-10 (MUST):" in block
    assert "A PING MUST be answered PING_SUCCESS by every addressee" in block
    assert FAILING_EXPECTED in block and "PING was answered with a hostile frame" in block
    started = artifacts.events[0]
    assert isinstance(started, RunStarted)
    assert f"repro: openair conform {started.target} --case {FAILING_ID}" in block
    # The excerpt: the last ten entries up to the divergence, both directions, with times.
    assert "trace #6–#15 of 16 (up to the divergence)" in block
    assert "step 5" not in block and "step 6" in block
    assert re.search(r"#13 \+\d+\.\d{3} s → raw#1 Message", block)
    assert re.search(r"#14 \+\d+\.\d{3} s ← raw#1 Message", block)
    assert re.search(r"▶ #15 \+\d+\.\d{3} s ← primary Message", block)
    assert "\\x1b[31mred\\x00\\xff" in block  # the terminal escape is shown, not obeyed


def test_every_problem_is_detailed(artifacts: Artifacts) -> None:
    # SYN-011 passed vacuously: inconclusive (OA-GEN-7), so a problem too.
    problems = artifacts.console.split("Problems (7)")[1]
    for case_id in ("SYN-002", "SYN-003", "SYN-006", "SYN-007", "SYN-008", "SYN-010", "SYN-011"):
        assert f"--case {case_id}" in problems
    for case_id in ("SYN-001", "SYN-004", "SYN-005", "SYN-009"):
        assert f"--case {case_id}" not in problems
    assert "ZeroDivisionError: bug" in problems and "expectation: fixed since" in problems


def test_a_terminal_gets_progress_and_colour(
    artifacts: Artifacts, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("NO_COLOR", raising=False)
    stream = _Tty()
    _feed(ConsoleReporter(stream, False, width=120), artifacts.events)
    text = stream.getvalue()
    assert f"\r[{len(SYNTHETIC)}/{len(SYNTHETIC)}] " + "█" * 20 + " 100%" in text
    assert "\x1b[1;31mfail" in text and _SGR.search(text)
    plain = _SGR.sub("", text)
    assert f"pass             {SYNTHETIC[0].info.id}" not in plain  # passes only count
    assert "fail             SYN-002" in plain
    # The progress line is cleared before the summary, and not drawn again.
    last = plain.rindex("\r[")
    assert plain.index("\r\x1b[K", last) < plain.index("Results by spec section") > last
    assert plain.endswith("\n")


def test_no_color_is_respected_on_a_terminal(
    artifacts: Artifacts, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("NO_COLOR", "1")
    stream = _Tty()
    _feed(ConsoleReporter(stream, False), artifacts.events)
    text = stream.getvalue()
    assert not _SGR.search(text) and "\r[" in text


def test_verbose_shows_every_trace_in_full(artifacts: Artifacts) -> None:
    stream = _Tty()
    _feed(ConsoleReporter(stream, True, color=False), artifacts.events)
    text = stream.getvalue()
    assert "\r" not in text  # verbose output is line by line, also on a terminal
    before = text.split("Results by spec section")[0]
    assert "step 0" in before and "soft" in before  # the whole trace and the message


def test_a_terminal_that_cannot_show_unicode_gets_escapes(artifacts: Artifacts) -> None:
    raw = io.BytesIO()
    stream = io.TextIOWrapper(raw, encoding="ascii")
    _feed(ConsoleReporter(stream, False), artifacts.events)
    text = raw.getvalue().decode("ascii")
    assert "\\u2192 raw#1 Message" in text and "Results by spec section" in text


def test_the_header_describes_the_target(artifacts: Artifacts) -> None:
    first = [e for e in artifacts.events if not isinstance(e, CaseFinished)][:1]
    stream = io.StringIO()
    _feed(ConsoleReporter(stream, False), tuple(first))
    text = stream.getvalue()
    assert "server fake/0 (OpenAIR/1.0); extensions: pipelining" in text
    assert f"{len(SYNTHETIC)} case(s), jobs 3" in text
    assert "stopped before every case was judged" in text
