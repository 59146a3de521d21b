"""`python -m openair …`: the same command as the `openair` script (reference/openair/cli.py)."""

from __future__ import annotations

from openair.cli import main

main()
