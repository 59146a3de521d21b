"""The one verdict model of every conformance run: outcome → verdict → result → summary.

A case of any target (a server over TCP, a client library through its shim, a world-model
module) ends by returning or by raising `Fail`, `Timing`, `Inconclusive`, `NotApplicable` or
anything else (a bug of the suite). `judge` maps that outcome to a `Verdict` by the case's
`Level`; `case_result` applies the OA-GEN-7 vacuous-pass rule and the expectations file and
builds the `CaseResult`; `summarize` counts verdicts and computes the latency percentiles.
`exit_code` applies the `--fail-on` policy. The engine (`engine.py`) is the only caller of the
first three; reporters read what they build.
"""

from __future__ import annotations

import math
import traceback
from collections.abc import Sequence
from dataclasses import dataclass

from openair_conformance.expectations import Expectation, apply_expectation
from openair_conformance.model import (
    CaseInfo,
    CaseResult,
    Fail,
    Inconclusive,
    Level,
    NotApplicable,
    RunSummary,
    TargetDeath,
    Timing,
    TraceEntry,
    Verdict,
)

__all__ = [
    "DEFAULT_FAIL_ON",
    "EXIT_TARGET_DIED",
    "LATENCY_MEASURE",
    "Attempt",
    "case_result",
    "exit_code",
    "judge",
    "percentile",
    "summarize",
]

DEFAULT_FAIL_ON = frozenset({Verdict.FAIL, Verdict.ERROR, Verdict.UNEXPECTED_PASS})
#: The measurement whose percentiles every summary reports (post → wakeup, milliseconds).
LATENCY_MEASURE = "post_to_wakeup_ms"
#: The exit code of a run during which the target died (README, exit codes).
EXIT_TARGET_DIED = 5


@dataclass(frozen=True, slots=True, kw_only=True)
class Attempt:
    """What a target gives back for one run of one case, before it is judged.

    `outcome` is None (the case returned) or what it raised; `divergence` the index into
    `trace` where behaviour diverged (None: not known); `vacuous_reason` non-empty when the
    case passed without observing what it checks (OA-GEN-7).
    """

    outcome: BaseException | None
    trace: tuple[TraceEntry, ...] = ()
    divergence: int | None = None
    measurements: tuple[tuple[str, float], ...] = ()
    repro: str = ""
    vacuous_reason: str = ""


def judge(info: CaseInfo, exc: BaseException | None) -> tuple[Verdict, str, str]:
    """Map a case's outcome to (verdict, message, expected), before expectations."""
    if exc is None:
        return Verdict.PASS, "", ""
    if isinstance(exc, Fail):
        verdict = {
            Level.MUST: Verdict.FAIL,
            Level.SHOULD: Verdict.PASS_NONSTRICT,
        }.get(info.level, Verdict.INFORMATIONAL)
        return verdict, exc.message, exc.expected
    if isinstance(exc, Timing):
        return Verdict.TIMING, str(exc), ""
    if isinstance(exc, Inconclusive):
        return Verdict.INCONCLUSIVE, str(exc), ""
    if isinstance(exc, NotApplicable):
        return Verdict.NOT_APPLICABLE, str(exc), ""
    text = "".join(traceback.format_exception(exc)).rstrip()
    return Verdict.ERROR, f"harness error (a bug in the suite, not in the server):\n{text}", ""


def case_result(
    info: CaseInfo, attempt: Attempt, *, duration: float, expectation: Expectation | None
) -> CaseResult:
    """Judge one attempt: the verdict, the vacuous-pass rule, then the expectation."""
    verdict, message, expected = judge(info, attempt.outcome)
    if verdict == Verdict.PASS and attempt.vacuous_reason:
        # OA-GEN-7: a pass whose precondition never happened proves nothing.
        verdict = Verdict.INCONCLUSIVE
        message = f"vacuous: {attempt.vacuous_reason}"
    final = apply_expectation(verdict, expectation)
    if expectation is not None and final == verdict and verdict != Verdict.PASS:
        message = f"(expected {expectation.verdict.value}, got {verdict.value}) {message}"
    return CaseResult(
        info=info,
        verdict=final,
        message=message,
        expected=expected or "\n".join(info.allowed),
        trace=attempt.trace,
        divergence=attempt.divergence,
        duration=duration,
        repro=attempt.repro,
        measurements=attempt.measurements,
        expectation_reason=expectation.describe() if expectation is not None else "",
    )


def percentile(values: Sequence[float], fraction: float) -> float:
    """The nearest-rank percentile of a non-empty sequence."""
    ordered = sorted(values)
    rank = max(1, math.ceil(fraction * len(ordered)))
    return ordered[rank - 1]


def summarize(
    results: Sequence[CaseResult],
    *,
    duration: float,
    latencies: Sequence[tuple[str, float]] = (),
    vacuous: Sequence[str] = (),
    unknown_expectations: tuple[str, ...] = (),
    deaths: Sequence[TargetDeath] = (),
    not_run: Sequence[str] = (),
) -> RunSummary:
    """Count the verdicts and add the post → wakeup percentiles to the target's `latencies`."""
    counts = {v: 0 for v in Verdict}
    for result in results:
        counts[result.verdict] += 1
    samples = [v for r in results for n, v in r.measurements if n == LATENCY_MEASURE]
    measured = list(latencies)
    if samples:
        measured += [
            ("post_to_wakeup_p50_ms", percentile(samples, 0.50)),
            ("post_to_wakeup_p99_ms", percentile(samples, 0.99)),
            ("post_to_wakeup_samples", float(len(samples))),
        ]
    return RunSummary(
        counts=tuple((v, n) for v, n in counts.items() if n),
        duration=duration,
        latencies=tuple(measured),
        vacuous=tuple(sorted(vacuous)),
        unknown_expectations=unknown_expectations,
        results=tuple(sorted(results, key=lambda r: r.info.id)),
        target_deaths=tuple(deaths),
        not_run=tuple(not_run),
    )


def exit_code(summary: RunSummary, fail_on: frozenset[Verdict] = DEFAULT_FAIL_ON) -> int:
    """Return 5 if the target died during the run, else 1 if any result has a verdict in
    `fail_on`, else 0."""
    if summary.target_deaths:
        return EXIT_TARGET_DIED
    return 1 if any(summary.count(v) for v in fail_on) else 0
