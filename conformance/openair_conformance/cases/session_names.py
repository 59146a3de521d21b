"""Session cases of spec 6.3 and 6.5 about which callback connection a name loses: a newer
callback connection replaces the older one, and a takeover closes the old callback connection,
whatever the order in which the connections were opened.

The case opens the connection that acts last FIRST, so that a server deciding by the order of
connections (comparing connection ids, issue #15) instead of by which one is the older callback
connection gets it wrong. The modules are raw connections (`_common.raw_module`).
"""

from __future__ import annotations

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._common import (
    ack,
    bind_nolisten,
    next_request,
    raw_module,
    setup_raw_subscribe,
    triggers_xml,
)
from openair_conformance.harness import CaseContext, RawConnection
from openair_conformance.model import Inconclusive
from openair_conformance.registry import case


async def _delivered_over(
    ctx: CaseContext, primary: RawConnection, callback: RawConnection, receive_id: str, name: str
) -> None:
    """Subscribe `name` and cc it a post; take the wakeup on `callback` (INCONCLUSIVE if not).

    Shows the server has made `callback` the module's callback connection before the case goes
    on (a Receive frame gets no reply to wait for, OA-SESS-7).
    """
    await setup_raw_subscribe(primary, name, triggers_xml(ctx.type("Go")))
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Go"), "go", cc=name)
    wakeup = await next_request(ctx, callback, receive_id=receive_id, name=name)
    await ack(callback, wakeup, name)
    if wakeup.type != "AIR.Instruct.Wakeup":
        raise Inconclusive(f"setup: the callback connection got {wakeup.type}, not the wakeup")


@case(
    id="SESS-080",
    title="A newer callback connection opened before the older one still replaces it",
    section="6.5",
    requirements=("OA-SESS-7",),
    allowed=(
        "the callback connection that sent its RECEIVE_NAME_NOTIFICATION first is closed when "
        "a connection opened before it sends one for the same name",
    ),
)
async def newer_callback_opened_first(ctx: CaseContext) -> None:
    """Open connection L; bind N with BIND_NOLISTEN and open its callback connection C (after
    L); take a wakeup over C; then send N's RECEIVE_NAME_NOTIFICATION on L. C must be closed.

    Catches: a server that closes the older callback connection only when it was opened
    before the newer one (comparing connection ids or their order instead of identity).
    """
    name = ctx.name("N")
    late = await ctx.raw("N/late")  # opened first, used last
    primary, callback, receive_id = await raw_module(ctx, "N")
    await _delivered_over(ctx, primary, callback, receive_id, name)
    await late.send_message(
        Message(type="RECEIVE_NAME_NOTIFICATION", sender=name), FrameTag.RECEIVE
    )
    await callback.expect_closed()


@case(
    id="SESS-081",
    title="A takeover from a connection opened before the old callback connection closes it",
    section="6.3",
    requirements=("OA-SESS-6",),
    allowed=(
        "both the earlier primary connection and the earlier callback connection of N are "
        "closed after a BIND_NOLISTEN N from a connection opened before them",
    ),
)
async def takeover_closes_newer_callback(ctx: CaseContext) -> None:
    """Open connection T; bind N with BIND_NOLISTEN on another connection and open its
    callback connection C (after T); take a wakeup over C; then BIND_NOLISTEN N on T (a
    takeover). The earlier primary connection and C must both be closed.

    Catches: a server that closes the old callback connection in a takeover only when it was
    opened before the taking connection (comparing connection ids instead of identity).
    """
    name = ctx.name("N")
    taker = await ctx.raw("N/taker")  # opened first, takes the name over last
    primary, callback, receive_id = await raw_module(ctx, "N")
    await _delivered_over(ctx, primary, callback, receive_id, name)
    await bind_nolisten(taker, name)
    await primary.expect_closed()
    await callback.expect_closed()
