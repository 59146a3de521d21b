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
from openair.protocol.framing import FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.server.aio.app import Server

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


def _garbage_after(
    client: Callable[[int, int], None], count: int, ended: Callable[[Server], bool]
) -> Counter[str]:
    """Run `client` `count` times against a fresh server, wait until `ended(server)`, and
    count by type what a collection then finds in reference cycles (collector off meanwhile)."""
    found: Counter[str] = Counter()

    async def body() -> None:
        server = await serving()
        gc.collect()
        gc.disable()
        gc.set_debug(gc.DEBUG_SAVEALL)
        try:
            for i in range(count):
                await asyncio.to_thread(client, server.port, i)
            for _ in range(250):
                if ended(server):
                    break
                await asyncio.sleep(0.02)
            assert ended(server)
            await asyncio.sleep(0.1)  # the monitor's connections end on their own
            gc.collect()
            found.update(type(obj).__qualname__ for obj in gc.garbage)
        finally:
            gc.set_debug(0)
            gc.garbage.clear()
            gc.enable()
        await server.stop()

    run(body)
    return found


def _all_closed(server: Server) -> bool:
    """Every connection ended (the server's and the monitor's: one address no longer open)."""
    return not server._conns and server.turns is not None and not server.turns.shared


@pytest.mark.parametrize("client", [_client, _http_client], ids=["openair", "monitor"])
def test_closed_connections_leave_no_reference_cycles(client: Callable[[int, int], None]) -> None:
    found = _garbage_after(client, _CONNECTIONS, _all_closed)
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


def _send(sock: socket.socket, msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> None:
    sock.sendall(encode_frame(to_frame(msg, tag)))


def _recv(sock: socket.socket, reader: FrameReader) -> None:
    while reader.next_frame() is None:
        data = sock.recv(65536)
        assert data, "the server closed the connection"
        reader.feed(data)


def _leaver(port: int, i: int) -> None:
    """A module that is woken and leaves before it acknowledges: its delivery is in flight."""
    name = f"Leaver{i}"
    with (
        socket.create_connection(("127.0.0.1", port), timeout=10) as primary,
        socket.create_connection(("127.0.0.1", port), timeout=10) as callback,
        socket.create_connection(("127.0.0.1", port), timeout=10) as poster,
    ):
        replies, wakeups, acks = FrameReader(), FrameReader(), FrameReader()
        _send(primary, Message(type="BIND_NOLISTEN", to="CNS", sender=name))
        _recv(primary, replies)
        _send(
            callback,
            Message(type="RECEIVE_NAME_NOTIFICATION", to="CNS", sender=name),
            FrameTag.RECEIVE,
        )
        triggers = f'<triggers><trigger from="WB1" type="Test.Leave.{i}"/></triggers>'
        _send(
            primary,
            Message(
                type="AIR.Subscribe", to="WB1", sender=name, content=triggers, content_is_xml=True
            ),
        )
        _recv(primary, replies)
        _send(
            poster, Message(type=f"Test.Leave.{i}", to="WB1", sender="Poster", content="x" * 1000)
        )
        _recv(poster, acks)
        _recv(callback, wakeups)  # woken, never acknowledged


def test_a_module_that_leaves_with_a_delivery_in_flight_leaves_no_cycle() -> None:
    """The cancelled delivery task's traceback held its frame, whose locals held the module's
    delivery state, which held the task: each module that left with a wakeup in flight kept its
    queue, that wakeup and its connection until a full collection (issue #19)."""

    def discarded(server: Server) -> bool:  # every queue discarded (OA-SESS-15)
        return not any(n.startswith("Leaver") for n in server.dispatcher.modules)

    found = _garbage_after(_leaver, 10, discarded)
    held = {
        k: n for k, n in found.items() if k in {"ModuleDelivery", "ServerConnection", "QueueItem"}
    }
    assert not held, held
