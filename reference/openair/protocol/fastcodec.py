"""A strict fast path for the common shapes of `codec.py`: reading and writing without lxml.

`fast_decode` reads simple documents only: a `<message>` whose slots are elements holding
nothing but text (no DOCTYPE, comment, processing instruction or CDATA, only the predefined
entities and character references, ASCII names without prefixes, depth 2). It returns None —
"not sure" — for anything else, including every input that would be an error, so the lxml path
in `codec.decode_message` decides those and the two paths cannot disagree on an error. No
entity is ever expanded beyond the five predefined ones and character references (OA-SEC-1/2);
the depth is 2, within every depth limit of 2 or more (OA-LIM-3).

`fast_encode` writes the canonical form of spec 3.5 for messages without embedded XML (text
content, text extension slots, no history) and returns None otherwise; its output is
byte-identical to lxml's serialization (tests/perf_equiv checks both directions).
"""

from __future__ import annotations

import re
from typing import Any

from openair.protocol import grammar
from openair.protocol.message import FIELDS, MAX_PRIORITY, MIN_PRIORITY, Message, Reference, Slot
from openair.protocol.times import AirTime
from openair.protocol.xmlsafe import XmlLimits

# The grammar both codecs share (slots, number patterns, the decimal writer).
_WS, _INT, _UINT, _DIGITS, _DECIMAL = (
    grammar.WS,
    grammar.INT,
    grammar.UINT,
    grammar.DIGITS,
    grammar.DECIMAL,
)
_MAX_SEC, _MIN_SEC, _NOT_XML_CHAR = grammar.MAX_SEC, grammar.MIN_SEC, grammar.NOT_XML_CHAR
_TEXT_SLOTS, _DERIVED = grammar.TEXT_SLOTS, grammar.DERIVED_SLOTS
_format_decimal = grammar.short_decimal_text  # exponent forms: the lxml path

__all__ = [
    "derived",
    "escape_attr",
    "escape_text",
    "fast_decode",
    "fast_encode",
    "fast_encode_str",
    "text_slot_xml",
    "time_xml",
]

_NAME = r"[A-Za-z_][A-Za-z0-9._-]*"
_ATTRS = rf"(?:[ \t\n]+{_NAME}[ \t\n]*=[ \t\n]*(?:\"[^\"<]*\"|'[^'<]*'))*"
_DECL = re.compile(r"<\?xml version=\"1\.0\"(?: encoding=\"(?:UTF|utf)-8\")?\?>[ \t\n]*")
_ROOT = re.compile(rf"<([Mm][Ee][Ss][Ss][Aa][Gg][Ee])({_ATTRS})[ \t\n]*>[ \t\n]*")
_CHILD = re.compile(rf"<({_NAME})({_ATTRS})[ \t\n]*(?:/>|>([^<]*)</\1[ \t\n]*>)[ \t\n]*")
_ATTR = re.compile(rf"({_NAME})[ \t\n]*=[ \t\n]*(?:\"([^\"<]*)\"|'([^'<]*)')")
# Characters a document may hold as they are; \r is left to lxml (line-end normalisation).
_BAD_CHAR = re.compile("[^\t\n\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")
_ENTITY = re.compile(r"&(?:(amp|lt|gt|quot|apos)|#([0-9]{1,7})|#x([0-9a-fA-F]{1,6}));")
_BARE_AMP = re.compile(r"&(?!(?:amp|lt|gt|quot|apos|#[0-9]{1,7}|#x[0-9a-fA-F]{1,6});)")
_PREDEFINED = {"amp": "&", "lt": "<", "gt": ">", "quot": '"', "apos": "'"}
_NOT_EXTRAS = frozenset(_TEXT_SLOTS) | _DERIVED | {"postedtime", "receivedtime", "content", "wbid"}
_DECLINED = frozenset({"inreplyto", "history"})
_NO_ATTRS: dict[str, str] = {}


# Text in the canonical layout: any character but `<` and those XML forbids (\r included:
# parsers normalise it), so a match of the whole layout is also the character check.
_TEXT = "[^<\x00-\x08\x0b-\x1f\ufffe\uffff]"


def _slot_re(name: str) -> str:
    return rf"(?:<{name}>({_TEXT}*)</{name}>|<{name}/>)"


def _time_re(name: str) -> str:
    return (
        rf'(?:<{name} sec="(-?[0-9]{{1,19}})" msec="([0-9]{{1,3}})"(?: usec="([0-9]{{1,3}})")?/>)?'
    )


# The canonical layout (spec 3.5) and the loadgen/JavaOpenAIR `<cc></cc>` spelling in one match;
# anything else goes through the general scanner below.
_CANONICAL = re.compile(
    r'<message(?: priority="([0-9.]{1,32})")?(?: timetolive="(-?[0-9.]{1,32})")?'
    r'(?: noreply="(yes|no)")?>'
    + "".join(_slot_re(n) for n in ("type", "id", "from", "to", "cc", "stored", "isresponse"))
    + _time_re("postedTime")
    + _time_re("receivedTime")
    + f"{_slot_re('comment')}?"
    + r"(?:<wbid>([0-9]{1,30})</wbid>)?"
    + f"{_slot_re('netprotocol')}?"
    + '<content language="([^"<&\t\n\x00-\x08\x0b-\x1f\ufffe\uffff]*)"'
    + f"(?:/>|>({_TEXT}*)</content>)</message>"
)
_FIELDS = FIELDS
_DEFAULTS = tuple(getattr(Message.trusted(type="-"), name) for name in _FIELDS)
_AT = {name: i for i, name in enumerate(_FIELDS)}
_TYPE, _ID, _SENDER, _TO, _CC = (_AT[n] for n in ("type", "id", "sender", "to", "cc"))
_STORED, _ISRESPONSE, _POSTED = (_AT[n] for n in ("stored", "isresponse", "posted"))
_RECEIVED, _PRIORITY, _TIMETOLIVE = (_AT[n] for n in ("received", "priority", "timetolive"))
_NOREPLY, _LANGUAGE, _CONTENT = (_AT[n] for n in ("noreply", "language", "content"))
_CONTENT_IS_XML, _COMMENT, _WBID = (_AT[n] for n in ("content_is_xml", "comment", "wbid"))
_NETPROTOCOL, _BINARY = _AT["netprotocol"], _AT["binary"]
#: The decoder's patterns validated every value: it builds with the trusted constructor.
_new_message = Message.trusted_row


def derived(msg: Message, **changes: Any) -> Message:
    """`Message.trusted_replace` (the trusted constructor), under its earlier name."""
    return msg.trusted_replace(**changes)


class _Decline(Exception):
    """The fast path is not sure: let the lxml path decide."""


# ----------------------------------------------------------------------------------- decoding


def fast_decode(
    xml: bytes | bytearray,
    chunks: tuple[bytes, ...] = (),
    limits: XmlLimits | None = None,
    *,
    clamp_priority: bool = False,
) -> Message | None:
    """Decode a simple message document, or return None to leave it to the lxml path.

    `clamp_priority` reads an out-of-range priority as the nearest end of 0.0-6.999, exactly as
    `codec.decode_message` does (OA-MSG-19); without it such a document is declined.
    """
    if limits is not None and (len(xml) > limits.max_bytes or limits.max_depth < 2):
        return None  # OA-LIM-1, OA-LIM-3: the lxml path reports the limit
    try:
        text = xml.decode("utf-8")
    except UnicodeDecodeError:
        return None
    if "]]>" in text:
        return None  # the sequence XML forbids in text
    try:
        groups = _canonical_groups(text)  # its text classes exclude what OA-MSG-14 forbids
        if groups is not None:
            return _canonical(groups, "&" in text, chunks, clamp_priority)
        if _BAD_CHAR.search(text) is not None:
            return None  # OA-MSG-14: the lxml path refuses it
        return _decode(text, chunks, clamp_priority)
    except _Decline:
        return None


#: Past this many characters the content of a canonical document is checked apart (below).
_LARGE = 64 * 1024
_CONTENT_AT = '<content language="'
_BODY_END = "</content></message>"
#: The ASCII characters `_TEXT` allows: tab, newline, 0x20 on, but not `<`.
_TEXT_ASCII = bytes([9, 10, *(c for c in range(0x20, 0x80) if c != 0x3C)])
_NOT_TEXT = re.compile("[" + _TEXT[2:])  # a character `_TEXT` does not allow


def _canonical_groups(text: str) -> tuple[Any, ...] | None:
    """Return the groups of `_CANONICAL.fullmatch(text)`, or None when it does not match.

    A large document's content is not scanned by the expression (a megabyte held the lock 2.7 ms
    on the worker while the loop waited, issue #19): the envelope is matched with an empty
    content, the content checked for `_TEXT`'s characters at memory speed, in windows.
    """
    if len(text) <= _LARGE or not text.endswith(_BODY_END):
        found = _CANONICAL.fullmatch(text)
        return None if found is None else found.groups()
    at = text.find(_CONTENT_AT)
    quote = text.find('"', at + len(_CONTENT_AT)) if at >= 0 else -1
    if quote < 0 or text[quote + 1 : quote + 2] != ">":
        found = _CANONICAL.fullmatch(text)  # `<content .../>` or not canonical: as it is
        return None if found is None else found.groups()
    body = text[quote + 2 : len(text) - len(_BODY_END)]
    if not _plain_text(body):
        return None  # a `<` or a character XML forbids: not this layout
    found = _CANONICAL.fullmatch(text[: quote + 2] + _BODY_END)
    if found is None:
        return None
    groups = found.groups()
    return (*groups[:-1], body)  # the content is the last group


def _plain_text(body: str) -> bool:
    """Whether `_TEXT*` matches the whole of `body` (read in windows, `grammar`)."""
    return not grammar.has_char_outside(body, _TEXT_ASCII, _NOT_TEXT)


def _canonical(g: tuple[Any, ...], amp: bool, chunks: tuple[bytes, ...], clamp: bool) -> Message:
    """Build the Message of a document in the canonical layout (groups of `_CANONICAL`)."""
    if amp:  # expand the entities of every text group (attributes hold none: see the pattern)
        g = tuple(_unescape(v) if v and "&" in v else v for v in g)
    values = list(_DEFAULTS)
    values[_TYPE] = g[3]
    if not g[3]:  # OA-MSG-2: the lxml path raises
        raise _Decline
    values[_ID] = g[4] or ""
    values[_SENDER] = g[5] or ""
    values[_TO] = g[6] or ""
    values[_CC] = g[7] or ""
    values[_STORED] = g[8] or ""
    values[_ISRESPONSE] = g[9] or ""
    if g[0] is not None:
        values[_PRIORITY] = _priority(g[0], clamp)
    if g[1] is not None:
        values[_TIMETOLIVE] = _decimal(g[1])
    if g[2] is not None:
        values[_NOREPLY] = g[2] == "yes"
    if g[10] is not None:
        values[_POSTED] = _time_of(g[10], g[11], g[12])
    if g[13] is not None:
        values[_RECEIVED] = _time_of(g[13], g[14], g[15])
    values[_COMMENT] = g[16] or ""
    if g[17] is not None:
        values[_WBID] = int(g[17])
    values[_NETPROTOCOL] = g[18] or ""
    language = g[19]
    body = g[20] or ""
    values[_LANGUAGE] = language
    if language.lower() == "xml":  # text only: the lxml path keeps it escaped
        values[_CONTENT] = escape_text(body) if body.strip(_WS) else ""
        values[_CONTENT_IS_XML] = True
    else:
        values[_CONTENT] = body
    values[_BINARY] = chunks
    return _new_message(values)


def _priority(text: str, clamp: bool) -> float:
    number = _decimal(text)
    if MIN_PRIORITY <= number <= MAX_PRIORITY:
        return number
    if clamp:  # OA-MSG-19: read as the nearest end of the range, as the lxml path does
        return min(max(number, MIN_PRIORITY), MAX_PRIORITY)
    raise _Decline  # OA-MSG-6: the lxml path raises


_TIMES: dict[tuple[str, str, str | None], AirTime] = {}  # times repeat within a burst
_TIMES_MAX = 256


def _time_of(sec_text: str, msec_text: str, usec_text: str | None) -> AirTime:
    key = (sec_text, msec_text, usec_text)
    known = _TIMES.get(key)
    if known is not None:
        return known
    if len(_TIMES) >= _TIMES_MAX:
        _TIMES.clear()
    known = _TIMES[key] = _new_time(sec_text, msec_text, usec_text)
    return known


def _new_time(sec_text: str, msec_text: str, usec_text: str | None) -> AirTime:
    sec, msec = int(sec_text), int(msec_text)
    usec = None if usec_text is None else int(usec_text)
    if not _MIN_SEC <= sec <= _MAX_SEC or msec > 999 or (usec is not None and usec > 999):
        raise _Decline  # OA-TIME-6
    return AirTime(sec=sec, msec=msec, usec=usec)


def _decode(text: str, chunks: tuple[bytes, ...], clamp: bool) -> Message | None:
    pos = 0
    if text.startswith("<?"):
        decl = _DECL.match(text)
        if decl is None:
            return None
        pos = decl.end()
    root = _ROOT.match(text, pos)
    if root is None:
        return None
    fields: dict[str, Any] = {"id": "", "binary": chunks}
    if root.group(2):
        _root_attributes(root.group(2), fields, clamp)
    seen: set[str] = set()
    extras: list[Slot] = []
    pos = root.end()
    child = _CHILD.match
    while (m := child(text, pos)) is not None:
        pos = m.end()
        tag = m.group(1)
        name = tag.lower()
        # duplicate attributes are not well-formed: _attributes declines them everywhere
        attrs = _attributes(m.group(2)) if m.group(2) else _NO_ATTRS
        if name in seen:  # OA-MSG-16: the lxml path raises
            return None
        body = m.group(3) or ""
        if "&" in body:
            body = _unescape(body)
        field = _TEXT_SLOTS.get(name)
        if field is not None:
            seen.add(name)
            fields[field] = body
        elif name in _NOT_EXTRAS or name in _DECLINED:
            seen.add(name)
            _special_slot(name, attrs, body, fields)
        else:
            if name == "extensions":
                seen.add(name)
            extras.append(Slot(name=tag, value=body))  # OA-MSG-5
    end = f"</{root.group(1)}"
    if not text.startswith(end, pos) or text[pos + len(end) :].strip(" \t\n") != ">":
        return None
    if not fields.get("type"):  # OA-MSG-2: the lxml path raises
        return None
    if extras:
        fields["extras"] = tuple(extras)
    values = list(_DEFAULTS)
    for key, value in fields.items():
        values[_AT[key]] = value
    return _new_message(values)


def _special_slot(name: str, attrs: dict[str, str], body: str, fields: dict[str, Any]) -> None:
    """Read postedTime, receivedTime, content or wbid; decline inreplyto and history."""
    if name == "content":
        language = attrs.get("language", "")
        fields["language"] = language
        if version := attrs.get("version", ""):  # OA-MSG-22
            fields["content_version"] = version
        if language.lower() == "xml":  # text only: the lxml path keeps it escaped
            fields["content"] = escape_text(body) if body.strip(_WS) else ""
            fields["content_is_xml"] = True
        else:
            fields["content"] = body
    elif name == "postedtime":
        fields["posted"] = _time(attrs)
    elif name == "receivedtime":
        fields["received"] = _time(attrs)
    elif name == "wbid":
        digits = body.strip(_WS)
        if not _DIGITS.fullmatch(digits):
            raise _Decline
        fields["wbid"] = int(digits)
    elif name == "history" and not body.strip(_WS):
        fields["history"] = ""
    elif name not in _DERIVED:
        raise _Decline  # inreplyto (a child element) or history with text


def _unescape(body: str) -> str:
    """Expand the predefined entities and character references; decline anything else."""
    if _BARE_AMP.search(body) is not None:
        raise _Decline  # a bare & or an undefined entity (OA-SEC-1): the lxml path refuses it
    return _ENTITY.sub(_expand, body)


def _expand(m: re.Match[str]) -> str:
    if m.group(1) is not None:
        return _PREDEFINED[m.group(1)]
    code = int(m.group(2)) if m.group(2) is not None else int(m.group(3), 16)
    if code == 13:
        return "\r"  # a reference, so not normalised away
    char = chr(code) if code <= 0x10FFFF else "\x00"
    if _BAD_CHAR.match(char) is not None:
        raise _Decline  # not an XML character: the lxml path refuses it
    return char


def _attributes(attrs: str) -> dict[str, str]:
    """Return attributes keyed by lower-cased name; decline duplicates and odd values."""
    out: dict[str, str] = {}
    for name, dq, sq in _ATTR.findall(attrs):
        key = name.lower()
        if key in out or key.startswith("xmlns"):
            raise _Decline
        value = dq or sq
        if "\t" in value or "\n" in value:
            raise _Decline  # attribute-value normalisation: left to lxml
        out[key] = _unescape(value) if "&" in value else value
    return out


def _root_attributes(attrs: str, fields: dict[str, Any], clamp: bool) -> None:
    for key, value in _attributes(attrs).items():
        if key == "priority":
            fields["priority"] = _priority(value, clamp)
        elif key == "timetolive":
            fields["timetolive"] = _decimal(value)
        elif key == "noreply":
            flag = value.strip(_WS).lower()
            if flag not in ("yes", "no"):  # OA-MSG-15
                raise _Decline
            fields["noreply"] = flag == "yes"


def _decimal(text: str) -> float:
    stripped = text.strip(_WS)
    if not _DECIMAL.fullmatch(stripped):
        raise _Decline
    return float(stripped) + 0.0


def _time(found: dict[str, str]) -> AirTime:
    """Read sec, msec (or ms) and usec (OA-TIME-1, OA-TIME-5); decline any bad value."""
    sec_text = found.get("sec")
    if sec_text is None:
        raise _Decline
    sec = _integer(sec_text, _INT)
    msec_text = found.get("msec", found.get("ms"))
    msec = 0 if msec_text is None else _integer(msec_text, _UINT)
    usec_text = found.get("usec")
    usec = None if usec_text is None else _integer(usec_text, _UINT)
    if not _MIN_SEC <= sec <= _MAX_SEC or msec > 999 or (usec is not None and usec > 999):
        raise _Decline  # OA-TIME-6
    return AirTime(sec=sec, msec=msec, usec=usec)


def _integer(text: str, pattern: re.Pattern[str]) -> int:
    stripped = text.strip(_WS)
    if not pattern.fullmatch(stripped):
        raise _Decline
    return int(stripped)


# ----------------------------------------------------------------------------------- encoding

_EXTRA_NAME = re.compile(_NAME)
_KNOWN_LOWER = frozenset(
    (*_TEXT_SLOTS, *_DERIVED, "inreplyto", "postedtime", "receivedtime", "history", "wbid")
) | {"content"}


def escape_text(text: str) -> str:
    """Escape text content exactly as libxml2 serializes it."""
    if "&" in text:
        text = text.replace("&", "&amp;")
    if "<" in text:
        text = text.replace("<", "&lt;")
    if ">" in text:
        text = text.replace(">", "&gt;")
    if "\r" in text:
        text = text.replace("\r", "&#13;")
    return text


_ATTR_ESCAPES = str.maketrans(
    {
        "&": "&amp;",
        "<": "&lt;",
        ">": "&gt;",
        '"': "&quot;",
        "\t": "&#9;",
        "\n": "&#10;",
        "\r": "&#13;",
    }
)
_ATTR_SPECIAL = re.compile('[&<>"\t\n\r]')


def escape_attr(value: str) -> str:
    """Escape an attribute value exactly as libxml2 serializes it (double quotes)."""
    return value.translate(_ATTR_ESCAPES) if _ATTR_SPECIAL.search(value) else value


def _slot(name: str, text: str) -> str:
    return f"<{name}>{escape_text(text)}</{name}>" if text else f"<{name}/>"


def text_slot_xml(name: str, text: str) -> str | None:
    """Write a text slot as the canonical writer does, or None for text XML cannot carry."""
    return None if _NOT_XML_CHAR.search(text) else _slot(name, text)


def time_xml(name: str, t: AirTime) -> str:
    """Write a time element as the canonical writer does (OA-TIME-1, OA-TIME-5)."""
    return _time_el(name, t)


def _time_el(name: str, t: AirTime) -> str:
    usec = f' usec="{t.usec}"' if t.usec is not None else ""
    return f'<{name} sec="{t.sec}" msec="{t.msec}"{usec}/>'


def _reference(ref: Reference) -> str:
    parts = [f'<inreplyto><reference id="{escape_attr(ref.id)}"']
    for name, value in (
        ("type", ref.type),
        ("from", ref.sender),
        ("to", ref.to),
        ("cc", ref.cc),
        ("stored", ref.stored),
    ):
        if value:
            parts.append(f' {name}="{escape_attr(value)}"')
    if ref.time is not None:
        parts.append(f' sec="{ref.time.sec}" msec="{ref.time.msec}"')
    parts.append("/></inreplyto>")
    return "".join(parts)


def _root_tag(msg: Message) -> str | None:
    attrs = []
    if msg.priority is not None:
        text = _format_decimal(msg.priority)
        if text is None:
            return None
        attrs.append(f' priority="{text}"')
    if msg.timetolive is not None:
        text = _format_decimal(msg.timetolive)
        if text is None:
            return None
        attrs.append(f' timetolive="{text}"')
    if msg.noreply:
        attrs.append(' noreply="yes"')
    return "<message" + "".join(attrs) + ">"


def _encodable(msg: Message, xml_content: bool) -> bool:
    """Whether every part of `msg` is something this writer produces exactly like lxml."""
    if not msg.type or msg.history or (msg.content_is_xml and not xml_content):
        return False
    if not msg.content_is_xml and msg.language.lower() == "xml":
        return False  # ApiMisuseError on the lxml path
    for slot in msg.extras:
        name = slot.name
        if slot.is_xml or not _EXTRA_NAME.fullmatch(name) or name.lower() in _KNOWN_LOWER:
            return False
    texts = [msg.type, msg.id, msg.sender, msg.to, msg.cc, msg.stored, msg.isresponse]
    texts += (msg.comment, msg.netprotocol, msg.language, msg.content_version)
    texts.extend(slot.value for slot in msg.extras)
    ref = msg.inreplyto
    if ref is not None:
        texts += (ref.id, ref.type, ref.sender, ref.to, ref.cc, ref.stored)
    content = "" if msg.content_is_xml else msg.content
    if len(content) <= _LARGE:  # one check for all; a large content apart (one copy less)
        texts.append(content)
        content = ""
    # OA-MSG-14: lxml raises
    if grammar.has_non_xml_char("".join(texts)):
        return False
    return not content or not grammar.has_non_xml_char(content)


def fast_encode_str(msg: Message, *, xml_content: bool = False) -> str | None:
    """Write `msg` canonically as text, or return None when only the lxml path can.

    With `xml_content`, XML content is spliced in as it is: only for content this kit
    serialized itself with lxml (serialization is idempotent, so grafting changes nothing).
    """
    if not _encodable(msg, xml_content):
        return None
    root = _root_tag(msg)
    if root is None:
        return None
    parts = [
        root,
        f"<type>{escape_text(msg.type)}</type>",
        _slot("id", msg.id),
        _slot("from", msg.sender),
        _slot("to", msg.to),
        _slot("cc", msg.cc),
        _slot("stored", msg.stored),
        _slot("isresponse", msg.isresponse),
    ]
    _middle(msg, parts)
    language = escape_attr(msg.language if not msg.content_is_xml else _xml_language(msg))
    if msg.content_version:  # OA-MSG-22: after language
        language += f'" version="{escape_attr(msg.content_version)}'
    body = msg.content if msg.content_is_xml else escape_text(msg.content)
    if body:
        parts.append(f'<content language="{language}">{body}</content>')
    else:
        parts.append(f'<content language="{language}"/>')
    for slot in msg.extras:
        parts.append(_slot(slot.name, slot.value))
    parts.append("</message>")
    return "".join(parts)


def _xml_language(msg: Message) -> str:
    return msg.language if msg.language.lower() == "xml" else "xml"


def _middle(msg: Message, parts: list[str]) -> None:
    if msg.inreplyto is not None:
        parts.append(_reference(msg.inreplyto))
    if msg.posted is not None:
        parts.append(_time_el("postedTime", msg.posted))
    if msg.received is not None:
        parts.append(_time_el("receivedTime", msg.received))
    if msg.comment:
        parts.append(_slot("comment", msg.comment))
    if msg.wbid is not None:
        parts.append(f"<wbid>{msg.wbid:08d}</wbid>")  # OA-MSG-13
    if msg.netprotocol:
        parts.append(_slot("netprotocol", msg.netprotocol))
    if msg.binary:  # OA-FRAME-4
        sizes = [len(chunk) for chunk in msg.binary]
        parts.append(f"<binarysizes>{','.join(map(str, sizes))}</binarysizes>")
        parts.append(f"<totalbinarysize>{sum(sizes)}</totalbinarysize>")


def fast_encode(msg: Message) -> bytes | None:
    """Return the canonical UTF-8 bytes of `msg`, or None when only the lxml path can."""
    text = fast_encode_str(msg)
    return None if text is None else text.encode("utf-8")
