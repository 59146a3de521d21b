"""Session cases of spec 6.3, 6.5 and 6.9: which BIND is a takeover (by the connection
that carries it, not by the order of connections), a callback connection that ends before or
after its module binds, and the callback connection closed with the primary one.

The modules here are raw connections (`_common.raw_module`): the case chooses exactly when each
callback connection opens and ends, and answers the server's requests itself.
"""

from __future__ import annotations

import asyncio

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._common import (
    ack,
    bind_nolisten,
    cns_request,
    next_request,
    raw_module,
    setup_subscribe,
    triggers_xml,
    view_of,
)
from openair_conformance.harness import CaseContext, RawConnection
from openair_conformance.harness.checks import wakeup_trigger_id
from openair_conformance.model import Inconclusive, NotApplicable
from openair_conformance.registry import case

#: The longest the case leaves a delivery with no way to the module (see `_no_path_s`).
_NO_PATH_MAX_S = 5.0


def _no_path_s(ctx: CaseContext) -> float:
    """How long the case leaves a delivery with no way to the module: as long as a server's
    retries of a failed delivery may take by its advertised limits (delivery-retries, each retry
    within retry-deadline-ms of the failure, OA-DELIV-15) and the case's deadline, so that a
    server that takes "no callback connection" for a failed attempt has abandoned it by then.
    NotApplicable when that is longer than `_NO_PATH_MAX_S`: a shorter wait would let such a
    server pass.
    """
    retries = ctx.server.limit("delivery-retries", 2)
    deadline_ms = ctx.server.limit("retry-deadline-ms", 1000)
    wait = retries * deadline_ms / 1000 + ctx.deadline
    if wait > _NO_PATH_MAX_S:
        raise NotApplicable(
            f"the retries may take {wait:.1f} s (delivery-retries {retries}, retry-deadline-ms "
            f"{deadline_ms}, and the deadline): more than the case waits, {_NO_PATH_MAX_S} s"
        )
    return wait


async def _subscribe(ctx: CaseContext, primary: RawConnection, name: str, pattern: str) -> None:
    msg = Message(
        type="AIR.Subscribe",
        sender=name,
        to="AIRCentral",
        content=triggers_xml(pattern),
        content_is_xml=True,
        language="xml",
    )
    reply = await primary.request(msg)
    if reply.type != "RECEIVE_ACCEPT":
        raise Inconclusive(f"setup: AIR.Subscribe was answered {reply.type} {reply.content!r}")


async def _open_callback(ctx: CaseContext, name: str, label: str) -> tuple[RawConnection, str]:
    """Open a raw callback connection for `name`; return it and the Receive frame's id."""
    callback = await ctx.raw(label)
    sent = await callback.send_message(
        Message(type="RECEIVE_NAME_NOTIFICATION", sender=name), FrameTag.RECEIVE
    )
    return callback, sent.id


async def _end_callback(ctx: CaseContext, callback: RawConnection, probe: RawConnection) -> None:
    """Close a callback connection and let the server see its end before the case goes on.

    The end travels on another connection than the case's next request, so the case waits a
    quarter of the deadline (ten round trips: time enough to see the end) and makes a round
    trip (a PING) on `probe` first.
    """
    await callback.close()
    await asyncio.sleep(ctx.deadline / 4)
    reply = await probe.request(cns_request(ctx, "PING"))
    if reply.type != "PING_SUCCESS":
        raise Inconclusive(f"setup: PING was answered {reply.type}")


async def _wakeup_for(
    ctx: CaseContext, callback: RawConnection, receive_id: str, name: str, message_id: str
) -> Message:
    """Return the wakeup for `message_id` on a raw callback, acknowledging every delivery."""
    while True:
        msg = await next_request(ctx, callback, receive_id=receive_id, name=name)
        await ack(callback, msg, name)
        if msg.type == "AIR.Instruct.Wakeup" and wakeup_trigger_id(msg) == message_id:
            return msg
        ctx.note(f"{name}: {msg.type} before the awaited wakeup (a phase update is allowed)")


@case(
    id="SESS-045",
    title="BIND again on the primary connection posts no notice; a takeover posts Restored",
    section="6.3",
    requirements=("OA-SESS-35", "OA-SESS-6"),
    allowed=(
        "no Psyclone.Module.Restored or Lost notice for N, bound twice on one connection",
        "Psyclone.Module.Restored.<M> for M taken over from a connection opened after the "
        "taking one; the later connection is closed",
    ),
)
async def takeover_by_connection(ctx: CaseContext) -> None:
    """BIND_NOLISTEN N twice on one connection; open connections A then B, BIND_NOLISTEN M on
    B and then on A; watch AIRCentral for the notices of N and M.

    Catches: a server that decides "takeover" by comparing connection ids or their order instead
    of identity (issue #15): the same connection binding again is then taken for a takeover
    (a Restored notice), or a takeover from a newer connection is missed (no Restored).
    """
    n, m = ctx.name("N"), ctx.name("M")
    watcher = await ctx.module("Watch")
    notices = [f"Psyclone.Module.{kind}.{who}" for who in (n, m) for kind in ("Restored", "Lost")]
    await setup_subscribe(watcher, triggers_xml(*notices, wb="AIRCentral"))
    same = await ctx.raw("N/primary")
    for _ in range(2):
        await bind_nolisten(same, n)
    older = await ctx.raw("M/older")
    newer = await ctx.raw("M/newer")
    await bind_nolisten(newer, m)
    got = await watcher.barrier()
    types = [t for t in (view_of(ctx, w).trigger for w in got) if t is not None]
    ctx.check(
        not types,
        f"notices after N bound twice on one connection: {[t.type for t in types]}",
        expected="none: binding again on the primary connection is no takeover (OA-SESS-35)",
    )
    await bind_nolisten(older, m)
    await newer.expect_closed()
    restored = await watcher.expect_wakeup(what="Psyclone.Module.Restored notice of M")
    trigger = view_of(ctx, restored).trigger
    ctx.check(
        trigger is not None and trigger.type == f"Psyclone.Module.Restored.{m}",
        f"the notice is {trigger.type if trigger else None!r}",
        expected=f"Psyclone.Module.Restored.{m}: a BIND from an older connection takes the "
        "name over as well (OA-SESS-6)",
    )


@case(
    id="SESS-046",
    title="Closing a module's primary connection closes its callback connection",
    section="6.9",
    requirements=("OA-SESS-15",),
    allowed=("the server closes the callback connection after the primary one closed",),
)
async def primary_close_ends_callback(ctx: CaseContext) -> None:
    """Bind with BIND_NOLISTEN, open the callback connection, take a wakeup there (so the server
    has adopted it), then close the primary connection.

    Catches: a server that forgets the callback connection of a lost module and leaves it open
    (the module would wait there for ever), issue #15.
    """
    primary, callback, receive_id = await raw_module(ctx, "N")
    name = ctx.name("N")
    poster = await ctx.module("Poster", bind=False)
    await _subscribe(ctx, primary, name, ctx.type("Go"))
    await poster.post("WB1", ctx.type("Go"), "adopted?")
    assert poster.last_sent is not None
    await _wakeup_for(ctx, callback, receive_id, name, poster.last_sent.id)
    await primary.close()
    await callback.expect_closed()


@case(
    id="SESS-047",
    title="A module without a callback connection gets its deliveries over the next one",
    section="6.5",
    requirements=("OA-SESS-5", "OA-SESS-7", "OA-SESS-36", "OA-DELIV-8"),
    allowed=(
        "each wakeup arrives on the module's next callback connection (a PING or a phase "
        "update there first is allowed)",
    ),
)
async def callback_ended(ctx: CaseContext) -> None:
    """Module A binds with BIND_NOLISTEN and its callback connection ends; module B's callback
    connection ends before B binds with BIND_NOLISTEN. Both register, a post wakes both, and
    only after the time the server's retries may take and a deadline (3 s at the default limits
    and deadline; not applicable beyond 5 s) each opens a new callback connection.

    Catches: a server that keeps a callback connection that has ended as the module's (or as
    the one a name gets when it binds) and so treats each delivery as failed, abandoning it
    after its retries instead of holding it until the module opens a callback connection again
    (OA-SESS-5, OA-DELIV-8), issue #15.
    """
    no_path = _no_path_s(ctx)
    a, b = ctx.name("A"), ctx.name("B")
    primary_a = await ctx.raw("A/primary")
    await bind_nolisten(primary_a, a)
    # The server reads a connection's Receive frame before its end: each first callback
    # connection is the module's (or kept for the name) until it ends. The modules register
    # only then, so that nothing is in flight on a connection that ends.
    first_a, _ = await _open_callback(ctx, a, "A/callback1")
    first_b, _ = await _open_callback(ctx, b, "B/callback1")
    primary_b = await ctx.raw("B/primary")
    await _end_callback(ctx, first_a, primary_a)
    await _end_callback(ctx, first_b, primary_b)
    await bind_nolisten(primary_b, b)
    for name, primary in ((a, primary_a), (b, primary_b)):
        await _subscribe(ctx, primary, name, ctx.type("Go"))
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Go"), "for A and B, who have no callback connection")
    assert poster.last_sent is not None
    go = poster.last_sent.id
    await asyncio.sleep(no_path)
    for name, label in ((a, "A/callback2"), (b, "B/callback2")):
        callback, receive_id = await _open_callback(ctx, name, label)
        await _wakeup_for(ctx, callback, receive_id, name, go)
