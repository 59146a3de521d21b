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

from openair.protocol import codec, fastcodec, grammar, xmlsafe
from openair.protocol.codec import to_frame
from openair.protocol.message import Message

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


@given(
    st.text(max_size=30) | st.text(st.characters(max_codepoint=0x7F), max_size=30),
    st.integers(1, 9),
)
def test_has_non_xml_char_is_the_expression(text: str, window: int) -> None:
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(grammar, "_WINDOW", window)  # a character on every side of a window edge
        assert grammar.has_non_xml_char(text) == (grammar.NOT_XML_CHAR.search(text) is not None)


# --- fastcodec: a large canonical document's content checked apart from its envelope ----------

_BODY_PIECES = ["x", "é", "<", "&amp;", "\x00", "\x0b", "\r", "\t", "\n", "\ufffe", ">", '"', "/"]
_LANGUAGES = ["", "text", "xml", "a>b", "a/", "q"]


@given(
    st.lists(st.sampled_from(_BODY_PIECES), max_size=12),
    st.sampled_from(_LANGUAGES),
    st.sampled_from(["", "<comment>c</comment>", "<wbid>00000007</wbid>"]),
    st.sampled_from(["</content></message>", "</content></message> ", "/></message>"]),
    st.integers(1, 9),
)
def test_large_canonical_documents_give_the_expressions_groups(
    pieces: list[str], language: str, middle: str, end: str, window: int
) -> None:
    body = "".join(p.encode().decode("unicode_escape") for p in pieces)
    head = "<message><type>T.x</type><id>i</id><from>A</from><to>WB1</to><cc/><stored/>"
    head += f"<isresponse/>{middle}"
    text = f'{head}<content language="{language}"' + (
        end if end.startswith("/") else f">{body}{end}"
    )
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(fastcodec, "_LARGE", 0)  # every document takes the large path
        patch.setattr(grammar, "_WINDOW", window)
        found = fastcodec._CANONICAL.fullmatch(text)
        assert fastcodec._canonical_groups(text) == (None if found is None else found.groups())


@pytest.mark.parametrize("char", ["\x00", "\x08", "\x0b", "\x1f", "\ufffe", "\ud800"])
def test_the_characters_xml_forbids_are_found(char: str) -> None:
    assert grammar.has_non_xml_char(f"ok{char}ok")


@pytest.mark.parametrize("char", ["\t", "\n", "\r", " ", "\x7f", "é", "\U0001f600"])
def test_the_characters_xml_allows_are_not(char: str) -> None:
    assert not grammar.has_non_xml_char(f"ok{char}ok")


@pytest.mark.parametrize("body", ["x" * 70_000, "é" * 70_000, "x" * 70_000 + "&amp;"])
@pytest.mark.parametrize("kind", [bytes, bytearray])
def test_a_large_canonical_post_decodes_through_the_large_path(body: str, kind: type) -> None:
    # A frame of a megabyte or more arrives as the reader's bytearray: the fast path reads it
    # too (it went to lxml, 10 % of the worker's time under the stalled-subscriber attack).
    msg = Message(type="T.x", to="WB1", sender="A", content=body.replace("&amp;", "&"))
    xml = kind(to_frame(msg).xml)
    assert len(xml) > fastcodec._LARGE
    with pytest.MonkeyPatch.context() as patch:
        checked: list[int] = []
        plain = fastcodec._plain_text
        patch.setattr(
            fastcodec, "_plain_text", lambda text: checked.append(len(text)) or plain(text)
        )
        patch.setattr(codec, "decode_with_lxml", None)  # not called
        decoded = codec.decode_message(xml)
    assert checked == [len(body)]  # the content was checked apart from the envelope
    assert decoded == msg
