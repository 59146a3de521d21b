"""Edges of the system components' commands (spec 6.2–6.4, 3.4): how CNS writes the content
objects of its replies.
"""

from __future__ import annotations

from openair.protocol.message import Message
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import WakeupUnreadable, attributes, content_object
from openair_conformance.registry import case


@case(
    id="SESS-060",
    title="RESOLVE_SUCCESS carries its <tcplocation> as XML content (language xml), not as text",
    section="6.4",
    requirements=("OA-SESS-8", "OA-MSG-12", "OA-MSG-10"),
    allowed=(
        "RESOLVE_SUCCESS for AIRCentral, WB1 and CNS whose content has language='xml' (any case) "
        "and is one <tcplocation> naming the resolved name",
    ),
)
async def resolve_location_is_xml(ctx: CaseContext) -> None:
    """Resolve AIRCentral, WB1 and CNS; read each reply's content language and object.

    Catches: a tcplocation written as escaped text (language empty or a natural language),
    which OA-MSG-10 makes text a receiver must not read as the content object OA-SESS-8 and
    OA-MSG-12 require (3.4: the objects appear inside `<content language="xml">`).
    """
    raw = await ctx.raw()
    for name in ("AIRCentral", "WB1", "CNS"):
        request = Message(type="RESOLVE_REQUEST", sender=ctx.name("R"), to="CNS", content=name)
        reply = await raw.request(request)
        ctx.check(
            reply.type == "RESOLVE_SUCCESS",
            f"RESOLVE of {name}: {reply.type}",
            expected="RESOLVE_SUCCESS (OA-SESS-8)",
        )
        ctx.check(
            reply.content_is_xml and reply.language.lower() == "xml",
            f"RESOLVE_SUCCESS for {name} has content language {reply.language!r}",
            expected="language='xml': the <tcplocation> is a content object (OA-MSG-12, OA-MSG-10)",
        )
        try:
            location = attributes(content_object(reply, "tcplocation"))
        except WakeupUnreadable as exc:
            ctx.fail(f"RESOLVE_SUCCESS for {name}: {exc}", expected="one <tcplocation> (OA-SESS-8)")
        ctx.check(
            location.get("name") == name,
            f"RESOLVE_SUCCESS for {name} names {location.get('name')!r}",
            expected=f"name='{name}' (OA-SESS-8)",
        )
