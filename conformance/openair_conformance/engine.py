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
import random
import secrets
import shlex
import ssl
import sys
import time
import traceback
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from openair_conformance.expectations import (
    Expectations,
    apply_expectation,
    find_expectation,
    load_expectations,
    unknown_entries,
)
from openair_conformance.harness.conn import TARGET_TLS
from openair_conformance.harness.context import GRACE_FACTOR, CaseContext, deadline_for
from openair_conformance.harness.liveness import Restarter, alive, first_unanswered
from openair_conformance.harness.probe import TargetUnreachable, probe
from openair_conformance.harness.trace import Trace
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
    TargetDeath,
    Timing,
    Verdict,
)
from openair_conformance.registry import RegisteredCase, all_cases, select_cases

__all__ = [
    "DEATH_ACTIONS",
    "DEFAULT_FAIL_ON",
    "DEFAULT_STREAM",
    "EXIT_TARGET_DIED",
    "LATENCY_MEASURE",
    "ORDERS",
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
#: Fuzzing examples against a slow target (see `_Run.fuzz_examples`).
_FUZZ_DEFAULT = 25
_FUZZ_FAST_RTT = 0.05
_FUZZ_MIN_EXAMPLES = 5
#: What `--on-target-death` may say (`restart` needs `restart_cmd`).
DEATH_ACTIONS = ("stop", "continue", "restart")
#: The orders cases may be started in (`--order`).
ORDERS = ("registry", "random")
#: The exit code of a run during which the target died (README, exit codes).
EXIT_TARGET_DIED = 5
#: Verdicts after which the target is not asked whether it is still alive: it just answered.
_ANSWERED = frozenset({Verdict.PASS, Verdict.NOT_APPLICABLE, Verdict.UNEXPECTED_PASS})


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
    #: Module names and secrets the secure-mode cases prove (spec 14.3; `--auth-secrets`).
    auth_secrets: Mapping[str, str] = field(default_factory=dict, repr=False)  # never shown
    #: TLS towards the target (spec 14.3, OA-AUTH-10; `--tls-ca`); None: plain TCP.
    tls: ssl.SSLContext | None = field(default=None, repr=False)
    run_id: str = field(default_factory=lambda: secrets.token_hex(2))
    probe_timeout: float = 10.0
    #: `registry` (ID order) or `random` (shuffled with `seed`; a seed is drawn when None).
    order: str = "registry"
    seed: int | None = None
    #: When the target stops answering: `stop`, `continue`, or `restart` (runs `restart_cmd`).
    on_target_death: str = "stop"
    restart_cmd: str = ""
    restart_timeout: float = 60.0

    def __post_init__(self) -> None:
        if self.jobs < 1:
            raise EngineError("jobs must be at least 1")
        if not (self.timeout_scale > 0 and math.isfinite(self.timeout_scale)):
            raise EngineError("timeout scale must be a positive number")
        if not self.run_id.isalnum():
            raise EngineError("run id must be letters and digits")
        if not self.stream or any(ch.isspace() or ch == ";" for ch in self.stream):
            raise EngineError("stream name must be non-empty, without white space or ';'")
        if self.order not in ORDERS:
            raise EngineError(f"order must be one of {', '.join(ORDERS)}")
        if self.order == "random" and self.seed is None:  # drawn, and reported to replay it
            object.__setattr__(self, "seed", secrets.randbelow(1 << 31))
        if self.on_target_death not in DEATH_ACTIONS:
            raise EngineError(f"on-target-death must be one of {', '.join(DEATH_ACTIONS)}")
        if (self.on_target_death == "restart") != bool(self.restart_cmd.strip()):
            raise EngineError("restart-cmd needs a command, and a command needs restart-cmd")

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
    """Return 5 if the target died during the run, else 1 if any result has a verdict in
    `fail_on`, else 0."""
    if summary.target_deaths:
        return EXIT_TARGET_DIED
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
    deaths: list[TargetDeath] = field(default_factory=list)
    not_run: list[str] = field(default_factory=list)
    stopped: bool = False
    down: bool = False  # the target was last seen dead (`continue` reports each death once)
    restarter: Restarter | None = None
    restarting: bool = False
    interrupted: list[tuple[RegisteredCase, CaseResult]] = field(default_factory=list)
    in_flight: set[str] = field(default_factory=set)
    #: Traces of the cases that may have been running when the target died (to name the one).
    watched: dict[str, Trace] = field(default_factory=dict)
    gate: asyncio.Event = field(default_factory=asyncio.Event)  # set: cases may start
    idle: asyncio.Event = field(default_factory=asyncio.Event)  # set: no case in flight

    def emit(self, event: Event) -> None:
        for reporter in self.reporters:
            reporter.handle(event)

    @property
    def rtt(self) -> float:
        return self.server.rtt_ms / 1000.0

    @property
    def fuzz_examples(self) -> int | None:
        """--fuzz-examples; else, for a slow target, fewer than the fuzzing cases' default.

        A fuzzing example is a dozen round trips: at 0.3 s each, the default 25 examples took
        over two minutes of a run that must fit in five (issue #16). Above `_FUZZ_FAST_RTT` the
        count shrinks with the round-trip time, to no fewer than `_FUZZ_MIN_EXAMPLES`.
        """
        if self.options.fuzz_examples is not None or self.rtt <= _FUZZ_FAST_RTT:
            return self.options.fuzz_examples
        return max(_FUZZ_MIN_EXAMPLES, int(_FUZZ_DEFAULT * _FUZZ_FAST_RTT / self.rtt))

    @property
    def deadline(self) -> float:
        return deadline_for(self.rtt, self.options.timeout_scale)

    def repro(self, info: CaseInfo, extra: Sequence[str]) -> str:
        words = ["openair", "conform", self.options.target_text, "--case", info.id]
        if self.options.timeout_scale != 1.0:
            words += ["--timeout-scale", f"{self.options.timeout_scale:g}"]
        if self.options.stream != DEFAULT_STREAM:
            words += ["--stream", self.options.stream]
        return shlex.join([*words, *extra])

    async def schedule(self, cases: Sequence[RegisteredCase], jobs: int) -> None:
        """Run `cases` `jobs` at a time; hold new starts while the target is restarted."""
        queue = list(cases)

        async def worker() -> None:
            while queue:
                await self.gate.wait()
                if self.stopped or not queue:
                    return
                await self.run_case(queue.pop(0))

        await asyncio.gather(*(worker() for _ in range(min(jobs, len(queue)))))
        self.not_run += [c.info.id for c in queue]

    def _enter(self, case_id: str) -> None:
        self.in_flight.add(case_id)
        self.idle.clear()

    def _leave(self, case_id: str) -> None:
        self.in_flight.discard(case_id)
        if not self.in_flight:
            self.idle.set()

    async def run_case(self, case: RegisteredCase, *, first: CaseResult | None = None) -> None:
        """Run one case, ask the target whether it survived, and emit the result."""
        info = case.info
        if first is None:
            self.emit(CaseStarted(info=info))
        self._enter(info.id)
        try:
            result = await self._attempt(case)
            problem = await self._dead(result)
        finally:
            self._leave(info.id)
        if first is not None:
            note = f"rerun after restart; the first attempt was {first.verdict.value}"
            message = f"{note}: {first.message}" if first.message else note
            result = replace(
                result,
                rerun_after_restart=True,
                message=f"{message}\n{result.message}" if result.message else message,
            )
        if problem is not None:
            result = replace(result, target_died=True)
            if await self._on_death(case, result, problem, rerun=first is not None):
                return  # held back: the case runs again after the restart
        else:
            self.watched.pop(info.id, None)
            if result.verdict is not Verdict.NOT_APPLICABLE:  # it ran: the target answered
                self.down = False
        self._finish(result)

    def _finish(self, result: CaseResult) -> None:
        self.results.append(result)
        self.emit(CaseFinished(result=result))

    async def _attempt(self, case: RegisteredCase) -> CaseResult:
        info = case.info
        ctx = CaseContext(
            case=info,
            target=self.options.target,
            rtt=self.rtt,
            timeout_scale=self.options.timeout_scale,
            server=self.server,
            run_id=self.options.run_id,
            fuzz_examples=self.fuzz_examples,
            replay=self.options.replay,
            stream=self.options.stream,
            secrets=self.options.auth_secrets,
        )
        self.watched[info.id] = ctx.trace
        started = time.monotonic()
        outcome = await self._execute(case, ctx)
        return self._result(info, ctx, outcome, time.monotonic() - started)

    async def _dead(self, result: CaseResult) -> str | None:
        """Return why the target looks dead after this result, or None (cheap: one PING).

        Not asked after a pass: the target has just answered. The wait is four deadlines (twice
        the fail threshold), so that a slow target is not taken for a dead one.
        """
        if result.verdict in _ANSWERED:
            return None
        host, port = self.options.target
        return await alive(host, port, timeout=self.deadline * 4)

    async def _on_death(
        self, case: RegisteredCase, result: CaseResult, problem: str, *, rerun: bool
    ) -> bool:
        """Act per --on-target-death; return True when the result is held for a rerun."""
        mode = self.options.on_target_death
        others = tuple(sorted(self.in_flight - {case.info.id}))
        if mode == "restart":
            if not rerun:
                self.interrupted.append((case, result))
            if not self.restarting:
                await self._restart(case.info.id, problem, others)
            return not rerun
        if mode == "continue":
            if not self.down:
                self._record(case.info.id, problem, "continued", others)
            self.down = True
            return False
        if not self.stopped:
            self._record(case.info.id, problem, "stopped", others)
        self.stopped = True
        self.gate.set()  # waiting workers see `stopped` and start nothing
        return False

    def _record(self, case_id: str, problem: str, action: str, others: tuple[str, ...]) -> None:
        """Record a death, naming the case that sent the first frame nothing answered.

        With cases in parallel the one whose liveness check failed first need not be the one
        that killed the target; the others that may have are listed in `in_flight`.
        """
        traces = {cid: (trace.origin, trace.entries) for cid, trace in self.watched.items()}
        culprit = first_unanswered(traces) or case_id
        suspects = (set(others) | {case_id} | set(self.watched)) - {culprit}
        death = TargetDeath(
            case=culprit, detail=problem, action=action, in_flight=tuple(sorted(suspects))
        )
        self.deaths.append(death)
        self.watched = {cid: t for cid, t in self.watched.items() if cid in self.in_flight}

    async def _restart(self, case_id: str, problem: str, others: tuple[str, ...]) -> None:
        """Hold new cases, let the running ones end, restart, then rerun the interrupted."""
        assert self.restarter is not None
        self.restarting = True
        self.gate.clear()
        await self.idle.wait()
        host, port = self.options.target
        failed = await self.restarter.restart(host, port, probe_timeout=self.deadline)
        self._record(case_id, problem, "restart-failed" if failed else "restarted", others)
        if failed:
            self.deaths[-1] = replace(self.deaths[-1], detail=f"{problem}; {failed}")
        held, self.interrupted = self.interrupted, []
        self.restarting = False
        if failed:
            for _, first in held:
                self._finish(first)
            self.stopped = True
            self.gate.set()
            return
        for again, first in held:
            await self.run_case(again, first=first)
        self.gate.set()

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
            # OA-GEN-7: a pass whose precondition never happened proves nothing.
            self.vacuous.append(info.id)
            verdict = Verdict.INCONCLUSIVE
            message = f"vacuous: {ctx.vacuous_reason}"
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
            target_deaths=tuple(self.deaths),
            not_run=tuple(self.not_run),
        )


def _ordered(cases: Sequence[RegisteredCase], options: RunOptions) -> list[RegisteredCase]:
    """Return the cases in the order asked for (`random`: shuffled with the run's seed)."""
    ordered = list(cases)
    if options.order == "random":
        random.Random(options.seed).shuffle(ordered)
    return ordered


def _options_record(options: RunOptions, server: ServerInfo) -> dict[str, str]:
    deadline = deadline_for(server.rtt_ms / 1000.0, options.timeout_scale)
    record = {
        "target": options.target_text,
        "jobs": str(options.jobs),
        "timeout_scale": f"{options.timeout_scale:g}",
        "deadline_s": f"{deadline:.3f}",
        "grace_s": f"{GRACE_FACTOR * deadline:.3f}",
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
    if options.order != "registry":
        record["order"] = options.order
        record["seed"] = str(options.seed)
    if options.on_target_death != "stop":
        record["on_target_death"] = options.on_target_death
    if options.restart_cmd:
        record["restart_cmd"] = options.restart_cmd
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
    token = TARGET_TLS.set(options.tls)  # every connection of this run (spec 14.3)
    try:
        return await _run(options, reporters, cases)
    finally:
        TARGET_TLS.reset(token)
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
    if options.on_target_death == "restart":
        state.restarter = Restarter(options.restart_cmd, timeout=options.restart_timeout)
    state.gate.set()
    state.idle.set()
    ordered = _ordered([c for c in selected if not c.info.residue], options)
    await state.schedule([c for c in ordered if not c.info.serial], options.jobs)
    # Serial cases need global state: each runs alone.
    await state.schedule([c for c in ordered if c.info.serial], 1)
    # Cases that may leave what no namespace holds come last, alone, in ID order: whatever
    # the order of the others, none of them can meet it.
    await state.schedule([c for c in selected if c.info.residue], 1)
    summary = state.summary(time.monotonic() - started, [c.info for c in known])
    state.emit(RunFinished(summary=summary))
    return summary
