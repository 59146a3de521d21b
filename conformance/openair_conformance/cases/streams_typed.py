"""Cases of the `typed-streams` extension (spec 11.7) that need no alarm: run-time creation,
addressing by type, the core commands on a fresh stream, rings by count and size, the hard size
limit, and SEARCH_SAMPLES.

Each case creates its own streams with Psyclone.System.Create.Stream (OA-XSTREAM-10), named and
typed under the case's prefix, so that ids start at 1 and nothing else writes to them. Without
`typed-streams` these cases are not applicable. Limits, locks and alarms are in
streams_alarms.py.
"""

from __future__ import annotations

from openair.protocol.message import Message
from openair_conformance.cases._common import check_error, esc
from openair_conformance.cases._streams import (
    StreamClient,
    check_from,
    chunk,
    create_stream,
    create_stream_request,
    marker,
    past_window,
    time_xml,
)
from openair_conformance.cases._streams_push import PushReader, push_ready
from openair_conformance.cases.streams_push import delivered_sample, marked
from openair_conformance.harness import CaseContext, RawConnection
from openair_conformance.harness.checks import WakeupUnreadable, attributes, content_object
from openair_conformance.registry import case

_TYPED = ("typed-streams",)


async def _resolves(ctx: CaseContext, raw: RawConnection, name: str) -> bool:
    reply = await raw.request(
        Message(type="RESOLVE_REQUEST", sender=ctx.name("R"), to="CNS", content=name)
    )
    return reply.type == "RESOLVE_SUCCESS"


async def _create_refused(ctx: CaseContext, raw: RawConnection, content: str, why: str) -> None:
    reply = await raw.request(create_stream_request(ctx, content))
    check_error(
        ctx, reply, names=("CONTENT_INVALID",), what=f"Create.Stream {why}", req="OA-XSTREAM-10"
    )


@case(
    id="XSTREAM-001",
    title="Psyclone.System.Create.Stream creates an empty stream; bad requests are CONTENT_INVALID",
    section="11.7",
    requirements=("OA-XSTREAM-10", "OA-STREAM-4", "OA-SESS-8", "OA-STREAM-16", "OA-STREAM-6"),
    needs=_TYPED,
    allowed=(
        "RECEIVE_ACCEPT; the name resolves, the stream is empty and its first ids are 1, 2; "
        "RECEIVE_ERROR CONTENT_INVALID for a taken name or type, no or an unknown whiteboard, "
        "softcount above hardcount, an invalid type, content that is no <stream>, the name of a "
        "bound module; GET_STREAMS lists the new streams last, in order",
    ),
)
async def create_at_run_time(ctx: CaseContext) -> None:
    """Create a stream and a typed one; resolve the name; GET_COUNT, GET_NEWEST_DATASAMPLE and
    two adds. Then ask for streams named like a bound module, an existing stream or a
    whiteboard, typed like an existing stream, without whiteboard, in an unknown whiteboard,
    with softcount 5 above hardcount 2, with the type `a..b`, with `<streem/>` and with no
    content. Finally GET_STREAMS lists the two new streams after the configured ones, in
    creation order.

    Catches: streams that cannot be created, created twice, or start with ids other than 1.
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(ctx, raw, "New", setup=False)
    typed = await create_stream(ctx, raw, "Typed", setup=False, type=ctx.type("Typed"))
    ctx.check(
        await _resolves(ctx, raw, name),
        f"RESOLVE_REQUEST of the new stream {name} failed",
        expected="RESOLVE_SUCCESS: a stream is a component (OA-SESS-8, OA-XSTREAM-10)",
    )
    client = await StreamClient.open(ctx, name)
    count = await client.number("GET_COUNT", "COUNT", req="OA-XSTREAM-10")
    ctx.check(count == 0, f"the new stream holds {count} samples", expected="none")
    await client.unknown("GET_NEWEST_DATASAMPLE", req="OA-STREAM-6")
    ids = [await client.add(b"first"), await client.add(b"second")]
    ctx.check(ids == [1, 2], f"the new stream gave the ids {ids}", expected="[1, 2] (OA-STREAM-4)")
    bound = await ctx.module("Bound", listen=False, callback=False)
    wb = 'whiteboard="WB1"'
    for content, why in (
        (f'<stream name="{bound.name}" {wb}/>', "with the name of a bound module"),
        (f'<stream name="{name}" {wb}/>', "with a name already used by a stream"),
        (f'<stream name="WB2" {wb}/>', "with the name of a whiteboard"),
        (f'<stream name="{ctx.name("T2")}" {wb} type="{ctx.type("Typed")}"/>', "with a taken type"),
        (f'<stream name="{ctx.name("NoWB")}"/>', "without a whiteboard"),
        (f'<stream name="{ctx.name("BadWB")}" whiteboard="{ctx.name("NoWB")}"/>', "in no board"),
        (
            f'<stream name="{ctx.name("Soft")}" {wb} type="{ctx.type("Soft")}" softcount="5" '
            'hardcount="2"/>',
            "with softcount above hardcount",
        ),
        (f'<stream name="{ctx.name("Dots")}" {wb} type="a..b"/>', "with the type a..b"),
        (f'<streem name="{ctx.name("Streem")}" {wb}/>', "whose content is no <stream>"),
        ("", "with no content"),
    ):
        await _create_refused(ctx, raw, content, why)
    ctx.check(
        not await _resolves(ctx, raw, ctx.name("NoWB")),
        "a refused stream resolves",
        expected="nothing created by a refused request (OA-XSTREAM-10)",
    )
    await _listed_in_order(ctx, raw, [name, typed])


async def _listed_in_order(ctx: CaseContext, raw: RawConnection, created: list[str]) -> None:
    """GET_STREAMS lists the streams created at run time after the others, in order."""
    reply = await raw.request(Message(type="GET_STREAMS", sender=ctx.name("R"), to="CNS"))
    want = "STREAMS listing the configured streams, then the created ones in order (OA-STREAM-16)"
    try:
        root = content_object(reply, "streams")
    except WakeupUnreadable as exc:
        ctx.fail(f"GET_STREAMS was answered {reply.type}: {exc}", expected=want)
    names = [attributes(el).get("name", "") for el in root if isinstance(el.tag, str)]
    ours = [n for n in names if n in created]
    first = min((names.index(n) for n in created if n in names), default=-1)
    ctx.check(
        ours == created and (ctx.stream not in names or names.index(ctx.stream) < first),
        f"GET_STREAMS lists {names}",
        expected=want,
    )


@case(
    id="XSTREAM-002",
    title="A typed stream is addressed, resolved and subscribed to by its type; a name wins",
    section="11.7",
    requirements=("OA-XSTREAM-1", "OA-STREAM-14", "OA-STREAM-8"),
    needs=_TYPED,
    allowed=(
        "media commands to the type answered from the stream's name; RESOLVE_SUCCESS for the "
        "type; pushes to a reader subscribed by type; deliveries to a module whose inputstream "
        "source is a type pattern; a name equal to another stream's type addresses that name",
    ),
)
async def typed_addressing(ctx: CaseContext) -> None:
    """Create a stream typed T; add to T, GET_NAME to T (and to T in upper case), resolve T,
    subscribe a push reader to T and register a module with both
    `<inputstream source="<prefix>.*"/>` and `<stream source=NAME/>` (one delivery per sample
    all the same). Create a stream named D and another typed D: GET_NAME to D names the first.

    Catches: types not resolved, replies from the type instead of the name, type patterns in
    registrations ignored, a type preferred over a name.
    """
    raw = await ctx.raw("Creator")
    kind = ctx.type("Video")
    name = await create_stream(ctx, raw, "Video", type=kind, idle=0)
    ctx.check(
        await _resolves(ctx, raw, kind),
        f"RESOLVE_REQUEST of the type {kind} failed",
        expected="RESOLVE_SUCCESS for a typed stream's type (OA-XSTREAM-1)",
    )
    by_type = await StreamClient.open(ctx, name, "ByType", to=kind)
    for to in (kind, kind.upper()):
        reply = await by_type.raw.request(Message(type="GET_NAME", sender=by_type.sender, to=to))
        check_from(ctx, reply, name, f"GET_NAME to {to}")
        ctx.check(
            reply.type == "NAME" and reply.content.strip() == name,
            f"GET_NAME to the type {to} was answered {reply.type} {reply.content!r}",
            expected=f"NAME {name!r}; a type is compared ignoring ASCII case (OA-XSTREAM-1)",
        )
    module = await ctx.module("Subscriber")
    source = f'<inputstream alias="In" source="{esc(ctx.type_prefix())}.*"/>'
    source += f'<stream name="Again" source="{esc(name)}"/>'  # the same stream a second time
    await module.subscribe(f'<module name="{module.name}">{source}</module>', check=True)
    async with await PushReader.subscribe(ctx, kind, "Reader") as reader:
        await push_ready(ctx, by_type, [reader])
        mark = marker(ctx)
        added = await by_type.add(b"typed", [mark, ("conf:via", "type")], req="OA-XSTREAM-1")
        await reader.until(
            lambda got: any(p.sample is not None and p.sample.id == added for p in got),
            what=f"the push of sample {added} to the reader subscribed by type",
        )
        via = ("conf:via", "type")
        msg = await delivered_sample(ctx, module, name, via)
        ctx.check(
            msg.sender == name and msg.to == module.name,
            f"the delivery by type pattern came from {msg.sender!r} to {msg.to!r}",
            expected=f"a DATASAMPLE from {name!r} (OA-STREAM-14, OA-XSTREAM-1)",
        )
        await module.barrier()
        copies = [m for m in module.deliveries_seen if marked(m, via)]
        ctx.check(
            len(copies) == 1,
            f"{module.name}, whose registration selects the stream twice (by type pattern and "
            f"by name), got the sample {len(copies)} times",
            expected="once per sample however many elements select the stream (OA-STREAM-14)",
        )
    await _name_wins(ctx, raw, ctx.type("Dual"))


async def _name_wins(ctx: CaseContext, raw: RawConnection, dual: str) -> None:
    """Create a stream named `dual` and one typed `dual`: `dual` addresses the first."""
    reply = await raw.request(
        create_stream_request(ctx, f'<stream name="{dual}" whiteboard="WB1"/>')
    )
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"creating the stream {dual} was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT: a stream name may hold dots (OA-XSTREAM-10)",
    )
    await create_stream(ctx, raw, "DualTyped", type=dual, idle=0)
    client = await StreamClient.open(ctx, dual, "Dual")
    reply = await client.request("GET_NAME")
    ctx.check(
        reply.type == "NAME" and reply.content.strip() == dual,
        f"GET_NAME to {dual} was answered {reply.type} {reply.content!r} (the stream named "
        f"{dual} exists, and {ctx.name('DualTyped')} has it as its type)",
        expected=f"NAME {dual!r}: a name takes precedence over a type (OA-XSTREAM-1)",
    )


@case(
    id="XSTREAM-003",
    title="On a stream of its own every reading and waiting command gives the exact answer",
    section="11.4",
    requirements=("OA-STREAM-6", "OA-STREAM-7", "OA-STREAM-4"),
    needs=_TYPED,
    allowed=(
        "empty: COUNT 0, SIZE 0, SAMPLE_UNKNOWN, an empty DATASAMPLES; with samples stamped T, "
        "T+10, T+20: the counts, sizes, newest and oldest samples and timestamps, and the "
        "waits' answers of the tables of 11.4 and 11.5",
    ),
)
async def fresh_stream_reads(ctx: CaseContext) -> None:
    """Create a stream; ask every reading command while it is empty and WAIT_FOR_* with
    timeout 0. Add three samples stamped T, T+10, T+20; ask them all again. Add a fourth
    stamped T-5 (timestamps out of order): newest timestamp, lookup and range again.

    Catches: answers that are only right on a busy stream (off-by-one in newest/oldest,
    timestamps of the wrong end), waits with timeout 0 that block.
    """
    raw = await ctx.raw("Creator")
    client = await StreamClient.open(ctx, await create_stream(ctx, raw, "Fresh"))
    await _numbers(ctx, client, 0, 0)
    for type in ("GET_NEWEST_DATASAMPLE", "GET_OLDEST_DATASAMPLE"):
        await client.unknown(type, req="OA-STREAM-6")
    for type in ("GET_NEWEST_TIMESTAMP", "GET_OLDEST_TIMESTAMP"):
        await client.unknown(type, req="OA-STREAM-6")
    await client.unknown("WAIT_FOR_FIRST_AFTERID 0", "0", req="OA-STREAM-7")
    base = past_window(ctx)
    sizes = (10, 20, 30)
    for dt, size in zip((0, 10, 20), sizes, strict=True):
        await client.add(bytes(size), [("builtin:timestamp", str(base + dt))])
    await _numbers(ctx, client, 3, sum(sizes))
    checks = (
        ("GET_NEWEST_DATASAMPLE", "", 3),
        ("GET_OLDEST_DATASAMPLE", "", 1),
        ("WAIT_FOR_FIRST_SAMPLE 0", time_xml(base + 5), 2),
        ("WAIT_FOR_LAST_SAMPLE 0", time_xml(base + 5), 3),
        ("WAIT_FOR_FIRST_SAMPLE 0", time_xml(base + 10), 2),
        ("WAIT_FOR_FIRST_AFTERID 0", "1", 2),
        ("WAIT_FOR_LAST_AFTERID 0", "1", 3),
    )
    for type, content, want in checks:
        reply = await client.request(type, content, xml=content.startswith("<"))
        got = client.sample_of(reply, f"{type} {content}", req="OA-STREAM-6")
        ctx.check(
            got.id == want,
            f"{type} {content} answered sample {got.id}",
            expected=f"sample {want} (OA-STREAM-6, OA-STREAM-7)",
        )
    await client.unknown("WAIT_FOR_LAST_AFTERID 0", "3", req="OA-STREAM-7")
    await client.unknown(
        "WAIT_FOR_FIRST_SAMPLE 0", time_xml(base + 21), xml=True, req="OA-STREAM-7"
    )
    for type, want in (("GET_NEWEST_TIMESTAMP", base + 20), ("GET_OLDEST_TIMESTAMP", base)):
        got_ms = await client.timestamp(type)
        ctx.check(got_ms == want, f"{type} is {got_ms}", expected=f"{want} (OA-STREAM-6)")
    await _out_of_order(ctx, client, base)


async def _out_of_order(ctx: CaseContext, client: StreamClient, base: int) -> None:
    """Add sample 4 stamped T-5: lookups by time must not assume ordered timestamps."""
    await client.add(b"late", [("builtin:timestamp", str(base - 5))])
    got_ms = await client.timestamp("GET_NEWEST_TIMESTAMP")
    ctx.check(
        got_ms == base - 5,
        f"GET_NEWEST_TIMESTAMP is {got_ms} after sample 4 stamped T-5",
        expected=f"{base - 5}: the timestamp of the newest sample (OA-STREAM-6)",
    )
    reply = await client.request("GET_SAMPLE_BY_TIME", time_xml(base + 25), xml=True)
    got = client.sample_of(reply, "GET_SAMPLE_BY_TIME T+25")
    # OA-STREAM-6: the greatest timestamp at or before the time, not the newest sample
    ctx.check(got.id == 3, f"GET_SAMPLE_BY_TIME T+25 answered {got.id}", expected="3")
    content = (
        f"<objectcollection><object>{time_xml(base - 5)}</object>"
        f"<object>{time_xml(base)}</object></objectcollection>"
    )
    reply = await client.request("GET_SAMPLES_BY_TIME", content, xml=True)
    ids = [
        s.id for s in client.samples_of(reply, "GET_SAMPLES_BY_TIME [T-5, T]", req="OA-STREAM-6")
    ]
    ctx.check(ids == [1, 4], f"[T-5, T] answered {ids}", expected="[1, 4], by id (OA-STREAM-6)")


async def _numbers(ctx: CaseContext, client: StreamClient, count: int, size: int) -> None:
    got = (await client.number("GET_COUNT", "COUNT"), await client.number("GET_SIZE", "SIZE"))
    ctx.check(
        got == (count, size),
        f"GET_COUNT, GET_SIZE answered {got}",
        expected=f"{(count, size)} (OA-STREAM-6)",
    )


@case(
    id="XSTREAM-004",
    title="A ring by maxcount or maxsize drops exactly the oldest samples; ids keep counting",
    section="11.1",
    requirements=("OA-STREAM-9", "OA-STREAM-4", "OA-XSTREAM-5"),
    needs=_TYPED,
    allowed=(
        "maxcount 3: after ids 1–5 the stream holds 3–5, after an ADD_SAMPLES of four 7–9, "
        "after locking them and adding one 8–10; "
        "maxsize 0.001 (1048 bytes) with 400-byte samples: two held",
    ),
)
async def rings(ctx: CaseContext) -> None:
    """Create an untyped stream with maxcount 3 and add five samples one by one and four with
    ADD_SAMPLES; lock the three held and add one more (an untyped stream ignores locks);
    create one with maxsize 0.001 and add three samples of 400 bytes.

    Catches: rings that keep one sample too many or too few, ids restarting after a drop,
    maxsize read in bytes or KiB.
    """
    raw = await ctx.raw("Creator")
    by_count = await StreamClient.open(ctx, await create_stream(ctx, raw, "Count", maxcount=3))
    ids = [await by_count.add(f"{n}".encode()) for n in range(5)]
    ids += await by_count.add_many([chunk(f"b{n}".encode()) for n in range(4)])
    ctx.check(
        ids == list(range(1, 10)),
        f"the ids given are {ids}",
        expected="1 … 9: ids keep counting when samples are dropped (OA-STREAM-4)",
    )
    await _held(ctx, by_count, [7, 8, 9], gone=[1, 6])
    reply = await by_count.request("LOCK_SAMPLES", "7-9")
    ctx.check(
        reply.type == "LOCKED",
        f"LOCK_SAMPLES on an untyped stream was answered {reply.type} {reply.content!r}",
        expected="LOCKED: granted, but it protects nothing (11.7, OA-XSTREAM-5)",
    )
    await by_count.add(b"after the lock")
    await _held(ctx, by_count, [8, 9, 10], gone=[7])
    by_size = await StreamClient.open(
        ctx, await create_stream(ctx, raw, "Size", maxsize="0.001"), "Sizer"
    )
    for _ in range(3):
        await by_size.add(bytes(400))
    await _held(ctx, by_size, [2, 3], gone=[1])


async def _held(ctx: CaseContext, client: StreamClient, want: list[int], gone: list[int]) -> None:
    count = await client.number("GET_COUNT", "COUNT", req="OA-STREAM-9")
    oldest = client.sample_of(await client.request("GET_OLDEST_DATASAMPLE"), "GET_OLDEST").id
    ctx.check(
        (count, oldest) == (len(want), want[0]),
        f"{client.stream} holds {count} samples, the oldest {oldest}",
        expected=f"{len(want)} samples {want} (OA-STREAM-9)",
    )
    for sample_id in gone:
        await client.unknown("GET_SAMPLE_BY_ID", str(sample_id), req="OA-STREAM-9")


@case(
    id="XSTREAM-007",
    title="A typed stream refuses a sample whose payload exceeds hardsize, and takes one at it",
    section="11.7",
    requirements=("OA-XSTREAM-4", "OA-STREAM-13"),
    needs=_TYPED,
    allowed=("DATA_NOT_ACCEPTED SAMPLE_INVALID for 1001 bytes; DATA_ACCEPTED for 1000",),
)
async def hard_size_limit(ctx: CaseContext) -> None:
    """Create a stream typed T with hardsize 1000; add 1001 bytes, then 1000 bytes.

    Catches: an oversized sample accepted (and everything else dropped for it), a limit
    treated as exclusive.
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(ctx, raw, "Hard", type=ctx.type("Hard"), hardsize=1000, idle=0)
    client = await StreamClient.open(ctx, name)
    reply = await client.add_chunk(chunk(bytes(1001)))
    client.refused(reply, "ADD_SAMPLE of 1001 bytes (hardsize 1000)", req="OA-XSTREAM-4")
    await client.add(bytes(1000), req="OA-XSTREAM-4")
    count = await client.number("GET_COUNT", "COUNT", req="OA-XSTREAM-4")
    ctx.check(count == 1, f"the stream holds {count} samples", expected="1 (OA-XSTREAM-4)")


_SEARCH_SAMPLES = (
    (("kind", "audio"), ("lang", "en")),
    (("kind", "video"),),
    (("kind", "audio"), ("lang", "de")),
    (("kind", "audio-hd"),),
    (("kind", "Audio"),),
)


def _search_xml(*parts: str) -> str:
    return f"<samplesearch>{''.join(parts)}</samplesearch>"


@case(
    id="XSTREAM-011",
    title="SEARCH_SAMPLES selects by parameter glob and inclusive time bounds, newest `latest`",
    section="11.7",
    requirements=("OA-XSTREAM-9", "OA-RET-8"),
    needs=_TYPED,
    allowed=(
        "DATASAMPLES oldest first: the samples whose parameters match every glob (a missing "
        "parameter never matches; case-sensitive; ? literal) within afterTime..untilTime, the "
        "newest `latest` of them",
    ),
)
async def search(ctx: CaseContext) -> None:
    """Create a typed stream and add five samples stamped T, T+10 … T+40 with the parameters
    kind=audio/video/audio/audio-hd/Audio (lang on two); search by `audio`, `audio*`, `*`,
    `audi?`, lang `*`, `latest`, time bounds as elements and as ms text, and all at once.

    Catches: globs as substrings or case-insensitive, `?` as a wildcard, exclusive bounds,
    `latest` taking the oldest, missing parameters matching `*`.
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(ctx, raw, "Search", type=ctx.type("Search"), idle=0)
    client = await StreamClient.open(ctx, name)
    base = past_window(ctx)
    for n, params in enumerate(_SEARCH_SAMPLES):
        stamp = ("builtin:timestamp", str(base + 10 * n))
        await client.add(f"s{n + 1}".encode(), (*params, stamp))
    after = f"<afterTime>{time_xml(base + 10)}</afterTime>"
    until = f"<untilTime>{base + 30}</untilTime>"

    def glob(key: str, pattern: str) -> str:
        return f'<param name="{key}">{esc(pattern)}</param>'

    for content, want in (
        (_search_xml(glob("kind", "audio")), [1, 3]),
        (_search_xml(glob("kind", "audio*")), [1, 3, 4]),
        (_search_xml(glob("kind", "*")), [1, 2, 3, 4, 5]),
        (_search_xml(glob("kind", "audi?")), []),
        (_search_xml(glob("lang", "*")), [1, 3]),
        (_search_xml(glob("kind", "audio*"), "<latest>2</latest>"), [3, 4]),
        (_search_xml("<latest>0</latest>"), [1, 2, 3, 4, 5]),
        (_search_xml(after, until), [2, 3, 4]),
        (_search_xml(after, until, glob("kind", "audio*"), "<latest>1</latest>"), [4]),
        (_search_xml(), [1, 2, 3, 4, 5]),
    ):
        reply = await client.request("SEARCH_SAMPLES", content, xml=True)
        got = [s.id for s in client.samples_of(reply, content, req="OA-XSTREAM-9")]
        ctx.check(got == want, f"{content} found {got}", expected=f"{want} (OA-XSTREAM-9)")


@case(
    id="XSTREAM-012",
    title="SEARCH_SAMPLES with content that is no valid <samplesearch> is CONTENT_INVALID",
    section="11.7",
    requirements=("OA-XSTREAM-9",),
    needs=_TYPED,
    allowed=("RECEIVE_ERROR with content 'CONTENT_INVALID: detail' for each",),
)
async def search_refused(ctx: CaseContext) -> None:
    """Send SEARCH_SAMPLES with an unknown child (empty, or holding a valid byte pattern), a
    `param` without name, a bound that is no time, another root element, `latest` twice and
    `untilTime` twice.

    Catches: searches that ignore what they cannot read (and so return more than asked for).
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(ctx, raw, "Search", type=ctx.type("Search"), idle=0)
    client = await StreamClient.open(ctx, name)
    await client.add(b"one")
    for bad in (
        _search_xml("<bogus/>"),
        _search_xml("<bogus>41 42</bogus>"),  # an unknown child, even with a valid byte pattern
        _search_xml("<param>x</param>"),
        _search_xml("<afterTime>soon</afterTime>"),
        "<search/>",
        _search_xml("<latest>1</latest><latest>2</latest>"),
        _search_xml("<untilTime>5</untilTime><untilTime>6</untilTime>"),
    ):
        reply = await client.request("SEARCH_SAMPLES", bad, xml=True)
        check_error(ctx, reply, names=("CONTENT_INVALID",), what=bad, req="OA-XSTREAM-9")
