"""The worker runs Python only while the event loop idles (issue #19, `loopgate.LoopGate`).

The selector opens the gate for each poll that waits, while a worker job waits or runs; the
worker, at each pause, lets the lock go and waits while the gate is shut (at most `WAIT_S`);
and the executor counts each job from its submission to its end, cancelled ones too. (A large
retrieve reply is written with pauses: tests/server_core/test_router_retrieve_pauses.py.)
"""

from __future__ import annotations

import selectors
import socket
import threading
import time
from concurrent.futures import Future
from typing import Any

import pytest

from openair.server.aio import budgets, loopgate
from openair.server.aio.fairselect import FairSelector
from openair.server.aio.loopgate import LoopGate

# -- the gate ------------------------------------------------------------------------------------


def test_a_gate_no_loop_opens_never_holds_the_worker(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(loopgate, "WAIT_S", 5.0)
    gate = LoopGate()  # no FairSelector was made for it: disabled
    began = time.monotonic()
    for _ in range(100):
        gate.pause()
    assert time.monotonic() - began < 1.0 and gate.waits == 0


def test_the_worker_waits_while_the_gate_is_shut(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(loopgate, "WAIT_S", 10.0)
    gate = LoopGate()
    gate.enabled = True
    waited: list[float] = []

    def worker() -> None:
        began = time.monotonic()
        gate.pause()  # the loop is at work: wait for its next poll
        waited.append(time.monotonic() - began)

    thread = threading.Thread(target=worker)
    thread.start()
    time.sleep(0.2)
    assert not waited  # still waiting: the gate is shut
    gate.polling()  # the loop polls with nothing else to do
    thread.join(10)
    assert waited and 0.15 < waited[0] < 5.0
    assert gate.waits == 1 and gate.timeouts == 0
    gate.pause()  # open: no wait
    assert gate.waits == 1
    gate.polled()
    assert not gate._open.is_set()


def test_a_loop_that_never_idles_still_lets_the_worker_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(loopgate, "WAIT_S", 0.05)
    gate = LoopGate()
    gate.enabled = True
    began = time.monotonic()
    gate.pause()
    gate.pause()
    took = time.monotonic() - began
    assert 0.09 < took < 5.0 and gate.waits == 2 and gate.timeouts == 2


# -- the selector opens it -----------------------------------------------------------------------


def _polls(monkeypatch: pytest.MonkeyPatch, gate: LoopGate, timeout: float | None) -> list[bool]:
    """Poll a FairSelector once; return whether the gate was open during the poll."""
    seen: list[bool] = []
    plain = selectors.EpollSelector.select

    def watched(self: Any, t: float | None = None) -> list[Any]:
        assert gate.enabled  # a FairSelector enables the gate it opens, while it is open
        seen.append(gate._open.is_set())
        return plain(self, t)

    monkeypatch.setattr(selectors.EpollSelector, "select", watched)
    selector = FairSelector()
    a, b = socket.socketpair()
    try:
        selector.register(a, selectors.EVENT_READ)
        selector.select(timeout)
    finally:
        selector.close()
        a.close()
        b.close()
    return seen


def test_the_selector_opens_the_gate_only_for_a_waiting_poll_during_a_job(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    gate = LoopGate()
    monkeypatch.setattr("openair.server.aio.fairselect.LOOP_GATE", gate)
    assert _polls(monkeypatch, gate, 0.01) == [False]  # no job: nothing to open for
    gate.job_submitted()
    assert _polls(monkeypatch, gate, 0.01) == [True]  # a job waits: open while the loop polls
    assert not gate._open.is_set()  # and shut once the poll returned
    assert _polls(monkeypatch, gate, 0) == [False]  # callbacks ready: the loop is at work
    gate.job_ended()
    assert _polls(monkeypatch, gate, 0.01) == [False]
    assert not gate.enabled  # the selector closed: no loop opens the gate any more


# -- the executor counts the jobs ----------------------------------------------------------------


def test_each_job_is_counted_from_its_submission_to_its_end(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    gate = LoopGate()
    monkeypatch.setattr(budgets, "LOOP_GATE", gate)
    executor = budgets._GatedExecutor(max_workers=1, thread_name_prefix="openair-large-test")
    release = threading.Event()
    try:
        first = executor.submit(release.wait, 10.0)
        assert gate.busy  # counted at once: the loop's next poll opens the gate
        second: Future[int] = executor.submit(lambda: 7)
        assert second.cancel()  # still queued behind the first
        release.set()
        assert first.result(10) is True
        third = executor.submit(lambda: 3)
        assert third.result(10) == 3
        deadline = time.monotonic() + 10
        while gate.busy and time.monotonic() < deadline:
            time.sleep(0.01)
        assert not gate.busy  # ended, cancelled and ended: nothing left counted
    finally:
        executor.shutdown(wait=True)


# -- a large decode pauses between its steps -----------------------------------------------------


def test_a_decode_pauses_between_its_steps_and_decodes_the_same() -> None:
    from openair.protocol.codec import decode_with_lxml, to_frame
    from openair.protocol.message import Message

    xml = to_frame(Message(type="Test.Big", to="WB1", sender="P", content="x" * 100_000)).xml
    pauses: list[int] = []
    paused = decode_with_lxml(xml, pause=lambda: pauses.append(1))
    assert len(pauses) == 3  # after the prolog check, after the parse, before the slots
    assert paused == decode_with_lxml(xml)
