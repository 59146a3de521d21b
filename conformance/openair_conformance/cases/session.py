"""Session cases (spec section 6), and the first cases that prove the harness end to end.

Besides PING, BIND, RESOLVE and CNS commands, this module holds one case each for a post
(section 7), a trigger wakeup and cc (section 8), a retrieve (section 9) and malformed XML
(section 13): the smallest set that exercises every path of the harness (raw connections,
bound and unbound modules, listener and callback deliveries, barrier-free waiting).
"""

from __future__ import annotations

import re

from openair.framing import Frame, FrameTag
from openair.message import Message
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    attributes,
    content_object,
    message_collection,
    wakeup_view,
)
from openair_conformance.registry import case

_DECIMAL = re.compile(r"^-?[0-9]+$")


def _same_time(a: object, b: object) -> bool:
    return a == b or (
        getattr(a, "sec", None) == getattr(b, "sec", 0)
        and getattr(a, "msec", None) == getattr(b, "msec", 0)
    )


# -- 6.7 PING and KEEPALIVE ------------------------------------------------------------------


@case(
    id="SESS-001",
    title="PING to CNS is answered PING_SUCCESS whose isresponse is the PING's id",
    section="6.7",
    requirements=("OA-SESS-10", "OA-SESS-1"),
    allowed=("PING_SUCCESS with isresponse = the id of the PING, on the same connection",),
)
async def ping_answered(ctx: CaseContext) -> None:
    """Send PING to CNS on a fresh connection; the one reply must be PING_SUCCESS for it."""
    raw = await ctx.raw()
    sent = await raw.send_message(Message(type="PING", sender=ctx.name("P"), to="CNS"))
    reply = await raw.read_message()
    ctx.check(
        reply.type == "PING_SUCCESS",
        f"PING was answered {reply.type}",
        expected="PING_SUCCESS (OA-SESS-10)",
    )
    ctx.check(
        reply.isresponse == sent.id,
        f"PING_SUCCESS has isresponse {reply.isresponse!r}, not the PING's id {sent.id!r}",
        expected="isresponse = the request's id (OA-SESS-1)",
    )


@case(
    id="SESS-008",
    title="KEEPALIVE with empty from and to is answered KEEPALIVESUCCESS",
    section="6.7",
    requirements=("OA-KEEP-2",),
    allowed=("KEEPALIVESUCCESS (its isresponse is checked by other cases, OA-SESS-1)",),
)
async def keepalive_answered(ctx: CaseContext) -> None:
    """Send KEEPALIVE (from and to empty, as OA-KEEP-1 says) and expect KEEPALIVESUCCESS."""
    raw = await ctx.raw()
    sent = await raw.send_message(Message(type="KEEPALIVE"))
    reply = await raw.read_message()
    ctx.check(
        reply.type == "KEEPALIVESUCCESS",
        f"KEEPALIVE was answered {reply.type}",
        expected="KEEPALIVESUCCESS (OA-KEEP-2)",
    )
    if reply.isresponse != sent.id:
        ctx.note(f"isresponse is {reply.isresponse!r}, not the KEEPALIVE's id (see OA-SESS-1)")


# -- 6.3 BIND and BIND_NOLISTEN --------------------------------------------------------------


@case(
    id="SESS-002",
    title="BIND without content is answered BIND_ACCEPT with a port as decimal text",
    section="6.3",
    requirements=("OA-SESS-3",),
    allowed=("BIND_ACCEPT whose content is a port 1–65535 in decimal (the server chooses it)",),
)
async def bind_accepted(ctx: CaseContext) -> None:
    """BIND a fresh name on a raw connection; the content must be the listening port."""
    raw = await ctx.raw()
    await raw.send_message(Message(type="BIND", sender=ctx.name("B"), to="CNS"))
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


# -- 6.4 RESOLVE_REQUEST ---------------------------------------------------------------------


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


# -- 6.2 CNS commands ------------------------------------------------------------------------


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


# -- 6.1 replies in order (pipelining) -------------------------------------------------------


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


# -- 7 a post --------------------------------------------------------------------------------


@case(
    id="WB-001",
    title="A post to WB1 from an unbound connection is acknowledged RECEIVE_ACCEPT",
    section="7.2",
    requirements=("OA-WB-2", "OA-WB-3", "OA-SESS-16", "OA-SESS-1"),
    allowed=("RECEIVE_ACCEPT with isresponse = the post's id",),
)
async def post_acknowledged(ctx: CaseContext) -> None:
    """Post to WB1 on the main port without BIND; expect RECEIVE_ACCEPT for that post."""
    client = await ctx.module("Poster", bind=False)
    reply = await client.post("WB1", ctx.type("Hello"), "hello whiteboard", check=False)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"the post was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT (OA-WB-2, OA-WB-3, OA-SESS-16)",
    )
    assert client.last_sent is not None
    ctx.check(
        reply.isresponse == client.last_sent.id,
        f"RECEIVE_ACCEPT has isresponse {reply.isresponse!r}",
        expected="isresponse = the post's id (OA-SESS-1)",
    )


# -- 8 triggers, cc and the wakeup -----------------------------------------------------------


def _check_wakeup_envelope(ctx: CaseContext, wakeup: Message, module: str) -> None:
    ctx.check(
        wakeup.sender == "WB1" and wakeup.to == module and wakeup.stored == "WB1",
        f"wakeup from={wakeup.sender!r} to={wakeup.to!r} stored={wakeup.stored!r}",
        expected=f"from='WB1', to='{module}', stored='WB1' (OA-WAKE-1)",
    )


def _check_trigger_copy(ctx: CaseContext, trigger: Message | None, sent: Message) -> None:
    if trigger is None:
        ctx.fail("the wakeup has no readable TriggerMessage", expected="OA-WAKE-2")
    same = (trigger.id, trigger.type, trigger.sender, trigger.to, trigger.content)
    want = (sent.id, sent.type, sent.sender, sent.to, sent.content)
    ctx.check(
        same == want,
        f"TriggerMessage (id, type, from, to, content) is {same}",
        expected=f"the posted message's {want} (OA-WAKE-2, OA-WB-4)",
    )
    ctx.check(
        trigger.stored == "WB1" and trigger.received is not None and trigger.wbid is not None,
        f"TriggerMessage stored={trigger.stored!r} receivedTime={trigger.received} "
        f"wbid={trigger.wbid}",
        expected="stored='WB1', a receivedTime and a wbid (OA-WB-4)",
    )
    ctx.check(
        _same_time(trigger.posted, sent.posted),
        f"TriggerMessage postedTime {trigger.posted} differs from the posted {sent.posted}",
        expected="the poster's postedTime, unchanged (OA-WAKE-2)",
    )


@case(
    id="WAKE-001",
    title="A matching trigger wakes the subscriber with TriggerMessage, RetrievedMessages and "
    "PhaseSpec",
    section="8.7",
    requirements=(
        "OA-REG-7",
        "OA-TRIG-1",
        "OA-WAKE-1",
        "OA-WAKE-2",
        "OA-WAKE-3",
        "OA-WAKE-4",
        "OA-DELIV-1",
        "OA-WB-4",
    ),
    allowed=(
        "delivery over the callback connection or a connection to the module's port",
        "a phase update (wakeup without TriggerMessage) before the wakeup, which is ignored",
        "extra <phase> attributes and children (pid, priority, currentcontexts, …)",
        "netprotocol and comment slots added to the stored copy",
    ),
)
async def trigger_wakes(ctx: CaseContext) -> None:
    """Subscribe `<prefix>.Ping.*` on WB1, post `<prefix>.Ping.A` from another client, and
    take the wakeup apart: envelope, object order, the stored copy, an empty collection and
    lasttrigger = the pattern."""
    sub = await ctx.module("Sub")
    poster = await ctx.module("Poster", bind=False)
    pattern = ctx.type("Ping.*")
    await sub.subscribe(f'<triggers><trigger from="WB1" type="{pattern}"/></triggers>', check=True)
    await poster.post("WB1", ctx.type("Ping.A"), "hello wake")
    assert poster.last_sent is not None
    sent = poster.last_sent
    wakeup = await sub.expect_wakeup_for(sent.id)
    ctx.note(f"the wakeup came over the {sub.delivery_paths[sub.wakeups_seen.index(wakeup)]}")
    _check_wakeup_envelope(ctx, wakeup, sub.name)
    try:
        view = wakeup_view(wakeup)
    except WakeupUnreadable as exc:
        ctx.fail(f"wakeup content: {exc}", expected="an <objectdictionary> (OA-WAKE-1)")
    order = ("TriggerMessage", "RetrievedMessages", "PhaseSpec")
    ctx.check(
        view.objects == order,
        f"wakeup objects are {view.objects}",
        expected=f"{order}, in that order (OA-WAKE-1)",
    )
    _check_trigger_copy(ctx, view.trigger, sent)
    ctx.check(
        view.has_collection and not view.retrieved,
        f"RetrievedMessages holds {len(view.retrieved)} message(s) "
        f"(objectcollection: {view.has_collection})",
        expected="an empty <objectcollection> (no retrieves registered, OA-WAKE-3)",
    )
    for attr in ("name", "module", "context"):
        ctx.check(
            view.phase_attr(attr) is not None,
            f"<phase> has no {attr} attribute",
            expected="name, module, context and lasttrigger (OA-WAKE-4)",
        )
    ctx.check(
        view.phase_attr("lasttrigger") == pattern,
        f"lasttrigger is {view.phase_attr('lasttrigger')!r}",
        expected=f"the pattern that fired, {pattern!r} (OA-WAKE-4)",
    )


async def _cc_wakeup(ctx: CaseContext, *, registered: bool) -> None:
    target = await ctx.module("Cc")
    if registered:
        other = ctx.type("Other.*")
        await target.subscribe(
            f'<triggers><trigger from="WB1" type="{other}"/></triggers>', check=True
        )
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Note"), "for your eyes", cc=target.name)
    assert poster.last_sent is not None
    wakeup = await target.expect_wakeup_for(poster.last_sent.id)
    try:
        view = wakeup_view(wakeup)
    except WakeupUnreadable as exc:
        ctx.fail(f"wakeup content: {exc}", expected="an <objectdictionary> (OA-WAKE-1)")
    ctx.check(
        view.phase_attr("lasttrigger") == "",
        f"lasttrigger of a wakeup due only to cc is {view.phase_attr('lasttrigger')!r}",
        expected="lasttrigger present and empty (OA-WAKE-4)",
    )


@case(
    id="CC-001",
    title="cc wakes a registered module whose triggers do not match, with an empty lasttrigger",
    section="8.5",
    requirements=("OA-CC-2", "OA-WAKE-4"),
    allowed=("one wakeup whose PhaseSpec has lasttrigger=''",),
)
async def cc_wakes_registered(ctx: CaseContext) -> None:
    """Register a trigger that cannot match, then post another type with cc naming the module."""
    await _cc_wakeup(ctx, registered=True)


@case(
    id="CC-002",
    title="cc wakes a bound module that never registered",
    section="8.5",
    requirements=("OA-CC-2",),
    allowed=("one wakeup whose PhaseSpec has lasttrigger=''",),
)
async def cc_wakes_unregistered(ctx: CaseContext) -> None:
    """Bind a module without AIR.Subscribe and post with cc naming it (Psyclone: DEV-12)."""
    await _cc_wakeup(ctx, registered=False)


# -- 9 retrieve ------------------------------------------------------------------------------


@case(
    id="RET-001",
    title="AIR.Retrieve with latest=0 returns the matching stored copies, newest first",
    section="9.3",
    requirements=("OA-RET-1", "OA-RET-4", "OA-RET-6", "OA-RET-7"),
    allowed=("AIR.Retrieve.Success with exactly the two messages, the later post first",),
)
async def retrieve_newest_first(ctx: CaseContext) -> None:
    """Post Data.1 then Data.2 to WB1; retrieve `<prefix>.Data.*` from WB1 via AIRCentral."""
    client = await ctx.module("R", bind=False)
    for n in (1, 2):
        await client.post("WB1", ctx.type(f"Data.{n}"), f"data {n}")
    spec = f'<retrieve from="WB1" type="{ctx.type("Data.*")}"><latest>0</latest></retrieve>'
    reply = await client.retrieve(spec)
    ctx.check(
        reply.type == "AIR.Retrieve.Success",
        f"the retrieve was answered {reply.type} {reply.content!r}",
        expected="AIR.Retrieve.Success (OA-RET-1, OA-RET-7)",
    )
    try:
        found = message_collection(reply)
    except WakeupUnreadable as exc:
        ctx.fail(f"retrieve result: {exc}", expected="an <objectcollection> (OA-RET-7)")
    types = [m.type for m in found]
    want = [ctx.type("Data.2"), ctx.type("Data.1")]
    ctx.check(
        types == want,
        f"the retrieve returned {types}",
        expected=f"{want}: all (latest=0, OA-RET-4), newest first (OA-RET-6)",
    )
    ctx.check(
        all(m.stored == "WB1" and m.wbid is not None for m in found),
        "a result is not a stored copy (stored/wbid missing)",
        expected="stored copies (OA-RET-7)",
    )


# -- 13 hostile: malformed XML ---------------------------------------------------------------


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
