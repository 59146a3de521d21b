"""Names of modules gone are forgotten after a retention time (issue #19, OA-LIM-15)."""

from __future__ import annotations

from router_harness import Harness

from openair.protocol.message import Message


def test_the_counters_of_a_module_gone_past_the_retention_are_forgotten() -> None:
    h = Harness()
    hour = 3_600 * 10**9
    for conn, name in enumerate(("Stays", "Goes", "Back"), start=1):
        h.bind(conn, name)
        h.send(conn, Message(type="PING", to="CNS", sender=name))  # counted while bound
    h.close(2)
    h.close(3)

    def names() -> set[str]:
        return set(h.router.counters()["modules"])  # type: ignore[call-overload]

    assert {"Stays", "Goes", "Back"} <= names()
    assert h.router.forget_gone(0, hour) == 0  # seen gone now
    h.bind(4, "Back")  # bound again before its retention ends: kept
    assert h.router.forget_gone(hour - 1, hour) == 0
    assert h.router.forget_gone(hour, hour) == 1  # OA-LIM-15
    assert "Goes" not in names() and {"Stays", "Back"} <= names()
    assert h.router.forget_gone(10 * hour, hour) == 0  # bound names are never forgotten
