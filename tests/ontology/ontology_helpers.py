"""Paths and a background server shared by the ontology tests (imported by name)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from server_thread import ReferenceServer

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
FIXTURES = Path(__file__).resolve().parent / "fixtures"
ONTOLOGY = EXAMPLES / "seed-paper.ontology.xml"
PSYSPEC = EXAMPLES / "seed-paper.psySpec.xml"
HISTORY = EXAMPLES / "seed-paper.history.xml"
ARTIFACTS = ROOT / "test-artifacts" / "ontology"


class ServerThread(ReferenceServer):
    """The reference server without its monitor, with a short shutdown grace."""

    def __init__(self, **options: Any) -> None:
        super().__init__(**{"monitor": False, "grace_s": 0.5, **options})
