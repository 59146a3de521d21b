"""Retrieve cases (spec section 9): every criterion, defaults, order, AIR.Retrieves, failures.

Most cases post the example whiteboard of 9.2 under the case's prefix (`_example`) and compare
retrieve results with the table; names are prefixed, so `Ret.A.*` becomes `<prefix>.Ret.A.*`.
"""

from __future__ import annotations

import asyncio
import struct
from dataclasses import replace

from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair_conformance.cases._common import (
    check_error,
    esc,
    message_xml,
    retrieved,
    send_big,
)
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    message_collection,
)
from openair_conformance.model import Inconclusive, NotApplicable
from openair_conformance.registry import case

#: The whiteboard of the examples of 9.2, oldest first: (type suffix, content).
_EXAMPLE = (
    ("Ret.A.1", "c1"),
    ("Ret.A.2", "c2"),
    ("Ret.B.1", "green tomato"),
    ("Ret.A.3", "c3"),
    ("Other.X", "x1"),
    ("Ret.A.5", "red tomato"),
    ("Ret.A.6", "c6"),
    ("Ret.a.7", "c7 lower"),
    ("Ret.A.8", "c8"),
)


async def _example(ctx: CaseContext) -> tuple[TestModule, list[Message]]:
    """Post the example messages to WB1 from one client; return it and the messages as sent."""
    client = await ctx.module("Poster", bind=False)
    sent = []
    for suffix, content in _EXAMPLE:
        await client.post("WB1", ctx.type(suffix), content)
        assert client.last_sent is not None
        sent.append(client.last_sent)
    return client, sent


def _spec(
    ctx: CaseContext, pattern: str | None, inner: str = "", attrs: str = "", board: str = "WB1"
) -> str:
    type_attr = f' type="{esc(ctx.type(pattern))}"' if pattern is not None else ""
    return f'<retrieve from="{board}"{type_attr} {attrs}>{inner}</retrieve>'


async def _expect(
    ctx: CaseContext,
    client: TestModule,
    spec: str,
    want: list[str],
    req: str,
    to: str = "AIRCentral",
) -> list[Message]:
    found = await retrieved(ctx, client, spec, to=to)
    prefix = ctx.type_prefix() + "."
    got = [m.type.removeprefix(prefix) for m in found if m.type.startswith(prefix)]
    ctx.check(got == want, f"{spec} returned {got}", expected=f"{want} ({req})")
    return list(found)


@case(
    id="RET-002",
    title="latest: default 1, 0 means all, as element or attribute; newest first",
    section="9.2",
    requirements=("OA-RET-4", "OA-RET-6", "OA-RET-3", "OA-MATCH-2"),
    allowed=("the results of the table of 9.2, newest first",),
)
async def latest(ctx: CaseContext) -> None:
    """Retrieve `Ret.A.*` with latest 3, default, `Ret.*` with latest 0 and latest="2", the
    exact `Ret.A` (no prefix match) and `*.1`, as in the table of 9.2.

    Catches: latest defaulting to all, 0 meaning none, the attribute form ignored.
    """
    client, _ = await _example(ctx)
    every = [s for s, _ in reversed(_EXAMPLE) if s.startswith("Ret.")]
    checks = [
        (_spec(ctx, "Ret.A.*", "<latest>3</latest>"), ["Ret.A.8", "Ret.a.7", "Ret.A.6"]),
        (_spec(ctx, "Ret.A.*"), ["Ret.A.8"]),
        (_spec(ctx, "Ret.*", "<latest>0</latest>"), every),
        (_spec(ctx, "Ret.*", attrs='latest="2"'), ["Ret.A.8", "Ret.a.7"]),
        (_spec(ctx, "Ret.A", "<latest>3</latest>"), []),
        (_spec(ctx, "*.1", "<latest>5</latest>"), ["Ret.B.1", "Ret.A.1"]),
    ]
    for spec, want in checks:
        await _expect(ctx, client, spec, want, "OA-RET-4, OA-RET-6")


@case(
    id="RET-003",
    title="sender and id select exactly; content is a case-sensitive glob with a literal ?",
    section="9.2",
    requirements=("OA-RET-3", "OA-RET-8"),
    allowed=("the results of the table of 9.2",),
)
async def sender_id_content(ctx: CaseContext) -> None:
    """Retrieve by sender (and its lower-cased form), by id, and with the content globs
    `*tomato*`, `green*`, `tomato` (a part of the text only), `Green*`, `c?` and `c*`.

    Catches: substring or case-insensitive sender matching, content matched as a regex or a
    substring (`tomato` must not match "green tomato"), `?` treated as a wildcard.
    """
    client, sent = await _example(ctx)
    checks = [
        (
            _spec(ctx, "Ret.*", "<latest>2</latest>", f'sender="{client.name}"'),
            ["Ret.A.8", "Ret.a.7"],
        ),
        (_spec(ctx, "Ret.*", "", f'sender="{client.name.lower()}"'), []),
        (_spec(ctx, None, "", f'id="{sent[2].id}"'), ["Ret.B.1"]),
        (_spec(ctx, "Ret.*", "<latest>10</latest>", 'content="*tomato*"'), ["Ret.A.5", "Ret.B.1"]),
        (_spec(ctx, "Ret.*", "<latest>10</latest>", 'content="green*"'), ["Ret.B.1"]),
        # OA-RET-8: the glob matches the whole text, never a part of it
        (_spec(ctx, "Ret.*", "<latest>10</latest>", 'content="tomato"'), []),
        (_spec(ctx, "Ret.*", "<latest>10</latest>", 'content="Green*"'), []),
        (_spec(ctx, "Ret.*", "<latest>10</latest>", 'content="c?"'), []),
        (_spec(ctx, "Ret.A.*", "<latest>2</latest>", 'content="c*"'), ["Ret.A.8", "Ret.a.7"]),
    ]
    for spec, want in checks:
        await _expect(ctx, client, spec, want, "OA-RET-3, OA-RET-8")


@case(
    id="RET-004",
    title="contentmatch='xml' matches the content's XML text; otherwise its text",
    section="9.2",
    requirements=("OA-RET-13", "OA-RET-8"),
    allowed=('*hello* matches as text; *x="1"* only with contentmatch XML',),
)
async def contentmatch(ctx: CaseContext) -> None:
    """Post XML content `<a x="1">hello</a>`; retrieve with content globs in both modes.

    Catches: contentmatch ignored, tags matched in text mode, `XML` compared case-sensitively.
    """
    client = await ctx.module("C", bind=False)
    await client.post("WB1", ctx.type("Xml"), '<a x="1">hello</a>', xml=True)
    checks = [
        ('content="*hello*"', ["Xml"]),
        ('content="*x=&quot;1&quot;*"', []),
        ('content="*x=&quot;1&quot;*" contentmatch="XML"', ["Xml"]),
        ('content="*hello*" contentmatch="text"', ["Xml"]),
    ]
    for attrs, want in checks:
        await _expect(ctx, client, _spec(ctx, "Xml", "", attrs), want, "OA-RET-13")


@case(
    id="RET-005",
    title="lastmsec selects by receivedTime, not postedTime; 0 sets no window",
    section="9.2",
    requirements=("OA-RET-5",),
    # Serial: a window counted from the newest message is told from one counted from now only
    # when no other case posts to WB1 meanwhile (its posts would be the newest).
    serial=True,
    allowed=(
        "a post with an old postedTime is within a 10-minute window",
        "a window that ends, counted back from the whiteboard's now, after the newest message "
        "selects none of them",
    ),
)
async def lastmsec(ctx: CaseContext) -> None:
    """Post with a postedTime ten hours old; retrieve with lastmsec 600000 and 0. Then let the
    server's clock pass the newest message (ticks on WB2) and retrieve with a window shorter
    than that: nothing may be selected.

    Catches: lastmsec applied to postedTime, 0 taken as an empty window, lastmsec ignored, or
    counted back from the newest message instead of from now (issue #15).
    """
    client, sent = await _example(ctx)
    old = Message(type=ctx.type("Old"), sender=client.name, to="WB1", content="old")
    stamped = sent[0].posted
    assert stamped is not None
    reply = await client.request(replace(old, posted=AirTime(sec=stamped.sec - 36000, msec=0)))
    ctx.check(reply.type == "RECEIVE_ACCEPT", f"post: {reply.type}", expected="RECEIVE_ACCEPT")
    await _expect(
        ctx, client, _spec(ctx, "Old", "<lastmsec>600000</lastmsec>"), ["Old"], "OA-RET-5"
    )
    await _expect(ctx, client, _spec(ctx, "Old", "<lastmsec>0</lastmsec>"), ["Old"], "OA-RET-5")
    copies = await retrieved(ctx, client, _spec(ctx, "*", "<latest>0</latest>"))
    times = [m.received.ms for m in copies if m.received is not None]
    if not times:
        ctx.fail("the stored copies carry no receivedTime", expected="receivedTime (OA-WB-4)")
    newest = max(times)
    now = await _server_time_after(ctx, client, newest + 3)
    # From the whiteboard's now the window ends after every example message; from the newest
    # message (a common mistake) it would still hold it.
    spec = _spec(ctx, "*", f"<latest>0</latest><lastmsec>{now - newest - 1}</lastmsec>")
    await _expect(ctx, client, spec, [], "OA-RET-5: the window ends before now, not the newest")


async def _server_time_after(ctx: CaseContext, client: TestModule, ms: int) -> int:
    """Return a receivedTime (ms) of WB2 at or after `ms`, posting ticks there until one is.

    Round trips, not a sleep: each tick is a post and a retrieve (OA-RET-5 needs the server's
    clock to have moved past the example; Inconclusive if it does not within the deadline).
    """
    loop = asyncio.get_running_loop()
    until = loop.time() + ctx.deadline
    while loop.time() < until:
        await client.post("WB2", ctx.type("Tick"), "tick")
        assert client.last_sent is not None
        tick = f'<retrieve from="WB2" id="{client.last_sent.id}"/>'
        found = await retrieved(ctx, client, tick, to="WB2")
        if found and found[0].received is not None and found[0].received.ms >= ms:
            return found[0].received.ms
    raise Inconclusive(f"the server's receivedTime did not reach {ms} ms within the deadline")


@case(
    id="RET-006",
    title="afterTime and untilTime are inclusive bounds on receivedTime, in all three forms",
    section="9.2",
    requirements=("OA-RET-9", "OA-WB-4"),
    allowed=("exactly the messages whose receivedTime lies within the bounds, bounds included",),
)
async def time_bounds(ctx: CaseContext) -> None:
    """Read the example's receivedTimes; retrieve between the 3rd and the 6th message's times
    with a time-element child, a milliseconds child and milliseconds attributes.

    Catches: exclusive bounds, bounds applied to postedTime, a form not understood, bounds
    ignored (a post made after the upper bound, once the server's clock passed it, must be left
    out even when the example's receivedTimes are all equal).
    """
    client, sent = await _example(ctx)
    copies = {m.id: m for m in await retrieved(ctx, client, _spec(ctx, "*", "<latest>0</latest>"))}
    received = [copies[m.id].received for m in sent if m.id in copies]
    if len(received) != len(sent) or any(t is None for t in received):
        ctx.fail("stored copies without receivedTime", expected="OA-WB-4")
    low, high = received[2], received[5]
    assert low is not None and high is not None
    # OA-GEN-7: with every receivedTime equal no bound would exclude anything; a post made once
    # the server's clock has passed the upper bound must be left out, whatever the example did.
    await _server_time_after(ctx, client, high.ms + 1)
    await client.post("WB1", ctx.type("Late"), "after the upper bound")
    want = [
        s
        for (s, _), t in reversed(list(zip(_EXAMPLE, received, strict=True)))
        if t is not None and low.ms <= t.ms <= high.ms
    ]
    forms = (
        f'<afterTime><time sec="{low.sec}" msec="{low.msec}"/></afterTime>'
        f'<untilTime><time sec="{high.sec}" msec="{high.msec}"/></untilTime>',
        f"<afterTime>{low.ms}</afterTime><untilTime>{high.ms}</untilTime>",
    )
    for inner in forms:
        await _expect(ctx, client, _spec(ctx, "*", f"<latest>0</latest>{inner}"), want, "OA-RET-9")
    attrs = f'afterTime="{low.ms}" untilTime="{high.ms}" latest="0"'
    await _expect(ctx, client, _spec(ctx, "*", "", attrs), want, "OA-RET-9")


@case(
    id="RET-007",
    title="AIR.Retrieves concatenates its retrieves in order; one failure fails the whole",
    section="9.3",
    requirements=("OA-RET-12", "OA-RET-1", "OA-RET-7"),
    allowed=(
        "AIR.Retrieves.Success with WB1's results then WB2's; AIR.Retrieves.Failed if one fails",
    ),
)
async def retrieves(ctx: CaseContext) -> None:
    """Post to WB1 and WB2; send `<retrieves>` with one retrieve per whiteboard, then with a
    third naming an unknown whiteboard.

    Catches: results merged or reordered, a partial success when one retrieve fails.
    """
    client = await ctx.module("C", bind=False)
    for board, suffix in (("WB1", "B1.1"), ("WB1", "B1.2"), ("WB2", "B2.1")):
        await client.post(board, ctx.type(suffix), suffix)
    both = _spec(ctx, "B1.*", "<latest>0</latest>") + _spec(ctx, "B2.*", board="WB2")
    found = await retrieved(
        ctx, client, f"<retrieves>{both}</retrieves>", plural=True, req="OA-RET-12"
    )
    got = [m.type.removeprefix(ctx.type_prefix() + ".") for m in found]
    ctx.check(
        got == ["B1.2", "B1.1", "B2.1"], f"AIR.Retrieves returned {got}", expected="OA-RET-12"
    )
    bad = both + _spec(ctx, "*", board=ctx.name("NoSuchWB"))
    reply = await client.retrieve(f"<retrieves>{bad}</retrieves>", plural=True)
    ctx.check(
        reply.type == "AIR.Retrieves.Failed",
        f"with a failing retrieve: {reply.type}",
        expected="OA-RET-12",
    )


@case(
    id="RET-008",
    title="A retrieve from an unknown whiteboard fails WHITEBOARD_UNKNOWN, names case-sensitive",
    section="9.4",
    requirements=("OA-RET-11", "OA-WB-10", "OA-ERR-6"),
    allowed=("AIR.Retrieve.Failed with content 'WHITEBOARD_UNKNOWN: <name>'",),
)
async def unknown_whiteboard(ctx: CaseContext) -> None:
    """Retrieve from a name unique to the run and from `wb1`.

    Catches: an empty success for an unknown whiteboard (Psyclone, DEV-13) and case-insensitive
    whiteboard names.
    """
    client = await ctx.module("C", bind=False)
    for board in (ctx.name("NoSuchWB"), "wb1"):
        reply = await client.retrieve(_spec(ctx, "*", board=board))
        ctx.check(
            reply.type == "AIR.Retrieve.Failed"
            and reply.content.strip() == f"WHITEBOARD_UNKNOWN: {board}",
            f"from {board!r}: {reply.type} {reply.content!r}",
            expected=f"AIR.Retrieve.Failed 'WHITEBOARD_UNKNOWN: {board}' (OA-RET-11)",
        )


@case(
    id="RET-009",
    title="Empty, unparsable or invalid retrieve specifications fail RETRIEVE_INVALID",
    section="9.4",
    requirements=("OA-RET-10", "OA-RET-16", "OA-RET-4", "OA-ERR-6"),
    allowed=("AIR.Retrieve.Failed (AIR.Retrieves.Failed) with content 'RETRIEVE_INVALID: …'",),
)
async def invalid_specs(ctx: CaseContext) -> None:
    """Send empty content, text `garbage`, `<foo/>`, `latest="x"`, `<latest>-1</latest>`, a
    context criterion (`before`), AIR.Retrieves holding a bare `<retrieve>`, a `latest`
    given as element and attribute with different values, and two `<retrieve>` (two
    `<retrieves>`) elements where one is required.

    Catches: everything returned for garbage (Psyclone, DEV-14), failures without a reason
    (DEV-15), context criteria silently ignored.
    """
    client = await ctx.module("C", bind=False)
    cases = [
        ("", False, False),
        ("garbage", False, False),
        ("<foo/>", True, False),
        (_spec(ctx, "*", attrs='latest="x"'), True, False),
        (_spec(ctx, "*", "<latest>-1</latest>"), True, False),
        (_spec(ctx, "*", attrs='before="Psyclone.System.Ready"'), True, False),
        (_spec(ctx, "*"), True, True),
        (_spec(ctx, "*", "<latest>1</latest>", 'latest="2"'), True, False),
        # Two roots are not "a <retrieve>" / "a <retrieves>" element (issue #15: the mutants
        # that take the first of several, or accept any count but 0, survived).
        (_spec(ctx, "*") * 2, True, False),
        (f"<retrieves>{_spec(ctx, '*')}</retrieves>" * 2, True, True),
    ]
    for content, xml, plural in cases:
        kind = "AIR.Retrieves" if plural else "AIR.Retrieve"
        msg = Message(
            type=kind,
            sender=client.name,
            to="AIRCentral",
            content=content,
            content_is_xml=xml,
            language="xml" if xml else "",
        )
        reply = await client.request(msg)
        check_error(
            ctx,
            reply,
            types=(f"{kind}.Failed",),
            names=("RETRIEVE_INVALID",),
            what=f"{kind} {content!r}",
            req="OA-RET-10",
        )


@case(
    id="RET-010",
    title="Without from, a retrieve reads the addressed whiteboard; unknown parts are ignored",
    section="9.2",
    requirements=("OA-RET-2", "OA-RET-16", "OA-RET-1"),
    allowed=("sent to WB1: WB1's message; sent to AIRCentral: nothing of WB1's",),
)
async def default_from(ctx: CaseContext) -> None:
    """Post to WB1; retrieve without from via WB1 and via AIRCentral, with an unknown attribute
    and child element.

    Catches: a default whiteboard other than the addressee, unknown parts refused.
    """
    client = await ctx.module("C", bind=False)
    await client.post("WB1", ctx.type("Here"), "here")
    spec = f'<retrieve type="{esc(ctx.type("Here"))}" confunknown="1"><confchild/></retrieve>'
    await _expect(ctx, client, spec, ["Here"], "OA-RET-2, OA-RET-16", to="WB1")
    await _expect(ctx, client, spec, [], "OA-RET-2", to="AIRCentral")


@case(
    id="RET-011",
    title="A retrieve sent as escaped text content is parsed like XML content",
    section="9.1",
    requirements=("OA-RET-14",),
    allowed=("AIR.Retrieve.Success with the message",),
)
async def text_spec(ctx: CaseContext) -> None:
    """Post; send AIR.Retrieve whose text content (language English) is the `<retrieve>` XML.

    Catches: a server that only reads language="xml" (legacy clients send text).
    """
    client = await ctx.module("C", bind=False)
    await client.post("WB1", ctx.type("Text"), "t")
    msg = Message(
        type="AIR.Retrieve",
        sender=client.name,
        to="AIRCentral",
        content=_spec(ctx, "Text"),
        language="English",
    )
    reply = await client.request(msg)
    ctx.check(
        reply.type == "AIR.Retrieve.Success",
        f"{reply.type} {reply.content[:100]!r}",
        expected="OA-RET-14",
    )


@case(
    id="RET-012",
    title="A retrieve whose reply would exceed max-frame-xml fails LIMIT_EXCEEDED",
    section="9.3",
    requirements=("OA-RET-15", "OA-WB-3"),
    allowed=("AIR.Retrieve.Failed with content 'LIMIT_EXCEEDED: …'",),
)
async def reply_too_large(ctx: CaseContext) -> None:
    """Post three messages of 40 % of max-frame-xml each to WB2 and retrieve all three.

    Catches: a reply frame the requester must refuse (or a server that builds it anyway).
    """
    limit = ctx.server.limit("max-frame-xml", 16 * 1024 * 1024)
    if limit > 32 * 1024 * 1024:
        raise NotApplicable(f"max-frame-xml is {limit}; too large to fill")
    client = await ctx.module("C", bind=False)
    raw = await ctx.raw()
    for n in range(3):
        xml = message_xml(ctx.type(f"Big.{n}"), to="WB2", content="x" * (limit * 2 // 5))
        await send_big(
            ctx, raw, b"Message\x00" + struct.pack("<I", len(xml)) + xml, what="a big post"
        )
        reply = await raw.read_message(timeout=ctx.deadline * 4)
        ctx.check(
            reply.type == "RECEIVE_ACCEPT", f"a big post got {reply.type}", expected="OA-WB-3"
        )
    reply = await client.retrieve(_spec(ctx, "Big.*", "<latest>0</latest>", board="WB2"))
    check_error(
        ctx,
        reply,
        types=("AIR.Retrieve.Failed",),
        names=("LIMIT_EXCEEDED",),
        what="a retrieve of 120 % of the limit",
        req="OA-RET-15",
    )


@case(
    id="RET-013",
    title="A retrieve reply counts its envelope against max-frame-xml, not only the contents",
    section="9.3",
    requirements=("OA-RET-15", "OA-WB-3"),
    allowed=(
        "AIR.Retrieve.Failed with content 'LIMIT_EXCEEDED: …'",
        "AIR.Retrieve.Success in a frame whose XML is at most max-frame-xml",
    ),
)
async def reply_envelope_too_large(ctx: CaseContext) -> None:
    """Post two messages to WB2 whose contents together are max-frame-xml less 256 bytes;
    retrieve both on a raw connection and measure the reply frame.

    The contents alone fit, but the two stored copies' envelopes (type, id, names, times,
    wbid) and the reply's own take the XML past the limit. A success must return both copies:
    with one (the other evicted by max-history-bytes, OA-LIM-10) nothing was tested, and the
    case is inconclusive. Catches: a server that checks only the contents (or allows itself a
    margin beyond the limit) and sends a frame its peers must refuse (issue #15: `content -
    allowance > max` survived).
    """
    limit = ctx.server.limit("max-frame-xml", 16 * 1024 * 1024)
    if limit > 32 * 1024 * 1024:
        raise NotApplicable(f"max-frame-xml is {limit}; too large to fill")
    each = (limit - 256) // 2
    history = ctx.server.limit("max-history-bytes", 256 * 1024 * 1024)
    needed = 2 * each + 4096  # the two contents and their envelopes
    if history and history < needed:
        raise NotApplicable(
            f"max-history-bytes ({history}) is below the {needed} bytes the two posts take: "
            "the first would be evicted (OA-LIM-10)"
        )
    raw = await ctx.raw()
    for n in range(2):
        xml = message_xml(ctx.type(f"Near.{n}"), to="WB2", content="x" * each)
        await send_big(
            ctx, raw, b"Message\x00" + struct.pack("<I", len(xml)) + xml, what="a big post"
        )
        reply = await raw.read_message(timeout=ctx.deadline * 4)
        if reply.type != "RECEIVE_ACCEPT":
            raise Inconclusive(f"setup: a post of {each} bytes got {reply.type} (OA-WB-3)")
    request = Message(
        type="AIR.Retrieve",
        sender=ctx.name("C"),
        to="AIRCentral",
        content=_spec(ctx, "Near.*", "<latest>0</latest>", board="WB2"),
        content_is_xml=True,
        language="xml",
    )
    sent = await raw.send_message(request)
    frame = await raw.read_frame(timeout=ctx.deadline * 4)
    ctx.check(
        len(frame.xml) <= limit,
        f"the retrieve reply's XML is {len(frame.xml)} bytes",
        expected=f"at most max-frame-xml ({limit} bytes): else LIMIT_EXCEEDED (OA-RET-15)",
    )
    reply = raw.stream.decode(frame)
    ctx.check(
        reply.isresponse == sent.id,
        f"the next message was {reply.type} (isresponse {reply.isresponse!r})",
        expected="the retrieve's reply",
    )
    if reply.type == "AIR.Retrieve.Success":
        try:
            copies = len(message_collection(reply))
        except WakeupUnreadable as exc:
            ctx.fail(f"retrieve result: {exc}", expected="an <objectcollection> (OA-RET-7)")
        if copies != 2:
            raise Inconclusive(f"setup: {copies} of the 2 posts were retrievable")
        return  # within the limit (checked above): a server may count exactly
    check_error(
        ctx,
        reply,
        types=("AIR.Retrieve.Failed",),
        names=("LIMIT_EXCEEDED",),
        what="a retrieve of two contents 256 bytes short of the limit",
        req="OA-RET-15",
    )


# -- 9.3 Results: newest first -----------------------------------------------------------------


@case(
    id="RET-001",
    title="AIR.Retrieve with latest=0 returns the matching stored copies, newest first",
    section="9.3",
    requirements=("OA-RET-1", "OA-RET-4", "OA-RET-6", "OA-RET-7"),
    allowed=("AIR.Retrieve.Success with exactly the two messages, the later post first",),
)
async def retrieve_newest_first(ctx: CaseContext) -> None:
    """Post Data.1 then Data.2 to WB1; retrieve `<prefix>.Data.*` from WB1 via AIRCentral."""
    client = await ctx.module("R", bind=False)
    for n in (1, 2):
        await client.post("WB1", ctx.type(f"Data.{n}"), f"data {n}")
    spec = f'<retrieve from="WB1" type="{ctx.type("Data.*")}"><latest>0</latest></retrieve>'
    reply = await client.retrieve(spec)
    ctx.check(
        reply.type == "AIR.Retrieve.Success",
        f"the retrieve was answered {reply.type} {reply.content!r}",
        expected="AIR.Retrieve.Success (OA-RET-1, OA-RET-7)",
    )
    try:
        found = message_collection(reply)
    except WakeupUnreadable as exc:
        ctx.fail(f"retrieve result: {exc}", expected="an <objectcollection> (OA-RET-7)")
    types = [m.type for m in found]
    want = [ctx.type("Data.2"), ctx.type("Data.1")]
    ctx.check(
        types == want,
        f"the retrieve returned {types}",
        expected=f"{want}: all (latest=0, OA-RET-4), newest first (OA-RET-6)",
    )
    ctx.check(
        all(m.stored == "WB1" and m.wbid is not None for m in found),
        "a result is not a stored copy (stored/wbid missing)",
        expected="stored copies (OA-RET-7)",
    )
