"""Large wakeups written later (issue #19): the router decides, `Delivery.build` writes.

`Router.defer_large_wakeups` (the asyncio server sets it) hands a wakeup whose text passes
`LARGE_WAKEUP` to the adapter unwritten; what `build()` writes must be the very message and
frame the router writes at once, whatever the retrieves, and writing it must leave the router's
cache of encoded copies alone (it runs on another thread): what it encoded is kept by the
router's next decision.
"""

from __future__ import annotations

import itertools

import pytest
from router_harness import Harness

from openair.protocol.message import Message
from openair.protocol.wakeup import PIECE_CHARS, parse_wakeup
from openair.server.core import commands as cmd
from openair.server.core.outcome import Delivery
from openair.server.core.retrieve import _LARGE_SCAN
from openair.server.core.wakeups import LARGE_WAKEUP, WakeupParts

RETRIEVING = (
    '<module name="Reader"><triggers from="WB1"><trigger type="Test.Go.*"/></triggers>'
    '<retrieves><retrieve type="Test.Fill.*"><latest>0</latest></retrieve></retrieves></module>'
)
PLAIN = '<module name="Reader"><triggers from="WB1"><trigger type="Test.*"/></triggers></module>'


def _wakeup(
    defer: bool, registration: str, fill: int, content: str, monkeypatch: pytest.MonkeyPatch
) -> Delivery:
    ids = itertools.count()
    monkeypatch.setattr(cmd, "fresh_id", lambda: f"id-{next(ids)}")
    h = Harness()
    h.router.defer_large_wakeups = defer
    for i in range(fill):
        h.post(1, f"Test.Fill.{i}", content=f"{i:05d}" + "x" * 1019, id=f"fill-{i}")
    h.bind(2, "Reader")
    assert h.subscribe(2, "Reader", registration, to="WB1").replies[0].type == "RECEIVE_ACCEPT"
    outcome = h.post(1, "Test.Go.1", content=content, id="go-1")
    (delivery,) = outcome.deliveries
    return delivery


@pytest.mark.parametrize(
    ("registration", "fill", "content"),
    [
        (RETRIEVING, 400, "small"),  # a thousand-odd retrieved messages make it large
        (PLAIN, 0, "<&>" * (LARGE_WAKEUP // 3 + 1)),  # a large trigger, escaped
        (RETRIEVING, 300, "ü" * (LARGE_WAKEUP // 4)),  # both, not ASCII
    ],
)
def test_a_large_wakeup_is_built_later_to_the_same_message_and_frame(
    registration: str, fill: int, content: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    now = _wakeup(False, registration, fill, content, monkeypatch)
    later = _wakeup(True, registration, fill, content, monkeypatch)
    assert now.build is None and now.wire is not None
    assert later.build is not None and later.wire is None
    assert later.build_bytes > LARGE_WAKEUP  # what the adapter counts while it waits
    message, wire = later.build()
    assert message == now.message
    assert wire == now.wire
    # The preview: same envelope and id, the PhaseSpec (lasttrigger), no trigger or results.
    preview = parse_wakeup(later.message)
    assert later.message.id == now.message.id
    assert preview.lasttrigger == parse_wakeup(now.message).lasttrigger
    assert preview.lasttrigger in ("Test.Go.*", "Test.*")
    assert preview.trigger is None and not preview.retrieved
    assert len(later.message.content) < 2048


@pytest.mark.parametrize(
    ("registration", "fill", "content"),
    [(RETRIEVING, 400, "small"), (RETRIEVING, 300, "ü" * (LARGE_WAKEUP // 4))],
)
def test_a_worker_with_pauses_gets_the_frame_in_pieces_with_a_pause_before_each(
    registration: str, fill: int, content: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    now = _wakeup(False, registration, fill, content, monkeypatch)
    later = _wakeup(True, registration, fill, content, monkeypatch)
    assert later.build is not None and isinstance(now.wire, bytes)
    build = later.build
    owner = getattr(build, "__self__", None)
    assert isinstance(owner, WakeupParts)
    pauses: list[int] = []
    owner.copies.pause = lambda: pauses.append(1)
    message, wire = build()
    assert message == now.message
    assert isinstance(wire, tuple)
    assert b"".join(wire) == now.wire  # the same frame, never joined on the worker
    content_pieces = wire[2:-1]  # after the header and the envelope, before the end tag
    assert len(content_pieces) == -(-len(now.message.content) // PIECE_CHARS)
    assert all(len(p) <= 4 * PIECE_CHARS for p in content_pieces)
    # one pause before each retrieved copy and the trigger, one before each piece
    assert len(pauses) >= len(content_pieces) + 1


def test_a_small_wakeup_is_written_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    delivery = _wakeup(True, PLAIN, 0, "x" * (LARGE_WAKEUP // 2), monkeypatch)
    assert delivery.build is None and delivery.wire is not None
    assert parse_wakeup(delivery.message).trigger is not None


def test_building_reads_the_cache_of_encoded_copies_and_the_router_keeps_what_it_wrote(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    ids = itertools.count()
    monkeypatch.setattr(cmd, "fresh_id", lambda: f"id-{next(ids)}")
    h = Harness()
    h.router.defer_large_wakeups = True
    h.bind(2, "Reader")
    h.subscribe(2, "Reader", PLAIN, to="WB1")
    copies = h.router._copies
    small = h.post(1, "Test.Small", content="y")  # written at once: its copy is cached
    assert small.deliveries[0].build is None
    cached = dict(copies._xml)
    big = h.post(1, "Test.Big", content="z" * (LARGE_WAKEUP + 1))
    (delivery,) = big.deliveries
    assert delivery.build is not None
    assert copies._xml == cached  # deciding wrote nothing
    message, _ = delivery.build()
    assert copies._xml == cached  # neither did building
    trigger = parse_wakeup(message).trigger
    assert isinstance(trigger, Message) and trigger.content == "z" * (LARGE_WAKEUP + 1)
    assert delivery.trigger is not None and copies.peek(delivery.trigger) is None
    h.post(1, "Test.Next", content="w")  # the router's next decision keeps what was offered
    assert copies.peek(delivery.trigger) is not None


def test_a_large_retrieve_reply_is_handed_over_as_its_frame_only() -> None:
    # The adapter sends the frame; the reply's text of megabytes is never joined (issue #19).
    h = Harness()
    h.router.defer_large_replies = h.router.frames_only = True
    for i in range(_LARGE_SCAN + 10):
        h.post(1, f"Test.Fill.{i}", content="x")
    retrieve = '<retrieve type="Test.*"><latest>0</latest></retrieve>'
    msg = Message(type="AIR.Retrieve", to="WB1", sender="R", content=retrieve, content_is_xml=True)
    later = h.send(2, msg).later
    assert later is not None
    reply, parts = later()
    assert reply.type == "AIR.Retrieve.Success" and reply.content == ""
    assert parts is not None and b"Test.Fill.0<" in b"".join(parts)
