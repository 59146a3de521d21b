"""`openair conform-worldmodel HOST:PORT --module NAME`: judge a world-model module."""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

import click

from openair_conformance.cli import load_reporters, parse_fail_on, report_options, reports_failed
from openair_conformance.schedule import NoCasesSelected
from openair_conformance.verdicts import exit_code
from openair_conformance.worldmodel.runner import WorldModelTarget, run_worldmodel


@click.command("conform-worldmodel")
@click.argument("address")
@click.option("--module", "module", required=True, help="The world-model module under test.")
@click.option("--whiteboard", default="WB1", show_default=True, help="Its robot's whiteboard.")
@click.option("--bound", default=10.0, show_default=True, help="Seconds each wait may take.")
@click.option("--case", "select", default="", help="Run only cases whose ID starts with this.")
@report_options
@click.option("-v", "--verbose", is_flag=True, help="Show traces of every result.")
def conform_worldmodel(
    address: str,
    module: str,
    whiteboard: str,
    bound: float,
    select: str,
    fail_on: str,
    junit: Path | None,
    json_path: Path | None,
    html: Path | None,
    html_traces: str,
    verbose: bool,
) -> None:
    """Run the world-model cases WM-001… (spec 16) against MODULE through a whiteboard.

    The results go to the reporters of `openair conform` (console, --json, --junit, --html)
    with the same verdicts.

    \b
    Exit codes: 0 no result has a verdict in the --fail-on set, 1 some result has,
    2 usage error (bad address, no case selected), 3 could not connect,
    4 a report asked for could not be written.
    """
    host, _, port = address.rpartition(":")
    if not host or not port.isdigit():
        raise click.BadParameter("expected HOST:PORT", param_hint="ADDRESS")
    fail = parse_fail_on(fail_on)
    reporters = load_reporters(
        sys.stdout,
        verbose=verbose,
        junit=junit,
        json_path=json_path,
        html=html,
        html_traces=html_traces,
    )
    target = WorldModelTarget(host, int(port), module, whiteboard=whiteboard, bound=bound)
    try:
        summary = asyncio.run(run_worldmodel(target, reporters, prefix=select))
    except NoCasesSelected as exc:
        raise click.UsageError(str(exc)) from exc
    except OSError as exc:
        click.echo(f"cannot connect to {address}: {exc}", err=True)
        raise SystemExit(3) from None
    sys.exit(4 if reports_failed(reporters) else exit_code(summary, fail))
