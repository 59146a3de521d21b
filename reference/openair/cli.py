"""The ``openair`` command line (one click group; each command is a thin wrapper)."""

from __future__ import annotations

import click


@click.group()
@click.version_option(package_name="openair-kit")
def main() -> None:
    """OpenAIR kit: reference whiteboard server, client tools and conformance suite."""
