"""`openair record` and `openair replay` (docs/recording.md); `openair monitor FILE` is in
`cli_monitor` (it needs the `monitor` extra).

Exit codes (all commands):

\b
  0  success
  1  the operation failed (a post refused during replay, a request without a reply)
  2  usage error, or a recording that cannot be read (not a recording, corrupt, hostile)
  3  cannot connect to the server, or it does not speak OpenAIR
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import signal

import click

from openair.client.cli_client import CliModule, run_command
from openair.protocol.address import parse_server
from openair.protocol.errors import OpenAIRError
from openair.protocol.types import validate_pattern
from openair_recording.fileformat import MessageRecord, Record, RecordingReader
from openair_recording.recorder import Recorder, RecordOptions
from openair_recording.replay import Replayer, ReplayOptions, plan

__all__ = ["EPILOG", "load_recording", "record", "replay"]

EXIT_USAGE = 2
EPILOG = "Exit codes: 0 ok, 1 failed, 2 usage or unreadable recording, 3 cannot connect."


def _server(ctx: click.Context, param: click.Parameter, value: str) -> tuple[str, int]:
    try:
        return parse_server(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


def _pattern(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    if value is None:
        return None
    try:
        return validate_pattern(value)
    except OpenAIRError as exc:
        raise click.BadParameter(str(exc.detail or exc)) from None


def load_recording(path: str) -> tuple[RecordingReader, list[Record]]:
    """Read a whole recording; warnings go to stderr; an unreadable file exits 2."""
    try:
        reader = RecordingReader.open(path)
        records = list(reader.records())
    except OSError as exc:
        click.echo(f"error: {path}: cannot read: {exc.strerror}", err=True)
        raise click.exceptions.Exit(EXIT_USAGE) from None
    except OpenAIRError as exc:
        click.echo(f"error: {path}: not a readable recording: {exc}", err=True)
        raise click.exceptions.Exit(EXIT_USAGE) from None
    for warning in reader.warnings:
        click.echo(f"warning: {warning}", err=True)
    return reader, records


@click.command(epilog=EPILOG)
@click.argument("server", metavar="HOST:PORT", callback=_server)
@click.option("-o", "--output", required=True, metavar="FILE", help="The recording to write.")
@click.option("--types", default="*", callback=_pattern, help="Type pattern (default: *).")
@click.option("--streams", default="all", metavar="NAMES|all", help="Comma-separated streams.")
@click.option("--duration", type=click.FloatRange(min=0, min_open=True), help="Stop after S s.")
@click.option("--name", default="Recorder", help="The recording module's name.")
@click.option("--timeout", default=10.0, type=click.FloatRange(min=0.1), help="Per request (s).")
def record(
    server: tuple[str, int],
    output: str,
    types: str,
    streams: str,
    duration: float | None,
    name: str,
    timeout: float,
) -> None:
    """Record every message the server routes and every stream sample, into FILE.

    A module registers for --types on every whiteboard and subscribes to the streams; it stops
    on Ctrl-C, SIGTERM or after --duration seconds, and the file is then complete (index and
    end record written). A crash loses at most the record being written.
    """
    names = None if streams == "all" else [s.strip() for s in streams.split(",") if s.strip()]
    options = RecordOptions(types=types, streams=names, name=name, timeout=timeout)
    host, port = server
    recorder = run_command(_record(host, port, output, options, duration))
    for note in recorder.notes:
        click.echo(f"note: {note}", err=True)
    click.echo(f"recorded {recorder.messages} messages and {recorder.samples} samples to {output}")


async def _record(
    host: str, port: int, output: str, options: RecordOptions, duration: float | None
) -> Recorder:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    # CliModule tells a peer that is not OpenAIR from one that is down (exit 3).
    recorder = Recorder(host, port, output, options, module_class=CliModule)
    try:
        await recorder.start()
        click.echo(f"recording {host}:{port} to {output} (Ctrl-C or SIGTERM stops)", err=True)
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(duration):
                await stop.wait()
    finally:
        await recorder.stop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)
    return recorder


def parse_when(text: str, start_us: int) -> int:
    """Return a --from/--until time in µs: seconds after `start_us`, or an ISO-8601 time."""
    try:
        return start_us + round(float(text) * 1e6)
    except ValueError:
        pass
    try:
        when = datetime.datetime.fromisoformat(text)
    except ValueError:
        raise click.BadParameter(f"{text!r}: not seconds nor an ISO-8601 time") from None
    if when.tzinfo is None:
        when = when.replace(tzinfo=datetime.UTC)
    return round(when.timestamp() * 1e6)


@click.command(epilog=EPILOG)
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--to", "server", required=True, metavar="HOST:PORT", callback=_server)
@click.option("--speed", default=1.0, type=click.FloatRange(min=0), help="0: no waiting.")
@click.option("--from", "start", metavar="T", help="Seconds after the first record, or ISO time.")
@click.option("--until", "until", metavar="T", help="Seconds after the first record, or ISO time.")
@click.option("--types", callback=_pattern, help="Only messages whose type matches.")
@click.option("--name", default="Replayer", help="The replaying client's name.")
@click.option("--timeout", default=10.0, type=click.FloatRange(min=0.1), help="Per request (s).")
def replay(
    file: str,
    server: tuple[str, int],
    speed: float,
    start: str | None,
    until: str | None,
    types: str | None,
    name: str,
    timeout: float,
) -> None:
    """Re-post a recording's messages and re-add its samples, with the original spacing.

    Messages go to the whiteboards they were stored on, with their attachments, priority,
    cc and content; the original postedTime is kept in the slot <originalPostedTime>. Samples
    go to their streams (created when missing, if the server can, else skipped with a note).
    T is seconds after the first record (e.g. 2.5) or an ISO-8601 time.
    """
    reader, records = load_recording(file)
    first = min((r.time_us for r in records), default=0)
    options = ReplayOptions(
        speed=speed,
        from_us=None if start is None else parse_when(start, first),
        until_us=None if until is None else parse_when(until, first),
        types=types or "",
    )
    steps = plan(records, options)
    host, port = server

    async def run() -> Replayer:
        module = CliModule(
            name, host, port, bind=False, reconnect=False, keepalive=None, request_timeout=timeout
        )
        async with module:
            replayer = Replayer(module, reader.header)
            await replayer.run(steps)
            return replayer

    with contextlib.suppress(KeyboardInterrupt):
        done = run_command(run())
        for note in done.notes:
            click.echo(f"note: {note}", err=True)
        click.echo(f"replayed {done.posted} messages and {done.added} samples to {host}:{port}")
        if done.posted < sum(1 for s in steps if isinstance(s.record, MessageRecord)):
            raise click.exceptions.Exit(1)
