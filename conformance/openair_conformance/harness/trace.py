"""The trace of one case: every frame in and out, raw bytes and notes, timed from the case start.

The trace is the evidence a report shows: good enough to fix the bug or to dispute the test. XML
is kept as it travelled (decoded as UTF-8, undecodable bytes escaped); raw bytes are hex-dumped.
Very long entries are cut, saying how much was left out.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from openair_conformance.model import TraceEntry

__all__ = ["MAX_HEX_BYTES", "MAX_TEXT_CHARS", "Trace", "hexdump"]

MAX_TEXT_CHARS = 65_536  # per entry; a 16 MiB frame must not make a 16 MiB report line
MAX_HEX_BYTES = 512


def hexdump(data: bytes, limit: int = MAX_HEX_BYTES) -> str:
    """Render bytes as `offset  hex  ascii` lines (16 bytes a line), cut after `limit` bytes."""
    lines = []
    for offset in range(0, min(len(data), limit), 16):
        chunk = data[offset : offset + 16]
        hexes = " ".join(f"{b:02x}" for b in chunk)
        text = "".join(chr(b) if 32 <= b < 127 else "." for b in chunk)
        lines.append(f"{offset:08x}  {hexes:<47}  {text}")
    if len(data) > limit:
        lines.append(f"… {len(data) - limit} more bytes")
    return "\n".join(lines) if lines else "(no bytes)"


def _cut(text: str) -> str:
    if len(text) <= MAX_TEXT_CHARS:
        return text
    return f"{text[:MAX_TEXT_CHARS]}… ({len(text) - MAX_TEXT_CHARS} more characters)"


class Trace:
    """Collects the `TraceEntry` list of one case; `t` is seconds since the trace began."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._t0 = clock()
        self._entries: list[TraceEntry] = []

    @property
    def origin(self) -> float:
        """When the trace began, on its clock (entries' `t` count from here)."""
        return self._t0

    def elapsed(self) -> float:
        """Seconds since the trace began."""
        return self._clock() - self._t0

    def add(self, conn: str, direction: str, tag: str, text: str) -> int:
        """Append an entry and return its index."""
        entry = TraceEntry(
            t=self.elapsed(), conn=conn, direction=direction, tag=tag, text=_cut(text)
        )
        self._entries.append(entry)
        return len(self._entries) - 1

    def note(self, text: str, conn: str = "") -> int:
        """Append a note (what the suite did or concluded) and return its index."""
        return self.add(conn, "note", "", text)

    def frame(
        self, conn: str, direction: str, tag: str, xml: bytes | bytearray, chunks: int = 0
    ) -> int:
        """Append a frame's XML (and how many binary chunks followed it)."""
        text = xml.decode("utf-8", errors="backslashreplace")
        if chunks:
            text += f"\n[+ {chunks} binary chunk(s)]"
        return self.add(conn, direction, tag, text)

    def raw(self, conn: str, direction: str, data: bytes) -> int:
        """Append raw bytes as a hex dump."""
        return self.add(conn, direction, "", hexdump(data))

    @property
    def entries(self) -> tuple[TraceEntry, ...]:
        """The entries so far, oldest first."""
        return tuple(self._entries)

    def __len__(self) -> int:
        return len(self._entries)
