"""The event loop before the worker at the interpreter lock (issue #19, fairness).

The server's one worker thread decodes large requests and writes large replies and wakeups in
Python. The event loop gives the interpreter lock up at each of its system calls (every poll,
read and write); a worker that wants the lock takes it then, and the loop waits to have it back
until the worker lets go — up to the switch interval, several times in one client's turn. That
wait, not the loop's own work, was most of another client's delay while ten retrieves of 10 000
messages were written (`make stress`, big-retrieves: canary p99 3.8-4.7 ms).

`LoopGate` lets the worker run Python only while the loop has nothing to do. The loop's selector
(`fairselect.FairSelector`) opens the gate while it polls with a timeout (no callback ready) and
shuts it when the poll returns, as long as a worker job waits or runs (`busy`). The worker, at
each of its pauses (`budgets.pause_for_the_loop`, between the pieces of its job), waits for the
gate while it is shut — at most `WAIT_S`, so a loop that never idles still lets large jobs
progress — and lets the lock go for a moment while it is open (a loop just back from its poll
takes the lock then). Between two pauses the worker holds the lock for about
`budgets.PAUSE_AFTER_S`, or the length of one C call of its job.
"""

from __future__ import annotations

import threading
import time

__all__ = ["LOOP_GATE", "WAIT_S", "LoopGate"]

#: The longest a worker waits for the loop to idle before it goes on for one more piece: with
#: the worker's pieces of ~0.1 ms, a loop busy without pause keeps ~95 % of the lock.
WAIT_S = 0.002


class LoopGate:
    """Open while the event loop polls for I/O with nothing else to do; the worker waits for it.

    One per process: a server's loop and its one worker (`budgets.off_loop_executor`).
    """

    def __init__(self) -> None:
        self._open = threading.Event()
        #: Whether a loop opens the gate when it polls (a `FairSelector` is open: set when one is
        #: made, cleared when it closes); without one the worker never waits (no one would
        #: open the gate).
        self.enabled = False
        # Jobs handed to the worker (counted by the loop as it submits one) and jobs ended
        # (counted by the worker): one writer each, no lock. Counted at submission, not when
        # the job starts: the loop may poll in between, and must open the gate for it then.
        self._submitted = 0
        self._ended = 0
        #: How often the worker waited for the gate, and how often it gave up waiting.
        self.waits = 0
        self.timeouts = 0

    @property
    def busy(self) -> bool:
        """Whether a worker job is waiting or in progress: the loop opens the gate only then."""
        return self._submitted != self._ended

    def polling(self) -> None:
        """On the loop, before a poll with a timeout: the worker may run."""
        self._open.set()

    def polled(self) -> None:
        """On the loop, back from that poll: the worker waits at its next pause."""
        self._open.clear()

    def pause(self) -> None:
        """On the worker, between two pieces of its job: wait while the loop is at work."""
        if not self.enabled:
            time.sleep(0)  # whoever waits for the lock takes it now
            return
        if self._open.is_set():
            time.sleep(0)  # a loop back from its poll, waiting for the lock, takes it now
            if self._open.is_set():
                return
        self.waits += 1
        if not self._open.wait(WAIT_S):
            self.timeouts += 1

    def job_submitted(self) -> None:
        """On the loop, as it hands the worker a job (it opens the gate from its next poll)."""
        self._submitted += 1

    def job_ended(self) -> None:
        """On the worker, as a job ends (or is cancelled before it began)."""
        self._ended += 1


LOOP_GATE = LoopGate()
