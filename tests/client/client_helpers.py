"""Helpers shared by the client tests: frames in and out, and a server in a background thread.

The background thread exists only in tests: the CLI and the blocking wrapper run their own event
loop in the calling thread, so the reference server they talk to must run elsewhere.
"""

from __future__ import annotations

from server_thread import ReferenceServer as ServerThread  # noqa: F401 (re-exported)

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.framing import FrameLimits, FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message

#: A fixed clock for sans-I/O tests: 2026-11-22T10:00:00.123456 UTC in nanoseconds.
FIXED_NS = 1_795_341_600_123_456_789


def wire(msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> bytes:
    """Return the frame bytes for `msg`, as a server would send them."""
    return encode_frame(to_frame(msg, tag))


def frames(data: bytes) -> list[tuple[FrameTag, Message]]:
    """Decode every complete frame in `data` (what the client sent)."""
    reader = FrameReader(FrameLimits())
    reader.feed(data)
    out: list[tuple[FrameTag, Message]] = []
    while (frame := reader.next_frame()) is not None:
        out.append((frame.tag, from_frame(frame)))
    return out


def one(data: bytes) -> Message:
    """Decode exactly one frame's message from `data`."""
    decoded = frames(data)
    assert len(decoded) == 1, decoded
    return decoded[0][1]
