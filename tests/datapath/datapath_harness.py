"""A deterministic harness for the data-path differential tests (issue #20).

One in-process server per run, its connections driven through fake transports: every byte a
connection writes is recorded, the clock (`time.time_ns`) is a fixed value the script advances,
and ids come from a fixed counter, so two runs that behave alike write the same bytes. A run's
`Transcript` holds every connection's output and the stored state (each whiteboard's history,
the router's and the dispatcher's counters); the tests compare transcripts of the reference,
the Python and the native data path.
"""

from __future__ import annotations

import asyncio
import itertools
import time
import uuid
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import pytest

from openair.protocol.codec import to_frame
from openair.protocol.framing import FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.server.aio import app
from openair.server.aio.app import Server, ServerOptions, start_server
from openair.server.aio.datapath import DataPath
from openair.server.aio.datapath.pure import PurePath
from openair.server.aio.protocol import Role, ServerConnection
from openair.server.core import commands as cmd

T0 = 1_764_300_000_000_000_000  # the fixed clock's start (ns)
TRIGGERS = (
    '<triggers><trigger from="WB1" type="Test.*"/>'
    '<trigger from="WB1" type="Late.*" after="5"/></triggers>'
)


def datapaths() -> dict[str, DataPath | None]:
    """The data paths to compare: reference, python, and native when the extension is built."""
    paths: dict[str, DataPath | None] = {"reference": None, "python": PurePath()}
    try:
        from openair.server.aio.datapath.native import NativePath
    except ImportError:
        return paths
    paths["native"] = NativePath()
    return paths


class FakeTransport(asyncio.Transport):
    """Records what the server writes; never buffers, never blocks; closing it ends the
    connection in the next loop turn, as a socket transport does."""

    def __init__(self, port: int) -> None:
        super().__init__()
        self.written = bytearray()
        self.closed = False
        self._port = port
        self.protocol: ServerConnection | None = None

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return ("127.0.0.1", self._port) if name == "peername" else default

    def set_write_buffer_limits(self, high: int | None = None, low: int | None = None) -> None:
        pass

    def write(self, data: bytes | bytearray | memoryview) -> None:
        self.written += data

    def get_write_buffer_size(self) -> int:
        return 0

    def can_write_eof(self) -> bool:
        return False

    def pause_reading(self) -> None:
        pass

    def resume_reading(self) -> None:
        pass

    def close(self) -> None:
        if not self.closed and self.protocol is not None:
            asyncio.get_running_loop().call_soon(self.protocol.connection_lost, None)
        self.closed = True

    def abort(self) -> None:
        self.close()


@dataclass
class Transcript:
    """Everything a run wrote and stored."""

    written: list[bytes] = field(default_factory=list)
    closed: list[bool] = field(default_factory=list)
    history: dict[str, list[Message]] = field(default_factory=dict)
    counters: dict[str, object] = field(default_factory=dict)


@contextmanager
def fixed_clock_and_ids(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[int]]:
    """Patch the wall clock and the id source; the yielded list holds the clock (ns)."""
    now = [T0]
    monkeypatch.setattr(time, "time_ns", lambda: now[0])
    monkeypatch.setattr(cmd, "_id_prefix", "00000000-0000-4000-8000-")
    monkeypatch.setattr(cmd, "_id_counter", itertools.count())
    monkeypatch.setattr(cmd, "_last_time", (-1, AirTime(sec=0)))
    uuids = itertools.count(1)
    monkeypatch.setattr(uuid, "uuid4", lambda: uuid.UUID(int=next(uuids)))
    ports = itertools.count(41000)
    monkeypatch.setattr(app, "free_port", lambda requested: requested or next(ports))
    yield now


def frame(msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> bytes:
    return encode_frame(to_frame(msg, tag))


def request(type_: str, sender: str, to: str, ident: str, content: str = "") -> bytes:
    posted = AirTime(sec=1_764_300_000, msec=1)
    msg = Message(type=type_, id=ident, sender=sender, to=to, posted=posted, content=content)
    return frame(msg)


def frames_of(data: bytes) -> list[bytes]:
    """Return the XML of every complete frame in `data` (the reader's view)."""
    reader = FrameReader()
    reader.feed(data)
    out = []
    while (f := reader.next_frame()) is not None:
        out.append(f.xml)
    return out


class Run:
    """A server and its fake connections for one run of a script."""

    def __init__(self, server: Server, now: list[int]) -> None:
        self.server = server
        self.now = now
        self.conns: list[ServerConnection] = []
        self.transports: list[FakeTransport] = []

    def open(self) -> int:
        transport = FakeTransport(40000 + len(self.conns))
        conn = ServerConnection(self.server, Role.RESPONDER)
        transport.protocol = conn
        conn.connection_made(transport)
        self.conns.append(conn)
        self.transports.append(transport)
        return len(self.conns) - 1

    async def feed(self, index: int, data: bytes, cuts: Sequence[int] = ()) -> None:
        """Hand `data` to connection `index` in reads cut at `cuts`, settling after each."""
        at = 0
        for cut in [*sorted(set(c for c in cuts if 0 < c < len(data))), len(data)]:
            if self.conns[index].is_closing:
                return
            self.conns[index].data_received(data[at:cut])
            at = cut
            await self.settle()

    async def settle(self) -> None:
        """Let every callback and task that is ready run (the dispatcher's included)."""
        for _ in range(30):
            await asyncio.sleep(0)

    def transcript(self) -> Transcript:
        router = self.server.router
        history = {}
        for name in self.server.whiteboards:
            board = router.whiteboard(name)
            assert board is not None
            history[name] = list(board.newest_first())
        counters = {"router": router.counters(), "dispatcher": self.server.dispatcher.counters()}
        return Transcript(
            written=[bytes(t.written) for t in self.transports],
            closed=[t.closed for t in self.transports],
            history=history,
            counters=counters,
        )


async def start(path: DataPath | None, now: list[int]) -> Run:
    """Start a server (no monitor) whose connections use `path`."""
    server = await start_server(ServerOptions(port=0, monitor=False, grace_s=0.05))
    server.datapath = path  # type: ignore[attr-defined]
    return Run(server, now)
