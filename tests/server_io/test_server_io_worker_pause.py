"""The worker lets the interpreter lock go between the pieces of a long job (issue #19).

`budgets.pause_for_the_loop` pauses at the loop gate (`loopgate.LoopGate.pause`: lets the lock
go, and waits while the loop is at work) once the worker held the lock `PAUSE_AFTER_S` since its
last pause, and never on any other thread; the server has the writer of large wakeups call it
before each copy (`Router.pause_builds`).
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import pytest
from server_io_helpers import run, serving

from openair.server.aio import budgets


class _Time:
    """A stand-in for the `time` module: a clock the test moves, and the sleeps asked for."""

    def __init__(self) -> None:
        self.now = 100.0
        self.sleeps: list[float] = []

    def perf_counter(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)


class _Gate:
    """A stand-in for the loop gate: counts the pauses."""

    def __init__(self, clock: _Time) -> None:
        self.clock = clock

    def pause(self) -> None:
        self.clock.sleep(0)


def _on_thread(name: str, body: Callable[[], None]) -> None:
    thread = threading.Thread(target=body, name=name)
    thread.start()
    thread.join(10)


def test_the_worker_pauses_once_per_slice_of_work(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = _Time()
    monkeypatch.setattr(budgets, "time", clock)
    monkeypatch.setattr(budgets, "LOOP_GATE", _Gate(clock))
    monkeypatch.setattr(budgets, "_paused_at", [clock.now])

    def work() -> None:
        for _ in range(5):  # a tenth of a slice each: no pause
            clock.now += budgets.PAUSE_AFTER_S / 10
            budgets.pause_for_the_loop()
        assert clock.sleeps == []
        for _ in range(3):  # past a slice each: a pause each
            clock.now += budgets.PAUSE_AFTER_S * 1.5
            budgets.pause_for_the_loop()

    _on_thread(f"{budgets._WORKER_NAME}_0", work)
    assert clock.sleeps == [0, 0, 0]


def test_no_other_thread_pauses(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = _Time()
    monkeypatch.setattr(budgets, "time", clock)
    monkeypatch.setattr(budgets, "LOOP_GATE", _Gate(clock))
    monkeypatch.setattr(budgets, "_paused_at", [0.0])
    budgets.pause_for_the_loop()  # this thread: the loop's, in a server
    _on_thread("another", budgets.pause_for_the_loop)
    assert clock.sleeps == []


def test_the_server_has_large_wakeups_written_with_pauses() -> None:
    async def body() -> None:
        server = await serving()
        try:
            assert server.router._copies.pause is budgets.pause_for_the_loop
        finally:
            await server.stop()

    run(body)
