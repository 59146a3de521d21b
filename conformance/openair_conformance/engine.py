"""The engine: run the selected cases against a target, judge them, emit events.

One engine for every kind of target (`targets`: a server over TCP, a client library through
its shim, a world-model module). `run_target(target, cases, reporters)` starts the target,
runs the non-serial cases `jobs` at a time in one event loop and then the serial ones alone,
judges each outcome with the one verdict model (`verdicts.case_result`, with the expectations
file when there is one) and emits `RunStarted`, `CaseStarted`, `CaseFinished` and `RunFinished`
to every reporter; `Reporter.close` is called once at the end, also when the run stops early.
After a case that did not pass the target is asked whether it is still alive, and
`--on-target-death` decides what a death does. `run(options, reporters)` is the server mode;
`exit_code` applies the `--fail-on` policy.
"""

from __future__ import annotations

import asyncio
import random
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Generic, TypeVar

from openair_conformance.expectations import (
    Expectations,
    find_expectation,
    load_expectations,
    unknown_entries,
)
from openair_conformance.harness.conn import TARGET_TLS
from openair_conformance.harness.liveness import first_unanswered
from openair_conformance.harness.probe import TargetUnreachable
from openair_conformance.model import (
    CaseFinished,
    CaseInfo,
    CaseResult,
    CaseStarted,
    Event,
    Reporter,
    RunFinished,
    RunStarted,
    RunSummary,
    TargetDeath,
    TraceEntry,
    Verdict,
)
from openair_conformance.registry import RegisteredCase, all_cases, select_cases
from openair_conformance.schedule import (
    DEATH_ACTIONS,
    ORDERS,
    EngineError,
    NoCasesSelected,
    Schedule,
)
from openair_conformance.targets import Case, Started, Target
from openair_conformance.targets.server import (
    DEFAULT_STREAM,
    RunOptions,
    ServerTarget,
    parse_target,
)
from openair_conformance.verdicts import (
    DEFAULT_FAIL_ON,
    EXIT_TARGET_DIED,
    LATENCY_MEASURE,
    case_result,
    exit_code,
    judge,
    summarize,
)

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
    "Schedule",
    "TargetUnreachable",
    "close_reporters",
    "exit_code",
    "judge",
    "parse_target",
    "run",
    "run_target",
]

C = TypeVar("C", bound=Case)

#: Verdicts after which the target is not asked whether it is still alive: it just answered.
_ANSWERED = frozenset({Verdict.PASS, Verdict.NOT_APPLICABLE, Verdict.UNEXPECTED_PASS})


@dataclass(slots=True)
class _Run(Generic[C]):
    target: Target[C]
    schedule: Schedule
    reporters: Sequence[Reporter]
    expectations: Expectations | None
    results: list[CaseResult] = field(default_factory=list)
    vacuous: list[str] = field(default_factory=list)
    deaths: list[TargetDeath] = field(default_factory=list)
    not_run: list[str] = field(default_factory=list)
    stopped: bool = False
    down: bool = False  # the target was last seen dead (`continue` reports each death once)
    restarting: bool = False
    interrupted: list[tuple[C, CaseResult]] = field(default_factory=list)
    in_flight: set[str] = field(default_factory=set)
    #: Traces of the cases that may have been running when the target died (to name the one):
    #: when each began, and how to read its entries so far.
    watched: dict[str, tuple[float, Callable[[], Sequence[TraceEntry]]]] = field(
        default_factory=dict
    )
    gate: asyncio.Event = field(default_factory=asyncio.Event)  # set: cases may start
    idle: asyncio.Event = field(default_factory=asyncio.Event)  # set: no case in flight

    def emit(self, event: Event) -> None:
        for reporter in self.reporters:
            reporter.handle(event)

    async def schedule_cases(self, cases: Sequence[C], jobs: int) -> None:
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

    async def run_case(self, case: C, *, first: CaseResult | None = None) -> None:
        """Run one case, ask the target whether it survived, and emit the result."""
        info = case.info
        if first is None:
            self.emit(CaseStarted(info=info))
        self._enter(info.id)
        try:
            result = await self._attempt(case)
            problem = None if result.verdict in _ANSWERED else await self.target.alive()
        finally:
            self._leave(info.id)
        if first is not None:
            result = _rerun(result, first)
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

    async def _attempt(self, case: C) -> CaseResult:
        info = case.info
        started = time.monotonic()

        def watch(origin: float, entries: Callable[[], Sequence[TraceEntry]]) -> None:
            self.watched[info.id] = (origin, entries)

        attempt = await self.target.attempt(case, watch)
        if attempt.outcome is None and attempt.vacuous_reason:
            self.vacuous.append(info.id)  # OA-GEN-7, judged in case_result
        expectation = find_expectation(self.expectations, info)
        duration = time.monotonic() - started
        return case_result(info, attempt, duration=duration, expectation=expectation)

    async def _on_death(self, case: C, result: CaseResult, problem: str, *, rerun: bool) -> bool:
        """Act per --on-target-death; return True when the result is held for a rerun."""
        mode = self.schedule.on_target_death
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
        traces = {cid: (origin, read()) for cid, (origin, read) in self.watched.items()}
        culprit = first_unanswered(traces) or case_id
        suspects = (set(others) | {case_id} | set(self.watched)) - {culprit}
        death = TargetDeath(
            case=culprit, detail=problem, action=action, in_flight=tuple(sorted(suspects))
        )
        self.deaths.append(death)
        self.watched = {cid: t for cid, t in self.watched.items() if cid in self.in_flight}

    async def _restart(self, case_id: str, problem: str, others: tuple[str, ...]) -> None:
        """Hold new cases, let the running ones end, restart, then rerun the interrupted."""
        self.restarting = True
        self.gate.clear()
        await self.idle.wait()
        failed = await self.target.restart()
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


def _rerun(result: CaseResult, first: CaseResult) -> CaseResult:
    note = f"rerun after restart; the first attempt was {first.verdict.value}"
    message = f"{note}: {first.message}" if first.message else note
    return replace(
        result,
        rerun_after_restart=True,
        message=f"{message}\n{result.message}" if result.message else message,
    )


def _ordered(cases: Sequence[C], schedule: Schedule) -> list[C]:
    """Return the cases in the order asked for (`random`: shuffled with the run's seed)."""
    ordered = list(cases)
    if schedule.order == "random":
        random.Random(schedule.seed).shuffle(ordered)
    return ordered


def close_reporters(reporters: Sequence[Reporter]) -> None:
    """Close every reporter once; one that fails must not stop the others' files."""
    for reporter in reporters:
        try:
            reporter.close()
        except Exception as exc:
            print(f"reporter {type(reporter).__name__} failed to close: {exc}", file=sys.stderr)


async def run_target(
    target: Target[C],
    selected: Sequence[C],
    reporters: Sequence[Reporter] = (),
    *,
    schedule: Schedule | None = None,
    expectations: Expectations | None = None,
    known: Sequence[CaseInfo] = (),
) -> RunSummary:
    """Start `target`, run `selected` and return the summary; reporters are closed always.

    Raises whatever `target.start()` raises (the target cannot be used) before any event.
    `known` (every case of the suite) only serves to name expectations that match none.
    """
    try:
        return await _run_target(
            target, selected, reporters, schedule or Schedule(), expectations, known
        )
    finally:
        close_reporters(reporters)


async def _run_target(
    target: Target[C],
    selected: Sequence[C],
    reporters: Sequence[Reporter],
    schedule: Schedule,
    expectations: Expectations | None,
    known: Sequence[CaseInfo],
) -> RunSummary:
    started_wall, started = time.time(), time.monotonic()
    begun: Started = await target.start()
    try:
        state = _Run(
            target=target, schedule=schedule, reporters=reporters, expectations=expectations
        )
        state.emit(
            RunStarted(
                target=target.label,
                started=started_wall,
                options=begun.options,
                server=begun.server,
                cases=len(selected),
            )
        )
        state.gate.set()
        state.idle.set()
        ordered = _ordered([c for c in selected if not c.info.residue], schedule)
        await state.schedule_cases([c for c in ordered if not c.info.serial], schedule.jobs)
        # Serial cases need global state: each runs alone.
        await state.schedule_cases([c for c in ordered if c.info.serial], 1)
        # Cases that may leave what no namespace holds come last, alone, in ID order: whatever
        # the order of the others, none of them can meet it.
        await state.schedule_cases([c for c in selected if c.info.residue], 1)
        summary = summarize(
            state.results,
            duration=time.monotonic() - started,
            latencies=begun.latencies,
            vacuous=state.vacuous,
            unknown_expectations=unknown_entries(expectations, known),
            deaths=state.deaths,
            not_run=state.not_run,
        )
        state.emit(RunFinished(summary=summary))
        return summary
    finally:
        await target.close()


async def run(
    options: RunOptions,
    reporters: Sequence[Reporter] = (),
    *,
    cases: Sequence[RegisteredCase] | None = None,
) -> RunSummary:
    """Server mode: probe the server at `options.target`, run the selected cases.

    `cases` replaces the registry (tests); the --case/--section filters apply to it too.
    Raises ExpectationError (bad expectations file), NoCasesSelected or TargetUnreachable before
    any event is emitted. Reporters are closed in every case.
    """
    token = TARGET_TLS.set(options.tls)  # every connection of this run (spec 14.3)
    try:
        expectations = load_expectations(options.expectations) if options.expectations else None
        known = list(cases) if cases is not None else all_cases()
        selected = select_cases(known, globs=options.case_globs, sections=options.sections)
        if not selected:
            raise NoCasesSelected("no case matches the --case/--section filters")
    except BaseException:
        TARGET_TLS.reset(token)
        close_reporters(reporters)
        raise
    try:
        return await run_target(
            ServerTarget(options),
            selected,
            reporters,
            schedule=options.schedule,
            expectations=expectations,
            known=[c.info for c in known],
        )
    finally:
        TARGET_TLS.reset(token)
