"""The sans-I/O client session: scripted bytes in, events and bytes out."""

from __future__ import annotations

import pytest
from client_helpers import FIXED_NS, frames, one, wire
from hypothesis import given
from hypothesis import strategies as st

from openair.client.session import (
    ClientConnection,
    Closed,
    Invalid,
    Reply,
    Request,
    Role,
    State,
)
from openair.protocol.errors import (
    ApiMisuseError,
    ConnectionClosedError,
    FrameTruncatedError,
    FrameUnknownTagError,
    MessageInvalidError,
)
from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair.protocol.times import AirTime


class Clock:
    """A clock that counts its reads and returns a fixed time."""

    def __init__(self, ns: int = FIXED_NS) -> None:
        self.ns = ns
        self.reads = 0

    def __call__(self) -> int:
        self.reads += 1
        return self.ns


def requester(*, window: int = 1, extensions: frozenset[str] = frozenset()) -> ClientConnection:
    return ClientConnection(now=Clock(), name="Reader", window=window, extensions=extensions)


def responder(*, extensions: frozenset[str] = frozenset()) -> ClientConnection:
    return ClientConnection(Role.RESPONDER, now=Clock(), name="Reader", extensions=extensions)


def reply_to(
    sent: Message, type_: str = "RECEIVE_ACCEPT", *, isresponse: str | None = None
) -> Message:
    return Message(
        type=type_,
        sender="WB1",
        to=sent.sender,
        isresponse=sent.id if isresponse is None else isresponse,
    )


# -- requester --------------------------------------------------------------------------------


def test_send_request_stamps_posted_time_from_the_clock() -> None:
    clock = Clock()
    conn = ClientConnection(now=clock, name="Reader")
    msg = Message(type="Test.Ping", sender="Reader", to="WB1", content="hi")
    sent = one(conn.send_request(msg))
    assert clock.reads == 1  # OA-TIME-2: one read, when the message is encoded
    assert sent.posted == AirTime.from_ns(FIXED_NS)
    assert sent.posted is not None and sent.posted.usec is None  # no usec without the extension
    assert (sent.type, sent.id, sent.content) == ("Test.Ping", msg.id, "hi")
    assert conn.last_sent == sent
    assert conn.in_flight == 1


def test_usec_extension_stamps_microseconds() -> None:
    conn = requester(extensions=frozenset({"usec"}))
    sent = one(conn.send_request(Message(type="A.B", to="WB1")))
    assert sent.posted == AirTime.from_ns(FIXED_NS, with_usec=True)
    assert sent.posted is not None and sent.posted.usec == 456


def test_replies_pair_with_requests_in_order_byte_at_a_time() -> None:
    conn = requester(window=3)
    sent = [one(conn.send_request(Message(type="A.B", to="WB1"))) for _ in range(3)]
    data = b"".join(wire(reply_to(m)) for m in sent)
    events = [e for i in range(len(data)) for e in conn.receive_data(data[i : i + 1])]
    assert [type(e) for e in events] == [Reply, Reply, Reply]
    assert [e.request_id for e in events if isinstance(e, Reply)] == [m.id for m in sent]
    assert conn.in_flight == 0


def test_empty_isresponse_pairs_with_oldest_request() -> None:
    conn = requester()
    conn.send_request(Message(type="KEEPALIVE"))
    request_id = conn.last_sent.id if conn.last_sent else ""
    # Psyclone's KEEPALIVESUCCESS carries an empty isresponse (OA-SESS-33).
    (event,) = conn.receive_data(wire(Message(type="KEEPALIVESUCCESS", sender="CNS")))
    assert isinstance(event, Reply)
    assert event.request_id == request_id
    assert event.message.type == "KEEPALIVESUCCESS"


def test_reply_naming_another_request_is_a_sticky_error() -> None:
    conn = requester(window=2)
    conn.send_request(Message(type="A.B", to="WB1"))
    second = Message(type="A.C", to="WB1")
    conn.send_request(second)
    out_of_order = wire(Message(type="RECEIVE_ACCEPT", isresponse=second.id))
    with pytest.raises(MessageInvalidError):
        conn.receive_data(out_of_order)
    assert conn.state is State.ERROR
    with pytest.raises(MessageInvalidError):
        conn.receive_data(wire(Message(type="RECEIVE_ACCEPT")))  # OA-FRAME-9: sticky
    with pytest.raises(ConnectionClosedError):
        conn.send_request(Message(type="A.D", to="WB1"))


def test_reply_without_request_is_an_error() -> None:
    conn = requester()
    with pytest.raises(MessageInvalidError):
        conn.receive_data(wire(Message(type="RECEIVE_ACCEPT", isresponse="nobody")))


def test_window_is_enforced() -> None:
    conn = requester()  # legacy: one request in flight (OA-SESS-18)
    conn.send_request(Message(type="A.B", to="WB1"))
    assert not conn.can_send
    with pytest.raises(ApiMisuseError):
        conn.send_request(Message(type="A.C", to="WB1"))
    conn.receive_data(wire(Message(type="RECEIVE_ACCEPT")))
    assert conn.can_send
    conn.window = 4
    for _ in range(4):
        conn.send_request(Message(type="A.B", to="WB1"))
    assert conn.in_flight == 4
    assert conn.counters.in_flight_peak == 4
    with pytest.raises(ApiMisuseError):
        conn.send_request(Message(type="A.B", to="WB1"))


def test_noreply_needs_the_extension_and_takes_no_slot() -> None:
    legacy = requester()
    with pytest.raises(ApiMisuseError):  # OA-GEN-2
        legacy.send_request(Message(type="A.B", to="WB1", noreply=True))
    conn = requester(extensions=frozenset({"noreply"}))
    for _ in range(3):
        sent = one(conn.send_request(Message(type="A.B", to="WB1", noreply=True)))
        assert sent.noreply
    assert conn.in_flight == 0
    assert conn.can_send


def test_peer_close_reports_unanswered_requests() -> None:
    conn = requester(window=2)
    conn.send_request(Message(type="A.B", to="WB1"))
    first = conn.last_sent
    conn.send_request(Message(type="A.C", to="WB1"))
    second = conn.last_sent
    assert first is not None and second is not None
    conn.receive_data(wire(reply_to(first)))
    assert conn.receive_data(b"") == [Closed(unanswered=(second.id,))]
    assert conn.state is State.CLOSED
    with pytest.raises(ConnectionClosedError):
        conn.send_request(Message(type="A.D", to="WB1"))


def test_close_inside_a_frame_is_truncated() -> None:
    conn = requester()
    sent = Message(type="A.B", to="WB1")
    conn.send_request(sent)
    data = wire(reply_to(sent))
    assert conn.receive_data(data[:-3]) == []
    with pytest.raises(FrameTruncatedError):  # OA-FRAME-8
        conn.receive_data(b"")
    assert conn.state is State.ERROR


def test_unknown_tag_is_a_sticky_error() -> None:
    conn = requester()
    conn.send_request(Message(type="A.B", to="WB1"))
    with pytest.raises(FrameUnknownTagError):  # OA-FRAME-6
        conn.receive_data(b"Garbage\x00\x05\x00\x00\x00hello")
    with pytest.raises(FrameUnknownTagError):
        conn.receive_data(b"more")


def test_local_close_drops_late_bytes_and_refuses_sends() -> None:
    conn = requester()
    conn.close()
    assert conn.receive_data(wire(Message(type="RECEIVE_ACCEPT"))) == []
    with pytest.raises(ConnectionClosedError):
        conn.send_request(Message(type="A.B", to="WB1"))


def test_requester_cannot_answer() -> None:
    conn = requester()
    with pytest.raises(ApiMisuseError):  # OA-SESS-28: roles are fixed
        conn.answer(Request(message=Message(type="PING")))


# -- callback and responder -------------------------------------------------------------------


def test_notification_turns_the_connection_around() -> None:
    conn = requester()
    note = Message(type="RECEIVE_NAME_NOTIFICATION", sender="Reader")
    ((tag, sent),) = frames(conn.send_notification(note))
    assert tag is FrameTag.RECEIVE  # OA-SESS-7
    assert sent.type == "RECEIVE_NAME_NOTIFICATION"
    assert conn.state is State.RESPONDER
    assert conn.in_flight == 0  # no reply expected
    with pytest.raises(ApiMisuseError):  # OA-SESS-28: the server is the requester now
        conn.send_request(Message(type="A.B", to="WB1"))
    (event,) = conn.receive_data(wire(Message(type="PING", sender="WB1", to="Reader")))
    assert isinstance(event, Request)


def test_notification_refused_with_requests_in_flight() -> None:
    conn = requester()
    conn.send_request(Message(type="A.B", to="WB1"))
    with pytest.raises(ApiMisuseError):
        conn.send_notification(Message(type="RECEIVE_NAME_NOTIFICATION", sender="Reader"))


@pytest.mark.parametrize(
    ("request_type", "answer_type"),
    [
        ("PING", "PING_SUCCESS"),  # OA-SESS-11
        ("KEEPALIVE", "KEEPALIVESUCCESS"),  # OA-KEEP-2
        ("AIR.Instruct.Wakeup", "RECEIVE_ACCEPT"),  # OA-DELIV-4
        ("Some.Forwarded.Message", "RECEIVE_ACCEPT"),  # OA-SESS-22
    ],
)
def test_default_answers(request_type: str, answer_type: str) -> None:
    conn = responder()
    delivered = Message(type=request_type, sender="WB1", to="Reader")
    (event,) = conn.receive_data(wire(delivered))
    assert isinstance(event, Request) and event.needs_answer
    answer = one(conn.answer(event))
    assert answer.type == answer_type
    assert answer.isresponse == delivered.id  # OA-SESS-1
    assert (answer.sender, answer.to) == ("Reader", "WB1")
    assert answer.posted == AirTime.from_ns(FIXED_NS)


def test_answers_must_follow_arrival_order() -> None:
    conn = responder(extensions=frozenset({"pipelining"}))
    data = wire(Message(type="PING", sender="WB1")) + wire(Message(type="A.B", sender="WB1"))
    first, second = conn.receive_data(data)
    assert isinstance(first, Request) and isinstance(second, Request)
    with pytest.raises(ApiMisuseError):  # OA-SESS-2
        conn.answer(second)
    assert one(conn.answer(first)).type == "PING_SUCCESS"
    assert one(conn.answer(second)).type == "RECEIVE_ACCEPT"
    with pytest.raises(ApiMisuseError):
        conn.answer(second)
    assert conn.unanswered == 0


def test_malformed_request_is_answered_and_the_connection_stays_usable() -> None:
    conn = responder()
    bad_xml = b"<message><type>Raw.Bad</type><to>WB1</to"
    bad = b"Message\x00" + len(bad_xml).to_bytes(4, "little") + bad_xml
    good = Message(type="PING", sender="WB1")
    bad_event, good_event = conn.receive_data(bad + wire(good))
    assert isinstance(bad_event, Invalid)
    answer = one(conn.answer(bad_event))
    assert answer.type == "RECEIVE_ERROR"
    assert answer.content.startswith("XML_MALFORMED")  # OA-ERR-2, OA-ERR-3
    assert answer.isresponse == ""  # OA-SESS-1: the id could not be read
    assert isinstance(good_event, Request)
    assert one(conn.answer(good_event)).isresponse == good.id


def test_noreply_delivery_is_not_answered() -> None:
    conn = responder(extensions=frozenset({"noreply"}))
    (event,) = conn.receive_data(wire(Message(type="A.B", sender="WB1", noreply=True)))
    assert isinstance(event, Request) and not event.needs_answer  # OA-MSG-15
    assert conn.unanswered == 0
    with pytest.raises(ApiMisuseError):
        conn.answer(event)


def test_explicit_answer_type_and_content() -> None:
    conn = responder()
    (event,) = conn.receive_data(wire(Message(type="AIR.Instruct.Wakeup", sender="WB1")))
    assert isinstance(event, Request)
    answer = one(conn.answer(event, "RECEIVE_ERROR", content="CONTENT_INVALID: no dictionary"))
    assert (answer.type, answer.content) == ("RECEIVE_ERROR", "CONTENT_INVALID: no dictionary")


def test_window_must_be_positive() -> None:
    with pytest.raises(ApiMisuseError):
        requester(window=0)


@given(st.lists(st.integers(min_value=1, max_value=40), max_size=30))
def test_any_split_gives_the_same_events(cuts: list[int]) -> None:
    stream = [
        Message(type=t, sender="WB1", content="x" * n) for n, t in enumerate(["PING", "A.B", "C"])
    ]
    data = b"".join(wire(m) for m in stream)
    conn = responder(extensions=frozenset({"pipelining"}))
    events = []
    pos = 0
    for size in cuts:
        events += conn.receive_data(data[pos : pos + size])
        pos += size
    events += conn.receive_data(data[pos:])
    events += conn.receive_data(b"")
    assert [e.message.id for e in events if isinstance(e, Request)] == [m.id for m in stream]
    assert isinstance(events[-1], Closed)
