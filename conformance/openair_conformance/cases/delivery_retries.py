"""Conformance cases for retrying a failed delivery (6.6, OA-DELIV-7, OA-DELIV-15).

The module here listens on a port of the case's own (`_delivery.Dropper`) and closes the
connection on each of the first N deliveries before acknowledging it: to the server that is a
delivery that failed, and each retry opens a new connection to the port. The suite counts the
attempts. The bound that makes the count final is advertised: a retry starts within
`retry-deadline-ms` of the failure it follows (OA-DELIV-15), so no attempt later than that plus
the deadline can come.
"""

from __future__ import annotations

import time

from openair_conformance.cases._delivery import (
    expect_attempts,
    no_more_attempts,
    retry_window,
    setup_dropper,
)
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import wakeup_trigger_id
from openair_conformance.model import Inconclusive, Level, NotApplicable
from openair_conformance.registry import case


@case(
    id="DELIV-012",
    title="A delivery whose connection closes unanswered is retried, and once acknowledged no more",
    section="6.6",
    requirements=("OA-DELIV-7", "OA-DELIV-15"),
    allowed=("the same wakeup on a new connection to the port, then nothing more",),
)
async def dropped_delivery_is_retried_once(ctx: CaseContext) -> None:
    """Drop the first attempt of a wakeup; the retry must come, and be the last attempt.

    Catches: a server that never retries (OA-DELIV-7 "at most twice" let it pass), retries
    late, or sends an acknowledged delivery again.
    """
    retries, _ = retry_window(ctx)
    if retries < 1:
        raise Inconclusive("the server advertises delivery-retries 0: nothing to retry")
    dropper, poster, _ = await setup_dropper(ctx, drops=1)
    try:
        await poster.post("WB1", ctx.type("Go"), "once")
        assert poster.last_sent is not None
        await expect_attempts(ctx, dropper, poster.last_sent.id, 2)
        await no_more_attempts(ctx, dropper, 2, "the second attempt was acknowledged")
    finally:
        await dropper.close()


@case(
    id="DELIV-013",
    title="A delivery that keeps failing is attempted exactly delivery-retries + 1 times",
    section="6.6",
    requirements=("OA-DELIV-7", "OA-DELIV-15", "OA-ERR-5"),
    allowed=(
        "the advertised delivery-retries (default 2) retries, then the delivery abandoned",
        "the module's next delivery arrives once the failed one is abandoned",
    ),
)
async def failing_delivery_is_retried_exactly(ctx: CaseContext) -> None:
    """Drop every attempt of a wakeup; count the attempts within the advertised retry window;
    then post again: that wakeup must arrive (the module answers it).

    Catches: too few retries, too many, or retries spaced beyond `retry-deadline-ms`; and an
    abandoned delivery that is never let go (retried for ever in the background, holding the
    module's one delivery slot, so that it gets nothing more, OA-DELIV-7, OA-ERR-5).
    """
    retries, _ = retry_window(ctx)
    dropper, poster, _ = await setup_dropper(ctx, drops=retries + 1)
    try:
        await poster.post("WB1", ctx.type("Go"), "always")
        assert poster.last_sent is not None
        await expect_attempts(ctx, dropper, poster.last_sent.id, retries + 1)
        await no_more_attempts(ctx, dropper, retries + 1, "every attempt was dropped")
        await poster.post("WB1", ctx.type("Go"), "after")
        assert poster.last_sent is not None
        after = await ctx.wait(
            dropper.arrived.get(),
            what="delivery after the abandoned one",
            expected="the abandoned delivery lets go of the module: its next one is sent "
            "(OA-DELIV-7, OA-ERR-5)",
        )
        ctx.check(
            wakeup_trigger_id(after) == poster.last_sent.id,
            f"after the abandoned delivery came {after.type} for {wakeup_trigger_id(after)!r}",
            expected=f"the wakeup for the next post, {poster.last_sent.id} (OA-DELIV-7)",
        )
    finally:
        await dropper.close()


#: The longest acknowledgement deadline DELIV-018 waits out (the default is 10 000 ms).
_MAX_ACK_DEADLINE_MS = 3_000


@case(
    id="DELIV-018",
    title="A delivery left unanswered for ack-deadline-ms has failed: its connection is closed "
    "and it is retried",
    section="6.6",
    level=Level.SHOULD,  # OA-DELIV-11 is a SHOULD: a server that never gives up is reported
    requirements=("OA-DELIV-11", "OA-DELIV-7", "OA-DELIV-15"),
    allowed=(
        "the server closes the connection that carries the unanswered delivery no sooner than "
        "ack-deadline-ms after sending it and within it plus the case's deadline, then sends "
        "the same wakeup again on a new connection within retry-deadline-ms, and once that is "
        "acknowledged nothing more",
    ),
)
async def unanswered_delivery_times_out(ctx: CaseContext) -> None:
    """Leave the first attempt of a wakeup unanswered with its connection open; the server must
    close that connection once `ack-deadline-ms` has passed, not before, and retry the delivery;
    the retry is acknowledged, and no attempt may follow.

    The earliest close allowed is measured from just before the post, so that a correct server
    is never failed for it; the latest from the delivery's arrival, and a close after it plus
    the case's deadline is TIMING, after twice that a failure (OA-GEN-6).
    Catches: a server that never gives up on an unanswered delivery (the module then gets
    nothing more), gives up before its advertised deadline, retries on the connection it
    should have closed, closes without retrying, or sends the delivery again after the retry
    was acknowledged.
    """
    deadline_ms = ctx.server.limit("ack-deadline-ms", 10_000)
    if deadline_ms > _MAX_ACK_DEADLINE_MS:
        raise NotApplicable(
            f"ack-deadline-ms is {deadline_ms}; run against a server advertising at most "
            f"{_MAX_ACK_DEADLINE_MS} (openair serve --ack-deadline-ms 500)"
        )
    retries, window = retry_window(ctx)
    if retries < 1:
        raise Inconclusive("the server advertises delivery-retries 0: nothing to retry")
    deadline = deadline_ms / 1000
    dropper, poster, _ = await setup_dropper(ctx, drops=0, silent=1)
    try:
        t0 = time.monotonic()
        await poster.post("WB1", ctx.type("Go"), "unanswered")
        assert poster.last_sent is not None
        trigger = poster.last_sent.id
        first = await ctx.wait(
            dropper.arrived.get(), what="the delivery", expected="the wakeup (OA-TRIG-1)"
        )
        sent = dropper.attempts[0][0]
        again = await ctx.wait(
            dropper.arrived.get(),
            what="the retry of the unanswered delivery",
            timeout=deadline + window + ctx.deadline,
            expected=f"the delivery failed after ack-deadline-ms ({deadline_ms} ms) and retried "
            "(OA-DELIV-11, OA-DELIV-7)",
        )
        closed = dropper.closed_at[0] if dropper.closed_at else None
        ctx.check(
            closed is not None,
            "the retry came while the connection of the unanswered delivery was still open",
            expected="that connection closed before the retry (OA-DELIV-11)",
        )
        assert closed is not None
        ctx.check(
            closed - t0 >= deadline,
            f"the connection was closed {(closed - t0) * 1000:.0f} ms after the post (the "
            f"delivery came {(sent - t0) * 1000:.0f} ms after it)",
            expected=f"no sooner than ack-deadline-ms, {deadline_ms} ms, after the delivery "
            "(OA-DELIV-11)",
        )
        ctx.check(
            wakeup_trigger_id(first) == trigger and wakeup_trigger_id(again) == trigger,
            f"the attempts were for {wakeup_trigger_id(first)!r} and {wakeup_trigger_id(again)!r}",
            expected=f"the same wakeup twice, for {trigger} (OA-DELIV-7)",
        )
        await no_more_attempts(ctx, dropper, 2, "the retry was acknowledged")
        ctx.judge_elapsed(
            "the close of the unanswered delivery's connection",
            closed - sent,
            limit=deadline + ctx.deadline,
        )
    finally:
        await dropper.close()
