"""The `binarysizes` marker is searched a read at a time (issue #19), and still found anywhere.

A frame's chunks are only known from its `<binarysizes>` slot; the reader looks for the marker
in the XML as it arrives instead of in the whole XML once it is complete, so one peer's large
frame does not stop the server's loop for the search. These feeds cut the marker at every place,
with the reader's own search and with the server's C one (`find_marker`) when it is built.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from openair.protocol.framing import Frame, FrameReader, FrameTag, encode_frame

_PAD = "x" * 300

try:
    from openair.server.aio.datapath._native import (  # type: ignore[import-not-found]
        find_marker as native_find_marker,
    )
except ImportError:  # no compiler when the package was built
    native_find_marker = None

Search = Callable[[bytearray, int, int], bool] | None
SEARCHES = pytest.mark.parametrize(
    "search",
    [
        None,
        pytest.param(
            native_find_marker,
            id="native",
            marks=pytest.mark.skipif(native_find_marker is None, reason="extension not built"),
        ),
    ],
)


def _frame(marker: str) -> bytes:
    xml = f"<message><type>T</type><content>{_PAD}</content><{marker}>2,3</{marker}></message>"
    return encode_frame(Frame(tag=FrameTag.MESSAGE, xml=xml.encode(), chunks=(b"ab", b"cde")))


@SEARCHES
@pytest.mark.parametrize("marker", ["binarysizes", "BinarySizes", "BINARYSIZES"])
def test_marker_cut_at_every_place_is_found(marker: str, search: Search) -> None:
    data = _frame(marker)
    at = data.index(marker.encode())
    for cut in range(at - 2, at + len(marker) + 2):  # the marker split across two reads
        reader = FrameReader(find_marker=search)
        reader.feed(data[:cut])
        assert reader.next_frame() is None
        reader.feed(data[cut:])
        frame = reader.next_frame()
        assert frame is not None and frame.chunks == (b"ab", b"cde"), cut


@SEARCHES
def test_marker_fed_a_byte_at_a_time_and_the_next_frame_starts_clean(search: Search) -> None:
    plain = encode_frame(Frame(tag=FrameTag.MESSAGE, xml=b"<message><type>U</type></message>"))
    data = _frame("binarySizes") + plain
    reader = FrameReader(find_marker=search)
    frames = []
    for i in range(len(data)):
        reader.feed(data[i : i + 1])
        while (frame := reader.next_frame()) is not None:
            frames.append(frame)
    assert [f.chunks for f in frames] == [(b"ab", b"cde"), ()]  # no marker carried over
