"""Unit tests of the one connection machine (openair.protocol.connection), without I/O."""

from __future__ import annotations

import pytest

from openair.protocol.connection import (
    ANSWER_FOR,
    CLIENT_RULES,
    HARNESS_RULES,
    SERVER_RULES,
    TRANSITIONS,
    Action,
    Connection,
    PairingRules,
    Role,
    State,
    answer_type,
)
from openair.protocol.errors import ApiMisuseError, ConnectionClosedError, MessageInvalidError
from openair.protocol.message import Message


def _requester(rules: PairingRules, *types: str) -> Connection[str]:
    conn: Connection[str] = Connection(Role.REQUESTER, rules=rules)
    for n, kind in enumerate(types):
        conn.send_request(f"r{n}", kind, f"t{n}")
    return conn


def test_one_answer_table() -> None:
    # OA-SESS-10, OA-KEEP-2, OA-SESS-11, OA-DELIV-4
    assert ANSWER_FOR == {"PING": "PING_SUCCESS", "KEEPALIVE": "KEEPALIVESUCCESS"}
    assert answer_type("PING") == "PING_SUCCESS"
    assert answer_type("KEEPALIVE") == "KEEPALIVESUCCESS"
    assert answer_type("AIR.Instruct.Wakeup") == "RECEIVE_ACCEPT"


def test_replies_pair_in_order_with_tokens() -> None:  # OA-SESS-33, OA-SESS-2
    conn = _requester(CLIENT_RULES, "PING", "AIR.Retrieve", "PING")
    assert conn.in_flight == 3 and conn.in_flight_peak == 3
    got = [conn.pair(Message(type="X", isresponse=f"r{n}")).pending for n in range(3)]
    assert [p.token for p in got if p is not None] == ["t0", "t1", "t2"]
    assert conn.in_flight == 0


def test_client_rules_refuse_a_reply_naming_another_request() -> None:  # OA-SESS-2
    conn = _requester(CLIENT_RULES, "PING", "PING")
    with pytest.raises(MessageInvalidError):
        conn.pair(Message(type="PING_SUCCESS", isresponse="r1"))
    with pytest.raises(MessageInvalidError):
        _requester(CLIENT_RULES).pair(Message(type="PING_SUCCESS"))  # nothing in flight


def test_an_empty_isresponse_pairs_with_the_oldest() -> None:  # OA-SESS-33
    conn = _requester(CLIENT_RULES, "KEEPALIVE", "PING")
    paired = conn.pair(Message(type="KEEPALIVESUCCESS"))
    assert paired.pending is not None and paired.pending.id == "r0"


def test_server_rules_pass_over_unanswered_keepalives() -> None:  # OA-KEEP-3
    conn = _requester(SERVER_RULES, "KEEPALIVE", "KEEPALIVE", "AIR.Instruct.Wakeup")
    paired = conn.pair(Message(type="RECEIVE_ACCEPT", isresponse="r2"))
    assert [p.id for p in paired.passed_over] == ["r0", "r1"]
    assert paired.pending is not None and paired.pending.id == "r2"
    conn = _requester(SERVER_RULES, "KEEPALIVE", "AIR.Instruct.Wakeup")
    paired = conn.pair(Message(type="KEEPALIVESUCCESS"))
    assert paired.passed_over == () and paired.pending is not None and paired.pending.id == "r0"
    conn = _requester(SERVER_RULES, "KEEPALIVE", "AIR.Instruct.Wakeup")
    paired = conn.pair(None)  # an unreadable reply is still the reply of the next delivery
    assert paired.pending is not None and paired.pending.id == "r1"


def test_server_rules_ignore_isresponse_and_note_orphans() -> None:
    conn = _requester(SERVER_RULES, "AIR.Instruct.Wakeup", "PING")
    paired = conn.pair(Message(type="RECEIVE_ACCEPT", isresponse="r1"))
    assert paired.pending is not None and paired.pending.id == "r0"
    orphan = conn.pair(Message(type="PING_SUCCESS", isresponse="zz"))
    assert orphan.pending is not None and orphan.pending.id == "r1"
    nothing = conn.pair(Message(type="PING_SUCCESS", isresponse="zz"))
    assert nothing.pending is None and nothing.note


def test_harness_rules_find_an_overtaking_reply_and_say_so() -> None:
    conn = _requester(HARNESS_RULES, "PING", "PING", "PING")
    paired = conn.pair(Message(type="PING_SUCCESS", isresponse="r2"))
    assert paired.pending is not None and paired.pending.id == "r2" and "overtook" in paired.note
    paired = conn.pair(Message(type="PING_SUCCESS", isresponse="nope"))
    assert paired.pending is not None and paired.pending.id == "r0" and "OA-SESS-33" in paired.note


@pytest.mark.parametrize("rules", [SERVER_RULES, HARNESS_RULES])
def test_a_session_request_out_of_turn_is_answered_not_paired(rules: PairingRules) -> None:
    conn = _requester(rules, "AIR.Instruct.Wakeup")
    for kind in ANSWER_FOR:
        paired = conn.pair(Message(type=kind))
        assert paired.out_of_turn and paired.pending is None
    assert conn.in_flight == 1
    conn.answer(Message(type="PING"))  # a requester may answer it (OA-SESS-10, OA-KEEP-2)
    strict = _requester(CLIENT_RULES, "PING")
    assert not strict.is_out_of_turn(Message(type="PING"))


def test_role_changes_follow_the_table() -> None:  # OA-SESS-7, OA-SESS-28
    server: Connection[None] = Connection(Role.RESPONDER, rules=SERVER_RULES)
    with pytest.raises(ApiMisuseError):
        server.send_request("x", "PING", None)  # the peer is the requester
    server.turn(Role.CALLBACK)
    assert (server.role, server.state) == (Role.CALLBACK, State.REQUESTER)
    with pytest.raises(ApiMisuseError):
        server.turn(Role.PUSH)  # turned once only
    client: Connection[None] = Connection(Role.REQUESTER)
    client.send_request("a", "PING", None)
    with pytest.raises(ApiMisuseError):
        client.send_notification()  # a request is in flight
    client.pair(Message(type="PING_SUCCESS", isresponse="a"))
    client.send_notification()
    assert (client.role, client.state) == (Role.RESPONDER, State.RESPONDER)
    with pytest.raises(ApiMisuseError):
        Connection(Role.RESPONDER).turn(Role.RESPONDER)


def test_requests_are_answered_in_arrival_order() -> None:  # OA-SESS-2
    conn: Connection[None] = Connection(Role.RESPONDER)
    first, second = Message(type="PING"), Message(type="PING")
    conn.receive_request(first)
    conn.receive_request(second)
    conn.receive_request(Message(type="X", noreply=True), needs_answer=False)
    assert conn.unanswered == 2
    with pytest.raises(ApiMisuseError):
        conn.answer(second)
    conn.answer(first)
    conn.answer(second)
    assert conn.unanswered == 0


def test_closing_ends_the_connection_and_hands_back_the_unanswered() -> None:
    conn = _requester(SERVER_RULES, "AIR.Instruct.Wakeup", "KEEPALIVE")
    assert [p.token for p in conn.peer_closed()] == ["t0", "t1"]
    assert conn.state is State.CLOSED and conn.peer_closed() == ()
    with pytest.raises(ConnectionClosedError):
        conn.send_request("late", "PING", "t")
    conn = _requester(CLIENT_RULES)
    conn.protocol_error()
    with pytest.raises(ConnectionClosedError):
        conn.send_request("late", "PING", "t")  # OA-FRAME-9: sticky


def test_every_state_has_a_way_to_end() -> None:
    for state in State:
        assert (state, Action.CLOSE) in TRANSITIONS
        assert (state, Action.PEER_CLOSED) in TRANSITIONS
