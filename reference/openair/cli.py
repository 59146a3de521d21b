"""The ``openair`` command line (one click group; each command is a thin wrapper).

Commands live beside the code they wrap: the client commands in ``openair.client.cli_client``,
``serve`` in ``openair.server.cli_serve``. This module only names them; a command's module is
imported when the command runs (or when ``--help`` lists it), so ``openair --version`` imports
nothing else and a command whose optional dependency is missing says which extra to install
instead of failing with a traceback. Commands of other installed packages (the conformance
suite's ``conform``, ``conform-client``, ``conform-worldmodel``; the applications beside the core:
``ontology``, ``record``, ``replay``, ``monitor``) are found through the entry point group
``openair.commands`` (pyproject.toml): the reference package never imports the suite that judges
it, nor the applications built on it.
"""

from __future__ import annotations

import importlib
from importlib.metadata import entry_points
from typing import Any, NoReturn

import click

from openair.extras import OPTIONAL, install_hint, missing_extra

__all__ = ["ENTRY_POINT_GROUP", "OPTIONAL", "main", "missing_extra"]

#: Command name -> "module:attribute".
_COMMANDS = {
    "serve": "openair.server.cli_serve:serve",
    "post": "openair.client.cli_client:post",
    "watch": "openair.client.cli_client:watch",
    "retrieve": "openair.client.cli_client:retrieve",
    "ping": "openair.client.cli_client:ping",
    "stream": "openair.client.cli_stream:stream",
}

#: The entry point group other packages declare their `openair` commands in.
ENTRY_POINT_GROUP = "openair.commands"


def _targets() -> dict[str, str]:
    """Every command name -> "module:attribute": this package's, then the entry points'."""
    found = {ep.name: ep.value for ep in entry_points(group=ENTRY_POINT_GROUP)}
    found.update(_COMMANDS)  # a plug-in cannot replace a command of the kit itself
    return found


#: Exit code of a command whose optional dependency is not installed (a usage error).
EXIT_MISSING = 2


def _unavailable(name: str, package: str, extra: str) -> click.Command:
    """A stand-in for a command whose optional dependency is missing: one line, exit 2."""

    def run() -> NoReturn:
        click.echo(
            f"openair {name}: needs {package}, which is not installed: {install_hint(extra)}",
            err=True,
        )
        raise click.exceptions.Exit(EXIT_MISSING)

    return click.Command(
        name,
        callback=run,
        help=f"(not available: {install_hint(extra)})",
        context_settings={"ignore_unknown_options": True, "allow_extra_args": True},
        add_help_option=False,
    )


def _load(name: str) -> click.Command | None:
    """Import the command `name` (a stand-in when an optional dependency is missing)."""
    target = _targets().get(name)
    if target is None:
        return None
    module_name, _, attr = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        extra = missing_extra(exc)
        if extra is None:
            raise
        return _unavailable(name, (exc.name or "").partition(".")[0], extra)
    command = getattr(module, attr)
    assert isinstance(command, click.Command)
    return command


class _LazyCommands(dict[str, click.Command]):
    """The group's `commands`: each one imported when it is first looked up."""

    def __missing__(self, name: str) -> click.Command:
        command = _load(name)
        if command is None:
            raise KeyError(name)
        self[name] = command
        return command


class _LazyGroup(click.Group):
    """A group whose commands are imported on first use."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.commands = _LazyCommands()

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(_targets())

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        try:
            return self.commands[cmd_name]
        except KeyError:
            return None


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="openair-kit")
def main() -> None:
    """OpenAIR kit: reference whiteboard server, client tools and conformance suite.

    \b
    Exit codes shared by every command: 0 success, 1 the operation failed (the server refused,
    a case failed), 2 usage error (also: an optional part is not installed; the message names
    the extra, e.g. pip install 'openair-kit[fuzz]'), 3 could not connect or the peer does not
    speak OpenAIR. Each command's --help says more.
    """


if __name__ == "__main__":
    main()
