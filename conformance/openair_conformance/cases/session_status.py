"""Session cases of spec 6.7–6.9: PING, KEEPALIVE and STATUS, configuration queries (Config,
ContextsAndPhases, AIRServer), and lifecycle notices.
"""

from __future__ import annotations

import asyncio

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    ADDRESSES,
    cns_request,
    dictionary_entries,
    retrieved,
    setup_subscribe,
    triggers_xml,
    view_of,
)
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    attributes,
    content_object,
)
from openair_conformance.model import Level
from openair_conformance.registry import case

# -- 6.7 PING, KEEPALIVE and STATUS ------------------------------------------------------------


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


@case(
    id="SESS-016",
    title="PING is answered PING_SUCCESS by CNS, by an empty to, by whiteboards and components",
    section="6.7",
    requirements=("OA-SESS-10", "OA-SESS-26", "OA-SESS-1"),
    allowed=("PING_SUCCESS with isresponse = the PING's id, for every addressee",),
)
async def ping_everyone(ctx: CaseContext) -> None:
    """PING `""`, CNS, AIRCentral, WB1, WB2 and every system component on one connection.

    Catches: a component that does not answer PING, or answers it RECEIVE_ACCEPT (a Psyclone
    module that does so never gets wakeups), and an empty `to` not taken as CNS.
    """
    raw = await ctx.raw()
    for to in ADDRESSES:
        sent = await raw.send_message(cns_request(ctx, "PING", to=to))
        reply = await raw.read_message()
        ctx.check(
            reply.type == "PING_SUCCESS" and reply.isresponse == sent.id,
            f"PING to {to!r} was answered {reply.type} (isresponse {reply.isresponse!r})",
            expected="PING_SUCCESS for the PING (OA-SESS-10, OA-SESS-1)",
        )


@case(
    id="SESS-017",
    title="KEEPALIVESUCCESS carries the KEEPALIVE's id in isresponse",
    section="6.7",
    requirements=("OA-SESS-1", "OA-KEEP-2"),
    allowed=("KEEPALIVESUCCESS with isresponse = the KEEPALIVE's id",),
)
async def keepalive_isresponse(ctx: CaseContext) -> None:
    """Send KEEPALIVE with empty from and to; check the reply's isresponse.

    Catches: Psyclone's KEEPALIVESUCCESS with an empty isresponse (DEV-24).
    """
    raw = await ctx.raw()
    sent = await raw.send_message(Message(type="KEEPALIVE"))
    reply = await raw.read_message()
    ctx.check(
        reply.type == "KEEPALIVESUCCESS" and reply.isresponse == sent.id,
        f"KEEPALIVE was answered {reply.type} with isresponse {reply.isresponse!r}",
        expected="KEEPALIVESUCCESS with isresponse = the request's id (OA-SESS-1)",
    )


@case(
    id="SESS-019",
    title="STATUS is answered STATUS_SUCCESS with a dictionary holding Name and Created",
    section="6.7",
    requirements=("OA-SESS-25",),
    allowed=(
        "STATUS_SUCCESS whose <dictionary> has the entries Name and Created (and others)",
        "the same Created in a second STATUS 1.05 s later (when CNS started, any readable form)",
    ),
)
async def status(ctx: CaseContext) -> None:
    """Send STATUS to CNS and read the dictionary; 1.05 s later send it again.

    The gap is over a second because Created may be written to the second: a Created that is
    the time of the reply would then show the same text in two replies less than a second
    apart, and only a gap past the next second tells it from the server's start.
    Catches: a STATUS reply without the entries a monitor relies on, a Created that is the time
    of the reply rather than when the server started.
    """
    raw = await ctx.raw()
    reply = await raw.request(cns_request(ctx, "STATUS"))
    ctx.check(reply.type == "STATUS_SUCCESS", f"STATUS: {reply.type}", expected="OA-SESS-25")
    entries = dictionary_entries(ctx, reply)
    ctx.check(
        entries.get("Name") == "CNS" and bool(entries.get("Created")),
        f"STATUS entries: {sorted(entries)} (Name={entries.get('Name')!r})",
        expected="Name='CNS' and a non-empty Created (OA-SESS-25)",
    )
    await asyncio.sleep(1.05)  # past the next second: see the docstring
    again = await raw.request(cns_request(ctx, "STATUS"))
    ctx.check(again.type == "STATUS_SUCCESS", f"second STATUS: {again.type}", expected="OA-SESS-25")
    created = (entries.get("Created"), dictionary_entries(ctx, again).get("Created"))
    ctx.check(
        created[0] == created[1],
        f"Created changed from {created[0]!r} to {created[1]!r} in 1.05 s",
        expected="the same Created: when the server started (OA-SESS-25)",
    )


@case(
    id="SESS-043",
    title="KEEPALIVE and PING are answered by every component: whiteboards, CNS, streams",
    section="6.7",
    requirements=("OA-KEEP-2", "OA-SESS-10", "OA-SESS-1"),
    allowed=("KEEPALIVESUCCESS / PING_SUCCESS with isresponse = the request's id, from each",),
)
async def every_component_answers(ctx: CaseContext) -> None:
    """Send KEEPALIVE and PING to each component by `to`, and to the stream on its port.

    Catches: a component other than CNS that stores a KEEPALIVE as a post, refuses it, or
    answers it RECEIVE_ACCEPT (OA-KEEP-2 says every responder answers it).
    """
    raw = await ctx.raw()
    targets: list[tuple[str, str]] = [(to, "") for to in ADDRESSES if to != "ContextsAndPhases"]
    resolve = Message(type="RESOLVE_REQUEST", sender=ctx.name("S"), to="CNS", content=ctx.stream)
    resolved = await raw.request(resolve)
    if resolved.type == "RESOLVE_SUCCESS":
        ctx.resolved(ctx.stream, attributes(content_object(resolved, "tcplocation")))
        targets.append((ctx.stream, ctx.stream))
    else:
        ctx.note(f"no stream {ctx.stream}: {resolved.type}; the streams are not asked")
    for to, component in targets:
        conn = await ctx.raw(f"to{to or 'empty'}", component=component) if component else raw
        for kind, answer in (("KEEPALIVE", "KEEPALIVESUCCESS"), ("PING", "PING_SUCCESS")):
            sent = await conn.send_message(Message(type=kind, sender=ctx.name("S"), to=to))
            reply = await conn.read_message()
            ctx.check(
                reply.type == answer and reply.isresponse == sent.id,
                f"{kind} to {to!r} was answered {reply.type} (isresponse {reply.isresponse!r})",
                expected=f"{answer} for the {kind} (OA-KEEP-2, OA-SESS-10, OA-SESS-1)",
            )


# -- 6.8 Configuration queries -----------------------------------------------------------------


@case(
    id="SESS-020",
    title="GET_ENTRY Global gives the global dictionary; an unknown module gives no content",
    section="6.8",
    requirements=("OA-SESS-12",),
    allowed=(
        "ENTRY with a <dictionary> holding spec, name, title, description, datastorefile, htmldir",
        "ENTRY with empty content for a module the configuration does not have",
    ),
)
async def get_entry(ctx: CaseContext) -> None:
    """Ask Config for `Global` and for a module name nobody configured.

    Catches: missing global entries (a JavaOpenAIR module reads them right after binding) and
    an ENTRY for an unconfigured module that carries a made-up `<module>`.
    """
    raw = await ctx.raw()
    reply = await raw.request(cns_request(ctx, "GET_ENTRY", to="Config", content="Global"))
    ctx.check(reply.type == "ENTRY", f"GET_ENTRY Global: {reply.type}", expected="ENTRY")
    missing = {"spec", "name", "title", "description", "datastorefile", "htmldir"}
    missing -= set(dictionary_entries(ctx, reply))
    ctx.check(not missing, f"the global entry lacks {sorted(missing)}", expected="OA-SESS-12")
    reply = await raw.request(
        cns_request(ctx, "GET_ENTRY", to="Config", content=ctx.name("Nobody"))
    )
    ctx.check(
        reply.type == "ENTRY" and not reply.content.strip(),
        f"GET_ENTRY of an unconfigured module: {reply.type} {reply.content[:200]!r}",
        expected="ENTRY with no content (OA-SESS-12)",
    )


@case(
    id="SESS-021",
    title="CurrentPhase answers no content before a registration and the <phase> after it",
    section="6.8",
    requirements=("OA-SESS-13",),
    allowed=(
        "Psyclone.Module.CurrentPhase with empty content for an unregistered module",
        "then a <phase> whose triggers include the registered pattern",
    ),
)
async def current_phase(ctx: CaseContext) -> None:
    """Ask Psyclone for the phase of a bound module, register a trigger, ask again.

    Catches: a CurrentPhase that ignores the module's registration, or that invents a phase
    for a module without one.
    """
    module = await ctx.module("M")
    ask = Message(type="Psyclone.Module.Request.CurrentPhase", sender=module.name, to="Psyclone")
    before = await module.request(ask)
    ctx.check(
        before.type == "Psyclone.Module.CurrentPhase" and not before.content.strip(),
        f"before registering: {before.type} {before.content[:200]!r}",
        expected="Psyclone.Module.CurrentPhase with no content (OA-SESS-13)",
    )
    pattern = ctx.type("Go.*")
    await setup_subscribe(module, triggers_xml(pattern))
    after = await module.request(Message(type=ask.type, sender=module.name, to="Psyclone"))
    try:
        phase = content_object(after, "phase")
    except WakeupUnreadable as exc:
        ctx.fail(f"after registering: {exc}", expected="a <phase> (OA-SESS-13)")
    types = [attributes(t).get("type") for t in phase.iter() if str(t.tag).lower() == "trigger"]
    ctx.check(pattern in types, f"the phase's triggers are {types}", expected="OA-SESS-13")


@case(
    id="SESS-022",
    title="GET_ID, GET_NAME and System.PerfStat to AIRServer are answered",
    section="6.8",
    requirements=("OA-SESS-14",),
    allowed=("ID (the same non-empty text twice), NAME (non-empty), RECEIVE_ACCEPT",),
)
async def airserver(ctx: CaseContext) -> None:
    """Ask GET_ID on two connections, GET_NAME, and send a System.PerfStat.

    Catches: an id that changes between requests, an empty NAME, a PerfStat left unanswered.
    """
    ids = []
    for _ in range(2):
        reply = await (await ctx.raw()).request(cns_request(ctx, "GET_ID", to="AIRServer"))
        ctx.check(
            reply.type == "ID" and bool(reply.content.strip()),
            f"GET_ID: {reply.type} {reply.content!r}",
            expected="ID with text (OA-SESS-14)",
        )
        ids.append(reply.content.strip())
    ctx.check(ids[0] == ids[1], f"GET_ID answered {ids}", expected="the same id (OA-SESS-14)")
    raw = await ctx.raw()
    reply = await raw.request(cns_request(ctx, "GET_NAME", to="AIRServer"))
    ctx.check(
        reply.type == "NAME" and bool(reply.content.strip()),
        f"GET_NAME: {reply.type} {reply.content!r}",
        expected="NAME (OA-SESS-14)",
    )
    perf = Message(
        type="System.PerfStat",
        sender=ctx.name("S"),
        to="AIRServer",
        content_is_xml=True,
        language="xml",
        content=f'<perfstat name="{ctx.name("S")}" count="0" received="0" posted="0"/>',
    )
    reply = await raw.request(perf)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT", f"System.PerfStat: {reply.type}", expected="OA-SESS-14"
    )


# -- 6.9 Lifecycle notices ---------------------------------------------------------------------


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
    allowed=(
        "a stored Psyclone.Context:Psyclone.System.Ready from Psyclone on AIRCentral, the "
        "same one after a later request",
    ),
)
async def ready_notice(ctx: CaseContext) -> None:
    """Retrieve the newest Psyclone.Context:Psyclone.System.Ready from AIRCentral; post once
    and retrieve it again.

    Catches: a server that never announces readiness (modules that wait for it never start),
    and one that announces it again later (with a request), which activates the Ready
    context anew for every module (OA-REG-13).
    """
    client = await ctx.module("R", bind=False)
    spec = '<retrieve from="AIRCentral" type="Psyclone.Context:Psyclone.System.Ready"/>'
    found = await retrieved(ctx, client, spec)
    ctx.check(
        len(found) == 1 and found[0].sender == "Psyclone",
        f"found {[(m.type, m.sender) for m in found]}",
        expected="one message from Psyclone (OA-SESS-31)",
    )
    await client.post("WB1", ctx.type("Later"), "a request after start-up")
    again = await retrieved(ctx, client, spec)
    ctx.check(
        [m.id for m in again] == [m.id for m in found],
        f"the newest notice is now {[m.id for m in again]}, was {[m.id for m in found]}",
        expected="the same one: posted at start-up, not with later requests (OA-SESS-31)",
    )
