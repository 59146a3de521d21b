"""Raw-frame peers for the server adapter tests: a requester and a module that answers.

Everything is bounded with `asyncio.wait_for`; nothing sleeps to synchronise: a test waits for a
reply, a PING round trip, an event set by a peer, or `Dispatcher.drained()`.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Awaitable, Callable, Coroutine
from typing import Any

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.framing import FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.server.aio.app import Server, ServerOptions, start_server

BOUND = 20.0  # seconds: the most any single wait in these tests may take

TRIGGERS = '<triggers><trigger from="WB1" type="Test.*"/></triggers>'


def run(test: Callable[[], Coroutine[Any, Any, None]], bound: float = 45.0) -> None:
    """Run one async test with an overall bound."""

    async def bounded() -> None:
        await asyncio.wait_for(test(), bound)

    asyncio.run(bounded())


async def serving(options: ServerOptions | None = None) -> Server:
    """Start a server on a port the OS picks."""
    base = options or ServerOptions()
    fields = {f: getattr(base, f) for f in base.__dataclass_fields__}
    fields["port"] = 0
    return await start_server(ServerOptions(**fields))


class Raw:
    """A raw connection: write frames or bytes, read whole frames back."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader = reader
        self.writer = writer
        self.frames = FrameReader()
        self.eof = False

    @classmethod
    async def open(cls, port: int, *, local: str | None = None) -> Raw:
        """Connect to the server on 127.0.0.1; from the loopback address `local` when given."""
        bind = (local, 0) if local is not None else None
        reader, writer = await asyncio.open_connection("127.0.0.1", port, local_addr=bind)
        return cls(reader, writer)

    def write(self, data: bytes) -> None:
        self.writer.write(data)

    def send(self, msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> None:
        self.writer.write(encode_frame(to_frame(msg, tag)))

    async def recv(self) -> Message | None:
        """Return the next message, or None at end of stream."""
        return await asyncio.wait_for(self._recv(), BOUND)

    async def _recv(self) -> Message | None:
        while True:
            frame = self.frames.next_frame()
            if frame is not None:
                return from_frame(frame)
            if self.eof:
                return None
            try:
                data = await self.reader.read(65536)
            except ConnectionError:
                data = b""
            if not data:
                self.eof = True
                continue
            self.frames.feed(data)

    async def request(self, msg: Message) -> Message:
        self.send(msg)
        reply = await self.recv()
        assert reply is not None, f"connection closed instead of answering {msg.type}"
        return reply

    async def ping(self) -> None:
        """A PING round trip: everything sent before it has been handled."""
        reply = await self.request(Message(type="PING", to="CNS", sender="Tester"))
        assert reply.type == "PING_SUCCESS", reply

    async def closed_by_server(self) -> bool:
        """Read until end of stream; True when it ends without another frame."""
        return await self.recv() is None

    async def close(self) -> None:
        self.writer.close()
        with contextlib.suppress(Exception):
            await self.writer.wait_closed()


Handler = Callable[[Message], Awaitable[str | None]]


class TestModule:
    """A module that receives deliveries on a callback connection or a listening port.

    The handler returns the reply type (None = the default acknowledgement) or raises
    `asyncio.CancelledError` to stay silent. Every delivery is recorded; `wait_for(n)` waits
    until `n` deliveries of type `kind` have arrived.
    """

    __test__ = False

    def __init__(self, name: str, port: int, handler: Handler | None = None) -> None:
        self.name = name
        self.server_port = port
        self.handler = handler
        self.received: list[Message] = []
        self._changed = asyncio.Event()
        self.primary: Raw | None = None
        self.listener: asyncio.Server | None = None
        self.tasks: set[asyncio.Task[None]] = set()
        self.answer = True

    async def bind(self, *, listen: bool, extensions: str = "") -> Message:
        """BIND (listening on a port of our own) or BIND_NOLISTEN + a callback connection."""
        self.primary = await Raw.open(self.server_port)
        msg = Message(type="BIND_NOLISTEN", to="CNS", sender=self.name)
        if listen:
            self.listener = await asyncio.start_server(self._accepted, "127.0.0.1", 0)
            port = self.listener.sockets[0].getsockname()[1]
            msg = Message(
                type="BIND",
                to="CNS",
                sender=self.name,
                content=f'<tcplocation port="{port}"/>',
                content_is_xml=True,
            )
        if extensions:
            msg = msg.with_extra("extensions", extensions)
        reply = await self.primary.request(msg)
        assert reply.type == "BIND_ACCEPT", reply
        if not listen:
            await self.open_callback(extensions)
        return reply

    async def open_callback(self, extensions: str = "") -> Raw:
        raw = await Raw.open(self.server_port)
        note = Message(type="RECEIVE_NAME_NOTIFICATION", to="CNS", sender=self.name)
        if extensions:
            note = note.with_extra("extensions", extensions)
        raw.send(note, FrameTag.RECEIVE)
        self._spawn(self._serve(raw))
        assert self.primary is not None
        await self.primary.ping()
        return raw

    async def subscribe(self, content: str = TRIGGERS) -> None:
        assert self.primary is not None
        msg = Message(
            type="AIR.Subscribe", to="WB1", sender=self.name, content=content, content_is_xml=True
        )
        reply = await self.primary.request(msg)
        assert reply.type == "RECEIVE_ACCEPT", reply

    def _spawn(self, coro: Coroutine[Any, Any, None]) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self.tasks.add(task)
        task.add_done_callback(self.tasks.discard)

    async def _accepted(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        assert task is not None
        self.tasks.add(task)
        task.add_done_callback(self.tasks.discard)
        await self._serve(Raw(reader, writer))

    async def _serve(self, raw: Raw) -> None:
        with contextlib.suppress(ConnectionError, asyncio.CancelledError):
            while (msg := await raw._recv()) is not None:
                self.received.append(msg)
                self._changed.set()
                kind = await self.handler(msg) if self.handler else None
                if not self.answer or kind == "":
                    continue
                default = {"PING": "PING_SUCCESS", "KEEPALIVE": "KEEPALIVESUCCESS"}
                reply = msg.reply(kind or default.get(msg.type, "RECEIVE_ACCEPT"), sender=self.name)
                raw.send(reply)
        await raw.close()

    def wakeups(self) -> list[Message]:
        """The wakeups a post to WB1 caused (phase updates come from ContextsAndPhases)."""
        return [m for m in self.received if m.type == "AIR.Instruct.Wakeup" and m.sender == "WB1"]

    def count(self, kind: str) -> int:
        if kind == "wakeup":
            return len(self.wakeups())
        return sum(1 for m in self.received if m.type == kind)

    async def wait_for(self, n: int, kind: str = "wakeup") -> None:
        """Wait until `n` deliveries of `kind` have arrived ("wakeup": those from WB1)."""

        async def waiting() -> None:
            while self.count(kind) < n:
                self._changed.clear()
                await self._changed.wait()

        await asyncio.wait_for(waiting(), BOUND)

    async def close(self) -> None:
        if self.primary is not None:
            await self.primary.close()
        if self.listener is not None:
            self.listener.close()
        for task in list(self.tasks):
            task.cancel()
        await asyncio.gather(*self.tasks, return_exceptions=True)


def post(sender: str, n: int, *, kind: str = "Test.Item", priority: float | None = None) -> Message:
    return Message(type=f"{kind}.{n}", to="WB1", sender=sender, priority=priority)
