"""A reference server in a child process with a psySpec and delivery options of the bench's.

`spawn(psyspec_xml, turn_budget=…)` writes the psySpec to a temporary file, starts
`python -c "from bench.serving import main; main()" FILE BUDGET` in the repository root (so that
`bench.*` internal module code can be imported), waits for its `listening on HOST:PORT` line and
yields (pid, port); the server is terminated when the block ends.
"""

from __future__ import annotations

import asyncio
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from openair.server.aio.app import ServerOptions, start_server
from openair.server.aio.dispatcher import DeliveryOptions
from openair.server.aio.scheduling import DEFAULT_TURN_BUDGET
from openair.server.core.config import load_config

ROOT = Path(__file__).resolve().parents[1]


async def _serve(config_path: str, turn_budget: int) -> None:
    options = ServerOptions(
        port=0,
        config=load_config(config_path),
        monitor=False,
        delivery=DeliveryOptions(turn_budget=turn_budget),
    )
    server = await start_server(options)
    print(f"listening on 127.0.0.1:{server.port}", flush=True)
    await server.serve_forever()


def main() -> None:
    """Serve the psySpec file argv[1] with the turn budget argv[2] until terminated."""
    asyncio.run(_serve(sys.argv[1], int(sys.argv[2])))


@contextmanager
def spawn(psyspec: str, *, turn_budget: int = DEFAULT_TURN_BUDGET) -> Iterator[tuple[int, int]]:
    """Start a server on `psyspec` in a child process; yield (pid, port)."""
    with tempfile.NamedTemporaryFile("w", suffix=".xml", delete=False) as f:
        f.write(psyspec)
    code = "from bench.serving import main; main()"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, f.name, str(turn_budget)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        if "listening on" not in line:
            raise RuntimeError(f"server did not start: {line!r}")
        yield proc.pid, int(line.rsplit(":", 1)[1])
    finally:
        proc.terminate()
        proc.wait(timeout=20)
        Path(f.name).unlink(missing_ok=True)
