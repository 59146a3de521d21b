"""Is the target still alive? The cheap probe between cases, and bringing a dead target back.

A legacy server may crash mid-run (Psyclone 1.1.7 did, twice in two runs); every case after the
crash would then be judged on "connection refused". `alive` is a TCP connect and one PING;
`restart` runs the user's restart command and waits until the target answers again.
"""

from __future__ import annotations

import asyncio
import subprocess
import time
from collections.abc import Mapping, Sequence

from openair.protocol.message import Message
from openair_conformance.harness.conn import (
    ConnectionLost,
    DecodeProblem,
    RequesterChannel,
    open_stream,
)
from openair_conformance.harness.trace import Trace
from openair_conformance.model import TraceEntry

__all__ = ["LIVENESS_NAME", "Restarter", "alive", "first_unanswered"]

LIVENESS_NAME = "ConformanceLiveness"


async def alive(host: str, port: int, *, timeout: float) -> str | None:
    """Connect and PING once; return None when answered, else what went wrong."""
    trace = Trace()
    try:
        stream = await open_stream(host, port, label="liveness", trace=trace, timeout=timeout)
    except ConnectionLost as exc:
        return str(exc)
    channel = RequesterChannel(stream, name=LIVENESS_NAME, pipelining=False)
    channel.start()
    try:
        _, reply = await channel.send(Message(type="PING", sender=LIVENESS_NAME, to="CNS"))
        await asyncio.wait_for(reply, timeout)
    except TimeoutError:
        return f"no answer to PING within {timeout:.1f} s"
    except (ConnectionLost, DecodeProblem) as exc:
        return f"PING: {exc}"
    finally:
        await channel.close()
    return None


def first_unanswered(traces: Mapping[str, tuple[float, Sequence[TraceEntry]]]) -> str | None:
    """Name the case that sent the earliest request nothing answered.

    `traces` maps each case that was running when the target died to the time (same clock for
    all) its trace began and its entries. A frame the suite sent on a connection where nothing
    came back after it was not answered; the earliest such frame is the likeliest to have
    killed the target (with cases in parallel that is evidence, not proof). Frames on the
    connections where the suite only answers the server are replies, and are left out. None
    when every request was answered.
    """
    unanswered: list[tuple[float, str]] = []
    for case, (origin, entries) in traces.items():
        last_in: dict[str, float] = {}
        for e in entries:
            if e.direction == "in":
                last_in[e.conn] = e.t
        unanswered += [
            (origin + e.t, case)
            for e in entries
            if e.direction == "out"
            and not _answering(e.conn)
            and e.t > last_in.get(e.conn, float("-inf"))
        ]
    return min(unanswered)[1] if unanswered else None


def _answering(conn: str) -> bool:
    """Whether a connection is one where the suite only answers the server (its frames are
    replies, which get no answer: they say nothing about the target being alive)."""
    return "/listener" in conn or "/callback" in conn


class Restarter:
    """Run the restart command (through the shell) and wait until the target answers.

    The command is not waited for: it may start the server in the foreground (it is then left
    running, as the target) or return after starting it. The restart failed when the command
    exits non-zero, or when the target does not answer within `timeout` seconds.
    """

    def __init__(self, command: str, *, timeout: float = 60.0) -> None:
        self.command = command
        self.timeout = timeout
        self.processes: list[subprocess.Popen[bytes]] = []

    async def restart(self, host: str, port: int, *, probe_timeout: float) -> str | None:
        """Return None once the target answers again, else why the restart failed."""
        process = subprocess.Popen(
            self.command,
            shell=True,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        self.processes.append(process)
        give_up = time.monotonic() + self.timeout
        pause = 0.05
        while True:
            code = process.poll()
            if code not in (None, 0):
                return f"the restart command exited with status {code}"
            if await alive(host, port, timeout=probe_timeout) is None:
                return None
            if time.monotonic() > give_up:
                return f"the target did not answer within {self.timeout:.0f} s of the restart"
            await asyncio.sleep(pause)  # polling a process that is not ours to signal
            pause = min(pause * 2, 1.0)
