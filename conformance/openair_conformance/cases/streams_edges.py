"""Stream cases at edges the other stream cases do not reach (spec 11.4-11.7, 14.1): waits by
id once the oldest samples are gone, the `subscribers` count of a typed stream with
registrations that select it and one that does not, and the byte limit of a stream created at
run time (OA-LIM-17).

Each case creates a typed stream of its own (Psyclone.System.Create.Stream), so what it holds
and who is subscribed to it are known exactly.
"""

from __future__ import annotations

from openair_conformance.cases._common import check_error, esc
from openair_conformance.cases._streams import StreamClient, create_stream, create_stream_request
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.model import Inconclusive
from openair_conformance.registry import case

_TYPED = ("typed-streams",)
_MIB = 1024 * 1024


@case(
    id="STREAM-060",
    title="Waits by id answer the held samples once the oldest are dropped",
    section="11.5",
    requirements=("OA-STREAM-7", "OA-XSTREAM-3"),
    needs=_TYPED,
    allowed=(
        "with hardcount 2 and samples 1-3 added (1 dropped): WAIT_FOR_FIRST_AFTERID 0 of id 1 "
        "answers sample 2, WAIT_FOR_LAST_AFTERID 0 of id 2 answers sample 3",
    ),
)
async def waits_after_drop(ctx: CaseContext) -> None:
    """Create a stream with hardcount 2; add three samples (the first is dropped). Ask
    WAIT_FOR_FIRST_AFTERID with the dropped id (the oldest held sample answers) and
    WAIT_FOR_LAST_AFTERID with the id just below the newest (the newest answers), timeout 0.

    Catches: the first-after-id lookup off by one when the id asked for is older than the
    oldest held sample; the last-after-id test made on the wrong end of the stream.
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(ctx, raw, "Drop", type=ctx.type("Drop"), hardcount=2, idle=0)
    client = await StreamClient.open(ctx, name)
    ids = [await client.add(bytes([i]) * 4) for i in range(3)]
    info = await client.info(req="OA-STREAM-16")
    if info.get("oldest") != str(ids[1]) or info.get("count") != "2":
        raise Inconclusive(f"setup: after three adds with hardcount 2 the stream is {info}")
    for type, after, want in (
        ("WAIT_FOR_FIRST_AFTERID 0", ids[0], ids[1]),
        ("WAIT_FOR_LAST_AFTERID 0", ids[1], ids[2]),
    ):
        reply = await client.request(type, str(after))
        got = client.sample_of(reply, f"{type} {after}", req="OA-STREAM-7")
        ctx.check(
            got.id == want,
            f"{type} {after} answered sample {got.id} (held: {ids[1]} and {ids[2]})",
            expected=f"sample {want} at once (OA-STREAM-7)",
        )


async def _registered(ctx: CaseContext, suffix: str, source: str) -> TestModule:
    module = await ctx.module(suffix)
    streams = f'<streams><inputstream alias="In" source="{esc(source)}"/></streams>'
    trigger = f'<trigger from="WB1" type="{esc(ctx.type("Never"))}"/>'
    reply = await module.subscribe(f'<module name="{module.name}">{streams}{trigger}</module>')
    if reply.type != "RECEIVE_ACCEPT":
        raise Inconclusive(
            f"setup: AIR.Subscribe with {streams} was answered {reply.type} {reply.content!r}"
        )
    return module


@case(
    id="XSTREAM-060",
    title="subscribers counts the modules whose registration selects the stream, no others",
    section="11.7",
    requirements=("OA-STREAM-14", "OA-STREAM-16"),
    needs=_TYPED,
    allowed=(
        "GET_INFO subscribers 1: one module registered with the stream's type T as source; "
        "one registered with source TZz (sorts after T, matches nothing) is not subscribed",
    ),
)
async def subscribers_by_type(ctx: CaseContext) -> None:
    """Create a typed stream of type T; register module A with `<inputstream source=T/>` and
    module B with `source=TZz`; GET_INFO's `subscribers` must be 1 (A only).

    Catches: a `subscribers` that leaves out the modules subscribed by registration, and a
    source compared with the type by ordering (TZz >= T) instead of equality or a pattern.
    """
    raw = await ctx.raw("Creator")
    stream_type = ctx.type("Subs")
    name = await create_stream(ctx, raw, "Subs", type=stream_type, idle=0)
    await _registered(ctx, "A", stream_type)
    await _registered(ctx, "B", stream_type + "Zz")
    client = await StreamClient.open(ctx, name)
    info = await client.info(req="OA-STREAM-16")
    ctx.check(
        info.get("subscribers") == "1",
        f"GET_INFO says subscribers={info.get('subscribers')!r}",
        expected="1: the module whose source is the type, not the one whose source only sorts "
        "after it (OA-STREAM-14, the subscribers attribute of 11.4)",
    )


@case(
    id="XSTREAM-061",
    title="A run-time stream whose maxsize exceeds max-created-stream-bytes is refused",
    section="14.1",
    requirements=("OA-LIM-17", "OA-XSTREAM-10"),
    needs=_TYPED,
    allowed=(
        "RECEIVE_ERROR LIMIT_EXCEEDED naming max-created-stream-bytes for <stream maxsize> one "
        "MiB above the advertised limit (maxsize is in units of 1 048 576 bytes)",
    ),
)
async def created_stream_bytes(ctx: CaseContext) -> None:
    """Read max-created-stream-bytes B (CAPABILITIES, default 64 MiB); ask to create a stream
    with maxsize = B / 1 MiB + 1 (in MiB). It must be refused, naming the limit.

    Catches: a byte check that does not convert maxsize from MiB to bytes.
    """
    limit = ctx.server.limit("max-created-stream-bytes", 64 * _MIB)
    over = limit // _MIB + 1
    raw = await ctx.raw("Creator")
    name = ctx.name("Big")
    content = (
        f'<stream name="{name}" whiteboard="WB1" type="{esc(ctx.type("Big"))}" maxsize="{over}"/>'
    )
    reply = await raw.request(create_stream_request(ctx, content))
    what = f"Psyclone.System.Create.Stream {content} (max-created-stream-bytes {limit})"
    if "max-created-streams" in reply.content:
        raise Inconclusive(f"setup: {what} was answered {reply.content!r}: no creations left")
    check_error(ctx, reply, names=("LIMIT_EXCEEDED",), what=what, req="OA-LIM-17")
    ctx.check(
        "max-created-stream-bytes" in reply.content,
        f"{what}: the refusal is {reply.content!r}",
        expected="the refusal names the limit max-created-stream-bytes (OA-LIM-17)",
    )
