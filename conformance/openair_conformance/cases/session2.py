"""More session cases (spec 6.2–6.5 and 6.9): BIND forms and names, takeover, callback
connections, forwarding to bound modules, lifecycle notices and fixed connection roles.

The first session cases are in session.py; IDs continue from SESS-009. Cases that need a module
whose callback connection the suite reads itself use `_common.raw_module`.
"""

from __future__ import annotations

import asyncio
import socket

from openair.framing import FrameTag
from openair.message import Message
from openair_conformance.cases._common import (
    ack,
    check_error,
    next_request,
    raw_module,
    retrieved,
    setup_subscribe,
    trigger_ids,
    triggers_xml,
    view_of,
)
from openair_conformance.harness import CaseContext
from openair_conformance.model import Level
from openair_conformance.registry import case

_COMPONENTS = ("CNS", "Config", "Psyclone", "AIRServer", "ContextsAndPhases")


def _msg(
    ctx: CaseContext, type: str, to: str = "CNS", content: str = "", sfx: str = "S"
) -> Message:
    return Message(type=type, sender=ctx.name(sfx), to=to, content=content)


# -- 6.3 BIND ---------------------------------------------------------------------------------


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _check_bind_refused(ctx: CaseContext, reply: Message, *, what: str, req: str) -> None:
    """Fail unless `reply` is BIND_ERROR whose content names BIND_REFUSED."""
    check_error(ctx, reply, types=("BIND_ERROR",), names=("BIND_REFUSED",), what=what, req=req)


@case(
    id="SESS-009",
    title="BIND with <tcplocation port> is accepted with that port or refused BIND_ERROR",
    section="6.3",
    requirements=("OA-SESS-4", "OA-SESS-3", "OA-ERR-6"),
    allowed=(
        "a port the module asks for: BIND_ACCEPT naming exactly that port, or BIND_ERROR "
        "with content 'BIND_REFUSED: detail'",
        "port 0 or 70000, or a port another bound module uses at the same address: BIND_ERROR",
    ),
)
async def bind_port(ctx: CaseContext) -> None:
    """Ask for a free port; ask for the same port under another name; ask for 0 and 70000.

    Catches: a server that ignores the requested port and answers another one, that gives two
    modules the same port at one address, or that accepts ports outside 1–65535.
    """
    raw = await ctx.raw()
    port = _free_port()

    def bind(suffix: str, value: int) -> Message:
        location = f'<tcplocation port="{value}"/>'
        return Message(
            type="BIND",
            sender=ctx.name(suffix),
            to="CNS",
            content=location,
            content_is_xml=True,
            language="xml",
        )

    first = await raw.request(bind("A", port))
    if first.type == "BIND_ACCEPT":
        ctx.check(
            first.content.strip() == str(port),
            f"BIND asking for port {port} was accepted with {first.content!r}",
            expected=f"BIND_ACCEPT naming {port}, or BIND_ERROR (OA-SESS-4)",
        )
        second = await (await ctx.raw()).request(bind("B", port))
        _check_bind_refused(
            ctx, second, what=f"a second module asking for port {port}", req="OA-SESS-4"
        )
    else:
        _check_bind_refused(ctx, first, what=f"BIND asking for port {port}", req="OA-SESS-4")
    for bad in (0, 70000):
        reply = await (await ctx.raw()).request(bind(f"P{bad}", bad))
        _check_bind_refused(ctx, reply, what=f"BIND asking for port {bad}", req="OA-SESS-4")


@case(
    id="SESS-010",
    title="A module bound with BIND_NOLISTEN is woken over its callback connection",
    section="6.5",
    requirements=("OA-SESS-5", "OA-SESS-7", "OA-DELIV-1", "OA-FRAME-10", "OA-REG-7"),
    allowed=(
        "the wakeup arrives on the callback connection (a PING there first is allowed)",
        "no reply to the Receive frame",
    ),
)
async def nolisten_callback(ctx: CaseContext) -> None:
    """Bind with BIND_NOLISTEN, open the callback connection, register, and get a wakeup.

    Catches: a server that tries to connect to a port the module never had, that answers the
    Receive frame, or that never uses the callback connection.
    """
    primary, callback, receive_id = await raw_module(ctx, "N")
    name = ctx.name("N")
    subscribe = Message(
        type="AIR.Subscribe",
        sender=name,
        to="AIRCentral",
        content=triggers_xml(ctx.type("Go")),
        content_is_xml=True,
        language="xml",
    )
    reply = await primary.request(subscribe)
    ctx.check(reply.type == "RECEIVE_ACCEPT", f"AIR.Subscribe: {reply.type}", expected="OA-REG-7")
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Go"), "go")
    assert poster.last_sent is not None
    wakeup = await next_request(ctx, callback, receive_id=receive_id, name=name)
    await ack(callback, wakeup, name)
    ctx.check(
        trigger_ids([wakeup]) == [poster.last_sent.id],
        f"the callback connection carried {wakeup.type}, not the wakeup for the post",
        expected="the wakeup, over the callback connection (OA-SESS-5, OA-DELIV-1)",
    )


@case(
    id="SESS-011",
    title="A second BIND for a bound name takes it over: old connections closed, Restored posted",
    section="6.3",
    requirements=("OA-SESS-6", "OA-SEC-3"),
    allowed=(
        "BIND_ACCEPT to the second BIND; the server closes the first primary and callback "
        "connections; Psyclone.Module.Restored.<name> (no Lost) on AIRCentral; the "
        "registration stays in force for the new session",
    ),
)
async def takeover(ctx: CaseContext) -> None:
    """Bind N and register it; bind N again from another connection; watch AIRCentral.

    Catches: a duplicate BIND that opens a second session (Psyclone, DEV-23), a takeover that
    posts Lost or no Restored, and one that drops the registration.
    """
    name = ctx.name("N")
    watcher = await ctx.module("Watch")
    notices = (f"Psyclone.Module.Restored.{name}", f"Psyclone.Module.Lost.{name}")
    await setup_subscribe(watcher, triggers_xml(*notices, wb="AIRCentral"))
    old_primary, old_callback, old_receive = await raw_module(ctx, "N")
    subscribe = Message(
        type="AIR.Subscribe",
        sender=name,
        to="AIRCentral",
        content=triggers_xml(ctx.type("Go")),
        content_is_xml=True,
        language="xml",
    )
    if (await old_primary.request(subscribe)).type != "RECEIVE_ACCEPT":
        ctx.note("the first session's registration was refused")
    # Acknowledge everything sent to the first session (a phase update may be on its way), so
    # that no delivery is in flight when the name is taken over.
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Drain"), "drain", cc=name)
    drained = await next_request(ctx, old_callback, receive_id=old_receive, name=name)
    await ack(old_callback, drained, name)
    new_primary, new_callback, receive_id = await raw_module(ctx, "N")
    del new_primary
    await old_primary.expect_closed()
    await old_callback.expect_closed()
    restored = await watcher.expect_wakeup(what="Psyclone.Module.Restored notice")
    view = view_of(ctx, restored)
    ctx.check(
        view.trigger is not None and view.trigger.type == notices[0],
        f"the first notice is {view.trigger.type if view.trigger else None!r}",
        expected=f"{notices[0]} (OA-SESS-6)",
    )
    lost = await watcher.barrier()
    ctx.check(not lost, f"{len(lost)} further notice(s), e.g. Lost", expected="no Lost (OA-SESS-6)")
    await poster.post("WB1", ctx.type("Go"), "still registered?")
    wakeup = await next_request(ctx, new_callback, receive_id=receive_id, name=name)
    await ack(new_callback, wakeup, name)
    assert poster.last_sent is not None
    ctx.check(
        trigger_ids([wakeup]) == [poster.last_sent.id],
        f"the new session got {wakeup.type} instead of the wakeup",
        expected="the registration survives the takeover (OA-SESS-6)",
    )


@case(
    id="SESS-012",
    title="BIND and BIND_NOLISTEN with an invalid or reserved name are answered BIND_ERROR",
    section="6.3",
    requirements=("OA-SESS-30", "OA-ERR-6"),
    allowed=("BIND_ERROR with content 'BIND_REFUSED: detail' for each name",),
)
async def bind_bad_names(ctx: CaseContext) -> None:
    """Bind an empty name, names with a space, a tab or `;`, a 256-byte name, and the names of
    a whiteboard and of system components.

    Catches: a server that lets a module take the name WB1 or CNS (its messages would then be
    misrouted) or accepts names that cc cannot carry (Psyclone, DEV-19).
    """
    long_name = ctx.name("L") + "x" * (256 - len(ctx.name("L")))
    names = [
        "",
        "has space",
        "semi;colon",
        "tab\tbed",
        long_name,
        "WB1",
        "AIRCentral",
        *_COMPONENTS,
    ]
    raw = await ctx.raw()
    for index, name in enumerate(names):
        kind = "BIND" if index % 2 == 0 else "BIND_NOLISTEN"
        reply = await raw.request(Message(type=kind, sender=name, to="CNS"))
        _check_bind_refused(ctx, reply, what=f"{kind} for the name {name[:40]!r}", req="OA-SESS-30")


@case(
    id="SESS-013",
    title="A BIND whose content is not a <tcplocation> is refused CONTENT_INVALID",
    section="3.3",
    requirements=("OA-MSG-12", "OA-ERR-6"),
    allowed=(
        "BIND_ERROR (or RECEIVE_ERROR) whose content is 'CONTENT_INVALID: detail' (OA-MSG-12)",
        "BIND_ERROR 'BIND_REFUSED: detail' (the command table of 6.2 names only BIND_REFUSED)",
    ),
)
async def bind_content_invalid(ctx: CaseContext) -> None:
    """Send BIND with the XML content `<dictionary/>`, which is not the object BIND takes.

    Catches: a server that ignores the content of a control message it cannot read.
    """
    raw = await ctx.raw()
    bind = Message(
        type="BIND",
        sender=ctx.name("B"),
        to="CNS",
        content="<dictionary/>",
        content_is_xml=True,
        language="xml",
    )
    reply = await raw.request(bind)
    check_error(
        ctx,
        reply,
        types=("BIND_ERROR", "RECEIVE_ERROR"),
        names=("CONTENT_INVALID", "BIND_REFUSED"),
        what="BIND with <dictionary/> content",
        req="OA-MSG-12",
    )


@case(
    id="SESS-014",
    title="A module that declares an unknown extension name is bound as usual",
    section="15.2",
    requirements=("OA-EXT-1", "OA-SESS-19"),
    allowed=("BIND_ACCEPT; the unknown name is ignored",),
)
async def unknown_extension_declared(ctx: CaseContext) -> None:
    """BIND with `<extensions>x-conformance-unknown</extensions>`.

    Catches: a server that refuses a BIND because of an extension name it does not know.
    """
    raw = await ctx.raw()
    bind = Message(type="BIND_NOLISTEN", sender=ctx.name("X"), to="CNS")
    reply = await raw.request(bind.with_extra("extensions", "x-conformance-unknown"))
    ctx.check(
        reply.type == "BIND_ACCEPT" and reply.content.strip() == "-1",
        f"BIND_NOLISTEN declaring an unknown extension was answered {reply.type} {reply.content!r}",
        expected="BIND_ACCEPT with -1: unknown names are ignored (OA-EXT-1)",
    )


# -- 6.2 forwarding ---------------------------------------------------------------------------


@case(
    id="SESS-024",
    title="A request to a name nobody has is answered FORWARD_FAILED naming it",
    section="6.2",
    requirements=("OA-SESS-21", "OA-WB-10", "OA-ERR-6"),
    allowed=("FORWARD_FAILED with content 'Could not forward message to: <to>'",),
)
async def forward_failed(ctx: CaseContext) -> None:
    """Post to a name unique to this run, and to `wb1` (whiteboard names are case-sensitive).

    Catches: a post to an unknown name acknowledged (and lost), case-insensitive routing.
    """
    raw = await ctx.raw()
    for to in (ctx.name("Nobody"), "wb1"):
        reply = await raw.request(_msg(ctx, ctx.type("Lost"), to=to, content="x"))
        ctx.check(
            reply.type == "FORWARD_FAILED"
            and reply.content.strip() == f"Could not forward message to: {to}",
            f"a message to {to!r} was answered {reply.type} {reply.content!r}",
            expected=f"FORWARD_FAILED 'Could not forward message to: {to}' (OA-SESS-21)",
        )


@case(
    id="SESS-025",
    title="A message to a bound module is acknowledged and delivered to it unchanged",
    section="6.2",
    requirements=("OA-SESS-22", "OA-MSG-5", "OA-TIME-4"),
    allowed=(
        "RECEIVE_ACCEPT to the sender; the module receives the message with the same type, id, "
        "from, to, postedTime, content and unknown slots (over either path)",
    ),
)
async def direct_delivery(ctx: CaseContext) -> None:
    """Send a message with an unknown slot to a bound module's name; take its delivery.

    Catches: a server that drops direct messages, rewrites them (new id, restamped postedTime,
    unknown slots lost) or passes the module's own acknowledgement back to the sender.
    """
    target = await ctx.module("T")
    sender = await ctx.module("S", bind=False)
    msg = Message(
        type=ctx.type("Direct"), sender=sender.name, to=target.name, content="for you only"
    ).with_extra("confslot", "kept & passed")
    reply = await sender.request(msg)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"the message was answered {reply.type}",
        expected="RECEIVE_ACCEPT (OA-SESS-22)",
    )
    sent = sender.last_sent
    assert sent is not None
    got = await target.next_delivery()
    extra = got.extra("confslot")
    fields = (got.type, got.id, got.sender, got.to, got.content, extra.value if extra else None)
    want = (sent.type, sent.id, sent.sender, sent.to, sent.content, "kept & passed")
    ctx.check(
        fields == want, f"the delivery is {fields}", expected=f"{want} (OA-SESS-22, OA-MSG-5)"
    )
    ctx.check(
        got.posted is not None and sent.posted is not None and got.posted.ms == sent.posted.ms,
        f"postedTime {got.posted} differs from the sent {sent.posted}",
        expected="postedTime unchanged (OA-TIME-4)",
    )


# -- 6.9 lifecycle ----------------------------------------------------------------------------


@case(
    id="SESS-026",
    title="Closing a module's primary connection posts Lost and removes its registration",
    section="6.9",
    requirements=("OA-SESS-15", "OA-TIME-2"),
    allowed=(
        "Psyclone.Module.Lost.<name> from Psyclone, stored on AIRCentral",
        "a later session under the same name is not woken by the old registration",
    ),
)
async def lost_notice(ctx: CaseContext) -> None:
    """Register M, close it, wait for the Lost notice, bind M again and post the old trigger.

    Catches: no Lost notice, a notice from the wrong component, and a registration that
    outlives its session (a new module under the name would get the old module's wakeups).
    """
    watcher = await ctx.module("Watch")
    module = await ctx.module("M")
    notice = f"Psyclone.Module.Lost.{module.name}"
    await setup_subscribe(watcher, triggers_xml(notice, wb="AIRCentral"))
    await setup_subscribe(module, triggers_xml(ctx.type("Old")))
    await module.close()
    wakeup = await watcher.expect_wakeup(what="Lost notice")
    trigger = view_of(ctx, wakeup).trigger
    ctx.check(
        trigger is not None
        and (trigger.type, trigger.sender, trigger.stored) == (notice, "Psyclone", "AIRCentral"),
        f"the notice is {(trigger.type, trigger.sender, trigger.stored) if trigger else None}",
        expected=f"({notice!r}, 'Psyclone', 'AIRCentral') (OA-SESS-15)",
    )
    ctx.check(
        trigger is not None and trigger.posted is not None,
        "the Lost notice has no postedTime",
        expected="the server, as poster, stamps postedTime (OA-TIME-2)",
    )
    again = await ctx.module("M")
    poster = await ctx.module("Poster", bind=False)
    # Post before the new session registers anything: a stale registration would decide this
    # wakeup (OA-WB-7); registering first would replace it and hide the fault.
    await poster.post("WB1", ctx.type("Old"), "for the old registration")
    await setup_subscribe(again, triggers_xml(ctx.type("Other")))  # the barrier's cc (DEV-12)
    woken = await again.barrier()
    ctx.check(
        not woken,
        f"the new session got {len(woken)} wakeup(s) of the old registration",
        expected="OA-SESS-15",
    )


@case(
    id="SESS-027",
    title="At start-up the server posted Psyclone.Context:Psyclone.System.Ready to AIRCentral",
    section="6.9",
    requirements=("OA-SESS-31",),
    level=Level.SHOULD,
    allowed=("a stored Psyclone.Context:Psyclone.System.Ready from Psyclone on AIRCentral",),
)
async def ready_notice(ctx: CaseContext) -> None:
    """Retrieve the newest Psyclone.Context:Psyclone.System.Ready from AIRCentral.

    Catches: a server that never announces readiness (modules that wait for it never start).
    """
    client = await ctx.module("R", bind=False)
    spec = '<retrieve from="AIRCentral" type="Psyclone.Context:Psyclone.System.Ready"/>'
    found = await retrieved(ctx, client, spec)
    ctx.check(
        len(found) == 1 and found[0].sender == "Psyclone",
        f"found {[(m.type, m.sender) for m in found]}",
        expected="one message from Psyclone (OA-SESS-31)",
    )


# -- 6.5 callback connections and roles --------------------------------------------------------


@case(
    id="SESS-030",
    title="A newer callback connection replaces the older one, which the server closes",
    section="6.5",
    requirements=("OA-SESS-7", "OA-SESS-28"),
    allowed=("the first callback connection is closed; deliveries come over the second",),
)
async def callback_replaced(ctx: CaseContext) -> None:
    """Bind with BIND_NOLISTEN, open two callback connections, cc the module.

    Catches: a server that keeps delivering over a stale callback connection.
    """
    primary, first, _ = await raw_module(ctx, "N")
    name = ctx.name("N")
    second = await ctx.raw("N/callback2")
    sent = await second.send_message(
        Message(type="RECEIVE_NAME_NOTIFICATION", sender=name), FrameTag.RECEIVE
    )
    await first.expect_closed()
    subscribe = Message(
        type="AIR.Subscribe",
        sender=name,
        to="AIRCentral",
        content=triggers_xml(ctx.type("Go")),
        content_is_xml=True,
        language="xml",
    )
    await primary.request(subscribe)
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Go"), "go", cc=name)
    wakeup = await next_request(ctx, second, receive_id=sent.id, name=name)
    await ack(second, wakeup, name)
    ctx.check(wakeup.type == "AIR.Instruct.Wakeup", f"got {wakeup.type}", expected="OA-SESS-7")


@case(
    id="SESS-031",
    title="The server sends requests only on callback and listener connections",
    section="6.1",
    requirements=("OA-SESS-28",),
    allowed=("only replies on the primary connection; only requests towards the module",),
)
async def roles_fixed(ctx: CaseContext) -> None:
    """Register a module, wake it twice (trigger and cc), and inspect the trace.

    Catches: a server that sends a wakeup or a PING on the module's primary connection.
    """
    module = await ctx.module("M")
    await setup_subscribe(module, triggers_xml(ctx.type("Go")))
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Go"), "go")
    await poster.post("WB1", ctx.type("Cc"), "cc", cc=module.name)
    await asyncio.gather(module.next_wakeup(), module.next_wakeup())
    bad = [e.text for e in ctx.trace.entries if "(OA-SESS-28)" in e.text]
    ctx.check(not bad, f"the trace notes: {bad[:3]}", expected="OA-SESS-28")
