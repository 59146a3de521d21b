"""`RawConnection`: a bare connection for cases that need byte-level control.

It goes to the main port, or to a component's own port (`CaseContext.raw(component=)`).
Nothing is answered or paired automatically: the case sends bytes or messages and reads what
comes back, frame by frame. Everything goes to the trace (raw bytes as a hex dump).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message
from openair_conformance.harness.conn import (
    ConnectionLost,
    DecodeProblem,
    FramedStream,
    open_stream,
)
from openair_conformance.model import Inconclusive

if TYPE_CHECKING:
    from openair_conformance.harness.context import CaseContext

__all__ = ["RawConnection"]


class RawConnection:
    """A raw, traced connection to the server's main port."""

    def __init__(
        self, ctx: CaseContext, *, label: str, address: tuple[str, int] | None = None
    ) -> None:
        self.ctx = ctx
        self.label = label
        self.address = address or ctx.target  # the main port, or a component's own port
        self._stream: FramedStream | None = None

    async def open(self) -> None:
        """Connect (INCONCLUSIVE if the server cannot be reached)."""
        host, port = self.address
        try:
            self._stream = await open_stream(
                host, port, label=self.label, trace=self.ctx.trace, timeout=self.ctx.deadline
            )
        except ConnectionLost as exc:
            raise Inconclusive(f"setup: {exc}") from exc

    @property
    def stream(self) -> FramedStream:
        """The underlying framed stream."""
        if self._stream is None:
            raise RuntimeError("raw connection not opened")
        return self._stream

    async def send(self, data: bytes) -> None:
        """Send raw bytes."""
        try:
            await self.stream.send_bytes(data)
        except ConnectionLost as exc:
            self.ctx.fail(f"cannot send: {exc}")

    async def send_message(self, msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> Message:
        """Send one message in a frame with `tag`; return it as sent (postedTime stamped)."""
        try:
            return await self.stream.send_message(msg, tag)
        except ConnectionLost as exc:
            self.ctx.fail(f"cannot send {msg.type}: {exc}")

    async def send_messages(self, msgs: list[Message]) -> list[Message]:
        """Send several Message frames in one write (pipelined); return them as sent."""
        try:
            return await self.stream.send_messages(msgs)
        except ConnectionLost as exc:
            self.ctx.fail(f"cannot send: {exc}")

    async def send_frame(self, frame: Frame) -> None:
        """Send a frame as given, e.g. with XML that is not well-formed (traced as a frame)."""
        try:
            await self.stream.send_frame(frame)
        except ConnectionLost as exc:
            self.ctx.fail(f"cannot send: {exc}")

    async def read_frame(self, *, timeout: float | None = None) -> Frame:
        """Return the next frame (Fail if none in time or the connection ends)."""
        return await self.ctx.wait(
            self.stream.read_frame(), what=f"frame on {self.label}", timeout=timeout
        )

    async def read_message(self, *, timeout: float | None = None) -> Message:
        """Return the next message (Fail if none in time, on end of stream or if unreadable)."""
        frame = await self.read_frame(timeout=timeout)
        try:
            return self.stream.decode(frame)
        except DecodeProblem as exc:
            self.ctx.fail(f"the server sent a message the suite cannot decode: {exc}")

    async def request(self, msg: Message, *, timeout: float | None = None) -> Message:
        """Send a message and return the next message received (no pairing)."""
        await self.send_message(msg)
        return await self.read_message(timeout=timeout)

    async def expect_closed(self, *, timeout: float | None = None) -> None:
        """Wait for the server to close the connection (Fail if it stays open; late: Timing).

        Frames received meanwhile are traced; bytes that break the framing are traced raw.
        """

        async def closed() -> None:
            try:
                while True:
                    await self.stream.read_frame()
            except ConnectionLost as exc:
                if not exc.framing or self.stream.at_eof:
                    return
            try:
                while await self.stream.read_bytes():
                    pass
            except ConnectionLost:
                return

        await self.ctx.wait(
            closed(),
            what=f"close of {self.label} by the server",
            timeout=timeout,
            expected="the server closes the connection",
        )

    @property
    def closed_by_server(self) -> bool:
        """Whether the server has closed its side (as far as reads have seen)."""
        return self.stream.at_eof

    async def close(self) -> None:
        """Close the connection."""
        if self._stream is not None:
            await self._stream.close()
