"""Verdict mapping, expectations, exit-code policy and the deadline policy of CaseContext."""

from __future__ import annotations

import asyncio

import pytest

from openair_conformance.engine import (
    DEFAULT_FAIL_ON,
    EngineError,
    RunOptions,
    exit_code,
    judge,
    parse_target,
)
from openair_conformance.expectations import (
    Expectation,
    ExpectationError,
    Expectations,
    apply_expectation,
    find_expectation,
    parse_expectations,
    resolve_expectations_path,
    unknown_entries,
)
from openair_conformance.harness import CaseContext
from openair_conformance.harness.conn import ConnectionLost
from openair_conformance.model import (
    CaseInfo,
    Fail,
    Inconclusive,
    Level,
    NotApplicable,
    RunSummary,
    ServerInfo,
    Timing,
    Verdict,
)


def _info(
    level: Level = Level.MUST,
    case_id: str = "SESS-001",
    requirements: tuple[str, ...] = ("OA-SESS-10",),
) -> CaseInfo:
    return CaseInfo(id=case_id, title="t", section="6.7", requirements=requirements, level=level)


@pytest.mark.parametrize(
    ("exc", "level", "verdict"),
    [
        (None, Level.MUST, Verdict.PASS),
        (None, Level.INFO, Verdict.PASS),
        (Fail("x"), Level.MUST, Verdict.FAIL),
        (Fail("x"), Level.SHOULD, Verdict.PASS_NONSTRICT),
        (Fail("x"), Level.MAY, Verdict.INFORMATIONAL),
        (Fail("x"), Level.INFO, Verdict.INFORMATIONAL),
        (Timing("late"), Level.MUST, Verdict.TIMING),
        (Timing("late"), Level.SHOULD, Verdict.TIMING),
        (Inconclusive("?"), Level.MUST, Verdict.INCONCLUSIVE),
        (NotApplicable("no"), Level.MUST, Verdict.NOT_APPLICABLE),
        (KeyError("bug"), Level.MUST, Verdict.ERROR),
        (AssertionError("bug"), Level.SHOULD, Verdict.ERROR),
    ],
)
def test_judge_maps_each_outcome(exc: BaseException | None, level: Level, verdict: Verdict) -> None:
    got, message, _ = judge(_info(level), exc)
    assert got is verdict
    if verdict is Verdict.ERROR:
        assert "harness error" in message and type(exc).__name__ in message


def test_judge_keeps_what_a_failure_says() -> None:
    _, message, expected = judge(_info(), Fail("it broke", expected="PING_SUCCESS"))
    assert (message, expected) == ("it broke", "PING_SUCCESS")


def _entry(verdict: Verdict, case: str = "SESS-*", requirement: str = "") -> Expectation:
    return Expectation(case=case, verdict=verdict, reason="because", requirement=requirement)


@pytest.mark.parametrize(
    ("expected", "actual", "final"),
    [
        (Verdict.FAIL, Verdict.FAIL, Verdict.EXPECTED_FAILURE),
        (Verdict.FAIL, Verdict.PASS_NONSTRICT, Verdict.EXPECTED_FAILURE),
        (Verdict.FAIL, Verdict.INFORMATIONAL, Verdict.EXPECTED_FAILURE),
        (Verdict.FAIL, Verdict.PASS, Verdict.UNEXPECTED_PASS),
        (Verdict.FAIL, Verdict.TIMING, Verdict.EXPECTED_FAILURE),  # issue #16: late, not absent
        (Verdict.FAIL, Verdict.ERROR, Verdict.ERROR),
        (Verdict.FAIL, Verdict.NOT_APPLICABLE, Verdict.NOT_APPLICABLE),
        (Verdict.TIMING, Verdict.TIMING, Verdict.EXPECTED_FAILURE),
        (Verdict.TIMING, Verdict.FAIL, Verdict.FAIL),
        (Verdict.PASS_NONSTRICT, Verdict.PASS_NONSTRICT, Verdict.EXPECTED_FAILURE),
        (Verdict.PASS_NONSTRICT, Verdict.FAIL, Verdict.FAIL),
        (Verdict.INCONCLUSIVE, Verdict.PASS, Verdict.UNEXPECTED_PASS),
        (Verdict.PASS, Verdict.PASS, Verdict.PASS),
        (Verdict.PASS, Verdict.FAIL, Verdict.FAIL),
    ],
)
def test_apply_expectation(expected: Verdict, actual: Verdict, final: Verdict) -> None:
    assert apply_expectation(actual, _entry(expected)) is final


def test_no_expectation_changes_nothing() -> None:
    assert apply_expectation(Verdict.FAIL, None) is Verdict.FAIL


def test_first_applicable_entry_wins_and_requirement_narrows() -> None:
    shield = _entry(Verdict.PASS, case="SESS-002")
    broad = _entry(Verdict.FAIL, case="*", requirement="OA-SESS-3")
    exps = Expectations(implementation="x", entries=(shield, broad))
    assert find_expectation(exps, _info(case_id="SESS-002", requirements=("OA-SESS-3",))) is shield
    assert find_expectation(exps, _info(case_id="SESS-009", requirements=("OA-SESS-3",))) is broad
    assert find_expectation(exps, _info(case_id="SESS-009", requirements=("OA-SESS-5",))) is None
    assert find_expectation(None, _info()) is None


def test_unknown_entries_are_those_matching_no_case() -> None:
    entries = (
        _entry(Verdict.FAIL, case="SESS-00[12]"),
        _entry(Verdict.FAIL, case="MATCH-*"),
        _entry(Verdict.FAIL, case="*", requirement="OA-MATCH-6"),
    )
    exps = Expectations(implementation="x", entries=entries, source="f.xml")
    unknown = unknown_entries(exps, [_info()])
    assert unknown == ("f.xml:0: MATCH-*", "f.xml:0: *[OA-MATCH-6]")
    assert unknown_entries(None, [_info()]) == ()


GOOD = b"""<?xml version="1.0"?>
<expectations implementation="Example 1.0">
  <description>for tests</description>
  <expect case="SESS-*" verdict="fail" reason="r1" link="http://x" deviation="DEV-3"/>
  <expect case="*" requirement="OA-CC-2" verdict="timing" reason="r2"/>
</expectations>"""


def test_parse_expectations_reads_entries_with_lines() -> None:
    exps = parse_expectations(GOOD, source="good.xml")
    assert exps.implementation == "Example 1.0"
    first, second = exps.entries
    assert (first.case, first.verdict, first.link, first.deviation, first.line) == (
        "SESS-*",
        Verdict.FAIL,
        "http://x",
        "DEV-3",
        4,
    )
    assert (second.requirement, second.verdict) == ("OA-CC-2", Verdict.TIMING)
    assert first.describe() == "DEV-3: r1 (http://x)"


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (
            b"<expectations implementation='x'><expect case='A-001' verdict='nope' reason='r'/>"
            b"</expectations>",
            "verdict",
        ),
        (
            b"<expectations implementation='x'><expect case='A-001' verdict='fail'/>"
            b"</expectations>",
            "reason",
        ),
        (
            b"<expectations implementation='x'><expect case='a b' verdict='fail' reason='r'/>"
            b"</expectations>",
            "case",
        ),
        (
            b"<expectations implementation='x'><expect case='A-001' verdict='fail' reason='r' "
            b"requirement='MATCH-6'/></expectations>",
            "requirement",
        ),
        (b"<expectations/>", "implementation"),
        (b"<expectations implementation='x'>", "f.xml"),
        (b"<!DOCTYPE expectations [<!ENTITY x 'y'>]><expectations implementation='&x;'/>", "f.xml"),
    ],
)
def test_invalid_expectations_are_refused(data: bytes, message: str) -> None:
    with pytest.raises(ExpectationError, match=message):
        parse_expectations(data, source="f.xml")


def test_shipped_files_are_found_by_name() -> None:
    assert resolve_expectations_path("psyclone-1.1.7").name == "psyclone-1.1.7.xml"
    assert resolve_expectations_path("psyclone-1.1.7.xml").name == "psyclone-1.1.7.xml"
    with pytest.raises(ExpectationError, match=r"psyclone-1\.1\.7"):
        resolve_expectations_path("no-such-implementation")


@pytest.mark.parametrize(
    ("counts", "fail_on", "code"),
    [
        ((), DEFAULT_FAIL_ON, 0),
        (((Verdict.PASS, 3), (Verdict.EXPECTED_FAILURE, 1)), DEFAULT_FAIL_ON, 0),
        (((Verdict.PASS, 3), (Verdict.TIMING, 1)), DEFAULT_FAIL_ON, 0),
        (((Verdict.PASS, 3), (Verdict.FAIL, 1)), DEFAULT_FAIL_ON, 1),
        (((Verdict.ERROR, 1),), DEFAULT_FAIL_ON, 1),
        (((Verdict.UNEXPECTED_PASS, 1),), DEFAULT_FAIL_ON, 1),
        (((Verdict.TIMING, 1),), frozenset({Verdict.TIMING}), 1),
        (((Verdict.FAIL, 1),), frozenset(), 0),
    ],
)
def test_exit_code_policy(
    counts: tuple[tuple[Verdict, int], ...], fail_on: frozenset[Verdict], code: int
) -> None:
    assert exit_code(RunSummary(counts=counts), fail_on) == code


@pytest.mark.parametrize(
    ("text", "target"),
    [
        ("localhost", ("localhost", 10000)),
        ("127.0.0.1:10001", ("127.0.0.1", 10001)),
        ("[::1]:7", ("::1", 7)),
        ("[::1]", ("::1", 10000)),
    ],
)
def test_parse_target(text: str, target: tuple[str, int]) -> None:
    assert parse_target(text) == target


@pytest.mark.parametrize("text", ["", ":10000", "host:port", "host:0", "host:70000", "[::1]x"])
def test_parse_target_refuses(text: str) -> None:
    with pytest.raises(ValueError):
        parse_target(text)


@pytest.mark.parametrize(
    "changes",
    [{"jobs": 0}, {"timeout_scale": 0.0}, {"timeout_scale": float("inf")}, {"run_id": "a-b"}],
)
def test_run_options_validate(changes: dict[str, object]) -> None:
    with pytest.raises(EngineError):
        RunOptions(target=("h", 1), **changes)  # type: ignore[arg-type]


# -- CaseContext: names and the deadline policy ------------------------------------------------


def _ctx(rtt: float = 0.0001, scale: float = 1.0) -> CaseContext:
    return CaseContext(
        case=_info(case_id="MATCH-003"),
        target=("127.0.0.1", 1),
        rtt=rtt,
        timeout_scale=scale,
        server=ServerInfo(legacy=True),
        run_id="ab12",
    )


def test_names_are_unique_per_case_and_run() -> None:
    ctx = _ctx()
    assert ctx.name("M1") == "Cab12_MATCH003_M1"
    assert ctx.name() == "Cab12_MATCH003"
    assert ctx.type_prefix() == "Conf.Rab12.MATCH003"
    assert ctx.type("Ping.A") == "Conf.Rab12.MATCH003.Ping.A"
    assert not ctx.barrier_type("M").startswith(ctx.type_prefix() + ".")
    with pytest.raises(ValueError):
        ctx.name("bad name")


@pytest.mark.parametrize(
    ("rtt", "scale", "deadline"),
    # 10 round trips, at least 1 s (issue #16: 100 gave a 0.3 s target 30 s deadlines)
    [(0.0001, 1.0, 1.0), (0.5, 1.0, 5.0), (0.0001, 3.0, 3.0), (0.2, 0.5, 1.0), (0.3, 1.0, 3.0)],
)
def test_deadline_derives_from_rtt(rtt: float, scale: float, deadline: float) -> None:
    ctx = _ctx(rtt, scale)
    assert ctx.deadline == pytest.approx(deadline)
    assert ctx.grace == pytest.approx(deadline)
    assert ctx.fail_threshold == pytest.approx(2 * deadline)  # OA-GEN-6


def _wait_with_result_at(delay: float | None, timeout: float) -> object:
    async def scenario() -> object:
        ctx = _ctx()
        future: asyncio.Future[str] = asyncio.get_running_loop().create_future()
        if delay is not None:
            asyncio.get_running_loop().call_later(delay, future.set_result, "value")
        try:
            return await ctx.wait(future, what="thing", timeout=timeout)
        except (Fail, Timing) as exc:
            return exc

    return asyncio.run(scenario())


def test_wait_on_time_returns_the_value() -> None:
    assert _wait_with_result_at(0.0, timeout=5.0) == "value"


def test_wait_within_the_grace_is_timing() -> None:
    # Timers fire in deadline order: the deadline (0.01 s) passes before the result (0.015 s),
    # which comes before the fail threshold (0.01 + 0.01 s, OA-GEN-6).
    outcome = _wait_with_result_at(0.015, timeout=0.01)
    assert isinstance(outcome, Timing) and "thing arrived after" in str(outcome)


def test_wait_past_the_grace_is_fail_with_divergence() -> None:
    outcome = _wait_with_result_at(None, timeout=0.01)
    assert isinstance(outcome, Fail) and outcome.message.startswith("no thing within")


@pytest.mark.parametrize(
    ("elapsed", "outcome"),
    [(0.5, None), (1.5, Timing), (2.5, Fail)],  # deadline 1 s, fail threshold 2 s
)
def test_a_late_answer_beyond_the_fail_threshold_is_fail(
    elapsed: float, outcome: type[Exception] | None
) -> None:
    """OA-GEN-6: the grey zone is TIMING, beyond 2 deadlines a timed rule FAILS."""
    ctx = _ctx(0.0001, 1.0)
    if outcome is None:
        ctx.judge_elapsed("the reply", elapsed)
        return
    with pytest.raises(outcome):
        ctx.judge_elapsed("the reply", elapsed)


def test_wait_on_a_lost_connection_is_fail() -> None:
    async def scenario() -> Fail:
        ctx = _ctx()
        ctx.note("before")
        future: asyncio.Future[str] = asyncio.get_running_loop().create_future()
        future.set_exception(ConnectionLost("M/primary"))
        with pytest.raises(Fail) as info:
            await ctx.wait(future, what="reply to PING")
        return info.value

    failure = asyncio.run(scenario())
    assert "closed by the server" in failure.message
    assert failure.divergence == 0
