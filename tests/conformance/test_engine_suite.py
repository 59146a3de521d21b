"""The registered cases against real servers: the reference server passes; faults are caught."""

from __future__ import annotations

import asyncio
from typing import Any

from openair_conformance.engine import RunOptions, run
from openair_conformance.model import CaseResult, RunSummary, Verdict
from openair_conformance.registry import all_cases, select_cases


def _run(target: tuple[str, int], **options: Any) -> RunSummary:
    return asyncio.run(run(RunOptions(target=target, **options)))


def _explain(results: tuple[CaseResult, ...]) -> str:
    lines = []
    for r in results:
        lines.append(f"{r.info.id} {r.verdict.value}: {r.message}")
        lines += [f"    {e.t:.3f} {e.conn} {e.direction} {e.tag} {e.text[:300]}" for e in r.trace]
    return "\n".join(lines)


# The engine's own proof uses the first cases; the whole suite against the reference server, with
# its known bugs and small-limit cases, is tests/conformance/test_suite_reference.py.
_ENGINE_CASES = ("SESS-00*", "WB-001", "WAKE-001", "CC-00[12]", "RET-001", "HOST-001")


def test_every_case_passes_against_the_target(target: tuple[str, int]) -> None:
    summary = _run(target, jobs=4, case_globs=_ENGINE_CASES)
    bad = tuple(
        r
        for r in summary.results
        if r.verdict is not Verdict.PASS
        and not (r.verdict is Verdict.NOT_APPLICABLE and r.info.needs)
    )
    assert not bad, _explain(bad)
    assert summary.total == len(select_cases(all_cases(), globs=_ENGINE_CASES))
    latencies = dict(summary.latencies)
    assert latencies["post_to_wakeup_samples"] >= 3  # WAKE-001, CC-001, CC-002
    assert 0 < latencies["post_to_wakeup_p50_ms"] <= latencies["post_to_wakeup_p99_ms"]
    wake = next(r for r in summary.results if r.info.id == "WAKE-001")
    assert any("the wakeup came over the" in e.text for e in wake.trace)
    assert any(e.direction == "in" and "AIR.Instruct.Wakeup" in e.text for e in wake.trace)


def test_parallel_and_sequential_runs_agree(target: tuple[str, int]) -> None:
    verdicts = [
        {r.info.id: r.verdict for r in _run(target, jobs=jobs, case_globs=_ENGINE_CASES).results}
        for jobs in (1, 8)
    ]
    assert verdicts[0] == verdicts[1]


def test_legacy_server_makes_extension_cases_not_applicable(fake_server_with: Any) -> None:
    summary = _run(fake_server_with(legacy=True), case_globs=("SESS-00*",))
    results = {r.info.id: r for r in summary.results}
    assert results["SESS-007"].verdict is Verdict.NOT_APPLICABLE  # needs pipelining
    assert results["SESS-001"].verdict is Verdict.PASS


def test_a_faulty_server_fails_with_evidence(fake_server_with: Any) -> None:
    address = fake_server_with(faults=frozenset({"ping_isresponse"}))
    summary = _run(address, case_globs=("SESS-001", "SESS-002"))
    results = {r.info.id: r for r in summary.results}
    failed = results["SESS-001"]
    assert failed.verdict is Verdict.FAIL, _explain((failed,))
    assert "OA-SESS-1" in failed.expected
    assert failed.divergence is not None
    diverged = failed.trace[failed.divergence]
    assert diverged.direction == "in" and "PING_SUCCESS" in diverged.text
    assert failed.repro == f"openair conform 127.0.0.1:{address[1]} --case SESS-001"
    assert results["SESS-002"].verdict is Verdict.PASS


def test_psyclone_expectations_against_a_conformant_server(target: tuple[str, int]) -> None:
    summary = _run(target, expectations="psyclone-1.1.7")
    results = {r.info.id: r for r in summary.results}
    # Conformant where Psyclone deviates: the expectations turn those passes into surprises.
    assert results["CC-002"].verdict is Verdict.UNEXPECTED_PASS
    assert results["HOST-001"].verdict is Verdict.UNEXPECTED_PASS
    assert "DEV-16" in results["HOST-001"].expectation_reason
    assert results["CC-001"].verdict is Verdict.PASS  # shielded by its verdict="pass" entry
    # An entry scoped to a requirement that no case cites yet is reported as unknown.
    cited = any("OA-MATCH-6" in c.info.requirements for c in all_cases())
    listed = any(e.endswith(": *[OA-MATCH-6]") for e in summary.unknown_expectations)
    assert listed is not cited
