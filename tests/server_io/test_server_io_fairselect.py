"""Each peer address gets at most a few sockets per loop turn (issue #19, `FairSelector`).

The flood of ends of stream, closes and reads of one address's many connections is work of one
turn that no `data_received` sees; the selector hands the loop at most `PER_PEER` ready sockets
of each address when others are connected, so another address's request is taken in the first
turn, not after the flood's.
"""

from __future__ import annotations

import asyncio
import contextlib
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.framing import FrameReader, encode_frame
from openair.protocol.message import Message
from openair.protocol.objects import parse_dictionary
from openair.server.aio.app import ServerOptions, start_server
from openair.server.aio.fairselect import PER_PEER, FairSelector, fair_event_loop, peer_of
from openair.server.aio.protocol import ServerConnection

PING = encode_frame(to_frame(Message(type="PING", to="CNS", sender="Flood")))


class _Transport(asyncio.Transport):
    def __init__(self, peer: str) -> None:
        super().__init__({"peername": (peer, 4000)})

    def _read_ready(self) -> None:  # what asyncio's reader handle calls
        pass


def _readable_pair() -> tuple[socket.socket, socket.socket]:
    a, b = socket.socketpair()
    b.send(b"x")  # `a` is readable until it is read: level-triggered
    return a, b


@pytest.fixture
def pairs() -> Iterator[list[socket.socket]]:
    made: list[socket.socket] = []
    yield made
    for sock in made:
        sock.close()


def _register(selector: FairSelector, peer: str | None, pairs: list[socket.socket]) -> int:
    loop = asyncio.new_event_loop()
    try:
        a, b = _readable_pair()
        pairs += [a, b]
        callback = _Transport(peer)._read_ready if peer else (lambda: None)
        handle = asyncio.Handle(callback, (), loop)
        key = selector.register(a, 1, (handle, None))
        assert peer_of(key) == peer
        return key.fd
    finally:
        loop.close()


def test_the_selector_hands_over_a_few_sockets_of_each_address(pairs: list[socket.socket]) -> None:
    selector = FairSelector()
    busy = {_register(selector, "10.0.0.1", pairs) for _ in range(3 * PER_PEER)}
    other = _register(selector, "10.0.0.2", pairs)
    listener = _register(selector, None, pairs)  # not a transport: never held back
    first = {key.fd for key, _ in selector.select(0)}
    assert other in first and listener in first
    assert len(first & busy) == PER_PEER
    assert selector.postponed == 2 * PER_PEER
    second = {key.fd for key, _ in selector.select(0)}
    assert len(second & busy) == PER_PEER and not (second & busy & first)  # round robin
    third = {key.fd for key, _ in selector.select(0)}
    assert (first | second | third) & busy == busy  # every socket had its turn
    selector.close()


def test_with_one_address_every_ready_socket_is_handed_over(pairs: list[socket.socket]) -> None:
    selector = FairSelector()
    busy = {_register(selector, "10.0.0.1", pairs) for _ in range(3 * PER_PEER)}
    assert not selector.shared
    assert {key.fd for key, _ in selector.select(0)} == busy
    assert selector.postponed == 0
    selector.close()


def test_unregistered_sockets_no_longer_count_as_an_address(pairs: list[socket.socket]) -> None:
    selector = FairSelector()
    for _ in range(2 * PER_PEER):
        _register(selector, "10.0.0.1", pairs)
    _register(selector, "10.0.0.2", pairs)
    assert selector.shared
    selector.unregister(pairs[-2])
    assert not selector.shared
    assert len(selector.select(0)) == 2 * PER_PEER
    selector.close()


class _FairServer:
    """The reference server on a `fair_event_loop` in a thread of its own."""

    def __init__(self) -> None:
        self.loop = fair_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        opts = ServerOptions(host="127.0.0.1", port=0)
        self.server: Any = asyncio.run_coroutine_threadsafe(start_server(opts), self.loop).result(
            30
        )

    def hold(self, seconds: float) -> None:
        """Keep the loop busy for `seconds` (its sockets' data piles up meanwhile)."""
        started = threading.Event()

        def busy() -> None:
            started.set()
            time.sleep(seconds)

        self.loop.call_soon_threadsafe(busy)
        assert started.wait(10)

    def stop(self) -> None:
        with contextlib.suppress(Exception):
            asyncio.run_coroutine_threadsafe(self.server.stop(), self.loop).result(10)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10)
        self.loop.close()


def _connect(port: int, address: str) -> socket.socket:
    sock = socket.create_connection(("127.0.0.1", port), timeout=10, source_address=(address, 0))
    sock.sendall(PING)
    assert sock.recv(65536)  # accepted, registered and answered
    return sock


def test_another_address_is_served_in_the_first_turn_not_after_the_flood(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    reads: list[str] = []
    original = ServerConnection.data_received

    def recording(self: ServerConnection, data: bytes) -> None:
        reads.append(self.peer[0])
        original(self, data)

    monkeypatch.setattr(ServerConnection, "data_received", recording)
    fair = _FairServer()
    socks: list[socket.socket] = []
    try:
        port = fair.server.port
        socks = [_connect(port, "127.0.0.1") for _ in range(10 * PER_PEER)]
        other = _connect(port, "127.0.0.2")
        reads.clear()
        fair.hold(0.3)
        for sock in socks:
            sock.sendall(PING)  # all ready together when the loop polls again
        other.sendall(PING)
        assert other.recv(65536)
        for sock in socks:
            assert sock.recv(65536)
        assert len(reads) == len(socks) + 1
        # Without the selector the other address's read came after all 160 of the flood.
        assert reads.index("127.0.0.2") <= PER_PEER, reads
        socks.append(other)
    finally:
        for sock in socks:
            sock.close()
        fair.stop()


def _serve(*args: str) -> tuple[subprocess.Popen[str], int]:
    code = "from openair.server.cli_serve import serve; serve()"
    argv = [sys.executable, "-c", code, "--port", "0", "--log-level", "warning", *args]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert line.startswith("listening on 127.0.0.1:"), line
    return proc, int(line.split(":", 1)[1].split()[0])


def _status(port: int) -> dict[str, str]:
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(encode_frame(to_frame(Message(type="STATUS", to="CNS", sender="T"))))
        reader = FrameReader()
        while (frame := reader.next_frame()) is None:
            reader.feed(sock.recv(65536))
    return dict(parse_dictionary(from_frame(frame).content).entries)


@pytest.mark.parametrize("slice_ms", ["1", "0"])
def test_openair_serve_polls_fairly_unless_fairness_is_off(slice_ms: str) -> None:
    proc, port = _serve("--fair-slice-ms", slice_ms)
    socks: list[socket.socket] = []
    try:
        socks = [_connect(port, "127.0.0.1") for _ in range(4 * PER_PEER)]
        socks.append(_connect(port, "127.0.0.2"))
        proc.send_signal(signal.SIGSTOP)  # every PING below is ready at its next poll
        try:
            for sock in socks:
                sock.sendall(PING)
        finally:
            proc.send_signal(signal.SIGCONT)
        for sock in socks:
            assert sock.recv(65536)
        postponed = int(_status(port)["fairness.postponed"])
        assert postponed >= 3 * PER_PEER if slice_ms != "0" else postponed == 0
    finally:
        for sock in socks:
            sock.close()
        proc.terminate()
        proc.wait(timeout=20)
