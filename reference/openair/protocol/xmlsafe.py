"""The one hardened XML parser every OpenAIR decoder uses (spec 14.2, OA-SEC-1/2, OA-LIM-3).

No DTD is loaded or processed, no entity other than the five predefined ones and character
references is expanded, nothing is fetched from the network or the file system, and documents are
bounded in size and element depth. A DOCTYPE anywhere is XML_FORBIDDEN, not merely ignored: a peer
that sends one is told so (style rule 6: the same hardening in lxml, libxml2 and JAXP).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import cast

from lxml import etree

from openair.protocol.errors import XmlForbiddenError, XmlMalformedError, XmlTooDeepError

DEFAULT_MAX_DEPTH = 64  # OA-LIM-3
DEFAULT_MAX_BYTES = 16 * 1024 * 1024  # OA-LIM-1

__all__ = [
    "DEFAULT_MAX_BYTES",
    "DEFAULT_MAX_DEPTH",
    "XmlLimits",
    "local_name",
    "parse_fragment",
    "parse_xml",
]


@dataclass(frozen=True, slots=True, kw_only=True)
class XmlLimits:
    """Bounds on one parsed document (OA-LIM-1, OA-LIM-3)."""

    max_bytes: int = DEFAULT_MAX_BYTES
    max_depth: int = DEFAULT_MAX_DEPTH


def _parser() -> etree.XMLParser:
    # resolve_entities=False keeps unknown entities unexpanded (they then fail to parse);
    # load_dtd/no_network/dtd_validation close every door to external resources (OA-SEC-2).
    return etree.XMLParser(
        resolve_entities=False,
        load_dtd=False,
        dtd_validation=False,
        no_network=True,
        # The size bound is ours (OA-LIM-1, checked before parsing); libxml2's own 10 MB text
        # node limit would refuse a legitimate 16 MiB message.
        huge_tree=True,
        remove_comments=False,
        remove_pis=False,
        collect_ids=False,
    )


_PARSER = _parser()


_DECLARATION = re.compile(rb"<!\s*(?:doctype|entity)", re.IGNORECASE)
_UTF16_STARTS = (b"\xff\xfe", b"\xfe\xff", b"<\x00", b"\x00<")
_DECLARED_ENCODING = re.compile(rb"<\?xml[^>]*?\sencoding\s*=\s*[\"']([A-Za-z0-9._-]*)[\"']")


#: Bytes searched in one call: a search holds the interpreter lock until it returns, and a
#: server decodes large documents on a worker thread while its loop waits for that lock.
_WINDOW = 1 << 20


def _declares(data: bytes | bytearray) -> bool:
    """Whether `data` holds `<!DOCTYPE` or `<!ENTITY` (any case, blanks allowed after `<!`).

    The same answer as searching the whole document with `_DECLARATION`, a megabyte at a time:
    a two-byte search reads only 1 GB/s, and 15 ms with the lock held stopped a server's event
    loop as long (issue #19). A `!` found by `memchr` (much faster) comes first.
    """
    if data.find(b"!") < 0:
        return False
    size = len(data)
    for start in range(0, size, _WINDOW):
        at = data.find(b"<!", start, min(start + _WINDOW + 1, size))
        while at >= 0:
            if _DECLARATION.match(data, at):
                return True
            at = data.find(b"<!", at + 2, min(start + _WINDOW + 1, size))
    return False


def _more_than(data: bytes | bytearray, byte: bytes, most: int) -> bool:
    """Whether `byte` occurs more than `most` times in `data` (`most` + 1 searches at most)."""
    at = -1
    for _ in range(most + 1):
        at = data.find(byte, at + 1)
        if at < 0:
            return False
    return True


def _check_prolog(data: bytes | bytearray) -> None:
    """Reject any DOCTYPE (OA-SEC-1; entity declarations need one) and non-UTF-8 XML (OA-MSG-1)."""
    if _declares(data):
        raise XmlForbiddenError("a DOCTYPE or entity declaration is not allowed")
    if data[:2] in _UTF16_STARTS:
        raise XmlMalformedError("the XML is UTF-16, not UTF-8")
    if data.startswith(b"<?xml"):
        declared = _DECLARED_ENCODING.match(data)
        if declared is not None and declared.group(1).lower() != b"utf-8":
            name = declared.group(1).decode("ascii")
            raise XmlMalformedError(f"the XML declares encoding {name!r}, not UTF-8")


def _depth(root: etree._Element, limit: int) -> None:
    """Raise XML_TOO_DEEP when any element lies deeper than `limit` (the root is depth 1)."""
    stack: list[tuple[etree._Element, int]] = [(root, 1)]
    while stack:
        el, depth = stack.pop()
        if depth > limit:
            raise XmlTooDeepError(f"element nesting deeper than {limit}")
        stack.extend((child, depth + 1) for child in el)


def parse_xml(
    data: bytes | bytearray,
    limits: XmlLimits | None = None,
    *,
    pause: Callable[[], None] | None = None,
) -> etree._Element:
    """Parse one whole XML document and return its root element.

    Raises XmlForbiddenError (DOCTYPE, entity declarations, undefined entities), XmlTooDeepError
    and XmlMalformedError (anything else that is not well-formed, including bytes over the limit).
    `pause`, when given, is called between the steps (each some milliseconds for a document of
    megabytes): a server's worker thread lets its event loop have the interpreter lock there.
    """
    lim = limits or XmlLimits()
    if len(data) > lim.max_bytes:
        raise XmlMalformedError(f"document of {len(data)} bytes exceeds {lim.max_bytes}")
    _check_prolog(data)
    if pause is not None:
        pause()
    try:
        # lxml reads any buffer (a large frame's XML is the bytearray it arrived in); its
        # type stubs name only str and bytes.
        root = etree.fromstring(cast(bytes, data), _PARSER)
    except etree.XMLSyntaxError as exc:
        text = str(exc)
        if "Entity" in text or "entity" in text:
            raise XmlForbiddenError(f"entity not allowed: {text}") from None
        if "Excessive depth" in text:
            raise XmlTooDeepError(text) from None
        raise XmlMalformedError(text) from None
    except ValueError as exc:  # e.g. a str with an encoding declaration
        raise XmlMalformedError(str(exc)) from None
    if root is None:
        raise XmlMalformedError("empty document")
    if pause is not None:
        pause()
    if _more_than(data, b"<", lim.max_depth):  # fewer tags cannot nest deeper than the limit
        _depth(root, lim.max_depth)
    return root


def parse_fragment(text: str, limits: XmlLimits | None = None) -> list[etree._Element]:
    """Parse XML content (zero or more sibling elements, OA-MSG-10) and return its elements.

    Whitespace between the elements is ignored (OA-MSG-17); non-whitespace text at the top level
    is XML_MALFORMED. The depth limit counts from the first content element.
    """
    lim = limits or XmlLimits()
    wrapper = parse_xml(
        b"<c>" + text.encode("utf-8") + b"</c>",
        XmlLimits(max_bytes=lim.max_bytes + 7, max_depth=lim.max_depth + 1),
    )
    texts = [wrapper.text or "", *(child.tail or "" for child in wrapper)]
    if any(t.strip() for t in texts):
        raise XmlMalformedError("text outside the elements of XML content")
    return [child for child in wrapper if isinstance(child.tag, str)]


def local_name(el: etree._Element) -> str:
    """Return an element's local name in lower case (OA-MSG-3: names compare in any case)."""
    tag = el.tag
    if not isinstance(tag, str):
        return ""
    return tag.rsplit("}", 1)[-1].lower()
