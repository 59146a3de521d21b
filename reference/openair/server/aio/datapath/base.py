"""The interface of a data path: the bytes of one socket read in, the rest out, in order (#20).

A data path sits in front of the reference router the way uvicorn puts httptools in front of
h11: the connection offers it the bytes of each read first; it handles the complete frames at
the front that it recognises and returns the bytes it left (the first frame it did not
recognise and everything after it, or an unfinished frame), which the connection's
`FrameReader` and the reference decoder then take as before. Frames are therefore always acted
on in the order they arrived (OA-SESS-2): the data path never skips over a frame.

A data path must give byte-identical output and identical stored state to the reference path
for every input; tests/datapath checks that with generated traffic.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

from openair.protocol.framing import Frame, FrameTag

if TYPE_CHECKING:
    from openair.server.aio.protocol import ServerConnection

__all__ = ["ACK_XML", "MARKER", "MESSAGE_FRAME", "MESSAGE_TAG", "RESPLICE_MAX", "DataPath"]

#: The first 8 header bytes of a Message frame (OA-FRAME-1).
MESSAGE_TAG = b"Message\0"
#: The frame `Responder.route` is told the request came in: only its tag is read.
MESSAGE_FRAME = Frame(tag=FrameTag.MESSAGE)
#: Unread bytes the reader may hold and still be taken back into the data path; more (a large
#: frame arriving over many reads) stays with the reader so no byte is copied twice per read.
RESPLICE_MAX = 64 * 1024
#: `binarysizes` anywhere in the XML, any case: the frame may carry chunks (OA-FRAME-4), so the
#: reader's full rules decide where it ends.
MARKER = re.compile(rb"binarysizes", re.IGNORECASE)

# Text the bytes-level ack recogniser accepts: printable ASCII without `<`, `&` and `>`, so the
# document is valid UTF-8, needs no entity expansion, cannot hold `]]>` and is well-formed.
_T = rb"[\t\n\x20-\x25\x27-\x3b\x3d\x3f-\x7e]*"


def _slot(name: bytes) -> bytes:
    return rb"(?:<" + name + rb">" + _T + rb"</" + name + rb">|<" + name + rb"/>)"


def _time(name: bytes) -> bytes:
    # 18 digits at most: always within the signed 64-bit seconds of OA-TIME-6.
    return rb"(?:<" + name + rb' sec="-?[0-9]{1,18}" msec="[0-9]{1,3}"(?: usec="[0-9]{1,3}")?/>)?'


#: A RECEIVE_ACCEPT reply in the canonical layout of spec 3.5 (what `fast_encode` writes), with
#: no root attributes: exactly the documents the reference decoder reads as a RECEIVE_ACCEPT
#: without error (OA-DELIV-4). Anything else — other layouts, entities, attributes, malformed
#: XML — is left to the full decoder.
ACK_XML = re.compile(
    rb"<message><type>RECEIVE_ACCEPT</type>"
    + b"".join(_slot(n) for n in (b"id", b"from", b"to", b"cc", b"stored", b"isresponse"))
    + _time(b"postedTime")
    + _time(b"receivedTime")
    + rb'<content language="[a-zA-Z0-9_.-]*"(?:/>|>'
    + _T
    + rb"</content>)</message>"
)


class DataPath(Protocol):
    """What a connection asks of its data path."""

    #: `python` or `native` (the reference path is no data path at all).
    name: str
    #: A search for `binarysizes` the connection's `FrameReader` uses instead of its own
    #: (`FrameReader(find_marker=)`): the C extension's; None: the reader's.
    find_marker: Callable[[bytearray, int, int], bool] | None

    def feed(self, conn: ServerConnection, data: bytes, received_ns: int) -> bytes:
        """Act on the complete frames it recognises at the front; return the bytes left.

        `data` is one read; bytes the connection's reader still holds come first (the data
        path may take them back with `FrameReader.take_unread`). Called only while the
        connection is open and not held by a wait or an off-loop decode.
        """
