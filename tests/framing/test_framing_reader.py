"""FrameReader, encode_frame and binary_sizes: behaviour the vectors do not pin down alone."""

from __future__ import annotations

import pytest

from openair.protocol.errors import (
    ApiMisuseError,
    BinarySizesInvalidError,
    BinaryTooLargeError,
    FrameTooLargeError,
    FrameTruncatedError,
    FrameUnknownTagError,
)
from openair.protocol.framing import (
    DEFAULT_MAX_BINARY,
    DEFAULT_MAX_XML,
    Frame,
    FrameLimits,
    FrameReader,
    FrameTag,
    binary_sizes,
    encode_frame,
)

PING = b"<message><type>PING</type><to>CNS</to></message>"


def sized(sizes: str, total: str | None = None) -> bytes:
    slots = f"<binarysizes>{sizes}</binarysizes>"
    if total is not None:
        slots += f"<totalbinarysize>{total}</totalbinarysize>"
    return f"<message><type>Vec</type>{slots}</message>".encode()


def drain(reader: FrameReader) -> list[Frame]:
    out: list[Frame] = []
    while (frame := reader.next_frame()) is not None:
        out.append(frame)
    return out


# -- values -------------------------------------------------------------------------------------


def test_reprs_are_valid_python() -> None:
    frame = Frame(tag=FrameTag.MESSAGE, xml=PING, chunks=(b"\x00\xff",))
    assert eval(repr(frame)) == frame
    assert repr(FrameTag.BINARY) == "FrameTag.BINARY"
    assert eval(repr(FrameLimits(max_xml=5))) == FrameLimits(max_xml=5)


def test_default_limits() -> None:
    assert FrameLimits() == FrameLimits(max_xml=16 * 1024 * 1024, max_binary=64 * 1024 * 1024)
    assert (DEFAULT_MAX_XML, DEFAULT_MAX_BINARY) == (16_777_216, 67_108_864)  # OA-LIM-1/2


@pytest.mark.parametrize(
    "kwargs",
    [{"xml": b"<x/>", "chunks": (b"a",)}, {"chunks": ()}, {"chunks": (b"a", b"b")}],
)
def test_binarym_frame_carries_exactly_one_chunk(kwargs: dict[str, object]) -> None:
    with pytest.raises(ApiMisuseError):
        Frame(tag=FrameTag.BINARY, **kwargs)  # type: ignore[arg-type]


def test_negative_limits_are_misuse() -> None:
    with pytest.raises(ApiMisuseError):
        FrameLimits(max_binary=-1)


# -- encoding -----------------------------------------------------------------------------------


def test_header_matches_the_spec_example() -> None:
    # Spec 2.1: a Message frame with 288 bytes of XML starts 4d 65 73 73 61 67 65 00 20 01 00 00.
    data = encode_frame(Frame(tag=FrameTag.MESSAGE, xml=b"x" * 288))
    assert data[:12] == bytes.fromhex("4d 65 73 73 61 67 65 00 20 01 00 00")
    assert len(data) == 12 + 288


def test_length_counts_utf8_bytes() -> None:
    xml = "<message><type>Grüße ☃</type></message>".encode()
    data = encode_frame(Frame(tag=FrameTag.RECEIVE, xml=xml))
    assert data[:8] == b"Receive\0"
    assert int.from_bytes(data[8:12], "little") == len(xml)  # OA-FRAME-3


def test_encode_chunks_follow_the_xml() -> None:
    xml = sized("2,0,3", "5")
    data = encode_frame(Frame(tag=FrameTag.MESSAGE, xml=xml, chunks=(b"ab", b"", b"cde")))
    assert data == b"Message\0" + len(xml).to_bytes(4, "little") + xml + b"abcde"


def test_encode_binarym_carries_the_chunk_as_body() -> None:
    data = encode_frame(Frame(tag=FrameTag.BINARY, chunks=(b"\x01\x02\x03",)))
    assert data == b"BinaryM\0\x03\x00\x00\x00\x01\x02\x03"  # OA-FRAME-5


# -- reading ------------------------------------------------------------------------------------


def test_huge_length_is_refused_after_the_12_header_bytes() -> None:
    reader = FrameReader()
    header = b"Message\0" + (DEFAULT_MAX_XML + 1).to_bytes(4, "little")
    reader.feed(header[:11])
    assert reader.next_frame() is None
    reader.feed(header[11:])
    with pytest.raises(FrameTooLargeError):  # OA-FRAME-7: no body byte was fed or awaited
        reader.next_frame()
    assert reader.buffered == 0


def test_binarym_over_limit_is_refused_from_the_header() -> None:
    reader = FrameReader(FrameLimits(max_binary=3))
    reader.feed(b"BinaryM\0\x04\x00\x00\x00")
    with pytest.raises(BinaryTooLargeError):
        reader.next_frame()


def test_chunk_total_over_limit_is_refused_before_any_chunk() -> None:
    xml = sized("3,4")
    reader = FrameReader(FrameLimits(max_binary=6))
    reader.feed(b"Message\0" + len(xml).to_bytes(4, "little") + xml)
    with pytest.raises(BinaryTooLargeError):
        reader.next_frame()


def test_unknown_tag_is_refused_at_the_first_impossible_byte() -> None:
    reader = FrameReader()
    reader.feed(b"Mes")
    assert reader.next_frame() is None
    reader.feed(b"S")
    with pytest.raises(FrameUnknownTagError):  # OA-FRAME-6: at once
        reader.next_frame()


def test_feed_accepts_bytearray_and_memoryview() -> None:
    data = encode_frame(Frame(tag=FrameTag.MESSAGE, xml=PING))
    reader = FrameReader()
    reader.feed(bytearray(data[:5]))
    reader.feed(memoryview(data)[5:])
    assert drain(reader) == [Frame(tag=FrameTag.MESSAGE, xml=PING)]


def test_buffered_and_in_frame() -> None:
    data = encode_frame(Frame(tag=FrameTag.MESSAGE, xml=PING))
    reader = FrameReader()
    assert (reader.buffered, reader.in_frame) == (0, False)
    reader.feed(data[:-1])
    assert reader.next_frame() is None
    assert (reader.buffered, reader.in_frame) == (len(data) - 1, True)  # OA-FRAME-12's clock runs
    reader.feed(data[-1:] + data[:3])
    assert reader.next_frame() == Frame(tag=FrameTag.MESSAGE, xml=PING)
    assert (reader.buffered, reader.in_frame) == (3, True)


def test_eof_between_frames_is_clean_and_final() -> None:
    reader = FrameReader()
    reader.feed(encode_frame(Frame(tag=FrameTag.MESSAGE, xml=PING)))
    reader.feed_eof()
    reader.feed_eof()  # idempotent
    assert drain(reader) == [Frame(tag=FrameTag.MESSAGE, xml=PING)]
    assert reader.next_frame() is None
    assert reader.error is None
    with pytest.raises(ApiMisuseError):
        reader.feed(b"M")


def test_eof_inside_a_frame_discards_it() -> None:
    reader = FrameReader()
    reader.feed(encode_frame(Frame(tag=FrameTag.MESSAGE, xml=PING))[:-3])
    assert reader.next_frame() is None
    with pytest.raises(FrameTruncatedError):  # OA-FRAME-8
        reader.feed_eof()
    assert reader.buffered == 0
    assert isinstance(reader.error, FrameTruncatedError)


def test_eof_keeps_complete_frames_then_reports_truncation() -> None:
    one = encode_frame(Frame(tag=FrameTag.MESSAGE, xml=PING))
    reader = FrameReader()
    reader.feed(one + one + one[:4])
    reader.feed_eof()  # two complete frames wait: nothing is lost yet
    assert reader.next_frame() == Frame(tag=FrameTag.MESSAGE, xml=PING)
    assert reader.next_frame() == Frame(tag=FrameTag.MESSAGE, xml=PING)
    with pytest.raises(FrameTruncatedError):
        reader.next_frame()


def test_sticky_error_is_the_same_object_every_time() -> None:
    reader = FrameReader()
    reader.feed(b"Receive\x01")
    with pytest.raises(FrameUnknownTagError) as first:
        reader.next_frame()
    for _ in range(3):
        with pytest.raises(FrameUnknownTagError) as again:
            reader.feed(b"ignored")
        assert again.value is first.value
    assert reader.error is first.value
    assert not reader.in_frame


def test_buffer_does_not_grow_with_the_stream() -> None:
    # White-box: consumed bytes are compacted away, so memory follows the unread bytes only.
    data = encode_frame(Frame(tag=FrameTag.MESSAGE, xml=b"<message>" + b"x" * 990 + b"</message>"))
    reader = FrameReader()
    for _ in range(500):
        reader.feed(data[:700])
        assert reader.next_frame() is None
        reader.feed(data[700:])
        assert reader.next_frame() is not None
    assert len(reader._buf) < 2 * 65536


# -- binary_sizes -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("xml", "sizes"),
    [
        (PING, ()),
        (sized("1,2", "3"), (1, 2)),
        (sized(" 10 ,\n0 "), (10, 0)),
        (sized(""), ()),
        (sized("0012", "12"), (12,)),
        (b"<MESSAGE><BINARYSIZES>4</BINARYSIZES></MESSAGE>", (4,)),
        (b"<message><binarysizes>4</binarysizes>", ()),  # unparsable: OA-FRAME-13
        (b"<other><binarysizes>4</binarysizes></other>", ()),
        (b"<message><content><binarysizes>4</binarysizes></content></message>", ()),
        (b"<message><totalbinarysize>4</totalbinarysize></message>", ()),
    ],
)
def test_binary_sizes(xml: bytes, sizes: tuple[int, ...]) -> None:
    assert binary_sizes(xml) == sizes


@pytest.mark.parametrize(
    "xml",
    [
        sized("-1"),
        sized("1;2"),
        sized("1,"),
        sized("١"),  # an Arabic-Indic digit is not an ASCII digit
        sized("1,2", "4"),
        sized("1", " "),
        b"<message><binarysizes>1</binarysizes><BinarySizes>1</BinarySizes></message>",
    ],
)
def test_invalid_binary_sizes(xml: bytes) -> None:
    with pytest.raises(BinarySizesInvalidError):  # OA-FRAME-4
        binary_sizes(xml)


def test_enormous_sizes() -> None:
    big = "9" * 50
    assert binary_sizes(sized(big, big)) == (int(big),)
    assert binary_sizes(sized(f"{big},1", "1" + "0" * 50)) == (int(big), 1)
    with pytest.raises(BinaryTooLargeError):
        binary_sizes(sized("9" * 5000))
    with pytest.raises(BinarySizesInvalidError):
        binary_sizes(sized("1", "9" * 5000))
