"""The engine end to end with synthetic cases: events, verdicts, scheduling, expectations."""

from __future__ import annotations

import asyncio
import socket
from collections.abc import Sequence
from pathlib import Path

import pytest
from test_engine_support import Recorder

from openair_conformance.engine import NoCasesSelected, RunOptions, TargetUnreachable, run
from openair_conformance.expectations import ExpectationError
from openair_conformance.harness import CaseContext
from openair_conformance.model import (
    CaseFinished,
    CaseInfo,
    CaseResult,
    CaseStarted,
    Fail,
    Inconclusive,
    Level,
    NotApplicable,
    RunFinished,
    RunStarted,
    RunSummary,
    Timing,
    Verdict,
)
from openair_conformance.registry import CaseFn, RegisteredCase


def _case(
    case_id: str,
    fn: CaseFn,
    *,
    level: Level = Level.MUST,
    needs: Sequence[str] = (),
    serial: bool = False,
    requirements: tuple[str, ...] = ("OA-SESS-10",),
) -> RegisteredCase:
    info = CaseInfo(
        id=case_id,
        title=f"synthetic {case_id}",
        section="6.7",
        requirements=requirements,
        level=level,
        needs=frozenset(needs),
        serial=serial,
        allowed=("anything",),
    )
    return RegisteredCase(info=info, fn=fn)


def _raising(exc: BaseException) -> CaseFn:
    async def fn(ctx: CaseContext) -> None:
        ctx.note("about to finish")
        raise exc

    return fn


async def _passes(ctx: CaseContext) -> None:
    ctx.measure("post_to_wakeup_ms", 2.0)


def _run(
    target: tuple[str, int],
    cases: Sequence[RegisteredCase],
    recorder: Recorder | None = None,
    **options: object,
) -> RunSummary:
    opts = RunOptions(target=target, **options)  # type: ignore[arg-type]
    return asyncio.run(run(opts, [recorder] if recorder else [], cases=list(cases)))


def _by_id(summary: RunSummary) -> dict[str, CaseResult]:
    return {r.info.id: r for r in summary.results}


def test_each_outcome_becomes_its_verdict(fake_target: tuple[str, int], recorder: Recorder) -> None:
    cases = [
        _case("SYN-001", _passes),
        _case("SYN-002", _raising(Fail("broke", expected="PING_SUCCESS"))),
        _case("SYN-003", _raising(Fail("soft")), level=Level.SHOULD),
        _case("SYN-004", _raising(Fail("meh")), level=Level.MAY),
        _case("SYN-005", _raising(Timing("late"))),
        _case("SYN-006", _raising(Inconclusive("refused"))),
        _case("SYN-007", _raising(NotApplicable("no"))),
        _case("SYN-008", _raising(ZeroDivisionError("bug"))),
    ]
    summary = _run(fake_target, cases, recorder, timeout_scale=2.0)
    verdicts = {k: r.verdict for k, r in _by_id(summary).items()}
    assert verdicts == {
        "SYN-001": Verdict.PASS,
        "SYN-002": Verdict.FAIL,
        "SYN-003": Verdict.PASS_NONSTRICT,
        "SYN-004": Verdict.INFORMATIONAL,
        "SYN-005": Verdict.TIMING,
        "SYN-006": Verdict.INCONCLUSIVE,
        "SYN-007": Verdict.NOT_APPLICABLE,
        "SYN-008": Verdict.ERROR,
    }
    failed = _by_id(summary)["SYN-002"]
    assert (failed.message, failed.expected, failed.divergence) == ("broke", "PING_SUCCESS", 0)
    assert failed.trace[0].text == "about to finish"
    assert failed.repro.endswith("--case SYN-002 --timeout-scale 2")
    assert "ZeroDivisionError" in _by_id(summary)["SYN-008"].message
    assert summary.total == 8 and summary.count(Verdict.PASS) == 1
    assert dict(summary.latencies)["post_to_wakeup_p50_ms"] == 2.0


def test_events_arrive_in_order_and_reporters_close_once(
    fake_target: tuple[str, int], recorder: Recorder
) -> None:
    summary = _run(
        fake_target, [_case("SYN-001", _passes), _case("SYN-002", _passes)], recorder, jobs=2
    )
    first, *middle, last = recorder.events
    assert isinstance(first, RunStarted) and first.cases == 2
    assert first.options["jobs"] == "2" and float(first.options["deadline_s"]) >= 1.0
    assert first.server.rtt_ms > 0 and not first.server.legacy
    assert isinstance(last, RunFinished) and last.summary == summary
    started = [e.info.id for e in middle if isinstance(e, CaseStarted)]
    finished = [e.result.info.id for e in middle if isinstance(e, CaseFinished)]
    assert sorted(started) == sorted(finished) == ["SYN-001", "SYN-002"]
    for case_id in started:  # each case starts before it finishes
        starts = [
            i for i, e in enumerate(middle) if isinstance(e, CaseStarted) and e.info.id == case_id
        ]
        ends = [
            i
            for i, e in enumerate(middle)
            if isinstance(e, CaseFinished) and e.result.info.id == case_id
        ]
        assert starts[0] < ends[0]
    assert recorder.closed == 1


def test_missing_extension_is_not_applicable_without_running(
    fake_target: tuple[str, int],
) -> None:
    ran: list[str] = []

    async def fn(ctx: CaseContext) -> None:
        ran.append(ctx.case.id)

    summary = _run(
        fake_target,
        [_case("SYN-001", fn, needs=("noreply",)), _case("SYN-002", fn, needs=("pipelining",))],
    )
    assert _by_id(summary)["SYN-001"].verdict is Verdict.NOT_APPLICABLE
    assert "noreply" in _by_id(summary)["SYN-001"].message
    assert ran == ["SYN-002"]  # the fake server advertises pipelining only


def test_parallel_cases_really_run_together(fake_target: tuple[str, int]) -> None:
    # Each case sets its own event and waits for the other's: only concurrency lets both pass.
    events = {"SYN-001": asyncio.Event, "SYN-002": asyncio.Event}
    made: dict[str, asyncio.Event] = {}

    async def fn(ctx: CaseContext) -> None:
        for key, factory in events.items():
            made.setdefault(key, factory())
        made[ctx.case.id].set()
        other = "SYN-002" if ctx.case.id == "SYN-001" else "SYN-001"
        await ctx.wait(made[other].wait(), what="the other case", timeout=2.0)

    summary = _run(fake_target, [_case("SYN-001", fn), _case("SYN-002", fn)], jobs=2)
    assert {r.verdict for r in summary.results} == {Verdict.PASS}


def test_serial_cases_run_alone_after_the_parallel_ones(fake_target: tuple[str, int]) -> None:
    active: list[str] = []
    log: list[tuple[str, int]] = []

    async def fn(ctx: CaseContext) -> None:
        active.append(ctx.case.id)
        log.append((ctx.case.id, len(active)))
        for _ in range(5):
            await asyncio.sleep(0)  # yield, so that overlapping cases would show
        active.remove(ctx.case.id)

    cases = [_case(f"SYN-00{n}", fn, serial=n in (1, 4)) for n in range(1, 6)]
    _run(fake_target, cases, jobs=3)
    serial = [(case_id, n) for case_id, n in log if case_id in ("SYN-001", "SYN-004")]
    assert serial == [("SYN-001", 1), ("SYN-004", 1)]
    assert [case_id for case_id, _ in log][-2:] == ["SYN-001", "SYN-004"]
    assert max(n for _, n in log) > 1  # the parallel ones did overlap


def test_vacuous_passes_are_listed(fake_target: tuple[str, int]) -> None:
    async def fn(ctx: CaseContext) -> None:
        ctx.vacuous("nothing to compare")

    summary = _run(fake_target, [_case("SYN-001", fn), _case("SYN-002", _passes)])
    assert summary.vacuous == ("SYN-001",)
    # OA-GEN-7: a vacuous pass is inconclusive, never pass.
    assert _by_id(summary)["SYN-001"].verdict is Verdict.INCONCLUSIVE
    assert _by_id(summary)["SYN-002"].verdict is Verdict.PASS
    assert "nothing to compare" in _by_id(summary)["SYN-001"].message


def test_expectations_apply_and_unknown_entries_are_reported(
    fake_target: tuple[str, int], tmp_path: Path
) -> None:
    path = tmp_path / "x.xml"
    path.write_text(
        '<expectations implementation="X">'
        '<expect case="SYN-001" verdict="fail" reason="known bug" deviation="DEV-1"/>'
        '<expect case="SYN-002" verdict="fail" reason="fixed since"/>'
        '<expect case="SYN-003" verdict="fail" reason="wrong kind"/>'
        '<expect case="GONE-*" verdict="fail" reason="stale"/>'
        "</expectations>"
    )
    cases = [
        _case("SYN-001", _raising(Fail("x"))),
        _case("SYN-002", _passes),
        _case("SYN-003", _raising(Inconclusive("refused"))),
        _case("SYN-004", _raising(Fail("y"))),
    ]
    summary = _run(fake_target, cases, expectations=path)
    results = _by_id(summary)
    assert results["SYN-001"].verdict is Verdict.EXPECTED_FAILURE
    assert results["SYN-001"].expectation_reason == "DEV-1: known bug"
    assert results["SYN-002"].verdict is Verdict.UNEXPECTED_PASS
    assert results["SYN-003"].verdict is Verdict.INCONCLUSIVE  # (a late one is covered: #16)
    assert "expected fail, got inconclusive" in results["SYN-003"].message
    assert results["SYN-004"].verdict is Verdict.FAIL
    assert summary.unknown_expectations == (f"{path}:1: GONE-*",)


def test_nothing_selected_is_an_error(fake_target: tuple[str, int], recorder: Recorder) -> None:
    with pytest.raises(NoCasesSelected):
        _run(fake_target, [_case("SYN-001", _passes)], recorder, case_globs=("NOPE-*",))
    assert recorder.events == [] and recorder.closed == 1


def test_bad_expectations_file_is_an_error(fake_target: tuple[str, int], tmp_path: Path) -> None:
    bad = tmp_path / "bad.xml"
    bad.write_text("<expectations/>")
    with pytest.raises(ExpectationError):
        _run(fake_target, [_case("SYN-001", _passes)], expectations=bad)


def _closed_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def test_unreachable_target(recorder: Recorder) -> None:
    with pytest.raises(TargetUnreachable):
        _run(
            ("127.0.0.1", _closed_port()), [_case("SYN-001", _passes)], recorder, probe_timeout=2.0
        )
    assert recorder.events == [] and recorder.closed == 1
