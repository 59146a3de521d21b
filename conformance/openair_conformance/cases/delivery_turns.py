"""Conformance cases for what a module is sent while a delivery awaits its acknowledgement
(6.6, 11.6): pushed samples one at a time to a legacy module, and a noreply message forwarded
as it was sent to a module that declared `noreply`.

The modules here bind with BIND_NOLISTEN and the case reads their callback connection by hand
(`raw_module`), so it decides exactly which acknowledgement is held.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    ack,
    next_request,
    raw_module,
    setup_raw_subscribe,
    stream_module_xml,
)
from openair_conformance.cases._streams import StreamClient, create_stream, sample_label
from openair_conformance.harness import CaseContext
from openair_conformance.model import Inconclusive
from openair_conformance.registry import case

#: How long DELIV-019 watches for a second sample while the first is unanswered (its docstring
#: says why a fixed time).
_QUIET_S = 0.5


@case(
    id="DELIV-019",
    title="A legacy module gets its pushed samples one at a time: the next only after the "
    "acknowledgement of the previous",
    section="6.6",
    requirements=("OA-DELIV-5", "OA-STREAM-14"),
    needs=("typed-streams",),
    allowed=(
        "sample A delivered; nothing more while A is unanswered; sample B delivered after A's "
        "acknowledgement",
    ),
)
async def samples_one_at_a_time(ctx: CaseContext) -> None:
    """A legacy module (no extension) registers for a stream of the case's own; sample A is
    pushed and held unanswered, sample B is added; B must not come before A is acknowledged,
    and must come after.

    The absence of B is watched for a fixed `_QUIET_S` (0.5 s), not a deadline derived from the
    round trip: a server that sends B without waiting does so as soon as the add is accepted,
    within milliseconds; and no longer than half of ack-deadline-ms, past which A has failed
    (OA-DELIV-11) and the server rightly closes the connection to retry it.
    Catches: a server that pushes each sample on its own delivery task or window (a new
    per-module state for every sample), so that a legacy module gets several deliveries in
    flight (OA-DELIV-5) and the window OA-STREAM-14 keeps is not the module's.
    """
    raw = await ctx.raw("Creator")
    stream = await create_stream(ctx, raw, "Turns", idle=0)
    name = ctx.name("L")
    primary, callback, receive_id = await raw_module(ctx, "L")
    await setup_raw_subscribe(primary, name, stream_module_xml(ctx, name, stream))
    writer = await StreamClient.open(ctx, stream, "Writer")

    def take() -> Awaitable[Message]:
        return next_request(ctx, callback, receive_id=receive_id, name=name)

    await writer.add(b"A", [("conf:n", "A")])
    first = await ctx.wait(
        take(), what="the push of sample A", expected="each sample added delivered (OA-STREAM-14)"
    )
    if sample_label(first) != "A":
        raise Inconclusive(f"setup: the module got {first.type}, not sample A")
    await writer.add(b"B", [("conf:n", "B")])
    quiet = min(_QUIET_S, ctx.server.limit("ack-deadline-ms", 10_000) / 2000)
    early: Message | None = None
    try:
        early = await asyncio.wait_for(take(), quiet)
    except TimeoutError:
        ctx.note(f"nothing came in {quiet} s while sample A was unanswered")
    ctx.check(
        early is None,
        f"the legacy module got {early.type if early else ''} "
        f"{sample_label(early) if early else ''} while sample A was unanswered",
        expected="one delivery at a time to a legacy module: B after A's acknowledgement "
        "(OA-DELIV-5, OA-STREAM-14)",
    )
    await ack(callback, first, name)
    second = await ctx.wait(
        take(),
        what="sample B after sample A was acknowledged",
        expected="each sample added delivered (OA-STREAM-14)",
    )
    ctx.check(
        sample_label(second) == "B",
        f"after sample A the module got {second.type} {sample_label(second)!r}",
        expected="sample B (OA-STREAM-14)",
    )
    await ack(callback, second, name)


@case(
    id="DELIV-020",
    title="A noreply message forwarded to a module that declared noreply keeps noreply",
    section="6.6",
    requirements=("OA-SESS-22", "OA-MSG-15"),
    needs=("noreply",),
    allowed=(
        "the delivery carries noreply='yes'; the module does not answer it, and a later "
        "message to the module still arrives",
    ),
)
async def noreply_kept_for_declarer(ctx: CaseContext) -> None:
    """Send `noreply="yes"` to a bound module that declared `noreply`; take its delivery,
    leave it unanswered (OA-MSG-15), then send an ordinary message: it must arrive.

    Catches: a server that strips noreply from every delivery (not only towards modules that
    did not declare it, DELIV-004), so that the message is not forwarded unchanged
    (OA-SESS-22) and the module, which must not answer a noreply message, is answered for, or
    a server that then waits for the acknowledgement that never comes.
    """
    name = ctx.name("N")
    _, callback, receive_id = await raw_module(ctx, "N", extensions=("noreply",))
    sender = await ctx.module("S", bind=False)
    quiet = Message(
        type=ctx.type("Quiet"), sender=sender.name, to=name, content="psst", noreply=True
    )
    await sender.send_noreply(quiet)
    got = await ctx.wait(
        next_request(ctx, callback, receive_id=receive_id, name=name),
        what=f"delivery of {quiet.type}",
        expected="the message queued for delivery to the module (OA-SESS-22)",
    )
    ctx.check(
        got.type == quiet.type and got.noreply,
        f"the delivery is {got.type!r} with noreply={got.noreply}",
        expected=f"{quiet.type!r} with noreply='yes', unchanged (OA-SESS-22)",
    )
    loud = Message(type=ctx.type("Loud"), sender=sender.name, to=name, content="hi")
    reply = await sender.request(loud)
    if reply.type != "RECEIVE_ACCEPT":
        raise Inconclusive(f"setup: {loud.type} was answered {reply.type} {reply.content!r}")
    after = await ctx.wait(
        next_request(ctx, callback, receive_id=receive_id, name=name),
        what=f"delivery of {loud.type} while the noreply delivery stays unanswered",
        expected="no acknowledgement awaited for a noreply message (OA-MSG-15)",
    )
    ctx.check(
        after.type == loud.type,
        f"after the noreply message the module got {after.type!r}",
        expected=f"{loud.type!r} (OA-SESS-22)",
    )
    await ack(callback, after, name)
