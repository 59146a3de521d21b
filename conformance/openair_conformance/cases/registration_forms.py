"""Registration forms at their edges (spec 8.2, 8.7; issue #15): the informative children of a
phase, a phase priority at the bottom of its range, a `<spec>` that holds something other than
contexts, and how PhaseSpec echoes a trigger's `alias` and `maxpriority`.
"""

from __future__ import annotations

from openair.protocol.message import Message
from openair_conformance.cases._common import check_error, triggers_xml
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import content_root
from openair_conformance.registry import case


async def _go(ctx: CaseContext, sub: TestModule, name: str = "Go") -> Message:
    """Post `name` to WB1 from another client; return the wakeup `sub` gets for it."""
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type(name), "go")
    assert poster.last_sent is not None
    return await sub.expect_wakeup_for(poster.last_sent.id)


@case(
    id="REG-040",
    title="A phase's informative children (description, posts, crank) are accepted and ignored",
    section="8.2",
    requirements=("OA-REG-4", "OA-REG-7"),
    allowed=("RECEIVE_ACCEPT and a wakeup for Go",),
)
async def phase_informative_children(ctx: CaseContext) -> None:
    """Register a form-3 phase holding `<description>`, `<posts>` and `<crank>` beside its
    triggers; post Go.

    Catches: a server that refuses the psySpec parts of a phase it does not implement (the
    set of ignored children emptied, issue #15) instead of ignoring them.
    """
    sub = await ctx.module("Sub")
    content = (
        f'<module name="{sub.name}"><spec><context name="Psyclone.System.Ready">'
        f'<phase name="P"><description>informative</description>'
        f'<posts><post type="{ctx.type("Out")}" to="WB1"/></posts><crank name="c"/>'
        f"{triggers_xml(ctx.type('Go'))}</phase></context></spec></module>"
    )
    await sub.subscribe(content, check=True)
    await _go(ctx, sub)


@case(
    id="REG-041",
    title="A phase priority of 0.0, the bottom of its range, is accepted and works",
    section="8.2",
    requirements=("OA-REG-4", "OA-REG-12", "OA-REG-7", "OA-WAKE-4"),
    allowed=("RECEIVE_ACCEPT and a wakeup for Go with a PhaseSpec <phase>",),
)
async def phase_priority_zero(ctx: CaseContext) -> None:
    """Register a root `<phase priority="0.0">`; post Go.

    Catches: a range test that excludes 0.0 (`0.0 < p` for `0.0 <= p`, issue #15), refusing
    the registration or failing to write the PhaseSpec that echoes the priority.
    """
    sub = await ctx.module("Sub")
    content = f'<phase name="P" priority="0.0">{triggers_xml(ctx.type("Go"))}</phase>'
    await sub.subscribe(content, check=True)
    wakeup = await _go(ctx, sub)
    phases = [el for root in content_root(wakeup) for el in root.iter("{*}phase", "phase")]
    ctx.check(
        len(phases) == 1,
        f"the wakeup holds {len(phases)} <phase> elements",
        expected="one <phase> in PhaseSpec (OA-WAKE-4)",
    )


@case(
    id="REG-042",
    title="A <spec> holding something other than <context> is refused",
    section="8.3",
    requirements=("OA-REG-4", "OA-REG-8"),
    allowed=("RECEIVE_ERROR 'REGISTRATION_INVALID: …'",),
)
async def spec_without_context(ctx: CaseContext) -> None:
    """Register `<module><spec><scene name="Psyclone.System.Ready"><phase>…` (a context-shaped
    element of another name inside `<spec>`).

    Catches: a server that reads any child of `<spec>` as a context (the name test turned
    around, issue #15), so that content of none of the five forms is accepted.
    """
    sub = await ctx.module("Sub")
    content = (
        f'<module name="{sub.name}"><spec><scene name="Psyclone.System.Ready">'
        f'<phase name="P">{triggers_xml(ctx.type("Go"))}</phase></scene></spec></module>'
    )
    reply = await sub.subscribe(content)
    check_error(
        ctx,
        reply,
        names=("REGISTRATION_INVALID",),
        what="a <spec> holding <scene>",
        req="OA-REG-8",
    )


@case(
    id="WAKE-040",
    title="PhaseSpec echoes a trigger's alias, and no alias or maxpriority it does not have",
    section="8.7",
    requirements=("OA-WAKE-4",),
    allowed=(
        'the Go trigger with alias="Eye"; the Other trigger without alias and maxpriority',
        "extra <phase> attributes and children (pid, priority, currentcontexts, …)",
    ),
)
async def phase_spec_alias(ctx: CaseContext) -> None:
    """Register Go with `alias="Eye"` and Other without alias or maxpriority; post Go and read
    the PhaseSpec's triggers.

    Catches: an echo that drops the alias, or writes attributes a trigger does not have (an
    empty alias, `maxpriority="None"`: a test turned around, issue #15).
    """
    sub = await ctx.module("Sub")
    go, other = ctx.type("Go"), ctx.type("Other")
    content = (
        f'<triggers><trigger from="WB1" type="{go}" alias="Eye"/>'
        f'<trigger from="WB1" type="{other}"/></triggers>'
    )
    await sub.subscribe(content, check=True)
    wakeup = await _go(ctx, sub)
    echoed: dict[str, dict[str, str]] = {}
    for root in content_root(wakeup):
        for phase in root.iter("{*}phase", "phase"):
            for el in phase.iter("{*}trigger", "trigger"):
                attrs = {str(k).lower(): str(v) for k, v in el.attrib.items()}
                echoed[attrs.get("type", "")] = attrs
    if go not in echoed or other not in echoed:
        ctx.fail(
            f"the PhaseSpec triggers are {sorted(echoed)}",
            expected=f"both {go!r} and {other!r} (OA-WAKE-4)",
        )
    ctx.check(
        echoed[go].get("alias") == "Eye",
        f"the {go} trigger is echoed with {echoed[go]}",
        expected='alias="Eye", as registered (OA-WAKE-4)',
    )
    extra = sorted(set(echoed[other]) & {"alias", "maxpriority"})
    ctx.check(
        not extra,
        f"the {other} trigger is echoed with {echoed[other]}",
        expected="no alias or maxpriority: the registered trigger has neither (OA-WAKE-4)",
    )
