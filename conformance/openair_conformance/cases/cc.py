"""cc cases (spec 8.5): lists and white space, exact names, names that are not bound modules,
and the poster naming itself.

Every cc'd module registers an unrelated trigger first, so that Psyclone (which honours cc only
for registered modules, DEV-12) is judged on the rule each case is about.
"""

from __future__ import annotations

import asyncio

from openair_conformance.cases._common import (
    setup_subscribe,
    trigger_ids,
    triggers_xml,
)
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    wakeup_view,
)
from openair_conformance.registry import case


async def _registered(ctx: CaseContext, *suffixes: str) -> list[TestModule]:
    """Open modules and register each with a trigger that no case posts."""
    modules = list(await asyncio.gather(*(ctx.module(s) for s in suffixes)))
    for module in modules:
        await setup_subscribe(module, triggers_xml(ctx.type(f"Never.{module.suffix}")))
    return modules


async def _woken_by(module: TestModule, message_id: str) -> int:
    return trigger_ids(await module.barrier()).count(message_id)


@case(
    id="CC-003",
    title="cc is split at ';' with white space ignored and empty names skipped",
    section="8.5",
    requirements=("OA-CC-1", "OA-CC-2"),
    allowed=("A, B and C each woken exactly once",),
)
async def cc_list(ctx: CaseContext) -> None:
    """Post with cc `" A ; B;;\tC ;"` (the three module names).

    Catches: names not trimmed, empty names treated as errors, only the first name honoured.
    """
    a, b, c = await _registered(ctx, "A", "B", "C")
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("List"), "x", cc=f" {a.name} ; {b.name};;\t{c.name} ;")
    assert poster.last_sent is not None
    counts = [await _woken_by(m, poster.last_sent.id) for m in (a, b, c)]
    ctx.check(counts == [1, 1, 1], f"wakeups per module {counts}", expected="[1, 1, 1] (OA-CC-1)")


@case(
    id="CC-004",
    title="cc names are exact: other case, commas and spaces do not separate or match",
    section="8.5",
    requirements=("OA-CC-1",),
    allowed=(
        "neither module is woken by a cc of 'A,B', 'A B' or the names in lower case (names "
        "always hold capitals)",
    ),
)
async def cc_exact(ctx: CaseContext) -> None:
    """Post three messages with cc `A,B`, `A B` and both names lower-cased.

    Catches: cc split at commas or spaces (Psyclone splits only at ';'), case-insensitive names.
    """
    a, b = await _registered(ctx, "A", "B")
    poster = await ctx.module("Poster", bind=False)
    for cc in (f"{a.name},{b.name}", f"{a.name} {b.name}", f"{a.name.lower()};{b.name.lower()}"):
        await poster.post("WB1", ctx.type("Exact"), cc, cc=cc)
    woken = [len(await m.barrier()) for m in (a, b)]
    ctx.check(woken == [0, 0], f"wakeups per module {woken}", expected="[0, 0] (OA-CC-1)")


@case(
    id="CC-005",
    title="cc naming unbound names, whiteboards and components does not make the post fail",
    section="8.5",
    requirements=("OA-CC-3", "OA-CC-2"),
    allowed=("RECEIVE_ACCEPT; the bound module in the list is woken; the other names are skipped",),
)
async def cc_unbound(ctx: CaseContext) -> None:
    """Post with cc naming nobody, WB1, CNS, a module that closed, and one bound module.

    Catches: a post refused or dropped because one cc name cannot be woken.
    """
    (live,) = await _registered(ctx, "Live")
    gone = await ctx.module("Gone")
    await gone.close()
    poster = await ctx.module("Poster", bind=False)
    cc = f"{ctx.name('Nobody')};WB1;CNS;{gone.name};{live.name}"
    await poster.post("WB1", ctx.type("Unbound"), "x", cc=cc)
    assert poster.last_sent is not None
    ctx.check(
        await _woken_by(live, poster.last_sent.id) == 1,
        "the bound module was not woken",
        expected="OA-CC-2",
    )


@case(
    id="CC-006",
    title="A poster that names itself in cc is woken once, whatever its self-triggering",
    section="8.5",
    requirements=("OA-CC-4",),
    allowed=("exactly one wakeup for the post",),
)
async def cc_self(ctx: CaseContext) -> None:
    """Register a trigger that matches the post (self-triggering off); post with cc = self.

    Catches: cc suppressed by the self-triggering rule, or two wakeups (trigger and cc).
    """
    module = await ctx.module("M")
    await setup_subscribe(module, triggers_xml(ctx.type("Self")))
    await module.post("WB1", ctx.type("Self"), "me", cc=module.name)
    assert module.last_sent is not None
    ctx.check(
        await _woken_by(module, module.last_sent.id) == 1,
        "not woken exactly once",
        expected="OA-CC-4",
    )


# -- 8.5 cc: a wakeup due only to cc -----------------------------------------------------------


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
