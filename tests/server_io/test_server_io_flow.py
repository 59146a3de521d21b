"""Flow control and requests in flight of one connection, over a scripted transport."""

from __future__ import annotations

import asyncio
from typing import Any

from server_io_helpers import run

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.framing import FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.server.aio.connhost import FlowLimits
from openair.server.aio.protocol import Role, ServerConnection
from openair.server.core.config import ServerLimits
from openair.server.core.router import Outcome


class FakeTransport(asyncio.Transport):
    """Records writes; its write buffer empties only when the test says so."""

    def __init__(self) -> None:
        super().__init__()
        self.written = bytearray()
        self.unflushed = 0
        self.reading = True
        self.aborted = False
        self.closed = False

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return ("127.0.0.1", 5555) if name == "peername" else default

    def set_write_buffer_limits(self, high: int | None = None, low: int | None = None) -> None:
        pass

    def write(self, data: bytes | bytearray | memoryview) -> None:
        self.written += data
        self.unflushed += len(data)

    def get_write_buffer_size(self) -> int:
        return self.unflushed

    def pause_reading(self) -> None:
        self.reading = False

    def resume_reading(self) -> None:
        self.reading = True

    def can_write_eof(self) -> bool:
        return False

    def close(self) -> None:
        self.closed = True

    def abort(self) -> None:
        self.aborted = True

    def replies(self) -> list[Message]:
        reader = FrameReader()
        reader.feed(bytes(self.written))
        out = []
        while (frame := reader.next_frame()) is not None:
            out.append(from_frame(frame))
        return out


class FakeHost:
    """Answers every request PING_SUCCESS, like the router would for PING."""

    def __init__(self, limits: ServerLimits, flow: FlowLimits) -> None:
        self.limits = limits
        self.flow = flow
        self.handled: list[Message] = []

    def connection_opened(self, conn: ServerConnection) -> int:
        return 1

    def handle(
        self, conn: ServerConnection, msg: Message, *, tag: FrameTag, received_ns: int
    ) -> Outcome:
        self.handled.append(msg)
        return Outcome(replies=(msg.reply("PING_SUCCESS", sender="CNS"),))

    def callback_opened(self, conn: ServerConnection, module: str) -> None:
        pass

    def connection_lost(self, conn: ServerConnection) -> None:
        pass


def _pings(n: int, start: int = 0) -> bytes:
    return b"".join(
        encode_frame(to_frame(Message(type="PING", id=f"p{i}", to="CNS")))
        for i in range(start, start + n)
    )


def _connection(
    limits: ServerLimits | None = None, flow: FlowLimits | None = None
) -> tuple[ServerConnection, FakeTransport, FakeHost]:
    host = FakeHost(limits or ServerLimits(), flow or FlowLimits())
    conn = ServerConnection(host, Role.RESPONDER)
    transport = FakeTransport()
    conn.connection_made(transport)
    return conn, transport, host


def test_requests_beyond_max_in_flight_get_limit_exceeded_in_their_turn() -> None:
    async def body() -> None:
        conn, transport, host = _connection(ServerLimits(max_in_flight=3))
        conn.data_received(_pings(5))  # the peer reads nothing: every reply stays buffered
        replies = transport.replies()
        assert [r.isresponse for r in replies] == ["p0", "p1", "p2", "p3", "p4"]  # OA-SESS-2
        assert [r.type for r in replies] == ["PING_SUCCESS"] * 3 + ["RECEIVE_ERROR"] * 2
        assert replies[3].content.startswith("LIMIT_EXCEEDED")  # OA-LIM-5
        assert len(host.handled) == 3
        transport.unflushed = 0  # the peer caught up
        conn.data_received(_pings(1, start=5))
        assert transport.replies()[-1].type == "PING_SUCCESS"

    run(body)


def test_reading_pauses_while_the_write_buffer_is_over_its_mark() -> None:
    async def body() -> None:
        conn, transport, _ = _connection()
        conn.pause_writing()
        assert not transport.reading
        conn.resume_writing()
        assert transport.reading

    run(body)


def test_a_peer_that_never_reads_is_cut_off_at_the_hard_cap() -> None:
    async def body() -> None:
        conn, transport, host = _connection(flow=FlowLimits(hard_cap=2_000))
        conn.data_received(_pings(40))
        assert transport.aborted
        handled = len(host.handled)
        assert handled < 40  # nothing after the cut is processed
        conn.data_received(_pings(3, start=40))
        assert len(host.handled) == handled

    run(body)


def test_a_callback_connection_pairs_replies_in_order() -> None:
    async def body() -> None:
        conn, _, _ = _connection()
        conn.role = Role.CALLBACK
        first = conn.send_request(Message(type="AIR.Instruct.Wakeup", id="w1"))
        second = conn.send_request(Message(type="PING", id="w2"))
        reply_1 = Message(type="RECEIVE_ACCEPT", isresponse="w1")
        reply_2 = Message(type="PING_SUCCESS", isresponse="")  # OA-SESS-33: empty is fine
        conn.data_received(encode_frame(to_frame(reply_1)) + encode_frame(to_frame(reply_2)))
        assert (await first).type == "RECEIVE_ACCEPT"
        assert (await second).type == "PING_SUCCESS"

    run(body)


def test_an_unanswered_keepalive_does_not_block_later_replies() -> None:
    async def body() -> None:
        conn, _, _ = _connection()
        conn.role = Role.OUTBOUND
        keepalive = conn.send_request(Message(type="KEEPALIVE", id="k"))
        wakeup = conn.send_request(Message(type="AIR.Instruct.Wakeup", id="w"))
        conn.data_received(encode_frame(to_frame(Message(type="RECEIVE_ACCEPT", isresponse="w"))))
        assert (await wakeup).isresponse == "w"  # OA-KEEP-3
        assert keepalive.cancelled()

    run(body)
