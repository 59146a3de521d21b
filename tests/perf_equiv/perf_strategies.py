"""Hypothesis strategies for the fast-path equivalence tests: messages, and hostile documents.

Messages use every field with hostile text (XML specials, \\r, non-ASCII, characters XML
forbids); documents are canonical encodings rewritten into legacy spellings and then mutated
with fragments an attacker or a broken peer would send (DOCTYPE, entities, CDATA, comments,
stray `&`, `]]>`, control bytes, truncation).
"""

from __future__ import annotations

from hypothesis import strategies as st
from lxml import etree

from openair.protocol.errors import ApiMisuseError
from openair.protocol.message import Message, Reference, Slot
from openair.protocol.times import AirTime

# XML-special characters are frequent; a few characters XML 1.0 forbids are included on purpose.
hostile_chars = st.one_of(
    st.sampled_from("<>&\"'\r\n\t ;]=/?!\x7f\x85\u00a0é日🎉"),
    st.sampled_from("\x00\x01\x0b\x1f\ufffe\uffff\ud800"),
    st.characters(exclude_categories=["Cs"]),
)
safe_chars = st.one_of(
    st.sampled_from("<>&\"'\r\n\t ;]\x7f\x85\u00a0é日🎉"),
    st.characters(exclude_categories=("Cs", "Cc"), exclude_characters="\ufffe\uffff"),
)
safe_text = st.text(safe_chars, max_size=10)
hostile_text = st.text(hostile_chars, max_size=10)
texts = st.one_of(safe_text, safe_text, hostile_text)
_plain_names = st.sampled_from(["a", "B", "c-d", "e.f", "_g", "Hh", "x9", "xmlfoo", "extensions"])
_names = st.one_of(_plain_names, st.sampled_from(["Type", "CONTENT", "a:b", "9z", "é", "{u}a"]))

times = st.builds(
    AirTime,
    sec=st.integers(min_value=-(2**63), max_value=2**63 - 1),
    msec=st.integers(0, 999),
    usec=st.none() | st.integers(0, 999),
)


def _fragment_element(name: str, attr: str, text: str) -> str:
    el = etree.Element(name)
    el.set("k", attr)
    el.text = text or None
    return etree.tostring(el, encoding="unicode")


_fragment_names = st.sampled_from(["a", "b", "objectdictionary", "retrieve"])
xml_fragments = st.one_of(
    st.just(""),
    st.lists(st.builds(_fragment_element, _fragment_names, safe_text, safe_text), max_size=2).map(
        "".join
    ),
    safe_text,  # stray text in XML content is kept (escaped) by the decoder
    st.sampled_from(
        [
            '<p:a xmlns:p="urn:x"><p:b k="1"/></p:a>',
            '<a xmlns="urn:y"><b>t</b></a><c/>',
            "<a>x<b/>y</a>",
            "<a>\n  <b/>\n</a>",
        ]
    ),
)

extras = st.one_of(
    st.builds(Slot, name=_names, value=texts, is_xml=st.just(False)),
    st.builds(Slot, name=_names, value=xml_fragments, is_xml=st.just(True)),
)
_writable_extras = st.one_of(
    st.builds(Slot, name=_plain_names, value=safe_text, is_xml=st.just(False)),
    st.builds(Slot, name=_plain_names, value=xml_fragments, is_xml=st.just(True)),
)
references = st.builds(
    Reference,
    id=texts,
    stored=texts,
    type=texts,
    sender=texts,
    to=texts,
    cc=texts,
    time=st.none() | times.map(lambda t: AirTime(sec=t.sec, msec=t.msec)),
)

_writable_references = st.builds(
    Reference,
    id=safe_text,
    type=safe_text,
    sender=safe_text,
    time=st.none() | times.map(lambda t: AirTime(sec=t.sec, msec=t.msec)),
)


@st.composite
def messages(draw: st.DrawFn, *, plain: bool = False, writable: bool = False) -> Message:
    """Draw a message; `plain` keeps to text parts and characters XML allows (the common case).

    `writable` keeps every part but draws only characters and names the writer accepts.
    """
    text = safe_text if plain or writable else texts
    xml_content = not plain and draw(st.booleans())
    language = draw(
        st.sampled_from(
            ["xml", "XML"] if xml_content else ["", "English", "xml"] if not plain else [""]
        )
    )
    return Message(
        type=draw(st.text(safe_chars, min_size=1, max_size=10) if plain else texts),
        id=draw(text),
        sender=draw(text),
        to=draw(text),
        cc=draw(text),
        stored=draw(text),
        isresponse=draw(text),
        inreplyto=draw(st.none() | (_writable_references if writable else references))
        if not plain
        else None,
        posted=draw(st.none() | times),
        received=draw(st.none() | times),
        priority=draw(st.none() | st.floats(0.0, 6.999)),
        timetolive=draw(st.none() | st.floats(allow_nan=not plain, allow_infinity=not plain)),
        noreply=draw(st.booleans()),
        comment=draw(text),
        history=draw(xml_fragments) if not plain else "",
        wbid=draw(st.none() | st.integers(min_value=0, max_value=10**12)),
        netprotocol=draw(text),
        extras=tuple(
            draw(
                st.lists(
                    st.builds(Slot, name=_plain_names, value=text)
                    if plain
                    else _writable_extras
                    if writable
                    else extras,
                    max_size=3,
                )
            )
        ),
        binary=tuple(draw(st.lists(st.binary(max_size=4), max_size=2))),
        language=language,
        content=draw(xml_fragments if xml_content else text),
        content_is_xml=xml_content,
    )


# --- documents -----------------------------------------------------------------------------

_LEGACY_REWRITES: tuple[tuple[bytes, bytes], ...] = (
    (b"<message", b"<MESSAGE"),
    (b"</message>", b"</MESSAGE>"),
    (b"<type>", b"<Type>"),
    (b"</type>", b"</Type>"),
    (b'msec="', b'ms="'),
    (b"<postedTime ", b"<postedtime "),
    (b"<cc/>", b"<cc></cc>"),
    (b"<cc/>", b"<cc>  </cc>"),
    (b'"', b"'"),
    (b"><", b">\n  <"),
    (b"><", b"> <"),
    (b"/>", b" />"),
    (b"</type>", b"</type >"),
    (b"e", b"&#101;"),
    (b"a", b"&#x61;"),
    (b"o", b"&#0000111;"),
    (b"&amp;", b"&#38;"),
    (b"&lt;", b"&#60;"),
    (b"&gt;", b">"),
    (b"'", b"&apos;"),
    (b"<content", b'<content LANGUAGE="x"'),
    (b"<message", b'<message priority="3" '),
    (b"<message", b'<message noreply="No" '),
    (b"<message", b'<message xmlns="urn:x" '),
    (b"<message", b'<message timetolive="1e5" '),
    (b"</message>", b"<extensions>noreply pipelining</extensions></message>"),
    (b"</message>", b"<wbid> 0012 </wbid></message>"),
    (b"</message>", b"<Odd a='1' b=\"2\">text</Odd></message>"),
    (b"</message>", b"<history/></message>"),
    (b"</message>", b"<inreplyto/></message>"),
)
_HOSTILE: tuple[bytes, ...] = (
    b'<!DOCTYPE message [<!ENTITY x "y">]>',
    b"&x;",
    b"&xxe;",
    b"&",
    b"&#0;",
    b"&#x110000;",
    b"&#xD800;",
    b"&#13;",
    b"]]>",
    b"<![CDATA[x]]>",
    b"<!-- c -->",
    b"<?pi x?>",
    b'<?xml version="1.0" encoding="UTF-8"?>',
    b'<?xml version="1.0" encoding="ISO-8859-1"?>',
    b"\r",
    b"\r\n",
    b"\x00",
    b"\x0c",
    b"\xef\xbb\xbf",
    b"\xff",
    b"\xc3",
    b"\xed\xa0\x80",
    b"\xef\xbf\xbe",
    b"<",
    b">",
    b"</",
    b"/>",
    b"<a>",
    b"</a>",
    b"<type>x</type>",
    b"<id>1</id>",
    b'<postedTime sec="1" msec="1000"/>',
    b'<postedTime sec="x"/>',
    b'<receivedTime sec="99999999999999999999"/>',
    b'<content language="xml"><a/></content>',
    b'<content language="xml">t&amp;</content>',
    b'a="1" a="2"',
    b' x="1" X="2"',
    b' priority="9.5"',
    b' noreply="maybe"',
    b"\t",
    b" ",
    b"\n",
    b"'",
    b'"',
    b"=",
)


@st.composite
def documents(draw: st.DrawFn, encode: object) -> bytes:
    """Draw a document: an encoded message, rewritten and then mutated (maybe not at all)."""
    assert callable(encode)
    try:
        data: bytes = encode(draw(messages(plain=draw(st.booleans()))))
    except ApiMisuseError:
        data = b'<message><type>A</type><content language="">x</content></message>'

    for old, new in draw(st.lists(st.sampled_from(_LEGACY_REWRITES), max_size=3)):
        data = data.replace(old, new, draw(st.sampled_from([1, -1])))
    for _ in range(draw(st.integers(0, 3))):
        pos = draw(st.integers(0, len(data)))
        kind = draw(st.integers(0, 3))
        if kind == 0:
            data = data[:pos] + draw(st.sampled_from(_HOSTILE)) + data[pos:]
        elif kind == 1:
            data = data[:pos] + data[pos + draw(st.integers(1, 8)) :]
        elif kind == 2:
            data = data[:pos] + bytes([draw(st.integers(0, 255))]) + data[pos + 1 :]
        else:
            data = data[:pos]
    return data
