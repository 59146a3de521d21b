"""The ``openair`` command line (one click group; each command is a thin wrapper).

Commands live beside the code they wrap: the client commands in ``openair.client.cli_client``,
``serve`` in ``openair.server.cli_serve``, ``conform`` in ``openair_conformance.cli``. This module
only assembles them, importing lazily so that ``openair --help`` stays fast.
"""

from __future__ import annotations

import click

from openair.client.cli_client import COMMANDS


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="openair-kit")
def main() -> None:
    """OpenAIR kit: reference whiteboard server, client tools and conformance suite.

    \b
    Exit codes shared by every command: 0 success, 1 the operation failed (the server refused,
    a case failed), 2 usage error, 3 could not connect. Each command's --help says more.
    """


def _register() -> None:
    """Add every command to the group (called once at import)."""
    from openair.client.cli_stream import stream
    from openair.ontology.cli_ontology import ontology
    from openair.server.cli_serve import serve
    from openair_conformance.cli import conform
    from openair_conformance.client_cli import conform_client
    from openair_conformance.worldmodel.cli import conform_worldmodel

    main.add_command(serve)
    for command in COMMANDS:
        main.add_command(command)
    main.add_command(conform)
    main.add_command(conform_client)
    main.add_command(conform_worldmodel)
    main.add_command(ontology)
    main.add_command(stream)


_register()
