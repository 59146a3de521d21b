"""The lexical grammar of the message envelope, shared by `codec` (lxml) and `fastcodec`.

One table of the known slots, one set of number patterns and one decimal writer, so that the two
codecs cannot drift apart: what one reads as a number the other reads too (OA-MSG-6, OA-TIME-1,
OA-MSG-13), and both write priorities and times to live with the same digits (spec 3.5).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from decimal import Decimal

from openair.protocol.errors import MessageInvalidError
from openair.protocol.times import AirTime

__all__ = [
    "DECIMAL",
    "DERIVED_SLOTS",
    "DIGITS",
    "INT",
    "MAX_SEC",
    "MIN_SEC",
    "NOT_XML_CHAR",
    "TEXT_SLOTS",
    "UINT",
    "WS",
    "clip",
    "decimal_text",
    "has_char_outside",
    "has_non_xml_char",
    "read_decimal",
    "read_integer",
    "read_time",
    "short_decimal_text",
]

#: XML white space (XML 1.0 production S).
WS = " \t\r\n"
#: xs:integer (`sec`, OA-TIME-1).
INT = re.compile(r"[+-]?[0-9]+")
#: A non-negative integer with an optional `+` (`msec`, `usec`, OA-TIME-1, OA-TIME-5).
UINT = re.compile(r"\+?[0-9]+")
#: Decimal digits only (`wbid`, OA-MSG-13; `binarysizes`).
DIGITS = re.compile(r"[0-9]+")
#: xs:decimal: no exponent, no inf or nan (`priority`, `timetolive`, OA-MSG-6).
DECIMAL = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)")
#: A character XML 1.0 does not allow (OA-MSG-14).
NOT_XML_CHAR = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")
#: The ASCII characters XML 1.0 allows: tab, newline, carriage return, and 0x20 on.
_XML_ASCII = bytes([9, 10, 13, *range(0x20, 0x80)])
#: Text is checked in windows of this many characters: under the allocator's mmap threshold, and
#: short enough that the event loop can take the interpreter lock between two (issue #19).
_WINDOW = 64 * 1024


def has_non_xml_char(text: str) -> bool:
    """Whether `text` holds a character XML 1.0 does not allow (OA-MSG-14).

    ASCII text (most of it) is checked at memory speed: the bytes that are left once the allowed
    ones are deleted. The expression reads 150 MB/s, 7 ms for a megabyte of content on the
    event loop (issue #19); this is ten times faster. Other text takes the expression.
    """
    return has_char_outside(text, _XML_ASCII, NOT_XML_CHAR)


def has_char_outside(text: str, ascii_allowed: bytes, outside: re.Pattern[str]) -> bool:
    """Whether `text` holds a character outside a set: `ascii_allowed` are its ASCII ones, and
    `outside` finds one character not in it (for text that is not ASCII).

    Text longer than a window is read a window at a time: one C call over a megabyte holds the
    interpreter lock a millisecond (issue #19). Short text, the common case, in one call.
    """
    step = _WINDOW
    if text.isascii():
        if len(text) <= step:
            return bool(text.encode("ascii").translate(None, ascii_allowed))
        return any(
            text[i : i + step].encode("ascii").translate(None, ascii_allowed)
            for i in range(0, len(text), step)
        )
    if len(text) <= step:
        return outside.search(text) is not None
    return any(outside.search(text, i, i + step) for i in range(0, len(text), step))


#: `sec` is a signed 64-bit integer (OA-TIME-1).
MAX_SEC = 2**63 - 1
MIN_SEC = -(2**63)

#: Text slots: lower-cased element name -> Message field.
TEXT_SLOTS: dict[str, str] = {
    "type": "type",
    "id": "id",
    "from": "sender",
    "to": "to",
    "cc": "cc",
    "stored": "stored",
    "isresponse": "isresponse",
    "comment": "comment",
    "netprotocol": "netprotocol",
}
#: Slots the spec defines that have no field of their own (OA-MSG-16 still forbids duplicates).
DERIVED_SLOTS = frozenset({"binarysizes", "totalbinarysize"})


def short_decimal_text(value: float) -> str | None:
    """The shortest digits that read back as `value` (2.0, 0.5, 6.999), as repr() writes them.

    None for a value that is not finite, or that repr() writes with an exponent (the fast path
    leaves those to `decimal_text` on the lxml path).
    """
    if not math.isfinite(value):
        return None
    text = repr(float(value) + 0.0)  # + 0.0 turns -0.0 into 0.0
    if "e" in text or "E" in text:
        return None
    return text if "." in text else text + ".0"


def decimal_text(value: float) -> str | None:
    """Write a decimal as the shortest digits that read back as `value`: 2.0, 0.5, 6.999.

    None for a value that is not finite (no decimal can carry it). Never an exponent: a value
    that repr() writes with one is written in positional notation (xs:decimal has none).
    """
    if not math.isfinite(value):
        return None
    text = short_decimal_text(value)
    if text is not None:
        return text
    text = format(Decimal(repr(float(value) + 0.0)), "f")
    return text if "." in text else text + ".0"


# -- strict readers (the lxml path; the fast path declines instead of raising) ---------------


def clip(text: str, limit: int = 40) -> str:
    """`text` stripped, cut to `limit` characters for an error message."""
    text = text.strip(WS)
    return text if len(text) <= limit else text[:limit] + "..."


def read_decimal(text: str, what: str) -> float:
    """Parse an xs:decimal (no exponent, no inf/nan) into a float (OA-MSG-6)."""
    stripped = text.strip(WS)
    if not DECIMAL.fullmatch(stripped):
        raise MessageInvalidError(f"{what} is not a decimal number: {text!r}")
    return float(stripped) + 0.0  # + 0.0 turns -0.0 into 0.0


def read_integer(text: str, pattern: re.Pattern[str], what: str) -> int:
    """Parse an integer `pattern` allows; anything else is MESSAGE_INVALID (OA-TIME-6)."""
    stripped = text.strip(WS)
    if not pattern.fullmatch(stripped):
        raise MessageInvalidError(f"{what} is not a decimal integer: {clip(text)!r}")
    return int(stripped)


def _below_1000(text: str, what: str) -> int:
    value = read_integer(text, UINT, what)
    if value > 999:  # OA-TIME-6
        raise MessageInvalidError(f"{what} must be 0-999, got {text!r}")
    return value


def read_time(attrs: Mapping[str, str], where: str) -> AirTime:
    """Build a time from lower-cased attributes; any bad value is MESSAGE_INVALID (OA-TIME-6)."""
    sec_text = attrs.get("sec")
    if sec_text is None:
        raise MessageInvalidError(f"<{where}> has no sec attribute")
    sec = read_integer(sec_text, INT, f"sec of <{where}>")
    if not MIN_SEC <= sec <= MAX_SEC:  # OA-TIME-1: signed 64-bit
        raise MessageInvalidError(f"sec of <{where}> is outside the 64-bit range: {sec_text!r}")
    msec_text = attrs.get("msec", attrs.get("ms"))  # OA-TIME-1: msec wins over ms
    msec = 0 if msec_text is None else _below_1000(msec_text, f"msec of <{where}>")
    usec_text = attrs.get("usec")  # OA-TIME-5
    usec = None if usec_text is None else _below_1000(usec_text, f"usec of <{where}>")
    return AirTime(sec=sec, msec=msec, usec=usec)
