"""`openair serve`: run the reference whiteboard server in the foreground."""

from __future__ import annotations

import asyncio
import contextlib
import gc
import logging
import signal
import sys

import click

from openair.server.app import Server, ServerOptions, start_server
from openair.server.config import ConfigError, ServerLimits
from openair.server.store import StoreSpecError

__all__ = ["serve"]

_LEVELS = ("debug", "info", "warning", "error")
_GC_GEN0 = 50_000  # allocations between gen-0 collections


def _hosts(extra: tuple[str, ...]) -> tuple[str, ...]:
    """Return the addresses that may post through the monitor: loopback and `extra`."""
    hosts = ["127.0.0.1", "::1"]
    hosts.extend(h.strip() for h in extra if h.strip() and h.strip() not in hosts)
    return tuple(hosts)


def _tune_gc() -> None:
    """Make cyclic garbage collection rare: the hot path allocates much and frees by refcount.

    With the default gen-0 threshold (700) a busy server runs hundreds of collections per
    second, each walking the young objects; the objects of start-up are frozen out of them.
    """
    gc.freeze()
    gc.set_threshold(_GC_GEN0, *gc.get_threshold()[1:])


async def _run(options: ServerOptions) -> None:
    """Start, announce readiness on stdout, and stop on SIGINT or SIGTERM."""
    server = await start_server(options)
    _tune_gc()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        with contextlib.suppress(NotImplementedError):  # not on every platform
            loop.add_signal_handler(sig, lambda: loop.create_task(server.stop()))
    boards = ", ".join(server.whiteboards)
    click.echo(f"listening on {server.host}:{server.port} (whiteboards: {boards})")
    if server.monitor is not None:
        click.echo(_monitor_line(server))
    sys.stdout.flush()
    try:
        await server.serve_forever()
    finally:
        # The loop is about to close: a late second signal (a supervisor repeating SIGTERM)
        # must not hit asyncio's wakeup fd; the stop is already done, so ignore it.
        for sig in (signal.SIGINT, signal.SIGTERM):
            with contextlib.suppress(NotImplementedError, ValueError):
                loop.remove_signal_handler(sig)
                signal.signal(sig, signal.SIG_IGN)


def _monitor_line(server: Server) -> str:
    """Describe where the web monitor answers (the main port, and the HTTP port if any)."""
    host = "127.0.0.1" if server.host in ("", "0.0.0.0", "::") else server.host
    urls = [f"http://{host}:{server.port}/"]
    http_port = getattr(server.monitor, "http_port", None)
    if http_port is not None:
        urls.append(f"http://{host}:{http_port}/")
    mode = "posting allowed" if server.options.monitor_post else "read-only"
    return f"monitor on {' and '.join(urls)} ({mode})"


@click.command("serve")
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to listen on.")
@click.option(
    "--port",
    default=10000,
    show_default=True,
    type=click.IntRange(0, 65535),
    help="Main port (0: any free port; the line printed at start names it).",
)
@click.option(
    "--config",
    "config_path",
    type=click.Path(dir_okay=False),
    help="psySpec configuration file (default: AIRCentral, WB1, WB2).",
)
@click.option(
    "--store",
    default="memory",
    show_default=True,
    help="Whiteboard history: 'memory', or 'sqlite:PATH' (durable).",
)
@click.option(
    "--log-level",
    default="info",
    show_default=True,
    type=click.Choice(_LEVELS, case_sensitive=False),
    help="Log level (stderr).",
)
@click.option(
    "--http-port",
    type=click.IntRange(0, 65535),
    default=None,
    help="Also serve the web monitor on this port (0: any free port), on the same host.",
)
@click.option(
    "--monitor-post",
    is_flag=True,
    help="Allow posting from the monitor's page (POST /api/post); read-only without it.",
)
@click.option(
    "--monitor-host",
    "monitor_hosts",
    multiple=True,
    metavar="ADDRESS",
    help="An address besides loopback that may post through the monitor (repeatable).",
)
@click.option(
    "--no-monitor",
    is_flag=True,
    help="Serve no HTTP at all: the main port speaks OpenAIR only.",
)
@click.option(
    "--stream-push-buffer",
    default=ServerLimits().stream_push_buffer,
    show_default=True,
    type=click.IntRange(1, 1_000_000),
    help="Samples buffered per stream subscriber before its oldest are dropped (OA-STREAM-8).",
)
@click.option(
    "--max-wait-ms",
    default=ServerLimits().max_wait_ms,
    show_default=True,
    type=click.IntRange(1, 24 * 3600 * 1000),
    help="The longest a WAIT_FOR_* may wait; longer timeouts are clipped (OA-STREAM-7).",
)
def serve(
    host: str,
    port: int,
    config_path: str | None,
    store: str,
    log_level: str,
    http_port: int | None,
    monitor_post: bool,
    monitor_hosts: tuple[str, ...],
    no_monitor: bool,
    stream_push_buffer: int,
    max_wait_ms: int,
) -> None:
    """Run the OpenAIR reference server until SIGINT or SIGTERM.

    When it is ready it prints one line, `listening on HOST:PORT (whiteboards: …)`, on stdout,
    then `monitor on URL… (read-only|posting allowed)` unless --no-monitor: the web monitor
    answers HTTP on the main port (and on --http-port when given). Log lines
    (`event=NAME key=value …`) go to stderr. On a signal it shuts down gracefully: new requests
    get SHUTTING_DOWN, decided deliveries are attempted for up to 5 s, the store is closed.

    \b
    Exit codes:
      0  stopped by SIGINT or SIGTERM after a graceful shutdown
      1  could not listen (address in use, permission) or could not open the store
      2  usage error, or an invalid configuration file (the message names file and line)
    """
    logging.basicConfig(
        level=log_level.upper(), stream=sys.stderr, format="%(asctime)s %(levelname)s %(message)s"
    )
    if no_monitor and (http_port is not None or monitor_post or monitor_hosts):
        raise click.UsageError("--no-monitor cannot be combined with other monitor options")
    options = ServerOptions(
        host=host,
        port=port,
        config_path=config_path,
        store=store,
        monitor=not no_monitor,
        http_port=http_port,
        monitor_post=monitor_post,
        monitor_hosts=_hosts(monitor_hosts),
        limits=ServerLimits(stream_push_buffer=stream_push_buffer, max_wait_ms=max_wait_ms),
    )
    try:
        asyncio.run(_run(options))
    except ConfigError as exc:
        click.echo(f"openair serve: {exc}", err=True)
        sys.exit(2)
    except StoreSpecError as exc:
        click.echo(f"openair serve: {exc}", err=True)
        sys.exit(2)
    except OSError as exc:
        click.echo(f"openair serve: cannot start: {exc}", err=True)
        sys.exit(1)
    except KeyboardInterrupt:  # a second Ctrl-C during shutdown
        sys.exit(0)
