"""Content cases (spec 3.3): XML content that holds stray text is kept, not refused.

JavaOpenAIR sends retrieves and registrations as `language="xml"` content even when the content
is plain text (`garbage`); the envelope is still valid, and only the command that reads the
content may fail (OA-MSG-18).
"""

from __future__ import annotations

from openair_conformance.cases._common import (
    check_error,
    esc,
    message_xml,
    retrieved,
    send_xml,
)
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case


@case(
    id="MSG-017",
    title="XML content with stray text is stored as received; commands fail with their own error",
    section="3.3",
    requirements=("OA-MSG-18", "OA-MSG-10"),
    allowed=(
        "RECEIVE_ACCEPT for the post, whose stored copy keeps the text and the element",
        "RECEIVE_ERROR 'REGISTRATION_INVALID: …' for AIR.Subscribe with XML content 'garbage'",
        "AIR.Retrieve.Failed 'RETRIEVE_INVALID: …' for AIR.Retrieve with XML content 'garbage'",
    ),
)
async def stray_text(ctx: CaseContext) -> None:
    """Post XML content `hello <b>x</b> tail`; read the stored copy. Then send AIR.Subscribe
    and AIR.Retrieve whose XML content is the text `garbage`.

    Catches: a message refused as XML_MALFORMED or MESSAGE_INVALID because its XML content is
    not only elements, stray text dropped from the stored copy, and commands that report an
    envelope error instead of their own failure.
    """
    raw = await ctx.raw()
    ident = ctx.name("Stray")
    body = '<content language="xml">hello <b>x</b> tail</content>'
    xml = message_xml(
        ctx.type("Stray"), to="WB1", sender=ctx.name("F"), id=ident, content=None, body=body
    )
    reply = await send_xml(raw, xml)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"the post got {reply.type} {reply.content!r}",
        expected="OA-MSG-18",
    )
    client = await ctx.module("C", bind=False)
    found = await retrieved(ctx, client, f'<retrieve from="WB1" id="{esc(ident)}"/>')
    content = found[0].content if len(found) == 1 else None
    kept = content is not None and all(part in content for part in ("hello", "<b>x</b>", "tail"))
    ctx.check(
        kept, f"the stored content is {content!r}", expected="the content as received (OA-MSG-18)"
    )
    for command, types, name in (
        ("AIR.Subscribe", ("RECEIVE_ERROR",), "REGISTRATION_INVALID"),
        ("AIR.Retrieve", ("AIR.Retrieve.Failed",), "RETRIEVE_INVALID"),
    ):
        body = '<content language="xml">garbage</content>'
        xml = message_xml(command, to="AIRCentral", sender=client.name, content=None, body=body)
        reply = await send_xml(raw, xml)
        check_error(
            ctx, reply, types=types, names=(name,), what=f"{command} 'garbage'", req="OA-MSG-18"
        )
