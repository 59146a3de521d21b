"""The session vectors (spec/vectors/sessions) drive both ends through the one connection machine.

For each connection of a vector session, a server end (`Connection` with `SERVER_RULES`, as the
server's asyncio Protocol holds it) and a client end (`ClientConnection`, which holds the same
machine with `CLIENT_RULES`) replay the session without I/O: the client sends each request as
bytes, the server end records it and answers the oldest with the reply the vector expects, and the
client pairs that reply with the request the vector names (`$id-of-step-N`, OA-SESS-33,
OA-SESS-2). A `Receive` frame turns both ends around (OA-SESS-7, OA-SESS-28); each expected wakeup
is then a request the server end sends on the module's callback connection (or on a connection it
opened to the module's port, OA-DELIV-1), answered by the client end (OA-DELIV-4) and paired by
the server end. Frames a client cannot send (undecodable XML, broken headers) take the client end
of that connection out of the replay; the server end goes on with `Invalid`-style requests.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from openair.client.session import ClientConnection, Closed, Reply, Request
from openair.protocol.codec import decode_message, from_frame, to_frame
from openair.protocol.connection import SERVER_RULES, Connection, Role, State, answer_type
from openair.protocol.errors import OpenAIRError
from openair.protocol.framing import FrameReader, encode_frame
from openair.protocol.message import Message

VECTORS = Path(__file__).resolve().parents[2] / "spec" / "vectors" / "sessions"
FILES = sorted(VECTORS.glob("*.json"))
_REF = re.compile(r"^\$id-of-step-(\d+)$")
_NOW = 1_795_329_509_624_000_000


@dataclass
class _Ends:
    """Both ends of one connection, and whether the client end still takes part."""

    server: Connection[str]
    client: ClientConnection | None
    requests: list[Any] = field(default_factory=list)  # what the server end must answer, in order
    held: list[dict[str, Any]] = field(default_factory=list)  # expects held back (pipelined)


def _client(role: Role) -> ClientConnection:
    return ClientConnection(role, now=lambda: _NOW, window=256, name="Vec", extensions=("noreply",))


def _reply_frame(data: bytes) -> Message:
    reader = FrameReader()
    reader.feed(data)
    frame = reader.next_frame()
    assert frame is not None and reader.next_frame() is None
    return from_frame(frame)


class Replay:
    """Runs one session through both ends of every connection."""

    def __init__(self, name: str, *, pipelined: bool = False) -> None:
        self.name = name
        self.pipelined = pipelined  # hold replies until the client has sent all it can (OA-SESS-17)
        self.ends: dict[str, _Ends] = {}
        self.ids: dict[int, str] = {}
        self.callbacks: dict[str, _Ends] = {}  # module -> its callback connection's ends
        self.paired = 0  # replies paired on either end (the test fails if nothing was)

    def conn(self, name: str) -> _Ends:
        if name not in self.ends:
            server: Connection[str] = Connection(Role.RESPONDER, rules=SERVER_RULES)
            self.ends[name] = _Ends(server=server, client=_client(Role.REQUESTER))
        return self.ends[name]

    def step(self, n: int, step: dict[str, Any]) -> None:
        if "conn" in step and "expect" not in step and "send" not in step:
            self.flush(self.conn(step["conn"]))
        if "send" in step and step["send"]["tag"] == "Receive":
            self.flush(self.conn(step["conn"]))
        if self.pipelined and "expect" in step:
            self.conn(step["conn"]).held.append(step["expect"])
        elif "send" in step:
            self.send(n, self.conn(step["conn"]), step["send"])
        elif "send_raw_hex" in step:
            ends = self.conn(step["conn"])
            ends.client = None  # a client never writes a broken header
            self.ids[n] = ""
        elif "expect" in step:
            self.expect(self.conn(step["conn"]), step["expect"])
        elif "expect_wakeup" in step:
            self.wakeup(step["module"], step["expect_wakeup"])
        elif step.get("expect_closed"):
            self.server_closes(self.conn(step["conn"]))
        elif step.get("close"):
            self.client_closes(self.conn(step["conn"]))

    def send(self, n: int, ends: _Ends, send: dict[str, str]) -> None:
        xml = send["xml"].encode("utf-8")
        try:
            msg = decode_message(xml)
        except OpenAIRError as exc:
            self.ids[n] = ""
            ends.client = None  # the client end cannot write what does not decode
            ends.server.receive_request(exc)  # answered RECEIVE_ERROR in turn (OA-ERR-3)
            ends.requests.append(exc)
            return
        self.ids[n] = msg.id
        if send["tag"] == "Receive":
            self.notification(ends, msg)
            return
        if ends.client is not None:
            data = ends.client.send_request(msg)
            assert _reply_frame(data).id == msg.id
        if ends.server.state is State.RESPONDER:
            ends.server.receive_request(msg)
            ends.requests.append(msg)

    def notification(self, ends: _Ends, msg: Message) -> None:
        """A `Receive` frame: both ends turn around (OA-SESS-7, OA-SESS-28)."""
        if ends.client is not None:
            ends.client.send_notification(msg)
            assert ends.client.state is State.RESPONDER
        if msg.type == "RECEIVE_NAME_NOTIFICATION" and msg.sender:
            ends.server.turn(Role.CALLBACK)
            assert ends.server.role is Role.CALLBACK and ends.server.state is State.REQUESTER
            self.callbacks[msg.sender] = ends

    def flush(self, ends: _Ends) -> None:
        """Answer the held requests, all replies in one read of the client end (OA-FRAME-11)."""
        held, ends.held = ends.held, []
        data, want = b"", []
        for expect in held:
            frame, request_id = self.answer(ends, expect)
            data += frame
            if frame:
                want.append(request_id)
        if ends.client is not None and data:
            events = ends.client.receive_data(data)
            assert [e.request_id for e in events if isinstance(e, Reply)] == want, self.name
            assert len(events) == len(want)  # OA-SESS-2: in request order
            self.paired += len(want)

    def finish(self) -> None:
        for ends in self.ends.values():
            self.flush(ends)

    def expect(self, ends: _Ends, expect: dict[str, Any]) -> None:
        frame, request_id = self.answer(ends, expect)
        if ends.client is None or not frame:
            return
        events = ends.client.receive_data(frame)
        assert len(events) == 1 and isinstance(events[0], Reply), self.name
        assert events[0].request_id == request_id  # OA-SESS-33, OA-SESS-2
        self.paired += 1

    def answer(self, ends: _Ends, expect: dict[str, Any]) -> tuple[bytes, str]:
        """The server end answers its oldest request as the vector expects: (frame, its id)."""
        if not ends.requests:
            return b"", ""  # a reply the adapter makes itself (a framing error), never paired
        request = ends.requests.pop(0)
        ends.server.answer(request)
        if not isinstance(request, Message):
            return b"", ""  # RECEIVE_ERROR for an unreadable request; the client end is out
        kind = expect.get("type") or expect["type_in"][0]
        named = expect.get("isresponse")
        if named == "":
            assert request.id == "", self.name  # OA-SESS-1: a request without a readable id
        elif named is not None:
            m = _REF.match(named)
            assert m is not None and self.ids[int(m.group(1))] == request.id, self.name
        reply = request.reply(kind, sender=expect.get("from", "CNS"))
        return encode_frame(to_frame(reply)), request.id

    def wakeup(self, module: str, expect: dict[str, Any]) -> None:
        """The server end delivers on the module's callback connection, or opens one to its port."""
        ends = self.callbacks.get(module)
        if ends is None or ends.client is None or ends.server.state is not State.REQUESTER:
            server: Connection[str] = Connection(Role.OUTBOUND, rules=SERVER_RULES)
            ends = _Ends(server=server, client=_client(Role.RESPONDER))
        assert ends.client is not None
        delivery = Message(type="AIR.Instruct.Wakeup", to=module, sender=expect.get("from", "WB1"))
        ends.server.send_request(delivery.id, delivery.type, "token:" + delivery.id)
        events = ends.client.receive_data(encode_frame(to_frame(delivery)))
        assert len(events) == 1 and isinstance(events[0], Request)
        answer = _reply_frame(ends.client.answer(events[0]))
        assert answer.type == answer_type(delivery.type) == "RECEIVE_ACCEPT"  # OA-DELIV-4
        paired = ends.server.pair(answer)
        assert paired.pending is not None and paired.pending.token == "token:" + delivery.id
        self.paired += 1

    def server_closes(self, ends: _Ends) -> None:
        ends.server.close()
        if ends.client is not None:
            events = ends.client.receive_data(b"")
            assert len(events) == 1 and isinstance(events[0], Closed)
            assert ends.client.state is State.CLOSED

    def client_closes(self, ends: _Ends) -> None:
        if ends.client is not None:
            ends.client.close()
        unanswered = ends.server.peer_closed()
        assert ends.server.state is State.CLOSED
        assert all(p.type == "KEEPALIVE" for p in unanswered)


@pytest.mark.parametrize("pipelined", [False, True], ids=["in-turn", "pipelined"])
@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_session_vector_drives_both_ends_of_the_one_machine(path: Path, pipelined: bool) -> None:
    data = json.loads(path.read_text(encoding="utf-8"))
    replay = Replay(path.stem, pipelined=pipelined)
    for n, step in enumerate(data["steps"], start=1):
        replay.step(n, step)
    replay.finish()
    assert replay.paired > 0
    for ends in replay.ends.values():
        if ends.server.state is State.RESPONDER:
            assert ends.server.unanswered == len(ends.requests)
        if ends.client is not None and ends.client.state is State.REQUESTER:
            assert ends.client.in_flight == len(ends.requests)  # every reply was paired


def test_the_vectors_exist() -> None:
    assert len(FILES) >= 9
