"""A large retrieve reply written later pauses as it goes (issue #19, the loop gate).

With `Router.defer_large_replies` (the asyncio server sets it) a retrieve of thousands of
copies is built on the worker thread; the build reads the stored copies' XML through the
router's cache and calls the pause the adapter gave `pause_builds` — before each copy, every
`whiteboard.PAUSE_EVERY` copies of the scan and before each encoded group — and what it writes
is the very reply and frame the router writes at once.
"""

from __future__ import annotations

import itertools

import pytest
from router_harness import Harness

from openair.protocol.codec import to_frame
from openair.protocol.framing import encode_frame
from openair.protocol.message import Message
from openair.server.core import commands as cmd
from openair.server.core.retrieve import _LARGE_SCAN
from openair.server.core.whiteboard import PAUSE_EVERY

FILL = _LARGE_SCAN + 500
SPEC = '<retrieve type="Test.Fill.*"><latest>0</latest></retrieve>'


def _retrieve(defer: bool, pauses: list[int], monkeypatch: pytest.MonkeyPatch) -> bytes:
    ids = itertools.count()
    monkeypatch.setattr(cmd, "fresh_id", lambda: f"id-{next(ids)}")
    h = Harness()
    h.router.defer_large_replies = defer
    h.router.frames_only = True
    h.router.pause_builds(lambda: pauses.append(1))
    for i in range(FILL):
        h.post(1, f"Test.Fill.{i}", content=f"{i:05d}" + "x" * 200, id=f"fill-{i}")
    request = Message(
        type="AIR.Retrieve", to="WB1", sender="R", content=SPEC, content_is_xml=True, id="r"
    )
    outcome = h.send(2, request)
    if not defer:
        assert outcome.later is None and len(outcome.replies) == 1
        return encode_frame(to_frame(outcome.replies[0]))
    assert outcome.later is not None and not outcome.replies
    reply, wire = outcome.later()
    assert reply.type == "AIR.Retrieve.Success" and wire is not None
    return wire if isinstance(wire, bytes) else b"".join(wire)


def test_a_deferred_retrieve_pauses_and_writes_what_the_router_writes_at_once(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    at_once: list[int] = []
    later: list[int] = []
    expected = _retrieve(False, at_once, monkeypatch)
    assert at_once == []  # written on the loop: it never pauses
    assert _retrieve(True, later, monkeypatch) == expected
    # a pause before each copy, one every PAUSE_EVERY copies scanned, one per encoded group
    assert len(later) >= FILL + FILL // PAUSE_EVERY + len(expected) // (256 * 1024)
