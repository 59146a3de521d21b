"""The harness against a scripted legacy peer (issue #16): verdicts you can trust.

The peer (tests/legacy_peer/psyclone_like.py) is the reference server behind Psyclone 1.1.7's
wire habits. Each test turns on what it needs and checks one harness fault is gone: barrier
sentinels echoed with another priority spelling, placeholder module names, stream cases on the
stream's own port, a target that dies mid-run (stop, continue, restart-cmd), expected
deviations made late by --timeout-scale.
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest
from legacy_peer.psyclone_like import LegacyOptions, start_legacy
from server_thread import ServerThread

from openair_conformance.engine import EXIT_TARGET_DIED, RunOptions, exit_code, run
from openair_conformance.model import CaseResult, RunSummary, Verdict
from openair_conformance.registry import RegisteredCase, all_cases

PEER_SCRIPT = Path(__file__).resolve().parents[1] / "legacy_peer" / "psyclone_like.py"


@pytest.fixture
def peer() -> Iterator[Any]:
    """Start scripted legacy peers with the given options; each is stopped after the test."""
    threads: list[ServerThread] = []

    def start(**options: Any) -> tuple[str, int]:
        legacy = LegacyOptions(**options)
        thread = ServerThread(lambda: start_legacy(legacy))
        threads.append(thread)
        return ("127.0.0.1", thread.port)

    yield start
    for thread in threads:
        thread.stop()


def _run(target: tuple[str, int], *globs: str, **options: Any) -> RunSummary:
    return asyncio.run(run(RunOptions(target=target, case_globs=globs, **options)))


def _verdicts(summary: RunSummary) -> dict[str, Verdict]:
    return {r.info.id: r.verdict for r in summary.results}


def _explain(results: Sequence[CaseResult]) -> str:
    return "\n".join(f"{r.info.id} {r.verdict.value}: {r.message[:300]}" for r in results)


# -- barrier recognition -----------------------------------------------------------------------


@pytest.mark.parametrize("spelling", ["{:.2f}", "{:.2f}e"])
def test_barrier_is_recognised_whatever_the_priority_echo(peer: Any, spelling: str) -> None:
    """6.999 echoed "7.00" (Psyclone), or spelled so that no decoder reads it: still found."""
    target = peer(priority_format=spelling)
    summary = _run(target, "CC-003", "CC-004", "MATCH-001")
    bad = [r for r in summary.results if r.verdict is not Verdict.PASS]
    assert not bad, _explain(bad)


# -- placeholder module names ------------------------------------------------------------------

_NAMED_REGISTRATIONS = ("REG-003", "REG-004", "REG-008", "REG-011", "REG-014", "WAKE-005")


def test_module_name_registrations_use_the_case_s_own_names(peer: Any) -> None:
    """A peer that takes `<module name>` as identity: the cases that register with a name pass."""
    summary = _run(peer(module_identity=True), *_NAMED_REGISTRATIONS, jobs=4)
    bad = [r for r in summary.results if r.verdict is not Verdict.PASS]
    assert not bad, _explain(bad)


def test_a_registration_naming_a_foreign_module_is_a_harness_error(
    target: tuple[str, int],
) -> None:
    from openair_conformance.harness import CaseContext
    from openair_conformance.model import CaseInfo, Level

    async def placeholder(ctx: CaseContext) -> None:
        module = await ctx.module("Sub")
        await module.subscribe('<module name="x"><trigger from="WB1" type="Conf.X"/></module>')

    info = CaseInfo(
        id="TEST-001", title="t", section="7", requirements=("OA-REG-1",), level=Level.MUST
    )
    summary = asyncio.run(
        run(RunOptions(target=target), cases=[RegisteredCase(info=info, fn=placeholder)])
    )
    (result,) = summary.results
    assert result.verdict is Verdict.ERROR
    assert "case isolation" in result.message


# -- streams on their own port -----------------------------------------------------------------


def test_stream_cases_talk_to_the_port_resolve_gave(peer: Any) -> None:
    """The peer answers LOC_INVALID for stream commands on the main port (as Psyclone did)."""
    summary = _run(peer(stream_ports=True), "STREAM-*", jobs=4)
    bad = [r for r in summary.results if r.verdict not in (Verdict.PASS, Verdict.NOT_APPLICABLE)]
    assert not bad, _explain(bad)
    moved = [r for r in summary.results if any("its own port" in e.text for e in r.trace)]
    assert moved, "no stream case noted the stream's own port"


# -- a target that dies mid-run ----------------------------------------------------------------

_AROUND_WB005 = ("SESS-001", "WB-004", "WB-005", "WB-006", "WB-007")


def test_death_stops_the_run_and_names_the_case(peer: Any, tmp_path: Path) -> None:
    from openair_conformance.reporters.jsonreport import JsonReporter, schema_errors

    report = tmp_path / "r.json"
    summary = asyncio.run(
        run(
            RunOptions(target=peer(die_at="WB005"), case_globs=_AROUND_WB005),
            reporters=[JsonReporter(report)],
        )
    )
    (death,) = summary.target_deaths
    assert (death.case, death.action) == ("WB-005", "stopped")
    judged = set(_verdicts(summary))
    assert {"WB-006", "WB-007"} <= set(summary.not_run)  # nothing started after the death
    assert judged | set(summary.not_run) == set(_AROUND_WB005)
    assert [r.info.id for r in summary.results if r.target_died] == ["WB-005"]
    assert exit_code(summary) == EXIT_TARGET_DIED
    data = json.loads(report.read_text())
    assert not schema_errors(data)
    assert data["summary"]["target_deaths"][0]["case"] == "WB-005"
    assert data["summary"]["not_run"] == list(summary.not_run)


def test_death_with_continue_runs_every_case_and_reports_it_once(peer: Any) -> None:
    summary = _run(peer(die_at="WB005"), *_AROUND_WB005, on_target_death="continue")
    (death,) = summary.target_deaths
    assert (death.case, death.action) == ("WB-005", "continued")
    assert set(_verdicts(summary)) == set(_AROUND_WB005)
    assert not summary.not_run
    assert exit_code(summary) == EXIT_TARGET_DIED


def test_death_with_restart_reruns_the_interrupted_case_once(peer: Any, tmp_path: Path) -> None:
    from openair_conformance.reporters.junit import JUnitReporter

    target = peer(die_at="WB005")
    pidfile = tmp_path / "peer.pid"
    command = f"{sys.executable} {PEER_SCRIPT} --port {target[1]} --pidfile {pidfile}"
    junit = tmp_path / "r.xml"
    try:
        summary = asyncio.run(
            run(
                RunOptions(
                    target=target,
                    case_globs=_AROUND_WB005,
                    on_target_death="restart",
                    restart_cmd=command,
                ),
                reporters=[JUnitReporter(junit)],
            )
        )
    finally:
        if pidfile.exists():
            os.kill(int(pidfile.read_text()), signal.SIGTERM)
    (death,) = summary.target_deaths
    assert (death.case, death.action) == ("WB-005", "restarted")
    verdicts = _verdicts(summary)
    assert set(verdicts) == set(_AROUND_WB005)
    rerun = summary.results[[r.info.id for r in summary.results].index("WB-005")]
    assert rerun.rerun_after_restart and rerun.verdict is Verdict.PASS, _explain([rerun])
    assert verdicts["WB-006"] is Verdict.PASS and verdicts["WB-007"] is not Verdict.INCONCLUSIVE
    assert "rerun after restart" in junit.read_text()
    assert exit_code(summary) == EXIT_TARGET_DIED


def test_with_cases_in_parallel_the_death_names_the_case_that_was_not_answered(
    peer: Any,
) -> None:
    globs = ("WB-00[1-3]", "WB-00[5-7]", "SESS-00[1-3]")
    summary = _run(peer(die_at="WB005"), *globs, jobs=6)
    (death,) = summary.target_deaths
    assert death.case == "WB-005"
    assert death.in_flight  # the others that were running are named too


def test_the_first_unanswered_request_names_the_culprit() -> None:
    from openair_conformance.harness.liveness import first_unanswered
    from openair_conformance.model import TraceEntry

    def entry(t: float, conn: str, direction: str) -> TraceEntry:
        return TraceEntry(t=t, conn=conn, direction=direction, tag="Message", text="")

    traces = {
        # A's request was answered, later than B's request went out.
        "A": (0.0, (entry(1.0, "A/primary", "out"), entry(3.0, "A/primary", "in"))),
        # B's request was never answered: the culprit.
        "B": (1.5, (entry(0.5, "B/primary", "out"),)),
        # C's acknowledgement of a delivery is a reply: it is never answered, and says nothing.
        "C": (0.0, (entry(1.9, "C/callback", "in"), entry(1.95, "C/callback", "out"))),
        # D's unanswered request came after B's.
        "D": (0.0, (entry(2.5, "raw#1", "out"),)),
    }
    assert first_unanswered(traces) == "B"
    assert first_unanswered({"A": traces["A"], "C": traces["C"]}) is None


def test_the_cli_exits_5_and_says_where_the_target_died(peer: Any) -> None:
    from click.testing import CliRunner

    from openair_conformance.cli import conform

    host, port = peer(die_at="WB005")
    args = ["run", f"{host}:{port}"]  # -j 4: the case is named by its unanswered request
    args += [arg for glob in _AROUND_WB005 for arg in ("--case", glob)]
    result = CliRunner().invoke(conform, args, catch_exceptions=False)
    assert result.exit_code == EXIT_TARGET_DIED, result.output
    assert "The target died during WB-005" in result.output
    assert "not run" in result.output
    usage = CliRunner().invoke(
        conform, ["run", f"{host}:{port}", "--on-target-death", "restart-cmd"]
    )
    assert usage.exit_code == 2


def test_restart_cmd_needs_a_command() -> None:
    from openair_conformance.engine import EngineError

    with pytest.raises(EngineError):
        RunOptions(target=("127.0.0.1", 1), on_target_death="restart")
    with pytest.raises(EngineError):
        RunOptions(target=("127.0.0.1", 1), on_target_death="later")


# -- expectations and timeout scaling ----------------------------------------------------------


def test_an_expected_deviation_made_late_by_the_scale_is_an_expected_failure(
    target: tuple[str, int], tmp_path: Path
) -> None:
    """A deviation (closing after ~13 s, not at once) seen inside the grace window: not TIMING."""
    from openair_conformance.harness import CaseContext
    from openair_conformance.model import CaseInfo, Level, Timing

    async def closes_late(ctx: CaseContext) -> None:
        raise Timing("no close within the deadline; closed after 13.0 s (within the grace)")

    info = CaseInfo(
        id="TEST-002", title="t", section="2", requirements=("OA-FRAME-1",), level=Level.MUST
    )
    expectations = tmp_path / "e.xml"
    expectations.write_text(
        '<expectations implementation="legacy">'
        '<expect case="TEST-002" verdict="fail" reason="closes after 13 s"/></expectations>'
    )
    summary = asyncio.run(
        run(
            RunOptions(target=target, timeout_scale=5, expectations=expectations),
            cases=[RegisteredCase(info=info, fn=closes_late)],
        )
    )
    (result,) = summary.results
    assert result.verdict is Verdict.EXPECTED_FAILURE
    assert "13.0 s" in result.message


# -- random orders -----------------------------------------------------------------------------


def test_residue_cases_run_after_every_other_case_in_any_order(target: tuple[str, int]) -> None:
    """A case that may leave an untyped message (MSG-004, WB-007) never precedes another."""
    from openair_conformance.harness import CaseContext
    from openair_conformance.model import CaseInfo, Level

    order: list[str] = []

    def make(case_id: str, *, residue: bool = False, serial: bool = False) -> RegisteredCase:
        async def fn(ctx: CaseContext) -> None:
            order.append(ctx.case.id)

        info = CaseInfo(
            id=case_id,
            title="t",
            section="3",
            requirements=("OA-MSG-2",),
            level=Level.MUST,
            residue=residue,
            serial=serial,
        )
        return RegisteredCase(info=info, fn=fn)

    cases = [make("TEST-001", residue=True), make("TEST-002"), make("TEST-003", serial=True)]
    cases += [make(f"TEST-{n:03d}") for n in range(4, 12)]
    for seed in range(5):
        order.clear()
        asyncio.run(run(RunOptions(target=target, order="random", seed=seed, jobs=3), cases=cases))
        assert order[-1] == "TEST-001"
        assert order[-2] == "TEST-003"  # serial, after the parallel ones
    assert {c.info.id for c in all_cases() if c.info.residue} >= {"MSG-004", "WB-007"}


def test_a_post_outside_the_run_s_names_is_a_harness_error(target: tuple[str, int]) -> None:
    from openair_conformance.harness import CaseContext
    from openair_conformance.model import CaseInfo, Level

    async def shared_type(ctx: CaseContext) -> None:
        module = await ctx.module("P", bind=False)
        await module.post("WB1", "Shared.Type", "anyone can match me")

    info = CaseInfo(
        id="TEST-003", title="t", section="7", requirements=("OA-WB-2",), level=Level.MUST
    )
    summary = asyncio.run(
        run(RunOptions(target=target), cases=[RegisteredCase(info=info, fn=shared_type)])
    )
    (result,) = summary.results
    assert result.verdict is Verdict.ERROR
    assert "case isolation" in result.message


def _orders_agree(target: tuple[str, int], seeds: Sequence[int]) -> None:
    # The claim is about order, not speed: a wide deadline keeps most of a loaded machine's
    # late arrivals out, and `timing` (an answer that came, only late) compares equal to
    # `pass`. An order that breaks a case shows as fail, inconclusive or error, never as timing.
    runs = {
        seed: _verdicts(_run(target, order="random", seed=seed, jobs=4, timeout_scale=2))
        for seed in seeds
    }
    first = runs[seeds[0]]
    assert set(first) == {c.info.id for c in all_cases()}

    def speedless(verdict: Verdict) -> Verdict:
        return Verdict.PASS if verdict is Verdict.TIMING else verdict

    for seed in seeds[1:]:
        differ = sorted(k for k in first if speedless(first[k]) is not speedless(runs[seed][k]))
        assert not differ, {k: (first[k].value, runs[seed][k].value) for k in differ}


@pytest.mark.slow
def test_random_orders_give_the_same_verdicts_against_the_reference(
    target: tuple[str, int],
) -> None:
    _orders_agree(target, (11, 12))


@pytest.mark.slow
def test_random_orders_give_the_same_verdicts_against_the_legacy_peer(peer: Any) -> None:
    _orders_agree(peer(), (21, 22))


# -- a slow (paced) legacy target --------------------------------------------------------------

#: One or two cases of each group: posts, wakeups, barriers, retrieves, streams, registrations.
_PACED_SUBSET = (
    "SESS-00[1-3]",
    "WB-00[1-2]",
    "CC-00[1-3]",
    "WAKE-001",
    "RET-00[1-2]",
    "MATCH-001",
    "REG-00[1-3]",
    "STREAM-00[2-3]",
    "FRAME-00[1-2]",
)


def _paced_agrees(globs: Sequence[str]) -> None:
    """The same verdicts from a peer answering at once and one answering 0.3 s late."""
    threads = [
        ServerThread(lambda pace=pace: start_legacy(LegacyOptions(pace_s=pace)))
        for pace in (0.0, 0.3)
    ]
    try:
        quick, paced = (
            _verdicts(_run(("127.0.0.1", t.port), *globs, jobs=4, timeout_scale=2)) for t in threads
        )
    finally:
        for thread in threads:
            thread.stop()
    differ = {k: (quick[k].value, paced[k].value) for k in quick if quick[k] is not paced.get(k)}
    assert not differ, differ
    assert not [k for k, v in paced.items() if v in (Verdict.TIMING, Verdict.ERROR)]


@pytest.mark.slow
def test_a_paced_legacy_target_gets_the_verdicts_of_a_quick_one() -> None:
    """A representative subset (the full paced run: OPENAIR_PACED_FULL=1, below)."""
    _paced_agrees(_PACED_SUBSET)


@pytest.mark.slow
@pytest.mark.skipif(
    not os.environ.get("OPENAIR_PACED_FULL"), reason="the full paced run takes minutes"
)
def test_the_whole_suite_against_a_paced_legacy_target() -> None:
    _paced_agrees(("*",))
