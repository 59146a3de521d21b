"""The route cache (issue #20): whom a post wakes is kept, never stale (OA-WB-7, spec 8.6).

Each test first makes the router cache an answer, then changes what the answer depends on —
a registration, a bind, an unbind, the poster's priority against an alarm trigger, `cc` — and
requires the next post to be routed as a router without a cache would route it.
"""

from __future__ import annotations

import pytest
from router_harness import Harness, wakeups

from openair.server.core import router_routes

SUB = '<triggers><trigger from="WB1" type="Test.*"/></triggers>'
OTHER = '<triggers><trigger from="WB1" type="Other.*"/></triggers>'


def _woken(h: Harness, type_: str = "Test.A", **kw: object) -> set[str]:
    return set(wakeups(h.post(9, type_, **kw)))


def test_a_new_registration_is_seen_by_the_next_post() -> None:
    h = Harness()
    h.bind(1, "M1")
    assert _woken(h) == set()  # cached: nobody
    h.subscribe(1, "M1", SUB)
    assert _woken(h) == {"M1"}
    h.subscribe(1, "M1", OTHER)  # replaced (OA-REG-1)
    assert _woken(h) == set()
    assert _woken(h, "Other.B") == {"M1"}


def test_bind_and_unbind_are_seen_by_the_next_post() -> None:
    h = Harness()
    h.subscribe(1, "M1", SUB)  # registered before it binds: not woken (only bound modules)
    assert _woken(h) == set()
    h.bind(1, "M1")
    assert _woken(h) == {"M1"}
    h.bind(2, "M2")
    h.subscribe(2, "M2", SUB)
    assert _woken(h) == {"M1", "M2"}
    h.close(1)  # M1 is unbound (OA-SESS-15)
    assert _woken(h) == {"M2"}


def test_the_sender_and_the_whiteboard_are_part_of_the_answer() -> None:
    h = Harness()
    h.bind(1, "M1")
    h.subscribe(1, "M1", SUB)  # allowselftriggering defaults to no (OA-TRIG-4)
    assert _woken(h, sender="Poster") == {"M1"}
    assert _woken(h, sender="M1") == set()
    assert _woken(h, to="AIRCentral") == set()  # the trigger names WB1 (OA-TRIG-2)


def test_alarm_triggers_see_each_posts_priority() -> None:
    h = Harness(extensions=frozenset({"noreply", "pipelining", "qos"}))
    h.bind(1, "M1")
    h.subscribe(1, "M1", '<triggers><trigger type="Test.*" maxpriority="1.0"/></triggers>')
    assert _woken(h, priority=3.0) == set()  # OA-TRIG-5
    assert _woken(h, priority=0.5) == {"M1"}
    assert _woken(h, priority=3.0) == set()


def test_cc_is_added_to_each_answer_never_kept() -> None:
    h = Harness()
    h.bind(1, "M1")
    h.bind(2, "M2")
    h.subscribe(1, "M1", SUB)
    assert _woken(h, cc="M2") == {"M1", "M2"}  # OA-CC-1
    assert _woken(h) == {"M1"}  # the cached answer did not keep M2


def test_a_full_cache_starts_again(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(router_routes, "ROUTE_CACHE_SIZE", 4)
    h = Harness()
    h.bind(1, "M1")
    h.subscribe(1, "M1", SUB)
    for i in range(10):
        assert _woken(h, f"Test.T{i}") == {"M1"}
    assert len(h.router._routes) <= 4
