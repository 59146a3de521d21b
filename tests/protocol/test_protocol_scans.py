"""The quicker scans of issue #19 give exactly the answers of the expressions they replace.

`xmlsafe._declares` (DOCTYPE or ENTITY, a window at a time), `xmlsafe._more_than` (a bounded
count) and `grammar.has_non_xml_char` (ASCII at memory speed) were written so that a large
document does not hold the interpreter lock, or the loop, for milliseconds; these properties
compare them with the plain expressions on generated text, with windows of a few bytes.
"""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from openair.protocol import grammar, xmlsafe

_PIECES = [
    b"<",
    b"!",
    b"<!",
    b"<! ",
    b"doctype",
    b"DocType",
    b"ENTITY",
    b"entity",
    b" ",
    b"x",
    b"-",
]


@given(st.lists(st.sampled_from(_PIECES), max_size=14), st.integers(1, 9))
def test_declares_is_the_expression_over_the_whole_document(
    pieces: list[bytes], window: int
) -> None:
    data = b"".join(pieces)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(xmlsafe, "_WINDOW", window)  # matches across every window edge
        assert xmlsafe._declares(data) == (xmlsafe._DECLARATION.search(data) is not None)
        assert xmlsafe._declares(bytearray(data)) == xmlsafe._declares(data)


@given(st.binary(max_size=40).map(lambda b: b.replace(b"a", b"<")), st.integers(0, 6))
def test_more_than_is_a_count(data: bytes, most: int) -> None:
    assert xmlsafe._more_than(data, b"<", most) == (data.count(b"<") > most)


@given(st.text(max_size=30) | st.text(st.characters(max_codepoint=0x7F), max_size=30))
def test_has_non_xml_char_is_the_expression(text: str) -> None:
    assert grammar.has_non_xml_char(text) == (grammar.NOT_XML_CHAR.search(text) is not None)


@pytest.mark.parametrize("char", ["\x00", "\x08", "\x0b", "\x1f", "\ufffe", "\ud800"])
def test_the_characters_xml_forbids_are_found(char: str) -> None:
    assert grammar.has_non_xml_char(f"ok{char}ok")


@pytest.mark.parametrize("char", ["\t", "\n", "\r", " ", "\x7f", "é", "\U0001f600"])
def test_the_characters_xml_allows_are_not(char: str) -> None:
    assert not grammar.has_non_xml_char(f"ok{char}ok")
