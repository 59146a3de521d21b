"""Context cases (spec 8.9, extension `contexts`): roots, the phase in force, phase updates,
phase sequencing and when a context post's own wakeups are decided. CTX-001 is in wakeups.py.

Every context name starts with a root unique to the run (`ConfR<run>…`), so the cases never
touch `Psyclone.System.Ready`, which every other case depends on.
"""

from __future__ import annotations

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    setup_subscribe,
    trigger_ids,
    triggers_xml,
    view_of,
    woken_by,
)
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.registry import case

PHASE_CHANGE = "Psyclone.Module.Report.PhaseChange"


def _module(name: str, phases: list[tuple[str, str, str]]) -> str:
    """Return a form-3 registration: (context, phase id, trigger type) per phase, in order."""
    groups: dict[str, list[str]] = {}
    for context, phase, type_ in phases:
        groups.setdefault(context, []).append(f'<phase id="{phase}">{triggers_xml(type_)}</phase>')
    inner = "".join(f'<context name="{c}">{"".join(p)}</context>' for c, p in groups.items())
    return f'<module name="{name}">{inner}</module>'


async def _switch(poster: TestModule, context: str) -> None:
    await poster.post("WB1", f"Psyclone.Context:{context}", "switch")


def _last_update(ctx: CaseContext, sub: TestModule, before: int, when: str) -> Message:
    ctx.check(
        len(sub.phase_updates) > before,
        f"no phase update {when}",
        expected="a phase update when the phase in force changes (OA-REG-15)",
    )
    return sub.phase_updates[-1]


@case(
    id="CTX-002",
    title="Contexts: roots are independent; the context that came into force last wins",
    section="8.9",
    requirements=("OA-REG-13", "OA-REG-14"),
    needs=("contexts",),
    allowed=(
        "woken by X, then Y, Y after refining X's root, Y after replacing X, X on its return",
    ),
)
async def roots_and_recency(ctx: CaseContext) -> None:
    """Phases in `<r1>.X` and `<r2>.Y` (two roots); activate X, then Y, refine X's root, replace
    X, activate X again (spelled `x`); post both trigger types after each step.

    Catches: one active context for all roots, the first listed context in force instead of the
    latest, a refinement (a descendant) taken as a new activation of its ancestor, context names
    compared case-sensitively.
    """
    r1, r2 = f"ConfR{ctx.run_id}Ca", f"ConfR{ctx.run_id}Cb"
    sub = await ctx.module("Sub")
    phases = [(f"{r1}.X", "PX", ctx.type("X")), (f"{r2}.Y", "PY", ctx.type("Y"))]
    await setup_subscribe(sub, _module(sub.name, phases))
    poster = await ctx.module("Poster", bind=False)
    steps = (
        (f"{r1}.X", ["X"]),
        (f"{r2}.Y", ["Y"]),
        (f"{r1}.X.Deep", ["Y"]),
        (f"{r1}.Z", ["Y"]),
        (f"{r1}.x", ["X"]),  # the same context, another case
    )
    for context, want in steps:
        await _switch(poster, context)
        got = await woken_by(ctx, sub, poster, ["X", "Y"])
        ctx.check(
            got == want,
            f"after {context}: woken by {got}",
            expected=f"{want} (OA-REG-13, OA-REG-14)",
        )


@case(
    id="CTX-003",
    title="Contexts: phase updates carry the new phase, or nothing out of context; cc still wakes",
    section="8.9",
    requirements=("OA-REG-15", "OA-REG-14", "OA-WAKE-9"),
    needs=("contexts",),
    # It counts phase updates: alone, so that no other case's context change can add one (a
    # server that sends an update on every context change would hide a missing one otherwise).
    serial=True,
    allowed=(
        "a PhaseSpec naming PAB in <r>.A.B after <r>.A.B (deeper context on a tie)",
        "an empty <objectdictionary/> after <r>.Other, and a cc'd post still wakes the module",
    ),
)
async def phase_updates(ctx: CaseContext) -> None:
    """Phases in `<r>.A` and `<r>.A.B`; post a message cc'd to the module (no context in force);
    activate `<r>.A.B`, then `<r>.Other`, then `<r>.A`; read the phase update after each and
    post the trigger types.

    Catches: no phase update on a change, an out-of-context update that still holds a PhaseSpec,
    the shallower context chosen on a tie, cc ignored for a module out of context.
    """
    root = f"ConfR{ctx.run_id}Cu"
    sub = await ctx.module("Sub")
    phases = [(f"{root}.A", "PA", ctx.type("A")), (f"{root}.A.B", "PAB", ctx.type("AB"))]
    await setup_subscribe(sub, _module(sub.name, phases))
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Cc"), "cc", cc=sub.name)  # OA-REG-14: out of context
    assert poster.last_sent is not None
    await sub.expect_wakeup_for(poster.last_sent.id)
    for context, phase, want in ((f"{root}.A.B", "PAB", ["AB"]), (f"{root}.A", "PA", ["A"])):
        if phase == "PA":
            before = len(sub.phase_updates)
            await _switch(poster, f"{root}.Other")
            await sub.barrier()
            out = view_of(ctx, _last_update(ctx, sub, before, f"after {root}.Other"))
            ctx.check(
                out.objects == (),
                f"out-of-context update holds {out.objects}",
                expected="an empty <objectdictionary/> (OA-REG-15)",
            )
        before = len(sub.phase_updates)
        await _switch(poster, context)
        got = await woken_by(ctx, sub, poster, ["A", "AB"])
        ctx.check(got == want, f"after {context}: woken by {got}", expected=f"{want} (OA-REG-14)")
        view = view_of(ctx, _last_update(ctx, sub, before, f"after {context}"))
        named = (view.phase_attr("name"), view.phase_attr("context"))
        ctx.check(
            named == (phase, context),
            f"after {context}: phase update names {named}",
            expected=f"{(phase, context)} (OA-REG-15)",
        )


@case(
    id="CTX-004",
    title="Contexts: PhaseChange advances to the next phase, wraps; re-entry starts at the first",
    section="8.9",
    requirements=("OA-REG-17", "OA-REG-15"),
    needs=("contexts",),
    residue=True,  # PhaseChange is a system type outside the run's names: it runs last
    allowed=("woken by T1, T2, T3, T1 as the module reports phase changes; T1 after re-entry",),
)
async def phase_sequencing(ctx: CaseContext) -> None:
    """Three phases in `<r>.S`; activate it, post PhaseChange from the module three times, then
    advance once, leave to `<r>.T` and come back.

    Catches: PhaseChange ignored, no wrap after the last phase, the position kept across a
    re-entry of the context, no phase update on a phase change.
    """
    root = f"ConfR{ctx.run_id}Cs"
    sub = await ctx.module("Sub")
    names = ["T1", "T2", "T3"]
    phases = [(f"{root}.S", f"P{i}", ctx.type(n)) for i, n in enumerate(names, 1)]
    await setup_subscribe(sub, _module(sub.name, phases))
    poster = await ctx.module("Poster", bind=False)
    await _switch(poster, f"{root}.S")
    got = [await woken_by(ctx, sub, poster, names)]
    for _ in range(3):
        before = len(sub.phase_updates)
        await sub.post("WB1", PHASE_CHANGE, "")
        got.append(await woken_by(ctx, sub, poster, names))
        _last_update(ctx, sub, before, "after PhaseChange")
    await sub.post("WB1", PHASE_CHANGE, "")
    await _switch(poster, f"{root}.T")
    await _switch(poster, f"{root}.S")
    got.append(await woken_by(ctx, sub, poster, names))
    want = [["T1"], ["T2"], ["T3"], ["T1"], ["T1"]]
    ctx.check(got == want, f"woken by {got}", expected=f"{want} (OA-REG-17)")


@case(
    id="CTX-005",
    title="Contexts: a context post wakes the triggers of the phase it brings into force",
    section="8.9",
    requirements=("OA-REG-18",),
    needs=("contexts",),
    allowed=("the module is woken by the Psyclone.Context post that activated its phase",),
)
async def context_post_wakes(ctx: CaseContext) -> None:
    """A phase in `<r>.Go` triggered by `Psyclone.Context:<r>.Go`; post that context.

    Catches: the change applied after the post's own wakeups were decided (the phase's
    bootstrap trigger would never fire).
    """
    context = f"ConfR{ctx.run_id}Cw.Go"
    sub = await ctx.module("Sub")
    await setup_subscribe(sub, _module(sub.name, [(context, "PGo", f"Psyclone.Context:{context}")]))
    poster = await ctx.module("Poster", bind=False)
    await _switch(poster, context)
    assert poster.last_sent is not None
    woken = poster.last_sent.id in trigger_ids(await sub.barrier())
    ctx.check(woken, "not woken by its context's post", expected="woken (OA-REG-18)")
