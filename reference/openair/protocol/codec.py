"""Message <-> XML: the lenient reader and the canonical writer of the envelope (spec 3, 4).

Reading accepts every legacy spelling (OA-MSG-3: names in any case, `ms` for `msec`, slots in
any order), keeps unknown slots in order (OA-MSG-5) and answers bad input with an error of the
table: XML_MALFORMED / XML_FORBIDDEN / XML_TOO_DEEP from `xmlsafe`, MESSAGE_INVALID for a slot
with a bad value. Writing produces the canonical form of spec 3.5 and nothing else:

- no XML declaration, no whitespace between elements, UTF-8;
- root attributes `priority`, `timetolive` (shortest decimal that reads back as the same number,
  at least one fractional digit: `2.0`) and `noreply="yes"` when set;
- the known slots in the order of `message.CANONICAL_SLOTS`; `type` ... `isresponse` always, an
  empty one as `<cc/>`; `postedTime` whenever the message has one; `content` always
  (`<content language=""/>` for empty text); then the unknown slots in order;
- `binarysizes` / `totalbinarysize` from `Message.binary` when it is not empty (OA-FRAME-4).

XML held as a string (`content` with language xml, `history`, XML extension slots) is parsed
with `xmlsafe` and grafted into the tree, never concatenated.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from lxml import etree

from openair.protocol import grammar
from openair.protocol._errors_base import OpenAIRError
from openair.protocol.errors import ApiMisuseError, MessageInvalidError, XmlMalformedError
from openair.protocol.fastcodec import fast_decode, fast_encode
from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import MAX_PRIORITY, MIN_PRIORITY, Message, Reference, Slot
from openair.protocol.times import AirTime
from openair.protocol.xmlsafe import XmlLimits, parse_fragment, parse_xml

__all__ = [
    "decode_message",
    "encode_message",
    "from_frame",
    "message_from_element",
    "message_to_element",
    "time_from_element",
    "time_to_element",
    "to_frame",
]

# The grammar shared with `fastcodec` (slots, number patterns and readers, the decimal writer).
_WS, _DIGITS = grammar.WS, grammar.DIGITS
_clip, _decimal, _time_from_attributes = grammar.clip, grammar.read_decimal, grammar.read_time
_YES_NO = {"yes": True, "no": False}
# Characters XML 1.0 does not allow (OA-MSG-14); used only to name the slot after lxml refused.
_NOT_XML_CHAR = grammar.NOT_XML_CHAR
_TEXT_SLOTS = grammar.TEXT_SLOTS  # lower-cased element name -> Message field
_DERIVED_SLOTS = grammar.DERIVED_SLOTS
_LISTED_EXTRAS = frozenset({"extensions"})


# ----------------------------------------------------------------------------------- decoding


def decode_message(
    xml: bytes | bytearray,
    chunks: tuple[bytes, ...] = (),
    limits: XmlLimits | None = None,
    *,
    clamp_priority: bool = False,
) -> Message:
    """Parse the XML of a Message or Receive frame into a `Message` carrying `chunks`.

    Raises XmlMalformedError (also when the root is not `message`, OA-MSG-1), XmlForbiddenError,
    XmlTooDeepError and MessageInvalidError. Simple documents take the strict fast path of
    `fastcodec`, which gives the same `Message`; anything else is parsed with lxml.
    `clamp_priority` reads a priority outside 0.0-6.999 as the nearest end of the range instead
    of refusing it: what a client does with the deliveries and replies it receives (OA-MSG-19);
    a server validating a post leaves it False (OA-MSG-6).
    """
    fast = fast_decode(xml, chunks, limits, clamp_priority=clamp_priority)
    if fast is not None:
        return fast
    return decode_with_lxml(xml, chunks, limits, clamp_priority=clamp_priority)


def decode_with_lxml(
    xml: bytes | bytearray,
    chunks: tuple[bytes, ...] = (),
    limits: XmlLimits | None = None,
    *,
    clamp_priority: bool = False,
    pause: Callable[[], None] | None = None,
) -> Message:
    """Decode like `decode_message` but always with lxml (the reference for the fast path).

    `pause`, when given, is called between the steps (see `parse_xml`).
    """
    root = parse_xml(xml, limits, pause=pause)  # UTF-8 only (OA-MSG-1), hardened (OA-SEC-1/2)
    if _local(root.tag) != "message":  # OA-MSG-1
        raise XmlMalformedError(f"root element is <{root.tag}>, not <message>")
    if pause is not None:
        pause()
    return _decode_element(root, chunks, clamp_priority)


def from_frame(
    frame: Frame, limits: XmlLimits | None = None, *, clamp_priority: bool = False
) -> Message:
    """Decode a Message or Receive frame; a BinaryM frame carries no message (OA-FRAME-5)."""
    if frame.tag is FrameTag.BINARY:
        raise MessageInvalidError("a BinaryM frame carries no message")
    return decode_message(frame.xml, frame.chunks, limits, clamp_priority=clamp_priority)


def message_from_element(el: etree._Element) -> Message:
    """Read a `<message>` element (any case), e.g. a stored copy inside a content object.

    A stored copy is what a server wrote, so it is read liberally: a priority outside
    0.0-6.999 (Psyclone echoes a posted 6.999 as `7.00`) is clamped to the range (OA-MSG-19).
    """
    if not isinstance(el.tag, str) or _local(el.tag) != "message":
        raise MessageInvalidError(f"expected a <message> element, found <{el.tag}>")
    return _decode_element(el, (), clamp_priority=True)


def _decode_element(
    root: etree._Element, chunks: tuple[bytes, ...], clamp_priority: bool = False
) -> Message:
    """Collect the slots of `root` into Message fields; reject duplicates (OA-MSG-16)."""
    fields: dict[str, Any] = {"id": "", "binary": chunks}
    if root.attrib:
        _read_root_attributes(root, fields, clamp_priority)
    extras: list[Slot] = []
    seen: set[str] = set()
    _no_text(root.text, "message")
    for child in root:  # the hot loop: one lxml access per property, no helper for text slots
        tail = child.tail
        if tail and tail.strip(_WS):
            _no_text(tail, "message")
        tag = child.tag
        if tag.__class__ is not str:
            continue  # a comment or processing instruction
        name = tag.lower() if "}" not in tag else _local(tag)
        if name in seen:  # OA-MSG-16
            raise MessageInvalidError(f"slot <{tag}> occurs more than once")
        field = _TEXT_SLOTS.get(name)
        if field is not None:
            seen.add(name)
            fields[field] = (child.text or "") if len(child) == 0 else _text(child)
        elif (reader := _READERS.get(name)) is not None:
            seen.add(name)
            reader(child, fields)
        else:
            _other_slot(child, name, seen, extras)
    if not fields.get("type"):  # OA-MSG-2
        raise MessageInvalidError("the type slot is missing or empty")
    if extras:
        fields["extras"] = tuple(extras)
    return Message(**fields)


def _other_slot(el: etree._Element, name: str, seen: set[str], extras: list[Slot]) -> None:
    """Handle a slot with no field: binarysizes (rebuilt from the chunks) or an unknown one."""
    if name in _DERIVED_SLOTS or name in _LISTED_EXTRAS:
        seen.add(name)  # defined by the spec, so at most once (OA-MSG-16)
    if name not in _DERIVED_SLOTS:
        extras.append(_read_extra(el))  # OA-MSG-5


def _local(tag: str) -> str:
    """Return the lower-cased local part of an element or attribute name (OA-MSG-3)."""
    if "}" in tag:
        tag = tag.rsplit("}", 1)[1]
    return tag.lower()


def _no_text(text: str | None, where: str) -> None:
    """Refuse non-whitespace text between elements (only indentation may sit there)."""
    if text and text.strip(_WS):
        raise MessageInvalidError(f"text {_clip(text)!r} between the elements of <{where}>")


def _attributes(el: etree._Element) -> dict[str, str]:
    """Return the attributes of `el` keyed by lower-cased name; a name given twice is invalid."""
    attrib = el.attrib
    if not attrib:
        return {}
    out: dict[str, str] = {}
    for key, value in attrib.items():
        name = _local(str(key))
        if name in out:  # the same attribute in two spellings (OA-MSG-3)
            raise MessageInvalidError(f"attribute {name!r} given twice on <{el.tag}>")
        out[name] = str(value)
    return out


def _read_root_attributes(root: etree._Element, fields: dict[str, Any], clamp: bool) -> None:
    """Read priority, timetolive and noreply; other root attributes are not kept."""
    attrs = _attributes(root)
    if (priority := attrs.get("priority")) is not None:
        fields["priority"] = _priority(priority, clamp)
    if (ttl := attrs.get("timetolive")) is not None:
        fields["timetolive"] = _decimal(ttl, "timetolive")
    if (noreply := attrs.get("noreply")) is not None:
        flag = _YES_NO.get(noreply.strip(_WS).lower())
        if flag is None:  # OA-MSG-15: yes or no, any case
            raise MessageInvalidError(f"noreply must be yes or no, got {noreply!r}")
        fields["noreply"] = flag


def _priority(text: str, clamp: bool) -> float:
    value = _decimal(text, "priority")
    if MIN_PRIORITY <= value <= MAX_PRIORITY:
        return value
    if clamp:  # OA-MSG-19: a legacy peer's 7.00 is read as 6.999, never refused
        return min(max(value, MIN_PRIORITY), MAX_PRIORITY)
    raise MessageInvalidError(f"priority {text!r} is outside 0.0-6.999")  # OA-MSG-6


def _text(el: etree._Element) -> str:
    """Return the text of a text slot; comments inside are skipped, elements are invalid."""
    if len(el) == 0:
        return el.text or ""
    parts = [el.text or ""]
    for child in el:
        if isinstance(child.tag, str):  # OA-MSG-9: these slots are text
            raise MessageInvalidError(f"slot <{el.tag}> must be text, found <{child.tag}>")
        parts.append(child.tail or "")
    return "".join(parts)


def _serialize(el: etree._Element) -> str:
    return etree.tostring(el, encoding="unicode", with_tail=False)


def _inner_elements(el: etree._Element, where: str) -> str:
    """Serialize the child elements of `el`; whitespace between them is dropped (OA-MSG-17)."""
    _no_text(el.text, where)
    parts: list[str] = []
    for child in el:
        if isinstance(child.tag, str):
            parts.append(_serialize(child))
        _no_text(child.tail, where)
    return "".join(parts)


def _inner_mixed(el: etree._Element) -> str:
    """Serialize the inside of an unknown slot: elements, and text other than indentation."""
    parts: list[str] = []
    if el.text and el.text.strip(_WS):
        parts.append(_escape(el.text))
    for child in el:
        if isinstance(child.tag, str):
            parts.append(_serialize(child))
        if child.tail and child.tail.strip(_WS):
            parts.append(_escape(child.tail))
    return "".join(parts)


def _escape(text: str) -> str:
    return (
        text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace("\r", "&#13;")
    )


def _read_extra(el: etree._Element) -> Slot:
    """Keep an unknown slot (OA-MSG-5): its text, or its inner XML when it holds elements."""
    name = el.tag.rsplit("}", 1)[-1] if isinstance(el.tag, str) else ""
    if any(isinstance(child.tag, str) for child in el):
        return Slot(name=name, value=_inner_mixed(el), is_xml=True)
    return Slot(name=name, value=_text(el))


def _read_content(el: etree._Element, fields: dict[str, Any]) -> None:
    """Read `content`: embedded XML under language="xml" (any case), text otherwise (OA-MSG-10)."""
    attrs = _attributes(el)
    language = attrs.get("language", "")
    fields["language"] = language
    if version := attrs.get("version", ""):  # OA-MSG-22: kept, never dropped
        fields["content_version"] = version
    if language.lower() == "xml":
        # Stray text is kept, not refused: the content is judged by the command that reads it
        # (an AIR.Retrieve of `garbage` is RETRIEVE_INVALID, OA-RET-10), and a relay passes it on.
        fields["content"] = _inner_mixed(el)
        fields["content_is_xml"] = True
    else:
        fields["content"] = _text(el)


def _read_posted(el: etree._Element, fields: dict[str, Any]) -> None:
    fields["posted"] = time_from_element(el)


def _read_received(el: etree._Element, fields: dict[str, Any]) -> None:
    fields["received"] = time_from_element(el)


def _read_wbid(el: etree._Element, fields: dict[str, Any]) -> None:
    text = _text(el).strip(_WS)
    if not _DIGITS.fullmatch(text):  # OA-MSG-13: a non-negative decimal integer
        raise MessageInvalidError(f"wbid must be a non-negative integer, got {_clip(text)!r}")
    fields["wbid"] = int(text)


def _read_history(el: etree._Element, fields: dict[str, Any]) -> None:
    fields["history"] = _inner_elements(el, "history")


def _read_inreplyto(el: etree._Element, fields: dict[str, Any]) -> None:
    """Read the one `<reference>` of `inreplyto` (OA-MSG-11)."""
    _no_text(el.text, "inreplyto")
    refs: list[etree._Element] = []
    for child in el:
        if isinstance(child.tag, str):
            if _local(child.tag) != "reference":
                raise MessageInvalidError(f"inreplyto holds <{child.tag}>, not <reference>")
            refs.append(child)
        _no_text(child.tail, "inreplyto")
    if len(refs) != 1:  # OA-MSG-11
        raise MessageInvalidError(f"inreplyto must hold one reference, found {len(refs)}")
    fields["inreplyto"] = _reference(refs[0])


def _reference(el: etree._Element) -> Reference:
    """Read a `<reference>`; its time is sec/msec or, as Psyclone writes, a postedTime child."""
    attrs = _attributes(el)
    time: AirTime | None = None
    if "sec" in attrs or "msec" in attrs or "ms" in attrs:
        time = _time_from_attributes(attrs, "reference")
    else:
        for child in el:
            if isinstance(child.tag, str) and _local(child.tag) == "postedtime":
                time = time_from_element(child)
    return Reference(
        id=attrs.get("id", ""),
        stored=attrs.get("stored", ""),
        type=attrs.get("type", ""),
        sender=attrs.get("from", ""),
        to=attrs.get("to", ""),
        cc=attrs.get("cc", ""),
        time=time,
    )


# Slots other than the text slots: lower-cased element name -> reader.
_READERS: dict[str, Callable[[etree._Element, dict[str, Any]], None]] = {
    "inreplyto": _read_inreplyto,
    "postedtime": _read_posted,
    "receivedtime": _read_received,
    "history": _read_history,
    "wbid": _read_wbid,
    "content": _read_content,
}


#: Every slot name with a field of its own or derived from one (an extra may not take them).
_KNOWN_SLOTS = frozenset(_TEXT_SLOTS) | frozenset(_READERS) | _DERIVED_SLOTS


# --------------------------------------------------------------------------------------- time


def time_from_element(el: etree._Element) -> AirTime:
    """Read a time element (OA-TIME-1): `sec`, `msec` (or `ms`), `usec`; `tzc` is ignored."""
    name = el.tag if isinstance(el.tag, str) else "time"
    return _time_from_attributes(_attributes(el), name)


def time_to_element(name: str, t: AirTime) -> etree._Element:
    """Write a time as `<name sec msec/>`, plus `usec` when the time has one (OA-TIME-5)."""
    el = etree.Element(name)
    el.set("sec", str(t.sec))
    el.set("msec", str(t.msec))
    if t.usec is not None:
        el.set("usec", str(t.usec))
    return el


# ----------------------------------------------------------------------------------- encoding


def encode_with_lxml(msg: Message) -> bytes:
    """Encode like `encode_message` but always with lxml (the reference for the fast path)."""
    return bytes(etree.tostring(message_to_element(msg), encoding="UTF-8"))


def encode_message(msg: Message) -> bytes:
    """Write `msg` in canonical form (spec 3.5): UTF-8 bytes, no XML declaration.

    Raises ApiMisuseError for a message that cannot be written: an empty type, a character XML
    1.0 forbids (OA-MSG-14), XML content that is not well-formed, an unknown slot whose name is
    not an XML name or shadows a known slot.
    """
    fast = fast_encode(msg)  # byte-identical for messages without embedded XML
    if fast is not None:
        return fast
    return encode_with_lxml(msg)


def to_frame(msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> Frame:
    """Build the Message or Receive frame for `msg`; its binary chunks follow the XML."""
    if tag is FrameTag.BINARY:
        raise ApiMisuseError("a message travels in a Message or Receive frame, not BinaryM")
    return Frame(tag=tag, xml=encode_message(msg), chunks=msg.binary)


def message_to_element(msg: Message) -> etree._Element:
    """Build the canonical `<message>` element for `msg` (see `encode_message`)."""
    if not msg.type:  # OA-MSG-2
        raise ApiMisuseError("a message needs a non-empty type")
    try:
        return _build(msg)
    except ValueError as exc:  # lxml refuses characters XML 1.0 does not allow
        raise ApiMisuseError(_misuse_detail(msg, exc)) from None


def _build(msg: Message) -> etree._Element:
    root = etree.Element("message")
    if msg.priority is not None:
        root.set("priority", _format_decimal(msg.priority, "priority"))
    if msg.timetolive is not None:
        root.set("timetolive", _format_decimal(msg.timetolive, "timetolive"))
    if msg.noreply:
        root.set("noreply", "yes")  # OA-MSG-15
    sub = etree.SubElement
    for name, value in (
        ("type", msg.type),
        ("id", msg.id),
        ("from", msg.sender),
        ("to", msg.to),
        ("cc", msg.cc),
        ("stored", msg.stored),
        ("isresponse", msg.isresponse),
    ):
        _set_text(sub(root, name), value)
    _build_middle(root, msg)
    root.append(_content_element(msg))
    for slot in msg.extras:
        root.append(_extra_element(slot))
    return root


def _build_middle(root: etree._Element, msg: Message) -> None:
    """Append the optional slots between isresponse and content, in canonical order."""
    sub = etree.SubElement
    if msg.inreplyto is not None:
        sub(root, "inreplyto").append(_reference_element(msg.inreplyto))
    if msg.posted is not None:  # a message received without one cannot be given one here
        root.append(time_to_element("postedTime", msg.posted))
    if msg.received is not None:
        root.append(time_to_element("receivedTime", msg.received))
    if msg.comment:
        _set_text(sub(root, "comment"), msg.comment)
    if msg.history:
        _graft(sub(root, "history"), msg.history, "history")
    if msg.wbid is not None:
        sub(root, "wbid").text = f"{msg.wbid:08d}"  # OA-MSG-13: at least 8 digits
    if msg.netprotocol:
        _set_text(sub(root, "netprotocol"), msg.netprotocol)
    if msg.binary:  # OA-FRAME-4
        sizes = [len(chunk) for chunk in msg.binary]
        sub(root, "binarysizes").text = ",".join(map(str, sizes))
        sub(root, "totalbinarysize").text = str(sum(sizes))


def _set_text(el: etree._Element, text: str) -> None:
    if text:  # an empty slot is written <cc/>
        el.text = text


def _format_decimal(value: float, what: str) -> str:
    """Write a decimal as the shortest digits that read back as `value`: 2.0, 0.5, 6.999."""
    text = grammar.decimal_text(value)
    if text is None:
        raise ApiMisuseError(f"{what} must be a finite number, got {value!r}")
    return text


def _reference_element(ref: Reference) -> etree._Element:
    """Write a `<reference>`: id always, the other attributes when set, then sec and msec."""
    el = etree.Element("reference")
    el.set("id", ref.id)
    for name, value in (
        ("type", ref.type),
        ("from", ref.sender),
        ("to", ref.to),
        ("cc", ref.cc),
        ("stored", ref.stored),
    ):
        if value:
            el.set(name, value)
    if ref.time is not None:  # schemas/message.xsd ReferenceType has no usec
        el.set("sec", str(ref.time.sec))
        el.set("msec", str(ref.time.msec))
    return el


def _content_element(msg: Message) -> etree._Element:
    """Write `content`, always present (OA-MSG-4); XML content unescaped (OA-MSG-10)."""
    el = etree.Element("content")
    language = msg.language
    is_xml_language = language.lower() == "xml"
    if msg.content_is_xml:
        el.set("language", language if is_xml_language else "xml")
        if msg.content_version:  # OA-MSG-22: after language, only when not empty
            el.set("version", msg.content_version)
        if msg.content:
            _graft(el, msg.content, "content")
        return el
    if is_xml_language:
        raise ApiMisuseError(f"text content cannot be labelled language={language!r}")
    el.set("language", language)
    if msg.content_version:  # OA-MSG-22
        el.set("version", msg.content_version)
    _set_text(el, msg.content)
    return el


def _graft_fragment(el: etree._Element, xml: str) -> None:
    """Append the elements of XML content to `el` (OA-MSG-10), parsed, never concatenated."""
    try:
        children = parse_fragment(xml)
    except (OpenAIRError, UnicodeError) as exc:  # the caller's string, not the peer's
        raise ApiMisuseError(f"content is not well-formed XML content: {exc}") from None
    for child in children:
        child.tail = None
        el.append(child)


def _graft(el: etree._Element, xml: str, where: str) -> None:
    """Copy inner XML (elements and text) into `el` via the hardened parser."""
    try:
        wrapper = parse_xml(b"<x>" + xml.encode("utf-8") + b"</x>")
    except (OpenAIRError, UnicodeError) as exc:  # the caller's string is not XML
        raise ApiMisuseError(f"{where} is not well-formed inner XML: {exc}") from None
    el.text = wrapper.text
    for child in list(wrapper):
        el.append(child)


def _extra_element(slot: Slot) -> etree._Element:
    """Write an unknown slot under its own name (OA-MSG-5)."""
    name = slot.name
    if _local(name) in _KNOWN_SLOTS:
        raise ApiMisuseError(f"extension slot {name!r} has the name of a known slot")
    try:
        el = etree.Element(name)
    except ValueError:
        raise ApiMisuseError(f"extension slot name {name!r} is not an XML name") from None
    if slot.is_xml:
        _graft(el, slot.value, f"extension slot {name!r}")
    else:
        _set_text(el, slot.value)
    return el


def _misuse_detail(msg: Message, exc: ValueError) -> str:
    """Name the first field holding a character XML 1.0 forbids (OA-MSG-14)."""
    candidates: list[tuple[str, str]] = [
        (name, value) for name, value in _text_fields(msg) if _NOT_XML_CHAR.search(value)
    ]
    if not candidates:
        return f"the message cannot be written as XML: {exc}"
    name, value = candidates[0]
    bad = _NOT_XML_CHAR.search(value)
    char = bad.group() if bad else "?"
    return f"{name} holds U+{ord(char):04X}, which XML 1.0 does not allow (OA-MSG-14)"


def _text_fields(msg: Message) -> list[tuple[str, str]]:
    fields = [
        ("type", msg.type),
        ("id", msg.id),
        ("from", msg.sender),
        ("to", msg.to),
        ("cc", msg.cc),
        ("stored", msg.stored),
        ("isresponse", msg.isresponse),
        ("comment", msg.comment),
        ("netprotocol", msg.netprotocol),
        ("language", msg.language),
        ("content", msg.content),
    ]
    if msg.inreplyto is not None:
        ref = msg.inreplyto
        fields += [(f"inreplyto {k}", v) for k, v in (("id", ref.id), ("type", ref.type))]
        fields += [("inreplyto from", ref.sender), ("inreplyto to", ref.to)]
        fields += [("inreplyto cc", ref.cc), ("inreplyto stored", ref.stored)]
    fields += [(f"slot {slot.name!r}", slot.value) for slot in msg.extras]
    return fields
