"""Hypothesis strategies for messages the codec must round-trip exactly.

Generated values are in the codec's normal form: XML strings are what lxml writes for the
elements they hold (the decoder serializes embedded XML the same way), references carry no
usec (schemas/message.xsd gives a reference only sec and msec), and extension slots never take
the name of a known slot.
"""

from __future__ import annotations

from hypothesis import strategies as st
from lxml import etree

from openair.protocol.message import MAX_PRIORITY, MIN_PRIORITY, Message, Reference, Slot
from openair.protocol.times import AirTime

# Every character XML 1.0 allows (OA-MSG-14); XML-special ones are made frequent on purpose.
xml_chars = st.one_of(
    st.sampled_from("<>&\"'\r\n\t ;]\x7f\x85\u00a0é日🎉"),
    st.characters(exclude_categories=("Cs", "Cc"), exclude_characters="\ufffe\uffff"),
)
xml_text = st.text(xml_chars, max_size=12)
nonempty_text = st.text(xml_chars, min_size=1, max_size=12)

_names = st.sampled_from(["a", "B", "c-d", "e.f", "_g", "Hh", "trigger", "Type", "ID", "x9"])

times = st.builds(
    AirTime,
    sec=st.integers(min_value=-(2**63), max_value=2**63 - 1),
    msec=st.integers(0, 999),
    usec=st.none() | st.integers(0, 999),
)
reference_times = st.builds(
    AirTime, sec=st.integers(-(2**40), 2**40), msec=st.integers(0, 999), usec=st.none()
)


def _element(depth: int) -> st.SearchStrategy[etree._Element]:
    children = st.lists(_element(depth - 1), max_size=2) if depth > 0 else st.just([])

    def build(
        name: str, attrs: dict[str, str], text: str, kids: list[etree._Element], tail: str
    ) -> etree._Element:
        el = etree.Element(name)
        for key, value in attrs.items():
            el.set(key, value)
        el.text = text or None
        for kid in kids:
            el.append(kid)
        el.tail = tail or None
        return el

    return st.builds(
        build,
        _names,
        st.dictionaries(_names, xml_text, max_size=2),
        xml_text,
        children,
        xml_text,
    )


def _serialize(elements: list[etree._Element]) -> str:
    return "".join(etree.tostring(el, encoding="unicode", with_tail=False) for el in elements)


#: Zero or more elements as the decoder writes them (the top-level tails are dropped).
xml_fragments = st.lists(_element(1), max_size=2).map(_serialize)
nonempty_xml_fragments = st.lists(_element(1), min_size=1, max_size=2).map(_serialize)

_known = {
    "type", "id", "from", "to", "cc", "stored", "isresponse", "inreplyto", "postedtime",
    "receivedtime", "comment", "history", "wbid", "netprotocol", "binarysizes",
    "totalbinarysize", "content", "extensions",
}  # fmt: skip
extra_names = _names.filter(lambda n: n.lower() not in _known)
extras = st.one_of(
    st.builds(Slot, name=extra_names, value=xml_text, is_xml=st.just(False)),
    st.builds(Slot, name=extra_names, value=nonempty_xml_fragments, is_xml=st.just(True)),
)

references = st.builds(
    Reference,
    id=xml_text,
    stored=xml_text,
    type=xml_text,
    sender=xml_text,
    to=xml_text,
    cc=xml_text,
    time=st.none() | reference_times,
)

_decimals = st.floats(allow_nan=False, allow_infinity=False)


@st.composite
def _content(draw: st.DrawFn) -> dict[str, object]:
    if draw(st.booleans()):
        language = draw(st.sampled_from(["xml", "XML", "Xml"]))
        return {"language": language, "content": draw(xml_fragments), "content_is_xml": True}
    language = draw(st.sampled_from(["", "English", "text/plain"]))
    return {"language": language, "content": draw(xml_text), "content_is_xml": False}


@st.composite
def messages(draw: st.DrawFn, *, binary: bool = False) -> Message:
    """Draw a message using every field; `binary` adds chunks (only a frame carries them)."""
    chunks = st.lists(st.binary(max_size=16), max_size=3).map(tuple) if binary else st.just(())
    return Message(
        type=draw(nonempty_text),
        id=draw(xml_text),
        sender=draw(xml_text),
        to=draw(xml_text),
        cc=draw(xml_text),
        stored=draw(xml_text),
        isresponse=draw(xml_text),
        inreplyto=draw(st.none() | references),
        posted=draw(st.none() | times),
        received=draw(st.none() | times),
        priority=draw(st.none() | st.floats(MIN_PRIORITY, MAX_PRIORITY)),
        timetolive=draw(st.none() | _decimals),
        noreply=draw(st.booleans()),
        comment=draw(xml_text),
        history=draw(xml_fragments),
        wbid=draw(st.none() | st.integers(min_value=0, max_value=10**12)),
        netprotocol=draw(xml_text),
        extras=tuple(draw(st.lists(extras, max_size=3))),
        binary=draw(chunks),
        **draw(_content()),  # type: ignore[arg-type]
    )
