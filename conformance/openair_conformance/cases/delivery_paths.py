"""Conformance cases for how a module is reached: RESOLVE, BIND again, callback paths (6.3-6.6).

The modules here are raw connections: the case chooses exactly when the callback connection
opens, which port a BIND names (a port nobody listens on, reserved and released by the case),
and answers the server's requests itself (`next_request`, `ack`).
"""

from __future__ import annotations

import asyncio
import socket

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._common import ack, esc, next_request, retrieved, triggers_xml
from openair_conformance.harness import CaseContext, RawConnection, TestModule
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    attributes,
    content_object,
    wakeup_trigger_id,
)
from openair_conformance.harness.conn import ConnectionLost, open_stream
from openair_conformance.model import Inconclusive
from openair_conformance.registry import case


class _RawAt(RawConnection):
    """A raw connection to a given address and port instead of the main port."""

    def __init__(self, ctx: CaseContext, *, label: str, host: str, port: int) -> None:
        super().__init__(ctx, label=label)
        self._at = (host, port)

    async def open(self) -> None:
        """Connect to the given address; Fail when nothing answers there."""
        host, port = self._at
        try:
            self._stream = await open_stream(
                host, port, label=self.label, trace=self.ctx.trace, timeout=self.ctx.deadline
            )
        except ConnectionLost as exc:
            self.ctx.fail(
                f"cannot connect to the resolved {host}:{port}: {exc}",
                expected="the component answers at the address and port RESOLVE gave (OA-SESS-34)",
            )


def _closed_port(host: str) -> int:
    """Return a port on `host` that nobody listens on (bound by the OS, then released)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind((host, 0))
        port: int = sock.getsockname()[1]
    return port


def _request(ctx: CaseContext, type_: str, name: str, **fields: object) -> Message:
    return ctx.message(type_, sender=name, **fields)


async def _bind(ctx: CaseContext, primary: RawConnection, name: str, port: int | None) -> str:
    """BIND `name` (asking for `port`, or BIND_NOLISTEN for None); return the reply's content."""
    if port is None:
        msg = _request(ctx, "BIND_NOLISTEN", name, to="CNS")
    else:
        location = f'<tcplocation port="{port}"/>'
        msg = _request(ctx, "BIND", name, to="CNS", content=location, content_is_xml=True)
    reply = await primary.request(msg)
    if reply.type != "BIND_ACCEPT":
        raise Inconclusive(f"setup: {msg.type} was answered {reply.type} {reply.content!r}")
    return reply.content.strip()


async def _callback(ctx: CaseContext, name: str) -> tuple[RawConnection, str]:
    """Open a raw callback connection for `name`; return it and the Receive frame's id."""
    callback = await ctx.raw("callback")
    sent = await callback.send_message(
        Message(type="RECEIVE_NAME_NOTIFICATION", sender=name), FrameTag.RECEIVE
    )
    return callback, sent.id


async def _subscribe(ctx: CaseContext, primary: RawConnection, name: str, pattern: str) -> None:
    msg = _request(
        ctx,
        "AIR.Subscribe",
        name,
        to="AIRCentral",
        content=triggers_xml(pattern),
        content_is_xml=True,
        language="xml",
    )
    reply = await primary.request(msg)
    if reply.type != "RECEIVE_ACCEPT":
        raise Inconclusive(f"setup: AIR.Subscribe was answered {reply.type} {reply.content!r}")


async def _woken(ctx: CaseContext, callback: RawConnection, receive_id: str, name: str) -> Message:
    """Return the next request on the callback connection, acknowledged."""
    wakeup = await next_request(ctx, callback, receive_id=receive_id, name=name)
    await ack(callback, wakeup, name)
    return wakeup


@case(
    id="SESS-040",
    title="A resolved address and port answer requests for the component named by 'to'",
    section="6.4",
    requirements=("OA-SESS-34", "OA-SESS-8", "OA-SESS-10"),
    allowed=(
        "the main port (the server routes by 'to', OA-SESS-9) or a port of WB1's own",
        "PING_SUCCESS from WB1 and AIR.Retrieve.Success there",
    ),
)
async def resolved_port_answers(ctx: CaseContext) -> None:
    """Resolve WB1, connect to the address and port given, PING WB1 and retrieve a post there.

    Catches: a server that hands out a port where nothing listens, or where the component does
    not answer requests addressed to it.
    """
    name = ctx.name("R")
    raw = await ctx.raw()
    reply = await raw.request(_request(ctx, "RESOLVE_REQUEST", name, to="CNS", content="WB1"))
    ctx.check(
        reply.type == "RESOLVE_SUCCESS", f"RESOLVE of WB1: {reply.type}", expected="OA-SESS-8"
    )
    try:
        location = attributes(content_object(reply, "tcplocation"))
    except WakeupUnreadable as exc:
        ctx.fail(f"RESOLVE_SUCCESS content: {exc}", expected="<tcplocation address port/>")
    port = location.get("port", "")
    ctx.check(port.isdigit(), f"tcplocation port {port!r}", expected="a port (OA-SESS-8)")
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("There"), "there")
    there = _RawAt(ctx, label="resolved", host=location.get("address", ""), port=int(port))
    await there.open()
    try:
        pong = await there.request(_request(ctx, "PING", name, to="WB1"))
        ctx.check(
            pong.type == "PING_SUCCESS",
            f"PING to WB1 at the resolved port: {pong.type} {pong.content!r}",
            expected="PING_SUCCESS (OA-SESS-34, OA-SESS-10)",
        )
        spec = f'<retrieve from="WB1" type="{esc(ctx.type("There"))}"/>'
        got = await there.request(
            _request(ctx, "AIR.Retrieve", name, to="WB1", content=spec, content_is_xml=True)
        )
        ctx.check(
            got.type == "AIR.Retrieve.Success" and ctx.type("There") in got.content,
            f"AIR.Retrieve to WB1 at the resolved port: {got.type} {got.content[:200]!r}",
            expected="AIR.Retrieve.Success with the post (OA-SESS-34)",
        )
    finally:
        await there.close()


@case(
    id="SESS-041",
    title="A callback connection opened before BIND becomes the module's when it binds",
    section="6.5",
    requirements=("OA-SESS-36", "OA-SESS-7", "OA-SESS-5"),
    allowed=("the wakeup arrives on the callback connection opened before the BIND",),
)
async def callback_before_bind(ctx: CaseContext) -> None:
    """Open the callback connection first, then BIND_NOLISTEN, subscribe and be woken.

    Catches: a server that closes or forgets a callback connection whose name is not bound yet,
    so that a module binding without a port is never reached.
    """
    name = ctx.name("N")
    callback, receive_id = await _callback(ctx, name)
    primary = await ctx.raw("primary")
    port = await _bind(ctx, primary, name, None)
    ctx.check(port == "-1", f"BIND_NOLISTEN answered {port!r}", expected="-1 (OA-SESS-5)")
    await _subscribe(ctx, primary, name, ctx.type("Go"))
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Go"), "go")
    wakeup = await _woken(ctx, callback, receive_id, name)
    ctx.check(
        wakeup.type == "AIR.Instruct.Wakeup",
        f"the callback connection opened before BIND got {wakeup.type}",
        expected="the wakeup, over the callback connection opened before BIND (OA-SESS-36)",
    )


@case(
    id="DELIV-010",
    title="A module whose listening port cannot be reached is woken over its callback connection",
    section="6.6",
    requirements=("OA-DELIV-13", "OA-DELIV-1", "OA-SESS-4"),
    allowed=("the wakeup arrives on the callback connection (whether or not the port was tried)",),
)
async def unreachable_port_falls_back(ctx: CaseContext) -> None:
    """BIND asking for a port nobody listens on, open a callback connection, subscribe, post.

    Catches: a server that delivers only to the listening port once a module has one, so a
    module on another host (or behind a firewall) that got an unusable port is never woken.
    """
    name = ctx.name("M")
    primary = await ctx.raw("primary")
    await _bind(ctx, primary, name, _closed_port(""))
    callback, receive_id = await _callback(ctx, name)
    await _subscribe(ctx, primary, name, ctx.type("Go"))
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Go"), "go")
    wakeup = await _woken(ctx, callback, receive_id, name)
    ctx.check(
        wakeup.type == "AIR.Instruct.Wakeup",
        f"the callback connection got {wakeup.type}",
        expected="the wakeup over the callback connection (OA-DELIV-13)",
    )


@case(
    id="SESS-042",
    title="BIND again on the primary connection changes the port and keeps the session",
    section="6.3",
    requirements=("OA-SESS-35", "OA-SESS-5", "OA-WB-3"),
    allowed=(
        "BIND_ACCEPT -1; the callback connection stays open; the registration stays in force",
    ),
)
async def rebind_same_connection(ctx: CaseContext) -> None:
    """BIND with an unusable port, open a callback, subscribe, then BIND_NOLISTEN on the same
    connection and post: the wakeup must still come over the same callback connection.

    Catches: a server that treats binding again on the same connection as a takeover (closing
    the module's own connections or dropping its registration), so a module cannot recover from
    a port it cannot listen on.
    """
    name = ctx.name("M")
    primary = await ctx.raw("primary")
    await _bind(ctx, primary, name, _closed_port(""))
    callback, receive_id = await _callback(ctx, name)
    await _subscribe(ctx, primary, name, ctx.type("Go"))
    poster = await ctx.module("Poster", bind=False)
    # The Receive frame gets no reply: a first wakeup on the callback shows the server has
    # adopted it before the second BIND (otherwise a takeover could miss a callback not yet
    # registered and the case would pass by luck).
    await poster.post("WB1", ctx.type("Go"), "ready")
    first = await _woken(ctx, callback, receive_id, name)
    if first.type != "AIR.Instruct.Wakeup":
        raise Inconclusive(f"setup: the callback connection got {first.type} before the BIND")
    reply = await primary.request(_request(ctx, "BIND_NOLISTEN", name, to="CNS"))
    ctx.check(
        reply.type == "BIND_ACCEPT" and reply.content.strip() == "-1",
        f"BIND_NOLISTEN on the bound connection: {reply.type} {reply.content!r}",
        expected="BIND_ACCEPT -1 (OA-SESS-35, OA-SESS-5)",
    )
    await poster.post("WB1", ctx.type("Go"), "go")
    wakeup = await _woken(ctx, callback, receive_id, name)
    ctx.check(
        wakeup.type == "AIR.Instruct.Wakeup",
        f"the callback connection got {wakeup.type}",
        expected="the registration and the callback connection kept (OA-SESS-35)",
    )
    go = esc(ctx.type("Go"))
    found = await retrieved(
        ctx, poster, f'<retrieve from="WB1" type="{go}"><latest>0</latest></retrieve>'
    )
    ctx.check(len(found) == 2, f"found {len(found)}", expected="both posts stored (OA-WB-3)")


@case(
    id="DELIV-011",
    title="No delivery goes on a new callback connection while one is unanswered on the listener",
    section="6.6",
    requirements=("OA-DELIV-12", "OA-DELIV-1", "OA-DELIV-5"),
    needs=("pipelining",),
    allowed=(
        "the later wakeups over the callback connection, after the listener's were acknowledged",
        "the later wakeups over the listening port (the server need not switch)",
    ),
)
async def one_connection_at_a_time(ctx: CaseContext) -> None:
    """Hold the acknowledgements on the listener, open a callback connection, wake again.

    The module declares `pipelining`, so only OA-DELIV-12 stops a server from sending a wakeup
    over the fresh callback connection while the first one is unanswered on the listener. The
    Receive frame gets no reply, so the case cannot know when the server has read it: it posts
    three more messages, each after a round trip, so that the later ones are decided once the
    callback connection is known. Until the listener's acknowledgements are released nothing
    may arrive on the callback connection; afterwards each wakeup may come over either path.
    Catches: a server that switches paths with deliveries in flight, so that deliveries overtake
    each other and the order of section 10 is lost.
    """
    module = await ctx.module("M", callback=False, extensions=("pipelining",))
    poster = await ctx.module("Poster", bind=False)
    module.pause_acks()
    await poster.post("WB1", ctx.type("First"), "1", cc=module.name)
    await module.expect_wakeup(what="the first wakeup, on the listener")
    callback, receive_id = await _callback(ctx, module.name)
    early: list[Message] = []
    paused = [True]  # the listener's acknowledgements are held
    on_callback: dict[str, asyncio.Event] = {}

    async def read_callback() -> None:
        while True:
            msg = await next_request(ctx, callback, receive_id=receive_id, name=module.name)
            if paused[0]:
                early.append(msg)
            await ack(callback, msg, module.name)
            on_callback.setdefault(wakeup_trigger_id(msg) or "", asyncio.Event()).set()

    reader = asyncio.ensure_future(read_callback())
    try:
        ids = []
        for n in range(3):
            await poster.request(_request(ctx, "PING", poster.name, to="CNS"))
            await poster.post("WB1", ctx.type(f"Later{n}"), str(n), cc=module.name)
            ids.append(poster.last_sent.id if poster.last_sent is not None else "")
        await poster.request(_request(ctx, "PING", poster.name, to="CNS"))
        ctx.check(
            not early,
            f"{len(early)} wakeup(s) arrived on the callback connection while the first was "
            "unanswered on the listener",
            expected="one connection at a time for a module's deliveries (OA-DELIV-12)",
        )
        paused[0] = False
        module.resume_acks()
        for message_id in ids:
            await _either_path(ctx, module, on_callback.setdefault(message_id, asyncio.Event()))
    finally:
        reader.cancel()
    if not any(event.is_set() for event in on_callback.values()):
        ctx.vacuous("the server kept the listening port; no switch of paths to judge")


async def _either_path(ctx: CaseContext, module: TestModule, seen: asyncio.Event) -> None:
    """Wait until the wakeup arrives on the callback connection (`seen`) or on the listener."""
    listener = asyncio.ensure_future(module.expect_wakeup(what="a later wakeup"))
    callback = asyncio.ensure_future(seen.wait())
    try:
        await asyncio.wait({listener, callback}, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in (listener, callback):
            if not task.done():
                task.cancel()
    if not seen.is_set():
        listener.result()  # re-raises a Fail: it came on neither path
