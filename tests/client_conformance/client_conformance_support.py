"""Shared pieces of the client-conformance tests: shim command lines and a run helper."""

from __future__ import annotations

import asyncio
import sys
from collections.abc import Sequence
from pathlib import Path

from openair_conformance.clientmode.engine import ClientRunOptions, run_client
from openair_conformance.model import CaseResult, Reporter, RunSummary

HERE = Path(__file__).resolve().parent
PYTHON_SHIM = (sys.executable, "-m", "openair.client.shim")


def broken_shim(mode: str) -> tuple[str, ...]:
    """The command line of the Python shim with one behaviour broken."""
    return (sys.executable, str(HERE / "broken_client_shim.py"), mode)


def fake_shim(mode: str) -> tuple[str, ...]:
    """The command line of a shim that breaks the shim protocol itself."""
    return (sys.executable, str(HERE / "fake_client_shim.py"), mode)


def run(
    shim: Sequence[str],
    scenarios: Sequence[str] = (),
    *,
    reporters: Sequence[Reporter] = (),
    jobs: int = 1,
) -> RunSummary:
    """Run the selected scenarios with `shim` and return the summary."""
    options = ClientRunOptions(shim=tuple(shim), scenario_globs=tuple(scenarios), jobs=jobs)
    return asyncio.run(run_client(options, reporters))


def result(summary: RunSummary, scenario_id: str) -> CaseResult:
    """The result of one scenario."""
    return next(r for r in summary.results if r.info.id == scenario_id)
