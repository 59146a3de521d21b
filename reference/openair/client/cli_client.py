"""Client commands of the ``openair`` command line: ``post``, ``watch``, ``retrieve``, ``ping``.

Each command is a thin function over `Module`. Exit codes (all commands):

\b
  0  success
  1  the server answered with a failure reply, or a reply did not come in time
  2  usage error (bad option, invalid type or pattern, malformed XML content)
  3  cannot connect to the server, or the connection was lost
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
from collections.abc import Callable, Coroutine
from typing import Any, TypeVar

import click

from openair.client.module import Module, WakeupEvent
from openair.content import RetrieveSpec, Trigger
from openair.errors import ConnectionClosedError, OpenAIRError
from openair.message import Message
from openair.times import AirTime
from openair.types import validate_pattern, validate_type
from openair.xmlsafe import parse_fragment

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_CONNECT = 3

DEFAULT_SERVER = "127.0.0.1:10000"
_EPILOG = "Exit codes: 0 ok, 1 request failed, 2 usage, 3 cannot connect."

_T = TypeVar("_T")


def parse_server(value: str) -> tuple[str, int]:
    """Split `HOST:PORT` (also `HOST` or `:PORT`; default 127.0.0.1:10000)."""
    host, sep, port_text = value.rpartition(":")
    if not sep:
        host, port_text = value, "10000"
    host = host.strip("[]") or "127.0.0.1"
    if not port_text.isdigit() or not 0 < int(port_text) < 65536:
        raise ValueError(f"not a port: {port_text!r}")
    return host, int(port_text)


def _server(ctx: click.Context, param: click.Parameter, value: str) -> tuple[str, int]:
    """Click callback: convert `HOST:PORT` (exit 2 when it is not an address)."""
    try:
        return parse_server(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


_server_option = click.option(
    "--server",
    metavar="HOST:PORT",
    callback=_server,
    default=DEFAULT_SERVER,
    envvar="OPENAIR_SERVER",
    show_default=True,
    help="Server address (or the OPENAIR_SERVER environment variable).",
)


def _run(coro: Coroutine[Any, Any, _T]) -> _T:
    """Run a command's coroutine; map errors to the documented exit codes."""
    try:
        return asyncio.run(coro)
    except (OSError, ConnectionClosedError) as exc:
        click.echo(f"error: cannot connect: {exc}", err=True)
        raise click.exceptions.Exit(EXIT_CONNECT) from None
    except OpenAIRError as exc:
        click.echo(f"error: {exc}", err=True)
        raise click.exceptions.Exit(EXIT_FAILED) from None


def _client(name: str, server: tuple[str, int]) -> Module:
    """A client that does not bind: it only sends requests (OA-SESS-16)."""
    host, port = server
    return Module(name, host, port, bind=False, reconnect=False, keepalive=None)


def _check(validate: Callable[[str], str]) -> Callable[[click.Context, click.Parameter, Any], Any]:
    """Build a click callback that validates a type or pattern (exit 2 when invalid)."""

    def callback(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
        if value is None:
            return None
        try:
            return validate(value)
        except OpenAIRError as exc:
            raise click.BadParameter(str(exc)) from None

    return callback


def _time(t: AirTime | None) -> str:
    """Render a time as `sec.msec` (or `-`)."""
    return str(t) if t is not None else "-"


@click.command(epilog=_EPILOG)
@click.argument("whiteboard")
@click.argument("type", callback=_check(validate_type))
@click.argument("content", default="")
@click.option("--cc", multiple=True, metavar="NAME", help="A module to wake (repeatable).")
@click.option("--priority", type=click.FloatRange(0.0, 6.999), help="0.0 (highest) to 6.999.")
@click.option("--from", "sender", default="openair-cli", show_default=True, help="The from slot.")
@click.option("--xml", "is_xml", is_flag=True, help="CONTENT is XML (language xml).")
@_server_option
def post(
    whiteboard: str,
    type: str,
    content: str,
    cc: tuple[str, ...],
    priority: float | None,
    sender: str,
    is_xml: bool,
    server: tuple[str, int],
) -> None:
    """Post a message of TYPE to WHITEBOARD and wait for RECEIVE_ACCEPT.

    Prints the id of the stored message's request.
    """
    if is_xml:
        try:
            parse_fragment(content)
        except OpenAIRError as exc:
            raise click.BadParameter(str(exc), param_hint="CONTENT") from None

    async def run() -> Message:
        async with _client(sender, server) as module:
            return await module.post(
                whiteboard, type, content, cc=cc, priority=priority, content_is_xml=is_xml
            )

    sent = _run(run())
    click.echo(f"posted {sent.type} to {whiteboard} id={sent.id} posted={_time(sent.posted)}")


def _wakeup_line(event: WakeupEvent) -> str:
    """One line per wakeup: type, from, the timestamps and the post→wakeup latency."""
    msg = event.wakeup.trigger
    assert msg is not None
    posted = msg.posted
    latency = f"{(event.received_ns - posted.us * 1000) / 1e6:.3f}" if posted else "-"
    woken = AirTime.from_ns(event.received_ns, with_usec=True)
    return (
        f"{msg.type} from={msg.sender or '-'} wb={msg.stored or event.message.sender or '-'} "
        f"posted={_time(posted)} stored={_time(msg.received)} woken={woken} "
        f"latency_ms={latency}"
    )


@click.command(epilog=_EPILOG)
@click.argument("pattern", callback=_check(validate_pattern))
@click.option("--from", "whiteboard", default="", help="Only this whiteboard (default: any).")
@click.option("--count", type=click.IntRange(min=1), help="Stop after N wakeups.")
@click.option("--name", default=None, help="Module name (default: watch-<pid>).")
@_server_option
def watch(
    pattern: str, whiteboard: str, count: int | None, name: str | None, server: tuple[str, int]
) -> None:
    """Register a trigger on PATTERN and print each wakeup on one line.

    Each line shows the type, the poster, the whiteboard, postedTime, the whiteboard's
    receivedTime, the time the wakeup arrived here, and the latency from post to wakeup in ms
    (meaningful when the clocks agree). Stops after --count wakeups or on Ctrl-C.
    """
    host, port = server

    async def run() -> None:
        module = Module(name or f"watch-{os.getpid()}", host, port)
        async with module:
            await module.subscribe(Trigger(pattern=pattern, whiteboard=whiteboard))
            seen = 0
            async for event in module.wakeups():
                if event.wakeup.trigger is None:
                    continue  # a phase update, not a message
                click.echo(_wakeup_line(event))
                seen += 1
                if count is not None and seen >= count:
                    return

    with contextlib.suppress(KeyboardInterrupt):
        _run(run())


def _message_json(msg: Message) -> dict[str, Any]:
    """A message as a JSON-friendly dict (times as {sec, msec[, usec]})."""

    def t(value: AirTime | None) -> dict[str, int] | None:
        if value is None:
            return None
        out = {"sec": value.sec, "msec": value.msec}
        return out | ({"usec": value.usec} if value.usec is not None else {})

    return {
        "type": msg.type,
        "id": msg.id,
        "from": msg.sender,
        "to": msg.to,
        "cc": msg.cc,
        "stored": msg.stored,
        "wbid": msg.wbid,
        "priority": msg.priority,
        "postedTime": t(msg.posted),
        "receivedTime": t(msg.received),
        "language": msg.language,
        "content": msg.content,
    }


@click.command(epilog=_EPILOG)
@click.argument("whiteboard")
@click.option("--type", "pattern", callback=_check(validate_pattern), help="Type pattern.")
@click.option("--sender", default="", help="Only messages from this poster.")
@click.option("--content", default="", help="Glob over the text content (* = any run).")
@click.option("--latest", type=click.IntRange(min=0), default=1, show_default=True,
              help="At most N messages (0 = no limit).")  # fmt: skip
@click.option("--lastmsec", type=click.IntRange(min=0), help="Only the last MS milliseconds.")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON list.")
@click.option("--from", "name", default="openair-cli", show_default=True, help="The from slot.")
@_server_option
def retrieve(
    whiteboard: str,
    pattern: str | None,
    sender: str,
    content: str,
    latest: int,
    lastmsec: int | None,
    as_json: bool,
    name: str,
    server: tuple[str, int],
) -> None:
    """Retrieve messages stored on WHITEBOARD, newest first.

    One line per message: wbid, type, poster, postedTime, receivedTime, content.
    """
    spec = RetrieveSpec(
        whiteboard=whiteboard,
        pattern=pattern or "",
        sender=sender,
        content=content,
        latest=latest,
        lastmsec=lastmsec,
    )

    async def run() -> list[Message]:
        async with _client(name, server) as module:
            return await module.retrieve(spec)

    found = _run(run())
    if as_json:
        click.echo(json.dumps([_message_json(m) for m in found], indent=2))
        return
    for msg in found:
        wbid = "-" if msg.wbid is None else str(msg.wbid)
        click.echo(
            f"{wbid} {msg.type} from={msg.sender or '-'} posted={_time(msg.posted)} "
            f"received={_time(msg.received)} {msg.content!r}"
        )


@click.command(epilog=_EPILOG)
@click.argument("server", metavar="HOST:PORT", callback=_server)
@click.option("--count", type=click.IntRange(min=1), default=1, show_default=True)
@click.option("--from", "name", default="openair-cli", show_default=True, help="The from slot.")
def ping(server: tuple[str, int], count: int, name: str) -> None:
    """PING the server at HOST:PORT and show its capabilities.

    Prints the round-trip time of each PING, then either the server's protocol, extensions and
    limits, or that it is a legacy server (it answered GET_CAPABILITIES with UNKNOWN_COMMAND).
    """

    async def run() -> Module:
        async with _client(name, server) as module:
            for seq in range(1, count + 1):
                rtt = await module.ping()
                where = f"{server[0]}:{server[1]}"
                click.echo(f"PING_SUCCESS from {where} seq={seq} rtt={rtt * 1e3:.3f} ms")
            return module

    module = _run(run())
    caps = module.capabilities
    if caps is None:
        click.echo("server: legacy (GET_CAPABILITIES answered UNKNOWN_COMMAND)")
        return
    click.echo(f"server: {caps.server} protocol={caps.protocol}")
    click.echo("extensions: " + (" ".join(caps.extensions) or "(none)"))
    click.echo("limits: " + " ".join(f"{k}={v}" for k, v in caps.limits))


#: The commands the lead registers on the ``openair`` group.
COMMANDS: list[click.Command] = [post, watch, retrieve, ping]
