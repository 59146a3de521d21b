"""Wakeup cases (spec 8.6–8.9): one wakeup per module and message, which trigger is reported,
`after` with cc, registration retrieves, the PhaseSpec, and contexts (extension).
"""

from __future__ import annotations

import time

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    esc,
    setup_subscribe,
    trigger_ids,
    triggers_xml,
    view_of,
)
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    content_root,
    wakeup_view,
)
from openair_conformance.registry import case


@case(
    id="WAKE-002",
    title="A module is woken once per message however many triggers match, cc included",
    section="8.6",
    requirements=("OA-WAKE-5",),
    allowed=("exactly one wakeup for the message",),
)
async def once_per_message(ctx: CaseContext) -> None:
    """Register three triggers that all match `<prefix>.Multi.A`; post it with cc = the module.

    Catches: one wakeup per matching trigger plus one for cc (Psyclone, DEV-11).
    """
    sub = await ctx.module("Sub")
    pattern_list = (ctx.type("Multi.*"), ctx.type("Multi.A"), ctx.type("*A"))
    await setup_subscribe(sub, triggers_xml(*pattern_list))
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Multi.A"), "x", cc=sub.name)
    assert poster.last_sent is not None
    count = trigger_ids(await sub.barrier()).count(poster.last_sent.id)
    ctx.check(count == 1, f"{count} wakeups for one message", expected="one (OA-WAKE-5)")


@case(
    id="WAKE-003",
    title="The matching trigger with the smallest after is reported; ties go to the first",
    section="8.6",
    requirements=("OA-WAKE-6", "OA-WAKE-4"),
    allowed=("lasttrigger = the after=0 pattern for A; the first-registered pattern for B",),
)
async def smallest_after(ctx: CaseContext) -> None:
    """Register `A` with after=5000 then `*.A` and `*.B`-style patterns with after=0; post A
    and B.

    Catches: the first matching trigger taken regardless of `after` (the wakeup would wait 5 s),
    and the last one taken on a tie.
    """
    sub = await ctx.module("Sub")
    slow, fast, first, second = ctx.type("A"), ctx.type("*A"), ctx.type("B"), ctx.type("*B")
    content = (
        f'<triggers><trigger from="WB1" type="{slow}" after="5000"/>'
        f'<trigger from="WB1" type="{fast}"/><trigger from="WB1" type="{first}"/>'
        f'<trigger from="WB1" type="{second}"/></triggers>'
    )
    await setup_subscribe(sub, content)
    poster = await ctx.module("Poster", bind=False)
    for type_, want in ((ctx.type("A"), fast), (ctx.type("B"), first)):
        await poster.post("WB1", type_, "x")
        assert poster.last_sent is not None
        view = view_of(ctx, await sub.expect_wakeup_for(poster.last_sent.id))
        got = view.phase_attr("lasttrigger")
        ctx.check(
            got == want, f"lasttrigger for {type_} is {got!r}", expected=f"{want!r} (OA-WAKE-6)"
        )


@case(
    id="WAKE-004",
    title="With cc and a matching trigger, the trigger is reported and its after applies",
    section="8.6",
    requirements=("OA-WAKE-6", "OA-WAKE-5"),
    allowed=("one wakeup, at least 300 ms after the post, with lasttrigger = the pattern",),
)
async def cc_and_trigger(ctx: CaseContext) -> None:
    """Register T with after=300; post T with cc = the module; time the one wakeup.

    Catches: the cc wakeup sent at once (and the trigger's later, a second wakeup), or
    lasttrigger left empty.
    """
    sub = await ctx.module("Sub")
    await setup_subscribe(sub, triggers_xml(ctx.type("T"), after=300))
    poster = await ctx.module("Poster", bind=False)
    started = time.monotonic()
    await poster.post("WB1", ctx.type("T"), "x", cc=sub.name)
    assert poster.last_sent is not None
    wakeup = await sub.expect_wakeup_for(poster.last_sent.id, timeout=ctx.deadline + 0.3)
    elapsed = time.monotonic() - started
    ctx.check(
        elapsed >= 0.3,
        f"woken after {elapsed * 1000:.0f} ms",
        expected="at least 300 ms (OA-WAKE-6)",
    )
    got = view_of(ctx, wakeup).phase_attr("lasttrigger")
    ctx.check(
        got == ctx.type("T"), f"lasttrigger {got!r}", expected="the trigger's pattern (OA-WAKE-6)"
    )
    count = trigger_ids(await sub.barrier()).count(poster.last_sent.id)
    ctx.check(
        count == 0, f"{count} more wakeup(s) for the message", expected="one in all (OA-WAKE-5)"
    )


@case(
    id="WAKE-005",
    title="Registration retrieves: newest first per retrieve, in order, the trigger included",
    section="8.6",
    requirements=("OA-WAKE-7", "OA-WAKE-3", "OA-RET-6"),
    allowed=("RetrievedMessages = Data.3, Data.2 (first retrieve) then Go (second, no from)",),
)
async def registration_retrieves(ctx: CaseContext) -> None:
    """Register Go on WB2 with retrieves `Data.*` latest 2 from WB2 and `Go` without from;
    post Data.1–3 and Go to WB2.

    Catches: retrieves evaluated before the trigger is stored, a retrieve without from reading
    AIRCentral instead of the trigger's whiteboard, results oldest first or interleaved.
    """
    sub = await ctx.module("Sub")
    content = (
        f'<module name="{sub.name}"><trigger from="WB2" type="{esc(ctx.type("Go"))}"/>'
        f'<retrieve from="WB2" type="{esc(ctx.type("Data.*"))}"><latest>2</latest></retrieve>'
        f'<retrieve type="{esc(ctx.type("Go"))}"/></module>'
    )
    await setup_subscribe(sub, content)
    poster = await ctx.module("Poster", bind=False)
    for n in (1, 2, 3):
        await poster.post("WB2", ctx.type(f"Data.{n}"), f"d{n}")
    await poster.post("WB2", ctx.type("Go"), "go")
    assert poster.last_sent is not None
    view = view_of(ctx, await sub.expect_wakeup_for(poster.last_sent.id))
    got = [m.type for m in view.retrieved]
    want = [ctx.type("Data.3"), ctx.type("Data.2"), ctx.type("Go")]
    ctx.check(got == want, f"RetrievedMessages {got}", expected=f"{want} (OA-WAKE-7, OA-WAKE-3)")
    ctx.check(
        view.retrieved[-1].id == poster.last_sent.id if view.retrieved else False,
        "the last result is not the trigger",
        expected="OA-WAKE-7",
    )


@case(
    id="WAKE-006",
    title="PhaseSpec lists the triggers (after, from, type); an unregistered module's has none",
    section="8.7",
    requirements=("OA-WAKE-4", "OA-WAKE-1"),
    allowed=(
        "the registered module's <phase> lists its trigger with after, from and type",
        "a cc'd module without registration gets a phase with no triggers in Psyclone.System.Ready",
        "the wakeup of a WB2 post comes from WB2 and is stored WB2",
    ),
)
async def phase_spec(ctx: CaseContext) -> None:
    """Register a trigger on WB2 with after=0; post to WB2 with cc naming an unregistered
    module; read both PhaseSpecs.

    Catches: triggers missing from PhaseSpec, a made-up phase for an unregistered module,
    wakeups from the wrong whiteboard.
    """
    sub, bare = await ctx.module("Sub"), await ctx.module("Bare")
    await setup_subscribe(sub, triggers_xml(ctx.type("T"), wb="WB2", after=0))
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB2", ctx.type("T"), "x", cc=bare.name)
    assert poster.last_sent is not None
    wakeup = await sub.expect_wakeup_for(poster.last_sent.id)
    envelope = (wakeup.sender, wakeup.stored, wakeup.to)
    ctx.check(
        envelope == ("WB2", "WB2", sub.name), f"from/stored/to {envelope}", expected="OA-WAKE-1"
    )
    view = view_of(ctx, wakeup)
    ctx.check(
        view.phase_trigger_count == 1,
        f"{view.phase_trigger_count} triggers in PhaseSpec",
        expected="one (OA-WAKE-4)",
    )
    bare_view = view_of(ctx, await bare.expect_wakeup_for(poster.last_sent.id))
    got = (
        bare_view.phase_trigger_count,
        bare_view.phase_attr("context"),
        bare_view.phase_attr("lasttrigger"),
    )
    ctx.check(
        got == (0, "Psyclone.System.Ready", ""),
        f"unregistered phase {got}",
        expected="(0, 'Psyclone.System.Ready', '') (OA-WAKE-4)",
    )


@case(
    id="CTX-001",
    title="Contexts: one active context per root; the phase in force follows it",
    section="8.9",
    requirements=("OA-REG-13", "OA-REG-14", "OA-REG-15"),
    needs=("contexts",),
    allowed=(
        "no trigger fires before a context is active; after Psyclone.Context:R.A only A's; "
        "after R.B only B's; posting R (an ancestor of R.B) changes nothing",
        "a phase update after each change of phase",
    ),
)
async def contexts(ctx: CaseContext) -> None:
    """Register phases in contexts `<root>.A` and `<root>.B` (a root unique to the run); switch
    the context with Psyclone.Context posts and post both trigger types after each switch.

    Catches: contexts of one root active together, an ancestor post replacing a descendant,
    phases not switching, missing phase updates.
    """
    root = f"ConfR{ctx.run_id}Ctx"
    sub = await ctx.module("Sub")
    content = "".join(
        f'<context name="{root}.{x}"><phase id="P{x}">{triggers_xml(ctx.type(x))}</phase></context>'
        for x in ("A", "B")
    )
    await setup_subscribe(sub, f'<module name="{sub.name}">{content}</module>')
    poster = await ctx.module("Poster", bind=False)
    steps: tuple[tuple[str | None, list[str]], ...] = (
        (None, []),
        (f"{root}.A", ["A"]),
        (f"{root}.B", ["B"]),
        (root, ["B"]),
    )
    for context, want in steps:
        if context is not None:
            await poster.post("WB1", f"Psyclone.Context:{context}", "switch")
        names = {}
        for x in ("A", "B"):
            await poster.post("WB1", ctx.type(x), x)
            assert poster.last_sent is not None
            names[poster.last_sent.id] = x
        got = [names[i] for i in trigger_ids(await sub.barrier()) if i in names]
        ctx.check(
            got == want,
            f"after {context or 'no context'}: woken by {got}",
            expected=f"{want} (OA-REG-13, OA-REG-14)",
        )
    ctx.check(
        len(sub.phase_updates) >= 2,
        f"{len(sub.phase_updates)} phase updates",
        expected="one per change (OA-REG-15)",
    )


# -- 8.7 The wakeup, taken apart ---------------------------------------------------------------


def _same_time(a: object, b: object) -> bool:
    return a == b or (
        getattr(a, "sec", None) == getattr(b, "sec", 0)
        and getattr(a, "msec", None) == getattr(b, "msec", 0)
    )


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
    take the wakeup apart: envelope, object order, the stored copy, an empty collection,
    lasttrigger = the pattern, and both registered triggers (the other with after=60000) in
    the PhaseSpec with after, from and type."""
    sub = await ctx.module("Sub")
    poster = await ctx.module("Poster", bind=False)
    pattern, other = ctx.type("Ping.*"), ctx.type("Other")
    triggers = (
        f'<trigger from="WB1" type="{pattern}"/><trigger from="WB1" type="{other}" after="60000"/>'
    )
    await sub.subscribe(f"<triggers>{triggers}</triggers>", check=True)
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
    got = sorted(_phase_triggers(wakeup))
    want = sorted([("0", "wb1", pattern), ("60000", "wb1", other)])
    ctx.check(
        got == want,
        f"the PhaseSpec triggers (after, from, type) are {got}",
        expected=f"{want}: each written with after, from and type (OA-WAKE-4)",
    )


def _phase_triggers(wakeup: Message) -> list[tuple[str, str, str]]:
    """Return (after, from lower-cased, type) of each `<trigger>` in the wakeup's `<phase>`
    (None for a missing attribute is written as '?')."""
    found = []
    for root in content_root(wakeup):
        for phase in root.iter("{*}phase", "phase"):
            for el in phase.iter("{*}trigger", "trigger"):
                attrs = {str(k).lower(): str(v) for k, v in el.attrib.items()}
                found.append(
                    (
                        attrs.get("after", "?"),
                        attrs.get("from", "?").lower(),
                        attrs.get("type", "?"),
                    )
                )
    return found
