"""Delivery and priority cases (spec 6.6 and section 10): one delivery at a time, slow modules,
priority order of a module's queue, and the bounded queue.

Order is observed under load: the module holds its acknowledgement of a first delivery, so that
later deliveries wait in its queue together (OA-PRIO-4), and then releases it. Those modules
bind with BIND_NOLISTEN and read their callback connection by hand (`_Hand`), so every delivery
takes one path and phase updates (OA-WAKE-9) are acknowledged at once.
"""

from __future__ import annotations

import struct

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    ack,
    message_xml,
    next_request,
    raw_module,
    send_big,
    setup_subscribe,
    trigger_ids,
    triggers_xml,
)
from openair_conformance.harness import CaseContext, RawConnection, TestModule
from openair_conformance.model import Inconclusive, NotApplicable
from openair_conformance.registry import case

#: The largest queue DELIV-003 fills; larger ones, up to the default max-queue, are DELIV-014's
#: (issue #15: overflow is checked at the defaults too, in about ten seconds).
_MAX_FILL = 2000
_MAX_DEFAULT_FILL = 10_000


class _Hand:
    """A module bound with BIND_NOLISTEN whose callback connection the case reads by hand.

    Phase updates are acknowledged at once (`next_request`); wakeups only when the case says,
    so that the case decides exactly which acknowledgement is held.
    """

    def __init__(self, ctx: CaseContext, primary: RawConnection, callback: RawConnection) -> None:
        self.ctx, self.primary, self.callback = ctx, primary, callback
        self.name = ctx.name("M")
        self.receive_id = ""

    @classmethod
    async def open(cls, ctx: CaseContext, *, extensions: tuple[str, ...] = ()) -> _Hand:
        """Bind, open the callback connection and register `<prefix>.*` on every whiteboard."""
        primary, callback, receive_id = await raw_module(ctx, "M", extensions=extensions)
        hand = cls(ctx, primary, callback)
        hand.receive_id = receive_id
        content = triggers_xml(ctx.type("*"), wb="any")
        subscribe = Message(
            type="AIR.Subscribe",
            sender=hand.name,
            to="AIRCentral",
            content=content,
            content_is_xml=True,
            language="xml",
        )
        if (await primary.request(subscribe)).type != "RECEIVE_ACCEPT":
            raise Inconclusive("setup: AIR.Subscribe was refused")
        return hand

    async def next(self, *, timeout: float | None = None) -> Message:
        """Return the next wakeup, not acknowledged yet."""
        return await self.ctx.wait(
            next_request(self.ctx, self.callback, receive_id=self.receive_id, name=self.name),
            what=f"delivery to {self.name}",
            timeout=timeout,
        )

    async def take(self, *, timeout: float | None = None) -> str:
        """Return the trigger id of the next wakeup, acknowledged."""
        wakeup = await self.next(timeout=timeout)
        await ack(self.callback, wakeup, self.name)
        return (trigger_ids([wakeup]) or [""])[0]


async def _plugged(ctx: CaseContext) -> tuple[_Hand, Message, TestModule]:
    """Return (module, held wakeup, poster): the first delivery is received, not acknowledged."""
    hand = await _Hand.open(ctx)
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Plug"), "plug")
    return hand, await hand.next(), poster


async def plugged_window(ctx: CaseContext) -> tuple[_Hand, list[Message], TestModule]:
    """Return (module, held wakeups, poster) with the module's whole window held.

    Under `pipelining` the module declares it and the server may have max-in-flight deliveries
    in flight (OA-DELIV-5): that many are received and held, so that later ones queue, and on
    release the queue drains without a round trip per delivery.
    """
    window = ctx.server.limit("max-in-flight", 256) if ctx.server.has("pipelining") else 1
    hand = await _Hand.open(ctx, extensions=("pipelining",) if window > 1 else ())
    poster = await ctx.module("Poster", bind=False)
    for n in range(window):
        await poster.post("WB1", ctx.type(f"Plug.{n}"), "plug")
    plugs = [await hand.next() for _ in range(window)]
    return hand, plugs, poster


async def drain_held(ctx: CaseContext, hand: _Hand, last: str, *, batch: int) -> list[str]:
    """Take deliveries up to the one for `last`; return their trigger ids in order.

    Acknowledgements go out `batch` at a time (fewer than the window, so the server always has
    room to send on): one write per delivery would make a queue of 10 000 a matter of seconds.
    """
    arrived: list[str] = []
    pending: list[Message] = []
    while not arrived or arrived[-1] != last:  # the newest fill is the last priority-2 one
        wakeup = await hand.next(timeout=ctx.deadline * 20)
        pending.append(wakeup.reply("RECEIVE_ACCEPT", sender=hand.name))
        arrived.append((trigger_ids([wakeup]) or [""])[0])
        if len(pending) >= batch or arrived[-1] == last:
            await hand.callback.send_messages(pending)
            pending = []
    return arrived


@case(
    id="PRIO-001",
    title="Queued deliveries go out by priority (lower first), FIFO within a priority",
    section="10",
    requirements=("OA-PRIO-1", "OA-PRIO-3"),
    allowed=("after the held one: priorities 0, 1 (first), 1 (second), absent (2.0), 3, 5",),
)
async def priority_order(ctx: CaseContext) -> None:
    """Hold the first delivery; post priorities 5, 1, 3, 1, absent, 0; release; read the order.

    Catches: a FIFO queue that ignores priorities, a LIFO order within a priority, an absent
    priority not treated as 2.0.
    """
    hand, plug, poster = await _plugged(ctx)
    order = (("p5", 5.0), ("p1a", 1.0), ("p3", 3.0), ("p1b", 1.0), ("p2", None), ("p0", 0.0))
    names = {}
    for name, priority in order:
        await poster.post("WB1", ctx.type(name), name, priority=priority)
        assert poster.last_sent is not None
        names[poster.last_sent.id] = name
    await ack(hand.callback, plug, hand.name)
    got = [names.get(await hand.take(), "?") for _ in order]
    want = ["p0", "p1a", "p1b", "p2", "p3", "p5"]
    ctx.check(got == want, f"deliveries in the order {got}", expected=f"{want} (OA-PRIO-1)")


@case(
    id="PRIO-002",
    title="Equal priorities from whiteboards of equal priority keep arrival order",
    section="10",
    requirements=("OA-PRIO-2", "OA-PRIO-1"),
    allowed=(
        "WB2's post first, then WB1's, then AIRCentral's (all whiteboards priority 1.0 on an "
        "unconfigured server)",
    ),
)
async def whiteboard_tie(ctx: CaseContext) -> None:
    """Hold the first delivery; post equal-priority messages to WB2, WB1 and AIRCentral.

    Catches: deliveries ordered by whiteboard name, or per-whiteboard queues drained in turn.
    The suite cannot configure whiteboard priorities, so it checks the equal-priority case.
    """
    hand, plug, poster = await _plugged(ctx)
    names = {}
    for board in ("WB2", "WB1", "AIRCentral"):
        await poster.post(board, ctx.type(f"From.{board}"), board)
        assert poster.last_sent is not None
        names[poster.last_sent.id] = board
    await ack(hand.callback, plug, hand.name)
    got = [names.get(await hand.take(), "?") for _ in names]
    ctx.check(
        got == ["WB2", "WB1", "AIRCentral"], f"order {got}", expected="arrival order (OA-PRIO-2)"
    )


def _pending_bytes(raw: RawConnection) -> int:
    """Bytes the server has sent on `raw` that the case has not read yet.

    Reads private buffers of the harness stream (its StreamReader and FrameReader): after a
    round trip elsewhere, data the server sent is in them even though nobody awaited a read.
    """
    stream = raw.stream
    reader_buffer = getattr(getattr(stream, "_reader", None), "_buffer", b"")
    frames = getattr(stream, "_frames", None)
    return len(reader_buffer) + int(getattr(frames, "buffered", 0))


@case(
    id="DELIV-001",
    title="A legacy module gets one delivery at a time: the next waits for the acknowledgement",
    section="6.6",
    requirements=("OA-DELIV-5", "OA-SESS-28"),
    allowed=("nothing more on the callback connection until the first wakeup is acknowledged",),
)
async def one_at_a_time(ctx: CaseContext) -> None:
    """Bind with BIND_NOLISTEN and read the callback connection by hand; post three messages;
    hold the first wakeup through a round trip on the primary connection, and check that no
    byte of a second delivery has arrived; acknowledge and read the rest.

    Catches: a server that pushes deliveries to a legacy module without waiting for its
    acknowledgements (JavaOpenAIR modules handle one at a time and would mis-pair replies).
    """
    hand = await _Hand.open(ctx)
    poster = await ctx.module("Poster", bind=False)
    for n in range(3):
        await poster.post("WB1", ctx.type(f"N.{n}"), str(n))
    for n in range(3):
        wakeup = await hand.next()
        reply = await hand.primary.request(Message(type="PING", sender=hand.name, to="CNS"))
        ctx.check(reply.type == "PING_SUCCESS", f"PING: {reply.type}", expected="PING_SUCCESS")
        pending = _pending_bytes(hand.callback)
        ctx.check(
            pending == 0,
            f"{pending} bytes of another delivery arrived before the acknowledgement of #{n + 1}",
            expected="OA-DELIV-5",
        )
        await ack(hand.callback, wakeup, hand.name)


@case(
    id="DELIV-002",
    title="A module that does not acknowledge delays neither other modules nor posters",
    section="6.6",
    requirements=("OA-DELIV-6",),
    allowed=("the posts are acknowledged and the other module gets every wakeup",),
)
async def slow_module(ctx: CaseContext) -> None:
    """Two modules register the same pattern; one holds its acknowledgements; post three.

    Catches: one delivery loop for all modules, or posts acknowledged only after delivery.
    """
    slow, fast = await ctx.module("Slow"), await ctx.module("Fast")
    for module in (slow, fast):
        await setup_subscribe(module, triggers_xml(ctx.type("*")))
    slow.pause_acks()
    poster = await ctx.module("Poster", bind=False)
    ids = []
    for n in range(3):
        await poster.post("WB1", ctx.type(f"N.{n}"), str(n))
        assert poster.last_sent is not None
        ids.append(poster.last_sent.id)
    for message_id in ids:
        await fast.expect_wakeup_for(message_id)
    slow.resume_acks()
    for message_id in ids:
        await slow.expect_wakeup_for(message_id)


@case(
    id="DELIV-003",
    title="A full queue drops the oldest of its lowest-priority deliveries, for that module only",
    section="6.6",
    requirements=("OA-DELIV-8", "OA-DELIV-9"),
    needs=("noreply",),
    serial=True,
    allowed=(
        "the priority-5 delivery and the oldest of the max-queue + 1 priority-2 deliveries are "
        "dropped (the ones in flight are not in the queue, OA-DELIV-8); the max-queue newest "
        "arrive in order",
    ),
)
async def queue_overflow(ctx: CaseContext) -> None:
    """Hold a first delivery; post one priority-5 message and max-queue + 1 priority-2 ones
    (noreply, then one acknowledged); release and count what arrives.

    Catches: an unbounded queue, dropping the newest, dropping by arrival instead of priority,
    a queue that overflows one early or counts the deliveries in flight.
    """
    limit = ctx.server.limit("max-queue", 10_000)
    if limit > _MAX_FILL:
        raise NotApplicable(
            f"max-queue is {limit}; DELIV-014 fills queues above {_MAX_FILL} (run this one "
            "against a server configured with a smaller max-queue: openair serve --max-queue)"
        )
    await _overflow(ctx, limit)


@case(
    id="DELIV-014",
    title="A queue at the default max-queue overflows as a small one does",
    section="6.6",
    requirements=("OA-DELIV-8", "OA-DELIV-9"),
    needs=("noreply",),
    serial=True,
    allowed=(
        "as DELIV-003, with max-queue above 2000 and at most 10 000 (the default): the "
        "priority-5 delivery is dropped, the newest fills arrive in order",
    ),
)
async def queue_overflow_at_default(ctx: CaseContext) -> None:
    """DELIV-003 at the advertised max-queue when it is large, up to the default 10 000.

    Catches: a queue whose capacity is fixed below the advertised max-queue (a ring of 8192),
    or that overflows differently once it is deep.
    """
    limit = ctx.server.limit("max-queue", 10_000)
    if not _MAX_FILL < limit <= _MAX_DEFAULT_FILL:
        raise NotApplicable(
            f"max-queue is {limit}: DELIV-003 fills queues up to {_MAX_FILL}, and one above "
            f"{_MAX_DEFAULT_FILL} (the default) is too slow to fill in a routine run"
        )
    await _overflow(ctx, limit)


async def _overflow(ctx: CaseContext, limit: int) -> None:
    """Fill a held module's queue with max-queue + 1 fills after one priority-5 message."""
    hand, plugs, poster = await plugged_window(ctx)
    await poster.post("WB1", ctx.type("Low"), "low", priority=5.0)
    assert poster.last_sent is not None
    low = poster.last_sent.id
    raw = await ctx.raw()
    data = bytearray()
    ids = []
    for n in range(limit):
        ident = f"{ctx.name('Q')}_{n}"
        ids.append(ident)
        xml = message_xml(ctx.type("Fill"), to="WB1", id=ident, attrs='noreply="yes"', content="")
        data += b"Message\x00" + struct.pack("<I", len(xml)) + xml
    await send_big(ctx, raw, bytes(data), what=f"{limit} noreply posts")
    last = await raw.request(
        Message(type=ctx.type("Fill"), sender=ctx.name("Q"), to="WB1"), timeout=ctx.deadline * 20
    )
    ids.append(last.isresponse)
    await hand.callback.send_messages([p.reply("RECEIVE_ACCEPT", sender=hand.name) for p in plugs])
    arrived = await drain_held(ctx, hand, ids[-1], batch=max(1, len(plugs) // 4))
    # A last, lowest-priority sentinel: the priority-5 delivery, if kept, arrives before it.
    await poster.post("WB1", ctx.type("Sentinel"), "end", priority=6.999)
    assert poster.last_sent is not None
    while arrived[-1] != poster.last_sent.id:
        arrived.append(await hand.take())
    ctx.check(low not in arrived, "the priority-5 delivery was not dropped", expected="OA-DELIV-9")
    wanted = set(ids)
    fills = [i for i in arrived if i in wanted]
    ctx.check(  # OA-DELIV-8: a full window's deliveries are sent, not queued
        len(fills) == limit,
        f"{len(fills)} of {limit + 1} fills arrived",
        expected=f"{limit}: the queue holds max-queue ({limit}) besides the window (OA-DELIV-8)",
    )
    ctx.check(
        fills == ids[len(ids) - len(fills) :],
        "the fills that arrived are not the newest, in order",
        expected="OA-DELIV-9",
    )


@case(
    id="DELIV-004",
    title="A noreply message forwarded to a legacy module arrives without noreply",
    section="6.6",
    requirements=("OA-GEN-2", "OA-SESS-22"),
    needs=("noreply",),
    allowed=("the delivery carries no noreply attribute (or noreply='no') and is acknowledged",),
)
async def noreply_stripped_for_legacy(ctx: CaseContext) -> None:
    """Send `noreply="yes"` to a bound module that declared no extension; take its delivery.

    Catches: a server that forwards the extension's wire form to a legacy module (OA-GEN-2),
    which would then not acknowledge it and stall its deliveries.
    """
    target = await ctx.module("Legacy")  # declares nothing: a legacy module (OA-SESS-19)
    sender = await ctx.module("S", bind=False)
    msg = Message(
        type=ctx.type("Quiet"), sender=sender.name, to=target.name, content="psst", noreply=True
    )
    await sender.send_noreply(msg)
    got = await target.next_delivery()
    ctx.check(
        got.type == msg.type and not got.noreply,
        f"the delivery is {got.type!r} with noreply={got.noreply}",
        expected=f"{msg.type!r} without noreply (OA-GEN-2)",
    )
