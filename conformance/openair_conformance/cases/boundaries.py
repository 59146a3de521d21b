"""Conformance cases at the boundaries the examples never touch (issue #15).

Slots rare on the wire compared in full on every copy the server hands out (OA-WB-4), letter
case in ids (OA-RET-3) and fractional priorities in a queue of dozens (section 10). The
session commands every component must answer (SESS-043) are in session_status.py.
"""

from __future__ import annotations

import random
from dataclasses import fields, replace

from openair.protocol.message import Message, Slot
from openair.protocol.times import AirTime
from openair_conformance.cases._common import (
    ack,
    retrieved,
    setup_subscribe,
    triggers_xml,
    view_of,
)
from openair_conformance.cases.priorities import _plugged
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import message_collection
from openair_conformance.registry import case

#: 2100-01-01T00:00:00.123Z: a postedTime far ahead of any server's clock (OA-TIME-4,
#: OA-RET-5). Ahead, not behind: a whiteboard that never lets receivedTime go back (OA-WB-12)
#: would hide a receivedTime taken from a postedTime in the past.
_FAR_POSTED = AirTime(sec=4_102_444_800, msec=123)


def _rare(ctx: CaseContext, sender: str) -> Message:
    """A post whose every slot is at a boundary: fractions, case, white space, a far clock."""
    msg = Message(
        type=ctx.type("Rare"),
        sender=sender,
        to="WB1",
        priority=1.25,
        timetolive=86_400_000.5,
        language="EnGlish",
        content="  padded\n\ttext  ",
        content_version="2.1",
        history='<step n="1"/>',
        posted=_FAR_POSTED,
    )
    return replace(msg, extras=(Slot(name="xNote", value=" Keep Me "),))


def _as_stored(sent: Message, got: Message) -> Message:
    """Return `sent` as its stored copy must be, taking what the server adds from `got`."""
    return replace(
        sent,
        stored="WB1",
        received=got.received,
        wbid=got.wbid,
        netprotocol=got.netprotocol,  # may be added (7.4)
        comment=got.comment,  # may be added on a cc'd copy (7.4)
    )


@case(
    id="WB-008",
    title="The stored copy keeps every slot: fractions, case, white space, a far postedTime",
    section="7.4",
    requirements=("OA-WB-4", "OA-MSG-5", "OA-MSG-7", "OA-MSG-22", "OA-TIME-4", "OA-RET-5"),
    allowed=(
        "every slot of the post as sent (priority 1.25, timetolive 86400000.5, language "
        "'EnGlish', content with its spaces, content version, history, the slot xNote, "
        "postedTime 2100-01-01) plus stored, receivedTime and wbid, in the wakeup and in the "
        "retrieve reply; a receivedTime of the server's own, so a 10-minute lastmsec finds it",
    ),
)
async def stored_copy_rare_slots(ctx: CaseContext) -> None:
    """Post a message whose slots sit at boundaries; compare every slot of its copies.

    Catches: content trimmed, language or unknown slots dropped or case-folded, a fractional
    priority or timetolive rounded, postedTime restamped, receivedTime taken from postedTime.
    """
    sub = await ctx.module("Sub")
    await setup_subscribe(sub, triggers_xml(ctx.type("Rare")))
    poster = await ctx.module("Poster", bind=False)
    sent_reply = await poster.request(_rare(ctx, poster.name))
    ctx.check(sent_reply.type == "RECEIVE_ACCEPT", f"post: {sent_reply.type}", expected="OA-WB-3")
    sent = poster.last_sent
    assert sent is not None
    trigger = view_of(ctx, await sub.expect_wakeup_for(sent.id)).trigger
    spec = f'<retrieve from="WB1" id="{sent.id}"><lastmsec>600000</lastmsec></retrieve>'
    found = await retrieved(ctx, poster, spec)
    ctx.check(
        len(found) == 1,
        f"{len(found)} copies within the last 10 minutes",
        expected="one: receivedTime is the server's, not the 2100 postedTime (OA-RET-5)",
    )
    for where, got in (("TriggerMessage", trigger), ("retrieved copy", found[0])):
        assert got is not None
        want = _as_stored(sent, got)
        differ = {
            f.name: (getattr(got, f.name), getattr(want, f.name))
            for f in fields(Message)
            if getattr(got, f.name) != getattr(want, f.name)
        }
        ctx.check(
            not differ,
            f"{where}: slots that differ (got, posted): {differ}",
            expected="every slot as posted (OA-WB-4, OA-MSG-5)",
        )
        ctx.check(
            got.received is not None and got.wbid is not None and got.received != sent.posted,
            f"{where}: receivedTime {got.received}, wbid {got.wbid}",
            expected="the whiteboard's receivedTime (not the postedTime) and a wbid (OA-WB-4)",
        )


@case(
    id="RET-022",
    title="Retrieve by id and sender compares exactly: another letter case selects nothing",
    section="9.2",
    requirements=("OA-RET-3", "OA-RET-2"),
    allowed=("the exact id and sender select the post; upper-cased ones, or from='wb1', none",),
)
async def retrieve_exact_case(ctx: CaseContext) -> None:
    """Post once; retrieve by its id and sender exactly, then in upper case, then from wb1.

    Catches: ids or senders compared case-insensitively, a `from` folded to a whiteboard.
    """
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Case"), "case")
    sent = poster.last_sent
    assert sent is not None
    checks = (
        (f'id="{sent.id}"', 1, "WB1"),
        (f'id="{sent.id.upper()}"', 0, "WB1"),
        (f'sender="{sent.sender}" type="{ctx.type("Case")}"', 1, "WB1"),
        (f'sender="{sent.sender.lower()}" type="{ctx.type("Case")}"', 0, "WB1"),
        (f'id="{sent.id}"', 0, "wb1"),
    )
    for attrs, want, board in checks:
        spec = f'<retrieve from="{board}" {attrs}/>'
        request = Message(
            type="AIR.Retrieve",
            sender=poster.name,
            to="AIRCentral",
            content=spec,
            content_is_xml=True,
            language="xml",
        )
        reply = await poster.request(request)
        # A `from` naming no whiteboard may fail (WHITEBOARD_UNKNOWN); it never selects.
        found = message_collection(reply) if reply.type == "AIR.Retrieve.Success" else ()
        ctx.check(
            want == 0 or reply.type == "AIR.Retrieve.Success",
            f"{spec} was answered {reply.type} {reply.content!r}",
            expected="AIR.Retrieve.Success (OA-RET-7)",
        )
        got = sum(1 for m in found if m.id == sent.id)
        ctx.check(got == want, f"{spec} selected {got}", expected=f"{want} (OA-RET-3, OA-RET-2)")


#: Priorities of PRIO-003: fractions between the integers, repeats, the extremes.
_LEVELS = (0.0, 0.25, 0.5, 1.0, 1.1, 1.125, 1.75, None, 2.5, 3.0, 4.999, 6.999)


@case(
    id="PRIO-003",
    title="Forty-eight queued deliveries go out by fractional priority, FIFO within each",
    section="10",
    requirements=("OA-PRIO-1", "OA-PRIO-3", "OA-MSG-6"),
    allowed=("after the held one: ascending priority (absent = 2.0), arrival order within one",),
)
async def deep_fractional_order(ctx: CaseContext) -> None:
    """Hold the first delivery; post 48 messages at 12 fractional levels in a fixed shuffle.

    Catches: priorities truncated or rounded to integers, an order kept only for the first
    few queued items, a FIFO order within a level lost in a deep queue.
    """
    hand, plug, poster = await _plugged(ctx)
    levels = list(_LEVELS) * 4
    random.Random(20261126).shuffle(levels)
    names: dict[str, int] = {}
    for n, priority in enumerate(levels):
        await poster.post("WB1", ctx.type(f"D{n}"), str(n), priority=priority)
        assert poster.last_sent is not None
        names[poster.last_sent.id] = n
    await ack(hand.callback, plug, hand.name)
    got = [names.get(await hand.take(), -1) for _ in levels]
    want = sorted(range(len(levels)), key=lambda n: (2.0 if levels[n] is None else levels[n], n))
    ctx.check(got == want, f"deliveries in the order {got}", expected=f"{want} (OA-PRIO-1)")
