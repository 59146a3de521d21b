"""Secure mode in the sans-I/O router (spec 14.3, OA-AUTH-2..8) and legacy mode untouched."""

from __future__ import annotations

import pytest
from router_harness import EXTENSIONS, Harness

from openair.protocol.auth import proof
from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair.server.core.auth import AuthGate
from openair.server.core.config import ServerLimits, default_config
from openair.server.core.router import Outcome, Router
from openair.server.core.store import MemoryStore

SECRETS = {"Alice": "alice-secret-0123456789", "Bob": "bob-secret-0123456789ab"}
NONCE = bytes(range(32))


def secure() -> Harness:
    """A harness whose router runs in secure mode with a fixed nonce source."""
    h = Harness()
    h.router = Router(
        default_config(),
        MemoryStore(),
        server_name="openair-kit/test",
        address="127.0.0.1",
        port=10000,
        limits=ServerLimits(),
        extensions=EXTENSIONS | {"auth"},
        auth=AuthGate(SECRETS, random_bytes=lambda n: NONCE[:n]),
    )
    h.router.start(h.now)
    return h


def prove(h: Harness, conn: int, name: str, secret: str | None = None) -> Message:
    """Run AUTH_CHALLENGE and AUTH_RESPONSE; return the AUTH_RESPONSE's reply."""
    nonce = h.reply(conn, "AUTH_CHALLENGE", sender=name)
    assert nonce.type == "AUTH_NONCE"
    assert nonce.content == NONCE.hex()
    offered = proof(secret or SECRETS[name], nonce.content, name)
    return h.reply(conn, "AUTH_RESPONSE", sender=name, content=offered)


def condition(reply: Message) -> str:
    return reply.content.split(":", 1)[0]


def test_proof_vector_matches_the_spec_example() -> None:
    nonce = bytes(range(32)).hex()
    expected = "a07677b31933e5bbc655a3898e4781dccb13af8718b1a4d8a76f76ce308f4904"
    assert proof("reader-secret-0123456789", nonce, "Reader") == expected


def test_a_good_proof_is_accepted_and_allows_bind() -> None:
    h = secure()
    assert prove(h, 1, "Alice").type == "AUTH_ACCEPT"
    assert h.reply(1, "BIND", sender="Alice").type == "BIND_ACCEPT"


@pytest.mark.parametrize(
    ("name", "secret"), [("Alice", "wrong-secret-0123456789"), ("Carol", "carol-secret-01234567")]
)
def test_a_bad_proof_or_unknown_name_fails(name: str, secret: str) -> None:
    h = secure()
    reply = prove(h, 1, name, secret)
    assert (reply.type, condition(reply)) == ("RECEIVE_ERROR", "AUTH_FAILED")
    bind = h.reply(1, "BIND", sender=name)
    assert (bind.type, condition(bind)) == ("BIND_ERROR", "AUTH_REQUIRED")


def test_a_nonce_is_used_once() -> None:
    h = secure()
    nonce = h.reply(1, "AUTH_CHALLENGE", sender="Alice").content
    good = proof(SECRETS["Alice"], nonce, "Alice")
    assert h.reply(1, "AUTH_RESPONSE", sender="Bob", content="0" * 64).type == "RECEIVE_ERROR"
    again = h.reply(1, "AUTH_RESPONSE", sender="Alice", content=good)  # the nonce is gone
    assert condition(again) == "AUTH_FAILED"


def test_a_proof_does_not_carry_to_another_connection() -> None:
    h = secure()
    prove(h, 1, "Alice")
    reply = h.reply(2, "BIND", sender="Alice")
    assert (reply.type, condition(reply)) == ("BIND_ERROR", "AUTH_REQUIRED")


def test_no_takeover_without_the_secret_but_with_it() -> None:
    h = secure()
    prove(h, 1, "Alice")
    h.bind(1, "Alice")
    prove(h, 2, "Bob")
    stolen = h.reply(2, "BIND", sender="Alice")
    assert (stolen.type, condition(stolen)) == ("BIND_ERROR", "AUTH_REQUIRED")
    info = h.router.module("Alice")
    assert info is not None and info.conn == 1
    prove(h, 3, "Alice")  # the module itself, after a restart, may take over
    assert h.reply(3, "BIND", sender="Alice").type == "BIND_ACCEPT"
    info = h.router.module("Alice")
    assert info is not None and info.conn == 3


@pytest.mark.parametrize(
    ("type_", "to"),
    [("Test.Post", "WB1"), ("AIR.Subscribe", "WB1"), ("AIR.Retrieve", "WB1"), ("STATUS", "CNS")],
)
def test_unproved_connections_are_refused(type_: str, to: str) -> None:
    h = secure()
    reply = h.reply(1, type_, to=to, sender="Alice")
    assert condition(reply) == "AUTH_REQUIRED"
    assert reply.type == ("AIR.Retrieve.Failed" if type_ == "AIR.Retrieve" else "RECEIVE_ERROR")


def test_from_must_be_a_proved_name() -> None:
    h = secure()
    prove(h, 1, "Alice")
    assert h.reply(1, "Test.Post", to="WB1", sender="Alice").type == "RECEIVE_ACCEPT"
    forged = h.reply(1, "Test.Post", to="WB1", sender="Bob")
    assert condition(forged) == "AUTH_REQUIRED"
    assert h.router.whiteboard("WB1") is not None
    assert h.router.whiteboard("WB1").received == 1


def test_open_commands_need_no_proof() -> None:
    h = secure()
    for type_ in ("PING", "KEEPALIVE", "GET_CAPABILITIES"):
        assert h.reply(1, type_).type in ("PING_SUCCESS", "KEEPALIVESUCCESS", "CAPABILITIES")


@pytest.mark.parametrize(
    "type_",
    [
        "AIR.Instruct.Wakeup",
        "air.instruct.wakeup",
        "Psyclone.Module.Lost.Bob",
        "Psyclone.Module.Restored.Alice",
        "Psyclone.Module.Connect.Bob",
        "Psyclone.Module.Reconnect.Bob",
    ],
)
def test_server_only_types_are_refused(type_: str) -> None:
    h = secure()
    prove(h, 1, "Alice")
    reply = h.reply(1, type_, to="AIRCentral", sender="Alice")
    assert condition(reply) == "AUTH_REQUIRED"


def test_own_connect_and_phase_change_are_allowed() -> None:
    h = secure()
    prove(h, 1, "Alice")
    for type_ in (
        "Psyclone.Module.Connect.Alice",
        "Psyclone.Module.Reconnect.Alice",
        "Psyclone.Module.Report.PhaseChange",
    ):
        assert h.reply(1, type_, to="AIRCentral", sender="Alice").type == "RECEIVE_ACCEPT"


def test_a_forged_wakeup_is_not_forwarded() -> None:
    h = secure()
    prove(h, 1, "Alice")
    h.bind(1, "Alice")
    prove(h, 2, "Bob")
    outcome = h.request(2, "AIR.Instruct.Wakeup", to="Alice", sender="Bob")
    assert outcome.deliveries == ()
    assert condition(outcome.replies[0]) == "AUTH_REQUIRED"


def receive(h: Harness, conn: int, name: str) -> Outcome:
    msg = Message(type="RECEIVE_NAME_NOTIFICATION", sender=name)
    return h.send(conn, msg, tag=FrameTag.RECEIVE)


def test_a_callback_needs_a_proof() -> None:
    h = secure()
    prove(h, 1, "Alice")
    h.bind(1, "Alice")
    stolen = receive(h, 2, "Alice")
    assert stolen.close_this and condition(stolen.replies[0]) == "AUTH_REQUIRED"
    info = h.router.module("Alice")
    assert info is not None and info.callback is None
    prove(h, 3, "Alice")
    assert receive(h, 3, "Alice").replies == ()
    info = h.router.module("Alice")
    assert info is not None and info.callback == 3


def test_closing_forgets_the_proof() -> None:
    h = secure()
    prove(h, 1, "Alice")
    h.close(1)
    assert condition(h.reply(1, "Test.Post", to="WB1", sender="Alice")) == "AUTH_REQUIRED"


def test_internal_modules_need_no_proof() -> None:
    h = secure()  # OA-CONF-8: negative connection ids are the server's own internal modules
    assert h.reply(-1, "BIND_NOLISTEN", sender="Inside").type == "BIND_ACCEPT"
    assert h.reply(-1, "Test.Post", to="WB1", sender="Inside").type == "RECEIVE_ACCEPT"


def test_legacy_mode_has_no_auth_commands() -> None:
    h = Harness()
    assert h.reply(1, "AUTH_CHALLENGE").type == "UNKNOWN_COMMAND"
    assert h.reply(1, "Test.Post", to="WB1", sender="Anyone").type == "RECEIVE_ACCEPT"
