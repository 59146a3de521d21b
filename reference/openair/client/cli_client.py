"""Client commands of the ``openair`` command line: ``post``, ``watch``, ``retrieve``, ``ping``.

Each command is a thin function over `Module`. Exit codes (all commands):

\b
  0  success
  1  the server answered with a failure reply, or a reply did not come within --timeout
  2  usage error (bad option, invalid type or pattern, malformed XML content, unreadable file)
  3  cannot connect to the server, the connection was lost, or the peer does not speak
     OpenAIR (no OpenAIR answer to the first request within --timeout)
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
from collections.abc import Callable, Coroutine
from typing import IO, Any, TypeVar

import click

from openair.client.module import FailedReplyError, Module, WakeupEvent
from openair.protocol.address import parse_server
from openair.protocol.content import RetrieveSpec, Trigger
from openair.protocol.errors import (
    ConnectionClosedError,
    ForwardFailedError,
    OpenAIRError,
    RequestTimeoutError,
    WhiteboardUnknownError,
)
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.types import validate_pattern, validate_type
from openair.protocol.xmlsafe import parse_fragment

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_CONNECT = 3

DEFAULT_SERVER = "127.0.0.1:10000"
DEFAULT_TIMEOUT_S = 10.0  # OA-SESS-27: at least 10 s per request is advised
_EPILOG = "Exit codes: 0 ok, 1 request failed, 2 usage, 3 cannot connect or not OpenAIR."
#: Characters of content shown per line by `retrieve` and `watch` (--full: all of it).
SHOWN_CHARS = 200
_TIMEOUT_KEY = "openair.timeout"

_T = TypeVar("_T")


def _server(ctx: click.Context, param: click.Parameter, value: str) -> tuple[str, int]:
    """Click callback: convert `HOST:PORT` (exit 2 when it is not an address)."""
    try:
        return parse_server(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


def _timeout(ctx: click.Context, param: click.Parameter, value: float) -> float:
    """Click callback: keep --timeout where `_client` finds it (every client command has it)."""
    ctx.meta[_TIMEOUT_KEY] = value
    return value


def _server_option(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Add --server HOST:PORT and --timeout SECONDS (not passed to the command) to a command."""
    fn = click.option(
        "--timeout",
        type=click.FloatRange(min=0, min_open=True),
        default=DEFAULT_TIMEOUT_S,
        show_default=True,
        metavar="SECONDS",
        callback=_timeout,
        expose_value=False,
        help="The longest to wait for each reply (and for the server's first answer).",
    )(fn)
    return click.option(
        "--server",
        metavar="HOST:PORT",
        callback=_server,
        default=DEFAULT_SERVER,
        envvar="OPENAIR_SERVER",
        show_default=True,
        help="Server address (or the OPENAIR_SERVER environment variable).",
    )(fn)


class CliFailure(Exception):
    """A failure a command explains in one line, with its exit code."""

    def __init__(self, code: int, text: str) -> None:
        super().__init__(text)
        self.code = code


def _run(coro: Coroutine[Any, Any, _T]) -> _T:
    """Run a command's coroutine; map errors to the documented exit codes."""
    try:
        return asyncio.run(coro)
    except CliFailure as exc:
        click.echo(f"error: {exc}", err=True)
        raise click.exceptions.Exit(exc.code) from None
    except (OSError, ConnectionClosedError) as exc:
        click.echo(f"error: cannot connect: {exc}", err=True)
        raise click.exceptions.Exit(EXIT_CONNECT) from None
    except RequestTimeoutError as exc:
        click.echo(f"error: {exc} (--timeout)", err=True)
        raise click.exceptions.Exit(EXIT_FAILED) from None
    except OpenAIRError as exc:
        click.echo(f"error: {exc}", err=True)
        raise click.exceptions.Exit(EXIT_FAILED) from None


#: The public name of `_run`, for the commands of the applications beside the core (apps/).
run_command = _run


class CliModule(Module):
    """A `Module` whose connect() tells a peer that is not OpenAIR from one that is down."""

    async def connect(self) -> None:
        where = f"{self.host}:{self.port}"
        try:
            await super().connect()
        except OSError as exc:
            raise CliFailure(EXIT_CONNECT, f"cannot connect to {where}: {exc}") from None
        except RequestTimeoutError:
            raise CliFailure(
                EXIT_CONNECT,
                f"{where} is not an OpenAIR server: no answer to GET_CAPABILITIES within "
                f"{self.request_timeout} s",
            ) from None
        except OpenAIRError as exc:  # unreadable frames, or a close instead of an answer
            raise CliFailure(
                EXIT_CONNECT, f"{where} is not an OpenAIR server (or hung up): {exc}"
            ) from None


def _request_timeout() -> float:
    """The --timeout of the command being run (the default outside a command)."""
    ctx = click.get_current_context(silent=True)
    value = ctx.meta.get(_TIMEOUT_KEY) if ctx is not None else None
    return float(value) if value is not None else DEFAULT_TIMEOUT_S


def _client(name: str, server: tuple[str, int]) -> Module:
    """A client that does not bind: it only sends requests (OA-SESS-16)."""
    host, port = server
    return CliModule(
        name,
        host,
        port,
        bind=False,
        reconnect=False,
        keepalive=None,
        request_timeout=_request_timeout(),
    )


def shown(content: str, full: bool, limit: int = SHOWN_CHARS) -> str:
    """Render content for one line: quoted, and cut after `limit` characters unless `full`."""
    if full or len(content) <= limit:
        return repr(content)
    return f"{content[:limit]!r}… [{len(content)} characters; --full shows all]"


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
@click.argument("content", default=None, required=False)
@click.option(
    "--file",
    "source",
    type=click.File("r", encoding="utf-8"),
    metavar="PATH|-",
    help="Read the content from PATH ('-': standard input) instead of CONTENT.",
)
@click.option("--cc", multiple=True, metavar="NAME", help="A module to wake (repeatable).")
@click.option("--priority", type=click.FloatRange(0.0, 6.999), help="0.0 (highest) to 6.999.")
@click.option("--from", "sender", default="openair-cli", show_default=True, help="The from slot.")
@click.option("--xml", "is_xml", is_flag=True, help="CONTENT is XML (language xml).")
@_server_option
def post(
    whiteboard: str,
    type: str,
    content: str | None,
    source: IO[str] | None,
    cc: tuple[str, ...],
    priority: float | None,
    sender: str,
    is_xml: bool,
    server: tuple[str, int],
) -> None:
    """Post a message of TYPE to WHITEBOARD and wait for RECEIVE_ACCEPT.

    The content is CONTENT, or what --file reads (large content: a shell limits one argument
    to about 128 KiB). Prints the id of the stored message's request. A WHITEBOARD that names
    nothing on the server fails with FORWARD_FAILED (OA-SESS-21), exit code 1.
    """
    if source is not None and content is not None:
        raise click.UsageError("give CONTENT or --file, not both")
    text = source.read() if source is not None else content or ""
    if is_xml:
        try:
            parse_fragment(text)
        except OpenAIRError as exc:
            raise click.BadParameter(str(exc), param_hint="CONTENT") from None

    async def run() -> Message:
        async with _client(sender, server) as module:
            try:
                return await module.post(
                    whiteboard, type, text, cc=cc, priority=priority, content_is_xml=is_xml
                )
            except FailedReplyError as exc:
                forward = exc.response.type == ForwardFailedError.reply  # OA-SESS-21
                if not forward and exc.condition is not ForwardFailedError:
                    raise
                where = f"{server[0]}:{server[1]}"
                raise CliFailure(
                    EXIT_FAILED,
                    f"{whiteboard!r} is no whiteboard, component, stream or bound module on "
                    f"{where} (FORWARD_FAILED)",
                ) from None

    sent = _run(run())
    click.echo(f"posted {sent.type} to {whiteboard} id={sent.id} posted={_time(sent.posted)}")


def _latency_ms(event: WakeupEvent) -> float | None:
    """Milliseconds from the post to this wakeup (meaningful when the clocks agree)."""
    msg = event.wakeup.trigger
    posted = msg.posted if msg is not None else None
    return None if posted is None else (event.received_ns - posted.us * 1000) / 1e6


def _wakeup_line(event: WakeupEvent, full: bool = False) -> str:
    """One line per wakeup: type, from, the timestamps, the latency, and the content."""
    msg = event.wakeup.trigger
    assert msg is not None
    latency = _latency_ms(event)
    woken = AirTime.from_ns(event.received_ns, with_usec=True)
    return (
        f"{msg.type} from={msg.sender or '-'} wb={msg.stored or event.message.sender or '-'} "
        f"posted={_time(msg.posted)} stored={_time(msg.received)} woken={woken} "
        f"latency_ms={'-' if latency is None else f'{latency:.3f}'} "
        f"{shown(msg.content, full, SHOWN_CHARS // 2)}"
    )


def _wakeup_json(event: WakeupEvent) -> str:
    """One wakeup as one JSON object on one line: the message (whole content) and timings."""
    msg = event.wakeup.trigger
    assert msg is not None
    record = _message_json(msg)
    woken = AirTime.from_ns(event.received_ns, with_usec=True)
    record["whiteboard"] = msg.stored or event.message.sender
    record["wokenTime"] = {"sec": woken.sec, "msec": woken.msec, "usec": woken.usec}
    record["latency_ms"] = _latency_ms(event)
    return json.dumps(record)


async def _check_whiteboard(module: Module, whiteboard: str, where: str) -> None:
    """Fail unless `whiteboard` exists: a retrieve from an unknown one fails (OA-RET-11).

    A server may accept a trigger on a whiteboard that does not exist, which then never fires
    (OA-REG-9): without this check `watch --from` a mistyped name would wait for ever.
    """
    try:
        await module.retrieve(RetrieveSpec(whiteboard=whiteboard, latest=1))
    except FailedReplyError as exc:
        if exc.condition is WhiteboardUnknownError:
            raise CliFailure(EXIT_FAILED, f"no whiteboard {whiteboard!r} on {where}") from None
        raise


@click.command(epilog=_EPILOG)
@click.argument("pattern", callback=_check(validate_pattern))
@click.option("--from", "whiteboard", default="", help="Only this whiteboard (default: any).")
@click.option("--count", type=click.IntRange(min=1), help="Stop after N wakeups.")
@click.option("--name", default=None, help="Module name (default: watch-<pid>).")
@click.option("--json", "as_json", is_flag=True, help="One JSON object per line (whole content).")
@click.option("--full", is_flag=True, help="Show the whole content on each line.")
@_server_option
def watch(
    pattern: str,
    whiteboard: str,
    count: int | None,
    name: str | None,
    as_json: bool,
    full: bool,
    server: tuple[str, int],
) -> None:
    """Register a trigger on PATTERN and print each wakeup on one line.

    Each line shows the type, the poster, the whiteboard, postedTime, the whiteboard's
    receivedTime, the time the wakeup arrived here, the latency from post to wakeup in ms
    (meaningful when the clocks agree) and the content (its first 100 characters unless
    --full). --json prints one JSON object per line instead, with the whole content. A --from
    whiteboard that does not exist fails at once (exit 1). Stops after --count wakeups or on
    Ctrl-C.
    """
    host, port = server

    async def run() -> None:
        module = CliModule(
            name or f"watch-{os.getpid()}", host, port, request_timeout=_request_timeout()
        )
        async with module:
            if whiteboard:
                await _check_whiteboard(module, whiteboard, f"{host}:{port}")
            await module.subscribe(Trigger(pattern=pattern, whiteboard=whiteboard))
            seen = 0
            async for event in module.wakeups():
                if event.wakeup.trigger is None:
                    continue  # a phase update, not a message
                click.echo(_wakeup_json(event) if as_json else _wakeup_line(event, full))
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
@click.option("--json", "as_json", is_flag=True, help="Print a JSON list (whole contents).")
@click.option("--full", is_flag=True, help="Print whole contents (else the first 200 characters).")
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
    full: bool,
    name: str,
    server: tuple[str, int],
) -> None:
    """Retrieve messages stored on WHITEBOARD, newest first.

    One line per message: wbid, type, poster, postedTime, receivedTime, content. A content
    longer than 200 characters is cut, with a note of its length; --full prints it whole.
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
            f"received={_time(msg.received)} {shown(msg.content, full)}"
        )


@click.command(epilog=_EPILOG)
@click.argument("target", metavar="[HOST:PORT]", required=False)
@click.option("--count", type=click.IntRange(min=1), default=1, show_default=True)
@click.option("--from", "name", default="openair-cli", show_default=True, help="The from slot.")
@_server_option
@click.pass_context
def ping(
    ctx: click.Context, target: str | None, count: int, name: str, server: tuple[str, int]
) -> None:
    """PING the server (--server, or HOST:PORT as an argument) and show its capabilities.

    Prints the round-trip time of each PING, then either the server's protocol, extensions and
    limits, or that it is a legacy server (it answered GET_CAPABILITIES with UNKNOWN_COMMAND).
    """
    if target is not None:
        if ctx.get_parameter_source("server") is click.core.ParameterSource.COMMANDLINE:
            raise click.UsageError("give HOST:PORT or --server, not both")
        server = _server(ctx, ctx.command.params[0], target)

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
