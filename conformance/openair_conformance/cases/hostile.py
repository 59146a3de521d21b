"""Hostile-input cases (spec 13 and 14): malformed and forbidden XML, nesting depth, garbage,
oversized frames and many broken connections. After each, a separate module must still be
served (`_still_served`: a registration, a post and its wakeup), since an error on one
connection must not affect another (OA-ERR-4).
"""

from __future__ import annotations

import asyncio
import struct

from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._common import (
    ERROR_NAMES,
    LOCAL_ERROR_NAMES,
    check_error,
    error_name,
    frames_until_closed,
    message_xml,
    ping_ok,
    send_xml,
    setup_subscribe,
    triggers_xml,
)
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case


async def _still_served(ctx: CaseContext, tag: str = "Alive") -> None:
    """Register a fresh module, post to it, and wait for the wakeup (OA-ERR-4)."""
    module = await ctx.module(f"{tag}Sub")
    await setup_subscribe(module, triggers_xml(ctx.type(tag)))
    poster = await ctx.module(f"{tag}Poster", bind=False)
    await poster.post("WB1", ctx.type(tag), "still served?")
    assert poster.last_sent is not None
    await module.expect_wakeup_for(poster.last_sent.id)


def _frame(xml: bytes) -> bytes:
    return b"Message\x00" + struct.pack("<I", len(xml)) + xml


@case(
    id="HOST-002",
    title="A DOCTYPE is refused XML_FORBIDDEN; the connection and the server go on",
    section="14.2",
    requirements=("OA-SEC-1", "OA-ERR-3", "OA-ERR-4"),
    allowed=("RECEIVE_ERROR 'XML_FORBIDDEN: …', then PING answered; other modules served",),
)
async def doctype(ctx: CaseContext) -> None:
    """Send a PING preceded by `<!DOCTYPE message>`; then PING; then check another module.

    Catches: a parser that loads DTDs, or that accepts a DOCTYPE it ignores.
    """
    raw = await ctx.raw()
    xml = b"<!DOCTYPE message>" + message_xml("PING", to="CNS", sender=ctx.name("H"))
    check_error(
        ctx, await send_xml(raw, xml), names=("XML_FORBIDDEN",), what="a DOCTYPE", req="OA-SEC-1"
    )
    await ping_ok(ctx, raw, what="after the DOCTYPE", req="OA-ERR-3")
    await _still_served(ctx)


_LAUGHS = (
    '<!DOCTYPE message [<!ENTITY a "haha">'
    + "".join(f'<!ENTITY {chr(98 + i)} "{("&" + chr(97 + i) + ";") * 10}">' for i in range(9))
    + "]>"
)


@case(
    id="HOST-003",
    title="Entity expansion attacks are refused without expanding anything",
    section="14.2",
    requirements=("OA-SEC-2", "OA-SEC-1", "OA-ERR-4"),
    allowed=(
        "RECEIVE_ERROR 'XML_FORBIDDEN: …' for the billion laughs and the external entity",
        "RECEIVE_ERROR 'XML_MALFORMED: …' or 'XML_FORBIDDEN: …' for an undeclared entity (it is "
        "not well-formed, and a reference to an entity the document does not define)",
    ),
)
async def entities(ctx: CaseContext) -> None:
    """Send the billion-laughs document, an external file entity, and `&undeclared;`.

    Catches: entity expansion (memory blow-up), file access through SYSTEM entities.
    """
    raw = await ctx.raw()
    body = message_xml(ctx.type("Laugh"), to="WB1", sender=ctx.name("H"), content="@")
    laughs = (_LAUGHS.encode() + body).replace(b">@<", b">&j;<")
    external = b'<!DOCTYPE message [<!ENTITY x SYSTEM "file:///etc/passwd">]>' + body.replace(
        b">@<", b">&x;<"
    )
    for xml, what in ((laughs, "the billion laughs"), (external, "an external entity")):
        check_error(
            ctx, await send_xml(raw, xml), names=("XML_FORBIDDEN",), what=what, req="OA-SEC-2"
        )
    undeclared = body.replace(b">@<", b">&undeclared;<")
    check_error(
        ctx,
        await send_xml(raw, undeclared),
        names=("XML_MALFORMED", "XML_FORBIDDEN"),
        what="&undeclared;",
        req="OA-SEC-2",
    )
    await _still_served(ctx)


@case(
    id="HOST-004",
    title="Nesting at max-xml-depth is accepted; one level deeper is XML_TOO_DEEP",
    section="14.1",
    requirements=("OA-LIM-3", "OA-ERR-3"),
    allowed=("RECEIVE_ACCEPT at the limit; RECEIVE_ERROR 'XML_TOO_DEEP: …' beyond it",),
)
async def depth(ctx: CaseContext) -> None:
    """Post messages whose unknown slot nests elements to exactly the advertised depth
    (counting `<message>` as 1) and to one more.

    Catches: no depth limit (stack exhaustion), or an off-by-one limit.
    """
    limit = ctx.server.limit("max-xml-depth", 64)
    raw = await ctx.raw()
    for levels, ok in ((limit - 1, True), (limit, False)):
        nest = "<d>" * levels + "</d>" * levels
        xml = message_xml(ctx.type("Deep"), to="WB1", sender=ctx.name("H")).replace(
            b"</message>", nest.encode() + b"</message>"
        )
        reply = await send_xml(raw, xml)
        if ok:
            ctx.check(
                reply.type == "RECEIVE_ACCEPT",
                f"depth {levels + 1}: {reply.type} {reply.content!r}",
                expected="OA-LIM-3",
            )
        else:
            check_error(
                ctx, reply, names=("XML_TOO_DEEP",), what=f"depth {levels + 1}", req="OA-LIM-3"
            )
    await ping_ok(ctx, raw, what="after the deep message", req="OA-ERR-3")


@case(
    id="HOST-005",
    title="Garbage bytes close only their own connection",
    section="13.2",
    requirements=("OA-ERR-4", "OA-FRAME-6"),
    allowed=("the garbage connection is closed without a reply; everything else goes on",),
)
async def garbage(ctx: CaseContext) -> None:
    """Send 4 KiB of bytes that are no frame on one connection (and, when the server does not
    advertise `monitor`, an HTTP request on another); then check another module.

    Catches: a reader that crashes the server or stalls other connections on garbage.
    """
    payloads = [bytes((i * 37 + 11) % 256 for i in range(4096))]
    if not ctx.server.has("monitor"):
        payloads.append(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
    for data in payloads:
        raw = await ctx.raw("garbage")
        await raw.send(data)
        frames = await frames_until_closed(ctx, raw, what="close after garbage")
        ctx.check(not frames, f"{len(frames)} replies to garbage", expected="no reply (OA-FRAME-6)")
    await _still_served(ctx)


@case(
    id="HOST-006",
    title="An oversized frame closes only its connection; a bound module is still woken",
    section="13.2",
    requirements=("OA-ERR-4", "OA-FRAME-7"),
    allowed=("the bound module's wakeup arrives after the other connection was closed",),
)
async def oversize_isolated(ctx: CaseContext) -> None:
    """Bind and register a module; on another connection announce a frame of 4 GiB − 1;
    after the close, post to the module.

    Catches: a server-wide failure (or a shared buffer) caused by one oversized frame.
    """
    module = await ctx.module("M")
    await setup_subscribe(module, triggers_xml(ctx.type("After")))
    raw = await ctx.raw()
    await raw.send(b"Message\x00" + struct.pack("<I", 0xFFFFFFFF) + b"<message>")
    await frames_until_closed(ctx, raw, what="close after the oversized frame")
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("After"), "after")
    assert poster.last_sent is not None
    await module.expect_wakeup_for(poster.last_sent.id)


@case(
    id="HOST-007",
    title="Many connections broken mid-frame do not disturb the server",
    section="13.2",
    requirements=("OA-ERR-4", "OA-FRAME-8"),
    allowed=("PING and a post with its wakeup still work afterwards",),
)
async def many_broken(ctx: CaseContext) -> None:
    """Open 40 connections; send half a frame (or half a header) on each; close them all.

    Catches: resources leaked per half-open connection, a partial frame acted upon.
    """
    raws = await asyncio.gather(*(ctx.raw(f"broken{i}") for i in range(40)))
    data = _frame(message_xml(ctx.type("Half"), to="WB1", sender=ctx.name("H")))
    for index, raw in enumerate(raws):
        await raw.send(data[: 6 if index % 2 else len(data) // 2])
    for raw in raws:
        await raw.close()
    await ping_ok(ctx, await ctx.raw("after"), what="after 40 broken connections", req="OA-ERR-4")
    await _still_served(ctx)


@case(
    id="HOST-008",
    title="Malformed XML on a module's primary connection leaves the module bound and woken",
    section="13.2",
    requirements=("OA-ERR-3", "OA-ERR-4"),
    allowed=(
        "RECEIVE_ERROR XML_MALFORMED to the bad frame; the module's registration still works",
    ),
)
async def malformed_on_primary(ctx: CaseContext) -> None:
    """Bind a module on a raw connection, register, send a malformed frame on that connection,
    then post to the module.

    Catches: a server that drops a module's session (or registration) on an XML error.
    """
    module = await ctx.module("M")
    await setup_subscribe(module, triggers_xml(ctx.type("Go")))
    raw = await ctx.raw()
    name = ctx.name("R")
    reply = await raw.request(Message(type="BIND_NOLISTEN", sender=name, to="CNS"))
    ctx.check(reply.type == "BIND_ACCEPT", f"BIND_NOLISTEN: {reply.type}", expected="BIND_ACCEPT")
    reply = await send_xml(raw, f"<message><type>{ctx.type('Oops')}</type".encode())
    check_error(ctx, reply, names=("XML_MALFORMED",), what="malformed XML", req="OA-ERR-3")
    resolve = await raw.request(Message(type="STATUS", sender=name, to="CNS"))
    ctx.check(
        resolve.type == "STATUS_SUCCESS", f"STATUS afterwards: {resolve.type}", expected="OA-ERR-3"
    )
    await _still_served(ctx)


@case(
    id="HOST-009",
    title="Error replies name conditions of the error table, never local ones",
    section="13.2",
    requirements=("OA-ERR-1", "OA-ERR-7", "OA-ERR-2"),
    allowed=(
        "RECEIVE_ERROR (or the command's failure reply) whose content is 'NAME: detail', NAME "
        "a condition of the table",
    ),
)
async def table_names(ctx: CaseContext) -> None:
    """Provoke six different failures and read the condition names.

    Catches: ad-hoc error texts that clients cannot classify, and local-only conditions
    (REQUEST_TIMEOUT, …) sent on the wire.
    """
    raw = await ctx.raw()
    me = ctx.name("H")
    requests = [
        f"<message><type>{ctx.type('X')}</type".encode(),
        message_xml(ctx.type("A..B"), to="WB1", sender=me),
        message_xml(ctx.type("P"), to="WB1", sender=me, attrs='priority="9"'),
        message_xml("AIR.Subscribe", to="AIRCentral", sender=me, content="not a registration"),
        message_xml("AIR.Retrieve", to="AIRCentral", sender=me, content="not a retrieve"),
        b"<!DOCTYPE message>" + message_xml("PING", to="CNS", sender=me),
    ]
    names = []
    for xml in requests:
        reply = await send_xml(raw, xml)
        names.append(error_name(reply.content))
    unknown = [n for n in names if n not in ERROR_NAMES or n in LOCAL_ERROR_NAMES]
    ctx.check(
        not unknown,
        f"condition names {names}",
        expected="names of the error table, blame not local (OA-ERR-1, OA-ERR-7)",
    )


# -- 13.2 Error replies: malformed XML ---------------------------------------------------------


@case(
    id="HOST-001",
    title="Malformed XML in a correct frame gets RECEIVE_ERROR and the connection stays usable",
    section="13.2",
    requirements=("OA-ERR-3", "OA-MSG-1", "OA-ERR-2"),
    allowed=(
        "RECEIVE_ERROR whose content starts with XML_MALFORMED, isresponse empty or the id",
        "then PING on the same connection is answered PING_SUCCESS",
    ),
)
async def malformed_xml(ctx: CaseContext) -> None:
    """Frame an unterminated `<message>`, expect RECEIVE_ERROR, then PING the same connection."""
    raw = await ctx.raw()
    bad = f"<message><type>{ctx.type('Bad')}</type><to>WB1</to".encode()
    await raw.send_frame(Frame(tag=FrameTag.MESSAGE, xml=bad))
    reply = await raw.read_message()
    ctx.check(
        reply.type == "RECEIVE_ERROR",
        f"malformed XML was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ERROR (OA-ERR-3, OA-MSG-1)",
    )
    ctx.check(
        reply.content.strip().startswith("XML_MALFORMED"),
        f"RECEIVE_ERROR content is {reply.content!r}",
        expected="'XML_MALFORMED: detail' (OA-ERR-2)",
    )
    sent = await raw.send_message(Message(type="PING", sender=ctx.name("H"), to="CNS"))
    after = await raw.read_message()
    ctx.check(
        after.type == "PING_SUCCESS" and after.isresponse == sent.id,
        f"PING after the error was answered {after.type} (isresponse {after.isresponse!r})",
        expected="PING_SUCCESS: the connection stays usable (OA-ERR-3)",
    )
