"""`openair serve` always stops (issue #18): after a conformance run, SIGTERM ends it.

The hang: a module's delivery task, cancelled by `Server.stop`, was woken in the same loop turn
as its cancel while it waited for the next item; `asyncio.wait_for` (3.11) then returned the
wake-up instead of raising, the task waited again for ever, and the unbounded stop waited for
the task. The unit test makes that turn happen on purpose; the process tests run the
conformance suite against a real server and signal it, many times.
"""

from __future__ import annotations

import asyncio
import os
import signal
import subprocess
import time
from collections.abc import Callable

import pytest
from product_support import STOP_S, ServeProcess, openair_command

from openair.client import Module
from openair.client.module import FailedReplyError
from openair.protocol.errors import ShuttingDownError
from openair.protocol.message import Message
from openair.server.aio.dispatcher import Dispatcher
from openair.server.aio.protocol import ServerConnection
from openair.server.core.router import Delivery, ModuleInfo
from openair_conformance.engine import RunOptions, exit_code, run

_FAR_NS = 3600 * 10**9  # a due time an hour ahead: the task waits with a timeout


class _NoPathHost:
    """A delivery host that knows no module: deliveries stay queued (6.6)."""

    def module_info(self, name: str) -> ModuleInfo | None:
        return None

    def connection(self, conn_id: int) -> ServerConnection | None:
        return None

    async def connect(self, module: str, address: str, port: int) -> ServerConnection:
        raise OSError("no path")

    def delivered(self, module: str, count: int) -> None:
        pass

    def dropped(self, module: str, count: int, reason: str) -> None:
        pass


def test_a_delivery_task_woken_as_it_is_cancelled_ends() -> None:
    async def body() -> None:
        dispatcher = Dispatcher(_NoPathHost(), capacity=10, max_in_flight=1)
        later = time.time_ns() + _FAR_NS
        msg = Message(type="A.B", sender="WB1")
        dispatcher.push(Delivery(module="M", message=msg, due_ns=later, priority=1, wb_priority=1))
        md = dispatcher.modules["M"]
        for _ in range(3):  # the task reaches its wait for the next item
            await asyncio.sleep(0)
        md.poke()  # a wake-up and a cancel in the same loop turn
        md.task.cancel()
        for _ in range(5):
            await asyncio.sleep(0)
        assert md.task.done(), "the delivery task swallowed its cancel"
        assert md.task.cancelled()
        assert await dispatcher.stop() == 1  # the queued delivery, counted DELIVERY_FAILED

    asyncio.run(body())


def _conform_process(port: int) -> None:
    """The whole suite through `openair conform`, as a user runs it."""
    done = subprocess.run(
        [*openair_command(), "conform", f"127.0.0.1:{port}", "-j", "2"],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    # The verdicts do not matter here (a loaded machine may time a case out); the run must
    # have reached the server and finished: 0 all passed, 1 some case did not.
    assert done.returncode in (0, 1), done.stdout[-2000:] + done.stderr
    assert " case(s) in " in done.stdout


def _conform_in_process(port: int) -> None:
    """The cases that leave the most server state behind, run by the engine in this process
    (saves an interpreter start per run): fuzzing (many modules, disconnects in the middle of
    deliveries), stream pushes and subscriptions, sessions, priorities and queues."""
    globs = ("FUZZ-001", "STREAM-*", "SESS-*", "PRIO-*")
    options = RunOptions(target=("127.0.0.1", port), case_globs=globs, jobs=2)
    summary = asyncio.run(run(options, []))
    assert exit_code(summary) in (0, 1), summary.counts  # 5: the server died in the run


def _run_then_stop(conform: Callable[[int], None]) -> None:
    server = ServeProcess()
    try:
        conform(server.port)
        code = server.stop(signal.SIGTERM, timeout=STOP_S)
        assert code == 0, f"no clean exit after SIGTERM ({code}): {server.stderr()[-3000:]}"
        assert "event=shutdown phase=done" in server.stderr()
    finally:
        server.kill()


# 12 runs in `make test`: the full suite once, the stateful cases 11 times (the full suite every
# time would add minutes). Before the fix about one run in ten hung; 12 runs catch that in 7 of
# 10 `make test`s. OPENAIR_SHUTDOWN_RUNS=N runs the stateful cases N times (a soak).
STATEFUL_RUNS = int(os.environ.get("OPENAIR_SHUTDOWN_RUNS", "11"))


@pytest.mark.slow
@pytest.mark.parametrize("run_no", range(1))
def test_sigterm_after_the_full_suite(run_no: int) -> None:
    _run_then_stop(_conform_process)


@pytest.mark.slow
@pytest.mark.parametrize("run_no", range(STATEFUL_RUNS))
def test_sigterm_after_the_stateful_cases(run_no: int) -> None:
    _run_then_stop(_conform_in_process)


def test_a_second_signal_forces_the_exit() -> None:
    server = ServeProcess()
    try:
        code = asyncio.run(_signal_twice(server))
        assert code == 128 + signal.SIGINT, server.stderr()[-2000:]
        assert "event=shutdown phase=forced" in server.stderr()
    finally:
        server.kill()


async def _signal_twice(server: ServeProcess) -> int | None:
    """Hold a delivery unacknowledged (the stop waits its grace period), then signal twice."""
    hold = asyncio.Event()

    async def never_ack(event: object) -> None:
        await hold.wait()  # the acknowledgement waits for this callback (6.6)

    slow = Module("Slow", port=server.port, on_wakeup=never_ack, reconnect=False, keepalive=None)
    poster = Module("Poster", port=server.port, bind=False, reconnect=False, keepalive=None)
    async with slow, poster:
        await slow.subscribe("Test.*")
        await poster.post("WB1", "Test.Hold", "x")
        server.proc.send_signal(signal.SIGTERM)
        refused = None
        while refused is None:  # OA-SESS-24: SHUTTING_DOWN once the stop has begun
            try:
                await poster.post("WB1", "Other.Probe", "x")
            except FailedReplyError as exc:
                refused = exc.condition
        assert refused is ShuttingDownError
        code = await asyncio.to_thread(server.stop, signal.SIGINT, STOP_S)
        hold.set()
        return code
