"""Unit tests of the codec's API edges and every error path (decode and encode)."""

from __future__ import annotations

import pytest
from lxml import etree

from openair.protocol.codec import (
    decode_message,
    encode_message,
    from_frame,
    message_from_element,
    message_to_element,
    time_from_element,
    time_to_element,
    to_frame,
)
from openair.protocol.errors import (
    ApiMisuseError,
    MessageInvalidError,
    XmlForbiddenError,
    XmlMalformedError,
    XmlTooDeepError,
)
from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message, Reference, Slot
from openair.protocol.times import AirTime
from openair.protocol.xmlsafe import XmlLimits, parse_xml

POSTED = b'<postedTime sec="1795328371" msec="396"/>'


def post(inner: bytes = POSTED, attrs: bytes = b"") -> bytes:
    return b"<message" + attrs + b"><type>T.A</type><id>i</id>" + inner + b"</message>"


def minimal(**fields: object) -> Message:
    return Message(type="T.A", id="i", posted=AirTime(sec=1, msec=2), **fields)  # type: ignore[arg-type]


# ------------------------------------------------------------------------------- decode errors


@pytest.mark.parametrize(
    ("inner", "attrs", "words"),
    [
        (POSTED + b"<ID>again</ID>", b"", "more than once"),
        (b'<postedTime sec="1"/><POSTEDTIME sec="2"/>', b"", "more than once"),
        (POSTED, b' priority="9"', "priority"),
        (POSTED, b' priority=""', "priority"),
        (POSTED, b' timetolive="NaN"', "timetolive"),
        (POSTED, b' noreply=""', "noreply"),
        (b'<postedTime sec="1" SEC="2"/>', b"", "twice"),
        (b'<postedTime sec="1" msec="1.5"/>', b"", "msec"),
        (b'<postedTime sec="1_000"/>', b"", "sec"),
        (b'<postedTime sec="\xd9\xa1"/>', b"", "sec"),  # ARABIC-INDIC DIGIT ONE is no ASCII digit
        (b'<receivedTime sec="1" ms="x"/>', b"", "msec"),
        (b"<wbid></wbid>", b"", "wbid"),
        (b"<wbid>1 2</wbid>", b"", "wbid"),
        (b"<inreplyto><ref/></inreplyto>", b"", "reference"),
        (b'<inreplyto><reference sec="x"/></inreplyto>', b"", "sec"),
        (b"<inreplyto>text<reference/></inreplyto>", b"", "text"),
        (b"<from><b/></from>", b"", "must be text"),
        (b"<history>note</history>", b"", "history"),
        (b"<binarysizes/><BinarySizes/>", b"", "more than once"),
        (b"<extensions/><EXTENSIONS/>", b"", "more than once"),
    ],
)
def test_invalid_slot_values(inner: bytes, attrs: bytes, words: str) -> None:
    with pytest.raises(MessageInvalidError, match=words) as info:
        decode_message(post(inner, attrs))
    assert info.value.name == "MESSAGE_INVALID"


def test_error_detail_names_the_slot_and_value() -> None:
    with pytest.raises(MessageInvalidError) as info:
        decode_message(post(b'<postedTime sec="1" msec="1000"/>'))
    assert "msec of <postedTime>" in info.value.detail and "1000" in info.value.detail
    assert info.value.wire_text().startswith("MESSAGE_INVALID: ")


def test_xml_errors_come_from_the_hardened_parser() -> None:
    with pytest.raises(XmlMalformedError):
        decode_message(b"<message><type>X</type>")
    with pytest.raises(XmlMalformedError, match="not <message>"):
        decode_message(b"<Envelope><type>X</type></Envelope>")
    with pytest.raises(XmlForbiddenError):
        decode_message(b'<!DOCTYPE m SYSTEM "http://example.invalid/m.dtd"><message/>')
    with pytest.raises(XmlTooDeepError):
        decode_message(post(b"<x><y/></x>"), limits=XmlLimits(max_depth=2))
    with pytest.raises(XmlMalformedError):
        decode_message(post(), limits=XmlLimits(max_bytes=10))


def test_root_may_be_any_case_and_in_a_namespace() -> None:
    msg = decode_message(b'<Message xmlns="urn:x"><Type>N.S</Type><ID>1</ID></Message>')
    assert (msg.type, msg.id) == ("N.S", "1")


def test_absent_slots_read_as_empty() -> None:
    msg = decode_message(b"<message><type>Only</type></message>")  # OA-MSG-9
    assert msg == Message(type="Only", id="")


def test_chunks_become_binary() -> None:
    xml = post(POSTED + b"<binarysizes>2</binarysizes><totalbinarysize>2</totalbinarysize>")
    assert decode_message(xml, (b"ab",)).binary == (b"ab",)


# ---------------------------------------------------------------------------------- elements


def test_message_from_element_reads_a_nested_copy() -> None:
    root = parse_xml(b"<object><MESSAGE><type>In.Side</type></MESSAGE></object>")
    assert message_from_element(root[0]).type == "In.Side"
    with pytest.raises(MessageInvalidError, match="expected a <message>"):
        message_from_element(root)


def test_message_to_element_is_what_encode_writes() -> None:
    msg = minimal(content="x")
    assert etree.tostring(message_to_element(msg), encoding="UTF-8") == encode_message(msg)


def test_time_elements() -> None:
    el = time_to_element("activationtime", AirTime(sec=5, msec=6, usec=7))
    assert etree.tostring(el) == b'<activationtime sec="5" msec="6" usec="7"/>'
    assert time_from_element(el) == AirTime(sec=5, msec=6, usec=7)
    both = parse_xml(b'<time ms="4" msec="3" sec="2" tzc="Greenwich_0_60"/>')
    assert time_from_element(both) == AirTime(sec=2, msec=3)  # OA-TIME-1: msec wins
    assert time_from_element(parse_xml(b'<time sec=" +9 " MS="01"/>')) == AirTime(sec=9, msec=1)
    with pytest.raises(MessageInvalidError, match="no sec"):
        time_from_element(parse_xml(b'<time msec="1"/>'))


# ------------------------------------------------------------------------------------ frames


def test_frames() -> None:
    msg = minimal(binary=(b"abc", b""))
    frame = to_frame(msg, FrameTag.RECEIVE)
    assert (frame.tag, frame.chunks) == (FrameTag.RECEIVE, (b"abc", b""))
    assert b"<binarysizes>3,0</binarysizes><totalbinarysize>3</totalbinarysize>" in frame.xml
    assert from_frame(frame) == msg
    assert to_frame(minimal()).tag is FrameTag.MESSAGE
    with pytest.raises(ApiMisuseError):
        to_frame(msg, FrameTag.BINARY)
    with pytest.raises(MessageInvalidError, match="BinaryM"):
        from_frame(Frame(tag=FrameTag.BINARY, chunks=(b"x",)))


# ------------------------------------------------------------------------------- encode errors


@pytest.mark.parametrize(
    ("fields", "words"),
    [
        ({"content": "a\x00b"}, "content holds U\\+0000"),
        ({"sender": "\ud800"}, "from holds U\\+D800"),
        ({"comment": "\ufffe"}, "comment holds U\\+FFFE"),
        ({"to": "\x1b[0m"}, "to holds U\\+001B"),
        ({"extras": (Slot(name="x", value="\x01"),)}, "slot 'x' holds U\\+0001"),
        ({"inreplyto": Reference(id="\x02")}, "inreplyto id holds"),
        ({"content": "<a>", "content_is_xml": True}, "well-formed"),
        ({"content": "<!DOCTYPE a><a/>", "content_is_xml": True}, "well-formed"),
        ({"content": "x", "language": "XML"}, "text content"),
        ({"history": "<group>"}, "history"),
        ({"extras": (Slot(name="1bad"),)}, "not an XML name"),
        ({"extras": (Slot(name="a b"),)}, "not an XML name"),
        ({"extras": (Slot(name="PostedTime"),)}, "known slot"),
        ({"extras": (Slot(name="binarysizes"),)}, "known slot"),
        ({"extras": (Slot(name="x", value="<a>", is_xml=True),)}, "not well-formed"),
        ({"timetolive": float("inf")}, "finite"),
    ],
)
def test_encode_refuses(fields: dict[str, object], words: str) -> None:
    with pytest.raises(ApiMisuseError, match=words) as info:
        encode_message(minimal(**fields))
    assert info.value.name == "API_MISUSE"


def test_encode_refuses_an_empty_type() -> None:
    with pytest.raises(ApiMisuseError, match="type"):
        encode_message(Message(type=""))  # OA-MSG-2


# ------------------------------------------------------------------------------ canonical form


def test_canonical_form_details() -> None:
    msg = minimal(
        priority=0.00001,
        wbid=123456789,
        content="<&>\r",
        content_is_xml=False,
        extras=(Slot(name="z", value="<b/>", is_xml=True), Slot(name="a", value="")),
    )
    assert encode_message(msg) == (
        b'<message priority="0.00001"><type>T.A</type><id>i</id><from/><to/><cc/><stored/>'
        b'<isresponse/><postedTime sec="1" msec="2"/><wbid>123456789</wbid>'
        b'<content language="">&lt;&amp;&gt;&#13;</content><z><b/></z><a/></message>'
    )


def test_xml_content_gets_language_xml() -> None:
    msg = minimal(content="<a/>", content_is_xml=True)
    assert b'<content language="xml"><a/></content>' in encode_message(msg)


def test_reference_writes_only_what_it_has() -> None:
    ref = Reference(id="r", time=AirTime(sec=1, msec=2, usec=3))
    xml = encode_message(minimal(inreplyto=ref))
    assert b'<inreplyto><reference id="r" sec="1" msec="2"/></inreplyto>' in xml
    assert decode_message(xml).inreplyto == Reference(id="r", time=AirTime(sec=1, msec=2))


def test_xml_content_with_stray_text_is_kept_for_the_command_to_judge() -> None:
    """JavaOpenAIR's `garbage` retrieve must reach the router intact (OA-RET-10, DEV-14)."""
    xml = (
        b"<message><type>AIR.Retrieve</type><id>r1</id>"
        b'<content language="xml">garbage<a x="1"/> tail &amp; more</content></message>'
    )
    msg = decode_message(xml)
    assert msg.content_is_xml
    assert msg.content == 'garbage<a x="1"/> tail &amp; more'
    assert decode_message(encode_message(msg)) == msg
