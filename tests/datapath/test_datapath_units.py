"""The data path's selector, its splitters (C and Python agree) and its ack recogniser (#20)."""

from __future__ import annotations

import pytest
from datapath_harness import datapaths, frame
from hypothesis import given, settings
from hypothesis import strategies as st

from openair.protocol.codec import from_frame
from openair.protocol.errors import OpenAIRError
from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.server.aio.datapath import select
from openair.server.aio.datapath.base import ACK_XML
from openair.server.aio.datapath.pure import split_plain


def test_the_selector_honours_openair_datapath() -> None:
    assert select({"OPENAIR_DATAPATH": "reference"}) is None
    python = select({"OPENAIR_DATAPATH": "python"})
    assert python is not None and python.name == "python"
    with pytest.raises(ValueError, match="OPENAIR_DATAPATH='fast'"):
        select({"OPENAIR_DATAPATH": "fast"})
    default = select({})
    assert default is not None
    assert default.name == ("native" if "native" in datapaths() else "python")


def test_native_is_refused_when_forced_without_the_extension(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "openair.server.aio.datapath.native", None)  # ImportError
    with pytest.raises(ImportError):
        select({"OPENAIR_DATAPATH": "native"})
    fallback = select({})
    assert fallback is not None and fallback.name == "python"


def _frames() -> st.SearchStrategy[bytes]:
    xml = st.sampled_from([b"<message/>", b"<x binarySizes='1'/>", b"BINARYSIZES", b"", b"ab"])
    tag = st.sampled_from([b"Message\0", b"Message\0", b"Receive\0", b"Bogus\0\0\0"])
    one = st.tuples(tag, xml, st.integers(-2, 2)).map(
        lambda t: t[0] + max(len(t[1]) + t[2], 0).to_bytes(4, "little") + t[1]
    )
    return st.lists(one, max_size=6).map(b"".join)


@settings(max_examples=300)
@given(buf=_frames(), cut=st.integers(0, 200), pos=st.integers(0, 30), max_xml=st.integers(0, 12))
def test_the_native_splitter_agrees_with_the_python_one(
    buf: bytes, cut: int, pos: int, max_xml: int
) -> None:
    native = datapaths().get("native")
    if native is None:
        pytest.skip("the native extension is not built")
    data = buf[:cut] if cut < len(buf) else buf
    assert native.split(data, pos, max_xml) == split_plain(data, pos, max_xml)  # type: ignore[union-attr]


_MARKER_ALPHABET = b"bBiInNaArRyYsSzZeE x<>"


@settings(max_examples=500)
@given(
    data=st.lists(
        st.sampled_from([b"binarysizes", b"BinarySizes", b"binarysize", b"bx", b"B"])
        | st.binary(max_size=4)
        | st.sampled_from([bytes([c]) for c in _MARKER_ALPHABET]),
        max_size=30,
    ).map(b"".join),
    start=st.integers(-2, 80),
    end=st.integers(-2, 200),
)
def test_the_native_marker_search_answers_as_a_lowered_search(
    data: bytes, start: int, end: int
) -> None:
    native = datapaths().get("native")
    if native is None or native.find_marker is None:
        pytest.skip("the native extension is not built")
    lo, hi = max(start, 0), min(end, len(data))
    expected = hi > lo and b"binarysizes" in data[lo:hi].lower()
    assert native.find_marker(bytearray(data), start, end) is expected


def test_the_native_marker_search_is_linear_on_many_candidates() -> None:
    """Searching for `b` and `B` again after each candidate was quadratic: a 1 MiB post of
    `bx` held the loop 2.6 s, a 16 MiB one would have held it for minutes (issue #19)."""
    native = datapaths().get("native")
    if native is None or native.find_marker is None:
        pytest.skip("the native extension is not built")
    data = bytearray(b"bx" * (8 << 20)) + b"BINARYSIZES"  # 16 MiB of candidates, then one
    assert native.find_marker(data, 0, len(data)) is True
    assert native.find_marker(data, 0, len(data) - 1) is False
    frame = b"Message\0" + (len(data) - 11).to_bytes(4, "little") + data[:-11]
    assert native.split(frame, 0, 1 << 30) == [(12, len(frame))]  # type: ignore[union-attr]


_POSTED = AirTime(sec=1_764_300_000, msec=7)


@given(
    type_=st.sampled_from(["RECEIVE_ACCEPT", "RECEIVE_ERROR", "PING"]),
    text=st.text(max_size=8),
    priority=st.sampled_from([None, 2.0]),
)
def test_an_ack_is_recognised_only_when_the_decoder_reads_a_receive_accept(
    type_: str, text: str, priority: float | None
) -> None:
    try:
        msg = Message(
            type=type_, id="i", sender=text, isresponse="x", posted=_POSTED, priority=priority
        )
        xml = frame(msg)[12:]
    except OpenAIRError:
        return  # text XML cannot carry: never on the wire
    recognised = ACK_XML.fullmatch(xml) is not None
    decoded = from_frame(Frame(tag=FrameTag.MESSAGE, xml=xml))
    if recognised:
        assert decoded.type == "RECEIVE_ACCEPT"
    if type_ == "RECEIVE_ACCEPT" and priority is None and text.isascii() and text.isalnum():
        assert recognised  # the canonical acks of the kit's own clients take the fast path


@pytest.mark.parametrize(
    "xml",
    [
        b"<message><type>RECEIVE_ACCEPT</type><id>x</id>",
        b"<message><type>RECEIVE_ACCEPT</type><id>a&amp;b</id><from/><to/><cc/><stored/>"
        b'<isresponse/><content language=""/></message>',
        b'<?xml version="1.0"?><message><type>RECEIVE_ACCEPT</type><id/><from/><to/><cc/>'
        b'<stored/><isresponse/><content language=""/></message>',
        b"<message><type>RECEIVE_ACCEPT</type><id/><from/><to/><cc/><stored/><isresponse/>"
        b'<postedTime sec="99999999999999999999" msec="1"/><content language=""/></message>',
        b'<message priority="9"><type>RECEIVE_ACCEPT</type><id/><from/><to/><cc/><stored/>'
        b'<isresponse/><content language=""/></message>',
    ],
)
def test_unusual_or_malformed_acks_go_to_the_decoder(xml: bytes) -> None:
    assert ACK_XML.fullmatch(xml) is None
