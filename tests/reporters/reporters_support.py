"""Support for the reporter tests: synthetic cases covering every verdict, and one engine run.

The cases (as in tests/conformance/test_engine_run.py) cover every verdict across three spec
sections, with real frames in the traces (a PING round trip against FakeServer) and a hostile
frame (markup, a terminal escape, NUL, invalid UTF-8) in the failing case's trace. FakeServer,
ServerThread and Recorder come from tests/conformance/test_engine_support.py.
"""

from __future__ import annotations

import asyncio
import io
import sys
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "conformance"))

from test_engine_support import FakeServer, Recorder, ServerThread

from openair.protocol.message import Message
from openair_conformance.engine import RunOptions, run
from openair_conformance.harness import CaseContext
from openair_conformance.model import (
    CaseInfo,
    Event,
    Fail,
    Inconclusive,
    Level,
    Reporter,
    RunSummary,
    Timing,
)
from openair_conformance.registry import CaseFn, RegisteredCase
from openair_conformance.reporters.console import ConsoleReporter
from openair_conformance.reporters.html import HtmlReporter
from openair_conformance.reporters.jsonreport import JsonReporter
from openair_conformance.reporters.junit import JUnitReporter

__all__ = ["FakeServer", "ServerThread"]

#: The frame the failing case "receives": markup, a terminal escape, NUL, invalid UTF-8.
HOSTILE = b"<script>alert('x')</script></pre><b>\x1b[31mred\x00\xff</b>]]>"
HOSTILE_TEXT = HOSTILE.decode("utf-8", errors="backslashreplace")
FAILING_ID = "SYN-002"
FAILING_MESSAGE = "PING was answered with a hostile frame"
FAILING_EXPECTED = "PING_SUCCESS (OA-SESS-10)"


def _case(
    case_id: str,
    fn: CaseFn,
    *,
    section: str = "6.7",
    level: Level = Level.MUST,
    requirements: tuple[str, ...] = ("OA-SESS-10",),
    needs: tuple[str, ...] = (),
) -> RegisteredCase:
    info = CaseInfo(
        id=case_id,
        title=f"synthetic {case_id} <i>title</i>",
        section=section,
        requirements=requirements,
        level=level,
        needs=frozenset(needs),
        allowed=(f"behaviour allowed for {case_id}",),
    )
    return RegisteredCase(info=info, fn=fn)


async def _ping(ctx: CaseContext) -> None:
    raw = await ctx.raw()
    await raw.send_message(Message(type="PING", sender=ctx.name("P"), to="CNS"))
    await raw.read_message()


async def _passes(ctx: CaseContext) -> None:
    await _ping(ctx)
    ctx.measure("post_to_wakeup_ms", 3.0)


async def _fails_hostile(ctx: CaseContext) -> None:
    for n in range(12):  # more entries than an excerpt shows
        ctx.note(f"step {n}")
    await _ping(ctx)
    ctx.trace.frame("primary", "in", "Message", HOSTILE)
    ctx.fail(FAILING_MESSAGE, expected=FAILING_EXPECTED)


def _raising(exc: BaseException) -> CaseFn:
    async def fn(ctx: CaseContext) -> None:
        ctx.note("about to finish")
        raise exc

    return fn


async def _vacuous(ctx: CaseContext) -> None:
    ctx.vacuous("nothing to compare")


SYNTHETIC = [
    _case("SYN-001", _passes),
    _case(FAILING_ID, _fails_hostile),
    _case("SYN-003", _raising(Fail("soft")), section="8.5", level=Level.SHOULD),
    _case("SYN-004", _raising(Fail("maybe")), section="8.5", level=Level.MAY),
    _case("SYN-005", _passes, section="9.1", needs=("noreply",)),
    _case("SYN-006", _raising(Timing("late by 2 s"))),
    _case("SYN-007", _raising(ZeroDivisionError("bug"))),
    _case("SYN-008", _raising(Inconclusive("BIND refused"))),
    _case("SYN-009", _raising(Fail("known")), section="9.1"),
    _case("SYN-010", _passes, section="9.1"),
    _case("SYN-011", _vacuous, section="8.5"),
]

EXPECTATIONS = (
    '<expectations implementation="fake">'
    '<expect case="SYN-009" verdict="fail" reason="known bug" deviation="DEV-1"/>'
    '<expect case="SYN-010" verdict="fail" reason="fixed since"/>'
    '<expect case="GONE-*" verdict="fail" reason="stale"/>'
    "</expectations>"
)


@dataclass(frozen=True, slots=True, kw_only=True)
class Artifacts:
    """What the run left: the events, the summary, the files and the console output."""

    events: tuple[Event, ...]
    summary: RunSummary
    junit: Path
    json: Path
    html: Path
    console: str
    closes: int


def run_all_reporters(target: tuple[str, int], folder: Path) -> Artifacts:
    """Run the synthetic cases once against `target`, with every reporter attached."""
    expectations = folder / "fake.xml"
    expectations.write_text(EXPECTATIONS)
    stream = io.StringIO()
    recorder = Recorder()
    out = folder / "out"
    reporters: list[Reporter] = [
        ConsoleReporter(stream, False),
        JUnitReporter(out / "junit.xml"),
        JsonReporter(out / "report.json"),
        HtmlReporter(out / "report.html", traces="failing"),  # as `openair conform` does
        recorder,
    ]
    options = RunOptions(target=target, jobs=3, expectations=expectations)
    summary = asyncio.run(run(options, reporters, cases=SYNTHETIC))
    return Artifacts(
        events=tuple(recorder.events),
        summary=summary,
        junit=out / "junit.xml",
        json=out / "report.json",
        html=out / "report.html",
        console=stream.getvalue(),
        closes=recorder.closed,
    )
