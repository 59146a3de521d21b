"""Session cases of spec 6.3–6.5: BIND and BIND_NOLISTEN (forms, ports, names, takeover, the
BIND content), RESOLVE_REQUEST, and the callback connection.

Cases that need a module whose callback connection the suite reads itself use
`_common.raw_module`.
"""

from __future__ import annotations

import re
import socket

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._common import (
    COMPONENTS,
    ack,
    check_error,
    cns_request,
    next_request,
    raw_module,
    raw_subscribe,
    setup_subscribe,
    trigger_ids,
    triggers_xml,
    view_of,
)
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    attributes,
    content_object,
)
from openair_conformance.registry import case

_DECIMAL = re.compile(r"^-?[0-9]+$")


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _check_bind_refused(ctx: CaseContext, reply: Message, *, what: str, req: str) -> None:
    """Fail unless `reply` is BIND_ERROR whose content names BIND_REFUSED."""
    check_error(ctx, reply, types=("BIND_ERROR",), names=("BIND_REFUSED",), what=what, req=req)


# -- 6.3 BIND and BIND_NOLISTEN ----------------------------------------------------------------


@case(
    id="SESS-002",
    title="BIND without content is answered BIND_ACCEPT with a port as decimal text",
    section="6.3",
    requirements=("OA-SESS-3",),
    allowed=(
        "BIND_ACCEPT whose content is a port 1–65535 in decimal (the server chooses it); two "
        "modules bound from one address get two ports",
    ),
)
async def bind_accepted(ctx: CaseContext) -> None:
    """BIND two fresh names on two raw connections from this host, both without content;
    each reply must be a listening port, and the two ports must differ.

    Catches: a port counter that does not move on (or skips the ports in use), which gives a
    second module the port the first listens on (issue #15).
    """
    ports = []
    for suffix in ("B", "C"):
        raw = await ctx.raw()
        await raw.send_message(Message(type="BIND", sender=ctx.name(suffix), to="CNS"))
        reply = await raw.read_message()
        ctx.check(
            reply.type == "BIND_ACCEPT",
            f"BIND was answered {reply.type} {reply.content!r}",
            expected="BIND_ACCEPT (OA-SESS-3)",
        )
        text = reply.content.strip()
        ctx.check(
            bool(_DECIMAL.match(text)) and 0 < int(text) < 65536,
            f"BIND_ACCEPT content {reply.content!r} is not a port number",
            expected="a decimal port number 1–65535 (OA-SESS-3)",
        )
        ports.append(int(text))
    ctx.check(
        ports[0] != ports[1],
        f"both modules were told to listen on port {ports[0]}",
        expected="two ports: two modules at one address cannot share one (OA-SESS-3, OA-SESS-4)",
    )


@case(
    id="SESS-003",
    title="BIND_NOLISTEN is answered BIND_ACCEPT with the content -1",
    section="6.3",
    requirements=("OA-SESS-5",),
    allowed=("BIND_ACCEPT with text content -1 (surrounding white space tolerated)",),
)
async def bind_nolisten_accepted(ctx: CaseContext) -> None:
    """BIND_NOLISTEN a fresh name; the reply must be BIND_ACCEPT with content -1."""
    raw = await ctx.raw()
    await raw.send_message(Message(type="BIND_NOLISTEN", sender=ctx.name("N"), to="CNS"))
    reply = await raw.read_message()
    ctx.check(
        reply.type == "BIND_ACCEPT" and reply.content.strip() == "-1",
        f"BIND_NOLISTEN was answered {reply.type} {reply.content!r}",
        expected="BIND_ACCEPT with content -1 (OA-SESS-5)",
    )


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
    """Ask for a free port; ask for the same port under two other names (sorting after and
    before the first); ask for 0 and 70000.

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
        # Names that sort after and before the holder's: the refusal must not depend on it.
        for suffix in ("B", "0"):
            second = await (await ctx.raw()).request(bind(suffix, port))
            _check_bind_refused(
                ctx, second, what=f"module {suffix} asking for port {port} too", req="OA-SESS-4"
            )
    else:
        _check_bind_refused(ctx, first, what=f"BIND asking for port {port}", req="OA-SESS-4")
    for bad in (0, 70000):
        reply = await (await ctx.raw()).request(bind(f"P{bad}", bad))
        _check_bind_refused(ctx, reply, what=f"BIND asking for port {bad}", req="OA-SESS-4")


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
    go = triggers_xml(ctx.type("Go"))
    if (await raw_subscribe(old_primary, name, go)).type != "RECEIVE_ACCEPT":
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
        *COMPONENTS,
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


# -- 6.4 RESOLVE_REQUEST -----------------------------------------------------------------------


@case(
    id="SESS-004",
    title="RESOLVE_REQUEST of AIRCentral is answered RESOLVE_SUCCESS with its tcplocation",
    section="6.4",
    requirements=("OA-SESS-8", "OA-WB-1"),
    allowed=(
        "RESOLVE_SUCCESS whose content is <tcplocation address port name='AIRCentral'/>",
        "any port 1–65535 (the main port, OA-SESS-9, or a port of its own)",
        "extra attributes (procid, auth, …), which are ignored",
    ),
)
async def resolve_aircentral(ctx: CaseContext) -> None:
    """Resolve AIRCentral, which always exists; check the tcplocation it returns."""
    raw = await ctx.raw()
    await raw.send_message(
        Message(type="RESOLVE_REQUEST", sender=ctx.name("R"), to="CNS", content="AIRCentral")
    )
    reply = await raw.read_message()
    ctx.check(
        reply.type == "RESOLVE_SUCCESS",
        f"RESOLVE of AIRCentral: {reply.type}",
        expected="RESOLVE_SUCCESS (OA-SESS-8, OA-WB-1)",
    )
    try:
        location = attributes(content_object(reply, "tcplocation"))
    except WakeupUnreadable as exc:
        ctx.fail(f"RESOLVE_SUCCESS content: {exc}", expected="<tcplocation address port name/>")
    port = location.get("port", "")
    # OA-SESS-8: the <tcplocation address port name/> of the component
    ctx.check(
        location.get("name") == "AIRCentral",
        f"tcplocation name is {location.get('name')!r}",
        expected="name='AIRCentral'",
    )
    ctx.check(
        bool(location.get("address")), "tcplocation has no address", expected="a non-empty address"
    )
    ctx.check(
        port.isdigit() and 0 < int(port) < 65536,
        f"tcplocation port is {port!r}",
        expected="a port 1–65535",
    )


@case(
    id="SESS-005",
    title="RESOLVE_REQUEST of a name nobody uses is answered RESOLVE_FAILED",
    section="6.4",
    requirements=("OA-SESS-8",),
    allowed=("RESOLVE_FAILED (content is not checked)",),
)
async def resolve_unknown(ctx: CaseContext) -> None:
    """Resolve a name unique to this run, which no component or module has."""
    raw = await ctx.raw()
    name = ctx.name("Nobody")
    await raw.send_message(
        Message(type="RESOLVE_REQUEST", sender=ctx.name("R"), to="CNS", content=name)
    )
    reply = await raw.read_message()
    ctx.check(
        reply.type == "RESOLVE_FAILED",
        f"RESOLVE of {name} was answered {reply.type}",
        expected="RESOLVE_FAILED (OA-SESS-8)",
    )


@case(
    id="SESS-015",
    title="RESOLVE_REQUEST resolves whiteboards and system components, case-sensitively",
    section="6.4",
    requirements=("OA-SESS-8", "OA-WB-1", "OA-WB-10", "OA-CONF-4"),
    allowed=(
        "RESOLVE_SUCCESS with <tcplocation address port name/> for AIRCentral, WB1, WB2 and "
        "the system components",
        "RESOLVE_FAILED for wb1 and aircentral",
    ),
)
async def resolve_components(ctx: CaseContext) -> None:
    """Resolve AIRCentral, WB1, WB2, CNS, Config, Psyclone, AIRServer, ContextsAndPhases, then
    `wb1` and `aircentral`.

    Catches: a missing default whiteboard or component, a tcplocation that names another
    component, and case-insensitive name lookup.
    """
    raw = await ctx.raw()
    for name in ("AIRCentral", "WB1", "WB2", *COMPONENTS):
        reply = await raw.request(cns_request(ctx, "RESOLVE_REQUEST", content=name))
        ctx.check(
            reply.type == "RESOLVE_SUCCESS",
            f"RESOLVE of {name}: {reply.type}",
            expected="RESOLVE_SUCCESS (OA-SESS-8, OA-WB-1)",
        )
        try:
            location = attributes(content_object(reply, "tcplocation"))
        except WakeupUnreadable as exc:
            ctx.fail(f"RESOLVE of {name}: {exc}", expected="<tcplocation address port name/>")
        ctx.check(
            location.get("name") == name and location.get("port", "").isdigit(),
            f"RESOLVE of {name} gave {location}",
            expected=f"name='{name}' and a port (OA-SESS-8)",
        )
    for name in ("wb1", "aircentral"):
        reply = await raw.request(cns_request(ctx, "RESOLVE_REQUEST", content=name))
        ctx.check(
            reply.type == "RESOLVE_FAILED",
            f"RESOLVE of {name} was answered {reply.type}",
            expected="RESOLVE_FAILED: names are case-sensitive (OA-SESS-8, OA-WB-10)",
        )


# -- 6.5 The callback connection ---------------------------------------------------------------


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
    reply = await raw_subscribe(primary, name, triggers_xml(ctx.type("Go")))
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
    await raw_subscribe(primary, name, triggers_xml(ctx.type("Go")))
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Go"), "go", cc=name)
    wakeup = await next_request(ctx, second, receive_id=sent.id, name=name)
    await ack(second, wakeup, name)
    ctx.check(wakeup.type == "AIR.Instruct.Wakeup", f"got {wakeup.type}", expected="OA-SESS-7")


@case(
    id="SESS-044",
    title="After a takeover from another port, deliveries go to the new module's port",
    section="6.3",
    requirements=("OA-SESS-6", "OA-DELIV-1"),
    allowed=(
        "the wakeup for the message cc'd to N after the takeover arrives at the second N's "
        "port, not the first's",
    ),
)
async def takeover_new_port(ctx: CaseContext) -> None:
    """Bind N listening on a port (no callback connection) and take the wakeup of a message
    cc'd to it there; bind N again from another connection with a listener of its own; cc N
    another message.

    Catches: a server that goes on writing to the connection it opened to the first port,
    though the name now belongs to a session at another port (OA-SESS-6, OA-DELIV-1).
    """
    first = await ctx.module("N", callback=False)
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("One"), "one", cc=first.name)
    assert poster.last_sent is not None
    await first.expect_wakeup_for(poster.last_sent.id)
    second = await ctx.module("N", callback=False)  # the same name: a takeover
    await poster.post("WB1", ctx.type("Two"), "two", cc=second.name)
    assert poster.last_sent is not None
    await second.expect_wakeup_for(poster.last_sent.id)
