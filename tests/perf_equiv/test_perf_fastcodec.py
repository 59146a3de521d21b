"""The fast codec path agrees with the lxml path: same bytes out, same Message or same error in."""

from __future__ import annotations

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from lxml import etree
from perf_strategies import documents, messages

from openair.protocol._errors_base import OpenAIRError
from openair.protocol.codec import (
    decode_message,
    decode_with_lxml,
    encode_message,
    encode_with_lxml,
)
from openair.protocol.errors import ApiMisuseError
from openair.protocol.fastcodec import escape_attr, escape_text, fast_decode, fast_encode
from openair.protocol.message import Message
from openair.protocol.xmlsafe import XmlLimits

_MANY = settings(max_examples=400)


def _lxml_bytes(msg: Message) -> bytes | type[OpenAIRError]:
    try:
        return encode_with_lxml(msg)
    except ApiMisuseError:
        return ApiMisuseError


@_MANY
@given(messages())
def test_fast_encoding_is_lxml_encoding_or_declines(msg: Message) -> None:
    expected = _lxml_bytes(msg)
    fast = fast_encode(msg)
    if fast is not None:
        assert fast == expected
    if isinstance(expected, bytes):
        assert encode_message(msg) == expected
    else:
        with pytest.raises(ApiMisuseError):
            encode_message(msg)


@given(messages(plain=True))
def test_plain_messages_take_the_fast_encoder(msg: Message) -> None:
    if any(v is not None and "e" in repr(v) for v in (msg.priority, msg.timetolive)):
        assert fast_encode(msg) is None  # exponent forms are left to the lxml path
        return
    assert fast_encode(msg) == encode_with_lxml(msg)


def _outcome(decode: object, data: bytes) -> Message | type[OpenAIRError]:
    assert callable(decode)
    try:
        result = decode(data)
    except OpenAIRError as exc:
        return type(exc)
    assert isinstance(result, Message)
    return result


@_MANY
@given(documents(encode_message))
@example(b'<message><type>A</type><content language="">&#13;x</content></message>')
@example(b"<message><type>A</type><id>&#x110000;</id></message>")
@example(b'<message><type>A</type><postedTime sec="1" sec="2"/></message>')
@example(b"<message><type>A</type></message >\n")
@example(b"<message><type a='&lt;'>A&amp;&apos;</type><type/></message>")
def test_fast_decoder_declines_or_agrees_with_lxml(data: bytes) -> None:
    expected = _outcome(decode_with_lxml, data)
    fast = fast_decode(data)
    if fast is not None:
        assert fast == expected
    assert _outcome(decode_message, data) == expected


@given(messages(plain=True))
def test_plain_canonical_messages_take_the_fast_decoder(msg: Message) -> None:
    data = encode_with_lxml(msg)
    expected = _outcome(lambda d: decode_with_lxml(d, msg.binary), data)
    fast = fast_decode(data, msg.binary)
    if isinstance(expected, Message) and b"\r" not in data:
        assert fast == expected  # a raw \r is normalised by XML parsers: the fast path declines
    else:
        assert fast is None


@pytest.mark.parametrize(
    "limits",
    [XmlLimits(max_bytes=50), XmlLimits(max_depth=1), XmlLimits(max_depth=2)],
    ids=["bytes", "depth1", "depth2"],
)
def test_limits_hold_on_the_fast_path(limits: XmlLimits) -> None:
    data = b"<message><type>A</type><id>" + b"x" * 60 + b"</id></message>"
    expected = _outcome(lambda d: decode_with_lxml(d, (), limits), data)
    assert _outcome(lambda d: decode_message(d, (), limits), data) == expected
    if not isinstance(expected, Message):
        assert fast_decode(data, (), limits) is None


@given(st.text(max_size=20))
def test_escapes_match_libxml2(text: str) -> None:
    el = etree.Element("a")
    try:
        el.set("v", text)
        el.text = text or None  # an empty string would be written <a></a>
        written = etree.tostring(el, encoding="unicode")
    except ValueError:
        return
    expected = f'<a v="{escape_attr(text)}">{escape_text(text)}</a>' if text else '<a v=""/>'
    assert written == expected
