"""Conformance cases for retrieve criteria at their boundaries (spec 9.2, issue #15): white
space in content globs, and criteria that must all hold (OA-RET-3).

White space around text content is part of the text a `content` glob sees (OA-RET-8,
OA-RET-18): a glob without `*` matches the whole text, spaces included.
"""

from __future__ import annotations

from openair_conformance.cases._common import esc, retrieved
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case

#: The posted text: spaces before and after, two inside.
_PADDED = "  pad  me  "


@case(
    id="RET-023",
    title="A content glob sees the text with its leading and trailing white space",
    section="9.2",
    requirements=("OA-RET-8", "OA-RET-18", "OA-RET-3"),
    allowed=(
        "the whole text '  pad  me  ' and '*pad  me*' select the post; 'pad  me', '*pad  me', "
        "'pad  me*' and '  pad me  ' do not",
    ),
)
async def content_glob_whitespace(ctx: CaseContext) -> None:
    """Post text content with spaces around it; retrieve with globs with and without them.

    Catches: content stripped before a glob is matched (or when it is stored), white space
    runs collapsed, a glob matched as a substring.
    """
    poster = await ctx.module("Poster", bind=False)
    kind = ctx.type("Padded")
    await poster.post("WB1", kind, _PADDED)
    checks = (
        (_PADDED, True),
        ("*pad  me*", True),
        ("pad  me", False),
        ("*pad  me", False),
        ("pad  me*", False),
        ("  pad me  ", False),
    )
    for glob, want in checks:
        spec = f'<retrieve from="WB1" type="{esc(kind)}" content="{esc(glob)}"/>'
        found = await retrieved(ctx, poster, spec, req="OA-RET-7, OA-RET-8")
        got = any(m.type == kind for m in found)
        ctx.check(
            got == want,
            f"content={glob!r} {'selected' if got else 'did not select'} the text {_PADDED!r}",
            expected=f"{'selected' if want else 'not selected'}: the whole text, spaces "
            "included, must match (OA-RET-8, OA-RET-18)",
        )


@case(
    id="RET-024",
    title="Every criterion of a retrieve must hold: type with id, sender or content",
    section="9.2",
    requirements=("OA-RET-3",),
    allowed=(
        "the post is selected by its type with its own id, sender and content, together or in "
        "pairs; never when one of them names something else",
    ),
)
async def criteria_all_hold(ctx: CaseContext) -> None:
    """Post one message; retrieve it by its type paired with each other criterion, matching
    and not, and by all of them together.

    Catches: criteria ORed, or only the first criterion (type) applied when there are two.
    """
    poster = await ctx.module("Poster", bind=False)
    kind = esc(ctx.type("Both"))
    await poster.post("WB1", ctx.type("Both"), "alpha")
    assert poster.last_sent is not None
    sent = poster.last_sent
    me, other = esc(poster.name), esc(ctx.name("Other"))
    own = f'id="{esc(sent.id)}" sender="{me}" content="alpha"'
    checks = (
        (f'id="{esc(sent.id)}"', True),
        (f'id="{esc(sent.id)}x"', False),
        (f'sender="{me}"', True),
        (f'sender="{other}"', False),
        ('content="alpha"', True),
        ('content="beta"', False),
        (own, True),
        (own.replace('content="alpha"', 'content="alph"'), False),
    )
    for attrs, want in checks:
        spec = f'<retrieve from="WB1" type="{kind}" {attrs}/>'
        found = await retrieved(ctx, poster, spec, req="OA-RET-3")
        got = any(m.id == sent.id for m in found)
        ctx.check(
            got == want,
            f"type with {attrs} {'selected' if got else 'did not select'} the post",
            expected=f"{'selected' if want else 'not selected'}: every criterion must hold "
            "(OA-RET-3)",
        )
