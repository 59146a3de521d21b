"""Conformance case for the range of the `wbid` slot a receiver accepts (spec 3.2, OA-MSG-13)."""

from __future__ import annotations

from openair_conformance.cases._common import esc, message_xml, retrieved, send_xml
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case

#: `wbid` values a receiver accepts: any width, leading zeros, up to 2^63 - 1 (OA-MSG-13).
_WBIDS = (("Wide", "0" * 20 + "9876543210"), ("Max", str(2**63 - 1)), ("Above32", str(2**32 + 5)))


@case(
    id="MSG-025",
    title="A post carrying a wide or 2^63 - 1 wbid is accepted; the stored copy has the board's",
    section="3.2",
    requirements=("OA-MSG-13", "OA-WB-4", "OA-WB-5"),
    allowed=("RECEIVE_ACCEPT to each post; stored copies numbered by the whiteboard",),
)
async def wbid_range(ctx: CaseContext) -> None:
    """Post three messages whose `wbid` slot is 30 digits wide, 2^63 - 1 and 2^32 + 5.

    A receiver accepts every non-negative wbid up to 2^63 - 1 in any width; a whiteboard then
    numbers its stored copy itself.
    Catches: a server that reads wbid into a 32-bit field or limits its digits, and so refuses
    a message a relay or a replaying client legitimately carries.
    """
    raw = await ctx.raw("Poster")
    for suffix, wbid in _WBIDS:
        body = f'<postedTime sec="1795328371" msec="0"/><wbid>{wbid}</wbid>'
        xml = message_xml(ctx.type(suffix), to="WB1", sender=ctx.name("Poster"), body=body)
        reply = await send_xml(raw, xml)
        ctx.check(
            reply.type == "RECEIVE_ACCEPT",
            f"a post with <wbid>{wbid}</wbid> was answered {reply.type} {reply.content!r}",
            expected="RECEIVE_ACCEPT: any width, values up to 2^63 - 1 (OA-MSG-13)",
        )
    reader = await ctx.module("Reader", bind=False)
    spec = f'<retrieve from="WB1" type="{esc(ctx.type("*"))}" latest="0"/>'
    found = await retrieved(ctx, reader, spec)
    numbers = sorted(m.wbid for m in found if m.wbid is not None)
    ctx.check(
        len(numbers) == len(_WBIDS) and len(set(numbers)) == len(numbers),
        f"stored copies numbered {numbers}",
        expected="one stored copy each, numbered by the whiteboard (OA-WB-4, OA-WB-5)",
    )
    posted = {int(w) for _, w in _WBIDS}
    ctx.check(
        not posted & set(numbers),
        f"a stored copy kept the poster's wbid: {sorted(posted & set(numbers))}",
        expected="the whiteboard's own wbid on each stored copy (OA-WB-4, OA-WB-5)",
    )
