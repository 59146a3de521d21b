"""Conformance cases for the delivery window of a module that declares its extensions again
(6.3, 6.6): a module that binds again on its primary connection without `pipelining` is a legacy
module from then on, even for the deliveries already in flight.

The module binds with BIND_NOLISTEN and the case reads its callback connection by hand
(`raw_module`), so it decides exactly which acknowledgements are held.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable

from openair.protocol.message import Message
from openair_conformance.cases._common import ack, next_request, raw_module
from openair_conformance.harness import CaseContext
from openair_conformance.model import Inconclusive
from openair_conformance.registry import case


@case(
    id="DELIV-060",
    title="A module that binds again without pipelining while two deliveries are unanswered gets "
    "the next one only after both are acknowledged",
    section="6.6",
    requirements=("OA-DELIV-5", "OA-SESS-19", "OA-SESS-35"),
    needs=("pipelining",),
    allowed=(
        "A and B delivered unanswered under pipelining; after the second BIND_NOLISTEN (no "
        "extensions) C is not sent while A or B is unanswered, and is sent after both are "
        "acknowledged",
    ),
)
async def window_shrinks_on_rebind(ctx: CaseContext) -> None:
    """A module declares `pipelining` (OA-SESS-19) and gets messages A and B, which it leaves
    unanswered; its queue is then empty. It binds again on the same connection declaring no
    extension (OA-SESS-35), which makes it a legacy module (OA-SESS-19), and message C is sent
    to it: C must not come while A or B is unanswered (one delivery at a time to a legacy
    module, OA-DELIV-5), and must come once both are acknowledged.

    The absence of C is watched for a fixed time (at most 0.5 s, and a quarter of
    ack-deadline-ms, so that A and B are not given up meanwhile, OA-DELIV-11): a server that
    sends C without waiting does so as soon as C is accepted, within milliseconds.
    Catches: a server that checks a module's window only before it waits for work, so that a
    delivery found after the wait goes out although the window, shrunk meanwhile, is full.
    """
    window = ctx.server.limit("max-in-flight", 256)
    if window < 2:
        raise Inconclusive(f"max-in-flight is {window}: no two deliveries in flight to hold")
    name = ctx.name("R")
    primary, callback, receive_id = await raw_module(ctx, "R", extensions=("pipelining",))
    sender = await ctx.module("S", bind=False)

    def take() -> Awaitable[Message]:
        return next_request(ctx, callback, receive_id=receive_id, name=name)

    async def send(label: str) -> str:
        msg = Message(type=ctx.type(label), sender=sender.name, to=name, content=label)
        reply = await sender.request(msg)
        if reply.type != "RECEIVE_ACCEPT":
            raise Inconclusive(f"setup: {msg.type} was answered {reply.type} {reply.content!r}")
        return msg.type

    held: list[Message] = []
    for label in ("A", "B"):
        sent = await send(label)
        got = await ctx.wait(
            take(),
            what=f"delivery of {label} while the earlier ones are unanswered",
            expected="up to max-in-flight deliveries to a module that declared pipelining "
            "(OA-DELIV-5)",
        )
        if got.type != sent:
            raise Inconclusive(f"setup: the module got {got.type}, not {sent}")
        held.append(got)
    rebind = await primary.request(Message(type="BIND_NOLISTEN", sender=name, to="CNS"))
    if rebind.type != "BIND_ACCEPT":
        raise Inconclusive(
            f"setup: the second BIND_NOLISTEN was answered {rebind.type} {rebind.content!r}"
        )
    third = await send("C")
    quiet = min(0.5, ctx.server.limit("ack-deadline-ms", 10_000) / 4000)
    for still in (2, 1):
        early: Message | None = None
        try:
            early = await asyncio.wait_for(take(), quiet)
        except TimeoutError:
            ctx.note(f"nothing came in {quiet} s while {still} deliveries were unanswered")
        ctx.check(
            early is None,
            f"the module, legacy since its second BIND_NOLISTEN, got "
            f"{early.type if early else ''} while {still} deliveries were unanswered",
            expected="one delivery at a time to a legacy module: C only after A and B are "
            "acknowledged (OA-DELIV-5, OA-SESS-19)",
        )
        await ack(callback, held.pop(0), name)
    got = await ctx.wait(
        take(),
        what="delivery of C after A and B were acknowledged",
        expected="the message queued for delivery to the module (OA-SESS-22)",
    )
    ctx.check(
        got.type == third,
        f"after A and B the module got {got.type!r}",
        expected=f"{third!r} (OA-SESS-22)",
    )
    await ack(callback, got, name)
