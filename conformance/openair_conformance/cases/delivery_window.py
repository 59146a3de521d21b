"""Conformance cases for delivery (6.6, 6.9): a delivery being retried when its module's
session ends.

The module here listens on a port of the case's own that drops the delivery (`_delivery.Dropper`),
so the case knows the delivery failed and a retry is waiting its back-off when the session ends.
"""

from __future__ import annotations

from openair_conformance.cases._common import raw_module
from openair_conformance.cases._delivery import accept_for, retry_window, setup_dropper
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import wakeup_trigger_id
from openair_conformance.registry import case


@case(
    id="DELIV-040",
    title="A delivery waiting for its retry when the session ends is dropped with it: the next "
    "session under the name never gets it",
    section="6.9",
    requirements=("OA-SESS-15", "OA-DELIV-7"),
    allowed=("no delivery of the old session's wakeup to the new session within the retry window",),
)
async def retry_discarded_with_session(ctx: CaseContext) -> None:
    """D's listening port drops the first attempt of a wakeup; at once D's port stops listening,
    D's session ends and a new session binds D with a callback connection: the retries of the
    old wakeup must not reach it.

    The new session binds within the back-off of the first retries (OA-DELIV-15), so a retry
    left running for the old session would find the new one's callback connection.
    Catches: a server that, when a session ends, drops the queue but leaves the pending retries
    (or the delivery task) running, so that a module that starts again gets stale work.
    """
    dropper, poster, primary = await setup_dropper(ctx, drops=99)
    await poster.post("WB1", ctx.type("Go"), "old")
    assert poster.last_sent is not None
    old = poster.last_sent.id
    first = await ctx.wait(
        dropper.arrived.get(), what="the first attempt of the wakeup", expected="OA-DELIV-1"
    )
    ctx.check(
        wakeup_trigger_id(first) == old,
        f"D got {first.type} for {wakeup_trigger_id(first)!r}",
        expected=f"the wakeup for {old}",
    )
    await dropper.close()  # the port stops listening: the retries cannot reach the old session
    await primary.close()  # the session ends (OA-SESS-15) while a retry waits its back-off
    name = ctx.name("D")
    _, again, again_id = await raw_module(ctx, "D")  # the same name, a new session
    retries, _ = retry_window(ctx)
    retry_s = ctx.server.limit("retry-deadline-ms", 1000) / 1000
    # Each retry of the old wakeup starts within retry-deadline-ms of the failure before it
    # (OA-DELIV-15); each read stays below the reply deadline.
    got = await accept_for(
        ctx, again, receive_id=again_id, name=name, seconds=ctx.deadline + retries * retry_s
    )
    ctx.check(
        old not in got,
        f"the new session of D got the old session's wakeup for {old} ({got})",
        expected="the old session's retries discarded with it (OA-SESS-15)",
    )
