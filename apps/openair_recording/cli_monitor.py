"""`openair monitor FILE`: the web monitor's JSON API over a recording (docs/recording.md).

A module of its own because it needs the monitor's HTTP server (`openair_monitor.http`, the
`monitor` extra): without it, `openair` lists the command and names the extra to install.
"""

from __future__ import annotations

import asyncio
import signal
from pathlib import Path

import click

from openair.client.cli_client import run_command
from openair_monitor.http import HttpConnection
from openair_recording.cli_recording import EPILOG, load_recording
from openair_recording.monitor import RecordingMonitor

__all__ = ["monitor"]


@click.command(epilog=EPILOG)
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--host", default="127.0.0.1", show_default=True)
@click.option("--port", default=10001, show_default=True, type=click.IntRange(0, 65535))
def monitor(file: str, host: str, port: int) -> None:
    """Serve the monitor's JSON API (/api/…) over a recording, read-only, until Ctrl-C."""
    reader, records = load_recording(file)
    app = RecordingMonitor(str(Path(file)), reader.header, records, reader.warnings)

    async def serve() -> None:
        loop = asyncio.get_running_loop()
        stop = asyncio.Event()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        listener = await loop.create_server(lambda: HttpConnection(app), host, port)
        where = listener.sockets[0].getsockname()
        click.echo(f"monitor of {file} on http://{where[0]}:{where[1]}/api/", err=True)
        async with listener:
            await stop.wait()
        for conn in list(app.connections):
            conn.close()

    run_command(serve())
