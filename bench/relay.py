"""The minimal relay: the baseline every server figure is divided by (`python -m bench.relay`).

It speaks just enough of the framing to forward: a connection whose first frame is `Receive`
becomes a subscriber; every frame from any other connection is copied unchanged to every
subscriber, except `PING`, which is answered. No XML is parsed, nothing is stored, nothing is
acknowledged. It runs on the same event loop machinery as the reference server, so the ratio
isolates what OpenAIR's routing costs above moving frames.
"""

from __future__ import annotations

import argparse
import asyncio
import struct
from typing import ClassVar

_HEADER = struct.Struct("<7sxI")
_PONG = (
    b"<message><type>PING_SUCCESS</type><id>0</id><from>CNS</from><to></to><cc></cc><stored>"
    b'</stored><isresponse></isresponse><postedTime sec="0" msec="0"/><content language=""/>'
    b"</message>"
)


class Relay(asyncio.Protocol):
    """One connection of the relay."""

    subscribers: ClassVar[list[asyncio.Transport]] = []

    def __init__(self) -> None:
        self.buf = bytearray()
        self.transport: asyncio.Transport | None = None
        self.first = True

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport

    def data_received(self, data: bytes) -> None:
        self.buf += data
        pos = 0
        out = bytearray()
        while len(self.buf) - pos >= 12:
            tag, length = _HEADER.unpack_from(self.buf, pos)
            end = pos + 12 + length
            if len(self.buf) < end:
                break
            if self.first and tag == b"Receive":
                assert self.transport is not None
                Relay.subscribers.append(self.transport)
            elif b"<type>PING</type>" in self.buf[pos:end]:
                assert self.transport is not None
                self.transport.write(_HEADER.pack(b"Message", len(_PONG)) + _PONG)
            else:
                out += self.buf[pos:end]
            self.first = False
            pos = end
        del self.buf[:pos]
        if out:
            chunk = bytes(out)
            for sub in Relay.subscribers:
                sub.write(chunk)

    def connection_lost(self, exc: Exception | None) -> None:
        if self.transport in Relay.subscribers:
            Relay.subscribers.remove(self.transport)


async def serve(port: int) -> None:
    """Run the relay on 127.0.0.1:port until cancelled."""
    loop = asyncio.get_running_loop()
    server = await loop.create_server(Relay, "127.0.0.1", port)
    print(f"listening on 127.0.0.1:{server.sockets[0].getsockname()[1]}", flush=True)
    async with server:
        await server.serve_forever()


def main() -> None:
    """Parse `--port` and run."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--port", type=int, default=0)
    asyncio.run(serve(parser.parse_args().port))


if __name__ == "__main__":
    main()
