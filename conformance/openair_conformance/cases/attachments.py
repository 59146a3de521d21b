"""Everything the whiteboard does, nothing silently lost (issue #21): attachments (OA-WB-13,
OA-MSG-21, OA-WAKE-10, OA-RET-19), the content `version` (OA-MSG-22), bare stream
registrations (OA-REG-16), the `qos` extension (timetolive, OA-DELIV-14; alarm triggers,
OA-TRIG-5) and the bounded payload search of typed streams (OA-XSTREAM-11).

Which chunk belongs to which nested stored copy is worked out here, from the XML the server
sent, independently of the reference's readers: the nested `<message>` elements in document
order, each taking as many chunks of the frame as its own `binarysizes` lists.
"""

from __future__ import annotations

from lxml import etree

from openair.protocol.message import Message
from openair_conformance.cases._common import check_error
from openair_conformance.cases._streams import StreamClient, create_stream
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    attributes,
    content_object,
    content_root,
    wakeup_trigger_id,
)
from openair_conformance.model import NotApplicable
from openair_conformance.registry import case

_QOS = ("qos",)
_TYPED = ("typed-streams",)


def _local(el: etree._Element) -> str:
    return etree.QName(el).localname.lower() if isinstance(el.tag, str) else ""


def _slot(el: etree._Element, name: str) -> str | None:
    for child in el:
        if _local(child) == name:
            return child.text or ""
    return None


def nested_attachments(msg: Message) -> list[tuple[str, tuple[bytes, ...]]]:
    """Return (id, chunks) of each nested stored copy, in document order (OA-MSG-21).

    Raises WakeupUnreadable when the frame's chunks do not match what the nested messages list.
    """
    found: list[tuple[str, tuple[bytes, ...]]] = []
    chunks = list(msg.binary)
    pos = 0
    for root in content_root(msg):
        for el in root.iter():
            if _local(el) != "message":
                continue
            text = (_slot(el, "binarysizes") or "").strip()
            sizes = [int(p.strip()) for p in text.split(",")] if text else []
            taken = tuple(chunks[pos : pos + len(sizes)])
            if len(taken) != len(sizes) or [len(c) for c in taken] != sizes:
                raise WakeupUnreadable(
                    f"nested message {_slot(el, 'id')!r} lists {sizes}, the frame has "
                    f"{[len(c) for c in chunks[pos:]]} left"
                )
            pos += len(sizes)
            found.append(((_slot(el, "id") or "").strip(), taken))
    if pos != len(chunks):
        raise WakeupUnreadable(f"{len(chunks) - pos} chunk(s) belong to no nested message")
    return found


def _attached(ctx: CaseContext, msg: Message, req: str) -> dict[str, tuple[bytes, ...]]:
    try:
        return dict(nested_attachments(msg))
    except (WakeupUnreadable, ValueError) as exc:
        ctx.fail(f"{msg.type}: {exc}", expected=f"chunks laid out as OA-MSG-21 says ({req})")


async def _post(
    ctx: CaseContext,
    poster: TestModule,
    name: str,
    *,
    chunks: tuple[bytes, ...] = (),
    priority: float | None = None,
    timetolive: float | None = None,
    language: str = "",
    version: str = "",
) -> Message:
    """Post `ctx.type(name)` to WB1 with `chunks` and slots; return the message as sent."""
    msg = Message(
        type=ctx.type(name),
        sender=poster.name,
        to="WB1",
        content=name,
        binary=chunks,
        priority=priority,
        timetolive=timetolive,
        language=language,
        content_version=version,
    )
    reply = await poster.request(msg)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"the post of {name} was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT (OA-WB-3)",
    )
    assert poster.last_sent is not None
    return poster.last_sent


def _retrieve_xml(pattern: str, latest: int = 0) -> str:
    return f'<retrieve from="WB1" type="{pattern}"><latest>{latest}</latest></retrieve>'


@case(
    id="ATT-001",
    title="A wakeup carries the attachments of its trigger and retrieved messages",
    section="8.7",
    requirements=("OA-WAKE-10", "OA-WB-13", "OA-MSG-21"),
    allowed=(
        "the wakeup's chunks: the trigger's (a 5-byte chunk), then Data.2's (none), then "
        "Data.1's (2 bytes and an empty chunk); each nested copy lists its own in binarysizes",
    ),
)
async def wakeup_attachments(ctx: CaseContext) -> None:
    """Register a trigger with a retrieve of `Data.*`; post Data.1 (two chunks), Data.2 (none)
    and Go (one chunk); read the wakeup's chunks by the nested copies' binarysizes.

    Catches: attachments dropped on storing, a wakeup frame without the chunks its nested
    copies list, and chunks of the retrieved messages in the wrong order.
    """
    reader = await ctx.module("Reader")
    poster = await ctx.module("Poster", bind=False)
    go, data = ctx.type("Go"), ctx.type("Data.*")
    content = (
        f'<triggers><trigger from="WB1" type="{go}"/></triggers>'
        f"<retrieves>{_retrieve_xml(data)}</retrieves>"
    )
    await reader.subscribe(content, check=True)
    one = await _post(ctx, poster, "Data.1", chunks=(b"\x01\x02", b""))
    two = await _post(ctx, poster, "Data.2")
    trigger = await _post(ctx, poster, "Go", chunks=(b"\x00\xffabc",))
    wakeup = await reader.expect_wakeup(lambda w: wakeup_trigger_id(w) == trigger.id)
    got = _attached(ctx, wakeup, "OA-WAKE-10")
    want = {trigger.id: (b"\x00\xffabc",), two.id: (), one.id: (b"\x01\x02", b"")}
    ctx.check(got == want, f"attachments by message: {got}", expected=f"{want} (OA-WAKE-10)")
    ctx.check(
        list(wakeup.binary) == [b"\x00\xffabc", b"\x01\x02", b""],
        f"the wakeup's chunks {list(wakeup.binary)}",
        expected="the trigger's chunks first, then the retrieved ones' (OA-WAKE-10)",
    )


@case(
    id="ATT-002",
    title="Retrieve replies carry the attachments of their results, in result order",
    section="9.3",
    requirements=("OA-RET-19", "OA-WB-13", "OA-MSG-21"),
    allowed=("the chunks of the newest result first; AIR.Retrieves in the order of its retrieves",),
)
async def retrieve_attachments(ctx: CaseContext) -> None:
    """Post A (chunks `a1`, `a2`), B (none) and C (`c`); retrieve `*` latest 0, then
    AIR.Retrieves of A then C.

    Catches: a reply without the chunks, chunks in posting order instead of result order, and
    AIR.Retrieves that lays out the chunks in another order than its results.
    """
    reader = await ctx.module("Reader", bind=False)
    a = await _post(ctx, reader, "A", chunks=(b"a1", b"a2"))
    b = await _post(ctx, reader, "B")
    c = await _post(ctx, reader, "C", chunks=(b"c",))
    reply = await reader.retrieve(_retrieve_xml(ctx.type("*")))
    ctx.check(reply.type == "AIR.Retrieve.Success", f"retrieve: {reply.type}", expected="Success")
    got = _attached(ctx, reply, "OA-RET-19")
    want = {c.id: (b"c",), b.id: (), a.id: (b"a1", b"a2")}
    ctx.check(got == want, f"attachments by result: {got}", expected=f"{want} (OA-RET-19)")
    ctx.check(
        list(reply.binary) == [b"c", b"a1", b"a2"],
        f"the reply's chunks {list(reply.binary)}",
        expected="newest result's chunks first (OA-RET-19, OA-RET-6)",
    )
    both = _retrieve_xml(ctx.type("A"), 1) + _retrieve_xml(ctx.type("C"), 1)
    reply = await reader.retrieve(f"<retrieves>{both}</retrieves>", plural=True)
    ctx.check(
        list(reply.binary) == [b"a1", b"a2", b"c"],
        f"AIR.Retrieves chunks {list(reply.binary)}",
        expected="A's chunks, then C's (OA-RET-19, OA-RET-12)",
    )


def _content_version(msg: Message) -> list[str]:
    """Return the `version` of the content of each nested message (absent: '')."""
    versions = []
    for root in content_root(msg):
        for el in root.iter():
            if _local(el) == "message":
                body = next((c for c in el if _local(c) == "content"), None)
                versions.append(attributes(body).get("version", "") if body is not None else "")
    return versions


@case(
    id="ATT-003",
    title="The content's version attribute is kept on the stored copy, in wakeups and retrieves",
    section="3.3",
    requirements=("OA-MSG-22",),
    allowed=('`version="CommonLISP"` on the content of the nested copy, language `LISP` kept',),
)
async def content_version(ctx: CaseContext) -> None:
    """Post `(+ 1 2)` with `language="LISP" version="CommonLISP"` to a module's trigger;
    read the version on the wakeup's trigger copy and on the retrieved copy.

    Catches: a server that stores only `language` and drops the version.
    """
    reader = await ctx.module("Reader")
    poster = await ctx.module("Poster", bind=False)
    pattern = ctx.type("Lisp")
    await reader.subscribe(
        f'<triggers><trigger from="WB1" type="{pattern}"/></triggers>', check=True
    )
    sent = await _post(ctx, poster, "Lisp", language="LISP", version="CommonLISP")
    wakeup = await reader.expect_wakeup(lambda w: wakeup_trigger_id(w) == sent.id)
    got = _content_version(wakeup)[:1]
    ctx.check(
        got == ["CommonLISP"], f"wakeup copy version {got}", expected="CommonLISP (OA-MSG-22)"
    )
    reply = await reader.retrieve(_retrieve_xml(pattern, 1))
    got = _content_version(reply)
    ctx.check(got == ["CommonLISP"], f"retrieved version {got}", expected="CommonLISP (OA-MSG-22)")


@case(
    id="ATT-004",
    title="Bare <stream> elements (with or without triggers) are a registration (form 5)",
    section="8.2",
    requirements=("OA-REG-16",),
    allowed=("RECEIVE_ACCEPT for both; the triggers beside the stream element wake the module",),
    serial=True,  # attached to the shared Stream1: other cases' samples would come first (#16)
)
async def bare_stream_registration(ctx: CaseContext) -> None:
    """Subscribe `<stream name source/>` alone, then with `<triggers>` beside it, and post.

    Catches: a server that refuses stream elements outside `<module>`, and one that accepts
    them but drops the triggers beside them.
    """
    reader = await ctx.module("Reader")
    poster = await ctx.module("Poster", bind=False)
    alone = '<stream name="Eyes" source="Stream1"/>'
    reply = await reader.subscribe(alone)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"{alone} was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT (OA-REG-16)",
    )
    pattern = ctx.type("Seen")
    both = f'<streams>{alone}</streams><triggers><trigger from="WB1" type="{pattern}"/></triggers>'
    reply = await reader.subscribe(both)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"{both} was answered {reply.type} {reply.content!r}",
        expected="RECEIVE_ACCEPT (OA-REG-16)",
    )
    sent = await _post(ctx, poster, "Seen")
    await reader.expect_wakeup(lambda w: wakeup_trigger_id(w) == sent.id, what="the form-5 trigger")


async def _status_entry(ctx: CaseContext, module: TestModule, name: str) -> str | None:
    reply = await module.request(Message(type="STATUS", sender=module.name, to="CNS"))
    try:
        dictionary = content_object(reply, "dictionary")
    except WakeupUnreadable as exc:
        ctx.fail(f"STATUS_SUCCESS: {exc}", expected="a <dictionary> (OA-SESS-25)")
    for entry in dictionary:
        if _local(entry) == "entry" and attributes(entry).get("name") == name:
            return (entry.text or "").strip()
    return None


@case(
    id="QOS-001",
    title="A delivery not sent within the message's timetolive is dropped and counted",
    section="6.6",
    requirements=("OA-DELIV-14",),
    needs=_QOS,
    allowed=(
        "a trigger with after=300: Stale (timetolive 50) is never delivered, Fresh is; STATUS "
        "Deliveries.Expired at least 1; Stale is still retrievable",
    ),
)
async def timetolive(ctx: CaseContext) -> None:
    """Register a trigger with after=300; post Stale with timetolive 50, then Fresh; wait for
    the first wakeup, then ask STATUS and retrieve Stale.

    The trigger's delay keeps both deliveries queued past Stale's time to live (an `after`
    does not extend it), so no sleep is needed. Catches: a server that ignores timetolive, one
    that drops expired deliveries without counting them, and one that removes the stored copy.
    """
    reader = await ctx.module("Reader")
    poster = await ctx.module("Poster", bind=False)
    pattern = ctx.type("Q.*")
    content = f'<triggers><trigger from="WB1" type="{pattern}" after="300"/></triggers>'
    await reader.subscribe(content, check=True)
    stale = await _post(ctx, poster, "Q.Stale", timetolive=50.0)
    fresh = await _post(ctx, poster, "Q.Fresh")
    got = wakeup_trigger_id(await reader.expect_wakeup(_has_trigger))
    ctx.check(
        got == fresh.id,
        f"the first wakeup was for {'Stale' if got == stale.id else got}",
        expected="Fresh: Stale expired while its wakeup waited (OA-DELIV-14)",
    )
    expired = await _status_entry(ctx, poster, "Deliveries.Expired")
    ctx.check(
        expired is not None and expired.isdigit() and int(expired) >= 1,
        f"STATUS Deliveries.Expired = {expired!r}",
        expected="at least 1 (OA-DELIV-14)",
    )
    reply = await poster.retrieve(_retrieve_xml(ctx.type("Q.Stale"), 1))
    ctx.check(
        stale.id in reply.content,
        "the expired message is no longer retrievable",
        expected="the stored copy stays (OA-DELIV-14)",
    )


def _has_trigger(wakeup: Message) -> bool:
    return wakeup_trigger_id(wakeup) is not None


@case(
    id="QOS-002",
    title="An alarm trigger (maxpriority) fires only for messages at least that urgent",
    section="8.4",
    requirements=("OA-TRIG-5",),
    needs=_QOS,
    allowed=(
        "no wakeup for priority 2.0; wakeups for 0.2 and 0.5 (inclusive); maxpriority 9 is "
        "REGISTRATION_INVALID",
    ),
)
async def alarm_trigger(ctx: CaseContext) -> None:
    """Register `maxpriority="0.5"`; post Tick (2.0), then Crit (0.2), then Edge (0.5).

    Catches: a server that ignores maxpriority (Tick, posted first, would wake first; queued
    behind Crit it comes later, before the barrier's sentinel), an exclusive bound, and one that
    accepts an out-of-range value.
    """
    reader = await ctx.module("Reader")
    poster = await ctx.module("Poster", bind=False)
    pattern = ctx.type("Sensor.*")
    bad = f'<triggers><trigger from="WB1" type="{pattern}" maxpriority="9"/></triggers>'
    reply = await reader.subscribe(bad)
    check_error(ctx, reply, names=("REGISTRATION_INVALID",), what=bad, req="OA-TRIG-5")
    content = f'<triggers><trigger from="WB1" type="{pattern}" maxpriority="0.5"/></triggers>'
    await reader.subscribe(content, check=True)
    tick = await _post(ctx, poster, "Sensor.Tick", priority=2.0)
    crit = await _post(ctx, poster, "Sensor.Crit", priority=0.2)
    first = wakeup_trigger_id(await reader.expect_wakeup(_has_trigger))
    ctx.check(
        first == crit.id,
        f"the first wakeup was for {'Tick' if first == tick.id else first}",
        expected="Crit: Tick (2.0) is not urgent enough (OA-TRIG-5)",
    )
    edge = await _post(ctx, poster, "Sensor.Edge", priority=0.5)
    second = wakeup_trigger_id(await reader.expect_wakeup(_has_trigger))
    ctx.check(second == edge.id, f"then {second}", expected="Edge: 0.5 is at most 0.5 (OA-TRIG-5)")
    # A Tick wakeup queued behind the others (Crit and Edge are more urgent, OA-PRIO-1) still
    # comes before the barrier's sentinel, the least urgent of all.
    late = [wakeup_trigger_id(m) for m in await reader.barrier()]
    ctx.check(
        tick.id not in late,
        "a wakeup for Tick (2.0) came after the others",
        expected="no wakeup for Tick at all: 2.0 is less urgent than 0.5 (OA-TRIG-5)",
    )


@case(
    id="XSTREAM-013",
    title="SEARCH_SAMPLES <payload> finds a byte pattern within the scan limit only",
    section="11.7",
    requirements=("OA-XSTREAM-11",),
    needs=_TYPED,
    allowed=(
        "ff d8 ff: samples 1 and 3; ab cd (bytes 65 534-65 535): sample 4; ab cd ef, which ends "
        "past byte 65 536: not found; 'zz', an empty <payload> and 'f' are CONTENT_INVALID",
    ),
)
async def payload_search(ctx: CaseContext) -> None:
    """Add a JPEG-like sample, a text sample, a sample with the pattern in the middle, and one
    whose pattern straddles byte 65 536; search for the patterns.

    Catches: a search that ignores <payload>, one that scans without bound, and one that
    accepts a pattern that is not hexadecimal.
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(ctx, raw, "Bytes", type=ctx.type("Bytes"), idle=0)
    client = await StreamClient.open(ctx, name)
    await client.add(b"\xff\xd8\xff\xe0 jpeg")
    await client.add(b"plain text")
    await client.add(b"head \xff\xd8\xff tail")
    await client.add(bytes(65_534) + b"\xab\xcd\xef")
    for pattern, want in (
        ("ff d8 ff", [1, 3]),
        ("FFD8FF", [1, 3]),
        ("ab cd", [4]),
        ("ab cd ef", []),
    ):
        content = f"<samplesearch><payload>{pattern}</payload></samplesearch>"
        reply = await client.request("SEARCH_SAMPLES", content, xml=True)
        got = [s.id for s in client.samples_of(reply, content, req="OA-XSTREAM-11")]
        ctx.check(got == want, f"{content} found {got}", expected=f"{want} (OA-XSTREAM-11)")
    for bad in ("zz", "", "f"):
        content = f"<samplesearch><payload>{bad}</payload></samplesearch>"
        reply = await client.request("SEARCH_SAMPLES", content, xml=True)
        check_error(ctx, reply, names=("CONTENT_INVALID",), what=content, req="OA-XSTREAM-11")


#: The largest max-frame-binary ATT-005 fills (three posts of a third of it each).
_MAX_FILL = 1024 * 1024


@case(
    id="ATT-005",
    title="Attachments over max-frame-binary: the wakeup omits retrieved messages, retrieve fails",
    section="8.7",
    requirements=("OA-WAKE-11", "OA-RET-15", "OA-RET-19"),
    allowed=(
        "the wakeup holds the trigger and the newest retrieved message with their chunks and "
        "<omitted>1</omitted>; a retrieve of all three is AIR.Retrieve.Failed LIMIT_EXCEEDED",
    ),
)
async def attachments_over_the_limit(ctx: CaseContext) -> None:
    """Post Data.1 and Data.2 and then Go, each with a chunk of a third of max-frame-binary plus
    one byte, to a registration that retrieves `Data.*`; then retrieve all three.

    Catches: a wakeup frame over the limit (or one that drops the trigger's chunks, or leaves
    out messages silently), and a retrieve reply over the limit.
    """
    limit = ctx.server.limit("max-frame-binary", 64 * 1024 * 1024)
    if limit > _MAX_FILL:
        raise NotApplicable(f"max-frame-binary is {limit}; too large to fill quickly")
    size = limit // 3 + 1  # two fit (2 * size <= limit), three do not
    reader = await ctx.module("Reader")
    poster = await ctx.module("Poster", bind=False)
    go, data = ctx.type("Go"), ctx.type("Data.*")
    content = (
        f'<triggers><trigger from="WB1" type="{go}"/></triggers>'
        f"<retrieves>{_retrieve_xml(data)}</retrieves>"
    )
    await reader.subscribe(content, check=True)
    await _post(ctx, poster, "Data.1", chunks=(b"1" * size,))
    two = await _post(ctx, poster, "Data.2", chunks=(b"2" * size,))
    trigger = await _post(ctx, poster, "Go", chunks=(b"g" * size,))
    wakeup = await reader.expect_wakeup(lambda w: wakeup_trigger_id(w) == trigger.id)
    got = _attached(ctx, wakeup, "OA-WAKE-11")
    want = {trigger.id: (b"g" * size,), two.id: (b"2" * size,)}
    ctx.check(
        got == want,
        f"the wakeup holds {len(got)} messages with {[len(c) for c in wakeup.binary]} bytes",
        expected="the trigger and Data.2 with their chunks (OA-WAKE-11)",
    )
    omitted = next((s.value.strip() for s in wakeup.extras if s.name.lower() == "omitted"), None)
    ctx.check(omitted == "1", f"omitted slot {omitted!r}", expected="<omitted>1</omitted>")
    reply = await poster.retrieve(_retrieve_xml(ctx.type("*")))
    check_error(
        ctx,
        reply,
        types=("AIR.Retrieve.Failed",),
        names=("LIMIT_EXCEEDED",),
        what="a retrieve of attachments over max-frame-binary",
        req="OA-RET-15",
    )
