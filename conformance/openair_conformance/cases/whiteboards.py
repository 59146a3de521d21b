"""Whiteboard cases (spec section 7): posts and commands, the stored copy, wbid, what is
stored, when a post is decided, and maxcount eviction.
"""

from __future__ import annotations

import itertools
import struct

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    esc,
    message_xml,
    retrieved,
    send_big,
    setup_subscribe,
    trigger_ids,
    triggers_xml,
    view_of,
)
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case


@case(
    id="WB-002",
    title="The stored copy keeps every slot of the post and adds stored, receivedTime and wbid",
    section="7.4",
    requirements=("OA-WB-4", "OA-WAKE-2", "OA-TIME-4", "OA-WB-3"),
    allowed=(
        "type, id, from, to, cc, priority, language and content as posted; stored = WB1; a "
        "receivedTime and a wbid; netprotocol or comment may be added",
    ),
)
async def stored_copy(ctx: CaseContext) -> None:
    """Post with cc, priority 3.5 and language English; compare the wakeup's trigger message
    and the retrieved copy with what was sent.

    Catches: a server that drops cc or language, rounds the priority, or restamps postedTime.
    """
    sub = await ctx.module("Sub")
    await setup_subscribe(sub, triggers_xml(ctx.type("Copy")))
    poster = await ctx.module("Poster", bind=False)
    await poster.post(
        "WB1", ctx.type("Copy"), "copy me", cc=sub.name, priority=3.5, language="English"
    )
    sent = poster.last_sent
    assert sent is not None
    trigger = view_of(ctx, await sub.expect_wakeup_for(sent.id)).trigger
    found = await retrieved(ctx, poster, f'<retrieve from="WB1" id="{sent.id}"/>')
    ctx.check(len(found) == 1, f"{len(found)} stored copies", expected="one (OA-WB-3)")
    want = (sent.type, sent.id, sent.sender, "WB1", sent.cc, 3.5, "English", "copy me", "WB1")
    for where, msg in (("TriggerMessage", trigger), ("retrieved copy", found[0])):
        assert msg is not None
        got = (
            msg.type,
            msg.id,
            msg.sender,
            msg.to,
            msg.cc,
            msg.priority,
            msg.language,
            msg.content,
            msg.stored,
        )
        ctx.check(got == want, f"{where}: {got}", expected=f"{want} (OA-WB-4)")
        ctx.check(
            msg.received is not None
            and msg.wbid is not None
            and msg.posted is not None
            and sent.posted is not None
            and msg.posted.ms == sent.posted.ms,
            f"{where}: receivedTime {msg.received}, wbid {msg.wbid}, postedTime {msg.posted}",
            expected="receivedTime, wbid, the poster's postedTime (OA-WB-4, OA-TIME-4)",
        )


@case(
    id="WB-003",
    title="wbid increases with each stored message; retrieve order is wbid descending",
    section="7.4",
    requirements=("OA-WB-5", "OA-RET-6", "OA-WB-12"),
    allowed=("five wbids, each at least 1, strictly decreasing in retrieve order",),
)
async def wbid_sequence(ctx: CaseContext) -> None:
    """Post five messages to WB2 and retrieve them all.

    Catches: wbids reused or not increasing, retrieve results in another order.
    """
    client = await ctx.module("C", bind=False)
    ids = []
    for n in range(5):
        await client.post("WB2", ctx.type(f"Seq.{n}"), f"seq {n}")
        assert client.last_sent is not None
        ids.append(client.last_sent.id)
    spec = f'<retrieve from="WB2" type="{esc(ctx.type("Seq.*"))}"><latest>0</latest></retrieve>'
    found = await retrieved(ctx, client, spec, to="WB2")
    ctx.check(
        [m.id for m in found] == ids[::-1],
        "retrieve order is not newest first",
        expected="OA-RET-6",
    )
    wbids = [-1 if m.wbid is None else m.wbid for m in found]
    ok = all(w >= 1 for w in wbids) and all(a > b for a, b in itertools.pairwise(wbids))
    ctx.check(
        ok, f"wbids newest first: {wbids}", expected="strictly decreasing, all >= 1 (OA-WB-5)"
    )


@case(
    id="WB-004",
    title="A whiteboard holds at most maxcount messages; the oldest is evicted",
    section="7.4",
    requirements=("OA-WB-6", "OA-CONF-2", "OA-WB-3"),
    needs=("noreply",),
    serial=True,
    allowed=(
        "after 10 002 posts to WB2 (default maxcount 10 000), exactly the newest 10 000 of "
        "them are retrievable; the first two are not",
    ),
)
async def maxcount_eviction(ctx: CaseContext) -> None:
    """Post a marker, 10 000 small noreply posts and a last acknowledged post to WB2 (whose
    maxcount is the default 10 000 on an unconfigured server), then retrieve them.

    Catches: a whiteboard that grows without bound, evicts the newest, or still returns an
    evicted message. Serial: it flushes WB2. Needs `noreply` to stay fast; the suite has no
    way to learn a configured board's maxcount, so it assumes the default.
    """
    client = await ctx.module("C", bind=False)
    raw = await ctx.raw()
    await client.post("WB2", ctx.type("Fill"), "marker")
    assert client.last_sent is not None
    marker = client.last_sent.id
    data = bytearray()
    for n in range(10_000):
        xml = message_xml(ctx.type("Fill"), to="WB2", attrs='noreply="yes"', content=str(n))
        data += b"Message\x00" + struct.pack("<I", len(xml)) + xml
    await send_big(ctx, raw, bytes(data), what="10 000 noreply posts")  # one (cut) trace entry
    last = Message(type=ctx.type("Fill"), sender=client.name, to="WB2", content="last")
    # 10 000 posts are processed first, and the retrieve returns 10 000: longer deadlines.
    reply = await raw.request(last, timeout=ctx.deadline * 20)
    ctx.check(reply.type == "RECEIVE_ACCEPT", f"the last post got {reply.type}", expected="OA-WB-3")
    spec = f'<retrieve from="WB2" type="{esc(ctx.type("Fill"))}"><latest>0</latest></retrieve>'
    found = await retrieved(ctx, client, spec, to="WB2", timeout=ctx.deadline * 20)
    ctx.check(
        marker not in {m.id for m in found}, "the oldest post was not evicted", expected="OA-WB-6"
    )
    ctx.check(
        len(found) == 10_000,
        f"{len(found)} of 10 002 posts are retrievable",
        expected="10 000 (OA-WB-6, OA-CONF-2)",
    )
    first = await retrieved(ctx, client, f'<retrieve from="WB2" id="{marker}"/>', to="WB2")
    ctx.check(not first, "a retrieve by id still returns the evicted marker", expected="OA-WB-6")


@case(
    id="WB-005",
    title="Only posts are stored: no commands, no wakeup records, no replies",
    section="7.4",
    requirements=("OA-WB-11",),
    allowed=("the module's two posts and nothing else under its name on WB1 and AIRCentral",),
)
async def only_posts_stored(ctx: CaseContext) -> None:
    """Subscribe on WB1 and on AIRCentral, post twice, get woken, retrieve; then list what WB1
    and AIRCentral hold with the module as sender.

    Catches: stored AIR.Subscribe or AIR.Retrieve messages and wakeup records (Psyclone,
    DEV-18), which retrieves with `*` would return.
    """
    module = await ctx.module("M")
    await setup_subscribe(module, triggers_xml(ctx.type("Go")), to="WB1")
    await setup_subscribe(module, triggers_xml(ctx.type("Go")), to="AIRCentral")
    await module.post("WB1", ctx.type("Go"), "one", cc=module.name)
    await module.post("WB1", ctx.type("Other"), "two", cc=module.name)
    await module.barrier()
    for board in ("WB1", "AIRCentral"):
        criteria = f'from="{board}" type="*" sender="{module.name}"'
        spec = f"<retrieve {criteria}><latest>0</latest></retrieve>"
        copies = await retrieved(ctx, module, spec, to=board)
        sentinels = ctx.barrier_type(module.suffix)  # the barrier's own posts are posts too
        found = [m.type for m in copies if m.type != sentinels]
        want = [ctx.type("Other"), ctx.type("Go")] if board == "WB1" else []
        ctx.check(
            found == want,
            f"{board} holds {found} from {module.name}",
            expected=f"{want} (OA-WB-11)",
        )


@case(
    id="WB-006",
    title="RECEIVE_ACCEPT means stored and decided: later registrations never see the post",
    section="7.3",
    requirements=("OA-WB-3", "OA-WB-7", "OA-ERR-5", "OA-REG-7"),
    allowed=(
        "the post is retrievable at once; the registration current at receipt gets its wakeup "
        "even though it was replaced after the acknowledgement; a module registered after the "
        "post is not woken by it",
    ),
)
async def decided_at_receipt(ctx: CaseContext) -> None:
    """A registers T; post T; A replaces its registration with `<triggers/>`; B registers T;
    A must still get the wakeup, B must not.

    Catches: matching at dispatch against the registrations current then (Psyclone, DEV-10),
    and an acknowledgement sent before the message is stored.
    """
    first, late = await ctx.module("A"), await ctx.module("B")
    await setup_subscribe(first, triggers_xml(ctx.type("T")))
    await setup_subscribe(late, triggers_xml(ctx.type("Unrelated")))
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("T"), "decided now")
    sent = poster.last_sent
    assert sent is not None
    now = await retrieved(ctx, poster, f'<retrieve from="WB1" id="{sent.id}"/>')
    ctx.check(
        len(now) == 1, "the acknowledged post is not retrievable", expected="stored (OA-WB-3)"
    )
    await setup_subscribe(first, "<triggers/>")
    await setup_subscribe(late, triggers_xml(ctx.type("T")))
    await first.expect_wakeup_for(sent.id)
    woken = trigger_ids(await late.barrier())
    ctx.check(
        sent.id not in woken,
        "a registration made after the post was woken by it",
        expected="OA-WB-7",
    )


@case(
    id="WB-007",
    title="A message to a whiteboard whose type is a CNS command is an ordinary post",
    section="7.2",
    requirements=("OA-WB-2",),
    allowed=(
        "RECEIVE_ACCEPT for each; each is stored; PING to WB1 is still answered PING_SUCCESS",
    ),
    residue=True,  # its types (BIND, STATUS, …) cannot be under the case's prefix
)
async def command_types_are_posts(ctx: CaseContext) -> None:
    """Post types BIND, RESOLVE_REQUEST, GET_CAPABILITIES and STATUS to WB1; retrieve by id.

    Catches: a whiteboard that executes CNS commands or refuses them instead of storing them.
    """
    client = await ctx.module("C", bind=False)
    for type_ in ("BIND", "RESOLVE_REQUEST", "GET_CAPABILITIES", "STATUS"):
        reply = await client.post("WB1", type_, f"{ctx.name()} as a post", check=False)
        ctx.check(
            reply.type == "RECEIVE_ACCEPT",
            f"{type_} to WB1: {reply.type} {reply.content!r}",
            expected="OA-WB-2",
        )
        assert client.last_sent is not None
        found = await retrieved(ctx, client, f'<retrieve from="WB1" id="{client.last_sent.id}"/>')
        ctx.check(len(found) == 1, f"{type_} was not stored", expected="OA-WB-2")
    reply = await client.request(Message(type="PING", sender=client.name, to="WB1"))
    ctx.check(reply.type == "PING_SUCCESS", f"PING to WB1: {reply.type}", expected="OA-WB-2")


# -- 7.2 Posts and whiteboard commands: the acknowledgement ------------------------------------


@case(
    id="WB-001",
    title="A post to WB1 from an unbound connection is acknowledged RECEIVE_ACCEPT",
    section="7.2",
    requirements=("OA-WB-2", "OA-WB-3", "OA-SESS-16", "OA-SESS-1"),
    allowed=("RECEIVE_ACCEPT with isresponse = the post's id",),
)
async def post_acknowledged(ctx: CaseContext) -> None:
    """Post to WB1 on the main port without BIND; expect RECEIVE_ACCEPT for that post."""
    client = await ctx.module("Poster", bind=False)
    reply = await client.post("WB1", ctx.type("Hello"), "hello whiteboard", check=False)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"the post was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT (OA-WB-2, OA-WB-3, OA-SESS-16)",
    )
    assert client.last_sent is not None
    ctx.check(
        reply.isresponse == client.last_sent.id,
        f"RECEIVE_ACCEPT has isresponse {reply.isresponse!r}",
        expected="isresponse = the post's id (OA-SESS-1)",
    )
