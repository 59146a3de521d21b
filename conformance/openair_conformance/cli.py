"""The `openair conform` command group: run the suite, list and explain cases, show coverage.

`openair conform HOST:PORT [OPTIONS]` runs the suite (the group treats a first argument that is
not a subcommand as the target of `run`). Reporters come from `openair_conformance.reporters`
when that package provides them; a missing one is announced and skipped.
"""

from __future__ import annotations

import asyncio
import contextlib
import difflib
import importlib
import os
import ssl
import sys
import textwrap
from collections.abc import Callable, Iterator, Sequence
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any, TextIO, TypeVar

import click

from openair.catalogue import Requirement, load_catalogue
from openair.protocol.auth import SecretsError
from openair.secretsfile import load_secrets
from openair_conformance.engine import (
    DEFAULT_FAIL_ON,
    DEFAULT_STREAM,
    EngineError,
    NoCasesSelected,
    RunOptions,
    TargetUnreachable,
    exit_code,
    parse_target,
    run,
)
from openair_conformance.expectations import (
    ExpectationError,
    Expectations,
    find_expectation,
    load_expectations,
)
from openair_conformance.model import (
    CaseFinished,
    Event,
    Reporter,
    RunFinished,
    RunStarted,
    Verdict,
)
from openair_conformance.registry import RegisteredCase, all_cases, select_cases
from openair_conformance.untestable import KNOWN_GAPS, NOT_CHECKED

__all__ = [
    "EXIT_CODES",
    "ConformGroup",
    "conform",
    "load_reporters",
    "parse_fail_on",
    "report_options",
    "reports_failed",
]

EXIT_CODES = """\b
Exit codes:
  0  no result has a verdict in the --fail-on set
  1  some result has a verdict in the --fail-on set
  2  usage error: bad option, unreadable expectations file, no case selected
  3  cannot connect to the target, or it does not answer PING
  4  a report asked for (--html, --json, --junit, report -o) could not be written
     (a missing folder is created, and said on stderr)
  5  the target died during the run (stopped answering; see --on-target-death)"""

_REPORTERS = "openair_conformance.reporters"
_F = TypeVar("_F", bound=Callable[..., Any])


class ConformGroup(click.Group):
    """A group whose first argument, when it is not a subcommand, is the target of `run`."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in self.commands and args[0] not in ctx.help_option_names:
            args = ["run", *args]
        return super().parse_args(ctx, args)


@click.group(
    cls=ConformGroup,
    context_settings={"help_option_names": ["-h", "--help"]},
    epilog=EXIT_CODES,
)
def conform() -> None:
    """Judge an OpenAIR server requirement by requirement.

    \b
    openair conform HOST:PORT [OPTIONS]      run the suite (options: `openair conform run -h`)
    openair conform list                     the cases
    openair conform explain CASE             what a case checks, with the requirement sentences
    openair conform coverage                 every MUST and SHOULD with the cases checking it
    openair conform report A.json … -o F     compare JSON reports in one HTML page
    """


def parse_fail_on(text: str) -> frozenset[Verdict]:
    """Parse a comma-separated list of verdicts (`none` for the empty set)."""
    if text.strip().lower() == "none":
        return frozenset()
    try:
        return frozenset(Verdict(word.strip()) for word in text.split(",") if word.strip())
    except ValueError as exc:
        known = ", ".join(v.value for v in Verdict)
        raise click.BadParameter(f"{exc}; verdicts are: {known}, or none") from exc


def report_options(command: _F) -> _F:
    """Add --fail-on, --junit, --json, --html and --html-traces (conform run and conform-client)."""
    options = (
        click.option(
            "--fail-on",
            "fail_on",
            default=",".join(sorted(v.value for v in DEFAULT_FAIL_ON)),
            show_default=True,
            metavar="LIST",
            help="Verdicts that make the exit code 1 (comma-separated, or 'none').",
        ),
        click.option(
            "--junit", type=click.Path(dir_okay=False, path_type=Path), help="Write JUnit XML."
        ),
        click.option(
            "--json",
            "json_path",
            type=click.Path(dir_okay=False, path_type=Path),
            help="Write the JSON report.",
        ),
        click.option(
            "--html", type=click.Path(dir_okay=False, path_type=Path), help="Write the HTML report."
        ),
        click.option(
            "--html-traces",
            type=click.Choice(["failing", "all"]),
            default="failing",
            show_default=True,
            help="Traces in the HTML report: of results that are not passes, or of every result.",
        ),
    )
    for option in reversed(options):  # the first listed is applied last: it shows first
        command = option(command)
    return command


def _import_reporter(module: str, option: str) -> Any | None:
    name = f"{_REPORTERS}.{module}"
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name not in (name, _REPORTERS):
            raise
    click.echo(f"note: {name} is not installed; {option} skipped", err=True)
    return None


def load_reporters(
    stream: TextIO,
    *,
    verbose: bool,
    junit: Path | None = None,
    json_path: Path | None = None,
    html: Path | None = None,
    html_traces: str = "failing",
) -> list[Reporter]:
    """Instantiate the console reporter and those asked for; skip (and say) what is missing."""
    reporters: list[Reporter] = []
    console = _import_reporter("console", "console output")
    if console is not None:
        reporters.append(console.ConsoleReporter(stream, verbose))
    else:
        reporters.append(_FallbackConsole(stream))
    wanted = (
        ("junit", "JUnitReporter", junit, "--junit"),
        ("jsonreport", "JsonReporter", json_path, "--json"),
        ("html", "HtmlReporter", html, "--html"),
    )
    for module_name, class_name, path, option in wanted:
        if path is None:
            continue
        module = _import_reporter(module_name, option)
        if module is not None:
            extra = {"traces": html_traces} if option == "--html" else {}
            reporters.append(getattr(module, class_name)(path, **extra))
    return reporters


def reports_failed(reporters: Sequence[Reporter]) -> bool:
    """Whether a file reporter could not write its report (exit code 4)."""
    return any(getattr(reporter, "failed", False) for reporter in reporters)


@contextlib.contextmanager
def _hypothesis_home() -> Iterator[None]:
    """Keep hypothesis' files (FUZZ-001) out of the working folder: under the user's cache.

    `$HYPOTHESIS_STORAGE_DIRECTORY` still wins; the variable is set only while the suite runs.
    """
    key = "HYPOTHESIS_STORAGE_DIRECTORY"
    if os.environ.get(key):
        yield
        return
    cache = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    os.environ[key] = str(Path(cache, "openair", "hypothesis"))
    try:
        yield
    finally:
        os.environ.pop(key, None)


class _FallbackConsole:
    """One line per result that is not a pass, and the totals (used without reporters.console)."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream

    def handle(self, event: Event) -> None:
        if isinstance(event, RunStarted):
            legacy = " (legacy)" if event.server.legacy else ""
            print(f"{event.target}{legacy}: {event.cases} case(s)", file=self.stream)
        elif isinstance(event, CaseFinished) and event.result.verdict is not Verdict.PASS:
            r = event.result
            print(f"{r.verdict.value:>16}  {r.info.id}  {r.info.title}", file=self.stream)
        elif isinstance(event, RunFinished):
            summary = event.summary
            for entry in summary.unknown_expectations:
                print(f"expectation matches no case: {entry}", file=self.stream)
            counts = ", ".join(f"{v.value} {n}" for v, n in summary.counts)
            print(f"{counts} in {summary.duration:.1f} s", file=self.stream)

    def close(self) -> None:
        self.stream.flush()


def _secrets(path: str | None) -> dict[str, str]:
    """Read --auth-secrets (spec 14.3); a file that cannot be used is a usage error."""
    if path is None:
        return {}
    try:
        return load_secrets(path)
    except SecretsError as exc:
        raise click.UsageError(f"--auth-secrets: {exc}") from exc


def _tls(cafile: str | None) -> ssl.SSLContext | None:
    """Read --tls-ca: a context that verifies the target against FILE (OA-AUTH-10)."""
    if cafile is None:
        return None
    try:
        return ssl.create_default_context(cafile=cafile)
    except (ssl.SSLError, OSError) as exc:
        raise click.UsageError(f"--tls-ca: {exc}") from exc


def _fuzz_available() -> bool:
    try:
        importlib.import_module("openair_conformance.fuzz")
    except ModuleNotFoundError as exc:
        if exc.name not in ("openair_conformance.fuzz", "hypothesis"):  # hypothesis: [fuzz]
            raise
        return False
    return True


@conform.command("run", epilog=EXIT_CODES, context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("target")
@click.option(
    "--case",
    "cases",
    multiple=True,
    metavar="GLOB",
    help="Run only cases whose ID matches (repeatable), e.g. 'MATCH-*'.",
)
@click.option(
    "--section",
    "sections",
    multiple=True,
    metavar="N",
    help="Run only cases of spec section N and its subsections (repeatable).",
)
@click.option(
    "-j",
    "--jobs",
    type=click.IntRange(min=1),
    default=4,
    show_default=True,
    help="Run N non-serial cases at a time (their names, types and whiteboard contents are "
    "their own); serial cases run alone afterwards.",
)
@click.option(
    "--timeout-scale",
    type=click.FloatRange(min=0, min_open=True),
    default=1.0,
    show_default=True,
    help="Multiply every deadline (slow targets).",
)
@click.option(
    "--expectations",
    metavar="PATH|NAME",
    help="Expectations file, or the name of a shipped one (psyclone-1.1.7).",
)
@report_options
@click.option("-v", "--verbose", is_flag=True, help="Show traces of every result.")
@click.option(
    "--fuzz-examples",
    type=click.IntRange(min=0),
    metavar="N",
    help="Examples per fuzzing case (openair_conformance.fuzz).",
)
@click.option("--replay", metavar="SEED", help="Replay one fuzzing run.")
@click.option(
    "--stream",
    default=DEFAULT_STREAM,
    show_default=True,
    metavar="NAME",
    help="The stream the stream cases use (not applicable when it does not resolve).",
)
@click.option(
    "--auth-secrets",
    type=click.Path(dir_okay=False, exists=True),
    metavar="FILE",
    help="Secrets file (<secrets><module name secret/></secrets>) of modules the secure-mode "
    "cases (extension auth, spec 14.3) may prove; without it they are not applicable.",
)
@click.option(
    "--tls-ca",
    type=click.Path(dir_okay=False, exists=True),
    metavar="FILE",
    help="Connect to the target with TLS, trusting the CA certificates (PEM) in FILE "
    "(spec 14.3, a server in secure mode).",
)
@click.option(
    "--order",
    type=click.Choice(["registry", "random"]),
    default="registry",
    show_default=True,
    help="Start cases in ID order, or shuffled (with --seed; a drawn seed is reported).",
)
@click.option("--seed", type=int, metavar="N", help="Seed of --order random.")
@click.option(
    "--on-target-death",
    type=click.Choice(["stop", "continue", "restart-cmd"]),
    default="stop",
    show_default=True,
    help="When the target stops answering: start no further case, go on, or run "
    "--restart-cmd, wait until it answers and run the interrupted case once more.",
)
@click.option(
    "--restart-cmd", metavar="CMD", default="", help="Shell command restarting the target."
)
def run_command(
    target: str,
    cases: tuple[str, ...],
    sections: tuple[str, ...],
    jobs: int,
    timeout_scale: float,
    expectations: str | None,
    fail_on: str,
    junit: Path | None,
    json_path: Path | None,
    html: Path | None,
    html_traces: str,
    verbose: bool,
    fuzz_examples: int | None,
    replay: str | None,
    stream: str,
    auth_secrets: str | None,
    tls_ca: str | None,
    order: str,
    seed: int | None,
    on_target_death: str,
    restart_cmd: str,
) -> None:
    """Run the suite against TARGET (HOST:PORT; the port defaults to 10000)."""
    try:
        address = parse_target(target)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="TARGET") from exc
    verdicts = parse_fail_on(fail_on)
    if expectations is not None:
        try:
            load_expectations(expectations)
        except ExpectationError as exc:
            raise click.UsageError(f"--expectations: {exc}") from exc
    if not _fuzz_available() and (not cases or any(fnmatchcase("FUZZ-001", g) for g in cases)):
        click.echo("note: FUZZ-001 not run: pip install 'openair-kit[fuzz]'", err=True)
    try:
        options = RunOptions(
            target=address,
            case_globs=cases,
            sections=sections,
            jobs=jobs,
            timeout_scale=timeout_scale,
            expectations=expectations,
            fail_on=verdicts,
            verbose=verbose,
            fuzz_examples=fuzz_examples,
            replay=replay,
            stream=stream,
            auth_secrets=_secrets(auth_secrets),
            tls=_tls(tls_ca),
            order=order,
            seed=seed,
            on_target_death="restart" if on_target_death == "restart-cmd" else on_target_death,
            restart_cmd=restart_cmd,
        )
    except EngineError as exc:
        raise click.UsageError(str(exc)) from exc
    reporters = load_reporters(
        sys.stdout,
        verbose=verbose,
        junit=junit,
        json_path=json_path,
        html=html,
        html_traces=html_traces,
    )
    try:
        with _hypothesis_home():
            summary = asyncio.run(run(options, reporters))
    except NoCasesSelected as exc:
        raise click.UsageError(str(exc)) from exc
    except TargetUnreachable as exc:
        click.echo(f"error: cannot talk to {options.target_text}: {exc}", err=True)
        sys.exit(3)
    sys.exit(4 if reports_failed(reporters) else exit_code(summary, verdicts))


@conform.command("list")
@click.option("--case", "cases", multiple=True, metavar="GLOB", help="Only IDs matching GLOB.")
@click.option("--section", "sections", multiple=True, metavar="N", help="Only section N.")
def list_command(cases: tuple[str, ...], sections: tuple[str, ...]) -> None:
    """List the cases by spec section: ID, level, section, title, and what they need."""
    selected = select_cases(all_cases(), globs=cases, sections=sections)
    for item in sorted(selected, key=lambda c: (_section_key(c.info.section), c.info.id)):
        info = item.info
        flags = [f"needs {','.join(sorted(info.needs))}"] if info.needs else []
        flags += ["serial"] if info.serial else []
        extra = f"  [{'; '.join(flags)}]" if flags else ""
        click.echo(f"{info.id:<10} {info.level.value:<6} {info.section:<6} {info.title}{extra}")


def _section_key(section: str) -> tuple[int, ...]:
    return tuple(int(part) for part in section.split("."))


def _find_case(case_id: str) -> RegisteredCase:
    known = {c.info.id: c for c in all_cases()}
    if case_id in known:
        return known[case_id]
    close = difflib.get_close_matches(case_id.upper(), list(known), n=3)
    hint = f" (did you mean {', '.join(close)}?)" if close else ""
    raise click.UsageError(f"no case {case_id!r}{hint}; see `openair conform list`")


def _requirement_line(req_id: str, catalogue: dict[str, Requirement]) -> str:
    req = catalogue.get(req_id)
    if req is None:
        return f"  {req_id}: NOT IN THE CATALOGUE"
    ext = f", extension {req.extension}" if req.extension else ""
    sentence = textwrap.fill(
        req.text, width=96, initial_indent="      ", subsequent_indent="      "
    )
    return f"  {req.id} ({req.level}, section {req.section}{ext}):\n{sentence}"


@conform.command("explain")
@click.argument("case_id", metavar="CASE")
@click.option("--expectations", metavar="PATH|NAME", help="Show the entry of this file.")
def explain_command(case_id: str, expectations: str | None) -> None:
    """Explain CASE: what it does, the requirements it checks, what the spec allows."""
    item = _find_case(case_id)
    info = item.info
    catalogue = load_catalogue()
    click.echo(f"{info.id}  {info.title}")
    needs = ", ".join(sorted(info.needs)) or "-"
    click.echo(
        f"section {info.section} · level {info.level.value} · needs {needs} · "
        f"{'serial' if info.serial else 'parallel'}"
    )
    if item.doc:
        click.echo("\nWhat it does:\n  " + item.doc.replace("\n", "\n  "))
    click.echo("\nRequirements:")
    for req_id in info.requirements:
        click.echo(_requirement_line(req_id, catalogue))
    if info.allowed:
        click.echo("\nAllowed behaviours:")
        for text in info.allowed:
            click.echo(f"  - {text}")
    if expectations is not None:
        _explain_expectation(info_id=info.id, item=item, spec=expectations)
    click.echo(f"\nRun it alone: openair conform HOST:PORT --case {info.id}")


def _explain_expectation(*, info_id: str, item: RegisteredCase, spec: str) -> None:
    try:
        loaded: Expectations = load_expectations(spec)
    except ExpectationError as exc:
        raise click.UsageError(f"--expectations: {exc}") from exc
    entry = find_expectation(loaded, item.info)
    if entry is None:
        click.echo(f"\n{loaded.implementation}: no expectation for {info_id}")
    else:
        click.echo(
            f"\n{loaded.implementation}: expected {entry.verdict.value} — {entry.describe()}"
        )


def coverage_rows(
    cases: Sequence[RegisteredCase], catalogue: dict[str, Requirement], levels: frozenset[str]
) -> list[tuple[Requirement, list[str]]]:
    """Return (requirement, IDs of the cases citing it) for each requirement of `levels`."""
    citing: dict[str, list[str]] = {}
    for item in cases:
        for req_id in item.info.requirements:
            citing.setdefault(req_id, []).append(item.info.id)
    return [(req, citing.get(req.id, [])) for req in catalogue.values() if req.level in levels]


def _unchecked(req_id: str) -> str:
    """Say why no case checks `req_id`: a known reason, or that it is a gap in the suite."""
    reason = NOT_CHECKED.get(req_id)
    if reason:
        return f"— not testable over TCP: {reason}"
    gap = KNOWN_GAPS.get(req_id)
    return f"— NOT CHECKED (known gap: {gap})" if gap else "— NOT CHECKED (a gap in the suite)"


@conform.command("coverage")
@click.option("--all", "include_may", is_flag=True, help="Include MAY requirements too.")
@click.option("--missing", is_flag=True, help="Show only requirements no case checks.")
def coverage_command(include_may: bool, missing: bool) -> None:
    """List every MUST and SHOULD of the catalogue with the cases that check it."""
    catalogue = load_catalogue()
    cases = all_cases()
    levels = frozenset({"MUST", "SHOULD", "MAY"} if include_may else {"MUST", "SHOULD"})
    rows = coverage_rows(cases, catalogue, levels)
    # The world-model cases (spec 16, `openair conform-worldmodel`) judge a module: add theirs.
    from openair_conformance.worldmodel.cases import CASES as WM_CASES

    for req, ids in rows:
        ids.extend(f"{wm.id} (conform-worldmodel)" for wm in WM_CASES if req.id in wm.requirements)
    for req, ids in rows:
        if missing and ids:
            continue
        ext = f" [ext {req.extension}]" if req.extension else ""
        checked = ", ".join(ids) if ids else _unchecked(req.id)
        click.echo(f"{req.id:<13} {req.level:<6} {req.section:<6} {checked}{ext}")
    for level in sorted(levels, key=["MUST", "SHOULD", "MAY"].index):
        total = [ids for req, ids in rows if req.level == level]
        covered = sum(1 for ids in total if ids)
        click.echo(f"{level}: {covered} of {len(total)} checked by at least one case")
    unknown = sorted({r for c in cases for r in c.info.requirements} - set(catalogue))
    if unknown:
        click.echo(
            f"error: cases cite requirements not in the catalogue: {', '.join(unknown)}", err=True
        )
        sys.exit(1)


@conform.command("report")
@click.argument(
    "reports", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path)
)
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="The HTML file to write.",
)
def report_command(reports: tuple[Path, ...], output: Path) -> None:
    """Render one or more JSON reports (A.json [B.json …]) as one HTML comparison page."""
    module = _import_reporter("html", "report")
    if module is None:
        sys.exit(2)
    try:
        module.write_comparison(list(reports), output)
    except ValueError as exc:  # jsonreport.ReportError: not a report of ours
        raise click.UsageError(str(exc)) from None
    except OSError as exc:
        click.echo(f"error: could not write {output}: {exc}", err=True)
        sys.exit(4)
    click.echo(f"wrote {output}")
