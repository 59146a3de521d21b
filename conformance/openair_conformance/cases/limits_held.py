"""Cases of the bytes a server holds (OA-LIM-14) and how long a gone module's counters stay
(OA-LIM-15), spec 14.1 (issue #15).

The 14.1 cases run when the server advertises small limits and are not applicable, with that
reason, otherwise: at the defaults (1 GiB held, an hour of retention) reaching a bound takes too
long. Run them on their own against a server started with `openair serve --max-held-bytes
262144` (LIM-014, LIM-016) or `--module-retention-ms 200` (LIM-015).
"""

from __future__ import annotations

import asyncio
import struct

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    check_error,
    dictionary_entries,
    esc,
    message_xml,
    send_big,
    setup_subscribe,
)
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    message_collection,
)
from openair_conformance.model import Inconclusive, NotApplicable
from openair_conformance.registry import case

#: The largest max-held-bytes LIM-014 fills (a quarter of it a post).
_MAX_HELD = 4 * 1024 * 1024
#: The longest module-retention-ms LIM-015 waits out.
_MAX_RETENTION_MS = 2_000


async def _status(ctx: CaseContext, module: TestModule) -> dict[str, str]:
    """Ask CNS for STATUS; return its dictionary's entries (name → text)."""
    reply = await module.request(Message(type="STATUS", sender=module.name, to="CNS"))
    return dictionary_entries(ctx, reply)


@case(
    id="LIM-014",
    title="A post that would take the bytes held past max-held-bytes is refused, not stored",
    section="14.1",
    requirements=("OA-LIM-14", "OA-ERR-5"),
    serial=True,  # it fills the server-wide max-held-bytes
    residue=True,  # and leaves it full (the posts stay stored): it runs after every other case
    allowed=(
        "the first post of a quarter of max-held-bytes accepted; by the fifth, one answered "
        "RECEIVE_ERROR 'LIMIT_EXCEEDED: …' and not retrievable",
    ),
)
async def held_bytes(ctx: CaseContext) -> None:
    """Post up to five messages of a quarter of max-held-bytes each to WB2 until one is refused;
    retrieve the refused one.

    Catches: no bound on the bytes held (issue #15: `held + size is not limit` survived), and a
    post refused after it was stored.
    """
    limit = ctx.server.limit("max-held-bytes", 1 << 30)
    history = ctx.server.limit("max-history-bytes", 256 * 1024 * 1024)
    if limit > _MAX_HELD:
        raise NotApplicable(
            f"max-held-bytes is {limit}; run against a server advertising at most {_MAX_HELD} "
            "(openair serve --max-held-bytes 262144)"
        )
    if history and history < 2 * limit:
        raise NotApplicable(
            f"max-history-bytes ({history}) is below twice max-held-bytes ({limit}): evictions "
            "free what the posts would take (OA-LIM-10)"
        )
    raw = await ctx.raw()
    size = limit // 4
    refused: tuple[str, Message] | None = None
    for n in range(5):
        type_ = ctx.type(f"Held.{n}")
        xml = message_xml(type_, to="WB2", content="x" * size)
        await send_big(
            ctx, raw, b"Message\x00" + struct.pack("<I", len(xml)) + xml, what="a big post"
        )
        reply = await raw.read_message(timeout=ctx.deadline * 4)
        if n == 0 and reply.type != "RECEIVE_ACCEPT":
            raise Inconclusive(f"setup: the first post of {size} bytes got {reply.type}")
        if reply.type != "RECEIVE_ACCEPT":
            refused = (type_, reply)
            break
    ctx.check(
        refused is not None,
        f"five posts of {size} bytes each (125 % of max-held-bytes {limit}) were all accepted",
        expected="one refused before the bytes held pass max-held-bytes (OA-LIM-14)",
    )
    assert refused is not None
    type_, reply = refused
    check_error(
        ctx, reply, names=("LIMIT_EXCEEDED",), what="a post past the bound", req="OA-LIM-14"
    )
    client = await ctx.module("C", bind=False)
    spec = f'<retrieve from="WB2" type="{esc(type_)}"><latest>0</latest></retrieve>'
    answer = await client.retrieve(spec)
    try:
        found = message_collection(answer)
    except WakeupUnreadable as exc:
        ctx.fail(
            f"the retrieve of the refused post was answered {answer.type}: {exc}",
            expected="AIR.Retrieve.Success with an empty collection (OA-RET-7)",
        )
    ctx.check(
        not found,
        f"the refused post is stored ({len(found)} copies retrieved)",
        expected="refused before it is stored (OA-LIM-14)",
    )


#: The tiny posts LIM-016 sends at most: each queues a wakeup carrying an eighth of
#: max-held-bytes, so the eighth must be refused.
_QUEUED_POSTS = 8


@case(
    id="LIM-016",
    title="Queued deliveries count toward max-held-bytes: tiny posts with big wakeups are refused",
    section="14.1",
    requirements=("OA-LIM-14", "OA-DELIV-8", "OA-WAKE-7", "OA-ERR-5"),
    serial=True,  # it fills the server-wide max-held-bytes
    allowed=(
        "Big (an eighth of max-held-bytes) accepted; of up to eight tiny posts, each queueing a "
        "wakeup (after 60 s) that retrieves Big, the first accepted and one answered "
        "RECEIVE_ERROR 'LIMIT_EXCEEDED: …' by the eighth; that post accepted once Sub has "
        "closed",
    ),
)
async def held_queued(ctx: CaseContext) -> None:
    """Post Big (an eighth of max-held-bytes and 64 bytes) to WB1; register Sub on `Go.*` with
    after=60000 and a retrieve of Big; post up to eight tiny `Go.n` until one is refused; close
    Sub (its queued wakeups are discarded, OA-SESS-15) and post the refused `Go.n` again: it
    must now be accepted, else the refusal had another cause and the case is inconclusive.

    Each accepted Go decides a wakeup that waits its `after` in Sub's queue (pending from its
    decision, OA-DELIV-8) and carries Big (OA-WAKE-7), so before the eighth the server holds
    Big and seven such wakeups: more than max-held-bytes whatever it held before. Catches: the
    bytes of queued deliveries left out of the budget (issue #15: `not self.queued_bytes is not
    None` survived), so posts are refused only for what is stored.
    """
    limit = ctx.server.limit("max-held-bytes", 1 << 30)
    if limit > _MAX_HELD:
        raise NotApplicable(
            f"max-held-bytes is {limit}; run against a server advertising at most {_MAX_HELD} "
            "(openair serve --max-held-bytes 262144)"
        )
    size = limit // _QUEUED_POSTS + 64  # eight of them pass the bound by 512 bytes
    bounds = {
        "max-history-bytes": (256 * 1024 * 1024, 2 * limit),
        "max-wakeup-result-bytes": (4 * 1024 * 1024, 2 * size),
        "max-queue-bytes": (64 * 1024 * 1024, 2 * limit),
        "max-queue": (10_000, 2 * _QUEUED_POSTS),
    }
    for name, (default, least) in bounds.items():
        value = ctx.server.limit(name, default)
        if value and value < least:
            raise NotApplicable(
                f"{name} ({value}) is below {least}: the wakeups would not hold Big"
            )
    raw = await ctx.raw()
    big = ctx.type("Big")
    xml = message_xml(big, to="WB1", content="x" * size)
    await send_big(ctx, raw, b"Message\x00" + struct.pack("<I", len(xml)) + xml, what="Big")
    reply = await raw.read_message(timeout=ctx.deadline * 4)
    if reply.type != "RECEIVE_ACCEPT":
        raise Inconclusive(f"setup: the post of Big ({size} bytes) got {reply.type}")
    sub = await ctx.module("Sub")
    await setup_subscribe(
        sub,
        f'<module name="{esc(sub.name)}">'
        f'<trigger from="WB1" type="{esc(ctx.type("Go.*"))}" after="60000"/>'
        f'<retrieve from="WB1" type="{esc(big)}"><latest>1</latest></retrieve></module>',
    )
    poster = await ctx.module("Poster", bind=False)
    refused: Message | None = None
    accepted = 0
    for n in range(1, _QUEUED_POSTS + 1):
        reply = await poster.post("WB1", ctx.type(f"Go.{n}"), "go", check=False)
        if reply.type != "RECEIVE_ACCEPT":
            refused = reply
            break
        accepted += 1
    if not accepted:
        raise Inconclusive(f"setup: the first tiny post got {refused.type if refused else None}")
    await sub.close()  # its queued wakeups go (OA-SESS-15): the bytes are free again
    ctx.check(
        refused is not None,
        f"{_QUEUED_POSTS} tiny posts were all accepted, each queueing a wakeup of Big "
        f"({size} bytes; max-held-bytes {limit})",
        expected="one refused by the eighth: queued deliveries count toward max-held-bytes "
        "(OA-LIM-14), and each carries Big (OA-WAKE-7)",
    )
    assert refused is not None
    check_error(
        ctx, refused, names=("LIMIT_EXCEEDED",), what="a post past the bound", req="OA-LIM-14"
    )
    await _freed(ctx, poster, ctx.type(f"Go.{accepted + 1}"))


async def _freed(ctx: CaseContext, poster: TestModule, type_: str) -> None:
    """Post `type_` again, now that Sub's queued wakeups are gone: accepted, else INCONCLUSIVE.

    The server drops a closed module's queue as it notices the close, so the post is tried
    until a deadline has passed.
    """
    loop = asyncio.get_running_loop()
    until = loop.time() + ctx.deadline
    while True:
        reply = await poster.post("WB1", type_, "go", check=False)
        if reply.type == "RECEIVE_ACCEPT":
            return
        if loop.time() >= until:
            raise Inconclusive(
                f"the refusal was not caused by queued deliveries: {type_} was answered "
                f"{reply.type} {reply.content!r} again after Sub closed"
            )
        await asyncio.sleep(ctx.deadline / 20)


@case(
    id="LIM-015",
    title="A gone module's counters leave STATUS within module-retention-ms and a quarter",
    section="14.1",
    requirements=("OA-LIM-15",),
    allowed=(
        "STATUS entries naming the module while it is bound; none once it has been gone "
        "module-retention-ms and a quarter of it",
    ),
)
async def retention(ctx: CaseContext) -> None:
    """Bind Gone and ping from it; STATUS must name it (else not applicable: the server shows
    no per-name state); close it, wait module-retention-ms × 1.25 and a deadline, ask again.

    Catches: counters of gone modules kept for ever (issue #15: `now / since` survived).
    """
    retention_ms = ctx.server.limit("module-retention-ms", 3_600_000)
    if retention_ms > _MAX_RETENTION_MS:
        raise NotApplicable(
            f"module-retention-ms is {retention_ms}; run against a server advertising at most "
            f"{_MAX_RETENTION_MS} (openair serve --module-retention-ms 200)"
        )
    gone = await ctx.module("Gone")
    asker = await ctx.module("Asker", bind=False)
    await gone.request(Message(type="PING", sender=gone.name, to="CNS"))
    naming = [name for name in await _status(ctx, asker) if gone.name in name]
    if not naming:
        raise NotApplicable("STATUS shows no per-module entries: OA-LIM-15 is not observable")
    await gone.close()
    await asyncio.sleep(retention_ms * 1.25 / 1000 + ctx.deadline)
    left = [name for name in await _status(ctx, asker) if gone.name in name]
    ctx.check(
        not left,
        f"STATUS still names the module gone {retention_ms * 1.25:.0f} ms ago: {left[:3]}",
        expected=f"forgotten within module-retention-ms ({retention_ms}) and a quarter (OA-LIM-15)",
    )
