"""Stream cases of spec 11.6 (continuous push), subscription by registration and the listing of
streams: order, the `dropped` slot of a slow subscriber, independence of subscribers, unknown
streams, inputstream deliveries to modules, GET_STREAMS and GET_INFO.

A push subscription and an add on another connection race in the server, so each case first
adds probe samples until every subscriber has had a push (`push_ready`); from then on every
sample added must reach it. Other cases may write to the stream meanwhile: pushed ids must then
still be consecutive, except where a `dropped` slot accounts for the gap.
"""

from __future__ import annotations

from collections.abc import Sequence

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._common import check_error, esc, ping_ok
from openair_conformance.cases._streams import (
    StreamClient,
    check_sample,
    chunk,
    marker,
    read_chunk,
    stream_under_test,
)
from openair_conformance.cases._streams_push import Pushed, PushReader, push_ready
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import WakeupUnreadable, attributes, content_object
from openair_conformance.model import Inconclusive
from openair_conformance.registry import case


def check_accounting(ctx: CaseContext, pushed: Sequence[Pushed], who: str) -> int:
    """Fail unless pushed ids increase and each gap equals the `dropped` slot; return the total
    dropped (OA-STREAM-8)."""
    ids = [p.sample.id if p.sample is not None else None for p in pushed]
    for p in pushed:
        ctx.check(
            not p.problem and p.sample is not None and p.sample.id is not None,
            f"a DATASAMPLE pushed to {who}: {p.problem or 'no builtin:id'}",
            expected="<datasample/> with one datasample chunk (OA-STREAM-12)",
        )
    for before, after, p in zip(ids, ids[1:], pushed[1:], strict=False):
        assert before is not None and after is not None
        ctx.check(
            after - before - 1 == p.dropped,
            f"{who} got sample {after} after {before} with dropped={p.dropped}",
            expected="every sample in id order; a gap only when the next DATASAMPLE's dropped "
            "slot counts it (OA-STREAM-8)",
        )
    return sum(p.dropped for p in pushed[1:])


def check_pushed_message(ctx: CaseContext, p: Pushed, stream: str, reader: str) -> None:
    """Fail unless a pushed message is a DATASAMPLE request from the stream to the reader."""
    msg = p.message
    try:
        content_object(msg, "datasample")
        readable = True
    except WakeupUnreadable:
        readable = False
    ctx.check(
        msg.sender == stream and msg.to == reader and readable and len(msg.binary) == 1,
        f"a push came as {msg.type} from {msg.sender!r} to {msg.to!r} with content "
        f"{msg.content[:100]!r} and {len(msg.binary)} chunks",
        expected=f"DATASAMPLE from {stream!r} to {reader!r}, <datasample/> and one chunk "
        "(OA-STREAM-12)",
    )


@case(
    id="STREAM-011",
    title="A push subscriber gets every new sample, in id order, as DATASAMPLE with its chunk",
    section="11.6",
    requirements=("OA-STREAM-8", "OA-STREAM-12", "OA-SESS-7"),
    allowed=(
        "DATASAMPLE requests from the stream to the reader (`to` = its name), one chunk each, "
        "consecutive ids; a gap only with a dropped slot counting it",
    ),
)
async def push_in_order(ctx: CaseContext) -> None:
    """Subscribe a reader (Receive frame, RECEIVE_NAME_NOTIFICATION to the stream), then add ten
    samples one by one and ten with one ADD_SAMPLES; the reader acknowledges each push.

    Catches: pushes out of order or lost, samples pushed without their chunk or altered, pushes
    addressed to someone else, a reply sent to the Receive frame.
    """
    stream = await stream_under_test(ctx)
    writer = await StreamClient.open(ctx, stream, "Writer")
    async with await PushReader.subscribe(ctx, stream, "Reader") as reader:
        await push_ready(ctx, writer, [reader])
        mark = marker(ctx)
        written = [(f"single {i}".encode(), (mark, ("conf:n", str(i)))) for i in range(10)]
        ids = [await writer.add(p, params) for p, params in written]
        batch = [(f"batch {i}".encode(), (mark, ("conf:n", str(10 + i)))) for i in range(10)]
        ids += await writer.add_many([chunk(p, params) for p, params in batch])
        written += batch
        last = ids[-1]
        pushed = await reader.until(
            lambda got: any(p.sample is not None and p.sample.id == last for p in got),
            what=f"the push of sample {last}",
        )
        ctx.check(
            not any(p.message.isresponse == reader.notice_id for p in pushed),
            "the server answered the Receive frame",
            expected="no reply to RECEIVE_NAME_NOTIFICATION (OA-SESS-7)",
        )
        for p in pushed:
            check_pushed_message(ctx, p, stream, reader.name)
        dropped = check_accounting(ctx, pushed, reader.name)
        mine = {p.sample.id: p.sample for p in pushed if p.sample is not None}
        if dropped and not set(ids) <= set(mine):
            raise Inconclusive(f"the reader fell behind ({dropped} dropped); cannot compare")
        for (payload, params), sample_id in zip(written, ids, strict=True):
            ctx.check(
                sample_id in mine, f"sample {sample_id} was never pushed", expected="OA-STREAM-8"
            )
            check_sample(
                ctx,
                mine[sample_id],
                payload=payload,
                params=params,
                sample_id=sample_id,
                what=f"pushed sample {sample_id}",
            )


@case(
    id="STREAM-012",
    title="A stalled push subscriber delays no writer or other reader and learns what it lost",
    section="11.6",
    requirements=("OA-STREAM-8", "OA-STREAM-12", "OA-DELIV-6", "OA-DELIV-5"),
    allowed=(
        "the writer's adds and the other reader's pushes go on; the stalled reader has one "
        "DATASAMPLE in flight; after it resumes, each gap is counted by a dropped slot and it "
        "reaches the newest sample",
    ),
)
async def slow_subscriber(ctx: CaseContext) -> None:
    """Subscribe a reader that holds its acknowledgements and one that answers at once. Add 150
    samples: every add is answered in time and the fast reader gets all of them while the
    stalled one has exactly one push. Then the stalled reader acknowledges again.

    Catches: a server that waits for the slowest reader, sends more than one push without an
    acknowledgement, drops samples without saying so, or loses the newest ones.
    """
    stream = await stream_under_test(ctx)
    writer = await StreamClient.open(ctx, stream, "Writer")
    slow = await PushReader.subscribe(ctx, stream, "Slow", paused=True)
    fast = await PushReader.subscribe(ctx, stream, "Fast")
    async with slow, fast:
        await push_ready(ctx, writer, [slow, fast])
        mark = marker(ctx)
        ids = [await writer.add(b"s" * 100, [mark, ("conf:n", str(i))]) for i in range(150)]
        await fast.until(lambda got: _reached(got, ids[-1]), what="the fast reader's pushes")
        check_accounting(ctx, fast.pushed, fast.name)
        ctx.check(
            len(slow.pushed) == 1,
            f"the stalled reader got {len(slow.pushed)} pushes without acknowledging one",
            expected="one DATASAMPLE at a time, each after the previous RECEIVE_ACCEPT "
            "(OA-STREAM-8, OA-DELIV-5)",
        )
        await slow.resume()
        pushed = await slow.until(lambda got: _reached(got, ids[-1]), what="the stalled pushes")
        dropped = check_accounting(ctx, pushed, slow.name)
        if not dropped:
            ctx.vacuous("the server buffered all 150 samples for the stalled reader")
        got = {p.sample.id for p in pushed if p.sample is not None}
        if ids[-1] not in got and pushed[-1].dropped:
            raise Inconclusive("other writers' samples pushed the case's last one out as well")
        ctx.check(
            ids[-1] in got,
            f"the stalled reader never got sample {ids[-1]}, the last one added",
            expected="the oldest unsent samples are dropped, the newest kept (OA-STREAM-8)",
        )


def _reached(pushed: Sequence[Pushed], last: int) -> bool:
    return any(p.sample is not None and (p.sample.id or 0) >= last for p in pushed)


@case(
    id="STREAM-013",
    title="A push subscription to an unknown stream is refused STREAM_UNKNOWN",
    section="11.6",
    requirements=("OA-STREAM-3", "OA-STREAM-8"),
    allowed=("RECEIVE_ERROR 'STREAM_UNKNOWN: detail'; the connection still answers PING",),
)
async def push_unknown_stream(ctx: CaseContext) -> None:
    """Send a Receive frame with RECEIVE_NAME_NOTIFICATION to a name no stream has, then PING.

    Catches: a silent subscription to nothing, a connection left in an unusable state.
    """
    raw = await ctx.raw("Reader")
    notice = Message(
        type="RECEIVE_NAME_NOTIFICATION", sender=ctx.name("Reader"), to=ctx.name("NoStream")
    )
    await raw.send_message(notice, FrameTag.RECEIVE)
    reply = await raw.read_message()
    check_error(ctx, reply, names=("STREAM_UNKNOWN",), what="the notification", req="OA-STREAM-8")
    await ping_ok(ctx, raw, what="after the refused subscription", req="OA-STREAM-8")


async def _stream_module(ctx: CaseContext, suffix: str, streams_xml: str) -> TestModule:
    module = await ctx.module(suffix)
    trigger = f'<trigger from="WB1" type="{esc(ctx.type("Never"))}"/>'
    reply = await module.subscribe(f'<module name="{module.name}">{streams_xml}{trigger}</module>')
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"AIR.Subscribe with {streams_xml} was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT: stream subscriptions are part of a registration (OA-STREAM-14)",
    )
    return module


def marked(msg: Message, mark: tuple[str, str]) -> bool:
    """Return whether `msg` is a DATASAMPLE whose sample carries the parameter `mark`."""
    if msg.type != "DATASAMPLE" or len(msg.binary) != 1:
        return False
    try:
        return read_chunk(msg.binary[0]).param(mark[0]) == mark[1]
    except ValueError:
        return False


async def delivered_sample(
    ctx: CaseContext, module: TestModule, stream: str, mark: tuple[str, str]
) -> Message:
    """Return the DATASAMPLE delivery to `module` that carries `mark` (others are skipped)."""
    while True:
        msg = await module.next_delivery()
        if marked(msg, mark):
            return msg


@case(
    id="STREAM-016",
    title="A module whose registration names the stream as a source receives each new sample",
    section="11.6",
    requirements=("OA-STREAM-14", "OA-STREAM-12"),
    allowed=(
        "DATASAMPLE delivered to the module (`to` = its name) on its delivery path for "
        "<inputstream source> and <stream source>; nothing for an <outputstream>",
    ),
)
async def registration_subscription(ctx: CaseContext) -> None:
    """Register one module with `<streams><inputstream alias source=STREAM/></streams>`, one
    with `<stream name source=STREAM/>` and one with only `<outputstream>`; add a marked
    sample. The first two get it as a DATASAMPLE delivery; the third gets nothing (shown with
    a barrier). (That two elements selecting one stream give one delivery is checked on a
    stream of its own, XSTREAM-002: on a shared stream a barrier waits behind every sample.)

    Catches: stream subscriptions in registrations ignored, deliveries without the chunk,
    outputstream treated as a subscription.
    """
    stream = await stream_under_test(ctx)
    source = f'source="{esc(stream)}"'
    both = f'<stream name="Video" {source}/><inputstream alias="Also" {source}/>'
    readers = [
        await _stream_module(
            ctx, "Input", f'<streams><inputstream alias="In" {source}/></streams>'
        ),
        await _stream_module(ctx, "Named", both),
    ]
    writer_only = await _stream_module(ctx, "Output", f'<outputstream alias="Out" {source}/>')
    writer = await StreamClient.open(ctx, stream, "Writer")
    mark = marker(ctx)
    params = (mark, ("conf:for", "modules"))
    added = await writer.add(b"to modules", params)
    for module in readers:
        msg = await delivered_sample(ctx, module, stream, mark)
        ctx.check(
            msg.to == module.name and msg.sender == stream,
            f"the delivery to {module.name} is from {msg.sender!r} to {msg.to!r}",
            expected=f"from {stream!r} to the module (OA-STREAM-14)",
        )
        got = writer.sample_of(msg, f"the delivery to {module.name}", req="OA-STREAM-14")
        check_sample(
            ctx, got, payload=b"to modules", params=params, sample_id=added, what="delivered"
        )
    await writer_only.barrier()
    samples = [m for m in writer_only.deliveries_seen if m.type == "DATASAMPLE"]
    ctx.check(
        not samples,
        f"the module with only an outputstream got {len(samples)} DATASAMPLE deliveries",
        expected="none: an outputstream declares what the module writes (OA-STREAM-14)",
    )


@case(
    id="STREAM-017",
    title="GET_STREAMS lists the streams; GET_INFO describes one",
    section="11.4",
    requirements=("OA-STREAM-16", "OA-STREAM-1"),
    allowed=(
        "STREAMS with <streams> holding a <streaminfo name whiteboard count size maxsize …/> for "
        "the stream; INFO with one <streaminfo> of the same name",
    ),
)
async def listing(ctx: CaseContext) -> None:
    """Add a sample; ask CNS for GET_STREAMS and the stream for GET_INFO; compare.

    Catches: a missing listing, a stream left out, counts or sizes that are not numbers.
    """
    stream = await stream_under_test(ctx)
    writer = await StreamClient.open(ctx, stream)
    await writer.add(b"listed", [marker(ctx)])
    reply = await writer.raw.request(Message(type="GET_STREAMS", sender=writer.sender, to="CNS"))
    want = "STREAMS with <streams> of <streaminfo> elements (OA-STREAM-16)"
    ctx.check(reply.type == "STREAMS", f"GET_STREAMS was answered {reply.type}", expected=want)
    try:
        root = content_object(reply, "streams")
    except WakeupUnreadable as exc:
        ctx.fail(f"STREAMS content: {exc}", expected=want)
    infos = [attributes(el) for el in root if isinstance(el.tag, str)]
    ours = [i for i in infos if i.get("name") == stream]
    ctx.check(len(ours) == 1, f"STREAMS lists {[i.get('name') for i in infos]}", expected=want)
    info = await writer.info(req="OA-STREAM-16")
    for what, attrs in (("STREAMS", ours[0]), ("INFO", info)):
        numbers = {k: attrs.get(k, "") for k in ("count", "size", "maxsize", "maxcount")}
        ctx.check(
            attrs.get("name") == stream
            and bool(attrs.get("whiteboard"))
            and all(v.isdigit() for v in numbers.values())
            and int(numbers["count"]) >= 1,
            f"the {what} streaminfo is {attrs}",
            expected="name, whiteboard, and decimal count (>= 1), size, maxsize and maxcount "
            "(OA-STREAM-16)",
        )
