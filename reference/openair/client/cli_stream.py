"""The ``openair stream`` commands: ``ls``, ``tail`` and ``push`` (spec section 11).

Thin functions over `Module.list_streams`, `Module.subscribe_stream` and `StreamHandle.submit`,
with the connection option and exit codes of the other client commands (``cli_client.py``):

\b
  0  success
  1  the server answered with a failure reply (unknown stream, refused sample), or a reply
     did not come in time
  2  usage error (bad option, missing file)
  3  cannot connect to the server, the connection was lost, or the peer does not speak OpenAIR
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import click

from openair.client.cli_client import _EPILOG, EXIT_FAILED, _client, _run, _server_option
from openair.client.module import Module
from openair.client.stream_wire import ReceivedSample, StreamInfo
from openair.protocol.datasample import BUILTIN_ID, BUILTIN_TIMESTAMP
from openair.protocol.errors import ConnectionClosedError, OpenAIRError

_MIB = 1_048_576
_LS_COLUMNS = ("NAME", "WHITEBOARD", "TYPE", "COUNT", "SIZE", "FILL", "SUBSCRIBERS")


@click.group(epilog=_EPILOG)
def stream() -> None:
    """List streams, follow one, or push a file into one (spec section 11)."""


# ------------------------------------------------------------------------------------- ls


def _bytes(n: int) -> str:
    """Render a byte count briefly: 512 B, 1.5 KiB, 10.0 MiB."""
    if n < 1024:
        return f"{n} B"
    if n < _MIB:
        return f"{n / 1024:.1f} KiB"
    return f"{n / _MIB:.1f} MiB"


def fill(info: StreamInfo) -> str:
    """How full a stream is against its (hard) limits: bytes, and samples when limited."""
    limit = info.hardsize if info.hardsize is not None else info.maxsize
    text = f"{100 * info.size / limit:.1f}% of {_bytes(limit)}" if limit else _bytes(info.size)
    count_limit = info.hardcount if info.hardcount is not None else info.maxcount
    if count_limit:
        text += f", {info.count}/{count_limit} samples"
    return text


def _row(info: StreamInfo) -> tuple[str, ...]:
    return (
        info.name,
        info.whiteboard,
        info.type or "-",
        str(info.count),
        _bytes(info.size),
        fill(info),
        str(info.subscribers),
    )


def table(rows: list[tuple[str, ...]], header: tuple[str, ...] = _LS_COLUMNS) -> list[str]:
    """Lay rows out in left-aligned columns under `header`."""
    widths = [max(len(r[i]) for r in (header, *rows)) for i in range(len(header))]
    return ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
            for r in (header, *rows)]  # fmt: skip


@stream.command(epilog=_EPILOG)
@click.option("--json", "as_json", is_flag=True, help="Print a JSON list of streaminfo.")
@click.option("--from", "name", default="openair-cli", show_default=True, help="The from slot.")
@_server_option
def ls(as_json: bool, name: str, server: tuple[str, int]) -> None:
    """List the server's streams (GET_STREAMS), in configuration order.

    Columns: name, whiteboard, type, samples held, payload bytes held, fill against the
    stream's limits, and subscribers (push connections and module subscriptions).
    """

    async def run() -> list[StreamInfo]:
        async with _client(name, server) as module:
            return await module.list_streams()

    infos = _run(run())
    if as_json:
        click.echo(json.dumps([info.as_dict() for info in infos], indent=2))
        return
    for line in table([_row(info) for info in infos]):
        click.echo(line)


# ----------------------------------------------------------------------------------- tail


def sample_record(got: ReceivedSample) -> dict[str, Any]:
    """One pushed sample as a JSON-friendly dict (the payload is not shown)."""
    sample = got.sample
    shown = {k: v for k, v in sample.params if k not in (BUILTIN_ID, BUILTIN_TIMESTAMP)}
    return {
        "stream": got.stream,
        "id": sample.id,
        "timestamp": sample.timestamp_ms,
        "size": len(sample.payload),
        "params": shown,
        "dropped": got.dropped,
    }


def sample_line(got: ReceivedSample) -> str:
    """One line per sample: id, timestamp, size, parameters, dropped."""
    rec = sample_record(got)
    params = ",".join(f"{k}={v}" for k, v in rec["params"].items()) or "-"
    return (
        f"id={rec['id']} timestamp={rec['timestamp']} size={rec['size']} "
        f"params={params} dropped={rec['dropped']}"
    )


@stream.command(epilog=_EPILOG)
@click.argument("target", metavar="NAME")
@click.option("--count", type=click.IntRange(min=1), help="Stop after N samples.")
@click.option("--json", "as_json", is_flag=True, help="One JSON object per line.")
@click.option("--buffer", type=click.IntRange(min=1), default=100, show_default=True,
              help="Samples buffered here before acknowledgements stop.")  # fmt: skip
@click.option("--name", default=None, help="Module name (default: tail-<pid>).")
@_server_option
def tail(
    target: str,
    count: int | None,
    as_json: bool,
    buffer: int,
    name: str | None,
    server: tuple[str, int],
) -> None:
    """Follow stream NAME (a name, or a type under typed-streams) by push subscription.

    Prints one line per new sample: id, timestamp (ms), payload size, parameters (other than
    builtin:id and builtin:timestamp) and how many samples the server dropped before it for
    this subscriber. Stops after --count samples or on Ctrl-C.
    """

    async def run() -> None:
        async with (
            _client(name or f"tail-{os.getpid()}", server) as module,
            module.subscribe_stream(target, buffer=buffer) as sub,
        ):
            seen = 0
            async for got in sub:
                click.echo(json.dumps(sample_record(got)) if as_json else sample_line(got))
                seen += 1
                if count is not None and seen >= count:
                    return
            raise ConnectionClosedError("the server closed the subscription")

    with contextlib.suppress(KeyboardInterrupt):
        _run(run())


# ----------------------------------------------------------------------------------- push


def chunks_of(data: bytes, size: int | None) -> list[memoryview]:
    """Split `data` into views of `size` bytes (the last may be shorter); None: one chunk."""
    view = memoryview(data)
    if not size or size >= len(view):
        return [view]
    return [view[i : i + size] for i in range(0, len(view), size)]


def _schedule(chunks: list[memoryview], loop: bool, count: int | None) -> Iterator[memoryview]:
    """The payloads to send: one pass, or round after round with --loop; at most `count`."""
    sent = 0
    while True:
        for chunk in chunks:
            if count is not None and sent >= count:
                return
            yield chunk
            sent += 1
        if not loop:
            return


class PushReport:
    """What a push did: samples and bytes written, acknowledgements, failures, elapsed time."""

    def __init__(self) -> None:
        self.sent = self.acked = self.refused = self.bytes = 0
        self.started = self.last_write = time.monotonic()
        self.first_error: OpenAIRError | None = None

    def settle(self, future: asyncio.Future[int]) -> None:
        """Count one acknowledgement (or refusal) as it arrives."""
        if future.cancelled():
            return
        error = future.exception()
        if error is None:
            self.acked += 1
            return
        self.refused += 1
        if self.first_error is None and isinstance(error, OpenAIRError):
            self.first_error = error

    def wrote(self, size: int) -> None:
        """Count one sample written now."""
        self.sent += 1
        self.bytes += size
        self.last_write = time.monotonic()

    def line(self, target: str, rate: float) -> str:
        """The summary: samples, bytes, time, achieved rate (first to last write), acks."""
        elapsed = time.monotonic() - self.started
        span = self.last_write - self.started
        achieved = f"{(self.sent - 1) / span:.1f}" if self.sent > 1 and span > 0 else "-"
        goal = f"{rate:g}" if rate else "unpaced"
        return (
            f"pushed {self.sent} samples ({self.bytes} bytes) to {target} in {elapsed:.3f} s: "
            f"{achieved} samples/s (target {goal}), {self.acked} acks, {self.refused} refused"
        )


async def _push(
    module: Module,
    target: str,
    payloads: Iterator[memoryview],
    *,
    rate: float,
    binary: bool,
    params: dict[str, str],
    report: PushReport,
) -> None:
    """Write the payloads at `rate` per second, numbered by builtin:seq, pipelined."""
    handle = module.stream(target)
    await handle.name()  # an unknown stream fails here, before the first sample
    pending: list[asyncio.Future[int]] = []
    report.started = report.last_write = start = time.monotonic()
    for seq, payload in enumerate(payloads, start=1):
        if rate:
            due = start + (seq - 1) / rate
            if (wait := due - time.monotonic()) > 0:
                await asyncio.sleep(wait)  # pacing, not synchronisation
        future = await handle.submit(payload, params, seq=seq, binary=binary)
        future.add_done_callback(report.settle)
        pending.append(future)
        report.wrote(len(payload))
    await asyncio.gather(*pending, return_exceptions=True)


def _params(values: tuple[str, ...]) -> dict[str, str]:
    """Read --param KEY=VALUE options."""
    out: dict[str, str] = {}
    for value in values:
        key, sep, text = value.partition("=")
        if not sep or not key:
            raise click.BadParameter(f"{value!r} is not KEY=VALUE", param_hint="--param")
        out[key] = text
    return out


@stream.command(epilog=_EPILOG)
@click.argument("target", metavar="NAME")
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--rate", type=click.FloatRange(min=0), required=True, metavar="HZ",
              help="Samples per second (0: as fast as the server acknowledges).")  # fmt: skip
@click.option("--chunk", type=click.IntRange(min=1), metavar="BYTES",
              help="Samples of BYTES each (default: all of FILE as one sample).")  # fmt: skip
@click.option("--loop", is_flag=True, help="Start again at the end of FILE (until --count).")
@click.option("--count", type=click.IntRange(min=1), help="Stop after N samples.")
@click.option("--binary", is_flag=True, help="Send bare BinaryM frames instead of ADD_SAMPLE.")
@click.option("--param", "param_values", multiple=True, metavar="KEY=VALUE",
              help="A parameter for every sample (repeatable).")  # fmt: skip
@click.option("--from", "name", default="openair-cli", show_default=True, help="The from slot.")
@_server_option
def push(
    target: str,
    file: Path,
    rate: float,
    chunk: int | None,
    loop: bool,
    count: int | None,
    binary: bool,
    param_values: tuple[str, ...],
    name: str,
    server: tuple[str, int],
) -> None:
    """Push FILE into stream NAME at --rate samples per second.

    Each sample carries builtin:seq (1, 2, …), so a typed stream detects gaps. Writes are
    pipelined; the report gives the achieved rate and how many samples the stream
    acknowledged. Exits 1 when any sample was refused.
    """
    params = _params(param_values)
    payloads = _schedule(chunks_of(file.read_bytes(), chunk), loop, count)
    report = PushReport()

    async def run() -> None:
        async with _client(name, server) as module:
            try:
                await _push(module, target, payloads, rate=rate, binary=binary, params=params,
                            report=report)  # fmt: skip
            finally:
                if report.sent:  # also after Ctrl-C
                    click.echo(report.line(target, rate))

    with contextlib.suppress(KeyboardInterrupt):
        _run(run())
    if report.first_error is not None:
        click.echo(f"error: {report.first_error}", err=True)
        raise click.exceptions.Exit(EXIT_FAILED)
