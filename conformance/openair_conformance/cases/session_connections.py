"""Session cases of spec 6.1 and 6.2: connections, requests and replies (order, isresponse,
the reply envelope, fixed connection roles); addressing and components (unknown commands, an
empty `to`, forwarding to bound modules).

The session cases are split by spec section: 6.1–6.2 here, 6.3–6.5 (BIND, RESOLVE, the callback
connection) in session_bind.py, 6.7–6.9 (PING, KEEPALIVE, STATUS, configuration queries,
lifecycle notices) in session_status.py; capabilities and extensions (15) in capabilities.py.
"""

from __future__ import annotations

import asyncio

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    COMPONENTS,
    cns_request,
    esc,
    setup_subscribe,
    triggers_xml,
)
from openair_conformance.harness import CaseContext
from openair_conformance.model import Level
from openair_conformance.registry import case

# -- 6.1 Connections, requests and replies -----------------------------------------------------


@case(
    id="SESS-007",
    title="Pipelined requests on one connection are answered in request order",
    section="6.1",
    requirements=("OA-SESS-2", "OA-SESS-17"),
    needs=("pipelining",),
    allowed=("one reply per request, in the order of the requests, each with its isresponse",),
)
async def replies_in_order(ctx: CaseContext) -> None:
    """Write five mixed requests (posts, PING, RESOLVE) in one TCP write; check reply order."""
    raw = await ctx.raw()
    me = ctx.name("O")
    requests = [
        Message(type=ctx.type("Order.1"), sender=me, to="WB1", content="one"),
        Message(type="PING", sender=me, to="CNS"),
        Message(type="RESOLVE_REQUEST", sender=me, to="CNS", content="WB1"),
        Message(type="PING", sender=me, to="WB1"),
        Message(type=ctx.type("Order.2"), sender=me, to="WB1", content="two"),
    ]
    sent = await raw.send_messages(requests)
    for position, request in enumerate(sent, start=1):
        reply = await raw.read_message()
        ctx.check(
            reply.isresponse == request.id,
            f"reply #{position} ({reply.type}) answers {reply.isresponse!r}, "
            f"not request #{position} ({request.type}, id {request.id!r})",
            expected="replies in request order (OA-SESS-2)",
        )


@case(
    id="SESS-028",
    title="Every kind of request gets exactly one reply whose isresponse is its id",
    section="6.1",
    requirements=("OA-SESS-1", "OA-SESS-18", "OA-MSG-11"),
    allowed=("one reply per request, in order, each with isresponse = the request's id",),
)
async def isresponse_everywhere(ctx: CaseContext) -> None:
    """Send, one at a time on one connection, a post, a refused post, AIR.Subscribe, a retrieve,
    RESOLVE, STATUS, GET_ENTRY, GET_ID, an unknown command and a message to nowhere.

    Catches: replies without isresponse (they cannot be paired), and a server that answers a
    lone request only once more data arrives.
    """
    raw = await ctx.raw()
    me = ctx.name("Q")
    requests = [
        Message(type=ctx.type("Post"), sender=me, to="WB1", content="x"),
        Message(type=ctx.type("Bad..Type"), sender=me, to="WB1"),
        Message(
            type="AIR.Subscribe",
            sender=me,
            to="AIRCentral",
            content="<triggers/>",
            content_is_xml=True,
            language="xml",
        ),
        Message(
            type="AIR.Retrieve",
            sender=me,
            to="AIRCentral",
            content=f'<retrieve from="WB1" type="{esc(ctx.type("*"))}"/>',
            content_is_xml=True,
            language="xml",
        ),
        Message(type="RESOLVE_REQUEST", sender=me, to="CNS", content="WB1"),
        Message(type="STATUS", sender=me, to="CNS"),
        Message(type="GET_ENTRY", sender=me, to="Config", content="Global"),
        Message(type="GET_ID", sender=me, to="AIRServer"),
        Message(type=f"CONF_NOPE_{ctx.run_id}".upper(), sender=me, to="CNS"),
        Message(type=ctx.type("Lost"), sender=me, to=ctx.name("Nobody")),
    ]
    for request in requests:
        sent = await raw.send_message(request)
        reply = await raw.read_message()
        ctx.check(
            reply.isresponse == sent.id,
            f"{sent.type} was answered {reply.type} with isresponse {reply.isresponse!r}",
            expected="isresponse = the request's id (OA-SESS-1)",
        )


@case(
    id="SESS-029",
    title="Replies carry a fresh id, the answering component in from and the requester in to",
    section="6.1",
    requirements=("OA-SESS-32", "OA-MSG-8"),
    level=Level.SHOULD,
    allowed=(
        "distinct non-empty ids; from = the component addressed (CNS, WB1, AIRCentral, "
        "Config, Psyclone, AIRServer, WB2); to = the requester; a postedTime",
    ),
)
async def reply_envelope(ctx: CaseContext) -> None:
    """PING CNS, post to WB1, retrieve via AIRCentral, PING the other components (issue #15:
    not only CNS); check each reply's envelope.

    Catches: replies that reuse the request's id, come from a generic name (every PING answered
    from CNS), or lack a time.
    """
    raw = await ctx.raw()
    me = ctx.name("E")
    requests = [
        (Message(type="PING", sender=me, to="CNS"), "CNS"),
        (Message(type=ctx.type("Post"), sender=me, to="WB1", content="x"), "WB1"),
        (
            Message(
                type="AIR.Retrieve",
                sender=me,
                to="AIRCentral",
                content=f'<retrieve from="WB1" type="{esc(ctx.type("*"))}"/>',
                content_is_xml=True,
                language="xml",
            ),
            "AIRCentral",
        ),
        *((Message(type="PING", sender=me, to=c), c) for c in ("Config", "Psyclone", "AIRServer")),
        (Message(type="PING", sender=me, to="WB2"), "WB2"),
    ]
    ids = set()
    for request, component in requests:
        sent = await raw.send_message(request)
        reply = await raw.read_message()
        ctx.check(
            bool(reply.id) and reply.id != sent.id and reply.id not in ids,
            f"{reply.type} has id {reply.id!r}",
            expected="a fresh id (OA-SESS-32, OA-MSG-8)",
        )
        ids.add(reply.id)
        got = (reply.sender, reply.to, reply.posted is not None)
        ctx.check(
            got == (component, me, True),
            f"{reply.type} from/to/postedTime: {got}",
            expected=f"({component!r}, {me!r}, True) (OA-SESS-32)",
        )


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


# -- 6.2 Addressing and components -------------------------------------------------------------


@case(
    id="SESS-006",
    title="An unknown command to CNS is answered UNKNOWN_COMMAND naming it",
    section="6.2",
    requirements=("OA-SESS-20",),
    allowed=("UNKNOWN_COMMAND with the text content 'Offending cmd: <type>'",),
)
async def unknown_command(ctx: CaseContext) -> None:
    """Send a command type CNS cannot know; the reply must name it."""
    raw = await ctx.raw()
    command = f"CONF_NO_SUCH_COMMAND_{ctx.run_id}".upper()
    await raw.send_message(Message(type=command, sender=ctx.name("U"), to="CNS"))
    reply = await raw.read_message()
    ctx.check(
        reply.type == "UNKNOWN_COMMAND",
        f"{command} was answered {reply.type}",
        expected="UNKNOWN_COMMAND (OA-SESS-20)",
    )
    ctx.check(
        reply.content.strip() == f"Offending cmd: {command}",
        f"UNKNOWN_COMMAND content is {reply.content!r}",
        expected=f"'Offending cmd: {command}' (OA-SESS-20)",
    )


@case(
    id="SESS-018",
    title="An empty to addresses CNS on the main port (BIND_NOLISTEN, RESOLVE, STATUS)",
    section="6.2",
    requirements=("OA-SESS-26",),
    allowed=("the CNS replies: BIND_ACCEPT -1, RESOLVE_SUCCESS, STATUS_SUCCESS",),
)
async def empty_to_is_cns(ctx: CaseContext) -> None:
    """Send CNS commands with `to` empty.

    Catches: a server that routes an empty `to` to nowhere (FORWARD_FAILED) instead of CNS.
    """
    raw = await ctx.raw()
    wants = (
        ("BIND_NOLISTEN", "", "BIND_ACCEPT"),
        ("RESOLVE_REQUEST", "WB1", "RESOLVE_SUCCESS"),
        ("STATUS", "", "STATUS_SUCCESS"),
    )
    for type_, content, want in wants:
        reply = await raw.request(cns_request(ctx, type_, to="", content=content))
        ctx.check(reply.type == want, f"{type_} with to='' got {reply.type}", expected="OA-SESS-26")


@case(
    id="SESS-023",
    title="Components other than CNS answer an unknown command UNKNOWN_COMMAND",
    section="6.2",
    requirements=("OA-SESS-29",),
    level=Level.SHOULD,
    allowed=("UNKNOWN_COMMAND with content 'Offending cmd: <type>' from each component",),
)
async def unknown_command_components(ctx: CaseContext) -> None:
    """Send an unknown command type to Config, Psyclone, AIRServer and ContextsAndPhases.

    Catches: a component that forwards, ignores or acknowledges a command it does not know.
    """
    raw = await ctx.raw()
    command = f"CONF_NO_SUCH_COMMAND_{ctx.run_id}".upper()
    for to in COMPONENTS[1:]:
        reply = await raw.request(cns_request(ctx, command, to=to))
        ctx.check(
            reply.type == "UNKNOWN_COMMAND"
            and reply.content.strip() == f"Offending cmd: {command}",
            f"{command} to {to} was answered {reply.type} {reply.content!r}",
            expected="UNKNOWN_COMMAND 'Offending cmd: <type>' (OA-SESS-29)",
        )


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
        reply = await raw.request(cns_request(ctx, ctx.type("Lost"), to=to, content="x"))
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
