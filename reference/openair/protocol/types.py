"""Validation of message types and trigger/retrieve patterns (spec section 5).

A type is one or more non-empty segments separated by `.`; a segment holds segment characters:
every character but `.`, `*` and those of the Unicode general categories Cc, Cf, Cs, Co, Zs, Zl
and Zp as Unicode 14.0.0 assigns them (OA-TYPE-1, OA-TYPE-5), `:` included (OA-TYPE-2). The
table is the shared vector file `spec/vectors/unicode/segment-exclusions.json`, read here, so
validity never depends on the Unicode version of the running Python. A pattern follows the same
segment rules except that `*` may appear inside segments, never twice in a row (OA-MATCH-7).
Validation never normalises: a valid input is returned unchanged, so callers can write
`type_ = validate_type(raw)`.

Length limits: OA-TYPE-4 asks for at most 255 bytes (UTF-8) and 32 segments per type, and
OA-MATCH-9 applies the same limits to patterns. Both are parameters (`None` disables a limit).
"""

from __future__ import annotations

import json
import re

from openair.protocol.errors import PatternInvalidError, TypeInvalidError
from openair.resources import spec_path

MAX_TYPE_BYTES = 255  # OA-TYPE-4
MAX_TYPE_SEGMENTS = 32  # OA-TYPE-4

_WHITESPACE = re.compile(r"\s")
#: The table of spec 5.1 as data (OA-TYPE-5): inclusive code point ranges, Unicode 14.0.0.
EXCLUSIONS_FILE = "vectors/unicode/segment-exclusions.json"


def _load_exclusions() -> tuple[tuple[int, int], ...]:
    """Read the excluded code point ranges of spec 5.1 from the shared vector file."""
    data = json.loads(spec_path(EXCLUSIONS_FILE).read_text(encoding="utf-8"))
    return tuple((int(r["first"][2:], 16), int(r["last"][2:], 16)) for r in data["ranges"])


EXCLUDED_RANGES = _load_exclusions()
_EXCLUDED = re.compile("[" + "".join(f"\\U{a:08x}-\\U{b:08x}" for a, b in EXCLUDED_RANGES) + "]")
# Whole-string shapes once whitespace and non-printables are excluded: segments of anything but
# `.` (and `*` for types) joined by single dots, so an empty segment fails to match.
_TYPE_SHAPE = re.compile(r"[^.*]+(?:\.[^.*]+)*")
_PATTERN_SHAPE = re.compile(r"[^.]+(?:\.[^.]+)*")
_SHOWN_CHARS = 60


def _show(text: str) -> str:
    """Return a short, printable rendering of `text` for an error detail."""
    if len(text) <= _SHOWN_CHARS:
        return repr(text)
    return repr(text[:_SHOWN_CHARS]) + f"... ({len(text)} characters)"


def _problem(
    text: str, *, pattern: bool, max_bytes: int | None, max_segments: int | None
) -> str | None:
    """Return why `text` is not a valid type (or pattern), or None when it is valid."""
    if not text:
        return "is empty"  # OA-TYPE-1, OA-MSG-2
    # Characters never outnumber UTF-8 bytes, so this rejects huge input before scanning it.
    if max_bytes is not None and len(text) > max_bytes:
        return f"is longer than {max_bytes} bytes"  # OA-TYPE-4
    if _WHITESPACE.search(text):
        return "contains whitespace"  # OA-TYPE-1, OA-MATCH-7
    if _EXCLUDED.search(text):
        return "contains a non-printable character (Cc, Cf, Cs, Co, Zs, Zl or Zp)"  # OA-TYPE-5
    if not pattern and "*" in text:
        return "contains '*'"  # OA-TYPE-1, OA-TYPE-3
    if pattern and "**" in text:
        return "contains two consecutive '*'"  # OA-MATCH-7
    if not (_PATTERN_SHAPE if pattern else _TYPE_SHAPE).fullmatch(text):
        return "has an empty segment"  # OA-TYPE-1, OA-MATCH-7
    if max_segments is not None and text.count(".") >= max_segments:
        return f"has more than {max_segments} segments"  # OA-TYPE-4
    # The table excluded lone surrogates (Cs) above, so encoding cannot fail here.
    if max_bytes is not None and len(text.encode("utf-8")) > max_bytes:
        return f"is longer than {max_bytes} bytes"  # OA-TYPE-4
    return None


def validate_type(
    t: str,
    *,
    max_bytes: int | None = MAX_TYPE_BYTES,
    max_segments: int | None = MAX_TYPE_SEGMENTS,
) -> str:
    """Return `t` unchanged if it is a valid message type, else raise TypeInvalidError.

    Rules: OA-TYPE-1 and OA-TYPE-5 (non-empty segments of segment characters: not `*`, `.` or a
    character of the table of spec 5.1), OA-TYPE-2 (`:` allowed), OA-TYPE-3 (a `*` is refused),
    OA-TYPE-4 (at most `max_bytes` UTF-8 bytes and `max_segments` segments; `None` disables a
    limit).
    """
    problem = _problem(t, pattern=False, max_bytes=max_bytes, max_segments=max_segments)
    if problem is not None:
        raise TypeInvalidError(f"type {_show(t)} {problem}")
    return t


def validate_pattern(
    p: str,
    *,
    max_bytes: int | None = MAX_TYPE_BYTES,
    max_segments: int | None = MAX_TYPE_SEGMENTS,
) -> str:
    """Return `p` unchanged if it is a valid type pattern, else raise PatternInvalidError.

    A pattern obeys the type rules (OA-TYPE-1, OA-TYPE-2) except that `*` may appear inside
    segments; two consecutive `*`, an empty segment or whitespace make it invalid (OA-MATCH-7).
    `*` alone is valid (OA-MATCH-5). The length limits are those of types (OA-MATCH-9).
    """
    problem = _problem(p, pattern=True, max_bytes=max_bytes, max_segments=max_segments)
    if problem is not None:
        raise PatternInvalidError(f"pattern {_show(p)} {problem}")
    return p


def is_valid_type(
    t: str,
    *,
    max_bytes: int | None = MAX_TYPE_BYTES,
    max_segments: int | None = MAX_TYPE_SEGMENTS,
) -> bool:
    """Return whether `validate_type` would accept `t`."""
    return _problem(t, pattern=False, max_bytes=max_bytes, max_segments=max_segments) is None


def is_valid_pattern(
    p: str,
    *,
    max_bytes: int | None = MAX_TYPE_BYTES,
    max_segments: int | None = MAX_TYPE_SEGMENTS,
) -> bool:
    """Return whether `validate_pattern` would accept `p`."""
    return _problem(p, pattern=True, max_bytes=max_bytes, max_segments=max_segments) is None
