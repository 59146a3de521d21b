"""`openair conform-worldmodel HOST:PORT --module NAME`: judge a world-model module."""

from __future__ import annotations

import asyncio

import click

from openair_conformance.worldmodel.runner import run_cases


@click.command("conform-worldmodel")
@click.argument("address")
@click.option("--module", "module", required=True, help="The world-model module under test.")
@click.option("--whiteboard", default="WB1", show_default=True, help="Its robot's whiteboard.")
@click.option("--bound", default=10.0, show_default=True, help="Seconds each wait may take.")
@click.option("--case", "select", default="", help="Run only cases whose ID starts with this.")
def conform_worldmodel(
    address: str, module: str, whiteboard: str, bound: float, select: str
) -> None:
    """Run the world-model cases WM-001… (spec 16) against MODULE through a whiteboard.

    \b
    Exit codes: 0 every case passed, 1 a case failed or could not run, 2 usage error,
    3 could not connect.
    """
    host, _, port = address.rpartition(":")
    if not host or not port.isdigit():
        raise click.BadParameter("expected HOST:PORT", param_hint="ADDRESS")
    try:
        results = asyncio.run(
            run_cases(host, int(port), module, whiteboard=whiteboard, bound=bound, select=select)
        )
    except OSError as exc:
        click.echo(f"cannot connect to {address}: {exc}", err=True)
        raise SystemExit(3) from None
    for result in results:
        reqs = ", ".join(result.case.requirements)
        line = f"{result.case.id} {result.verdict:7} {result.case.title} [{reqs}]"
        click.echo(line + (f": {result.detail}" if result.detail else ""))
    failed = [r for r in results if r.verdict != "passed"]
    click.echo(f"{len(results) - len(failed)} passed, {len(failed)} not passed")
    raise SystemExit(1 if failed or not results else 0)
