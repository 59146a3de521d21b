"""The client-mode engine: probe the shim, run the selected scenarios, judge them, emit events.

The scenarios run on the one engine (`engine.run_target`) over a `ShimTarget`: the same
events as server mode (`RunStarted`, `CaseStarted`, `CaseFinished`, `RunFinished`) go to the
same reporters, and a scenario's outcome becomes a `CaseResult` through the same verdict model
(`verdicts`), so verdicts, summaries, reports and exit codes mean the same in both modes. The run's
`ServerInfo` describes the library instead of a server: `server` is the shim's
`library version` (the label of its column in a comparison page), `protocol` the shim protocol.
"""

from __future__ import annotations

import asyncio
import math
import secrets
import shlex
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from openair_conformance.clientmode.runner import DEADLINE_S, ScenarioRun
from openair_conformance.clientmode.scenario import Scenario, load_scenarios, select_scenarios
from openair_conformance.engine import close_reporters, run_target
from openair_conformance.model import (
    Fail,
    Reporter,
    RunSummary,
    ServerInfo,
    Verdict,
)
from openair_conformance.schedule import EngineError, Schedule
from openair_conformance.shim.driver import ShimDriver, ShimError, ShimInfo
from openair_conformance.targets import Started, Watch
from openair_conformance.verdicts import DEFAULT_FAIL_ON, Attempt

__all__ = [
    "ClientRunOptions",
    "NoScenariosSelected",
    "ShimTarget",
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


class ShimTarget:
    """A client library through its shim: each scenario starts its own peer and shim."""

    def __init__(self, options: ClientRunOptions) -> None:
        self.options = options
        self.label = options.shim_text

    async def start(self) -> Started:
        info, ready_after = await probe_shim(self.options)
        return Started(
            server=ServerInfo(legacy=False, server=info.label, protocol=info.protocol),
            options=_options_record(self.options, self.options.timeout_scale),
            latencies=(("rtt_ms", 0.0), ("shim_ready_ms", ready_after * 1000)),
        )

    async def attempt(self, case: Scenario, watch: Watch) -> Attempt:
        run = ScenarioRun(
            case,
            shim=self.options.shim,
            run_id=self.options.run_id,
            timeout_scale=self.options.timeout_scale,
            env=dict(self.options.env) or None,
        )
        watch(run.trace.origin, lambda: run.trace.entries)
        outcome: BaseException | None = None
        try:
            await asyncio.wait_for(run.run(), _BUDGET_S * self.options.timeout_scale)
        except TimeoutError:
            outcome = RuntimeError("the scenario did not finish within its budget")
        except Exception as exc:
            outcome = exc
        return Attempt(
            outcome=outcome,
            trace=run.trace.entries,
            divergence=outcome.divergence if isinstance(outcome, Fail) else None,
            measurements=tuple(run.measurements),
            repro=self.options.repro(case.info.id),
        )

    async def alive(self) -> None:
        """Each scenario has a shim and a peer of its own: there is nothing to die."""
        return None

    async def restart(self) -> None:
        return None

    async def close(self) -> None:
        return None


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
        known = list(scenarios) if scenarios is not None else load_scenarios(options.scenario_dir)
        selected = select_scenarios(known, options.scenario_globs)
        if not selected:
            raise NoScenariosSelected("no scenario matches the --scenario filters")
    except BaseException:
        close_reporters(reporters)
        raise
    return await run_target(
        ShimTarget(options), selected, reporters, schedule=Schedule(jobs=options.jobs)
    )
