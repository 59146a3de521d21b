"""Registration and trigger cases (spec 8.1–8.4): every AIR.Subscribe form, replacement,
refusals that keep the old registration, `from` on triggers and groups, `after`, and
self-triggering.
"""

from __future__ import annotations

import asyncio
import time

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    check_error,
    esc,
    setup_subscribe,
    trigger_ids,
    triggers_xml,
    view_of,
)
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.model import Level, NotApplicable
from openair_conformance.registry import case


async def _data_then_go(ctx: CaseContext, sub: TestModule, board: str = "WB1") -> Message:
    """Post Data.1–3 then Go to `board`; return the wakeup for Go."""
    poster = await ctx.module("Poster", bind=False)
    for n in (1, 2, 3):
        await poster.post(board, ctx.type(f"Data.{n}"), f"d{n}")
    await poster.post(board, ctx.type("Go"), "go")
    assert poster.last_sent is not None
    return await sub.expect_wakeup_for(poster.last_sent.id)


def _retrieved_types(ctx: CaseContext, wakeup: Message) -> list[str]:
    return [m.type for m in view_of(ctx, wakeup).retrieved]


async def _form(ctx: CaseContext, content: str, want: list[str], req: str) -> Message:
    """Register `content`, post Data.1–3 and Go, and check the wakeup's RetrievedMessages."""
    sub = await ctx.module("Sub")
    await sub.subscribe(content, check=True)
    wakeup = await _data_then_go(ctx, sub)
    got = _retrieved_types(ctx, wakeup)
    ctx.check(got == want, f"RetrievedMessages holds {got}", expected=f"{want} ({req})")
    return wakeup


@case(
    id="REG-001",
    title="The bare form <triggers> plus <retrieves> registers triggers and retrieves",
    section="8.2",
    requirements=("OA-REG-2", "OA-WAKE-3", "OA-MSG-17"),
    allowed=("a wakeup for Go whose RetrievedMessages holds Data.3 and Data.2",),
)
async def bare_form(ctx: CaseContext) -> None:
    """Register `<triggers>…</triggers> <retrieves>…</retrieves>` (two roots, white space
    between), post Data.1–3 and Go.

    Catches: retrieves of the bare form dropped (Psyclone, DEV-7), a second root ignored.
    """
    content = (
        f'<triggers><trigger from="WB1" type="{ctx.type("Go")}"/></triggers>\n  '
        f'<retrieves><retrieve from="WB1" type="{ctx.type("Data.*")}"><latest>2</latest>'
        "</retrieve></retrieves>"
    )
    await _form(ctx, content, [ctx.type("Data.3"), ctx.type("Data.2")], "OA-REG-2")


@case(
    id="REG-002",
    title="The <module> form with direct <trigger> and <retrieve> children registers both",
    section="8.2",
    requirements=("OA-REG-3", "OA-REG-1"),
    allowed=("a wakeup for Go with Data.3 retrieved; the name attribute does not matter",),
)
async def module_form_direct(ctx: CaseContext) -> None:
    """Register `<module name="SomebodyElse"><trigger …/><retrieve …/></module>`.

    Catches: the MARY form refused, and a registration filed under the `name` attribute
    instead of the sender's `from`.
    """
    content = (
        f'<module name="{ctx.name("SomebodyElse")}"><trigger from="WB1" type="{ctx.type("Go")}"/>'
        f'<retrieve from="WB1" type="{ctx.type("Data.*")}"/></module>'
    )
    await _form(ctx, content, [ctx.type("Data.3")], "OA-REG-3, OA-REG-1")


@case(
    id="REG-003",
    title="A from on a <triggers> or <retrieves> group applies to children without their own",
    section="8.2",
    requirements=("OA-REG-3", "OA-REG-5", "OA-TRIG-1"),
    allowed=(
        "Go on WB2 and Stop on WB1 wake the module; Go on WB1 does not; WB2's data is retrieved",
    ),
)
async def group_from(ctx: CaseContext) -> None:
    """Register `<triggers from="WB2">` with Go (no from) and Stop (from WB1), and
    `<retrieves from="WB2">`; post on both whiteboards.

    Catches: group attributes ignored (Go firing on every whiteboard), or a group `from` that
    overrides a trigger's own.
    """
    sub = await ctx.module("Sub")
    content = (
        f'<module name="{sub.name}"><triggers from="WB2"><trigger type="{ctx.type("Go")}"/>'
        f'<trigger from="WB1" type="{ctx.type("Stop")}"/></triggers>'
        f'<retrieves from="WB2"><retrieve type="{ctx.type("Data.*")}"/></retrieves></module>'
    )
    await sub.subscribe(content, check=True)
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB2", ctx.type("Data.1"), "wb2 data")
    sent = {}
    for board, name in (("WB1", "Go"), ("WB2", "Go"), ("WB1", "Stop"), ("WB2", "Stop")):
        await poster.post(board, ctx.type(name), f"{name} on {board}")
        assert poster.last_sent is not None
        sent[poster.last_sent.id] = f"{name}@{board}"
    wakeups = await sub.barrier()
    got = [sent.get(i, "?") for i in trigger_ids(wakeups)]
    ctx.check(
        got == ["Go@WB2", "Stop@WB1"], f"woken by {got}", expected="Go@WB2, Stop@WB1 (OA-REG-5)"
    )
    ctx.check(
        _retrieved_types(ctx, wakeups[0]) == [ctx.type("Data.1")],
        f"retrieved {_retrieved_types(ctx, wakeups[0])}",
        expected="WB2's Data.1 (the retrieves group's from, OA-REG-5)",
    )


@case(
    id="REG-004",
    title="The <module> form with contexts and phases (with or without <spec>, <phases>)",
    section="8.2",
    requirements=("OA-REG-4", "OA-WAKE-4"),
    allowed=("a wakeup for Go whose PhaseSpec names the phase (by id or name) and the context",),
)
async def context_phase_form(ctx: CaseContext) -> None:
    """Register the Greta form (`<spec><context><phase id>`) on one module and the form with
    `<phases>` and a phase `name` on another.

    Catches: either nesting refused, or a phase named by `id` losing its name.
    """
    forms = {
        "Main1": '<spec><context name="{c}"><phase id="Main1">{b}</phase></context></spec>',
        "Main2": '<context name="{c}"><phases><phase name="Main2">{b}</phase></phases></context>',
    }
    body = (
        f'<triggers><trigger from="WB1" type="{ctx.type("Go")}"/></triggers>'
        f'<retrieves><retrieve from="WB1" type="{ctx.type("Data.*")}"/></retrieves>'
    )
    modules = {}
    for phase, form in forms.items():
        modules[phase] = await ctx.module(phase)
        await modules[phase].subscribe(
            f'<module name="{modules[phase].name}">'
            f"{form.format(b=body, c='Psyclone.System.Ready')}</module>",
            check=True,
        )
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Go"), "go")
    assert poster.last_sent is not None
    for phase, module in modules.items():
        view = view_of(ctx, await module.expect_wakeup_for(poster.last_sent.id))
        got = (view.phase_attr("name"), view.phase_attr("context"))
        ctx.check(
            got == (phase, "Psyclone.System.Ready"), f"phase {got}", expected="OA-REG-4, OA-WAKE-4"
        )


@case(
    id="REG-005",
    title="A root <phase> registers one phase in Psyclone.System.Ready",
    section="8.2",
    requirements=("OA-REG-12",),
    allowed=("a wakeup for Go with Data.3 retrieved and phase name Main",),
)
async def root_phase_form(ctx: CaseContext) -> None:
    """Register `<phase name="Main"><triggers/><retrieves/></phase>`.

    Catches: a root phase acknowledged but ignored (Psyclone, DEV-9).
    """
    content = (
        f'<phase name="Main"><triggers><trigger from="WB1" type="{ctx.type("Go")}"/></triggers>'
        f'<retrieves><retrieve from="WB1" type="{ctx.type("Data.*")}"/></retrieves></phase>'
    )
    wakeup = await _form(ctx, content, [ctx.type("Data.3")], "OA-REG-12")
    ctx.check(view_of(ctx, wakeup).phase_attr("name") == "Main", "phase name", expected="Main")


@case(
    id="REG-006",
    title="A new AIR.Subscribe, sent to any whiteboard, replaces the whole registration",
    section="8.1",
    requirements=("OA-REG-1", "OA-REG-7"),
    allowed=("only B wakes the module after the second registration",),
)
async def replace(ctx: CaseContext) -> None:
    """Register A via AIRCentral, then B (a trigger on WB1) via WB2; post A and B to WB1.

    Catches: registrations merged instead of replaced, and triggers limited to the whiteboard
    the AIR.Subscribe was sent to.
    """
    sub = await ctx.module("Sub")
    await sub.subscribe(triggers_xml(ctx.type("A")), check=True)
    await sub.subscribe(triggers_xml(ctx.type("B")), to="WB2", check=True)
    poster = await ctx.module("Poster", bind=False)
    ids = {}
    for name in ("A", "B"):
        await poster.post("WB1", ctx.type(name), name)
        assert poster.last_sent is not None
        ids[poster.last_sent.id] = name
    got = [ids.get(i, "?") for i in trigger_ids(await sub.barrier())]
    ctx.check(got == ["B"], f"woken by {got}", expected="['B'] (OA-REG-1)")


@case(
    id="REG-007",
    title="Invalid registrations are refused with RECEIVE_ERROR and the old one stays",
    section="8.3",
    requirements=("OA-REG-8", "OA-ERR-2"),
    allowed=(
        "RECEIVE_ERROR 'REGISTRATION_INVALID: …' (RETRIEVE_INVALID or PATTERN_INVALID where "
        "the retrieve or pattern is the fault) for each; Keep still wakes the module",
        "RECEIVE_ACCEPT for after = 2^63 - 1",
    ),
)
async def invalid_registrations(ctx: CaseContext) -> None:
    """Register Keep; then send empty content, text, `<foo/>`, a trigger without type,
    `after="-5"`, `after="soon"`, `<triggers>` holding a `<retrieve>` or a `<typo>`, a retrieve
    with `latest="x"`, and a valid form with an empty `from`; post Keep; then register a
    trigger with `after` = 2^63 - 1, which is valid.

    Catches: refusals that are acknowledged anyway (Psyclone, DEV-8), and a refused
    registration that still replaces the old one, and a bound on after one short of 2^63 - 1.
    """
    sub = await ctx.module("Sub")
    await setup_subscribe(sub, triggers_xml(ctx.type("Keep")))
    t = esc(ctx.type("X"))
    bad = [
        ("", False),
        ("just text", False),
        ("<foo/>", True),
        ('<triggers><trigger from="WB1"/></triggers>', True),
        (f'<triggers><trigger from="WB1" type="{t}" after="-5"/></triggers>', True),
        (f'<triggers><trigger from="WB1" type="{t}" after="soon"/></triggers>', True),
        # <triggers> holds only <trigger> elements (issue #15: a name compared by order, so
        # that <retrieve> or <typo> passed for a trigger, survived).
        (f'<triggers><retrieve from="WB1" type="{t}"/></triggers>', True),
        (f'<triggers><typo from="WB1" type="{t}"/></triggers>', True),
        (
            f'<module name="{sub.name}"><trigger type="{t}"/>'
            f'<retrieve from="WB1" type="{t}" latest="x"/></module>',
            True,
        ),
    ]
    for content, xml in bad:
        msg = Message(
            type="AIR.Subscribe",
            sender=sub.name,
            to="AIRCentral",
            content=content,
            content_is_xml=xml,
            language="xml" if xml else "",
        )
        reply = await sub.request(msg)
        check_error(
            ctx,
            reply,
            names=("REGISTRATION_INVALID", "RETRIEVE_INVALID"),
            what=f"AIR.Subscribe {content!r}",
            req="OA-REG-8",
        )
    raw = await ctx.raw()
    anonymous = Message(
        type="AIR.Subscribe",
        to="AIRCentral",
        content=triggers_xml(ctx.type("X")),
        content_is_xml=True,
        language="xml",
    )
    reply = await raw.request(anonymous)
    check_error(
        ctx,
        reply,
        names=("REGISTRATION_INVALID",),
        what="AIR.Subscribe with an empty from",
        req="OA-REG-8",
    )
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Keep"), "keep")
    assert poster.last_sent is not None
    await sub.expect_wakeup_for(poster.last_sent.id)
    # The edge of the valid: the largest after a signed 64-bit integer holds is a non-negative
    # integer (issue #15: a bound one short refused it).
    far = f'<triggers><trigger from="WB1" type="{t}" after="{2**63 - 1}"/></triggers>'
    await sub.subscribe(far, check=True)


@case(
    id="REG-008",
    title="A registration without triggers is valid and removes every trigger",
    section="8.1",
    requirements=("OA-REG-11", "OA-REG-7"),
    allowed=("RECEIVE_ACCEPT for <triggers/> and for <module name='M'/>; T no longer wakes",),
)
async def empty_registration(ctx: CaseContext) -> None:
    """Register T; replace it with `<triggers/>`; register T again; replace with `<module/>`.

    Catches: empty registrations refused (a module could never unsubscribe) or ignored.
    """
    sub = await ctx.module("Sub")
    poster = await ctx.module("Poster", bind=False)
    for empty in ("<triggers/>", f'<module name="{sub.name}"/>'):
        await setup_subscribe(sub, triggers_xml(ctx.type("T")))
        await sub.subscribe(empty, check=True)
        await poster.post("WB1", ctx.type("T"), f"after {empty}")
        woken = await sub.barrier()
        ctx.check(not woken, f"after {empty} T still woke the module", expected="OA-REG-11")


@case(
    id="REG-009",
    title="A trigger's from is case-insensitive; any, *, empty and absent mean every whiteboard",
    section="8.4",
    requirements=("OA-TRIG-2", "OA-WB-10"),
    allowed=("'wb1' fires for WB1 only; any, *, '' and no from fire for WB1 and WB2; 'WB*' never",),
)
async def trigger_from(ctx: CaseContext) -> None:
    """Register one module per `from` form; post T to WB1 and to WB2.

    Catches: case-sensitive trigger `from`, `any` taken as a whiteboard name, globbing in
    `from`.
    """
    forms = {
        "Lower": 'from="wb1"',
        "Any": 'from="any"',
        "Star": 'from="*"',
        "Empty": 'from=""',
        "None": "",
        "Glob": 'from="WB*"',
    }
    want = {
        "Lower": ["WB1"],
        "Any": ["WB1", "WB2"],
        "Star": ["WB1", "WB2"],
        "Empty": ["WB1", "WB2"],
        "None": ["WB1", "WB2"],
        "Glob": [],
    }
    modules = await asyncio.gather(*(ctx.module(name) for name in forms))
    for module, attr in zip(modules, forms.values(), strict=True):
        await module.subscribe(
            f'<triggers><trigger {attr} type="{ctx.type("T")}"/></triggers>', check=True
        )
    poster = await ctx.module("Poster", bind=False)
    boards = {}
    for board in ("WB1", "WB2"):
        await poster.post(board, ctx.type("T"), board)
        assert poster.last_sent is not None
        boards[poster.last_sent.id] = board
    results = await asyncio.gather(*(m.barrier() for m in modules))
    for name, wakeups in zip(forms, results, strict=True):
        got = [boards.get(i, "?") for i in trigger_ids(wakeups)]
        ctx.check(
            got == want[name],
            f"trigger {forms[name] or 'without from'} fired for {got}",
            expected=f"{want[name]} (OA-TRIG-2)",
        )


@case(
    id="REG-010",
    title="after (and its synonym delay) delays the wakeup by at least that many ms",
    section="8.4",
    requirements=("OA-TRIG-3",),
    allowed=("each wakeup arrives no sooner than 300 ms after the post was sent",),
)
async def trigger_after(ctx: CaseContext) -> None:
    """Register `after="300"` on one module and `delay="300"` on another; post; time the
    wakeups with the local clock (receivedTime is after the send, so this is a lower bound).

    Catches: `after` ignored, `delay` not read, a delay counted from the wrong moment.
    """
    modules = [await ctx.module("After"), await ctx.module("Delay")]
    for module, attr in zip(modules, ("after", "delay"), strict=True):
        await module.subscribe(
            f'<triggers><trigger from="WB1" type="{ctx.type("T")}" {attr}="300"/></triggers>',
            check=True,
        )
    poster = await ctx.module("Poster", bind=False)
    started = time.monotonic()
    await poster.post("WB1", ctx.type("T"), "later")
    assert poster.last_sent is not None
    for module in modules:
        await module.expect_wakeup_for(poster.last_sent.id, timeout=ctx.deadline + 0.3)
        elapsed = time.monotonic() - started
        ctx.check(
            elapsed >= 0.3,
            f"{module.name} was woken after {elapsed * 1000:.0f} ms",
            expected="at least 300 ms (OA-TRIG-3)",
        )


@case(
    id="REG-011",
    title="A module's own posts wake it only when its registration allows self-triggering",
    section="8.4",
    requirements=("OA-TRIG-4", "OA-REG-6", "OA-SEC-3"),
    allowed=("no wakeup without allowselftriggering; one with allowselftriggering='YES'",),
)
async def self_triggering(ctx: CaseContext) -> None:
    """Register T; post T from the module and from another client that writes the module's
    name in from; then register with `allowselftriggering="YES"` and post again.

    Catches: self-triggering on by default, the attribute value compared case-sensitively,
    `from` checked against the connection instead of the slot.
    """
    module = await ctx.module("M")
    await setup_subscribe(module, triggers_xml(ctx.type("T")))
    forger = await ctx.module("Forger", bind=False)
    await module.post("WB1", ctx.type("T"), "own")
    await forger.post("WB1", ctx.type("T"), "in its name", sender=module.name)
    woken = await module.barrier()
    ctx.check(not woken, f"{len(woken)} self-triggered wakeup(s)", expected="none (OA-TRIG-4)")
    trigger = f'<trigger from="WB1" type="{ctx.type("T")}"/>'
    allow = f'<module name="{module.name}" allowselftriggering="YES">{trigger}</module>'
    await setup_subscribe(module, allow)
    await module.post("WB1", ctx.type("T"), "own, allowed")
    assert module.last_sent is not None
    await module.expect_wakeup_for(module.last_sent.id)


@case(
    id="REG-012",
    title="A trigger on an unknown whiteboard is accepted (and never fires) or refused",
    section="8.3",
    requirements=("OA-REG-9", "OA-REG-7"),
    level=Level.MAY,
    allowed=("RECEIVE_ACCEPT", "RECEIVE_ERROR 'WHITEBOARD_UNKNOWN: …'"),
)
async def unknown_whiteboard_trigger(ctx: CaseContext) -> None:
    """Register a trigger with `from="NoSuchWB"`.

    Catches: any other answer (a crash, FORWARD_FAILED, a registration that fires anyway).
    """
    sub = await ctx.module("Sub")
    reply = await sub.subscribe(triggers_xml(ctx.type("T"), wb=ctx.name("NoSuchWB")))
    if reply.type != "RECEIVE_ACCEPT":
        check_error(
            ctx,
            reply,
            names=("WHITEBOARD_UNKNOWN",),
            what="a trigger on an unknown whiteboard",
            req="OA-REG-9",
        )
        return
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("T"), "not for the unknown board")
    ctx.check(
        not await sub.barrier(), "the trigger fired for WB1", expected="never fires (OA-REG-9)"
    )


@case(
    id="REG-013",
    title="max-triggers triggers are accepted; one more is refused LIMIT_EXCEEDED",
    section="14.1",
    requirements=("OA-LIM-6", "OA-REG-8"),
    # Alone: reading a registration of a thousand triggers holds the server for a while, and
    # the replies of the cases beside it came late for that (REG-012, REG-014 at 0.54 s, #15).
    serial=True,
    allowed=(
        "RECEIVE_ACCEPT at the limit; RECEIVE_ERROR 'LIMIT_EXCEEDED: …' beyond; the first stays",
    ),
)
async def max_triggers(ctx: CaseContext) -> None:
    """Register exactly max-triggers triggers; then one more than that; post the last type.

    Catches: an off-by-one limit, no limit at all, and a refusal that drops the registration.
    """
    limit = ctx.server.limit("max-triggers", 1024)
    if limit > 10_000:
        raise NotApplicable(f"max-triggers is {limit}; too many to send")
    sub = await ctx.module("Sub")
    patterns = [ctx.type(f"T.{n}") for n in range(limit + 1)]
    # No "at once" rule times these replies (OA-LIM-6 is about the answer): a deadline per
    # 256 triggers read, as a reply to a frame that large takes that much longer to come.
    slow = ctx.deadline * (1 + limit // 256)
    await sub.subscribe(triggers_xml(*patterns[:limit]), check=True, timeout=slow)
    reply = await sub.subscribe(triggers_xml(*patterns), timeout=slow)
    check_error(ctx, reply, names=("LIMIT_EXCEEDED",), what=f"{limit + 1} triggers", req="OA-LIM-6")
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", patterns[limit - 1], "last at the limit")
    assert poster.last_sent is not None
    await sub.expect_wakeup_for(poster.last_sent.id)


@case(
    id="REG-014",
    title="Phases in other contexts are accepted; only the first Ready phase is in force",
    section="8.3",
    requirements=("OA-REG-10",),
    allowed=("Ready's first phase fires; the second Ready phase and the other context's do not",),
)
async def other_contexts(ctx: CaseContext) -> None:
    """Register a phase in an inactive context (unique to the run) and two phases in
    Psyclone.System.Ready; post the three trigger types.

    Catches: registrations with other contexts refused, every phase's triggers merged.
    """
    other = f"ConfR{ctx.run_id}.Idle"
    content = (
        f'<module name="{ctx.name("Sub")}"><context name="{other}">'
        f'<phase id="O">{triggers_xml(ctx.type("Other"))}</phase></context>'
        '<context name="Psyclone.System.Ready">'
        f'<phase id="R1">{triggers_xml(ctx.type("First"))}</phase>'
        f'<phase id="R2">{triggers_xml(ctx.type("Second"))}</phase></context></module>'
    )
    sub = await ctx.module("Sub")
    await sub.subscribe(content, check=True)
    poster = await ctx.module("Poster", bind=False)
    names = {}
    for name in ("Other", "First", "Second"):
        await poster.post("WB1", ctx.type(name), name)
        assert poster.last_sent is not None
        names[poster.last_sent.id] = name
    got = [names.get(i, "?") for i in trigger_ids(await sub.barrier())]
    ctx.check(got == ["First"], f"woken by {got}", expected="['First'] (OA-REG-10)")


@case(
    id="REG-015",
    title="A phase may carry a priority; one outside 0.0–6.999 is refused or works",
    section="8.2",
    requirements=("OA-REG-4", "OA-REG-7", "OA-REG-8"),
    allowed=(
        "priority 2.5: RECEIVE_ACCEPT and a wakeup for Go",
        "priority 7.5: RECEIVE_ERROR 'REGISTRATION_INVALID: …', or RECEIVE_ACCEPT and a wakeup "
        "for Go (the priority read clamped or ignored; PhaseSpec's priority is informative)",
    ),
)
async def phase_priority(ctx: CaseContext) -> None:
    """Register a context phase with `priority="2.5"` on one module and `priority="7.5"` on
    another; post Go.

    Catches: a server that refuses a phase carrying Psyclone's `priority` attribute in range
    (a range test turned around, issue #15), and one that accepts a priority it cannot handle,
    so that the wakeups of the phase (whose PhaseSpec echoes it) are never sent.
    """
    body = triggers_xml(ctx.type("Go"))
    accepted = []
    for suffix, priority in (("In", "2.5"), ("Out", "7.5")):
        sub = await ctx.module(suffix)
        content = (
            f'<module name="{sub.name}"><context name="Psyclone.System.Ready">'
            f'<phase name="P" priority="{priority}">{body}</phase></context></module>'
        )
        reply = await sub.subscribe(content, check=priority == "2.5")
        if reply.type == "RECEIVE_ACCEPT":
            accepted.append(sub)
        else:
            check_error(
                ctx,
                reply,
                names=("REGISTRATION_INVALID",),
                what=f"a phase with priority {priority}",
                req="OA-REG-8",
            )
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Go"), "go")
    assert poster.last_sent is not None
    for sub in accepted:
        await sub.expect_wakeup_for(poster.last_sent.id)
