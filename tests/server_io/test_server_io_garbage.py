"""A closed connection is freed by reference counting, not left to the garbage collector.

After a flood of connections, every object a closed connection left in a reference cycle waited
for a gen-0 collection, and collections of tens of thousands of them stopped the event loop for
20 ms (issue #19). The clients here are plain blocking sockets on a thread, so every asyncio
object the collector finds is the server's.
"""

from __future__ import annotations

import asyncio
import gc
import socket
from collections import Counter
from collections.abc import Callable

import pytest
from server_io_helpers import run, serving

from openair.protocol.codec import to_frame
from openair.protocol.framing import FrameReader, encode_frame
from openair.protocol.message import Message

_CONNECTIONS = 50


def _client(port: int, i: int) -> None:
    """Bind a name, PING, and close: a module that came and went."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        reader = FrameReader()
        for kind in ("BIND_NOLISTEN", "PING"):
            sock.sendall(encode_frame(to_frame(Message(type=kind, to="CNS", sender=f"Gone{i}"))))
            while reader.next_frame() is None:
                data = sock.recv(65536)
                assert data, "the server closed the connection"
                reader.feed(data)


def _http_client(port: int, i: int) -> None:
    """Half an HTTP request to the monitor on the main port, then away."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(b"GET /api/overview HTTP/1.1\r\nHost: localhost\r\n")


@pytest.mark.parametrize("client", [_client, _http_client], ids=["openair", "monitor"])
def test_closed_connections_leave_no_reference_cycles(client: Callable[[int, int], None]) -> None:
    found: Counter[str] = Counter()

    async def body() -> None:
        server = await serving()
        gc.collect()
        gc.disable()
        gc.set_debug(gc.DEBUG_SAVEALL)
        try:
            for i in range(_CONNECTIONS):
                await asyncio.to_thread(client, server.port, i)
            for _ in range(50):  # until the server has seen every connection end
                if not server._conns and server.turns is not None and not server.turns.shared:
                    break
                await asyncio.sleep(0.02)
            assert not server._conns
            await asyncio.sleep(0.1)  # the monitor's connections end on their own
            gc.collect()
            found.update(type(obj).__qualname__ for obj in gc.garbage)
        finally:
            gc.set_debug(0)
            gc.garbage.clear()
            gc.enable()
        await server.stop()

    run(body)
    server_side = {
        kind: n
        for kind, n in found.items()
        if kind
        in {
            "ServerConnection",
            "Responder",
            "Requester",
            "_SelectorSocketTransport",
            "HttpConnection",
        }
    }
    assert not server_side, server_side
