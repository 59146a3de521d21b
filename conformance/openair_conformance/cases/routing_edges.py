"""Edges of routing a post to its deliveries (issue #15): a `timetolive` of 0 sets no limit
(section 5, OA-MSG-7, OA-DELIV-14).
"""

from __future__ import annotations

from openair.protocol.message import Message
from openair_conformance.cases._common import setup_subscribe, triggers_xml
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case

_QOS = ("qos",)
#: The trigger's delay: the wakeup waits in the queue before it is sent.
_AFTER_MS = 200


@case(
    id="QOS-003",
    title="A timetolive of 0 sets no limit: the delivery is sent, not expired",
    section="6.6",
    requirements=("OA-DELIV-14", "OA-MSG-7"),
    needs=_QOS,
    allowed=(
        f"a trigger with after={_AFTER_MS}: the wakeup for a post with timetolive 0 is delivered",
    ),
)
async def timetolive_zero(ctx: CaseContext) -> None:
    """Register a trigger with after=200; post Zero with timetolive 0; wait for its wakeup.

    Section 5 reads `timetolive` 0 as no limit, and OA-DELIV-14 expires only a timetolive
    greater than 0. Catches: a server that expires a delivery at its message's receivedTime plus
    0 ms (issue #15: `not ttl > -1` survived), so it is dropped before it is sent.
    """
    reader = await ctx.module("Reader")
    poster = await ctx.module("Poster", bind=False)
    await setup_subscribe(reader, triggers_xml(ctx.type("Z.*"), after=_AFTER_MS))
    msg = Message(
        type=ctx.type("Z.Zero"),
        sender=poster.name,
        to="WB1",
        content="zero",
        timetolive=0.0,
    )
    reply = await poster.request(msg)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"the post with timetolive 0 was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT (OA-WB-3)",
    )
    await reader.expect_wakeup_for(msg.id, timeout=ctx.deadline + _AFTER_MS / 1000)
