"""`openair ontology`: document, infer and lint message-type ontologies.

Each command is a thin function over the package's API. Exit codes (all commands):

\b
  0  success (lint: no finding at or above --fail-on)
  1  lint: at least one finding at or above --fail-on
  2  usage error, or an input that cannot be read: an invalid ontology, psySpec or history
  3  cannot connect to the server of a HOST:PORT history
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import click

from openair.protocol.address import parse_server
from openair.protocol.psyspec import ConfigError, load_config
from openair_ontology.history import (
    History,
    HistoryConnectError,
    HistoryError,
    history_of_recording,
    load_history,
    read_sqlite,
    read_xml,
    retrieve_live,
)
from openair_ontology.infer import infer_ontology
from openair_ontology.lint import Level, lint
from openair_ontology.markdown import write_markdown
from openair_ontology.model import Ontology, TypeIndex
from openair_ontology.parse import OntologyError, encode_ontology, read_ontology
from openair_ontology.paths import Paths
from openair_ontology.site import build_context, write_site
from openair_ontology.usage import Usage, merge, usage_from_config, usage_from_history

__all__ = ["ontology"]

EXIT_OK = 0
EXIT_FINDINGS = 1
EXIT_USAGE = 2
EXIT_CONNECT = 3

_EPILOG = (
    "Exit codes: 0 ok, 1 lint findings at or above --fail-on, 2 usage or bad input, "
    "3 cannot connect."
)
_HISTORY_HELP = (
    "A recorded history: sqlite:PATH (a server's store), HOST:PORT (a running server) or an "
    "XML file of <objectcollection> (a retrieve result). Repeatable."
)
_LEVELS = {"error": Level.ERROR, "warning": Level.WARNING, "info": Level.INFO}


def _fail(message: str, code: int = EXIT_USAGE) -> click.exceptions.Exit:
    click.echo(f"error: {message}", err=True)
    return click.exceptions.Exit(code)


def _histories(sources: Sequence[str], whiteboards: Sequence[str]) -> list[Usage]:
    """Read each history source; exit 2 (unreadable) or 3 (cannot connect) on failure."""
    usages = []
    for source in sources:
        try:
            history = load_history(source, whiteboards=whiteboards)
        except HistoryConnectError as exc:
            raise _fail(str(exc), EXIT_CONNECT) from None
        except HistoryError as exc:
            raise _fail(str(exc)) from None
        for note in history.notes:
            click.echo(f"note: {history.source}: {note}", err=True)
        usages.append(usage_from_history(history.messages))
    return usages


def _inputs(
    path: str, psyspec: str | None, sources: Sequence[str], whiteboards: Sequence[str]
) -> tuple[Ontology, Usage]:
    """Read the ontology, the psySpec and the histories; exit 2 or 3 when one cannot be read."""
    try:
        onto = read_ontology(path)
    except OntologyError as exc:
        raise _fail(str(exc)) from None
    usages = []
    if psyspec is not None:
        try:
            usages.append(usage_from_config(load_config(psyspec)))
        except ConfigError as exc:
            raise _fail(str(exc)) from None
    usages.extend(_histories(sources, whiteboards))
    return onto, merge(usages)


_psyspec_option = click.option(
    "--psyspec", metavar="SPEC.xml", help="The system's psySpec (modules, triggers, posts)."
)
_history_option = click.option(
    "--history", "histories", multiple=True, metavar="SRC", help=_HISTORY_HELP
)
_whiteboard_option = click.option(
    "--whiteboard",
    "whiteboards",
    multiple=True,
    metavar="NAME",
    help="For a HOST:PORT history: the whiteboards to read (default: those STATUS names).",
)


@click.group(context_settings={"help_option_names": ["-h", "--help"]}, epilog=_EPILOG)
def ontology() -> None:
    """Document, infer and lint message-type ontologies (schemas/ontology.xsd).

    An ontology writes down a system's dot-delimited message types as a tree, with
    descriptions, content, examples and deprecations. See docs/ontology.md.
    """


@ontology.command(epilog=_EPILOG)
@click.argument("ontology_file", metavar="ONTOLOGY.xml")
@_psyspec_option
@_history_option
@_whiteboard_option
@click.option("-o", "--output", required=True, metavar="DIR", help="Folder to write.")
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["html", "md"]),
    default="html",
    show_default=True,
    help="html: a static site that works from file://; md: Markdown pages for a wiki.",
)
def docs(
    ontology_file: str,
    psyspec: str | None,
    histories: tuple[str, ...],
    whiteboards: tuple[str, ...],
    output: str,
    fmt: str,
) -> None:
    """Write browsable docs of ONTOLOGY.xml into DIR.

    With --psyspec and --history the pages also say which modules post and receive each type,
    through which patterns, and what the history saw; the overview draws the system (Graphviz).
    """
    onto, usage = _inputs(ontology_file, psyspec, histories, whiteboards)
    paths = Paths(ext=".md" if fmt == "md" else ".html")
    ctx = build_context(onto, usage, paths=paths)
    out = Path(output)
    try:
        pages = write_markdown(ctx, out) if fmt == "md" else write_site(ctx, out).pages
    except OSError as exc:
        raise _fail(f"cannot write {out}: {exc.strerror}") from None
    if ctx.diagram is not None and ctx.diagram.problem:
        click.echo(f"note: no diagram: {ctx.diagram.problem}", err=True)
    click.echo(f"wrote {pages} pages to {out}/{paths.index}")


@ontology.command("lint", epilog=_EPILOG)
@click.argument("ontology_file", metavar="ONTOLOGY.xml")
@_psyspec_option
@_history_option
@_whiteboard_option
@click.option(
    "--fail-on",
    type=click.Choice(["error", "warning", "info", "never"]),
    default="error",
    show_default=True,
    help="Exit 1 when a finding is at least this serious.",
)
@click.option("--json", "as_json", is_flag=True, help="Print the findings as a JSON list.")
def lint_command(
    ontology_file: str,
    psyspec: str | None,
    histories: tuple[str, ...],
    whiteboards: tuple[str, ...],
    fail_on: str,
    as_json: bool,
) -> None:
    """Check ONTOLOGY.xml against a psySpec and recorded histories.

    \b
    Reports: patterns that match no defined type (with the nearest names), posted types
    missing from the ontology, defined types nobody uses, patterns Psyclone 1.1.7 matched
    differently, deprecated types still in use, and more (docs/ontology.md lists every code).
    """
    onto, usage = _inputs(ontology_file, psyspec, histories, whiteboards)
    findings = lint(TypeIndex(onto), usage)
    if as_json:
        click.echo(json.dumps([f.as_dict() for f in findings], indent=2))
    else:
        for finding in findings:
            click.echo(str(finding))
        counts = {level: sum(1 for f in findings if f.level is level) for level in Level}
        click.echo(
            f"{counts[Level.ERROR]} errors, {counts[Level.WARNING]} warnings, "
            f"{counts[Level.INFO]} notes"
        )
    threshold = _LEVELS.get(fail_on)
    if threshold is not None and any(f.level >= threshold for f in findings):
        raise click.exceptions.Exit(EXIT_FINDINGS)


def _infer_source(
    server: str | None, store: str | None, file: str | None, whiteboards: Sequence[str]
) -> History:
    """Read the one history source `infer` was given; raise HistoryError."""
    if file:
        return read_xml(file)
    if store:
        if not store.startswith("sqlite:"):
            raise HistoryError(f"--from-store must be sqlite:PATH, not {store!r}")
        return read_sqlite(store.removeprefix("sqlite:"))
    try:
        host, port = parse_server(server or "")
    except ValueError as exc:
        raise HistoryError(f"--from {server!r}: {exc}") from None
    return retrieve_live(host, port, whiteboards=whiteboards)


@ontology.command(epilog=_EPILOG)
@click.option("--from", "server", metavar="HOST:PORT", help="Retrieve a running server's history.")
@click.option("--from-store", "store", metavar="sqlite:PATH", help="Read a server's SQLite store.")
@click.option("--from-file", "file", metavar="FILE.xml", help="Read an <objectcollection> file.")
@click.option("--from-recording", "recording", metavar="FILE", help="Read an openair record file.")
@_whiteboard_option
@click.option("--name", default=None, help="The ontology's name (default: from the source).")
@click.option("-o", "--output", required=True, metavar="FILE", help="Where to write ('-': stdout).")
def infer(
    server: str | None,
    store: str | None,
    file: str | None,
    recording: str | None,
    whiteboards: tuple[str, ...],
    name: str | None,
    output: str,
) -> None:
    """Write a skeleton ontology of every type a history holds.

    Each type gets its message count, first and last time, posters and an example of its
    content; descriptions are left for you to write.
    """
    if len([s for s in (server, store, file, recording) if s]) != 1:
        raise _fail("give exactly one of --from, --from-store, --from-file and --from-recording")
    try:
        if recording:
            history = history_of_recording(recording)
            for note in history.notes:  # a recording cut short says so
                click.echo(f"warning: {note}", err=True)
        else:
            history = _infer_source(server, store, file, whiteboards)
    except HistoryConnectError as exc:
        raise _fail(str(exc), EXIT_CONNECT) from None
    except HistoryError as exc:
        raise _fail(str(exc)) from None
    onto, report = infer_ontology(
        history.messages, name=name or f"Inferred from {history.source}", source=history.source
    )
    data = encode_ontology(onto)
    if output == "-":
        click.echo(data.decode("utf-8"), nl=False)
    else:
        try:
            Path(output).write_bytes(data)
        except OSError as exc:
            raise _fail(f"cannot write {output}: {exc.strerror}") from None
    for bad, count in report.invalid:
        click.echo(f"note: left out {count} message(s) of invalid type {bad!r}", err=True)
    click.echo(f"{report.types} types from {report.messages} messages", err=True)
