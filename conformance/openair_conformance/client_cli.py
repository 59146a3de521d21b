"""The `openair conform-client` command: judge a client library through its shim.

`openair conform-client --shim "CMD ARGS" [OPTIONS]` runs the client scenarios
(`scenarios/*.xml`) against the library the shim drives (shim/PROTOCOL.md) and reports them with
the reporters of server mode; `--list` lists the scenarios. JSON reports of several bindings
compare side by side with `openair conform report a.json b.json -o matrix.html` (each column is
labelled with the shim's library name and version).
"""

from __future__ import annotations

import asyncio
import shlex
import sys
from pathlib import Path

import click

from openair_conformance.cli import load_reporters, parse_fail_on, report_options, reports_failed
from openair_conformance.clientmode.engine import (
    ClientRunOptions,
    NoScenariosSelected,
    ShimUnavailable,
    run_client,
)
from openair_conformance.clientmode.scenario import ScenarioError, load_scenarios, select_scenarios
from openair_conformance.engine import exit_code
from openair_conformance.shim.driver import ShimError

__all__ = ["CLIENT_EXIT_CODES", "conform_client"]

CLIENT_EXIT_CODES = """\b
Exit codes:
  0  no result has a verdict in the --fail-on set
  1  some result has a verdict in the --fail-on set
  2  usage error: bad option, bad scenario file, no scenario selected
  3  the shim cannot be started, or does not write its ready line
  4  a report asked for (--junit, --json, --html) could not be written"""


def _list(globs: tuple[str, ...], folder: Path | None) -> None:
    for scenario in select_scenarios(load_scenarios(folder), globs):
        info = scenario.info
        click.echo(
            f"{info.id:<8} {info.level.value:<6} {info.section:<5} {scenario.peer.kind:<20} "
            f"{info.title}"
        )


@click.command(
    "conform-client",
    epilog=CLIENT_EXIT_CODES,
    context_settings={"help_option_names": ["-h", "--help"]},
)
@click.option("--shim", metavar='"CMD ARGS"', help="The shim command line (split like a shell).")
@click.option(
    "--scenario",
    "scenarios",
    multiple=True,
    metavar="GLOB",
    help="Run only scenarios whose ID matches (repeatable), e.g. 'CLI-01*'.",
)
@click.option("--list", "list_only", is_flag=True, help="List the scenarios and exit.")
@click.option(
    "-j",
    "--jobs",
    type=click.IntRange(min=1),
    default=1,
    show_default=True,
    help="Run N scenarios at a time (each has its own server and shim).",
)
@click.option(
    "--timeout-scale",
    type=click.FloatRange(min=0, min_open=True),
    default=1.0,
    show_default=True,
    help="Multiply every deadline (slow shims or machines).",
)
@report_options
@click.option(
    "--scenario-dir",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    help="Read scenarios from this folder instead of the shipped ones.",
)
@click.option("-v", "--verbose", is_flag=True, help="Show traces of every result.")
def conform_client(
    shim: str | None,
    scenarios: tuple[str, ...],
    list_only: bool,
    jobs: int,
    timeout_scale: float,
    fail_on: str,
    junit: Path | None,
    json_path: Path | None,
    html: Path | None,
    html_traces: str,
    scenario_dir: Path | None,
    verbose: bool,
) -> None:
    """Judge a client library through its shim, scenario by scenario.

    The shim is a small program of the binding that speaks openair-shim/1 on its standard input
    and output; the kit plays the server (the reference server behind a frame-capturing proxy,
    or a scripted misbehaving peer) and checks both the shim's answers and every frame the
    library put on the wire. Example:

    \b
      openair conform-client --shim "python -m openair.client.shim" --json py.json
    """
    if list_only:
        try:
            _list(scenarios, scenario_dir)
        except ScenarioError as exc:
            raise click.UsageError(str(exc)) from exc
        return
    options = ClientRunOptions(
        shim=_shim_argv(shim),
        scenario_globs=scenarios,
        jobs=jobs,
        timeout_scale=timeout_scale,
        fail_on=parse_fail_on(fail_on),
        scenario_dir=scenario_dir,
    )
    reporters = load_reporters(
        sys.stdout,
        verbose=verbose,
        junit=junit,
        json_path=json_path,
        html=html,
        html_traces=html_traces,
    )
    try:
        summary = asyncio.run(run_client(options, reporters))
    except (ScenarioError, NoScenariosSelected) as exc:
        raise click.UsageError(str(exc)) from exc
    except (ShimUnavailable, ShimError) as exc:
        click.echo(f"error: the shim cannot be used: {exc}", err=True)
        sys.exit(3)
    sys.exit(4 if reports_failed(reporters) else exit_code(summary, options.fail_on))


def _shim_argv(shim: str | None) -> tuple[str, ...]:
    """Split --shim like a shell would; a usage error when it is missing or empty."""
    if not shim:
        raise click.UsageError("--shim is required (or --list)")
    try:
        argv = tuple(shlex.split(shim))
    except ValueError as exc:  # an unclosed quote
        raise click.BadParameter(str(exc), param_hint="--shim") from exc
    if not argv:
        raise click.BadParameter("the shim command is empty", param_hint="--shim")
    return argv
