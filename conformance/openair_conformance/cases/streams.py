"""Stream cases (spec section 11): unknown streams, samples on the wire, writing and reading.

Every server is judged on STREAM-001 (a server without streams answers media commands as for an
unknown stream, OA-GEN-4). The other core cases use the stream `--stream` names (default
`Stream1`, which Psyclone and the kit's server offer without a configuration, OA-STREAM-15);
when it does not resolve they are not applicable. The stream is shared with other cases and
may hold samples already: cases find their own samples by id, by a parameter unique to the case
(`marker`) or by explicit timestamps in a window unique to the case (`past_window`). Waiting is
in streams_wait.py, push and listing in streams_push.py, the typed-streams extension in
streams_typed.py.
"""

from __future__ import annotations

from openair.protocol.message import Message
from openair_conformance.cases._common import check_error
from openair_conformance.cases._streams import (
    MIB,
    Sample,
    StreamClient,
    check_from,
    check_sample,
    chunk,
    marker,
    past_window,
    samples_xml,
    stream_under_test,
    time_xml,
)
from openair_conformance.harness import CaseContext
from openair_conformance.model import Inconclusive, NotApplicable
from openair_conformance.registry import case

#: Media commands of 11.3–11.5 that need no content to be recognised.
_MEDIA_COMMANDS = ("GET_COUNT", "GET_NEWEST_DATASAMPLE", "GET_OLDEST_TIMESTAMP", "GET_SIZE")
#: The largest stream limit the suite fills (STREAM-014, STREAM-015).
_MAX_FILL = 32 * MIB


@case(
    id="STREAM-001",
    title="A media command to a name that is no stream is answered STREAM_UNKNOWN",
    section="11.1",
    requirements=("OA-STREAM-3", "OA-GEN-4", "OA-ERR-6"),
    allowed=("RECEIVE_ERROR with content 'STREAM_UNKNOWN: detail' (not FORWARD_FAILED)",),
)
async def media_command_unknown_stream(ctx: CaseContext) -> None:
    """Send GET_COUNT, GET_NEWEST_DATASAMPLE, GET_OLDEST_TIMESTAMP and GET_SIZE to a name no
    component, whiteboard, stream or module has.

    Catches: media commands routed like posts (FORWARD_FAILED), which gives a stream client no
    way to tell a missing stream from a missing module.
    """
    raw = await ctx.raw()
    to = ctx.name("NoStream")
    for command in _MEDIA_COMMANDS:
        reply = await raw.request(Message(type=command, sender=ctx.name("S"), to=to))
        check_error(
            ctx, reply, names=("STREAM_UNKNOWN",), what=f"{command} to {to}", req="OA-STREAM-3"
        )


@case(
    id="STREAM-002",
    title="A sample's payload and parameters come back exactly; id and timestamp are the stream's",
    section="11.2",
    requirements=("OA-STREAM-1", "OA-STREAM-2", "OA-STREAM-4", "OA-STREAM-5"),
    allowed=(
        "DATA_ACCEPTED from the stream with increasing ids; DATASAMPLE with <datasample/> and one "
        "chunk: the payload unchanged, the writer's parameters in order, builtin:id = the id, "
        "builtin:timestamp = the writer's or the receive time",
    ),
)
async def sample_round_trip(ctx: CaseContext) -> None:
    """Add three samples to the stream: every byte value (and the separators) as payload with
    parameters that include a `%` and `builtin:id` twice; an empty payload whose only parameter
    is the invalid `builtin:timestamp=-5`; and 1000 bytes with an explicit `builtin:timestamp`
    and an empty value. Read each back by id.

    Catches: payload bytes altered or cut at NUL or at `%sep%`, parameters reordered or lost,
    the writer's builtin:id kept or moved, a writer's timestamp ignored (or an invalid one
    kept), replies not from the stream.
    """
    stream = await stream_under_test(ctx)
    writer = await StreamClient.open(ctx, stream)
    stamp = past_window(ctx) + 7
    written = [
        (
            bytes(range(256)) * 4 + b"%sep%%equals%\0",
            (
                marker(ctx),
                ("conf:text", "a b=c;50% off"),
                ("builtin:id", "999999999"),
                ("conf:k", "v"),
                ("builtin:id", "5"),
            ),
        ),
        (b"", (("builtin:timestamp", "-5"),)),
        (b"C" * 1000, (("builtin:timestamp", str(stamp)), marker(ctx), ("conf:empty", ""))),
    ]
    ids = []
    for payload, params in written:
        reply = await writer.add_chunk(chunk(payload, params))
        ids.append(writer.accepted_id(reply, "ADD_SAMPLE", req="OA-STREAM-5"))
        check_from(ctx, reply, stream, "DATA_ACCEPTED")
    ctx.check(
        ids == sorted(set(ids)),
        f"the stream gave the ids {ids}",
        expected="increasing ids (OA-STREAM-4)",
    )
    for (payload, params), sample_id in zip(written, ids, strict=True):
        reply = await writer.request("GET_SAMPLE_BY_ID", str(sample_id))
        check_from(ctx, reply, stream, f"GET_SAMPLE_BY_ID {sample_id}")
        got = writer.sample_of(reply, f"GET_SAMPLE_BY_ID {sample_id}")
        check_sample(
            ctx,
            got,
            payload=payload,
            params=params,
            sample_id=sample_id,
            what=f"sample {sample_id}",
            timestamp=stamp if sample_id == ids[2] else None,
        )


@case(
    id="STREAM-003",
    title="Ids go up by one per sample added, also within ADD_SAMPLES; a writer's id is ignored",
    section="11.3",
    requirements=("OA-STREAM-4", "OA-STREAM-5", "OA-STREAM-6"),
    serial=True,
    allowed=("ids newest+1 … newest+5, whatever builtin:id the writer gave",),
)
async def consecutive_ids(ctx: CaseContext) -> None:
    """Alone on the server (serial), read the newest id N, add three samples (two carrying
    `builtin:id` 1 and 999999) and then two with one ADD_SAMPLES; expect N+1 … N+5, the newest
    sample N+5, and the stored builtin:id of each equal to its id.

    Catches: ids that skip, restart, or follow the writer's builtin:id.
    """
    stream = await stream_under_test(ctx)
    writer = await StreamClient.open(ctx, stream)
    newest = await writer.newest_id()
    mark = marker(ctx)
    ids = [
        await writer.add(b"one", [mark]),
        await writer.add(b"two", [("builtin:id", "1"), mark]),
        await writer.add(b"three", [mark, ("builtin:id", "999999")]),
    ]
    ids += await writer.add_many([chunk(b"four", [mark]), chunk(b"five", [mark])])
    want = list(range(newest + 1, newest + 6))
    ctx.check(
        ids == want,
        f"after newest id {newest} the stream gave {ids}",
        expected=f"{want}: each sample one more than the one before (OA-STREAM-4)",
    )
    for sample_id in ids:
        got = await writer.get(sample_id)
        ctx.check(
            got.id == sample_id,
            f"sample {sample_id} is stored with builtin:id {got.param('builtin:id')!r}",
            expected="builtin:id = the id the stream gave (OA-STREAM-4)",
        )
    ctx.check(
        await writer.newest_id() == want[-1],
        "GET_NEWEST_DATASAMPLE is not the last sample added",
        expected=f"sample {want[-1]} (OA-STREAM-6)",
    )


def _invalid_chunks(ctx: CaseContext) -> list[tuple[str, bytes]]:
    mark = marker(ctx)
    good = chunk(b"x", [mark])
    return [
        ("a chunk of 3 bytes", b"\x01\x00\x00"),
        ("a payload length beyond the chunk", (100).to_bytes(4, "little") + b"abc\0"),
        ("a chunk whose last byte is not NUL", good[:-1] + b"!"),
        ("non-ASCII parameters", b"\x01\x00\x00\x00x" + "k%equals%\u00e9".encode() + b"\0"),
        ("a parameter without %equals%", b"\x01\x00\x00\x00xnovalue\0"),
        ("a parameter with an empty key", b"\x01\x00\x00\x00x%equals%v\0"),
        ("a parameter with two %equals%", b"\x01\x00\x00\x00xk%equals%v%equals%w\0"),
    ]


@case(
    id="STREAM-004",
    title="Invalid chunks are refused SAMPLE_INVALID, and a refused ADD_SAMPLES adds nothing",
    section="11.2",
    requirements=("OA-STREAM-10", "OA-STREAM-5", "OA-STREAM-2"),
    allowed=(
        "DATA_NOT_ACCEPTED with content 'SAMPLE_INVALID: detail' for each invalid request; "
        "none of the samples of a refused ADD_SAMPLES is held",
    ),
)
async def invalid_chunks(ctx: CaseContext) -> None:
    """Send ADD_SAMPLE with chunks that are too short, announce more payload than they hold,
    lack the final NUL, or whose parameters are not ASCII `key%equals%value` pairs; ADD_SAMPLE
    without a chunk; ADD_SAMPLES with fewer or more chunks than datasamples or with none; and
    ADD_SAMPLES
    of a valid,
    an invalid and a valid sample. Then show, by their timestamps, that the valid ones were not
    added, and that a valid ADD_SAMPLES adds both, in order.

    Catches: lenient chunk readers, partial ADD_SAMPLES, a server that closes or hangs.
    """
    stream = await stream_under_test(ctx)
    writer = await StreamClient.open(ctx, stream)
    for what, data in _invalid_chunks(ctx):
        writer.refused(await writer.add_chunk(data), f"ADD_SAMPLE with {what}", req="OA-STREAM-10")
    reply = await writer.request("ADD_SAMPLE", "<datasample/>", xml=True)
    writer.refused(reply, "ADD_SAMPLE without a chunk", req="OA-STREAM-5")
    two = (chunk(b"a"), chunk(b"b"))
    reply = await writer.request("ADD_SAMPLES", samples_xml(3), xml=True, binary=two)
    writer.refused(reply, "ADD_SAMPLES of 3 datasamples with 2 chunks", req="OA-STREAM-5")
    reply = await writer.request("ADD_SAMPLES", samples_xml(1), xml=True, binary=two)
    writer.refused(reply, "ADD_SAMPLES of 1 datasample with 2 chunks", req="OA-STREAM-5")
    reply = await writer.request("ADD_SAMPLES", "<objectcollection/>", xml=True)
    writer.refused(reply, "ADD_SAMPLES without any sample", req="OA-STREAM-5")
    base = past_window(ctx)
    valid = [chunk(b"first", [("builtin:timestamp", str(base + 1)), marker(ctx)])]
    valid.append(chunk(b"third", [("builtin:timestamp", str(base + 3)), marker(ctx)]))
    mixed = (valid[0], _invalid_chunks(ctx)[2][1], valid[1])
    reply = await writer.request("ADD_SAMPLES", samples_xml(3), xml=True, binary=mixed)
    writer.refused(reply, "ADD_SAMPLES whose second sample is invalid", req="OA-STREAM-5")
    window = await _between(writer, base, base + 59_999, "OA-STREAM-5")
    ctx.check(
        not window,
        f"after the refused ADD_SAMPLES the stream holds {len(window)} of its samples",
        expected="none: a refused ADD_SAMPLES adds no sample (OA-STREAM-5)",
    )
    ids = await writer.add_many(valid)
    window = await _between(writer, base, base + 59_999, "OA-STREAM-5")
    ctx.check(
        [(s.payload, s.id) for s in window] == [(b"first", ids[0]), (b"third", ids[1])],
        f"after a valid ADD_SAMPLES the window holds {[(s.payload, s.id) for s in window]}",
        expected=f"the two samples with ids {ids}, oldest first (OA-STREAM-5)",
    )


async def _between(writer: StreamClient, start: int, end: int, req: str) -> list[Sample]:
    content = (
        f"<objectcollection><object>{time_xml(start)}</object>"
        f"<object>{time_xml(end)}</object></objectcollection>"
    )
    reply = await writer.request("GET_SAMPLES_BY_TIME", content, xml=True)
    return writer.samples_of(reply, f"GET_SAMPLES_BY_TIME {start}..{end}", req=req)


@case(
    id="STREAM-005",
    title="Reading commands answer from the samples held; none there is SAMPLE_UNKNOWN",
    section="11.4",
    requirements=("OA-STREAM-6", "OA-STREAM-1"),
    allowed=(
        "NAME = the stream's name; COUNT and SIZE decimal; newest id >= the sample added, oldest "
        "<= it; TIMESTAMP a time element; SAMPLE_UNKNOWN for ids and times with no sample; "
        "CONTENT_INVALID for an id that is no integer, a time without sec, a range of one or three "
        "times; "
        "UNKNOWN_COMMAND 'Offending cmd: TYPE' for another type",
    ),
)
async def reading_commands(ctx: CaseContext) -> None:
    """Ping the stream and ask GET_NAME; add a 100-byte sample; then GET_COUNT, GET_SIZE,
    GET_NEWEST/OLDEST_DATASAMPLE, GET_NEWEST/OLDEST_TIMESTAMP; GET_SAMPLE_BY_ID of an id not
    yet given and of 0; GET_SAMPLE_BY_TIME of the epoch; GET_SAMPLES_BY_TIME of an empty range;
    an id that is no number, a time without `sec`, a range of one time; a type no stream
    knows.

    Catches: wrong reply types, an empty range answered SAMPLE_UNKNOWN instead of an empty
    collection, unknown ids answered with the nearest sample, bad content accepted.
    """
    stream = await stream_under_test(ctx)
    reader = await StreamClient.open(ctx, stream, "R")
    reply = await reader.request("PING")
    ctx.check(
        reply.type == "PING_SUCCESS", f"PING was answered {reply.type}", expected="OA-STREAM-1"
    )
    reply = await reader.request("GET_NAME")
    ctx.check(
        reply.type == "NAME" and reply.content.strip() == stream,
        f"GET_NAME was answered {reply.type} {reply.content!r}",
        expected=f"NAME with the content {stream!r} (OA-STREAM-1)",
    )
    added = await reader.add(bytes(100), [marker(ctx)])
    count = await reader.number("GET_COUNT", "COUNT")
    ctx.check(count >= 1, f"GET_COUNT is {count} after an add", expected="OA-STREAM-6")
    size = await reader.number("GET_SIZE", "SIZE")
    ctx.check(size >= 100, f"GET_SIZE is {size} after a 100-byte add", expected="OA-STREAM-6")
    newest = await reader.newest_id()
    ctx.check(newest >= added, f"the newest id is {newest} < {added}", expected="OA-STREAM-6")
    reply = await reader.request("GET_OLDEST_DATASAMPLE")
    oldest = reader.sample_of(reply, "GET_OLDEST_DATASAMPLE").id
    ctx.check(
        oldest is not None and oldest <= added,
        f"the oldest sample has id {oldest}, after {added}",
        expected="the oldest sample held (OA-STREAM-6)",
    )
    await reader.timestamp("GET_NEWEST_TIMESTAMP")
    await reader.timestamp("GET_OLDEST_TIMESTAMP")
    await reader.unknown("GET_SAMPLE_BY_ID", str(newest + 10**12), req="OA-STREAM-6")
    await reader.unknown("GET_SAMPLE_BY_ID", "0", req="OA-STREAM-6")
    await reader.unknown("GET_SAMPLE_BY_TIME", time_xml(0), xml=True, req="OA-STREAM-6")
    empty = await _between(reader, 0, 0, "OA-STREAM-6")
    ctx.check(not empty, f"{len(empty)} samples at time 0", expected="none (OA-STREAM-6)")
    one_time = f"<objectcollection><object>{time_xml(0)}</object></objectcollection>"
    three_times = (
        one_time.replace("</objectcollection>", "") + 2 * f"<object>{time_xml(0)}</object>"
    )
    for type, content, xml in (
        ("GET_SAMPLE_BY_ID", "abc", False),
        ("GET_SAMPLE_BY_ID", "", False),
        ("GET_SAMPLE_BY_TIME", '<time msec="5"/>', True),
        ("GET_SAMPLES_BY_TIME", one_time, True),
        ("GET_SAMPLES_BY_TIME", three_times + "</objectcollection>", True),
    ):
        reply = await reader.request(type, content, xml=xml)
        check_error(
            ctx, reply, names=("CONTENT_INVALID",), what=f"{type} {content!r}", req="OA-STREAM-6"
        )
    unknown = f"CONF_NO_MEDIA_COMMAND_{ctx.run_id}"
    reply = await reader.request(unknown)
    ctx.check(
        reply.type == "UNKNOWN_COMMAND" and reply.content.strip() == f"Offending cmd: {unknown}",
        f"{unknown} to the stream was answered {reply.type} {reply.content!r}",
        expected=f"UNKNOWN_COMMAND 'Offending cmd: {unknown}' (OA-STREAM-1)",
    )


@case(
    id="STREAM-006",
    title="Time lookups: the greatest timestamp at or before t; ranges include both ends",
    section="11.4",
    requirements=("OA-STREAM-6", "OA-STREAM-4"),
    allowed=(
        "GET_SAMPLE_BY_TIME: the sample with the greatest timestamp <= t; GET_SAMPLES_BY_TIME: "
        "every sample with from <= timestamp <= until, oldest first; an empty collection for a "
        "range without samples",
    ),
)
async def time_lookups(ctx: CaseContext) -> None:
    """Add samples stamped T, T+10 and T+20 ms (T in a window of the year 2000–2008 unique to
    the case, msec 123). Look up T, T+9, T+10, T+19, T+20 and T+25 by time, and the ranges
    [T, T+20], [T+10, T+20], [T+10, T+10], [T+1, T+9], [T+11, T+19] and [T+20, T].

    Catches: the nearest sample instead of the one at or before t, exclusive range ends, the
    msec attribute ignored, an empty range answered with an error.
    """
    stream = await stream_under_test(ctx)
    reader = await StreamClient.open(ctx, stream, "R")
    base = past_window(ctx)
    ids = [
        await reader.add(f"at +{dt}".encode(), [("builtin:timestamp", str(base + dt)), marker(ctx)])
        for dt in (0, 10, 20)
    ]
    by_offset = dict(zip((0, 10, 20), ids, strict=True))
    for dt, want in ((0, 0), (9, 0), (10, 10), (19, 10), (20, 20), (25, 20)):
        reply = await reader.request("GET_SAMPLE_BY_TIME", time_xml(base + dt), xml=True)
        got = reader.sample_of(reply, f"GET_SAMPLE_BY_TIME T+{dt}")
        ctx.check(
            got.id == by_offset[want] and got.timestamp == base + want,
            f"GET_SAMPLE_BY_TIME T+{dt} answered sample {got.id} stamped T+"
            f"{(got.timestamp or 0) - base}",
            expected=f"sample {by_offset[want]} stamped T+{want}: the greatest timestamp at or "
            "before t (OA-STREAM-6)",
        )
    for start, end, want_offsets in (
        (0, 20, [0, 10, 20]),
        (10, 20, [10, 20]),
        (10, 10, [10]),
        (1, 9, []),
        (11, 19, []),
        (20, 0, []),
    ):
        got_ids = [s.id for s in await _between(reader, base + start, base + end, "OA-STREAM-6")]
        want_ids = [by_offset[dt] for dt in want_offsets]
        ctx.check(
            got_ids == want_ids,
            f"GET_SAMPLES_BY_TIME [T+{start}, T+{end}] answered the ids {got_ids}",
            expected=f"{want_ids}: both ends inclusive, oldest first (OA-STREAM-6)",
        )


async def _stream_limit(writer: StreamClient, req: str) -> int:
    """Return the stream's byte limit from GET_INFO (maxsize in bytes); Inconclusive if none."""
    info = await writer.info(req=req)
    text = info.get("maxsize", "")
    if not text.isdigit() or int(text) == 0:
        raise Inconclusive(f"setup: GET_INFO gives maxsize {text!r}, not a byte count")
    limit = int(text)
    if limit > _MAX_FILL:
        raise NotApplicable(
            f"the stream's maxsize is {limit} bytes; the suite fills at most 32 MiB"
        )
    return limit


@case(
    id="STREAM-014",
    title="A sample whose payload alone exceeds the stream's byte limit is refused",
    section="11.1",
    requirements=("OA-STREAM-13", "OA-STREAM-5"),
    serial=True,
    allowed=("DATA_NOT_ACCEPTED with content 'SAMPLE_INVALID: detail'",),
)
async def oversized_sample(ctx: CaseContext) -> None:
    """Read the stream's maxsize (bytes) with GET_INFO and add a sample one byte larger (alone
    on the server, serial: 10 MiB would hold up the cases beside it).

    Catches: a stream that accepts it and then drops everything, itself included (or keeps
    more than its limit).
    """
    stream = await stream_under_test(ctx)
    writer = await StreamClient.open(ctx, stream)
    limit = await _stream_limit(writer, "OA-STREAM-13")
    reply = await writer.add_chunk(chunk(bytes(limit + 1), [marker(ctx)]))
    writer.refused(reply, f"ADD_SAMPLE of {limit + 1} bytes", req="OA-STREAM-13")


@case(
    id="STREAM-015",
    title="Beyond maxsize the oldest samples go until the payload bytes fit the limit exactly",
    section="11.1",
    requirements=("OA-STREAM-9", "OA-STREAM-13"),
    serial=True,
    allowed=(
        "with 1 MiB samples and maxsize M: the newest M/1 MiB samples are held, the older ones "
        "are SAMPLE_UNKNOWN, GET_SIZE <= M; a sample of exactly M bytes is accepted",
    ),
)
async def ring_by_bytes(ctx: CaseContext) -> None:
    """Alone on the server (serial): read maxsize M (GET_INFO), add M/1 MiB + 2 samples of
    1 MiB each; after each of the last two expect GET_COUNT = M/1 MiB and GET_SIZE = their
    bytes; then the two first are gone and the third is held. Then add one sample of exactly
    M bytes: it is accepted and is all the stream holds.

    Catches: a ring that keeps one sample too many or drops one too many, limits counted with
    the parameters, a limit of maxsize bytes treated as exclusive.
    """
    stream = await stream_under_test(ctx)
    writer = await StreamClient.open(ctx, stream)
    limit = await _stream_limit(writer, "OA-STREAM-9")
    size = min(MIB, limit)
    held = limit // size
    ids = [await writer.add(bytes(size), [marker(ctx)]) for _ in range(held)]
    for _ in range(2):  # each of these two adds goes above the limit by one sample
        ids.append(await writer.add(bytes(size), [marker(ctx)]))
        count = await writer.number("GET_COUNT", "COUNT", req="OA-STREAM-9")
        total = await writer.number("GET_SIZE", "SIZE", req="OA-STREAM-9")
        ctx.check(
            (count, total) == (held, held * size),
            f"after {len(ids)} samples of {size} bytes (maxsize {limit}) the stream holds "
            f"{count} samples, {total} bytes",
            expected=f"{held} samples, {held * size} bytes: the oldest dropped until the "
            "payload bytes are <= maxsize (OA-STREAM-9)",
        )
    for gone in ids[:2]:
        await writer.unknown("GET_SAMPLE_BY_ID", str(gone), req="OA-STREAM-9")
    kept = await writer.get(ids[2], req="OA-STREAM-9")
    ctx.check(kept.id == ids[2], f"GET_SAMPLE_BY_ID {ids[2]} answered {kept.id}")
    whole = await writer.add(bytes(limit), [marker(ctx)], req="OA-STREAM-13")
    count = await writer.number("GET_COUNT", "COUNT", req="OA-STREAM-9")
    total = await writer.number("GET_SIZE", "SIZE", req="OA-STREAM-9")
    ctx.check(
        (count, total) == (1, limit),
        f"after a sample of exactly maxsize ({limit} bytes, id {whole}) the stream holds "
        f"{count} samples, {total} bytes",
        expected=f"that sample alone: 1 sample, {limit} bytes (OA-STREAM-9)",
    )
