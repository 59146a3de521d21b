"""Conformance cases for the times a whiteboard stamps (spec 4, issue #15).

The stored copy carries the receivedTime the whiteboard stamped (OA-TIME-3), to the
millisecond: read against the server's own clock (GET_TIME, extension `gettime`), a receipt
time lies between a GET_TIME answered before the post and one answered after it.
"""

from __future__ import annotations

from openair_conformance.cases._common import cns_request, esc, retrieved
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import attributes, content_root
from openair_conformance.registry import case

#: Posts bracketed; a receivedTime rounded to the second escapes the bracket unless the post
#: happened within the first milliseconds of a second, so three posts make that certain.
_POSTS = 3


async def _server_ms(ctx: CaseContext, client: TestModule) -> int:
    """Return the server's clock in ms from a GET_TIME answer (Fail unless TIME)."""
    reply = await client.request(cns_request(ctx, "GET_TIME"))
    ctx.check(reply.type == "TIME", f"GET_TIME: {reply.type}", expected="TIME (OA-EXT-2)")
    roots = content_root(reply)
    attrs = attributes(roots[0]) if roots else {}
    ctx.check(
        attrs.get("sec", "").isdigit() and (attrs.get("msec", "0") or "0").isdigit(),
        f"TIME attributes {attrs}",
        expected="<time sec msec/> (OA-EXT-2)",
    )
    return int(attrs["sec"]) * 1000 + int(attrs.get("msec", "0") or "0")


@case(
    id="TIME-001",
    title="receivedTime is the server's clock at receipt, to the millisecond",
    section="4",
    requirements=("OA-TIME-3", "OA-WB-4"),
    needs=("gettime",),
    allowed=(
        "for each of three posts, GET_TIME before <= the stored copy's receivedTime <= "
        "GET_TIME after (milliseconds of the server's own clock)",
    ),
)
async def received_time_bracketed(ctx: CaseContext) -> None:
    """Ask GET_TIME, post, ask GET_TIME again; the stored receivedTime lies between the two.

    Catches: receivedTime rounded or truncated (to the second), taken from postedTime or from
    a clock other than the one GET_TIME reads, or stamped long after receipt.
    """
    client = await ctx.module("C", bind=False)
    kind = ctx.type("Stamp")
    for n in range(_POSTS):
        before = await _server_ms(ctx, client)
        await client.post("WB1", kind, f"post {n}")
        assert client.last_sent is not None
        posted_id = client.last_sent.id
        after = await _server_ms(ctx, client)
        spec = f'<retrieve from="WB1" id="{esc(posted_id)}"/>'
        found = await retrieved(ctx, client, spec)
        ctx.check(len(found) == 1, f"{len(found)} stored copies", expected="one (OA-WB-3)")
        got = found[0].received
        received = got.sec * 1000 + got.msec if got is not None else None
        ctx.check(
            received is not None and before <= received <= after,
            f"post {n}: receivedTime {received} ms, GET_TIME before {before}, after {after}",
            expected="receivedTime within the two GET_TIME answers (OA-TIME-3, OA-WB-4)",
        )
