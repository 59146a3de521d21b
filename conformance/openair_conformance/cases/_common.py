"""Helpers shared by the case modules: XML by hand, error replies, retrieves, wakeup reading.

Cases build some messages by hand (`message_xml`) to control spellings, slot order and invalid
values that the codec would refuse to write. Everything a case concludes from a server message is
read with the independent readers of `harness.checks`, never with the reference's own parsers.
The module name starts with `_`, so `cases/__init__` does not import it as a case module.
"""

from __future__ import annotations

import uuid
from collections.abc import Iterable, Sequence

from lxml import etree

from openair.protocol.connection import ANSWER_FOR
from openair.protocol.errors import ErrorCode
from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message
from openair_conformance.harness import CaseContext, RawConnection, TestModule
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    WakeupView,
    attributes,
    content_object,
    is_phase_update,
    message_collection,
    wakeup_trigger_id,
    wakeup_view,
)
from openair_conformance.harness.conn import ConnectionLost
from openair_conformance.model import Inconclusive

__all__ = [
    "ADDRESSES",
    "COMPONENTS",
    "ERROR_NAMES",
    "LOCAL_ERROR_NAMES",
    "ack",
    "bind_nolisten",
    "check_error",
    "cns_request",
    "dictionary_entries",
    "error_name",
    "esc",
    "frames_until_closed",
    "message_collection_raw",
    "message_xml",
    "next_request",
    "parse_xml",
    "ping_ok",
    "raw_module",
    "retrieved",
    "send_big",
    "send_only",
    "send_xml",
    "setup_subscribe",
    "trigger_ids",
    "trigger_types",
    "triggers_xml",
    "view_of",
    "woken_by",
]

#: The system components every server has besides AIRCentral and the whiteboards (spec 6.2).
COMPONENTS = ("CNS", "Config", "Psyclone", "AIRServer", "ContextsAndPhases")
#: Every address a request may be sent to on the main port: `to` empty (CNS), AIRCentral, the
#: example whiteboards and the system components.
ADDRESSES = ("", "AIRCentral", "WB1", "WB2", *COMPONENTS)

#: The condition names of the error table (spec 13.1); only these may travel (OA-ERR-1).
ERROR_NAMES: frozenset[str] = frozenset(code.name for code in ErrorCode)
#: Conditions whose blame is local: never sent on the wire (OA-ERR-7).
LOCAL_ERROR_NAMES = frozenset(
    {"API_MISUSE", "CONNECTION_CLOSED", "REQUEST_TIMEOUT", "REQUEST_FAILED"}
)

_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
_ESCAPES = {"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;"}
_ESCAPES.update({"\t": "&#9;", "\n": "&#10;", "\r": "&#13;"})


def cns_request(
    ctx: CaseContext, type: str, to: str = "CNS", content: str = "", sfx: str = "S"
) -> Message:
    """A request of `type` from a fresh name of the case (suffix `sfx`) to `to`."""
    return Message(type=type, sender=ctx.name(sfx), to=to, content=content)


def esc(text: str) -> str:
    """Escape text for an XML attribute or element (white space kept as character references)."""
    return "".join(_ESCAPES.get(ch, ch) for ch in text)


def parse_xml(data: bytes | bytearray) -> etree._Element:
    """Parse XML the server sent, without DTDs or entities (ValueError if not well-formed)."""
    try:
        return etree.fromstring(bytes(data), _PARSER)
    except etree.XMLSyntaxError as exc:
        raise ValueError(str(exc)) from exc


def message_xml(
    type: str,
    *,
    to: str = "",
    sender: str = "",
    id: str | None = None,
    body: str = "",
    attrs: str = "",
    content: str | None = "",
) -> bytes:
    """Write a `<message>` by hand: `body` is raw XML placed after `to`, `attrs` raw attributes.

    `content=None` leaves the content element out; otherwise it is escaped text content.
    """
    ident = str(uuid.uuid4()) if id is None else id
    parts = [f"<message{(' ' + attrs) if attrs else ''}>", f"<type>{esc(type)}</type>"]
    parts += [f"<id>{esc(ident)}</id>", f"<from>{esc(sender)}</from>", f"<to>{esc(to)}</to>"]
    parts.append(body)
    if content is not None:
        parts.append(f'<content language="">{esc(content)}</content>')
    parts.append("</message>")
    return "".join(parts).encode()


async def send_only(raw: RawConnection, xml: bytes, tag: FrameTag = FrameTag.MESSAGE) -> None:
    """Send hand-written XML in one frame, reading nothing (noreply messages)."""
    await raw.send_frame(Frame(tag=tag, xml=xml))


def message_collection_raw(root: etree._Element) -> list[etree._Element]:
    """Return the `<message>` elements nested in a raw message's content (stored copies)."""
    return [
        el
        for el in root.iter()
        if el is not root
        and isinstance(el.tag, str)
        and etree.QName(el).localname.lower() == "message"
    ]


async def send_big(ctx: CaseContext, raw: RawConnection, data: bytes, *, what: str) -> None:
    """Send many bytes under the deadline policy: a server that stops reading makes the case
    FAIL instead of stalling it until its budget runs out."""
    await ctx.wait(
        raw.send(data),
        what=f"the server to read {what} ({len(data)} bytes)",
        timeout=ctx.deadline * 10,
        expected="the server reads what it is sent",
    )


async def send_xml(raw: RawConnection, xml: bytes, tag: FrameTag = FrameTag.MESSAGE) -> Message:
    """Send hand-written XML in one frame and return the next message the server sends."""
    await raw.send_frame(Frame(tag=tag, xml=xml))
    return await raw.read_message()


def dictionary_entries(ctx: CaseContext, reply: Message) -> dict[str, str]:
    """Return the entries of the `<dictionary>` a reply carries (STATUS, GET_ENTRY) as name →
    text; Fail when it carries none."""
    try:
        dictionary = content_object(reply, "dictionary")
    except WakeupUnreadable as exc:
        ctx.fail(f"{reply.type} content: {exc}", expected="a <dictionary>")
    return {
        attributes(e).get("name", ""): "".join(str(t) for t in e.itertext())
        for e in dictionary
        if isinstance(e.tag, str) and e.tag.lower() == "entry"
    }


def error_name(content: str) -> str:
    """Return NAME of a `NAME: detail` content (OA-ERR-2)."""
    return content.strip().split(":", 1)[0].strip()


def check_error(
    ctx: CaseContext,
    reply: Message,
    *,
    types: Sequence[str] = ("RECEIVE_ERROR",),
    names: Sequence[str],
    what: str,
    req: str,
) -> None:
    """Fail unless `reply` is one of `types` whose content names one of `names` (OA-ERR-2)."""
    wanted = f"{' or '.join(types)} with content '{' or '.join(names)}: detail' ({req}, OA-ERR-2)"
    ctx.check(
        reply.type in types,
        f"{what} was answered {reply.type} {reply.content!r}",
        expected=wanted,
    )
    ctx.check(
        error_name(reply.content) in names,
        f"{what}: {reply.type} content is {reply.content!r}",
        expected=wanted,
    )


async def ping_ok(ctx: CaseContext, raw: RawConnection, *, what: str, req: str) -> None:
    """PING CNS on `raw` and fail unless the next message is its PING_SUCCESS."""
    sent = await raw.send_message(Message(type="PING", sender=ctx.name("Ping"), to="CNS"))
    reply = await raw.read_message()
    ctx.check(
        reply.type == "PING_SUCCESS" and reply.isresponse == sent.id,
        f"PING {what} was answered {reply.type} (isresponse {reply.isresponse!r})",
        expected=f"PING_SUCCESS: the connection is still usable ({req})",
    )


async def frames_until_closed(
    ctx: CaseContext, raw: RawConnection, *, what: str, timeout: float | None = None
) -> list[Frame]:
    """Read every frame until the server closes `raw`; Fail (or Timing) if it stays open."""

    async def collect() -> list[Frame]:
        frames: list[Frame] = []
        try:
            while True:
                frames.append(await raw.stream.read_frame())
        except ConnectionLost as exc:
            if exc.framing and not raw.stream.at_eof:
                try:
                    while await raw.stream.read_bytes():
                        pass
                except ConnectionLost:
                    pass
        return frames

    return await ctx.wait(
        collect(), what=what, expected="the server closes the connection", timeout=timeout
    )


async def setup_subscribe(module: TestModule, content_xml: str, *, to: str = "AIRCentral") -> None:
    """Register as a setup step: a refusal makes the case INCONCLUSIVE, not FAIL."""
    reply = await module.subscribe(content_xml, to=to)
    if reply.type != "RECEIVE_ACCEPT":
        raise Inconclusive(f"setup: AIR.Subscribe was answered {reply.type} {reply.content!r}")


def triggers_xml(*patterns: str, wb: str = "WB1", after: int | None = None) -> str:
    """Return `<triggers>` (the bare form) with one trigger per pattern on whiteboard `wb`."""
    delay = "" if after is None else f' after="{after}"'
    inner = "".join(f'<trigger from="{esc(wb)}" type="{esc(p)}"{delay}/>' for p in patterns)
    return f"<triggers>{inner}</triggers>"


async def retrieved(
    ctx: CaseContext,
    module: TestModule,
    spec_xml: str,
    *,
    to: str = "AIRCentral",
    plural: bool = False,
    req: str = "OA-RET-7",
    timeout: float | None = None,
) -> tuple[Message, ...]:
    """Retrieve and return the stored copies; Fail unless the reply is the Success reply."""
    request = Message(
        type="AIR.Retrieves" if plural else "AIR.Retrieve",
        sender=module.name,
        to=to,
        content=spec_xml,
        content_is_xml=True,
        language="xml",
    )
    reply = await module.request(request, timeout=timeout)
    want = "AIR.Retrieves.Success" if plural else "AIR.Retrieve.Success"
    ctx.check(
        reply.type == want,
        f"the retrieve {spec_xml} was answered {reply.type} {reply.content!r}",
        expected=f"{want} ({req})",
    )
    try:
        return message_collection(reply)
    except WakeupUnreadable as exc:
        ctx.fail(f"retrieve result: {exc}", expected="an <objectcollection> (OA-RET-7)")


def view_of(ctx: CaseContext, wakeup: Message) -> WakeupView:
    """Take a wakeup apart; Fail when it is unreadable (OA-WAKE-1)."""
    try:
        return wakeup_view(wakeup)
    except WakeupUnreadable as exc:
        ctx.fail(f"wakeup content: {exc}", expected="an <objectdictionary> (OA-WAKE-1)")


def trigger_ids(wakeups: Iterable[Message]) -> list[str]:
    """Return the TriggerMessage ids of wakeups, in order ('' when unreadable)."""
    return [wakeup_trigger_id(w) or "" for w in wakeups]


def trigger_types(wakeups: Iterable[Message]) -> list[str]:
    """Return the TriggerMessage types of wakeups, in order ('' when unreadable)."""
    found = []
    for wakeup in wakeups:
        try:
            trigger = wakeup_view(wakeup).trigger
        except WakeupUnreadable:
            trigger = None
        found.append(trigger.type if trigger is not None else "")
    return found


async def bind_nolisten(raw: RawConnection, name: str) -> None:
    """BIND_NOLISTEN `name` on `raw`; a refusal is INCONCLUSIVE (a setup step)."""
    reply = await raw.request(Message(type="BIND_NOLISTEN", sender=name, to="CNS"))
    if reply.type != "BIND_ACCEPT":
        raise Inconclusive(f"setup: BIND_NOLISTEN was answered {reply.type} {reply.content!r}")


async def raw_module(
    ctx: CaseContext, suffix: str, *, extensions: tuple[str, ...] = ()
) -> tuple[RawConnection, RawConnection, str]:
    """Bind `ctx.name(suffix)` with BIND_NOLISTEN on a raw connection and open a raw callback.

    Returns (primary, callback, id of the RECEIVE_NAME_NOTIFICATION). The case reads and answers
    the callback connection itself (`next_request`, `ack`). A refused BIND is INCONCLUSIVE.
    `extensions` are declared in the `extensions` slot of both (OA-SESS-19).
    """
    name = ctx.name(suffix)
    primary = await ctx.raw(f"{suffix}/primary")
    bind = Message(type="BIND_NOLISTEN", sender=name, to="CNS")
    if extensions:
        bind = bind.with_extra("extensions", " ".join(extensions))
    reply = await primary.request(bind)
    if reply.type != "BIND_ACCEPT":
        raise Inconclusive(f"setup: BIND_NOLISTEN was answered {reply.type} {reply.content!r}")
    callback = await ctx.raw(f"{suffix}/callback")
    notice = Message(type="RECEIVE_NAME_NOTIFICATION", sender=name)
    if extensions:
        notice = notice.with_extra("extensions", " ".join(extensions))
    sent = await callback.send_message(notice, FrameTag.RECEIVE)
    return primary, callback, sent.id


async def next_request(
    ctx: CaseContext, callback: RawConnection, *, receive_id: str = "", name: str = ""
) -> Message:
    """Return the next request on a raw callback connection, answering PING and KEEPALIVE.

    Fails if the server answers the Receive frame (OA-SESS-7) or sends a reply there
    (OA-SESS-28).
    """
    while True:
        msg = await callback.read_message()
        ctx.check(
            not (receive_id and msg.isresponse == receive_id),
            f"the server answered the Receive frame with {msg.type}",
            expected="no reply to RECEIVE_NAME_NOTIFICATION (OA-SESS-7)",
        )
        if msg.type in ANSWER_FOR:
            await callback.send_message(msg.reply(ANSWER_FOR[msg.type], sender=name))
            continue
        if is_phase_update(msg):  # OA-WAKE-9: allowed at any time; not what the case awaits
            await ack(callback, msg, name)
            continue
        ctx.check(
            not msg.isresponse,
            f"the server sent a reply ({msg.type}) on the callback connection",
            expected="only requests from the server on a callback connection (OA-SESS-28)",
        )
        return msg


async def ack(callback: RawConnection, msg: Message, name: str) -> None:
    """Acknowledge a delivery on a raw callback connection (RECEIVE_ACCEPT, OA-DELIV-4)."""
    await callback.send_message(msg.reply("RECEIVE_ACCEPT", sender=name))


def subscribe_message(name: str, content_xml: str) -> Message:
    """Return the AIR.Subscribe of `name` to AIRCentral with the registration `content_xml`."""
    return Message(
        type="AIR.Subscribe",
        sender=name,
        to="AIRCentral",
        content=content_xml,
        content_is_xml=True,
        language="xml",
    )


async def raw_subscribe(raw: RawConnection, name: str, content_xml: str) -> Message:
    """Send `subscribe_message(name, content_xml)` on `raw`; return the reply."""
    return await raw.request(subscribe_message(name, content_xml))


async def setup_raw_subscribe(raw: RawConnection, name: str, content_xml: str) -> None:
    """`raw_subscribe` as a setup step: anything but RECEIVE_ACCEPT is INCONCLUSIVE."""
    reply = await raw_subscribe(raw, name, content_xml)
    if reply.type != "RECEIVE_ACCEPT":
        raise Inconclusive(f"setup: AIR.Subscribe was answered {reply.type} {reply.content!r}")


async def setup_raw_bind(
    raw: RawConnection,
    name: str,
    port: int,
    *,
    extensions: tuple[str, ...] = (),
    echoed: bool = False,
) -> None:
    """BIND `name` on `raw` with a tcplocation of `port` as a setup step (INCONCLUSIVE unless
    BIND_ACCEPT, and with `echoed` unless its content is the port). `extensions` are declared
    in the `extensions` slot (OA-SESS-19)."""
    location = f'<tcplocation port="{port}"/>'
    bind = Message(type="BIND", sender=name, to="CNS", content=location, content_is_xml=True)
    if extensions:
        bind = bind.with_extra("extensions", " ".join(extensions))
    reply = await raw.request(bind)
    if reply.type != "BIND_ACCEPT" or (echoed and reply.content.strip() != str(port)):
        raise Inconclusive(f"setup: BIND was answered {reply.type} {reply.content!r}")


async def setup_raw_bind_subscribe(
    raw: RawConnection,
    name: str,
    port: int,
    content_xml: str,
    *,
    extensions: tuple[str, ...] = (),
    echoed: bool = False,
) -> None:
    """`setup_raw_bind` then `setup_raw_subscribe`: a module listening on `port`, registered."""
    await setup_raw_bind(raw, name, port, extensions=extensions, echoed=echoed)
    await setup_raw_subscribe(raw, name, content_xml)


def stream_module_xml(ctx: CaseContext, name: str, stream: str) -> str:
    """Return the registration of module `name` reading `stream` as input `In`, with only a
    trigger that never fires (the case's Never type), so that all it gets is the push."""
    never = f'<trigger from="WB1" type="{esc(ctx.type("Never"))}"/>'
    inputs = f'<streams><inputstream alias="In" source="{esc(stream)}"/></streams>'
    return f'<module name="{esc(name)}">{inputs}{never}</module>'


async def woken_by(
    ctx: CaseContext, sub: TestModule, poster: TestModule, names: list[str]
) -> list[str]:
    """Post one message per trigger type name; return the names that woke `sub`, in order."""
    ids: dict[str, str] = {}
    for name in names:
        await poster.post("WB1", ctx.type(name), name)
        assert poster.last_sent is not None
        ids[poster.last_sent.id] = name
    return [ids[i] for i in trigger_ids(await sub.barrier()) if i in ids]
