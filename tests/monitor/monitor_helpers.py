"""Helpers for the monitor tests: a server with its monitor, a raw HTTP client, an SSE reader.

Nothing sleeps to synchronise: every wait is for bytes, an event or a reply, bounded by BOUND.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator, Callable, Coroutine
from contextlib import asynccontextmanager, suppress
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from openair.server.aio.app import Server, ServerOptions, start_server
from openair.server.aio.observed import ObservedView
from openair_monitor import Monitor, MonitorOptions, attach

BOUND = 15.0  # seconds: the most any single wait may take
ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts" / "monitor"  # screenshots


def run(test: Callable[[], Coroutine[Any, Any, None]], bound: float = 30.0) -> None:
    """Run one async test with an overall bound."""

    async def bounded() -> None:
        await asyncio.wait_for(test(), bound)

    asyncio.run(bounded())


@asynccontextmanager
async def serving(
    monitor: MonitorOptions | None = None, **options: Any
) -> AsyncIterator[tuple[Server, Monitor]]:
    """Start a server on a free port with its monitor (options as given); stop it afterwards.

    With `monitor` (MonitorOptions) the server starts without one and the monitor is attached
    with those options (short deadlines for tests); otherwise the server attaches its own.
    """
    opts = ServerOptions(port=0, grace_s=0.5, **options)
    if monitor is not None:
        opts = replace(opts, monitor=False)
    server = await start_server(opts)
    try:
        if monitor is not None:
            # post, hosts, port: from opts
            server.monitor = await attach(ObservedView(server), monitor)
        assert isinstance(server.monitor, Monitor)
        yield server, server.monitor
    finally:
        await server.stop()


def _headers(lines: list[str]) -> dict[str, str]:
    return {k.lower(): v.strip() for k, _, v in (ln.partition(":") for ln in lines if ln)}


@dataclass
class Reply:
    """One HTTP response."""

    status: int
    headers: dict[str, str]
    body: bytes

    def json(self) -> Any:
        return json.loads(self.body)


@dataclass
class HttpClient:
    """A raw HTTP/1.1 connection: write any bytes, read responses framed by Content-Length."""

    reader: asyncio.StreamReader
    writer: asyncio.StreamWriter
    port: int

    @classmethod
    async def open(cls, port: int) -> HttpClient:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        return cls(reader, writer, port)

    def write(self, data: bytes) -> None:
        self.writer.write(data)

    async def request(
        self,
        method: str,
        path: str,
        *,
        body: bytes = b"",
        headers: dict[str, str] | None = None,
    ) -> Reply:
        head = {"Host": f"127.0.0.1:{self.port}", **(headers or {})}
        if body or method == "POST":
            head["Content-Length"] = str(len(body))
        lines = [f"{method} {path} HTTP/1.1", *(f"{k}: {v}" for k, v in head.items())]
        self.write(("\r\n".join(lines) + "\r\n\r\n").encode() + body)
        return await self.response(head_only=method == "HEAD")

    async def response(self, *, head_only: bool = False) -> Reply:
        """Read one response (a body by Content-Length, or none after HEAD)."""
        raw = await asyncio.wait_for(self.reader.readuntil(b"\r\n\r\n"), BOUND)
        lines = raw.decode("latin-1").split("\r\n")
        status = int(lines[0].split()[1])
        headers = {
            k.lower(): v.strip() for k, _, v in (ln.partition(":") for ln in lines[1:] if ln)
        }
        length = 0 if head_only else int(headers.get("content-length", "0"))
        body = await asyncio.wait_for(self.reader.readexactly(length), BOUND) if length else b""
        return Reply(status, headers, body)

    async def closed(self) -> bool:
        """Wait for the server to close the connection; True when it did (EOF)."""
        data = await asyncio.wait_for(self.reader.read(65536), BOUND)
        while data:
            data = await asyncio.wait_for(self.reader.read(65536), BOUND)
        return True

    async def close(self) -> None:
        self.writer.close()
        with suppress(ConnectionError):
            await self.writer.wait_closed()


async def get(port: int, path: str, **kwargs: Any) -> Reply:
    """One request on a fresh connection."""
    client = await HttpClient.open(port)
    try:
        return await client.request("GET", path, **kwargs)
    finally:
        await client.close()


async def post_json(port: int, body: object, headers: dict[str, str] | None = None) -> Reply:
    client = await HttpClient.open(port)
    try:
        data = json.dumps(body).encode()
        heads = {"Content-Type": "application/json", **(headers or {})}
        return await client.request("POST", "/api/post", body=data, headers=heads)
    finally:
        await client.close()


@dataclass
class SseReader:
    """An open /api/events stream, read event by event."""

    client: HttpClient
    head: Reply
    comments: int = 0
    buffer: list[tuple[str, str]] = field(default_factory=list)
    body: bytearray = field(default_factory=bytearray)  # de-chunked, not yet parsed

    @classmethod
    async def open(cls, port: int, query: str) -> SseReader:
        client = await HttpClient.open(port)
        client.write(f"GET /api/events?{query} HTTP/1.1\r\nHost: localhost\r\n\r\n".encode())
        raw = await asyncio.wait_for(client.reader.readuntil(b"\r\n\r\n"), BOUND)
        lines = raw.decode("latin-1").split("\r\n")
        headers = {
            k.lower(): v.strip() for k, _, v in (ln.partition(":") for ln in lines[1:] if ln)
        }
        return cls(client, Reply(int(lines[0].split()[1]), headers, b""))

    async def block(self) -> bytes:
        """Return the body up to the next empty line, reading chunks (RFC 9112 7.1) as needed."""
        while (end := self.body.find(b"\n\n")) < 0:
            if self.head.headers.get("transfer-encoding") != "chunked":
                self.body += await asyncio.wait_for(self.client.reader.read(65536), BOUND)
                continue
            size_line = await asyncio.wait_for(self.client.reader.readuntil(b"\r\n"), BOUND)
            size = int(size_line.split(b";")[0], 16)
            chunk = await asyncio.wait_for(self.client.reader.readexactly(size + 2), BOUND)
            assert chunk.endswith(b"\r\n") and size > 0, "the stream ended"
            self.body += chunk[:-2]
        block = bytes(self.body[: end + 2])
        del self.body[: end + 2]
        return block

    async def next(self) -> tuple[str, str]:
        """Return the next (event name, data); comments are counted and skipped."""
        while True:
            block = await self.block()
            name, data = "message", []
            for line in block.decode().split("\n"):
                if line.startswith(":"):
                    self.comments += 1
                elif line.startswith("event: "):
                    name = line[7:]
                elif line.startswith("data: "):
                    data.append(line[6:])
            if data:
                return name, "\n".join(data)

    async def until(self, name: str, check: Callable[[Any], bool] = lambda _: True) -> Any:
        """Return the data (parsed JSON) of the first `name` event that passes `check`."""
        while True:
            event, data = await self.next()
            if event == name and check(parsed := json.loads(data)):
                return parsed

    async def close(self) -> None:
        await self.client.close()
