"""The client-mode engine: probe the shim, run the selected scenarios, judge them, emit events.

The same events as server mode (`RunStarted`, `CaseStarted`, `CaseFinished`, `RunFinished`) go
to the same reporters, and a scenario's outcome becomes a `CaseResult` through the same
`engine.judge`, so verdicts, reports and exit codes mean the same in both modes. The run's
`ServerInfo` describes the library instead of a server: `server` is the shim's
`library version` (the label of its column in a comparison page), `protocol` the shim protocol.
"""

from __future__ import annotations

import asyncio
import math
import secrets
import shlex
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from openair_conformance.clientmode.runner import DEADLINE_S, LATENCY_MEASURE, ScenarioRun
from openair_conformance.clientmode.scenario import Scenario, load_scenarios, select_scenarios
from openair_conformance.engine import DEFAULT_FAIL_ON, EngineError, close_reporters, judge
from openair_conformance.model import (
    CaseFinished,
    CaseResult,
    CaseStarted,
    Event,
    Fail,
    Reporter,
    RunFinished,
    RunStarted,
    RunSummary,
    ServerInfo,
    Verdict,
)
from openair_conformance.shim.driver import ShimDriver, ShimError, ShimInfo

__all__ = [
    "ClientRunOptions",
    "NoScenariosSelected",
    "ShimUnavailable",
    "probe_shim",
    "run_client",
]

_BUDGET_S = 120.0  # per scenario (× timeout scale): every wait inside is bounded far below


class NoScenariosSelected(EngineError):
    """The --scenario filters selected nothing."""


class ShimUnavailable(Exception):
    """The shim cannot be started or does not say ready (exit code 3)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class ClientRunOptions:
    """What to run, with which shim, and how."""

    shim: tuple[str, ...]
    scenario_globs: tuple[str, ...] = ()
    jobs: int = 1
    timeout_scale: float = 1.0
    fail_on: frozenset[Verdict] = DEFAULT_FAIL_ON
    run_id: str = field(default_factory=lambda: secrets.token_hex(2))
    scenario_dir: Path | None = None
    env: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        if not self.shim:
            raise EngineError("no shim command")
        if self.jobs < 1:
            raise EngineError("jobs must be at least 1")
        if not (self.timeout_scale > 0 and math.isfinite(self.timeout_scale)):
            raise EngineError("timeout scale must be a positive number")

    @property
    def shim_text(self) -> str:
        """The shim command as one shell word list."""
        return shlex.join(self.shim)

    def repro(self, scenario_id: str) -> str:
        words = ["openair", "conform-client", "--shim", self.shim_text, "--scenario", scenario_id]
        if self.timeout_scale != 1.0:
            words += ["--timeout-scale", f"{self.timeout_scale:g}"]
        return shlex.join(words)


async def probe_shim(options: ClientRunOptions) -> tuple[ShimInfo, float]:
    """Start the shim once, read its ready line, close it; ShimUnavailable if that fails."""
    driver = ShimDriver(options.shim, env=dict(options.env) or None)
    try:
        info = await driver.start(10.0 * options.timeout_scale)
    except ShimError as exc:
        raise ShimUnavailable(str(exc)) from exc
    finally:
        await driver.close(5.0 * options.timeout_scale)
    return info, driver.ready_after


def _percentile(values: Sequence[float], fraction: float) -> float:
    ordered = sorted(values)
    return ordered[max(1, math.ceil(fraction * len(ordered))) - 1]


@dataclass(slots=True)
class _ClientRun:
    options: ClientRunOptions
    reporters: Sequence[Reporter]
    results: list[CaseResult] = field(default_factory=list)

    def emit(self, event: Event) -> None:
        for reporter in self.reporters:
            reporter.handle(event)

    async def run_scenario(self, scenario: Scenario) -> None:
        info = scenario.info
        self.emit(CaseStarted(info=info))
        run = ScenarioRun(
            scenario,
            shim=self.options.shim,
            run_id=self.options.run_id,
            timeout_scale=self.options.timeout_scale,
            env=dict(self.options.env) or None,
        )
        started = time.monotonic()
        outcome: BaseException | None = None
        try:
            await asyncio.wait_for(run.run(), _BUDGET_S * self.options.timeout_scale)
        except TimeoutError:
            outcome = RuntimeError("the scenario did not finish within its budget")
        except Exception as exc:
            outcome = exc
        verdict, message, expected = judge(info, outcome)
        divergence = outcome.divergence if isinstance(outcome, Fail) else None
        result = CaseResult(
            info=info,
            verdict=verdict,
            message=message,
            expected=expected or "\n".join(info.allowed),
            trace=run.trace.entries,
            divergence=divergence,
            duration=time.monotonic() - started,
            repro=self.options.repro(info.id),
            measurements=tuple(run.measurements),
        )
        self.results.append(result)
        self.emit(CaseFinished(result=result))

    def summary(self, duration: float, ready_ms: float) -> RunSummary:
        counts = {v: 0 for v in Verdict}
        for result in self.results:
            counts[result.verdict] += 1
        samples = [v for r in self.results for n, v in r.measurements if n == LATENCY_MEASURE]
        latencies: list[tuple[str, float]] = [("rtt_ms", 0.0), ("shim_ready_ms", ready_ms)]
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
            results=tuple(sorted(self.results, key=lambda r: r.info.id)),
        )


def _options_record(options: ClientRunOptions, scale: float) -> dict[str, str]:
    record = {
        "mode": "client",
        "shim": options.shim_text,
        "jobs": str(options.jobs),
        "timeout_scale": f"{scale:g}",
        "deadline_s": f"{DEADLINE_S * scale:.3f}",
        "run_id": options.run_id,
        "fail_on": ",".join(sorted(v.value for v in options.fail_on)),
    }
    if options.scenario_globs:
        record["scenarios"] = " ".join(options.scenario_globs)
    return record


async def run_client(
    options: ClientRunOptions,
    reporters: Sequence[Reporter] = (),
    *,
    scenarios: Sequence[Scenario] | None = None,
) -> RunSummary:
    """Probe the shim, run the selected scenarios and return the summary.

    Raises ScenarioError (a bad scenario file), NoScenariosSelected or ShimUnavailable before
    any event. Reporters are closed in every case.
    """
    try:
        return await _run(options, reporters, scenarios)
    finally:
        close_reporters(reporters)


async def _run(
    options: ClientRunOptions, reporters: Sequence[Reporter], scenarios: Sequence[Scenario] | None
) -> RunSummary:
    known = list(scenarios) if scenarios is not None else load_scenarios(options.scenario_dir)
    selected = select_scenarios(known, options.scenario_globs)
    if not selected:
        raise NoScenariosSelected("no scenario matches the --scenario filters")
    started_wall, started = time.time(), time.monotonic()
    info, ready_after = await probe_shim(options)
    state = _ClientRun(options=options, reporters=reporters)
    state.emit(
        RunStarted(
            target=options.shim_text,
            started=started_wall,
            options=_options_record(options, options.timeout_scale),
            server=ServerInfo(legacy=False, server=info.label, protocol=info.protocol),
            cases=len(selected),
        )
    )
    window = asyncio.Semaphore(options.jobs)

    async def limited(scenario: Scenario) -> None:
        async with window:
            await state.run_scenario(scenario)

    await asyncio.gather(*(limited(s) for s in selected))
    summary = state.summary(time.monotonic() - started, ready_after * 1000)
    state.emit(RunFinished(summary=summary))
    return summary
