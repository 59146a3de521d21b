"""Validation of types and patterns (OA-TYPE-1..4, OA-MATCH-7)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from openair.protocol.errors import ErrorCode, PatternInvalidError, TypeInvalidError
from openair.protocol.types import (
    MAX_TYPE_BYTES,
    MAX_TYPE_SEGMENTS,
    is_valid_pattern,
    is_valid_type,
    validate_pattern,
    validate_type,
)


def _independent_valid(text: str, *, pattern: bool) -> bool:
    """Restate the rules without the module's regexes (no length limits)."""
    if pattern and "**" in text:
        return False
    for segment in text.split("."):
        if not segment:
            return False
        for char in segment:
            if char.isspace() or not char.isprintable() or (char == "*" and not pattern):
                return False
    return True


@pytest.mark.parametrize(
    "t", ["A", "Test.Ping", "Psyclone.Context:A.B", ":", "a.b:c.d", "Test.P?ng.[AB]", "\u00e9.x"]
)
def test_valid_types_are_returned_unchanged(t: str) -> None:
    assert validate_type(t) is t
    assert validate_pattern(t) is t  # every valid type is also a valid pattern


@pytest.mark.parametrize(
    ("t", "reason"),
    [
        ("", "is empty"),
        ("Test.", "empty segment"),
        (".Ping", "empty segment"),
        ("A..B", "empty segment"),
        ("Test Ping", "whitespace"),
        ("A\u00a0B", "whitespace"),
        ("A\x00B", "non-printable"),
        ("A\u200bB", "non-printable"),
        ("A\ud800B", "non-printable"),
        ("A*", "'*'"),
        ("*", "'*'"),
    ],
)
def test_invalid_types(t: str, reason: str) -> None:
    with pytest.raises(TypeInvalidError) as caught:
        validate_type(t)
    assert reason in caught.value.detail
    assert caught.value.code == ErrorCode.TYPE_INVALID
    assert caught.value.wire_text().startswith("TYPE_INVALID: type ")
    assert not is_valid_type(t)


@pytest.mark.parametrize("p", ["*", "Test.*", "*.A", "A*B", "Te*t.Ping", "*:*", "A.*.B.*", "*.*"])
def test_valid_patterns(p: str) -> None:
    assert validate_pattern(p) is p
    assert is_valid_pattern(p)


@pytest.mark.parametrize(
    ("p", "reason"),
    [
        ("", "is empty"),
        ("**", "two consecutive"),
        ("***", "two consecutive"),
        ("A.**", "two consecutive"),
        ("Test.Ping.", "empty segment"),
        (".*", "empty segment"),
        ("*.", "empty segment"),
        ("Te st.*", "whitespace"),
        ("A\tB", "whitespace"),
        ("A\x07", "non-printable"),
    ],
)
def test_invalid_patterns(p: str, reason: str) -> None:
    with pytest.raises(PatternInvalidError) as caught:
        validate_pattern(p)
    assert reason in caught.value.detail
    assert caught.value.code == ErrorCode.PATTERN_INVALID
    assert not is_valid_pattern(p)


def test_byte_limit_counts_utf8_bytes() -> None:
    assert MAX_TYPE_BYTES == 255
    validate_type("A" * 255)
    validate_type("\u00e9" * 127)  # 254 bytes
    with pytest.raises(TypeInvalidError, match="longer than 255 bytes"):
        validate_type("\u00e9" * 128)  # 128 characters, 256 bytes
    with pytest.raises(TypeInvalidError, match="longer than 255 bytes"):
        validate_type("A" * 256)


def test_segment_limit() -> None:
    assert MAX_TYPE_SEGMENTS == 32
    validate_type(".".join("a" * 32))
    with pytest.raises(TypeInvalidError, match="more than 32 segments"):
        validate_type(".".join("a" * 33))
    with pytest.raises(PatternInvalidError, match="more than 32 segments"):
        validate_pattern(".".join("*" * 33))


def test_limits_are_parameters() -> None:
    with pytest.raises(TypeInvalidError):
        validate_type("ABCDE", max_bytes=4)
    with pytest.raises(PatternInvalidError):
        validate_pattern("A.B.*", max_segments=2)
    huge = ".".join(["seg"] * 1000)
    assert validate_type(huge, max_bytes=None, max_segments=None) is huge
    assert is_valid_pattern(huge + ".*", max_bytes=None, max_segments=None)
    assert not is_valid_type(huge)


def test_error_detail_of_huge_input_is_short() -> None:
    with pytest.raises(TypeInvalidError) as caught:
        validate_type("x" * 1_000_000)
    assert len(caught.value.detail) < 200


_ALPHABET = st.sampled_from(["a", "B", ".", "*", ":", " ", "\t", "\u00e9", "\x00", "\u2028"])


@given(st.text(alphabet=_ALPHABET, max_size=12))
def test_type_rules_match_an_independent_statement(text: str) -> None:
    expected = _independent_valid(text, pattern=False)
    assert is_valid_type(text, max_bytes=None, max_segments=None) == expected


@given(st.text(alphabet=_ALPHABET, max_size=12))
def test_pattern_rules_match_an_independent_statement(text: str) -> None:
    expected = _independent_valid(text, pattern=True)
    assert is_valid_pattern(text, max_bytes=None, max_segments=None) == expected
