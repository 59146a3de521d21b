"""Envelope and time cases (spec sections 3 and 4): spellings, slot order, unknown slots,
priorities, times, content, noreply, and the canonical form of what the server writes.

Most cases post a hand-written message (`message_xml`) and read the stored copy back with a
retrieve by id; the stored copy is what the server made of the message (OA-WB-4).
"""

from __future__ import annotations

import re

from lxml import etree

from openair.protocol.message import CANONICAL_SLOTS, Message
from openair_conformance.cases._common import (
    check_error,
    esc,
    message_collection_raw,
    message_xml,
    parse_xml,
    ping_ok,
    retrieved,
    send_only,
    send_xml,
    setup_subscribe,
    trigger_ids,
    triggers_xml,
    view_of,
)
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.registry import case

_ALWAYS = ("type", "id", "from", "to", "cc", "stored", "isresponse", "postedTime", "content")
_WBID = re.compile(r"^[0-9]{8,}$")


async def _stored(ctx: CaseContext, client: TestModule, message_id: str) -> Message:
    """Return the one stored copy on WB1 with this id (Fail if there is not exactly one)."""
    found = await retrieved(ctx, client, f'<retrieve from="WB1" id="{esc(message_id)}"/>')
    ctx.check(
        len(found) == 1,
        f"{len(found)} stored copies with id {message_id}",
        expected="one (OA-WB-3)",
    )
    return found[0]


async def _post_xml(ctx: CaseContext, xml: bytes, *, what: str) -> None:
    """Post hand-written XML on a raw connection; Fail unless RECEIVE_ACCEPT."""
    reply = await send_xml(await ctx.raw(), xml)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"{what} was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT",
    )


@case(
    id="MSG-001",
    title="Slot names in any case and order, legacy spellings and ms are read as the slots",
    section="3.1",
    requirements=("OA-MSG-3", "OA-MSG-16", "OA-TIME-1", "OA-TIME-4", "OA-MSG-6"),
    allowed=(
        "the stored copy has the type, from, content, priority 3 and postedTime 1000000000.250",
    ),
)
async def spellings(ctx: CaseContext) -> None:
    """Post `<message Priority="3">` with CONTENT first, `postedtime` with `ms` and `tzc`,
    `isResponse`, `TO`, `From`, `ID`, `Type` last; read the stored copy.

    Catches: case-sensitive slot names, a reader that expects the canonical order, `ms` or
    `tzc` not understood, a priority written `3` not read as a number.
    """
    ident = ctx.name("Id")
    xml = (
        f'<message Priority="3"><CONTENT language="">legacy</CONTENT>'
        '<postedtime sec="1000000000" ms="250" tzc="Greenwich_0_60"/><isResponse></isResponse>'
        f"<TO>WB1</TO><From>{ctx.name('F')}</From><ID>{ident}</ID>"
        f"<Type>{ctx.type('Legacy')}</Type></message>"
    ).encode()
    await _post_xml(ctx, xml, what="a post with legacy spellings")
    copy = await _stored(ctx, await ctx.module("C", bind=False), ident)
    got = (copy.type, copy.sender, copy.content, copy.effective_priority)
    want = (ctx.type("Legacy"), ctx.name("F"), "legacy", 3.0)
    ctx.check(got == want, f"the stored copy has {got}", expected=f"{want} (OA-MSG-3, OA-MSG-16)")
    posted = (copy.posted.sec, copy.posted.msec) if copy.posted else None
    ctx.check(
        posted == (1000000000, 250),
        f"postedTime {posted}",
        expected="(1000000000, 250) (OA-TIME-1)",
    )


@case(
    id="MSG-002",
    title="Unknown slots are kept, with their values and order, on stored copies and in wakeups",
    section="3.1",
    requirements=("OA-MSG-5", "OA-WB-4", "OA-WAKE-2"),
    allowed=("the unknown slots zeta, Alpha (XML) and omega, in that order, with their values",),
)
async def unknown_slots(ctx: CaseContext) -> None:
    """Post a message with three unknown slots (text, XML, empty); read the wakeup's trigger
    message and the retrieved stored copy.

    Catches: a server that drops what it does not know, reorders it, or flattens XML slots.
    """
    sub = await ctx.module("Sub")
    await setup_subscribe(sub, triggers_xml(ctx.type("Slots")))
    ident = ctx.name("Id")
    body = '<zeta>first</zeta><Alpha><x a="1">t</x></Alpha><omega></omega>'
    xml = message_xml(ctx.type("Slots"), to="WB1", sender=ctx.name("F"), id=ident, content="c")
    xml = xml.replace(b"</message>", body.encode() + b"</message>")
    await _post_xml(ctx, xml, what="a post with unknown slots")
    trigger = view_of(ctx, await sub.expect_wakeup_for(ident)).trigger
    copy = await _stored(ctx, sub, ident)
    for where, msg in (("wakeup", trigger), ("stored copy", copy)):
        assert msg is not None
        names = [s.name.lower() for s in msg.extras if s.name.lower() in ("zeta", "alpha", "omega")]
        ctx.check(
            names == ["zeta", "alpha", "omega"], f"{where} slots {names}", expected="OA-MSG-5"
        )
        zeta, alpha = msg.extra("zeta"), msg.extra("alpha")
        ok = zeta is not None and zeta.value == "first" and alpha is not None
        ok = ok and alpha is not None and alpha.is_xml and 'a="1"' in alpha.value
        ctx.check(ok, f"{where}: zeta={zeta!r} Alpha={alpha!r}", expected="values kept (OA-MSG-5)")


@case(
    id="MSG-003",
    title="A message with a known slot twice is refused MESSAGE_INVALID",
    section="3.1",
    requirements=("OA-MSG-16", "OA-ERR-2", "OA-ERR-3"),
    allowed=("RECEIVE_ERROR 'MESSAGE_INVALID: …' for each; the connection stays usable",),
)
async def duplicate_slot(ctx: CaseContext) -> None:
    """Post with two `<type>`, then two `<to>`, then two `<postedTime>`.

    Catches: a reader that silently takes the first or last of two values (a message could
    then be routed one way and stored another).
    """
    raw = await ctx.raw()
    dup_type = f"<type>{esc(ctx.type('Other'))}</type>"
    for name, extra in (
        ("type", dup_type),
        ("to", "<to>WB2</to>"),
        ("postedTime", '<postedTime sec="1" msec="0"/><postedTime sec="2" msec="0"/>'),
    ):
        xml = message_xml(ctx.type("Dup"), to="WB1", sender=ctx.name("F"), body=extra)
        reply = await send_xml(raw, xml)
        check_error(
            ctx, reply, names=("MESSAGE_INVALID",), what=f"two {name} slots", req="OA-MSG-16"
        )
    await ping_ok(ctx, raw, what="after the refusals", req="OA-ERR-3")


@case(
    id="MSG-004",
    title="A message without a type, or with an empty one, is refused MESSAGE_INVALID",
    section="3.1",
    requirements=("OA-MSG-2", "OA-ERR-2"),
    allowed=("RECEIVE_ERROR 'MESSAGE_INVALID: …'",),
    residue=True,  # Psyclone stores the untyped message (DEV-17); its empty type matches all
)
async def missing_type(ctx: CaseContext) -> None:
    """Post to WB1 with no `<type>` element, then with `<type></type>`.

    Catches: a whiteboard that stores a message without a type (Psyclone, DEV-17).
    """
    raw = await ctx.raw()
    sender = ctx.name("F")
    for xml in (
        f"<message><id>{ctx.name('A')}</id><from>{sender}</from><to>WB1</to></message>",
        f"<message><type></type><from>{sender}</from><to>WB1</to></message>",
    ):
        reply = await send_xml(raw, xml.encode())
        check_error(ctx, reply, names=("MESSAGE_INVALID",), what=xml, req="OA-MSG-2")


@case(
    id="MSG-005",
    title="Priorities 0–6.999 in any decimal form are accepted; others are MESSAGE_INVALID",
    section="3.2",
    requirements=("OA-MSG-6", "OA-PRIO-3"),
    allowed=(
        "RECEIVE_ACCEPT for 0, 2, 2.00 and 6.999, with that priority on the stored copy",
        "RECEIVE_ERROR 'MESSAGE_INVALID: …' for 7, -0.5, 6.9991 and high",
        "an absent priority stays absent or is written 2.0",
    ),
)
async def priorities(ctx: CaseContext) -> None:
    """Post with each priority value and read back the stored copies of the accepted ones.

    Catches: out-of-range priorities accepted (they would jump every queue), `2.00` refused,
    a missing priority stored as something other than 2.0.
    """
    raw = await ctx.raw()
    client = await ctx.module("C", bind=False)
    values = (("0", 0.0), ("2", 2.0), ("2.00", 2.0), ("6.999", 6.999), (None, 2.0))
    for index, (value, want) in enumerate(values):
        ident = ctx.name(f"P{index}")
        attrs = f'priority="{value}"' if value is not None else ""
        reply = await send_xml(raw, message_xml(ctx.type("Prio"), to="WB1", id=ident, attrs=attrs))
        ctx.check(
            reply.type == "RECEIVE_ACCEPT", f"priority {value!r}: {reply.type}", expected="OA-MSG-6"
        )
        copy = await _stored(ctx, client, ident)
        ctx.check(
            copy.effective_priority == want,
            f"priority {value!r} stored as {copy.priority}",
            expected=f"{want} (OA-MSG-6, OA-PRIO-3)",
        )
    for value in ("7", "-0.5", "6.9991", "high"):
        xml = message_xml(ctx.type("Prio"), to="WB1", attrs=f'priority="{value}"')
        reply = await send_xml(raw, xml)
        check_error(
            ctx, reply, names=("MESSAGE_INVALID",), what=f"priority {value!r}", req="OA-MSG-6"
        )


@case(
    id="MSG-006",
    title="A postedTime with a bad sec or msec is refused MESSAGE_INVALID",
    section="4",
    requirements=("OA-TIME-6", "OA-TIME-1"),
    allowed=("RECEIVE_ERROR 'MESSAGE_INVALID: …' for each bad time",),
)
async def bad_times(ctx: CaseContext) -> None:
    """Post with `sec="abc"`, no `sec`, `msec="1000"`, `msec="-1"` and a 20-digit `sec`.

    Catches: times parsed leniently (a non-numeric sec read as 0) or overflowing.
    """
    raw = await ctx.raw()
    for attrs in (
        'sec="abc" msec="1"',
        'msec="5"',
        'sec="1" msec="1000"',
        'sec="1" msec="-1"',
        'sec="99999999999999999999" msec="0"',
    ):
        body = f"<postedTime {attrs}/>"
        reply = await send_xml(raw, message_xml(ctx.type("Time"), to="WB1", body=body))
        check_error(
            ctx, reply, names=("MESSAGE_INVALID",), what=f"postedTime {attrs}", req="OA-TIME-6"
        )


@case(
    id="MSG-007",
    title="The whiteboard stamps receivedTime, wbid and stored itself and keeps postedTime",
    section="4",
    requirements=("OA-TIME-3", "OA-TIME-4", "OA-WB-4", "OA-WB-5", "OA-WB-12"),
    allowed=(
        "stored = WB1, a receivedTime and a wbid of the whiteboard's own (the poster's forged "
        "values are replaced), postedTime unchanged; a later post has a larger wbid and a "
        "receivedTime not earlier",
    ),
)
async def server_stamps(ctx: CaseContext) -> None:
    """Post a message that carries forged `receivedTime`, `stored` and `wbid`, then a plain one.

    Catches: a server that trusts the poster's receivedTime or wbid, restamps postedTime, or
    numbers messages out of arrival order.
    """
    first = ctx.name("First")
    body = (
        '<stored>Forged</stored><postedTime sec="1000000000" msec="123"/>'
        '<receivedTime sec="1" msec="1"/><wbid>99999999</wbid>'
    )
    await _post_xml(
        ctx, message_xml(ctx.type("Stamp"), to="WB1", id=first, body=body), what="a post"
    )
    client = await ctx.module("C", bind=False)
    await client.post("WB1", ctx.type("Stamp"), "second")
    assert client.last_sent is not None
    second = client.last_sent.id
    one, two = await _stored(ctx, client, first), await _stored(ctx, client, second)
    ctx.check(one.stored == "WB1", f"stored = {one.stored!r}", expected="WB1 (OA-WB-4)")
    posted = (one.posted.sec, one.posted.msec) if one.posted else None
    ctx.check(posted == (1000000000, 123), f"postedTime became {posted}", expected="OA-TIME-4")
    received = (one.received.sec, one.received.msec) if one.received else None
    ctx.check(
        received not in (None, (1, 1)),
        f"receivedTime {received}",
        expected="the whiteboard's own (OA-TIME-3)",
    )
    ctx.check(
        one.wbid is not None
        and two.wbid is not None
        and one.wbid != 99999999
        and two.wbid > one.wbid,
        f"wbids {one.wbid} then {two.wbid}",
        expected="the whiteboard's increasing sequence (OA-WB-5)",
    )
    ctx.check(
        one.received is not None and two.received is not None and two.received >= one.received,
        f"receivedTime {one.received} then {two.received}",
        expected="receivedTime order agrees with wbid order (OA-WB-12)",
    )


@case(
    id="MSG-008",
    title="noreply='yes' posts are stored and get no reply, even when they fail",
    section="3.2",
    requirements=("OA-MSG-15", "OA-WB-8"),
    needs=("noreply",),
    allowed=("no reply to either post; the next reply on the connection is the PING's",),
)
async def noreply(ctx: CaseContext) -> None:
    """Post with `noreply="yes"`, then an invalid type with `noreply="YES"`, then PING.

    Catches: acknowledgements sent anyway (they would be paired with the PING), errors reported
    for noreply posts, noreply posts not stored.
    """
    raw = await ctx.raw()
    ident = ctx.name("Quiet")
    await send_only(raw, message_xml(ctx.type("Quiet"), to="WB1", id=ident, attrs='noreply="yes"'))
    bad = message_xml(ctx.type("Bad..Type"), to="WB1", attrs='noreply="YES"')
    await send_only(raw, bad)
    await ping_ok(ctx, raw, what="after two noreply posts", req="OA-MSG-15")
    await _stored(ctx, await ctx.module("C", bind=False), ident)


@case(
    id="MSG-009",
    title="A message of only type and to is accepted; absent slots are empty",
    section="3.1",
    requirements=("OA-MSG-9", "OA-MSG-17", "OA-SESS-1"),
    allowed=("RECEIVE_ACCEPT with empty isresponse; the stored copy has empty from and content",),
)
async def minimal_message(ctx: CaseContext) -> None:
    """Post `<message><type>T</type><to>WB1</to></message>` (no id, from, time or content).

    Catches: a reader that requires optional slots, or a reply that invents an isresponse.
    """
    type_ = ctx.type(f"Minimal.{ctx.run_id}")
    reply = await send_xml(
        await ctx.raw(), f"<message><type>{type_}</type><to>WB1</to></message>".encode()
    )
    ctx.check(
        reply.type == "RECEIVE_ACCEPT" and reply.isresponse == "",
        f"answered {reply.type} with isresponse {reply.isresponse!r}",
        expected="RECEIVE_ACCEPT, isresponse empty (OA-MSG-9, OA-SESS-1)",
    )
    client = await ctx.module("C", bind=False)
    found = await retrieved(ctx, client, f'<retrieve from="WB1" type="{type_}"/>')
    got = [(m.sender, m.content) for m in found]
    ctx.check(got == [("", "")], f"stored copies {got}", expected="[('', '')] (OA-MSG-17)")


@case(
    id="MSG-010",
    title="Text content is escaped and unescaped; XML content is kept as elements",
    section="3.3",
    requirements=("OA-MSG-10", "OA-MSG-17"),
    allowed=("the same text and the same elements back, the language kept",),
)
async def content_kinds(ctx: CaseContext) -> None:
    """Post text `a < b & "c" <tag/>` (language English) and XML content with white space
    between two roots (language `XML`); read both stored copies.

    Catches: text content parsed as XML, XML content escaped into text, `XML` in upper case
    not recognised, whitespace text kept as a third node.
    """
    client = await ctx.module("C", bind=False)
    text = 'a < b & "c" <tag/>'
    await client.post("WB1", ctx.type("Text"), text, language="English")
    assert client.last_sent is not None
    copy = await _stored(ctx, client, client.last_sent.id)
    ctx.check(
        (copy.content, copy.language) == (text, "English"),
        f"text copy {(copy.content, copy.language)}",
        expected="OA-MSG-10",
    )
    ident = ctx.name("Xml")
    body = '<content language="XML"><a x="1"><b/></a>\n   <c>t</c></content>'
    xml = message_xml(ctx.type("Xml"), to="WB1", id=ident, content=None, body=body)
    await _post_xml(ctx, xml, what="a post with XML content")
    copy = await _stored(ctx, client, ident)
    names = [el.tag for el in parse_xml(f"<w>{copy.content}</w>".encode())]
    ctx.check(
        copy.content_is_xml and names == ["a", "c"],
        f"XML copy: is_xml={copy.content_is_xml} {names}",
        expected="elements a and c (OA-MSG-10, OA-MSG-17)",
    )


def _canonical_problems(el: etree._Element, where: str) -> list[str]:
    """Return how a `<message>` element departs from the canonical form of 3.5."""
    names = [etree.QName(c).localname for c in el if isinstance(c.tag, str)]
    known = [n for n in names if n in CANONICAL_SLOTS]
    problems = [f"{where}: missing {n}" for n in _ALWAYS if n not in names]
    order = [CANONICAL_SLOTS.index(n) for n in known]
    if order != sorted(order):
        problems.append(f"{where}: slot order {known}")
    folded = {s.lower(): s for s in CANONICAL_SLOTS}
    problems += [
        f"{where}: spelling {n}" for n in names if n.lower() in folded and n not in folded.values()
    ]
    after = names[names.index("content") + 1 :] if "content" in names else []
    problems += [f"{where}: {n} after content" for n in after if n.lower() in folded]
    return problems


@case(
    id="MSG-011",
    title="Messages the server writes are in canonical form (slot order, spellings, content)",
    section="3.5",
    requirements=("OA-MSG-4",),
    allowed=("the order of 3.5, postedTime/receivedTime spelled so, content always present",),
)
async def canonical_form(ctx: CaseContext) -> None:
    """Read the raw XML of a PING reply, a post's acknowledgement and a retrieve reply (with
    its stored copies) and check each `<message>`.

    Catches: slots in another order, `postedtime`, an absent `<content>` on empty replies
    (Psyclone, DEV-25).
    """
    raw = await ctx.raw()
    me = ctx.name("F")
    await raw.send_message(Message(type=ctx.type("Canon"), sender=me, to="WB1", content="c"))
    frames = [await raw.read_frame()]
    await raw.send_message(Message(type="PING", sender=me, to="CNS"))
    frames.append(await raw.read_frame())
    spec = f'<retrieve from="WB1" type="{esc(ctx.type("Canon"))}"/>'
    await raw.send_message(
        Message(
            type="AIR.Retrieve",
            sender=me,
            to="AIRCentral",
            content=spec,
            content_is_xml=True,
            language="xml",
        )
    )
    frames.append(await raw.read_frame())
    problems = []
    for frame in frames:
        root = parse_xml(frame.xml)
        problems += _canonical_problems(root, root.findtext("type") or "?")
        problems += [
            p for m in message_collection_raw(root) for p in _canonical_problems(m, "stored copy")
        ]
    ctx.check(not problems, "; ".join(problems[:10]), expected="canonical form (OA-MSG-4)")


@case(
    id="MSG-012",
    title="Stored copies carry wbid as at least 8 zero-padded digits",
    section="3.2",
    requirements=("OA-MSG-13",),
    allowed=("<wbid> text of 8 or more digits",),
)
async def wbid_digits(ctx: CaseContext) -> None:
    """Post, retrieve on a raw connection, and read the `<wbid>` text of the stored copy.

    Catches: a wbid written without padding (legacy readers compare it as text).
    """
    raw = await ctx.raw()
    me = ctx.name("F")
    await raw.request(Message(type=ctx.type("Wbid"), sender=me, to="WB1", content="w"))
    spec = f'<retrieve from="WB1" type="{esc(ctx.type("Wbid"))}"/>'
    await raw.send_message(
        Message(
            type="AIR.Retrieve",
            sender=me,
            to="AIRCentral",
            content=spec,
            content_is_xml=True,
            language="xml",
        )
    )
    copies = message_collection_raw(parse_xml((await raw.read_frame()).xml))
    texts = [next((c.text or "" for c in m if str(c.tag).lower() == "wbid"), None) for m in copies]
    ctx.check(
        len(texts) == 1 and texts[0] is not None and bool(_WBID.match(texts[0])),
        f"wbid texts {texts}",
        expected="OA-MSG-13",
    )


@case(
    id="MSG-013",
    title="Two posts with the same id are both stored and both wake the subscriber",
    section="3.2",
    requirements=("OA-MSG-8",),
    allowed=("two RECEIVE_ACCEPT, two wakeups, two stored copies",),
)
async def duplicate_ids(ctx: CaseContext) -> None:
    """Post twice with one id (as JavaOpenAIR does after a RESOLVE_REQUEST).

    Catches: a server that deduplicates by id and loses the second message.
    """
    sub = await ctx.module("Sub")
    await setup_subscribe(sub, triggers_xml(ctx.type("Twin.*")))
    ident = ctx.name("Twin")
    for n in (1, 2):
        await _post_xml(
            ctx, message_xml(ctx.type(f"Twin.{n}"), to="WB1", id=ident), what=f"post {n}"
        )
    woken = trigger_ids(await sub.barrier())
    ctx.check(
        woken == [ident, ident], f"{len(woken)} wakeup(s) for the id", expected="two (OA-MSG-8)"
    )
    found = await retrieved(
        ctx, sub, f'<retrieve from="WB1" id="{ident}"><latest>0</latest></retrieve>'
    )
    ctx.check(len(found) == 2, f"{len(found)} stored copies", expected="two (OA-MSG-8)")


@case(
    id="MSG-014",
    title="inreplyto with one reference is kept; with two references it is MESSAGE_INVALID",
    section="3.2",
    requirements=("OA-MSG-11",),
    allowed=("the stored copy's inreplyto names the referenced id; RECEIVE_ERROR for two",),
)
async def inreplyto(ctx: CaseContext) -> None:
    """Post with `<inReplyTo><reference id=…/></inReplyTo>`, then with two references.

    Catches: a reference dropped from the stored copy, or two references accepted.
    """
    ident = ctx.name("R")
    ref = '<reference id="ref-1" type="X.Y" from="A" stored="WB1" sec="1" msec="2"/>'
    body = f"<inReplyTo>{ref}</inReplyTo>"
    await _post_xml(
        ctx, message_xml(ctx.type("Reply"), to="WB1", id=ident, body=body), what="a post"
    )
    copy = await _stored(ctx, await ctx.module("C", bind=False), ident)
    got = copy.inreplyto.id if copy.inreplyto else None
    ctx.check(
        got == "ref-1", f"inreplyto {copy.inreplyto}", expected="the reference kept (OA-MSG-11)"
    )
    two = f"<inreplyto>{ref}{ref}</inreplyto>"
    reply = await send_xml(await ctx.raw(), message_xml(ctx.type("Reply"), to="WB1", body=two))
    check_error(ctx, reply, names=("MESSAGE_INVALID",), what="two references", req="OA-MSG-11")


@case(
    id="MSG-015",
    title="A module that declared no extension gets no extension wire forms (usec, noreply)",
    section="1.2",
    requirements=("OA-GEN-2", "OA-SESS-19"),
    allowed=("no usec attribute and no noreply attribute in anything sent to the module",),
)
async def legacy_module(ctx: CaseContext) -> None:
    """Bind a module declaring nothing; register; wake it; retrieve; scan every frame it got.

    Catches: a server that writes `usec` or `noreply` to a peer that did not declare them.
    """
    module = await ctx.module("Legacy")
    await setup_subscribe(module, triggers_xml(ctx.type("Go")))
    await module.post("WB1", ctx.type("Go"), "go")
    await module.post("WB1", ctx.type("Other"), "cc", cc=module.name)
    await module.barrier()
    await module.retrieve(
        f'<retrieve from="WB1" type="{esc(ctx.type("*"))}"><latest>0</latest></retrieve>'
    )
    bad = [
        e.text[:120]
        for e in ctx.trace.entries
        if e.direction == "in" and re.search(r"\b(usec|noreply)=", e.text)
    ]
    ctx.check(not bad, f"frames with extension forms: {bad[:3]}", expected="OA-GEN-2")


@case(
    id="MSG-016",
    title="An XML declaration is optional; a non-UTF-8 one or another root is XML_MALFORMED",
    section="3.1",
    requirements=("OA-MSG-1", "OA-ERR-3", "OA-ERR-2"),
    allowed=(
        "PING_SUCCESS for a PING with <?xml version='1.0' encoding='UTF-8'?>",
        "RECEIVE_ERROR 'XML_MALFORMED: …' for encoding ISO-8859-1, a <msg> root, invalid UTF-8",
    ),
)
async def xml_documents(ctx: CaseContext) -> None:
    """Send a PING with a UTF-8 declaration, then three malformed documents, on one connection.

    Catches: declarations refused, other encodings silently transcoded, any root accepted.
    """
    raw = await ctx.raw()
    ping = message_xml("PING", to="CNS", sender=ctx.name("F"))
    reply = await send_xml(raw, b'<?xml version="1.0" encoding="UTF-8"?>' + ping)
    ctx.check(
        reply.type == "PING_SUCCESS", f"PING with a declaration: {reply.type}", expected="OA-MSG-1"
    )
    for bad in (
        b'<?xml version="1.0" encoding="ISO-8859-1"?>' + ping,
        ping.replace(b"<message>", b"<msg>").replace(b"</message>", b"</msg>"),
        ping.replace(b"<to>CNS</to>", b"<to>CNS\xff\xfe</to>"),
    ):
        reply = await send_xml(raw, bad)
        check_error(
            ctx, reply, names=("XML_MALFORMED",), what=bad[:60].decode("latin-1"), req="OA-MSG-1"
        )
    await ping_ok(ctx, raw, what="after the malformed documents", req="OA-ERR-3")
