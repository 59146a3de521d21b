"""The callback request path of a server connection pairs and fails exactly like the future path."""

from __future__ import annotations

import asyncio
from typing import Any

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.errors import ConnectionClosedError
from openair.protocol.framing import FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.server.aio.connhost import FlowLimits
from openair.server.aio.protocol import Role, ServerConnection
from openair.server.core.config import ServerLimits
from openair.server.core.router import Outcome


class _Transport(asyncio.Transport):
    def __init__(self) -> None:
        super().__init__()
        self.written = bytearray()

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return ("127.0.0.1", 5555) if name == "peername" else default

    def set_write_buffer_limits(self, high: int | None = None, low: int | None = None) -> None:
        pass

    def write(self, data: bytes | bytearray | memoryview) -> None:
        self.written += data

    def get_write_buffer_size(self) -> int:
        return 0

    def can_write_eof(self) -> bool:
        return False

    def close(self) -> None:
        pass

    def abort(self) -> None:
        pass

    def sent(self) -> list[Message]:
        reader = FrameReader()
        reader.feed(bytes(self.written))
        out = []
        while (frame := reader.next_frame()) is not None:
            out.append(from_frame(frame))
        return out


class _Host:
    limits = ServerLimits()
    flow = FlowLimits()

    def connection_opened(self, conn: ServerConnection) -> int:
        return 1

    def handle(
        self, conn: ServerConnection, msg: Message, *, tag: FrameTag, received_ns: int
    ) -> Outcome:
        return Outcome()

    def callback_opened(self, conn: ServerConnection, module: str) -> None:
        pass

    def connection_lost(self, conn: ServerConnection) -> None:
        pass


Outcomes = list[tuple[str, Message | None, BaseException | None]]


def _recorder(outcomes: Outcomes, tag: str) -> Any:
    def record(reply: Message | None, error: BaseException | None) -> None:
        outcomes.append((tag, reply, error))

    return record


def _callback_connection() -> tuple[ServerConnection, _Transport]:
    conn = ServerConnection(_Host(), Role.CALLBACK)
    transport = _Transport()
    conn.connection_made(transport)
    return conn, transport


def _reply(isresponse: str, type_: str = "RECEIVE_ACCEPT") -> bytes:
    return encode_frame(to_frame(Message(type=type_, isresponse=isresponse)))


def test_callbacks_and_futures_are_paired_in_send_order() -> None:
    async def body() -> None:
        conn, transport = _callback_connection()
        outcomes: Outcomes = []
        conn.send_request_cb(
            Message(type="AIR.Instruct.Wakeup", id="w1"), None, _recorder(outcomes, "a")
        )
        future = conn.send_request(Message(type="AIR.Instruct.Wakeup", id="w2"))
        conn.send_request_cb(Message(type="PING", id="w3"), None, _recorder(outcomes, "c"))
        conn.flush()
        assert [m.id for m in transport.sent()] == ["w1", "w2", "w3"]
        conn.data_received(_reply("w1") + _reply("w2") + _reply("", "PING_SUCCESS"))
        assert (await future).isresponse == "w2"
        assert [(tag, r.type if r else None, e) for tag, r, e in outcomes] == [
            ("a", "RECEIVE_ACCEPT", None),
            ("c", "PING_SUCCESS", None),
        ]

    asyncio.run(body())


def test_a_noreply_request_is_settled_at_once_and_a_closed_connection_fails() -> None:
    async def body() -> None:
        conn, _ = _callback_connection()
        outcomes: Outcomes = []
        noreply = Message(type="AIR.Instruct.Wakeup", id="n", noreply=True)
        conn.send_request_cb(noreply, None, _recorder(outcomes, "n"))
        assert outcomes == [("n", noreply, None)]
        conn.send_request_cb(Message(type="X", id="p"), None, _recorder(outcomes, "p"))
        conn.connection_lost(None)
        tag, reply, error = outcomes[-1]
        assert (tag, reply) == ("p", None) and isinstance(error, ConnectionClosedError)
        conn.send_request_cb(Message(type="X", id="q"), None, _recorder(outcomes, "q"))
        assert outcomes[-1][0] == "q" and isinstance(outcomes[-1][2], ConnectionClosedError)

    asyncio.run(body())


def test_an_unanswered_keepalive_callback_is_passed_over() -> None:
    async def body() -> None:
        conn, _ = _callback_connection()
        outcomes: Outcomes = []
        conn.send_request_cb(Message(type="KEEPALIVE", id="k"), None, _recorder(outcomes, "k"))
        conn.send_request_cb(
            Message(type="AIR.Instruct.Wakeup", id="w"), None, _recorder(outcomes, "w")
        )
        conn.data_received(_reply("w"))  # OA-KEEP-3
        assert outcomes[0][0] == "k" and isinstance(outcomes[0][2], asyncio.CancelledError)
        assert outcomes[1][0] == "w" and outcomes[1][1] is not None

    asyncio.run(body())


def test_a_given_frame_is_sent_as_it_is() -> None:
    async def body() -> None:
        conn, transport = _callback_connection()
        msg = Message(type="AIR.Instruct.Wakeup", id="w")
        wire = encode_frame(to_frame(msg))
        conn.send_request_cb(msg, wire, _recorder([], "w"))
        conn.flush()
        assert bytes(transport.written) == wire

    asyncio.run(body())
