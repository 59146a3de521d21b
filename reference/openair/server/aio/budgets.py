"""The asyncio side of the server's budgets (issue #19): accept errors, off-loop worker, buffers.

`quiet_accept_errors` turns asyncio's traceback per failed accept (EMFILE, ENFILE: out of file
descriptors) into one log line per interval; asyncio already waits a second before it accepts
again. `off_loop_executor` is the one worker thread for large requests and replies, and
`pause_for_the_loop` lets it give the interpreter lock up between the pieces of a long job
(and wait while the loop is at work, `loopgate`);
`return_large_buffers` sets glibc's mmap threshold. The counts are `openair.server.core.budgets`.
"""

from __future__ import annotations

import asyncio
import errno
import sys
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from functools import partial
from typing import Any, ParamSpec, TypeVar

from openair.server.aio.loopgate import LOOP_GATE
from openair.server.core.budgets import RateLimitedLog

_T = TypeVar("_T")
_P = ParamSpec("_P")

__all__ = [
    "ACCEPT_BATCH",
    "full_backlog",
    "off_loop_executor",
    "pause_for_the_loop",
    "quiet_accept_errors",
    "return_large_buffers",
]

_FD_ERRNOS = frozenset({errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM})


def quiet_accept_errors(
    loop: asyncio.AbstractEventLoop, clock: Callable[[], float]
) -> RateLimitedLog:
    """Log failed accepts for lack of descriptors once per interval, not as a traceback each.

    asyncio reports them through the loop's exception handler ("socket.accept() out of system
    resource") and retries after a second; other reports go to the handler in place before.
    """
    previous = loop.get_exception_handler()
    note = RateLimitedLog("accept_failed")

    def handler(lp: asyncio.AbstractEventLoop, context: dict[str, object]) -> None:
        exc = context.get("exception")
        if isinstance(exc, OSError) and exc.errno in _FD_ERRNOS:
            note.note(clock(), f"errno={errno.errorcode.get(exc.errno or 0, '?')}")
            return
        if previous is not None:
            previous(lp, context)
        else:
            lp.default_exception_handler(context)

    loop.set_exception_handler(handler)
    return note


_M_TRIM_THRESHOLD = -1  # glibc mallopt parameters (malloc.h)
_M_MMAP_THRESHOLD = -3
_MMAP_FROM = 256 * 1024


def return_large_buffers() -> bool:
    """Make glibc give large buffers back to the system when they are freed (issue #19).

    glibc raises its mmap threshold each time a large block is freed, after which frames and
    contents of a megabyte come from the heap and the heap's top cannot shrink past the live
    blocks above them: a burst of large posts kept the server's RSS high long after it was
    gone. A fixed threshold serves every buffer of 256 KiB or more by mmap, unmapped on free.
    Returns False where this is not glibc (nothing changes).
    """
    try:
        import ctypes  # only here: the rest of the server has no use for it

        libc = ctypes.CDLL("libc.so.6")
        ok = int(libc.mallopt(_M_MMAP_THRESHOLD, _MMAP_FROM)) == 1
        return ok and int(libc.mallopt(_M_TRIM_THRESHOLD, 4 * _MMAP_FROM)) == 1
    except (OSError, AttributeError):
        return False


_OFF_LOOP: list[ThreadPoolExecutor] = []
_WORKER_NAME = "openair-large"
_SWITCH_S = 0.0005


class _GatedExecutor(ThreadPoolExecutor):
    """The worker's executor: each job is counted by the loop gate and first waits for it."""

    def submit(self, fn: Callable[_P, _T], /, *args: _P.args, **kwargs: _P.kwargs) -> Future[_T]:
        LOOP_GATE.job_submitted()
        try:
            future = super().submit(partial(_gated, fn, *args, **kwargs))
        except BaseException:
            LOOP_GATE.job_ended()  # refused (the executor shut down): it will not run
            raise
        future.add_done_callback(_cancelled)
        return future


def _cancelled(future: Future[Any]) -> None:
    if future.cancelled():  # it never ran: `_gated` did not count its end
        LOOP_GATE.job_ended()


def _gated(fn: Callable[_P, _T], *args: _P.args, **kwargs: _P.kwargs) -> _T:
    try:
        pause_for_the_loop()  # begin when the loop idles (or has waited `loopgate.WAIT_S`)
        return fn(*args, **kwargs)
    finally:
        LOOP_GATE.job_ended()


def off_loop_executor() -> ThreadPoolExecutor:
    """The one worker thread that decodes large requests and writes large replies (issue #19).

    One, not one per core: the writing holds the interpreter lock most of the time, and the
    event loop waits for that lock behind every thread that wants it (up to the 5 ms switch
    interval each), so each more worker lengthens every other client's turn; one also bounds
    the memory of the large requests and replies in progress to one at a time.
    """
    if not _OFF_LOOP:
        # The loop waits for the lock at most this long after asking (5 ms by default): the
        # worker's share of a second barely changes, every other client's wait falls.
        sys.setswitchinterval(_SWITCH_S)
        # Not at a lower scheduling priority: a worker preempted while it holds the lock would
        # keep the loop waiting for as long as the system leaves it off the processor.
        _OFF_LOOP.append(_GatedExecutor(max_workers=1, thread_name_prefix=_WORKER_NAME))
    return _OFF_LOOP[0]


#: How long the worker holds the interpreter lock at most between two `pause_for_the_loop`s.
PAUSE_AFTER_S = 0.0001
_paused_at = [0.0]


def pause_for_the_loop() -> None:
    """On the worker: every `PAUSE_AFTER_S` of its job, give the event loop the lock.

    The event loop gives the lock up at each of its system calls and then waits for it until
    the holder lets go: up to the switch interval each time, several times in one client's
    turn. Called between the pieces of a long job (the copies of a large wakeup or retrieve
    reply, the steps of a large decode), it bounds that wait: the worker lets the lock go, and
    while the loop is at work waits until it polls again (`loopgate.LoopGate.pause`). Measured
    on `make stress` (2026-11-29): a turn of 1.5 ms of work took 5-6 ms while the worker wrote
    a wakeup of a thousand copies, 2-3 ms with the lock let go every 0.1 ms; during ten
    retrieves of 10 000 messages another client's p99 was 3.8-4.7 ms, 1.2-2.4 ms with the gate.
    Only the worker pauses: on the loop's thread (a wakeup written at once) it would let the
    worker in.
    """
    now = time.perf_counter()
    if now - _paused_at[0] > PAUSE_AFTER_S and threading.current_thread().name.startswith(
        _WORKER_NAME
    ):
        LOOP_GATE.pause()
        _paused_at[0] = time.perf_counter()


#: Connections asyncio accepts in one loop turn at most (each costs some 60 µs to set up, twice
#: that when the monitor takes it over): the `backlog` the listener is created with. Chosen on
#: `make stress` (2026-11-29): with 8, another client's p99 was 4-5.6 ms while 130 half-sent
#: HTTP requests came and went; with 4, 1.7-2.3 ms.
ACCEPT_BATCH = 4


def full_backlog(listener: asyncio.Server, backlog: int) -> None:
    """Give the kernel's queue of connections to accept the full `backlog` (issue #19).

    asyncio accepts as many connections in one loop turn as the backlog it was given: with
    1024, a flood's accepts took every other client's turn. The listener was created with
    `ACCEPT_BATCH`; listening again on the same socket sets the queue's length.
    """
    for sock in listener.sockets:
        with sock.dup() as listening:
            listening.listen(backlog)
