"""Properties of the codec over generated messages (every field, hostile text, XML, chunks)."""

from __future__ import annotations

import random

from codec_strategies import messages
from hypothesis import given
from hypothesis import strategies as st
from lxml import etree

from openair.protocol.codec import (
    decode_message,
    encode_message,
    from_frame,
    message_to_element,
    to_frame,
)
from openair.protocol.framing import FrameTag, binary_sizes
from openair.protocol.message import Message
from openair.protocol.xmlsafe import parse_xml

# Envelope elements whose attribute names are the protocol's (OA-MSG-3); extension slots keep
# their names as written, and embedded content is opaque, so neither is renamed.
_ENVELOPE = {
    "message", "type", "id", "from", "to", "cc", "stored", "isresponse", "inreplyto",
    "reference", "postedtime", "receivedtime", "comment", "history", "wbid", "netprotocol",
    "binarysizes", "totalbinarysize", "content",
}  # fmt: skip


def _recase(xml: bytes, change: str) -> bytes:
    """Rename the envelope's elements and attributes with `str.lower` or `str.upper`."""
    root = parse_xml(xml)
    renamed = [root, *root]
    renamed += [ref for child in root if child.tag == "inreplyto" for ref in child]
    for el in renamed:
        if el.tag not in _ENVELOPE:
            continue
        attrs = dict(el.attrib)
        el.attrib.clear()
        for key, value in attrs.items():
            el.set(getattr(str(key), change)(), value)
        el.tag = getattr(el.tag, change)()
    return bytes(etree.tostring(root, encoding="UTF-8"))


@given(messages())
def test_decode_inverts_encode(msg: Message) -> None:
    assert decode_message(encode_message(msg)) == msg


@given(messages())
def test_encode_is_deterministic_and_canonical(msg: Message) -> None:
    encoded = encode_message(msg)
    assert encode_message(msg) == encoded
    assert encode_message(decode_message(encoded)) == encoded
    assert not encoded.startswith(b"<?xml")


@given(messages(binary=True), st.sampled_from([FrameTag.MESSAGE, FrameTag.RECEIVE]))
def test_frame_round_trip_with_chunks(msg: Message, tag: FrameTag) -> None:
    frame = to_frame(msg, tag)
    assert frame.tag is tag
    assert frame.chunks == msg.binary
    assert binary_sizes(frame.xml) == tuple(len(c) for c in msg.binary)  # OA-FRAME-4
    assert from_frame(frame) == msg


@given(messages(), st.sampled_from(["lower", "upper"]))
def test_any_case_decodes_the_same(msg: Message, change: str) -> None:
    assert decode_message(_recase(encode_message(msg), change)) == msg  # OA-MSG-3


@given(messages(), st.randoms(use_true_random=False))
def test_slot_order_and_indentation_do_not_matter(msg: Message, rnd: random.Random) -> None:
    root = message_to_element(msg)
    known = [el for el in root if el.tag in _ENVELOPE]
    others = [el for el in root if el.tag not in _ENVELOPE]
    rnd.shuffle(known)
    for el in list(root):
        root.remove(el)
    for el in [*known, *others]:  # OA-MSG-16: any order; extension slots keep theirs
        el.tail = "\n\t"
        root.append(el)
    root.text = "\n\t"
    assert decode_message(etree.tostring(root)) == msg
