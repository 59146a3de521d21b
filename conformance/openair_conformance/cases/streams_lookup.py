"""Cases of time lookups after a soft limit dropped a sample from the middle of a stream (spec
11.4, 11.5, 11.7; issue #15).

When the oldest sample is locked, the soft limit drops the oldest unlocked samples behind it
(OA-XSTREAM-2), so the two samples either side of a dropped one become neighbours. A stream
that keeps track of whether its timestamps are in order, to bisect on them, must then compare
those two: here they go backwards although every pair that went backwards before the drop
involved the dropped sample.

Each case creates its own stream with Psyclone.System.Create.Stream (OA-XSTREAM-10), so that ids
start at 1 and nothing else writes to it: without `typed-streams` they are not applicable.
"""

from __future__ import annotations

from openair_conformance.cases._streams import (
    StreamClient,
    create_stream,
    holds_exactly,
    past_window,
    samples_by_time,
    stamped,
    time_xml,
)
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case

_TYPED = ("typed-streams",)


async def _one(
    ctx: CaseContext, client: StreamClient, command: str, base: int, dt: int, want: int
) -> None:
    """`command` (GET_SAMPLE_BY_TIME or a wait with timeout 0) at T+dt answers sample `want`."""
    req = "OA-STREAM-6" if command == "GET_SAMPLE_BY_TIME" else "OA-STREAM-7"
    reply = await client.request(command, time_xml(base + dt), xml=True)
    what = f"{command} T{dt:+}"
    got = client.sample_of(reply, what, req=req)
    ctx.check(
        got.id == want,
        f"{what} answered sample {got.id} stamped T{(got.timestamp or 0) - base:+}",
        expected=f"sample {want} ({req}; the table of 11.5), whatever the order of the "
        "timestamps held",
    )


async def _held(ctx: CaseContext, client: StreamClient, held: list[int], gone: int) -> None:
    """Fail unless the stream holds exactly the ids `held`, not `gone`."""
    why = ": the soft limit drops the oldest unlocked samples, never the newest (OA-XSTREAM-2)"
    await holds_exactly(
        ctx, client, held, [gone], count_req="OA-STREAM-9", req="OA-XSTREAM-2", why=why
    )


@case(
    id="XSTREAM-070",
    title="Time lookups after the soft limit dropped a sample from behind a locked one",
    section="11.4",
    requirements=("OA-STREAM-6", "OA-STREAM-7", "OA-XSTREAM-2", "OA-XSTREAM-5"),
    needs=_TYPED,
    allowed=(
        "softcount 2: sample 1 stamped T+100 and locked, 2 stamped T, 3 stamped T+50 (drops 2): "
        "by time T+100 1, T+60 3, T+49 none; [T+90, T+100] [1], [T+40, T+100] [1, 3]; "
        "WAIT_FOR_FIRST_SAMPLE T+60 1, WAIT_FOR_LAST_SAMPLE T+60 1; sample 4 stamped T+200 "
        "(drops 3): T+150 1, T+200 4, [T+100, T+200] [1, 4]",
    ),
)
async def lookups_after_inner_drop(ctx: CaseContext) -> None:
    """Create a stream typed T with softcount 2; add sample 1 stamped T+100 and lock it, then
    2 stamped T and 3 stamped T+50: the soft limit drops 2, the only unlocked sample but the
    newest, leaving T+100, T+50 (falling). Look up by time, range and wait. Add 4 stamped T+200
    (the soft limit drops 3; T+100, T+200 rise) and look up again.

    Catches: a stream that, when it drops a sample from between two others, forgets that
    those two now go backwards (its only falling pair was the one into the dropped sample), takes
    T+100, T+50 for ordered and bisects: T+100 answers 3, [T+90, T+100] nothing.
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(
        ctx, raw, "Inner", type=ctx.type("Inner"), softcount=2, hardcount=10, idle=0
    )
    client = await StreamClient.open(ctx, name)
    base = past_window(ctx)
    first = await stamped(client, base, 100)
    reply = await client.request("LOCK_SAMPLES", f"{first}-{first}")
    ctx.check(
        reply.type == "LOCKED",
        f"LOCK_SAMPLES {first}-{first} was answered {reply.type} {reply.content!r}",
        expected="LOCKED with a lock id (OA-XSTREAM-5)",
    )
    ids = [first] + [await stamped(client, base, dt) for dt in (0, 50)]
    ctx.check(ids == [1, 2, 3], f"the new stream gave the ids {ids}", expected="[1, 2, 3]")
    await _held(ctx, client, [1, 3], gone=2)
    for dt, want in ((100, 1), (60, 3)):
        await _one(ctx, client, "GET_SAMPLE_BY_TIME", base, dt, want)
    await client.unknown("GET_SAMPLE_BY_TIME", time_xml(base + 49), xml=True, req="OA-STREAM-6")
    await samples_by_time(ctx, client, base, (90, 100), [1])
    await samples_by_time(ctx, client, base, (40, 100), [1, 3])
    await _one(ctx, client, "WAIT_FOR_FIRST_SAMPLE 0", base, 60, 1)
    await _one(ctx, client, "WAIT_FOR_LAST_SAMPLE 0", base, 60, 1)
    await stamped(client, base, 200)
    await _held(ctx, client, [1, 4], gone=3)
    for dt, want in ((150, 1), (200, 4), (100, 1)):
        await _one(ctx, client, "GET_SAMPLE_BY_TIME", base, dt, want)
    await samples_by_time(ctx, client, base, (100, 200), [1, 4])
