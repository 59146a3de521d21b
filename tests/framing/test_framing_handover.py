"""Large frames keep the buffer they arrived in (issue #19): no copy of megabytes on the loop.

A frame whose XML is at least `_HAND_OVER` bytes (and carries no chunks) is returned with the
reader's buffer as its XML, a `bytearray`; what followed it stays with the reader. The bytes,
the frames after it and the marker search over windows are the same as before.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from openair.protocol import framing
from openair.protocol.codec import decode_message
from openair.protocol.framing import Frame, FrameLimits, FrameReader, FrameTag, encode_frame

_BIG = framing._HAND_OVER + 5000


def _post(content: bytes) -> bytes:
    return b"<message><type>Test.Big</type><content>" + content + b"</content></message>"


def _frames(data: bytes, read: int) -> list[Frame]:
    reader = FrameReader(FrameLimits(max_xml=4 << 20))
    found: list[Frame] = []
    for at in range(0, len(data), read):
        reader.feed(data[at : at + read])
        while (frame := reader.next_frame()) is not None:
            found.append(frame)
    assert reader.buffered == 0
    return found


@settings(max_examples=25, deadline=None)
@given(read=st.sampled_from([4096, 65536, 262144, 1 << 22]), tail=st.integers(0, 3))
def test_a_large_frame_is_handed_its_buffer_and_the_frames_after_it_stay_intact(
    read: int, tail: int
) -> None:
    big = _post(b"x" * _BIG)
    small = [_post(f"s{i}".encode()) for i in range(tail)]
    data = b"".join(encode_frame(Frame(tag=FrameTag.MESSAGE, xml=x)) for x in [big, *small])
    frames = _frames(data, read)
    assert [bytes(f.xml) for f in frames] == [big, *small]
    assert isinstance(frames[0].xml, bytearray)  # handed over, not copied
    assert all(isinstance(f.xml, bytes) for f in frames[1:])
    assert decode_message(frames[0].xml).content == "x" * _BIG  # the decoders read it as bytes


def test_a_frame_under_the_size_or_with_chunks_is_copied_as_before() -> None:
    under = _post(b"y" * (framing._HAND_OVER - 100))
    chunked = b"<message><type>T</type><binarysizes>3</binarysizes></message>"
    data = encode_frame(Frame(tag=FrameTag.MESSAGE, xml=under)) + encode_frame(
        Frame(tag=FrameTag.MESSAGE, xml=chunked, chunks=(b"abc",))
    )
    first, second = _frames(data, 65536)
    assert type(first.xml) is bytes and first.xml == under
    assert type(second.xml) is bytes and second.chunks == (b"abc",)


@given(
    pad=st.integers(0, 3 * framing._SCAN_WINDOW),
    name=st.sampled_from(["binarysizes", "BinarySizes"]),
)
@settings(max_examples=40, deadline=None)
def test_the_marker_is_found_across_every_window_edge(pad: int, name: str) -> None:
    """`binarysizes` anywhere in a large XML announces chunks, however the windows fall."""
    xml = (
        f"<message><type>T</type><content>{'z' * pad}</content>"
        f"<{name}>2</{name}><comment>{'z' * (3 * framing._SCAN_WINDOW - pad)}</comment></message>"
    ).encode()
    data = encode_frame(Frame(tag=FrameTag.MESSAGE, xml=xml, chunks=(b"ab",)))
    for read in (1000, 65536, 1 << 20):
        (frame,) = _frames(data, read)
        assert frame.chunks == (b"ab",) and bytes(frame.xml) == xml
