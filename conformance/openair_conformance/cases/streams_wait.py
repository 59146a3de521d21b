"""Stream cases of spec 11.5 (waiting) and of BinaryM (11.3): WAIT_FOR_* at once, after an add and
at the timeout; a pending wait holding back later requests; BinaryM with and without a current
stream.

Waits by time use timestamps ten days ahead (`future_base`), which only this case writes, so that
"the oldest sample stamped at or after t" is one of the case's own samples on a shared stream.
"""

from __future__ import annotations

import time

from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._common import check_error
from openair_conformance.cases._streams import (
    StreamClient,
    check_from,
    check_sample,
    chunk,
    future_base,
    marker,
    past_window,
    stream_under_test,
    time_xml,
)
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case

#: An id no stream reaches during a run.
_NEVER_ID = 10**15
#: A time no sample of the suite is stamped with (the year 3000).
_NEVER_MS = 32_503_680_000_000
#: The timeout of waits that must end by timing out.
_SHORT_MS = 300


def _long_ms(ctx: CaseContext) -> int:
    """A timeout longer than the suite waits for a reply: a wait that times out fails."""
    return int((ctx.deadline + ctx.grace) * 1000) + 2000


async def _answered(
    ctx: CaseContext,
    client: StreamClient,
    sent: Message,
    what: str,
    *,
    timeout: float | None = None,
) -> Message:
    reply = await client.raw.read_message(timeout=timeout)
    ctx.check(
        reply.isresponse == sent.id,
        f"{what}: the reply is {reply.type} with isresponse {reply.isresponse!r}",
        expected="the reply to the wait (OA-SESS-1, OA-SESS-2)",
    )
    return reply


@case(
    id="STREAM-007",
    title="WAIT_FOR_* answers at once when a sample qualifies, else as soon as one is added",
    section="11.5",
    requirements=("OA-STREAM-7",),
    allowed=(
        "DATASAMPLE: FIRST/LAST_SAMPLE the oldest/newest sample stamped at or after t, "
        "FIRST/LAST_AFTERID the oldest/newest with a greater id; at once, or right after the "
        "add that makes one qualify",
    ),
)
async def waits_answer(ctx: CaseContext) -> None:
    """Add samples stamped F+5 and F+6 (F ten days ahead). WAIT_FOR_FIRST_SAMPLE F and
    WAIT_FOR_LAST_SAMPLE F answer them at once, WAIT_FOR_FIRST_AFTERID id-1 the first and
    WAIT_FOR_LAST_AFTERID id-1 the newest. Then, with long timeouts, wait for an id after the
    newest, for a sample stamped F+200 and for the last one stamped F+300, while a second
    connection adds samples.

    Catches: waits that time out at once or only answer at the timeout, FIRST and LAST swapped,
    "after" read as "at or after" for ids.
    """
    stream = await stream_under_test(ctx)
    waiter = await StreamClient.open(ctx, stream, "Waiter")
    writer = await StreamClient.open(ctx, stream, "Writer")
    base, mark, wait = future_base(), marker(ctx), _long_ms(ctx)
    first = await writer.add(b"F+5", [("builtin:timestamp", str(base + 5)), mark])
    second = await writer.add(b"F+6", [("builtin:timestamp", str(base + 6)), mark])
    for type, content, xml, low, high in (
        ("WAIT_FOR_FIRST_SAMPLE", time_xml(base), True, first, first),
        ("WAIT_FOR_LAST_SAMPLE", time_xml(base), True, second, second),
        ("WAIT_FOR_FIRST_AFTERID", str(first - 1), False, first, first),
        ("WAIT_FOR_LAST_AFTERID", str(first - 1), False, second, None),
    ):
        reply = await waiter.request(f"{type} {wait}", content, xml=xml)
        got = waiter.sample_of(reply, f"{type} {wait} {content}", req="OA-STREAM-7")
        ctx.check(
            got.id is not None and low <= got.id <= (high or got.id),
            f"{type} {content} answered sample {got.id}",
            expected=f"sample {low}{'' if high == low else ' or newer'} at once (OA-STREAM-7)",
        )
    newest = await waiter.newest_id()
    pending = [
        ("WAIT_FOR_FIRST_AFTERID", str(newest), False, 0),
        ("WAIT_FOR_FIRST_SAMPLE", time_xml(base + 200), True, 200),
        ("WAIT_FOR_LAST_SAMPLE", time_xml(base + 300), True, 300),
    ]
    for type, content, xml, offset in pending:
        sent = await waiter.raw.send_message(waiter.message(f"{type} {wait}", content, xml=xml))
        stamp = base + offset if offset else None
        params = [mark] + ([("builtin:timestamp", str(stamp))] if stamp else [])
        added = await writer.add(b"late", params)
        reply = await _answered(ctx, waiter, sent, f"{type} {content}")
        got = waiter.sample_of(reply, f"{type} {content} after an add", req="OA-STREAM-7")
        ok = newest < (got.id or 0) <= added if not offset else got.id == added
        ctx.check(
            ok,
            f"{type} {content} answered sample {got.id} after sample {added} was added",
            expected=f"{'a sample after ' + str(newest) if not offset else 'sample ' + str(added)}"
            ", as soon as it was added (OA-STREAM-7)",
        )


@case(
    id="STREAM-008",
    title="WAIT_FOR_* times out with SAMPLE_UNKNOWN; a timeout that is no integer is refused",
    section="11.5",
    requirements=("OA-STREAM-7",),
    allowed=(
        "RECEIVE_ERROR SAMPLE_UNKNOWN no sooner than the timeout; MESSAGE_INVALID for no "
        "timeout and the timeouts abc, -5 and 1.5",
    ),
)
async def waits_time_out(ctx: CaseContext) -> None:
    """WAIT_FOR_FIRST_AFTERID 300 for an id no stream reaches, WAIT_FOR_LAST_SAMPLE 300 for the
    year 3000 and WAIT_FOR_FIRST_SAMPLE 0; time the errors. Then send WAIT types without a
    timeout and with the timeouts `abc`, `-5` and `1.5`.

    Catches: waits that end at once, that never end, or that read a bad timeout as 0.
    """
    stream = await stream_under_test(ctx)
    waiter = await StreamClient.open(ctx, stream, "Waiter")
    for type, content, xml, ms in (
        ("WAIT_FOR_FIRST_AFTERID", str(_NEVER_ID), False, _SHORT_MS),
        ("WAIT_FOR_LAST_SAMPLE", time_xml(_NEVER_MS), True, _SHORT_MS),
        ("WAIT_FOR_FIRST_SAMPLE", time_xml(_NEVER_MS), True, 0),
    ):
        started = time.monotonic()
        reply = await waiter.request(
            f"{type} {ms}", content, xml=xml, timeout=ctx.deadline + ms / 1000
        )
        elapsed = time.monotonic() - started
        check_error(ctx, reply, names=("SAMPLE_UNKNOWN",), what=f"{type} {ms}", req="OA-STREAM-7")
        ctx.check(
            elapsed >= ms / 1000,
            f"{type} {ms} timed out after {elapsed * 1000:.0f} ms",
            expected=f"not before its timeout of {ms} ms (OA-STREAM-7)",
        )
    for type, suffix, content in (
        ("WAIT_FOR_FIRST_AFTERID", "", "1"),
        ("WAIT_FOR_FIRST_AFTERID", "abc", "1"),
        ("WAIT_FOR_LAST_AFTERID", "-5", "1"),
        ("WAIT_FOR_FIRST_SAMPLE", "1.5", time_xml(_NEVER_MS)),
    ):
        full = f"{type} {suffix}" if suffix else type
        reply = await waiter.request(full, content, xml=content.startswith("<"))
        check_error(ctx, reply, names=("MESSAGE_INVALID",), what=repr(full), req="OA-STREAM-7")


@case(
    id="STREAM-009",
    title="A pending WAIT_FOR_* holds back the later requests on its connection",
    section="11.5",
    requirements=("OA-STREAM-7", "OA-SESS-2"),
    needs=("pipelining",),
    allowed=("the wait's reply first (DATASAMPLE or SAMPLE_UNKNOWN), then the later replies",),
)
async def wait_blocks_connection(ctx: CaseContext) -> None:
    """On one connection send WAIT_FOR_FIRST_AFTERID 400 for an id no stream reaches and then
    GET_NAME; then WAIT_FOR_FIRST_AFTERID (long) for the newest id and GET_COUNT, and add a
    sample from another connection.

    Catches: later requests answered while a wait is pending (replies out of order).
    """
    stream = await stream_under_test(ctx)
    waiter = await StreamClient.open(ctx, stream, "Waiter")
    writer = await StreamClient.open(ctx, stream, "Writer")
    started = time.monotonic()
    wait = waiter.message(f"WAIT_FOR_FIRST_AFTERID {_SHORT_MS + 100}", str(_NEVER_ID))
    sent = await waiter.raw.send_messages([wait, waiter.message("GET_NAME")])
    reply = await _answered(ctx, waiter, sent[0], "the first reply", timeout=ctx.deadline + 0.4)
    check_error(ctx, reply, names=("SAMPLE_UNKNOWN",), what="the wait", req="OA-STREAM-7")
    ctx.check(
        time.monotonic() - started >= 0.4,
        "the wait timed out before its 400 ms",
        expected="OA-STREAM-7",
    )
    reply = await _answered(ctx, waiter, sent[1], "the second reply")
    # OA-STREAM-7: the later request is answered, after the wait
    ctx.check(reply.type == "NAME", f"GET_NAME was answered {reply.type}", expected="NAME")
    newest = await waiter.newest_id()
    wait = waiter.message(f"WAIT_FOR_FIRST_AFTERID {_long_ms(ctx)}", str(newest))
    sent = await waiter.raw.send_messages([wait, waiter.message("GET_COUNT")])
    added = await writer.add(b"wake", [marker(ctx)])
    reply = await _answered(ctx, waiter, sent[0], "the first reply after the add")
    got = waiter.sample_of(reply, "the wait", req="OA-STREAM-7")
    ctx.check(
        newest < (got.id or 0) <= added,
        f"the wait answered sample {got.id}",
        expected=f"a sample after {newest} (OA-STREAM-7)",
    )
    reply = await _answered(ctx, waiter, sent[1], "the reply to GET_COUNT")
    # OA-STREAM-7: the later request is answered, after the wait
    ctx.check(reply.type == "COUNT", f"GET_COUNT was answered {reply.type}", expected="COUNT")


@case(
    id="STREAM-010",
    title="BinaryM adds to the connection's current stream; with none it is UNKNOWN_COMMAND",
    section="11.3",
    requirements=("OA-STREAM-11", "OA-FRAME-5", "OA-STREAM-10"),
    allowed=(
        "before any media command: UNKNOWN_COMMAND 'Offending cmd: BinaryOnly'; after one: "
        "DATA_ACCEPTED from the stream with the new id (DATA_NOT_ACCEPTED SAMPLE_INVALID for a "
        "bad chunk), the sample held exactly as sent",
    ),
)
async def binary_frames(ctx: CaseContext) -> None:
    """On a fresh connection send a BinaryM frame; then GET_NAME to the stream, PING to CNS
    (not a media command), a BinaryM frame with a valid chunk and one whose last byte is not
    NUL. Read the added sample by id. A second connection without a media command sends a
    BinaryM frame too.

    Catches: BinaryM ignored or refused after a media command, the current stream per server
    instead of per connection, a bad chunk accepted.
    """
    stream = await stream_under_test(ctx)
    client = await StreamClient.open(ctx, stream, "Binary")
    params = (("builtin:timestamp", str(past_window(ctx) + 1)), marker(ctx), ("conf:via", "B"))
    data = chunk(b"\x00binary\xff" * 10, params)
    reply = await client.send_binary(data)
    _binary_only(ctx, reply, "a BinaryM frame before any media command")
    reply = await client.request("GET_NAME")
    ctx.check(reply.type == "NAME", f"GET_NAME was answered {reply.type}", expected="NAME")
    reply = await client.raw.request(Message(type="PING", sender=client.sender, to="CNS"))
    ctx.check(reply.type == "PING_SUCCESS", f"PING was answered {reply.type}")
    reply = await client.send_binary(data)
    added = client.accepted_id(reply, "a BinaryM frame after GET_NAME", req="OA-STREAM-11")
    check_from(ctx, reply, stream, "DATA_ACCEPTED of a BinaryM frame")
    ctx.check(
        not reply.isresponse,
        f"DATA_ACCEPTED of a BinaryM frame has isresponse {reply.isresponse!r}",
        expected="an empty isresponse: a BinaryM frame has no id (OA-STREAM-11)",
    )
    bad = await client.send_binary(data[:-1] + b"!")
    client.refused(bad, "a BinaryM frame whose chunk lacks the NUL", req="OA-STREAM-10")
    got = await client.get(added, req="OA-STREAM-11")
    check_sample(
        ctx,
        got,
        payload=b"\x00binary\xff" * 10,
        params=params,
        sample_id=added,
        what=f"the BinaryM sample {added}",
        timestamp=past_window(ctx) + 1,
    )
    other = await StreamClient.open(ctx, stream, "Other")
    await other.raw.send_frame(Frame(tag=FrameTag.BINARY, chunks=(data,)))
    _binary_only(ctx, await other.raw.read_message(), "BinaryM on a second connection")


def _binary_only(ctx: CaseContext, reply: Message, what: str) -> None:
    ctx.check(
        reply.type == "UNKNOWN_COMMAND" and "BinaryOnly" in reply.content,
        f"{what} was answered {reply.type} {reply.content!r}",
        expected="UNKNOWN_COMMAND 'Offending cmd: BinaryOnly': no current stream (OA-STREAM-11)",
    )
