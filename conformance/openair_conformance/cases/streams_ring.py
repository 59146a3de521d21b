"""Cases of a stream's ring at its edges (spec 11.1, 11.4, 11.7; issue #15): time lookups on a
stream of its own while its timestamps rise and after the ring dropped samples around a falling
one, the soft limit at one sample, what a lock covers and what GET_INFO counts as locked, and a
payload search that must not look past the payload.

Each case creates its own stream with Psyclone.System.Create.Stream (OA-XSTREAM-10), so that ids
start at 1 and nothing else writes to it: without `typed-streams` they are not applicable. On
the shared stream of the core cases other writers' timestamps are never in order, so these
lookups would never meet a stream whose timestamps rise.
"""

from __future__ import annotations

from openair_conformance.cases._streams import (
    StreamClient,
    chunk,
    create_stream,
    holds_exactly,
    past_window,
    samples_by_time,
    stamped,
    time_xml,
)
from openair_conformance.cases.streams_alarms import AlarmWatch
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case

_TYPED = ("typed-streams",)


async def _by_time(ctx: CaseContext, client: StreamClient, base: int, dt: int, want: int) -> None:
    """GET_SAMPLE_BY_TIME T+dt answers sample `want` (0: SAMPLE_UNKNOWN)."""
    if not want:
        await client.unknown("GET_SAMPLE_BY_TIME", time_xml(base + dt), xml=True, req="OA-STREAM-6")
        return
    reply = await client.request("GET_SAMPLE_BY_TIME", time_xml(base + dt), xml=True)
    got = client.sample_of(reply, f"GET_SAMPLE_BY_TIME T{dt:+}")
    ctx.check(
        got.id == want,
        f"GET_SAMPLE_BY_TIME T{dt:+} answered sample {got.id} stamped "
        f"T{(got.timestamp or 0) - base:+}",
        expected=f"sample {want}: the greatest timestamp at or before the time (OA-STREAM-6)",
    )


async def _held(ctx: CaseContext, client: StreamClient, held: list[int], gone: list[int]) -> None:
    """Fail unless the stream holds exactly the ids `held` (and none of `gone`)."""
    why = " (OA-STREAM-9, OA-XSTREAM-2)"
    await holds_exactly(
        ctx, client, held, gone, count_req="OA-STREAM-9", req="OA-STREAM-9", why=why
    )


async def _wait(
    ctx: CaseContext, client: StreamClient, type: str, base: int, dt: int, want: int
) -> None:
    """`type` 0 with the time T+dt answers sample `want` at once."""
    reply = await client.request(f"{type} 0", time_xml(base + dt), xml=True)
    got = client.sample_of(reply, f"{type} 0 T{dt:+}", req="OA-STREAM-7")
    ctx.check(
        got.id == want,
        f"{type} 0 T{dt:+} answered sample {got.id}",
        expected=f"sample {want} (the table of 11.5, OA-STREAM-7)",
    )


@case(
    id="XSTREAM-030",
    title="Time lookups on a ring: rising timestamps, then a falling one among dropped samples",
    section="11.4",
    requirements=("OA-STREAM-6", "OA-STREAM-7", "OA-STREAM-9"),
    needs=_TYPED,
    allowed=(
        "maxcount 3, samples 1-3 stamped T, T+10, T+20: by time T-1 none, T 1, T+9 1, T+10 2, "
        "T+20 3, T+99 3; sample 4 stamped T+5 drops 1: T+7 4, T+12 2, [T, T+12] [2, 4], "
        "[T+6, T+30] [2, 3], WAIT_FOR_LAST_SAMPLE T+6 3, WAIT_FOR_FIRST_SAMPLE T+1 2; sample 5 "
        "(T+30) drops 2 and sample 6 (T+40) drops 3: T+35 5, T+4 none",
    ),
)
async def ring_time_lookups(ctx: CaseContext) -> None:
    """Create an untyped stream with maxcount 3; add samples stamped T, T+10, T+20 and look them
    up by time (rising timestamps). Add one stamped T+5: the ring drops sample 1 and holds
    T+10, T+20, T+5; look up by time, range and wait. Add T+30 and T+40 (the ring drops 2 and 3,
    the timestamps rise again) and look up again.

    Catches: an off-by-one in a binary search over rising timestamps (the sample after the
    time, or one too far), and a stream that, once a drop took the sample before a falling
    timestamp, takes its timestamps for ordered again while they are not (a binary search
    over T+10, T+20, T+5).
    """
    raw = await ctx.raw("Creator")
    client = await StreamClient.open(ctx, await create_stream(ctx, raw, "Ring", maxcount=3))
    base = past_window(ctx)
    ids = [await stamped(client, base, dt) for dt in (0, 10, 20)]
    ctx.check(ids == [1, 2, 3], f"the new stream gave the ids {ids}", expected="[1, 2, 3]")
    for dt, want in ((-1, 0), (0, 1), (9, 1), (10, 2), (20, 3), (99, 3)):
        await _by_time(ctx, client, base, dt, want)
    await stamped(client, base, 5)
    await _held(ctx, client, [2, 3, 4], gone=[1])
    for dt, want in ((7, 4), (12, 2), (25, 3), (4, 0)):
        await _by_time(ctx, client, base, dt, want)
    await samples_by_time(ctx, client, base, (0, 12), [2, 4])
    await samples_by_time(ctx, client, base, (6, 30), [2, 3])
    await _wait(ctx, client, "WAIT_FOR_LAST_SAMPLE", base, 6, 3)
    await _wait(ctx, client, "WAIT_FOR_FIRST_SAMPLE", base, 1, 2)
    await stamped(client, base, 30)
    await stamped(client, base, 40)
    await _held(ctx, client, [4, 5, 6], gone=[3])
    for dt, want in ((35, 5), (29, 4), (4, 0), (40, 6)):
        await _by_time(ctx, client, base, dt, want)
    await samples_by_time(ctx, client, base, (5, 30), [4, 5])


async def _locked(ctx: CaseContext, client: StreamClient, want: int, why: str) -> None:
    info = await client.info(req="OA-STREAM-6")
    ctx.check(
        info.get("locked") == str(want),
        f"GET_INFO says locked={info.get('locked')!r} {why}",
        expected=f"locked={want}: the number of samples held that a lock covers (11.4, "
        "OA-STREAM-6, OA-XSTREAM-5)",
    )


async def _lock(ctx: CaseContext, client: StreamClient, text: str) -> str:
    reply = await client.request("LOCK_SAMPLES", text)
    ctx.check(
        reply.type == "LOCKED" and reply.content.strip().isdigit(),
        f"LOCK_SAMPLES {text} was answered {reply.type} {reply.content!r}",
        expected="LOCKED with a decimal lock id (OA-XSTREAM-5)",
    )
    return reply.content.strip()


@case(
    id="XSTREAM-031",
    title="A lock covers the held samples of its range only; GET_INFO counts the locked ones",
    section="11.7",
    requirements=("OA-XSTREAM-5", "OA-XSTREAM-2", "OA-STREAM-6"),
    needs=_TYPED,
    allowed=(
        "softcount 2: locked 0 before any lock; LOCK_SAMPLES 1-100 with sample 1 held: locked 1, "
        "still 1 after sample 2 is added; adding 3 drops 2 (1 is locked), locked 1; after "
        "LOCK_SAMPLES 1-3 and 3-3 locked 2; after the first lock's unlock still 2",
    ),
)
async def lock_coverage(ctx: CaseContext) -> None:
    """Create a stream typed T with softcount 2; add 1, lock 1-100, add 2 and 3 (the soft limit
    drops 2, the only unlocked sample but the newest); lock 1-3 and 3-3 (overlapping ranges),
    unlock the first lock. GET_INFO's `locked` after each step.

    Catches: a lock that also covers samples added after it (ids in its range not yet given),
    a `locked` count that stays 0 or counts a sample twice.
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(
        ctx, raw, "Locks", type=ctx.type("Locks"), softcount=2, hardcount=10, idle=0
    )
    client = await StreamClient.open(ctx, name)
    await client.add(b"one")
    await _locked(ctx, client, 0, "before any lock")
    first = await _lock(ctx, client, "1-100")
    await _locked(ctx, client, 1, "after LOCK_SAMPLES 1-100 with only sample 1 held")
    await client.add(b"two")
    await _locked(
        ctx, client, 1, "after sample 2 was added (the lock 1-100 was made before it existed)"
    )
    await client.add(b"three")
    await _held(ctx, client, [1, 3], gone=[2])
    await _locked(ctx, client, 1, "holding 1 (locked) and 3")
    await _lock(ctx, client, "1-3")
    await _lock(ctx, client, "3-3")
    await _locked(ctx, client, 2, "with the locks 1-100, 1-3 and 3-3 over the samples 1 and 3")
    reply = await client.request("UNLOCK_SAMPLES", first)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"UNLOCK_SAMPLES {first} was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT (OA-XSTREAM-5)",
    )
    await _locked(ctx, client, 2, "after the lock 1-100 was released (1-3 and 3-3 remain)")


@case(
    id="XSTREAM-032",
    title="At softcount 1 every add leaves only its newest sample, the SoftLimit counting drops",
    section="11.7",
    requirements=("OA-XSTREAM-2", "OA-XSTREAM-6"),
    needs=_TYPED,
    allowed=(
        "softcount 1, 10-byte samples: adding 2 drops 1 and posts SoftLimit with count 1, size "
        "10, dropped 1; an ADD_SAMPLES of 3-5 leaves 5",
    ),
)
async def soft_count_one(ctx: CaseContext) -> None:
    """Create a stream typed T with softcount 1 (no hard count); add 1 and 2, then 3-5 in one
    ADD_SAMPLES; check what is held and the SoftLimit alarm of the second add.

    Catches: soft enforcement that never goes below two samples, a SoftLimit `dropped` that
    is not the number of samples dropped.
    """
    raw = await ctx.raw("Creator")
    name = ctx.name("One")
    watch = await AlarmWatch.open(ctx, name)
    await create_stream(ctx, raw, "One", type=ctx.type("One"), softcount=1, idle=0)
    client = await StreamClient.open(ctx, name)
    await client.add(bytes(10), req="OA-XSTREAM-2")
    await client.add(bytes(10), req="OA-XSTREAM-2")
    await _held(ctx, client, [2], gone=[1])
    entries = await watch.next("SoftLimit")
    ctx.check(
        (entries.get("count"), entries.get("size"), entries.get("dropped")) == ("1", "10", "1"),
        f"the SoftLimit alarm has the entries {entries}",
        expected="count 1, size 10, dropped 1: one sample dropped, one of 10 bytes held "
        "(OA-XSTREAM-2)",
    )
    ids = await client.add_many([chunk(bytes(10)) for _ in range(3)], req="OA-XSTREAM-2")
    ctx.check(ids == [3, 4, 5], f"ADD_SAMPLES gave the ids {ids}", expected="[3, 4, 5]")
    await _held(ctx, client, [5], gone=[2, 3, 4])


@case(
    id="XSTREAM-033",
    title="SEARCH_SAMPLES <payload> looks in the payload, never in the parameters after it",
    section="11.7",
    requirements=("OA-XSTREAM-11",),
    needs=_TYPED,
    allowed=(
        "'needle' (6e 65 65 64 6c 65): only the sample whose payload holds it, not the one "
        "whose payload ends 'nee' before a parameter 'dle', nor the one with a parameter "
        "'needle'; 00 (the chunk's final NUL): none",
    ),
)
async def payload_only(ctx: CaseContext) -> None:
    """Create a typed stream; add a payload `hay nee` with the parameter `dle=1`, a payload
    `a needle`, and a payload `plain` with the parameter `needle=yes`; search for `needle` and
    for a zero byte.

    Catches: a payload search over the whole stored chunk (the parameter string and its NUL
    behind the payload) instead of the payload alone.
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(ctx, raw, "Bytes", type=ctx.type("Bytes"), idle=0)
    client = await StreamClient.open(ctx, name)
    await client.add(b"hay nee", [("dle", "1")])
    await client.add(b"a needle")
    await client.add(b"plain", [("needle", "yes")])
    for pattern, want in ((b"needle".hex(" "), [2]), ("00", [])):
        content = f"<samplesearch><payload>{pattern}</payload></samplesearch>"
        reply = await client.request("SEARCH_SAMPLES", content, xml=True)
        got = [s.id for s in client.samples_of(reply, content, req="OA-XSTREAM-11")]
        ctx.check(
            got == want,
            f"{content} found {got}",
            expected=f"{want}: the pattern within the sample's payload bytes (OA-XSTREAM-11)",
        )
