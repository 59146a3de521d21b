"""The engine: probe the target, run the selected cases, judge them, emit events.

`run(options, reporters)` probes the server (round-trip time, capabilities), runs the non-serial
cases `jobs` at a time in one event loop and then the serial ones alone, maps each outcome to a
verdict (`judge`), applies the expectations file (`apply_expectation`) and emits `RunStarted`,
`CaseStarted`, `CaseFinished` and `RunFinished` to every reporter; `Reporter.close` is called
once at the end, also when the run stops early. `exit_code` applies the `--fail-on` policy.
"""

from __future__ import annotations

import asyncio
import math
import secrets
import shlex
import sys
import time
import traceback
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from openair_conformance.expectations import (
    Expectations,
    apply_expectation,
    find_expectation,
    load_expectations,
    unknown_entries,
)
from openair_conformance.harness.context import CaseContext, deadline_for
from openair_conformance.harness.probe import TargetUnreachable, probe
from openair_conformance.model import (
    CaseFinished,
    CaseInfo,
    CaseResult,
    CaseStarted,
    Event,
    Fail,
    Inconclusive,
    Level,
    NotApplicable,
    Reporter,
    RunFinished,
    RunStarted,
    RunSummary,
    ServerInfo,
    Timing,
    Verdict,
)
from openair_conformance.registry import RegisteredCase, all_cases, select_cases

__all__ = [
    "DEFAULT_FAIL_ON",
    "DEFAULT_STREAM",
    "LATENCY_MEASURE",
    "EngineError",
    "NoCasesSelected",
    "RunOptions",
    "TargetUnreachable",
    "exit_code",
    "judge",
    "parse_target",
    "run",
]

DEFAULT_FAIL_ON = frozenset({Verdict.FAIL, Verdict.ERROR, Verdict.UNEXPECTED_PASS})
LATENCY_MEASURE = "post_to_wakeup_ms"
DEFAULT_PORT = 10000
DEFAULT_STREAM = "Stream1"
# A case that runs longer than this many deadlines (and at least _MIN_BUDGET s) is stopped and
# judged ERROR: every wait in the harness is bounded, so only a harness bug gets there.
_BUDGET_DEADLINES = 60
_MIN_BUDGET = 60.0


class EngineError(Exception):
    """The run cannot start (bad options, nothing selected)."""


class NoCasesSelected(EngineError):
    """The --case / --section filters selected no case."""


@dataclass(frozen=True, slots=True, kw_only=True)
class RunOptions:
    """What to run, against what, and how."""

    target: tuple[str, int]
    case_globs: tuple[str, ...] = ()
    sections: tuple[str, ...] = ()
    jobs: int = 1
    timeout_scale: float = 1.0
    expectations: Path | str | None = None
    fail_on: frozenset[Verdict] = DEFAULT_FAIL_ON
    verbose: bool = False
    fuzz_examples: int | None = None
    replay: str | None = None
    #: The stream the stream cases use (spec section 11; Stream1 is offered without a
    #: configuration, OA-STREAM-15).
    stream: str = DEFAULT_STREAM
    run_id: str = field(default_factory=lambda: secrets.token_hex(2))
    probe_timeout: float = 10.0

    def __post_init__(self) -> None:
        if self.jobs < 1:
            raise EngineError("jobs must be at least 1")
        if not (self.timeout_scale > 0 and math.isfinite(self.timeout_scale)):
            raise EngineError("timeout scale must be a positive number")
        if not self.run_id.isalnum():
            raise EngineError("run id must be letters and digits")
        if not self.stream or any(ch.isspace() or ch == ";" for ch in self.stream):
            raise EngineError("stream name must be non-empty, without white space or ';'")

    @property
    def target_text(self) -> str:
        """HOST:PORT (IPv6 hosts in brackets)."""
        host, port = self.target
        return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def parse_target(text: str) -> tuple[str, int]:
    """Parse `HOST[:PORT]` or `[V6]:PORT`; the port defaults to 10000. ValueError if bad."""
    text = text.strip()
    if text.startswith("["):
        host, _, rest = text[1:].partition("]")
        port_text = rest[1:] if rest.startswith(":") else ""
        if rest and not rest.startswith(":"):
            raise ValueError(f"bad target {text!r}")
    elif text.count(":") == 1:
        host, port_text = text.split(":")
    else:
        host, port_text = text, ""
    if not host:
        raise ValueError(f"bad target {text!r}: no host")
    try:
        port = int(port_text) if port_text else DEFAULT_PORT
    except ValueError as exc:
        raise ValueError(f"bad target {text!r}: port is not a number") from exc
    if not 0 < port < 65536:
        raise ValueError(f"bad target {text!r}: port out of range")
    return host, port


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


def exit_code(summary: RunSummary, fail_on: frozenset[Verdict] = DEFAULT_FAIL_ON) -> int:
    """Return 1 if any result has a verdict in `fail_on`, else 0."""
    return 1 if any(summary.count(v) for v in fail_on) else 0


def _percentile(values: Sequence[float], fraction: float) -> float:
    ordered = sorted(values)
    rank = max(1, math.ceil(fraction * len(ordered)))  # nearest-rank
    return ordered[rank - 1]


@dataclass(slots=True)
class _Run:
    options: RunOptions
    reporters: Sequence[Reporter]
    server: ServerInfo
    expectations: Expectations | None
    results: list[CaseResult] = field(default_factory=list)
    vacuous: list[str] = field(default_factory=list)

    def emit(self, event: Event) -> None:
        for reporter in self.reporters:
            reporter.handle(event)

    @property
    def rtt(self) -> float:
        return self.server.rtt_ms / 1000.0

    def repro(self, info: CaseInfo, extra: Sequence[str]) -> str:
        words = ["openair", "conform", self.options.target_text, "--case", info.id]
        if self.options.timeout_scale != 1.0:
            words += ["--timeout-scale", f"{self.options.timeout_scale:g}"]
        if self.options.stream != DEFAULT_STREAM:
            words += ["--stream", self.options.stream]
        return shlex.join([*words, *extra])

    async def run_case(self, case: RegisteredCase) -> CaseResult:
        info = case.info
        self.emit(CaseStarted(info=info))
        ctx = CaseContext(
            case=info,
            target=self.options.target,
            rtt=self.rtt,
            timeout_scale=self.options.timeout_scale,
            server=self.server,
            run_id=self.options.run_id,
            fuzz_examples=self.options.fuzz_examples,
            replay=self.options.replay,
            stream=self.options.stream,
        )
        started = time.monotonic()
        outcome = await self._execute(case, ctx)
        result = self._result(info, ctx, outcome, time.monotonic() - started)
        self.results.append(result)
        self.emit(CaseFinished(result=result))
        return result

    async def _execute(self, case: RegisteredCase, ctx: CaseContext) -> BaseException | None:
        missing = sorted(case.info.needs - set(self.server.capabilities))
        if missing:
            return NotApplicable(f"the server does not advertise {', '.join(missing)}")
        budget = max(_MIN_BUDGET, _BUDGET_DEADLINES * ctx.deadline)
        outcome: BaseException | None = None
        try:
            await asyncio.wait_for(case.fn(ctx), budget)
        except TimeoutError:
            outcome = RuntimeError(f"the case did not finish within its {budget:.0f} s budget")
        except Exception as exc:
            outcome = exc
        finally:
            try:
                await ctx.aclose()
            except Exception as exc:
                ctx.note(f"closing the case's connections failed: {exc!r}")
        return outcome

    def _result(
        self, info: CaseInfo, ctx: CaseContext, outcome: BaseException | None, duration: float
    ) -> CaseResult:
        verdict, message, expected = judge(info, outcome)
        divergence = None
        if isinstance(outcome, Fail):
            divergence = outcome.divergence
            if divergence is None and len(ctx.trace):
                divergence = len(ctx.trace) - 1
        if verdict == Verdict.PASS and ctx.vacuous_reason:
            self.vacuous.append(info.id)
            message = f"vacuous pass: {ctx.vacuous_reason}"
        expectation = find_expectation(self.expectations, info)
        final = apply_expectation(verdict, expectation)
        if expectation is not None and final == verdict and verdict != Verdict.PASS:
            message = f"(expected {expectation.verdict.value}, got {verdict.value}) {message}"
        return CaseResult(
            info=info,
            verdict=final,
            message=message,
            expected=expected or "\n".join(info.allowed),
            trace=ctx.trace.entries,
            divergence=divergence,
            duration=duration,
            repro=self.repro(info, ctx.repro_args),
            measurements=ctx.measurements,
            expectation_reason=expectation.describe() if expectation is not None else "",
        )

    def summary(self, duration: float, known: Sequence[CaseInfo]) -> RunSummary:
        counts = {v: 0 for v in Verdict}
        for result in self.results:
            counts[result.verdict] += 1
        samples = [
            value
            for result in self.results
            for name, value in result.measurements
            if name == LATENCY_MEASURE
        ]
        latencies: list[tuple[str, float]] = [("rtt_ms", self.server.rtt_ms)]
        if samples:
            latencies += [
                ("post_to_wakeup_p50_ms", _percentile(samples, 0.50)),
                ("post_to_wakeup_p99_ms", _percentile(samples, 0.99)),
                ("post_to_wakeup_samples", float(len(samples))),
            ]
        return RunSummary(
            counts=tuple((v, n) for v, n in counts.items() if n),
            duration=duration,
            latencies=tuple(latencies),
            vacuous=tuple(sorted(self.vacuous)),
            unknown_expectations=unknown_entries(self.expectations, known),
            results=tuple(sorted(self.results, key=lambda r: r.info.id)),
        )


def _options_record(options: RunOptions, server: ServerInfo) -> dict[str, str]:
    deadline = deadline_for(server.rtt_ms / 1000.0, options.timeout_scale)
    record = {
        "target": options.target_text,
        "jobs": str(options.jobs),
        "timeout_scale": f"{options.timeout_scale:g}",
        "deadline_s": f"{deadline:.3f}",
        "grace_s": f"{3 * deadline:.3f}",
        "run_id": options.run_id,
        "fail_on": ",".join(sorted(v.value for v in options.fail_on)),
    }
    if options.case_globs:
        record["cases"] = " ".join(options.case_globs)
    if options.sections:
        record["sections"] = " ".join(options.sections)
    if options.expectations is not None:
        record["expectations"] = str(options.expectations)
    if options.fuzz_examples is not None:
        record["fuzz_examples"] = str(options.fuzz_examples)
    if options.replay is not None:
        record["replay"] = options.replay
    if options.stream != DEFAULT_STREAM:
        record["stream"] = options.stream
    return record


async def run(
    options: RunOptions,
    reporters: Sequence[Reporter] = (),
    *,
    cases: Sequence[RegisteredCase] | None = None,
) -> RunSummary:
    """Probe the target, run the selected cases and return the summary.

    `cases` replaces the registry (tests); the --case/--section filters apply to it too.
    Raises ExpectationError (bad expectations file), NoCasesSelected or TargetUnreachable before
    any event is emitted. Reporters are closed in every case.
    """
    try:
        return await _run(options, reporters, cases)
    finally:
        close_reporters(reporters)


def close_reporters(reporters: Sequence[Reporter]) -> None:
    """Close every reporter once; one that fails must not stop the others' files."""
    for reporter in reporters:
        try:
            reporter.close()
        except Exception as exc:
            print(f"reporter {type(reporter).__name__} failed to close: {exc}", file=sys.stderr)


async def _run(
    options: RunOptions, reporters: Sequence[Reporter], cases: Sequence[RegisteredCase] | None
) -> RunSummary:
    expectations = load_expectations(options.expectations) if options.expectations else None
    known = list(cases) if cases is not None else all_cases()
    selected = select_cases(known, globs=options.case_globs, sections=options.sections)
    if not selected:
        raise NoCasesSelected("no case matches the --case/--section filters")
    started_wall, started = time.time(), time.monotonic()
    server = await probe(*options.target, timeout=options.probe_timeout)
    state = _Run(options=options, reporters=reporters, server=server, expectations=expectations)
    state.emit(
        RunStarted(
            target=options.target_text,
            started=started_wall,
            options=_options_record(options, server),
            server=server,
            cases=len(selected),
        )
    )
    parallel = [c for c in selected if not c.info.serial]
    serial = [c for c in selected if c.info.serial]
    window = asyncio.Semaphore(options.jobs)

    async def limited(case: RegisteredCase) -> None:
        async with window:
            await state.run_case(case)

    await asyncio.gather(*(limited(c) for c in parallel))
    for case in serial:  # serial cases need global state: each runs alone
        await state.run_case(case)
    summary = state.summary(time.monotonic() - started, [c.info for c in known])
    state.emit(RunFinished(summary=summary))
    return summary
