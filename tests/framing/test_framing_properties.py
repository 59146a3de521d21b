"""Hypothesis properties of the frame reader: round trip, split invariance, stickiness, fuzz."""

from __future__ import annotations

import itertools
import re

from hypothesis import given
from hypothesis import strategies as st

from openair.protocol.errors import RemoteProtocolError
from openair.protocol.framing import Frame, FrameLimits, FrameReader, FrameTag, encode_frame

_MARKER = re.compile(rb"binarysizes", re.IGNORECASE)
_TAG_FIELDS = {b"Message\0", b"Receive\0", b"BinaryM\0"}

chunk = st.binary(max_size=40)
# Characters XML 1.0 allows (no surrogates, no U+FFFE/U+FFFF), escaped as character data.
text = st.text(
    st.characters(min_codepoint=0x20, max_codepoint=0xFFFD, exclude_categories=["Cs"]),
    max_size=30,
).map(lambda s: s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;"))


@st.composite
def message_frames(draw: st.DrawFn) -> Frame:
    """A Message/Receive frame whose XML announces exactly its chunks."""
    tag = draw(st.sampled_from([FrameTag.MESSAGE, FrameTag.RECEIVE]))
    if draw(st.booleans()):
        # Arbitrary bytes: without the word binarysizes they announce no chunk (fast path).
        xml = draw(st.binary(max_size=60).filter(lambda b: not _MARKER.search(b)))
        return Frame(tag=tag, xml=xml)
    chunks = tuple(draw(st.lists(chunk, max_size=4)))
    name = draw(st.sampled_from(["binarysizes", "BinarySizes", "BINARYSIZES"]))
    sizes = ",".join(str(len(c)) for c in chunks)
    total = f"<totalbinarysize>{sum(map(len, chunks))}</totalbinarysize>" if chunks else ""
    xml = (
        f"<message><type>P</type><{name}>{sizes}</{name}>{total}"
        f"<content>{draw(text)}</content></message>"
    ).encode()
    return Frame(tag=tag, xml=xml, chunks=chunks)


frames = st.one_of(message_frames(), chunk.map(lambda c: Frame(tag=FrameTag.BINARY, chunks=(c,))))


def read_all(pieces: list[bytes], limits: FrameLimits | None = None) -> list[Frame]:
    reader = FrameReader(limits)
    out: list[Frame] = []
    for piece in pieces:
        reader.feed(piece)
        while (frame := reader.next_frame()) is not None:
            out.append(frame)
    reader.feed_eof()
    return out


def split(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({c % (len(data) + 1) for c in cuts} | {0, len(data)})
    return [data[a:b] for a, b in itertools.pairwise(points)]


@given(frames)
def test_encode_then_read_is_identity(frame: Frame) -> None:
    assert read_all([encode_frame(frame)]) == [frame]


@given(st.lists(frames, max_size=6))
def test_byte_at_a_time_gives_the_same_frames(batch: list[Frame]) -> None:
    data = b"".join(encode_frame(f) for f in batch)
    assert read_all([data[i : i + 1] for i in range(len(data))]) == batch  # OA-FRAME-11


@given(st.lists(frames, max_size=6), st.lists(st.integers(min_value=0), max_size=12))
def test_any_split_gives_the_same_frames(batch: list[Frame], cuts: list[int]) -> None:
    data = b"".join(encode_frame(f) for f in batch)
    assert read_all(split(data, cuts)) == batch


def operate(reader: FrameReader, op: str) -> None:
    if op == "feed":
        reader.feed(b"Message\0")
    elif op == "next":
        reader.next_frame()
    else:
        reader.feed_eof()


@given(
    st.lists(frames, max_size=3),
    st.binary(min_size=8, max_size=8).filter(lambda b: b not in _TAG_FIELDS),
    st.binary(max_size=30),
    st.lists(st.sampled_from(["feed", "next", "eof"]), min_size=1, max_size=6),
)
def test_error_is_sticky(
    good: list[Frame], bad_field: bytes, rest: bytes, later: list[str]
) -> None:
    reader = FrameReader()
    reader.feed(b"".join(encode_frame(f) for f in good) + bad_field + rest)
    taken = []
    try:
        while (frame := reader.next_frame()) is not None:
            taken.append(frame)
        raise AssertionError("an unknown tag was accepted")
    except RemoteProtocolError as exc:
        first = exc
    assert taken == good and first.name == "FRAME_UNKNOWN_TAG"
    for op in later:  # OA-FRAME-9: every later operation reports the same failure
        try:
            operate(reader, op)
        except RemoteProtocolError as exc:
            assert exc is first
        else:
            raise AssertionError(f"{op} succeeded after a framing error")


@given(st.binary(max_size=300), st.lists(st.integers(min_value=0), max_size=8))
def test_arbitrary_bytes_give_frames_or_a_table_error(data: bytes, cuts: list[int]) -> None:
    # Hostile input never escapes as anything but a framing error from the table.
    reader = FrameReader(FrameLimits(max_xml=200, max_binary=200))
    try:
        for piece in split(data, cuts):
            reader.feed(piece)
            while reader.next_frame() is not None:
                pass
        reader.feed_eof()
    except RemoteProtocolError as exc:
        assert exc.code // 100 == 1  # codes 1xx: the framing errors
        assert reader.error is exc
