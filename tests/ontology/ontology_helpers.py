"""Paths and a background server shared by the ontology tests (imported by name)."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Coroutine
from pathlib import Path
from typing import Any, TypeVar

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
FIXTURES = Path(__file__).resolve().parent / "fixtures"
ONTOLOGY = EXAMPLES / "seed-paper.ontology.xml"
PSYSPEC = EXAMPLES / "seed-paper.psySpec.xml"
HISTORY = EXAMPLES / "seed-paper.history.xml"
ARTIFACTS = ROOT / "test-artifacts" / "ontology"

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")

_T = TypeVar("_T")


class ServerThread:
    """The reference server on 127.0.0.1 (port 0) in a background event loop."""

    def __init__(self, **options: Any) -> None:
        from openair.server.app import ServerOptions, start_server

        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, daemon=True)
        self._thread.start()
        opts = ServerOptions(host="127.0.0.1", port=0, monitor=False, grace_s=0.5, **options)
        self.server = self.call(start_server(opts))
        self.port: int = self.server.port

    def call(self, coro: Coroutine[Any, Any, _T], timeout: float = 30.0) -> _T:
        """Run a coroutine on the server's loop and wait for its result."""
        return asyncio.run_coroutine_threadsafe(coro, self._loop).result(timeout)

    def stop(self) -> None:
        try:
            self.call(self.server.stop())
        finally:
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(timeout=10)
            self._loop.close()
