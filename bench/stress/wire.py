"""Raw OpenAIR peers for the attacks, and the canary that times PING round trips."""

from __future__ import annotations

import asyncio
import contextlib
import socket
import threading
import time
from dataclasses import dataclass, field

from openair.codec import from_frame, to_frame
from openair.framing import FrameReader, FrameTag, encode_frame
from openair.message import Message

__all__ = ["Canary", "Raw", "frame_of", "p99"]

BOUND_S = 60.0


def frame_of(msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> bytes:
    """Return the frame bytes of `msg`."""
    return encode_frame(to_frame(msg, tag))


class Raw:
    """A raw connection: write frames or bytes, read whole messages back."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader = reader
        self.writer = writer
        self.frames = FrameReader()
        self.eof = False

    @classmethod
    async def open(cls, port: int) -> Raw:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        return cls(reader, writer)

    def send(self, msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> None:
        self.writer.write(frame_of(msg, tag))

    async def recv(self) -> Message | None:
        """Return the next message, or None at end of stream."""
        async with asyncio.timeout(BOUND_S):
            while True:
                frame = self.frames.next_frame()
                if frame is not None:
                    return from_frame(frame)
                if self.eof:
                    return None
                try:
                    data = await self.reader.read(1 << 16)
                except ConnectionError:
                    data = b""
                self.eof = not data
                if data:
                    self.frames.feed(data)

    async def request(self, msg: Message) -> Message | None:
        self.send(msg)
        return await self.recv()

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.writer.close()


def p99(values: list[float]) -> float:
    """Return the 99th percentile of `values` (0.0 when empty)."""
    if not values:
        return 0.0
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(len(ordered) * 0.99))]


@dataclass(slots=True)
class Canary:
    """A client in its own thread that PINGs every `period_s` and records round trips (ms).

    A PING that gets no answer within the socket timeout counts as one `timeouts`.
    """

    port: int
    period_s: float = 0.02
    samples: list[float] = field(default_factory=list)
    timeouts: int = 0
    _stop: threading.Event = field(default_factory=threading.Event)
    _thread: threading.Thread | None = None

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def take(self) -> list[float]:
        """Return the samples so far and start a new series."""
        taken, self.samples = self.samples, []
        return taken

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(10.0)

    def _run(self) -> None:
        with socket.create_connection(("127.0.0.1", self.port), timeout=10.0) as sock:
            ping = frame_of(Message(type="PING", to="CNS", sender="Canary"))
            reader = FrameReader()
            while not self._stop.is_set():
                began = time.perf_counter()
                sock.sendall(ping)
                try:
                    while reader.next_frame() is None:
                        data = sock.recv(1 << 16)
                        if not data:
                            return
                        reader.feed(data)
                except TimeoutError:
                    self.timeouts += 1
                    continue
                self.samples.append((time.perf_counter() - began) * 1000)
                self._stop.wait(self.period_s)
