"""Byte and result bounds (spec 14.1, issue #15): the bytes of a module's queued deliveries
(OA-LIM-8), what a wakeup's retrieves return together (OA-LIM-9) and the bytes of stored copies
a whiteboard keeps (OA-LIM-10).

At the defaults (64 MiB, 1 000 results, 4 MiB, 256 MiB) reaching a bound takes thousands of
posts or hundreds of MiB, so these cases run when the server advertises small limits and are
not applicable, with that reason, otherwise. The bounds are read from CAPABILITIES (OA-CAP-2).
Run them on their own against a server started with small bounds (`openair serve
--max-queue-bytes 65536 --max-wakeup-results 8 --max-wakeup-result-bytes 5 --max-history-bytes
60000`, then `openair conform HOST:PORT --case 'LIM-*'`): at such bounds the wakeups of other
cases lose the retrieved messages they expect.
"""

from __future__ import annotations

from openair_conformance.cases._common import esc, retrieved, triggers_xml, view_of
from openair_conformance.cases.priorities import drain_held, plugged_window
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import wakeup_trigger_id
from openair_conformance.model import NotApplicable
from openair_conformance.registry import case

#: The largest bounds these cases fill (a post each); larger ones need too many posts.
_MAX_RESULTS = 64
_MAX_RESULT_BYTES = 64
_MAX_HISTORY_BYTES = 1 << 20
_MAX_QUEUE_BYTES = 1 << 20
#: A generous upper bound on what a server counts for a copy beyond its text slots (the spec
#: says "a fixed allowance for the envelope"; the reference server counts 512 bytes).
_ENVELOPE_ALLOWANCE = 4096


def _retrieve(pattern: str) -> str:
    return f'<retrieve from="WB1" type="{esc(pattern)}"><latest>0</latest></retrieve>'


async def _wakeup_results(
    ctx: CaseContext, a_count: int, b_count: int, content: str
) -> tuple[list[str], list[str], list[str]]:
    """Register Go with two retrieves (A, then B); post `a_count` A and `b_count` B messages
    with `content`, then Go; return (A ids, B ids, the ids the wakeup retrieved)."""
    reader = await ctx.module("Reader")
    poster = await ctx.module("Poster", bind=False)
    go, a, b = ctx.type("Go"), ctx.type("A"), ctx.type("B")
    registration = f"{triggers_xml(go)}<retrieves>{_retrieve(a)}{_retrieve(b)}</retrieves>"
    await reader.subscribe(registration, check=True)
    a_ids = [await _post(poster, a, content) for _ in range(a_count)]
    b_ids = [await _post(poster, b, content) for _ in range(b_count)]
    trigger = await _post(poster, go, "go")
    wakeup = await reader.expect_wakeup(lambda w: wakeup_trigger_id(w) == trigger)
    return a_ids, b_ids, [m.id for m in view_of(ctx, wakeup).retrieved]


async def _post(
    poster: TestModule, type_: str, content: str, *, priority: float | None = None
) -> str:
    await poster.post("WB1", type_, content, priority=priority)
    assert poster.last_sent is not None
    return poster.last_sent.id


@case(
    id="LIM-001",
    title="A wakeup's retrieves return at most max-wakeup-results messages, in retrieve order",
    section="14.1",
    requirements=("OA-LIM-9", "OA-WAKE-7", "OA-RET-12"),
    allowed=(
        "exactly max-wakeup-results messages: the first retrieve's two results newest first, "
        "then the newest of the second retrieve's",
    ),
)
async def wakeup_result_count(ctx: CaseContext) -> None:
    """Register Go with a retrieve of A then one of B; post 2 A and max-wakeup-results B
    messages (empty content), then Go.

    Catches: no bound, an off-by-one bound, a bound applied to each retrieve instead of to
    all of them together, the second retrieve's oldest kept instead of its newest.
    """
    limit = ctx.server.limit("max-wakeup-results", 1_000)
    if limit > _MAX_RESULTS:
        raise NotApplicable(
            f"max-wakeup-results is {limit}; run against a server advertising at most "
            f"{_MAX_RESULTS} (openair serve --max-wakeup-results 8)"
        )
    a_ids, b_ids, got = await _wakeup_results(ctx, 2, limit, "")
    want = (a_ids[::-1] + b_ids[::-1])[:limit]
    ctx.check(
        got == want,
        f"the wakeup retrieved {len(got)} messages {got}",
        expected=f"the {limit} messages {want} (OA-LIM-9, OA-WAKE-7)",
    )


@case(
    id="LIM-002",
    title="A wakeup's retrieves return messages whose text fits max-wakeup-result-bytes",
    section="14.1",
    requirements=("OA-LIM-9", "OA-WAKE-7"),
    allowed=(
        "with one-character contents: exactly min(max-wakeup-results, max-wakeup-result-bytes) "
        "messages, the A message first, then the newest B messages",
    ),
)
async def wakeup_result_bytes(ctx: CaseContext) -> None:
    """Register Go with a retrieve of A then one of B; post 1 A and max-wakeup-result-bytes
    B messages of one character each, then Go.

    Catches: no byte bound, a bound one byte off (a message that takes the total to the bound
    exactly is kept; the next one is not), a bound counted per retrieve.
    """
    size = ctx.server.limit("max-wakeup-result-bytes", 4 * 1024 * 1024)
    count = ctx.server.limit("max-wakeup-results", 1_000)
    if size > _MAX_RESULT_BYTES or size < 2:
        raise NotApplicable(
            f"max-wakeup-result-bytes is {size}; run against a server advertising 2 to "
            f"{_MAX_RESULT_BYTES} (openair serve --max-wakeup-result-bytes 5)"
        )
    # One A message: the second retrieve's budget is then the bound less one byte, not a
    # power of two a bitwise slip would keep (issue #15: `max_bytes & size` survived).
    a_ids, b_ids, got = await _wakeup_results(ctx, 1, size, "x")
    want = (a_ids[::-1] + b_ids[::-1])[: min(size, count)]
    ctx.check(
        got == want,
        f"the wakeup retrieved {len(got)} messages {got}",
        expected=f"the {len(want)} messages {want}: one text byte each (OA-LIM-9)",
    )


@case(
    id="LIM-003",
    title="A whiteboard keeps at most max-history-bytes of copies: the oldest go, the newest stays",
    section="14.1",
    requirements=("OA-LIM-10", "OA-WB-6"),
    serial=True,  # it evicts the other cases' copies from WB1
    allowed=(
        "the newest copies, in order, whose text fits the bound (at least those that fit with a "
        f"{_ENVELOPE_ALLOWANCE}-byte allowance each); then the newer of two copies larger than the "
        "bound, alone",
    ),
)
async def history_bytes(ctx: CaseContext) -> None:
    """Post twelve copies of a sixth of max-history-bytes each to WB1 and retrieve them; then
    post two copies twice the bound each and retrieve again.

    Catches: no byte bound (maxcount only), the newest evicted instead of the oldest, a copy
    larger than the bound refused or evicted with the rest, eviction of more than needed.
    """
    limit = ctx.server.limit("max-history-bytes", 256 * 1024 * 1024)
    if limit > _MAX_HISTORY_BYTES:
        raise NotApplicable(
            f"max-history-bytes is {limit}; run against a server advertising at most "
            f"{_MAX_HISTORY_BYTES} (openair serve --max-history-bytes 60000)"
        )
    poster = await ctx.module("Poster", bind=False)
    each = max(1, limit // 6)
    sent = [await _post(poster, ctx.type("Fill"), "f" * each) for _ in range(12)]
    spec = f'<retrieve from="WB1" type="{esc(ctx.type("*"))}"><latest>0</latest></retrieve>'
    kept = [m.id for m in await retrieved(ctx, poster, spec)][::-1]  # oldest first
    fits = limit // (each + _ENVELOPE_ALLOWANCE)
    ctx.check(
        kept == sent[len(sent) - len(kept) :] and len(kept) * each <= limit,
        f"kept {len(kept)} of 12 copies of {each} bytes: {kept}",
        expected=f"the newest, in order, at most {limit // each} (OA-LIM-10)",
    )
    ctx.check(
        len(kept) >= max(1, fits),
        f"kept {len(kept)} copies of {each} bytes under a {limit}-byte bound",
        expected=f"at least {max(1, fits)}: only the copies beyond the bound go (OA-LIM-10)",
    )
    # Two copies each over the bound: the first goes with the older ones, the second stays.
    big = [await _post(poster, ctx.type("Big"), "b" * (2 * limit)) for _ in range(2)]
    kept = [m.id for m in await retrieved(ctx, poster, spec)]
    ctx.check(
        kept == [big[1]],
        f"after two copies of {2 * limit} bytes each the history holds {kept}",
        expected=f"only the second, {big[1]}: the newest is always kept, alone (OA-LIM-10)",
    )


@case(
    id="LIM-004",
    title="A module's queue keeps at most max-queue-bytes: lowest priority, then oldest, go",
    section="14.1",
    requirements=("OA-LIM-8", "OA-DELIV-9"),
    serial=True,
    allowed=(
        "the priority-5 delivery is dropped, the newest fills arrive in order, as many as fit "
        f"(at least those that fit with a {_ENVELOPE_ALLOWANCE}-byte allowance each); a "
        "delivery larger than the bound alone is still delivered (the newer of two such)",
    ),
)
async def queue_bytes(ctx: CaseContext) -> None:
    """Hold a module's deliveries; post ten priority-2 messages, one priority-5 one and two
    priority-2 ones, each of a sixth of max-queue-bytes; release and read what arrives. Then
    hold it again and post two messages twice the bound each.

    Catches: no byte bound (max-queue only), dropping the newest or by arrival instead of
    priority, a queue that drops its only delivery because it is too large.
    """
    limit = ctx.server.limit("max-queue-bytes", 64 * 1024 * 1024)
    if limit > _MAX_QUEUE_BYTES:
        raise NotApplicable(
            f"max-queue-bytes is {limit}; run against a server advertising at most "
            f"{_MAX_QUEUE_BYTES} (openair serve --max-queue-bytes 65536)"
        )
    each = max(1, limit // 6)
    hand, plugs, poster = await plugged_window(ctx)
    fills = [await _post(poster, ctx.type("Fill"), "f" * each) for _ in range(10)]
    # Late among the fills: only its priority, not its age, makes it the first to go.
    low = await _post(poster, ctx.type("Low"), "l" * each, priority=5.0)
    fills += [await _post(poster, ctx.type("Fill"), "f" * each) for _ in range(2)]
    await hand.callback.send_messages([p.reply("RECEIVE_ACCEPT", sender=hand.name) for p in plugs])
    arrived = await drain_held(ctx, hand, fills[-1], batch=1)
    # A last, lowest-priority sentinel: the priority-5 delivery, if kept, arrives before it.
    sentinel = await _post(poster, ctx.type("Sentinel"), "end", priority=6.999)
    while arrived[-1] != sentinel:
        arrived.append(await hand.take())
    kept = [i for i in arrived if i in fills]
    ctx.check(
        low not in arrived, "the priority-5 delivery arrived", expected="dropped first (OA-LIM-8)"
    )
    ctx.check(
        kept == fills[len(fills) - len(kept) :] and len(kept) * each <= limit,
        f"{len(kept)} of 12 deliveries of {each} bytes arrived: {kept}",
        expected=f"the newest, in order, at most {limit // each} (OA-LIM-8, OA-DELIV-9)",
    )
    fits = max(1, limit // (each + _ENVELOPE_ALLOWANCE))
    ctx.check(
        len(kept) >= fits,
        f"{len(kept)} deliveries of {each} bytes kept under a {limit}-byte bound",
        expected=f"at least {fits}: only deliveries beyond the bound are dropped (OA-LIM-8)",
    )
    holds = [await _post(poster, ctx.type(f"Hold.{n}"), "hold") for n in range(len(plugs))]
    held = [await hand.next() for _ in holds]  # the window is full again: the next one queues
    # Two deliveries each over the bound: the first is dropped for the second, which stays.
    big = [await _post(poster, ctx.type("Big"), "b" * (2 * limit)) for _ in range(2)]
    await hand.callback.send_messages([h.reply("RECEIVE_ACCEPT", sender=hand.name) for h in held])
    got = await hand.take()
    ctx.check(
        got == big[1],
        f"after two deliveries of {2 * limit} bytes each the module got {got} first",
        expected=f"only the second, {big[1]}: a queue always keeps one, alone (OA-LIM-8)",
    )
