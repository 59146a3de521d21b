"""Content objects carried in `<content language="xml">` (spec 3.4, 15.1): readers and writers.

Readers take the content text of a message, parse it with the hardened parser
(`xmlsafe.parse_fragment`) and match element and attribute names in any case (OA-MSG-3). Writers
build lxml elements and serialize them in the canonical spelling, so what they write always
parses back to the same value. Content that is not the object asked for is CONTENT_INVALID
(OA-MSG-12); XML that is not well-formed is reported as CONTENT_INVALID too, while forbidden or
too deep XML keeps its own condition (XML_FORBIDDEN, XML_TOO_DEEP).

The small helpers at the top (`attr`, `elements`, `parse_root`, `element`, `serialize`, …) are
shared with `registration.py` and `wakeup.py`; so are the `<retrieve>` element reader and writer
at the bottom (`read_retrieve`, `retrieve_element`), whose public wrappers (`parse_retrieves`,
`encode_retrieve`, …) live in `registration.py` with the rest of spec sections 8 and 9.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from lxml import etree

from openair.protocol._errors_base import OpenAIRError
from openair.protocol.codec import (
    message_from_element,
    message_to_element,
    time_from_element,
    time_to_element,
)
from openair.protocol.content import ContentMatch, Dictionary, RetrieveSpec, TcpLocation
from openair.protocol.errors import (
    ApiMisuseError,
    ContentInvalidError,
    MessageInvalidError,
    RetrieveInvalidError,
    XmlMalformedError,
)
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.types import is_valid_pattern, validate_pattern
from openair.protocol.xmlsafe import local_name, parse_fragment

__all__ = [
    "MAX_INT64",
    "Capabilities",
    "attr",
    "element",
    "elements",
    "encode_capabilities",
    "encode_dictionary",
    "encode_message_collection",
    "encode_tcplocation",
    "encode_time",
    "inner_text",
    "message_collection_element",
    "parse_capabilities",
    "parse_content",
    "parse_dictionary",
    "parse_integer",
    "parse_message_collection",
    "parse_root",
    "parse_tcplocation",
    "parse_time",
    "read_message_collection",
    "read_retrieve",
    "read_retrieves_group",
    "retrieve_element",
    "retrieves_element",
    "serialize",
    "single_child",
    "time_bound",
]

MAX_INT64 = 2**63 - 1
_CONTEXT_CRITERIA = ("before", "during", "after", "beforecontext", "duringcontext", "aftercontext")
_INTEGER = re.compile(r"[+-]?[0-9]{1,19}")
_INT32 = (-(2**31), 2**31 - 1)  # xs:int, the schema type of tcplocation's port


# --------------------------------------------------------------------------------------------
# Shared helpers
# --------------------------------------------------------------------------------------------


def attr(el: etree._Element, name: str) -> str | None:
    """Return the attribute `name` of `el`, its name matched in any case (OA-MSG-3), or None."""
    exact = el.get(name)
    if exact is not None:
        return exact
    wanted = name.lower()
    for key, value in el.attrib.items():
        if str(key).rsplit("}", 1)[-1].lower() == wanted:
            return str(value)
    return None


def elements(el: etree._Element) -> list[etree._Element]:
    """Return the child elements of `el` (comments and processing instructions skipped)."""
    return [child for child in el if isinstance(child.tag, str)]


def parse_root(content: str, names: Iterable[str], error: type[OpenAIRError]) -> etree._Element:
    """Parse `content` as exactly one element whose lower-cased name is in `names`.

    Raises `error` (an OpenAIRError class taking a detail) when the content is empty, not
    well-formed, more than one element, or another element.
    """
    allowed = tuple(names)
    roots = parse_content(content, error)
    if len(roots) != 1 or local_name(roots[0]) not in allowed:
        found = ", ".join(f"<{local_name(r)}>" for r in roots) or "no element"
        wanted = " or ".join(f"<{n}>" for n in allowed)
        raise error(f"content must be one {wanted}, found {found}")
    return roots[0]


def parse_content(content: str, error: type[OpenAIRError]) -> list[etree._Element]:
    """Parse XML content into its top-level elements; XML_MALFORMED becomes `error`."""
    try:
        return parse_fragment(content)
    except XmlMalformedError as exc:
        raise error(f"content is not well-formed XML: {exc.detail}") from None


def element(tag: str, attrs: Iterable[tuple[str, str]] = (), text: str = "") -> etree._Element:
    """Build an element with attributes in the given order; characters XML forbids are misuse."""
    try:
        el = etree.Element(tag)
        for key, value in attrs:
            el.set(key, value)
        if text:
            el.text = text
    except ValueError as exc:  # OA-MSG-14: lxml refuses characters XML 1.0 cannot carry
        raise ApiMisuseError(f"cannot write <{tag}>: {exc}") from None
    return el


def inner_text(el: etree._Element) -> str:
    """Return the text inside `el`, its descendants' text included."""
    return "".join(str(t) for t in el.itertext())


def serialize(el: etree._Element) -> str:
    """Serialize an element as XML text without declaration or indentation."""
    return str(etree.tostring(el, encoding="unicode"))


def parse_integer(text: str | None) -> int | None:
    """Return the decimal integer in `text` (surrounding white space allowed), else None."""
    if text is None:
        return None
    stripped = text.strip()
    if not _INTEGER.fullmatch(stripped):
        return None
    return int(stripped)


def single_child(el: etree._Element, what: str, error: type[OpenAIRError]) -> etree._Element:
    """Return the one element inside an `<object>` (spec 3.4), else raise `error`."""
    children = elements(el)
    if len(children) != 1:
        raise error(f"{what} must hold exactly one element, found {len(children)}")
    return children[0]


# --------------------------------------------------------------------------------------------
# Capabilities (spec 15.1)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class Capabilities:
    """The content of a CAPABILITIES reply (OA-CAP-1): extensions and limits, in order."""

    protocol: str = "OpenAIR/1.0"
    server: str = ""
    extensions: tuple[str, ...] = ()
    limits: tuple[tuple[str, int], ...] = ()

    def limit(self, name: str, default: int) -> int:
        """Return the advertised value of the limit `name`, or `default` (OA-CAP-2)."""
        return next((v for k, v in self.limits if k == name), default)


def parse_capabilities(content: str) -> Capabilities:
    """Read `<capabilities protocol server>` with `<extension>` and `<limit>` children.

    `protocol` and `server` are required (OA-CAP-1). Names are kept as written; a client
    ignores the ones it does not know (OA-CAP-3, OA-EXT-1), so unknown children are skipped
    too. A repeated extension or limit keeps its first occurrence.
    """
    root = parse_root(content, ("capabilities",), ContentInvalidError)
    protocol, server = attr(root, "protocol"), attr(root, "server")
    if not protocol:
        raise ContentInvalidError("capabilities without a protocol")  # OA-CAP-1
    if server is None:
        raise ContentInvalidError("capabilities without a server")  # OA-CAP-1
    extensions: list[str] = []
    limits: dict[str, int] = {}
    for child in elements(root):
        kind = local_name(child)
        if kind not in ("extension", "limit"):
            continue  # OA-CAP-3: what a client does not know, it ignores
        name = attr(child, "name")
        if not name:
            raise ContentInvalidError(f"<{kind}> without a name")
        if kind == "extension":
            if name not in extensions:
                extensions.append(name)
            continue
        value = parse_integer(attr(child, "value"))
        if value is None or value < 0:
            raise ContentInvalidError(f"limit {name!r} has no non-negative integer value")
        limits.setdefault(name, value)
    return Capabilities(
        protocol=protocol,
        server=server,
        extensions=tuple(extensions),
        limits=tuple(limits.items()),
    )


def encode_capabilities(c: Capabilities) -> str:
    """Write `<capabilities>`: extensions first, then limits (OA-CAP-1)."""
    root = element("capabilities", (("protocol", c.protocol), ("server", c.server)))
    for name in c.extensions:
        root.append(element("extension", (("name", name),)))
    for name, value in c.limits:
        if value < 0:
            raise ApiMisuseError(f"limit {name!r} is negative: {value}")
        root.append(element("limit", (("name", name), ("value", str(value)))))
    return serialize(root)


# --------------------------------------------------------------------------------------------
# tcplocation (spec 3.4, 6.4)
# --------------------------------------------------------------------------------------------

_TCP_KNOWN = ("address", "port", "name")


def parse_tcplocation(content: str) -> TcpLocation:
    """Read `<tcplocation address port name …/>`; other attributes are kept in order.

    `port` is required and a decimal integer (OA-SESS-4, OA-SESS-8); whether its value is a
    usable port is for the caller to judge (a BIND for port 0 is BIND_REFUSED, not malformed).
    """
    root = parse_root(content, ("tcplocation",), ContentInvalidError)
    port_text = attr(root, "port")
    port = parse_integer(port_text)
    if port is None or not _INT32[0] <= port <= _INT32[1]:
        raise ContentInvalidError(f"tcplocation port {port_text!r} is not an integer")
    extra = tuple(
        (str(k), str(v))
        for k, v in root.attrib.items()
        if str(k).rsplit("}", 1)[-1].lower() not in _TCP_KNOWN
    )
    return TcpLocation(
        address=attr(root, "address") or "",
        port=port,
        name=attr(root, "name") or "",
        extra=extra,
    )


def encode_tcplocation(t: TcpLocation) -> str:
    """Write `<tcplocation>`: address and name only when set (the BIND form is port only)."""
    attrs: list[tuple[str, str]] = []
    if t.address:
        attrs.append(("address", t.address))
    attrs.append(("port", str(t.port)))
    if t.name:
        attrs.append(("name", t.name))
    for key, value in t.extra:
        if key.lower() in _TCP_KNOWN:
            raise ApiMisuseError(f"tcplocation extra attribute {key!r} shadows a field")
        attrs.append((key, value))
    return serialize(element("tcplocation", attrs))


# --------------------------------------------------------------------------------------------
# dictionary (spec 3.4)
# --------------------------------------------------------------------------------------------


def parse_dictionary(content: str) -> Dictionary:
    """Read `<dictionary><entry name="k">text</entry>…</dictionary>`, entries in order.

    An entry without a name, or holding an element (that is an objectdictionary's job), is
    CONTENT_INVALID; so is any child other than `entry`.
    """
    root = parse_root(content, ("dictionary",), ContentInvalidError)
    entries: list[tuple[str, str]] = []
    for child in elements(root):
        if local_name(child) != "entry":
            raise ContentInvalidError(f"<dictionary> holds <{local_name(child)}>, not <entry>")
        name = attr(child, "name")
        if name is None:
            raise ContentInvalidError("dictionary entry without a name")
        if elements(child):
            raise ContentInvalidError(f"dictionary entry {name!r} holds an element")
        entries.append((name, inner_text(child)))
    return Dictionary(entries=tuple(entries))


def encode_dictionary(d: Dictionary) -> str:
    """Write `<dictionary>` with one `<entry name>` per entry, in order."""
    root = element("dictionary")
    for key, value in d.entries:
        root.append(element("entry", (("name", key),), value))
    return serialize(root)


# --------------------------------------------------------------------------------------------
# Message collections (OA-RET-7, OA-WAKE-3)
# --------------------------------------------------------------------------------------------


def read_message_collection(root: etree._Element) -> tuple[Message, ...]:
    """Read the messages of an `<objectcollection>` element, one `<object>` each.

    Stored copies are read leniently (OA-MSG-3, OA-MSG-16: Psyclone writes `wbid` before
    `postedTime` and omits empty content); a message the codec refuses is CONTENT_INVALID.
    """
    if local_name(root) != "objectcollection":
        raise ContentInvalidError(f"expected <objectcollection>, found <{local_name(root)}>")
    messages: list[Message] = []
    for index, obj in enumerate(elements(root)):
        if local_name(obj) != "object":
            raise ContentInvalidError(f"<objectcollection> holds <{local_name(obj)}>")
        inner = single_child(obj, f"object {index}", ContentInvalidError)
        if local_name(inner) != "message":
            raise ContentInvalidError(f"object {index} holds <{local_name(inner)}>, not a message")
        try:
            messages.append(message_from_element(inner))
        except MessageInvalidError as exc:
            raise ContentInvalidError(f"object {index}: {exc.detail}") from None
    return tuple(messages)


def parse_message_collection(content: str) -> tuple[Message, ...]:
    """Read `<objectcollection><object><message>…` (retrieve results, OA-RET-7)."""
    return read_message_collection(parse_root(content, ("objectcollection",), ContentInvalidError))


def message_collection_element(msgs: Sequence[Message]) -> etree._Element:
    """Build `<objectcollection>` with one `<object>` per message, in order."""
    root = element("objectcollection")
    for msg in msgs:
        obj = element("object")
        obj.append(message_to_element(msg))
        root.append(obj)
    return root


def encode_message_collection(msgs: Sequence[Message]) -> str:
    """Write `<objectcollection>` of messages; empty is `<objectcollection/>` (OA-RET-7)."""
    return serialize(message_collection_element(msgs))


# --------------------------------------------------------------------------------------------
# Time (spec 4, OA-EXT-2)
# --------------------------------------------------------------------------------------------


def encode_time(name: str, t: AirTime) -> str:
    """Write one time element `<name sec msec [usec]/>` (section 4)."""
    return serialize(time_to_element(name, t))


def parse_time(content: str) -> AirTime:
    """Read content that is one time element (any name with a `sec` attribute, section 4).

    A bad `sec`, `msec` or `usec` (OA-TIME-6) is CONTENT_INVALID here: it is the content
    object, not the envelope, that is wrong.
    """
    roots = parse_content(content, ContentInvalidError)
    if len(roots) != 1 or attr(roots[0], "sec") is None:
        raise ContentInvalidError("content must be one time element with a sec attribute")
    try:
        return time_from_element(roots[0])
    except MessageInvalidError as exc:
        raise ContentInvalidError(f"time: {exc.detail}") from None


# --------------------------------------------------------------------------------------------
# Retrieve specifications (spec 9.2); the public readers and writers are in registration.py
# --------------------------------------------------------------------------------------------


def _criterion_values(el: etree._Element, name: str) -> tuple[list[str], list[etree._Element]]:
    """Return the non-empty attribute value (as a list) and the child elements called `name`."""
    value = attr(el, name)
    children = [c for c in elements(el) if local_name(c) == name]
    return ([value] if value else []), children


def _count(el: etree._Element, name: str) -> int | None:
    """Read `latest` or `lastmsec`: attribute and/or child, a non-negative integer (OA-RET-4/5)."""
    texts, children = _criterion_values(el, name)
    for child in children:
        if elements(child):
            raise RetrieveInvalidError(f"<{name}> holds an element")
        texts.append(inner_text(child))
    values = set()
    for text in texts:
        value = parse_integer(text)
        if value is None or not 0 <= value <= MAX_INT64:
            raise RetrieveInvalidError(f"{name} {text!r} is not a non-negative integer")
        values.add(value)
    if len(values) > 1:  # OA-RET-4: given twice with different values
        raise RetrieveInvalidError(f"{name} given with different values {sorted(values)}")
    return values.pop() if values else None


def _epoch_ms(text: str, name: str, error: type[OpenAIRError] = RetrieveInvalidError) -> AirTime:
    """Read milliseconds since the epoch (OA-RET-9)."""
    value = parse_integer(text)
    if value is None or not -MAX_INT64 - 1 <= value <= MAX_INT64:
        raise error(f"{name} {text.strip()!r} is not milliseconds since the epoch")
    return AirTime.from_ms(value)


def time_bound(
    child: etree._Element, name: str, error: type[OpenAIRError] = RetrieveInvalidError
) -> AirTime:
    """Read an `<afterTime>`/`<untilTime>` element: one time element, or epoch ms as text.

    Retrieve criteria (OA-RET-9) and sample searches (OA-XSTREAM-9) share the form; `error` is
    the condition a malformed bound raises.
    """
    inner = elements(child)
    text = "".join(t for t in (child.text, *(c.tail for c in inner)) if t).strip()
    if not inner:
        return _epoch_ms(text, name, error)
    if len(inner) > 1 or text:
        raise error(f"<{name}> must hold one time element or a number")
    try:
        return time_from_element(inner[0])
    except MessageInvalidError as exc:  # OA-TIME-6 inside a criterion is OA-RET-10
        raise error(f"{name}: {exc.detail}") from None


def _bound(el: etree._Element, name: str) -> AirTime | None:
    """Read `afterTime` or `untilTime` in any of the three forms of OA-RET-9."""
    texts, children = _criterion_values(el, name)
    values = {_epoch_ms(t, name) for t in texts} | {time_bound(c, name) for c in children}
    if len(values) > 1:
        raise RetrieveInvalidError(f"{name} given with different values")
    return values.pop() if values else None


def _content_match(value: str) -> ContentMatch:
    """Read `contentmatch`: `xml`, or empty / `text`, in any case (OA-RET-13)."""
    folded = value.lower()
    if folded == "xml":
        return ContentMatch.XML
    if folded in ("", "text"):
        return ContentMatch.TEXT
    raise RetrieveInvalidError(f"contentmatch {value!r} is not xml or text")


def read_retrieve(el: etree._Element, group_from: str, *, strict: bool) -> RetrieveSpec:
    """Read one `<retrieve>`; `group_from` is the `<retrieves from>` default (OA-REG-5)."""
    if local_name(el) != "retrieve":
        raise RetrieveInvalidError(f"expected <retrieve>, found <{local_name(el)}>")

    def text(name: str) -> str:
        return attr(el, name) or ""  # spec 9.2: an empty attribute is an absent one

    pattern = text("type")
    if strict:
        if pattern:
            validate_pattern(pattern)  # OA-MATCH-7
        for name in _CONTEXT_CRITERIA:
            values, children = _criterion_values(el, name)
            if values or children:  # OA-RET-16: refused, not ignored, when not implemented
                raise RetrieveInvalidError(f"context criterion {name!r} is not implemented")
    latest = _count(el, "latest")
    return RetrieveSpec(
        whiteboard=text("from") or group_from,  # OA-RET-2, OA-REG-5
        pattern=pattern,
        id=text("id"),
        sender=text("sender"),
        content=text("content"),
        contentmatch=_content_match(text("contentmatch")),
        latest=1 if latest is None else latest,  # OA-RET-4
        lastmsec=_count(el, "lastmsec"),
        after_time=_bound(el, "aftertime"),
        until_time=_bound(el, "untiltime"),
    )


def read_retrieves_group(el: etree._Element, *, strict: bool) -> list[RetrieveSpec]:
    """Read the `<retrieve>` children of a `<retrieves from>` group (OA-REG-5)."""
    group_from = attr(el, "from") or ""
    return [read_retrieve(child, group_from, strict=strict) for child in elements(el)]


def retrieve_element(spec: RetrieveSpec) -> etree._Element:
    """Build `<retrieve>`: set criteria as attributes, counts and time bounds as children."""
    if spec.pattern and not is_valid_pattern(spec.pattern):
        raise ApiMisuseError(f"retrieve type {spec.pattern!r} is not a valid pattern")
    attrs = [
        (name, value)
        for name, value in (
            ("from", spec.whiteboard),
            ("type", spec.pattern),
            ("id", spec.id),
            ("sender", spec.sender),
            ("content", spec.content),
            ("contentmatch", "xml" if spec.contentmatch is ContentMatch.XML else ""),
        )
        if value
    ]
    el = element("retrieve", attrs)
    for name, count in (("latest", spec.latest), ("lastmsec", spec.lastmsec)):
        if count is None:
            continue
        if count < 0:
            raise ApiMisuseError(f"retrieve {name} is negative: {count}")
        el.append(element(name, text=str(count)))
    for name, bound in (("afterTime", spec.after_time), ("untilTime", spec.until_time)):
        if bound is not None:
            el.append(_bound_element(name, bound))
    return el


def _bound_element(name: str, t: AirTime) -> etree._Element:
    """Build a time bound: epoch ms as text, or a `<time>` child when ms cannot say it all."""
    el = element(name)
    if t.usec is None and -MAX_INT64 - 1 <= t.ms <= MAX_INT64:
        el.text = str(t.ms)  # the form Psyclone's own writer uses (openair-historic 4.3)
    else:
        el.append(time_to_element("time", t))
    return el


def retrieves_element(specs: Iterable[RetrieveSpec]) -> etree._Element:
    """Build `<retrieves>` holding one `<retrieve>` per spec, in order."""
    root = element("retrieves")
    root.extend(retrieve_element(spec) for spec in specs)
    return root
