"""Cases of the stream service's bookkeeping across connections and registrations (spec 11.5,
11.6, 11.7): a wait whose connection the server closed, and a registration that names streams
created after it.

Both create their own streams (OA-XSTREAM-10), so they need `typed-streams`. A server reads no
request behind a pending wait (OA-STREAM-7), so a waiting connection that the peer closes may stay
unnoticed until the wait ends; XSTREAM-051 has the server close it, by a takeover of its module
name (OA-SESS-6), and sees the server forget it when the lock it held is released
(OA-XSTREAM-5).
"""

from __future__ import annotations

import asyncio

from openair_conformance.cases._common import bind_nolisten, esc
from openair_conformance.cases._streams import (
    StreamClient,
    check_from,
    check_sample,
    create_stream,
    marker,
)
from openair_conformance.cases.streams_push import marked
from openair_conformance.harness import CaseContext
from openair_conformance.model import Fail, Inconclusive, Timing
from openair_conformance.registry import case

_TYPED = ("typed-streams",)


def _long_ms(ctx: CaseContext) -> int:
    """A timeout longer than the suite waits for a reply: a wait that times out fails."""
    return int((ctx.deadline + ctx.grace) * 1000) + 2000


async def _unlocked(client: StreamClient) -> None:
    """Ask GET_INFO until no sample is locked (the server learns of a close asynchronously),
    pausing a little between the requests."""
    while (await client.info(req="OA-XSTREAM-5")).get("locked") != "0":
        await asyncio.sleep(min(0.02, client.ctx.deadline / 50))


async def _taken_over(
    ctx: CaseContext, old: StreamClient, suffix: str, watch: StreamClient
) -> None:
    """Bind `old`'s name on a new connection (a takeover, OA-SESS-6): the server closes `old`;
    return once it has forgotten it (`watch` sees no locked sample any more, OA-XSTREAM-5)."""
    await bind_nolisten(await ctx.raw(suffix), old.sender)
    try:
        await old.raw.expect_closed()
    except (Fail, Timing) as exc:
        raise Inconclusive(f"setup: the takeover of {old.sender} left its connection open") from exc
    await old.raw.close()  # the server may linger until the peer closes too
    try:
        await ctx.wait(_unlocked(watch), what="GET_INFO locked=0 after the waiter's close")
    except (Fail, Timing) as exc:
        raise Inconclusive("setup: the closed waiter's lock was not released") from exc


@case(
    id="XSTREAM-051",
    title="A wait whose connection closed is forgotten: the next add and the other waits go on",
    section="11.5",
    requirements=("OA-STREAM-7", "OA-STREAM-5", "OA-XSTREAM-5"),
    needs=_TYPED,
    allowed=(
        "DATA_ACCEPTED for the add after a waiting connection was closed, and DATASAMPLE (that "
        "sample) for a wait still open on the same condition",
    ),
)
async def closed_waiter(ctx: CaseContext) -> None:
    """Create a stream and add sample 1. Connection A binds a module name, locks 1-1 and sends
    `WAIT_FOR_FIRST_AFTERID <long> 1`; connection B sends the same wait. A third connection
    binds A's name, so the server closes A; once GET_INFO shows no locked sample (A is
    forgotten), a writer adds sample 2. The add is DATA_ACCEPTED and B's wait is answered with
    sample 2.

    Catches: the waits of a closed connection kept, so that the first add that satisfies them
    fails or leaves the other waits of the stream unanswered.
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(ctx, raw, "Waited", type=ctx.type("Waited"), idle=0)
    writer = await StreamClient.open(ctx, name, "Writer")
    first = await writer.add(b"before", [marker(ctx)], req="OA-XSTREAM-10")
    wait = f"WAIT_FOR_FIRST_AFTERID {_long_ms(ctx)}"
    gone = await StreamClient.open(ctx, name, "Gone")
    await bind_nolisten(gone.raw, gone.sender)
    locked = await gone.request("LOCK_SAMPLES", f"{first}-{first}")
    if locked.type != "LOCKED":
        raise Inconclusive(f"setup: LOCK_SAMPLES was answered {locked.type} {locked.content!r}")
    await gone.raw.send_message(gone.message(wait, str(first)))
    stays = await StreamClient.open(ctx, name, "Stays")
    sent = await stays.raw.send_message(stays.message(wait, str(first)))
    await _taken_over(ctx, gone, "Again", writer)
    params = (marker(ctx), ("conf:after", "close"))
    added = await writer.add(b"after a waiter left", params, req="OA-STREAM-5")
    reply = await stays.raw.read_message()
    ctx.check(
        reply.isresponse == sent.id,
        f"the open wait was answered by {reply.type} with isresponse {reply.isresponse!r}",
        expected="the reply to the wait (OA-SESS-1, OA-STREAM-7)",
    )
    check_from(ctx, reply, name, "the open wait")
    got = stays.sample_of(reply, f"{wait} {first} (the open wait)", req="OA-STREAM-7")
    check_sample(
        ctx, got, payload=b"after a waiter left", params=params, sample_id=added, what="waited"
    )


@case(
    id="XSTREAM-050",
    title="A registration's sources subscribe to streams created after it, by type and by name",
    section="11.7",
    requirements=("OA-STREAM-14", "OA-XSTREAM-10", "OA-STREAM-12"),
    needs=_TYPED,
    allowed=(
        "a DATASAMPLE delivery to the module for a sample added to a stream created after the "
        "registration, whose type its inputstream pattern matches or whose name its source is",
    ),
)
async def later_streams(ctx: CaseContext) -> None:
    """Register a module with `<inputstream source="<prefix>.Later.*"/>` and
    `<inputstream source=NAME/>` where no such stream exists yet; then create a stream typed
    `<prefix>.Later.Raw` and one named NAME, and add a marked sample to each. The module gets
    both as DATASAMPLE deliveries.

    Catches: subscriptions by registration resolved only against the streams that exist when
    the module registers.
    """
    module = await ctx.module("Subscriber")
    named = ctx.name("Named")
    sources = (
        f'<inputstream alias="ByType" source="{esc(ctx.type("Later"))}.*"/>'
        f'<inputstream alias="ByName" source="{esc(named)}"/>'
    )
    await module.subscribe(f'<module name="{module.name}">{sources}</module>', check=True)
    raw = await ctx.raw("Creator")
    typed = await create_stream(ctx, raw, "Typed", type=ctx.type("Later.Raw"), idle=0)
    made = await create_stream(ctx, raw, "Named")
    if made != named:
        raise RuntimeError(f"create_stream named {made!r}, not {named!r}")
    wanted: dict[str, tuple[str, str]] = {}
    for stream in (typed, named):
        writer = await StreamClient.open(ctx, stream, f"W{stream[-5:]}")
        mark = ("conf:to", stream)
        await writer.add(b"created later", [marker(ctx), mark], req="OA-XSTREAM-10")
        wanted[stream] = mark
    while wanted:
        msg = await module.next_delivery()
        found = next((s for s, mark in wanted.items() if marked(msg, mark)), None)
        if found is None:
            continue
        ctx.check(
            msg.sender == found and msg.to == module.name,
            f"the delivery of {found}'s sample came from {msg.sender!r} to {msg.to!r}",
            expected=f"a DATASAMPLE from {found!r} to the module (OA-STREAM-12)",
        )
        del wanted[found]
