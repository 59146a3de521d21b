"""`openair serve`: run the reference whiteboard server in the foreground."""

from __future__ import annotations

import asyncio
import contextlib
import gc
import logging
import os
import signal
import socket
import ssl
import sys
import threading
from typing import Any

import click

from openair.extras import install_hint
from openair.protocol.auth import SecretsError
from openair.secretsfile import load_secrets
from openair.server.aio.app import Server, ServerOptions, start_server
from openair.server.aio.budgets import return_large_buffers
from openair.server.aio.fairselect import fair_event_loop
from openair.server.cli_budgets import budget_options
from openair.server.core.config import ConfigError, ServerLimits
from openair.server.core.store import StoreSpecError

__all__ = ["serve"]

log = logging.getLogger("openair.server")

_LEVELS = ("debug", "info", "warning", "error")
#: A forced exit (a second SIGINT/SIGTERM, or a shutdown that overran) returns 128 + signal.
EXIT_FORCED_BASE = 128
# The stop's own stages are bounded (app.py); past the grace period plus this, force the exit.
_STOP_MARGIN_S = 15.0
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
    return_large_buffers()  # RSS falls again after a burst of large posts (issue #19)


class _Stopper:
    """The SIGINT/SIGTERM handler: the first signal stops gracefully, a second one forces exit.

    Plain `signal.signal` handlers, not the event loop's: they run even when the loop is busy.
    The first signal also arms a watchdog thread, so the process ends even if a graceful stop
    never finishes; a forced exit returns 128 + the signal's number (130, 143).
    """

    def __init__(self, loop: asyncio.AbstractEventLoop, server: Server, bound_s: float) -> None:
        self._loop = loop
        self._server = server
        self._bound_s = bound_s
        self._first: int | None = None
        self._task: asyncio.Task[None] | None = None

    def install(self) -> None:
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, self._on_signal)

    def _on_signal(self, signum: int, frame: object) -> None:
        if self._first is not None:
            _force_exit(signum, "a second signal")
            return
        self._first = signum
        watchdog = threading.Timer(self._bound_s, _force_exit, (signum, "the shutdown overran"))
        watchdog.daemon = True
        watchdog.start()
        self._loop.call_soon_threadsafe(self._begin)

    def _begin(self) -> None:
        self._task = self._loop.create_task(self._server.stop())


def _force_exit(signum: int, why: str) -> None:
    """End the process at once: the graceful shutdown was interrupted or did not finish."""
    with contextlib.suppress(Exception):
        log.warning("event=shutdown phase=forced reason=%r", why)
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(EXIT_FORCED_BASE + signum)


def _cluster_store(store: str, cluster: str | None, node: str | None) -> str:
    """The store spec: `cluster:NODE@URLS` for a cluster node (spec 17), else --store."""
    if cluster is None:
        if node is not None:
            raise click.UsageError("--node needs --cluster")
        return store
    if store != "memory":
        raise click.UsageError("--cluster keeps the whiteboards in JetStream: no --store")
    return f"cluster:{node or socket.gethostname()}@{cluster}"


async def _run(options: ServerOptions) -> None:
    """Start, announce readiness on stdout, and stop on SIGINT or SIGTERM."""
    server = await start_server(options)
    _tune_gc()
    _Stopper(asyncio.get_running_loop(), server, options.grace_s + _STOP_MARGIN_S).install()
    boards = ", ".join(server.whiteboards)
    click.echo(f"listening on {server.host}:{server.port} (whiteboards: {boards})")
    if server.monitor is not None:
        click.echo(_monitor_line(server))
    elif options.monitor and options.auth_secrets is None:  # the application is not installed
        click.echo(f"no web monitor: {install_hint('monitor')}", err=True)
    sys.stdout.flush()
    await server.serve_forever()
    # Stopped: a late signal (a supervisor repeating SIGTERM) has nothing left to force.
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)


def _secure(
    auth_path: str | None, cert: str | None, key: str | None, *, monitor_options: bool
) -> dict[str, Any]:
    """Return the ServerOptions of secure mode and TLS (spec 14.3); exit 2 on a bad file."""
    if (cert is None) != (key is None):
        raise click.UsageError("--tls-cert and --tls-key go together")
    if auth_path is not None and monitor_options:
        raise click.UsageError("--auth turns the web monitor off (OA-AUTH-11)")
    found: dict[str, Any] = {}
    try:
        if auth_path is not None:
            found["auth_secrets"] = load_secrets(auth_path)
        if cert is not None and key is not None:
            context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
            context.minimum_version = ssl.TLSVersion.TLSv1_2  # OA-AUTH-10
            context.load_cert_chain(cert, key)
            found["tls"] = context
    except (SecretsError, OSError, ssl.SSLError) as exc:
        click.echo(f"openair serve: {exc}", err=True)
        sys.exit(2)
    if auth_path is not None and cert is None:
        log.warning("event=insecure detail=secure mode without TLS (OA-AUTH-10)")
    return found


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
    default=None,
    type=click.IntRange(0, 65535),
    help="Main port (0: any free port; the line printed at start names it). Default: the "
    "psySpec's <global><port>, else 10000.",
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
    "--cluster",
    metavar="nats://HOST:PORT[,...]",
    default=None,
    help="Be a node of a cluster whose whiteboards live in NATS JetStream (spec 17); "
    "needs the extra cluster. Not with --store.",
)
@click.option("--node", default=None, help="This node's name in the cluster (default: host name).")
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
    "--auth",
    "auth_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Secure mode (extension auth, spec 14.3): the module secrets file "
    "(<secrets><module name secret/></secrets>). Turns the web monitor off.",
)
@click.option("--tls-cert", type=click.Path(dir_okay=False), help="TLS certificate (PEM).")
@click.option("--tls-key", type=click.Path(dir_okay=False), help="TLS private key (PEM).")
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
@click.option(
    "--max-queue",
    default=ServerLimits().max_queue,
    show_default=True,
    type=click.IntRange(1, 100_000_000),
    help="Deliveries queued per module before the oldest lowest-priority ones drop (OA-DELIV-8).",
)
@click.option(
    "--max-in-flight",
    default=ServerLimits().max_in_flight,
    show_default=True,
    type=click.IntRange(1, 1_000_000),
    help="Requests in flight per connection, and deliveries per pipelining module (OA-LIM-5).",
)
@click.option(
    "--delivery-retries",
    default=ServerLimits().delivery_retries,
    show_default=True,
    type=click.IntRange(1, 100),
    help="Retries of a failed delivery before it is abandoned (OA-DELIV-7, OA-DELIV-15).",
)
@click.option(
    "--retry-deadline-ms",
    default=ServerLimits().retry_deadline_ms,
    show_default=True,
    type=click.IntRange(1, 3_600_000),
    help="The longest wait between a failed delivery and its retry (OA-DELIV-15).",
)
@click.option(
    "--ack-deadline-ms",
    default=ServerLimits().ack_deadline_ms,
    show_default=True,
    type=click.IntRange(1, 3_600_000),
    help="How long a delivery may wait for its acknowledgement before it has failed: its "
    "connection is closed and it is retried (OA-DELIV-11).",
)
@click.option(
    "--fair-slice-ms",
    default=ServerOptions().fair_slice_s * 1000,
    show_default=True,
    type=click.FloatRange(0, 1000),
    help="The processor time the connections of one peer address may take in one turn of the "
    "event loop before they wait for the next (0: no limit). Bounds how long one client's "
    "burst keeps every other client waiting.",
)
@budget_options  # --max-queue-bytes … --frame-total-deadline-ms (OA-LIM-8 to OA-LIM-13)
def serve(
    host: str,
    port: int | None,
    config_path: str | None,
    store: str,
    cluster: str | None,
    node: str | None,
    log_level: str,
    http_port: int | None,
    monitor_post: bool,
    monitor_hosts: tuple[str, ...],
    no_monitor: bool,
    auth_path: str | None,
    tls_cert: str | None,
    tls_key: str | None,
    stream_push_buffer: int,
    max_wait_ms: int,
    max_queue: int,
    max_in_flight: int,
    delivery_retries: int,
    retry_deadline_ms: int,
    ack_deadline_ms: int,
    fair_slice_ms: float,
    budgets: dict[str, int],
) -> None:
    """Run the OpenAIR reference server until SIGINT or SIGTERM.

    When it is ready it prints one line, `listening on HOST:PORT (whiteboards: …)`, on stdout,
    then `monitor on URL… (read-only|posting allowed)` unless --no-monitor: the web monitor
    answers HTTP on the main port (and on --http-port when given). Log lines
    (`event=NAME key=value …`) go to stderr. On a signal it shuts down gracefully: new requests
    get SHUTTING_DOWN, decided deliveries are attempted for up to 5 s, the store is closed. A
    second SIGINT or SIGTERM ends it at once, and so does a shutdown still running 20 s after
    the first signal.

    \b
    Exit codes:
      0    stopped by SIGINT or SIGTERM after a graceful shutdown
      1    could not listen (address in use, permission)
      2    usage error, an invalid configuration file (the message names file and line), or a
           store that cannot be opened (no such directory, a directory, not a database)
      130  (SIGINT) or 143 (SIGTERM): 128 + the signal, when the shutdown was forced
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
        store=_cluster_store(store, cluster, node),
        monitor=not no_monitor,
        http_port=http_port,
        monitor_post=monitor_post,
        monitor_hosts=_hosts(monitor_hosts),
        fair_slice_s=fair_slice_ms / 1000,
        **_secure(auth_path, tls_cert, tls_key, monitor_options=bool(http_port or monitor_post)),
        limits=ServerLimits(
            stream_push_buffer=stream_push_buffer,
            max_wait_ms=max_wait_ms,
            max_queue=max_queue,
            max_in_flight=max_in_flight,
            delivery_retries=delivery_retries,
            retry_deadline_ms=retry_deadline_ms,
            ack_deadline_ms=ack_deadline_ms,
            **budgets,
        ),
    )
    try:
        # issue #19: a flood's sockets wait their turn behind other addresses' (fairselect)
        with asyncio.Runner(loop_factory=fair_event_loop if fair_slice_ms > 0 else None) as run:
            run.run(_run(options))
    except (ConfigError, StoreSpecError) as exc:
        click.echo(f"openair serve: {exc}", err=True)
        sys.exit(2)
    except OSError as exc:
        click.echo(f"openair serve: cannot start: {exc}", err=True)
        sys.exit(1)
    except KeyboardInterrupt:  # Ctrl-C while starting, before the handlers are installed
        sys.exit(EXIT_FORCED_BASE + signal.SIGINT)
