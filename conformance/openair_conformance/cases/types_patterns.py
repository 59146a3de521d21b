"""Conformance cases for the character table, the pattern limits and literal characters (spec 5).

Every type and pattern lives under the case's own prefix (`ctx.type`), so the cases run in
parallel with others and against a server that keeps history.
"""

from __future__ import annotations

from openair_conformance.cases._common import check_error, esc, retrieved, triggers_xml
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case

#: Segments holding one character of the table of spec 5.1 (OA-TYPE-5), by category.
_REFUSED = (
    ("Cf", "Soft\u00adHyphen"),
    ("Cf", "Rlo\u202eX"),
    ("Cf", "Tag\U000e0041"),
    ("Co", "Private\ue000"),
    ("Zs", "Ideographic\u3000Space"),
)
#: Segments that are segment characters only: unassigned in Unicode 14.0.0, marks, symbols.
_ACCEPTED = (
    ("Cn", "Unassigned\u0378"),
    ("Cn in 14.0.0", "Later\U00013439"),
    ("Mn", "Mark\u00e9\u0301"),
    ("So", "Symbol\u00a9"),
)


@case(
    id="MATCH-020",
    title="Types are judged by the Unicode 14.0.0 category table, not by a 'printable' test",
    section="5.1",
    requirements=("OA-TYPE-5", "OA-TYPE-3", "OA-TYPE-1", "OA-WB-3"),
    allowed=(
        "RECEIVE_ERROR 'TYPE_INVALID: …' for a type with a Cc, Cf, Cs, Co, Zs, Zl or Zp character",
        "RECEIVE_ACCEPT for every other character, unassigned code points included",
    ),
)
async def category_table(ctx: CaseContext) -> None:
    """Post one type per excluded category, then types with unassigned and other characters.

    Catches: a server that lets format or private-use characters into types (U+00AD, U+202E,
    tag characters), or that refuses unassigned code points because its runtime's "printable"
    test does (Python's `isprintable`, Java's `Character.getType` of a newer Unicode).
    """
    poster = await ctx.module("Poster", bind=False)
    for category, segment in _REFUSED:
        reply = await poster.post("WB1", ctx.type(segment), "x", check=False)
        check_error(
            ctx,
            reply,
            names=("TYPE_INVALID",),
            what=f"a post whose type holds a {category} character ({segment!a})",
            req="OA-TYPE-5, OA-TYPE-3",
        )
    for category, segment in _ACCEPTED:
        reply = await poster.post("WB1", ctx.type(segment), "x", check=False)
        ctx.check(
            reply.type == "RECEIVE_ACCEPT",
            f"a type with a {category} character ({segment!a}) was answered "
            f"{reply.type} {reply.content!r}",
            expected="RECEIVE_ACCEPT: only the categories of the table of 5.1 are refused "
            "(OA-TYPE-5)",
        )
    found = await retrieved(
        ctx, poster, f'<retrieve from="WB1" type="{esc(ctx.type("*"))}" latest="0"/>'
    )
    types = {m.type for m in found}
    missing = [ascii(s) for _, s in _ACCEPTED if ctx.type(s) not in types]
    ctx.check(not missing, f"accepted types not stored: {missing}", expected="OA-TYPE-5, OA-WB-3")


def _at_limits(prefix: str, last: str) -> str:
    """Return `prefix.L…L.S.….S.<last>` of exactly 32 segments and 255 UTF-8 bytes."""
    head = prefix.split(".")
    fillers = 32 - len(head) - 2  # the L segment and `last`
    text = ".".join([*head, "L", *(["S"] * fillers), last])
    return text.replace(".L.", "." + "L" * (1 + 255 - len(text.encode())) + ".", 1)


@case(
    id="MATCH-021",
    title="A pattern of 255 bytes and 32 segments is accepted in a trigger and a retrieve",
    section="5.2",
    requirements=("OA-MATCH-9", "OA-REG-7", "OA-RET-7", "OA-TYPE-4"),
    allowed=("RECEIVE_ACCEPT to the registration, the wakeup, and the retrieve's result",),
)
async def pattern_at_limits(ctx: CaseContext) -> None:
    """Register a 255-byte, 32-segment trigger pattern, post a type it matches, retrieve it.

    Catches: a server whose pattern limit is below the type limits of OA-TYPE-4 (for example
    counting the `*`s, or a bound of 254 bytes or 31 segments).
    """
    pattern = _at_limits(ctx.type_prefix(), "*")
    type_ = _at_limits(ctx.type_prefix(), "Z")
    if len(pattern.encode()) != 255 or pattern.count(".") != 31:
        ctx.fail(f"harness: built a pattern of {len(pattern.encode())} bytes", expected="255")
    module = await ctx.module("M")
    reply = await module.subscribe(triggers_xml(pattern))
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"a trigger pattern of 255 bytes and 32 segments was answered {reply.type} "
        f"{reply.content!r}",
        expected="RECEIVE_ACCEPT (OA-MATCH-9, OA-REG-7)",
    )
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", type_, "at the limits")
    await module.expect_wakeup(what="the wakeup of the 255-byte pattern")
    found = await retrieved(ctx, poster, f'<retrieve from="WB1" type="{esc(pattern)}"/>')
    ctx.check(
        [m.type for m in found] == [type_],
        f"the retrieve with the 255-byte pattern returned {[m.type for m in found]}",
        expected="the post (OA-MATCH-9, OA-RET-7)",
    )


#: (pattern suffix, the only posted type suffix it may select) — OA-MATCH-10.
_LITERALS = (("[A&&B]", "[A&&B]"), ("[^A]", "[^A]"), ("A+", "A+"), ("\\d", "\\d"))
_POSTED = ("[A&&B]", "A", "B", "&", "[^A]", "C", "A+", "AA", "\\d", "1")


@case(
    id="MATCH-022",
    title="Pattern characters other than '*' are literal: no classes, escapes or operators",
    section="5.2",
    requirements=("OA-MATCH-10", "OA-MATCH-2", "OA-RET-3"),
    allowed=("each retrieve returns exactly the type spelled like its pattern",),
)
async def no_character_classes(ctx: CaseContext) -> None:
    """Post types such as `[A&&B]`, `A`, `&`, then retrieve with the star-less patterns.

    Catches: a matcher built on a regular-expression engine without escaping, where `[A&&B]`
    is a class (Java's intersection), `[^A]` a negated class, `A+` a repetition and `\\d` a
    digit.
    """
    poster = await ctx.module("Poster", bind=False)
    for suffix in _POSTED:
        await poster.post("WB1", ctx.type(suffix), suffix)
    for pattern, only in _LITERALS:
        spec = f'<retrieve from="WB1" type="{esc(ctx.type(pattern))}" latest="0"/>'
        found = [m.type for m in await retrieved(ctx, poster, spec)]
        ctx.check(
            found == [ctx.type(only)],
            f"type={ctx.type(pattern)!r} returned {found}",
            expected=f"only {ctx.type(only)!r}: every character but '*' is literal (OA-MATCH-10)",
        )
