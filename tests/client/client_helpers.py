"""Helpers shared by the client tests: frames in and out, and a server in a background thread.

The background thread exists only in tests: the CLI and the blocking wrapper run their own event
loop in the calling thread, so the reference server they talk to must run elsewhere.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Coroutine
from typing import Any, TypeVar

from openair.codec import from_frame, to_frame
from openair.framing import FrameLimits, FrameReader, FrameTag, encode_frame
from openair.message import Message

_T = TypeVar("_T")

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


class ServerThread:
    """The reference server on 127.0.0.1 (port 0) in a background event loop (tests only)."""

    def __init__(self, **options: Any) -> None:
        from openair.server.app import ServerOptions, start_server

        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, daemon=True)
        self._thread.start()
        self.server = self.call(start_server(ServerOptions(host="127.0.0.1", port=0, **options)))
        self.port: int = self.server.port

    def call(self, coro: Coroutine[Any, Any, _T], timeout: float = 30.0) -> _T:
        """Run a coroutine on the server's loop and wait for its result."""
        return asyncio.run_coroutine_threadsafe(coro, self._loop).result(timeout)

    def stop(self) -> None:
        """Stop the server and its loop."""
        try:
            self.call(self.server.stop())
        finally:
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(timeout=10)
            self._loop.close()
