"""Conformance cases for what a retrieve `content` glob is matched against (spec 9.2).

The posts go out as hand-written XML on a raw connection, so that the server sees exactly the
indentation, quoting, `<c></c>` spelling, comments and CDATA the case chose (the harness's own
writer would normalise them first). The globs then name the canonical XML text (OA-RET-17) or
the text content (OA-RET-18) exactly, without `*` where that matters.
"""

from __future__ import annotations

from openair_conformance.cases._common import esc, message_xml, retrieved, send_xml
from openair_conformance.harness import CaseContext, RawConnection, TestModule
from openair_conformance.registry import case

#: (suffix of the type, XML content as posted, canonical XML text, text content); spec 9.2.
_POSTS = (
    ("Indented", "<a  x='1'>\n  <b>y</b>\n  <c></c>\n</a>", '<a x="1"><b>y</b><c/></a>', "y"),
    ("Siblings", "<a>x</a>\n <b>y</b>", "<a>x</a><b>y</b>", "xy"),
    ("Comment", "<a>x <!--n--> y</a>", "<a>x  y</a>", "x  y"),
    ("Cdata", "<a q='\"'><![CDATA[<&>]]><?pi z?></a>", '<a q="&quot;">&lt;&amp;&gt;</a>', "<&>"),
    (
        "Ns",
        '<p:a xmlns:p="urn:p"><p:b>t</p:b>\n</p:a>',
        '<p:a xmlns:p="urn:p"><p:b>t</p:b></p:a>',
        "t",
    ),
)


async def _post_raw(ctx: CaseContext, raw: RawConnection, type_: str, xml_content: str) -> None:
    """Post `xml_content` verbatim as XML content to WB1; Fail unless RECEIVE_ACCEPT."""
    body = f'<postedTime sec="1795328371" msec="0"/><content language="xml">{xml_content}</content>'
    xml = message_xml(type_, to="WB1", sender=ctx.name("Poster"), body=body, content=None)
    reply = await send_xml(raw, xml)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"the post of {type_} was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT (OA-WB-3)",
    )


async def _selects(
    ctx: CaseContext, reader: TestModule, type_: str, glob: str, *, xml: bool
) -> bool:
    """Return whether a retrieve of `type_` with this content glob returns the post."""
    match = ' contentmatch="xml"' if xml else ""
    spec = f'<retrieve from="WB1" type="{esc(type_)}" content="{esc(glob)}"{match} latest="0"/>'
    found = await retrieved(ctx, reader, spec, req="OA-RET-7, OA-RET-13")
    return any(m.type == type_ for m in found)


@case(
    id="RET-020",
    title="contentmatch='xml' globs see the canonical XML text: no indentation, <c/> not <c></c>",
    section="9.2",
    requirements=("OA-RET-13", "OA-RET-17", "OA-RET-3"),
    allowed=("exactly the canonical XML text of OA-RET-17, whatever spelling the poster used",),
)
async def xml_canonical_text(ctx: CaseContext) -> None:
    """Post five XML contents verbatim, then retrieve each with its canonical XML text.

    Each glob is the whole canonical text without `*`, so one character of difference (an
    indentation kept, `<c></c>`, single quotes, a comment or CDATA kept) loses the message.
    Then `*<c/>*` must select the first post and `*<c></c>*` must not.
    Catches: a server that matches the XML as the poster wrote it, or as its XML library
    serializes it.
    """
    raw = await ctx.raw("Poster")
    for suffix, content, _, _ in _POSTS:
        await _post_raw(ctx, raw, ctx.type(suffix), content)
    reader = await ctx.module("Reader", bind=False)
    for suffix, content, canonical, _ in _POSTS:
        ctx.check(
            await _selects(ctx, reader, ctx.type(suffix), canonical, xml=True),
            f"content={canonical!r} contentmatch='xml' did not select the post of {content!r}",
            expected=f"the canonical XML text is {canonical!r} (OA-RET-17, OA-RET-13)",
        )
    first = ctx.type(_POSTS[0][0])
    ctx.check(
        await _selects(ctx, reader, first, "*<c/>*", xml=True),
        "content='*<c/>*' did not select <c></c>",
        expected="an empty element is written <c/> (OA-RET-17)",
    )
    ctx.check(
        not await _selects(ctx, reader, first, "*<c></c>*", xml=True),
        "content='*<c></c>*' selected the post",
        expected="an empty element is written <c/>, never <c></c> (OA-RET-17)",
    )


@case(
    id="RET-021",
    title="Plain content globs see the text content: kept text runs joined without separators",
    section="9.2",
    requirements=("OA-RET-8", "OA-RET-18", "OA-RET-13"),
    allowed=("exactly the text content of OA-RET-18",),
)
async def xml_text_content(ctx: CaseContext) -> None:
    """Post five XML contents verbatim, then retrieve each with its whole text content.

    `<a>x</a> <b>y</b>` has the text content `xy` (white space between elements is not text), so
    `x y` must not select it; the comment case keeps both spaces around the comment; CDATA is
    text; attribute values are not.
    Catches: a server that joins element texts with a space, keeps indentation as text, drops
    CDATA or matches attribute values.
    """
    raw = await ctx.raw("Poster")
    for suffix, content, _, _ in _POSTS:
        await _post_raw(ctx, raw, ctx.type(suffix), content)
    reader = await ctx.module("Reader", bind=False)
    for suffix, content, _, text in _POSTS:
        ctx.check(
            await _selects(ctx, reader, ctx.type(suffix), text, xml=False),
            f"content={text!r} did not select the post of {content!r}",
            expected=f"the text content is {text!r} (OA-RET-18, OA-RET-8)",
        )
    siblings = ctx.type("Siblings")
    ctx.check(
        not await _selects(ctx, reader, siblings, "x y", xml=False),
        "content='x y' selected <a>x</a> <b>y</b>",
        expected="the text content is 'xy': no separator between text runs (OA-RET-18)",
    )
    ctx.check(
        not await _selects(ctx, reader, ctx.type("Cdata"), '*"*', xml=False),
        "content='*\"*' selected a post whose only '\"' is an attribute value",
        expected="attribute values are not text content (OA-RET-18)",
    )
