"""Helpers of the delivery cases (6.6): a module's listening port of the case's own that drops
deliveries (`Dropper`), the advertised retry window, and counting the attempts of a delivery.

The module here listens on a port of the case's own and closes the connection on each of the
first N deliveries before acknowledging it: to the server that is a delivery that failed, and
each retry opens a new connection to the port. The bound that makes a count final is advertised:
a retry starts within `retry-deadline-ms` of the failure it follows (OA-DELIV-15), so no attempt
later than that plus the deadline can come. The module name starts with `_`, so `cases/__init__`
does not import it as a case module.
"""

from __future__ import annotations

import asyncio
import contextlib
import time

from openair.protocol.connection import ANSWER_FOR
from openair.protocol.message import Message
from openair_conformance.cases._common import next_request, setup_raw_bind_subscribe, triggers_xml
from openair_conformance.harness import CaseContext, RawConnection, TestModule
from openair_conformance.harness.checks import is_phase_update, wakeup_trigger_id
from openair_conformance.harness.conn import ConnectionLost, DecodeProblem, FramedStream

__all__ = ["Dropper", "expect_attempts", "no_more_attempts", "retry_window", "setup_dropper"]


class Dropper:
    """A module's listening port that drops (closes without acknowledging) `drops` deliveries."""

    def __init__(self, ctx: CaseContext, *, name: str, drops: int, silent: int = 0) -> None:
        self.ctx = ctx
        self.name = name
        self.drops = drops
        #: The first `silent` attempts are neither answered nor closed: the port keeps reading
        #: until the server closes the connection (OA-DELIV-11); `closed_at` says when.
        self.silent = silent
        self.closed_at: list[float] = []
        self.attempts: list[tuple[float, Message]] = []
        self.arrived: asyncio.Queue[Message] = asyncio.Queue()
        self._server: asyncio.Server | None = None
        self._streams: list[FramedStream] = []

    async def listen(self, host: str, port: int = 0) -> int:
        """Listen on `port` (0: a free one) of `host`; return the port."""
        self._server = await asyncio.start_server(self._accept, host, port)
        return int(self._server.sockets[0].getsockname()[1])

    async def _accept(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        label = f"{self.name[-1]}/listener#{len(self._streams) + 1}"
        stream = FramedStream(reader, writer, label=label, trace=self.ctx.trace)
        self._streams.append(stream)
        with contextlib.suppress(ConnectionLost, DecodeProblem):
            while await self._one(stream):
                pass
        await stream.close()

    async def _one(self, stream: FramedStream) -> bool:
        """Answer one request; return False once the connection is to be closed."""
        msg = stream.decode(await stream.read_frame())
        if msg.type in ANSWER_FOR:
            await stream.send_message(msg.reply(ANSWER_FOR[msg.type], sender=self.name))
            return True
        if is_phase_update(msg):
            await stream.send_message(msg.reply("RECEIVE_ACCEPT", sender=self.name))
            return True
        self.attempts.append((time.monotonic(), msg))
        self.arrived.put_nowait(msg)
        if len(self.attempts) <= self.silent:
            self.ctx.note(f"attempt {len(self.attempts)} left unanswered, connection kept open")
            try:
                while True:  # whatever comes now is not answered either
                    await stream.read_frame()
            except ConnectionLost:
                self.closed_at.append(time.monotonic())
                return False
        if len(self.attempts) <= self.drops:
            self.ctx.note(f"attempt {len(self.attempts)} dropped: connection closed unanswered")
            return False
        await stream.send_message(msg.reply("RECEIVE_ACCEPT", sender=self.name))
        return True

    async def close(self) -> None:
        """Stop listening and close every accepted connection."""
        for stream in self._streams:
            await stream.close()
        if self._server is not None:
            self._server.close()


def retry_window(ctx: CaseContext) -> tuple[int, float]:
    """Return the advertised retries and the longest wait for one retry (OA-DELIV-15)."""
    retries = ctx.server.limit("delivery-retries", 2)
    return retries, ctx.server.limit("retry-deadline-ms", 1000) / 1000 + ctx.deadline


async def setup_dropper(
    ctx: CaseContext, *, drops: int, silent: int = 0
) -> tuple[Dropper, TestModule, RawConnection]:
    """Bind a dropping module on its own port, registered for the case's Go type; it drops
    the first `drops` deliveries and leaves the first `silent` unanswered (`Dropper`)."""
    name = ctx.name("D")
    primary = await ctx.raw("D/primary")
    dropper = Dropper(ctx, name=name, drops=drops, silent=silent)
    port = await dropper.listen(primary.stream.local_host)
    await setup_raw_bind_subscribe(primary, name, port, triggers_xml(ctx.type("Go")))
    poster = await ctx.module("P")
    return dropper, poster, primary


async def expect_attempts(ctx: CaseContext, dropper: Dropper, trigger: str, count: int) -> None:
    """Wait for `count` attempts of the wakeup for `trigger`, each within the retry window."""
    retries, window = retry_window(ctx)
    for n in range(1, count + 1):
        timeout = ctx.deadline if n == 1 else window
        what = "the delivery" if n == 1 else f"retry {n - 1} of {retries} of the failed delivery"
        msg = await ctx.wait(
            dropper.arrived.get(),
            what=what,
            timeout=timeout,
            expected=f"{retries} retries, each within retry-deadline-ms (OA-DELIV-7, OA-DELIV-15)",
        )
        ctx.check(
            wakeup_trigger_id(msg) == trigger,
            f"attempt {n} delivered {msg.type} for {wakeup_trigger_id(msg)!r}, not the retry",
            expected=f"the same wakeup again, for {trigger} (OA-DELIV-7)",
        )


async def no_more_attempts(ctx: CaseContext, dropper: Dropper, allowed: int, why: str) -> None:
    """Fail if another attempt comes within the retry window (OA-DELIV-7, OA-DELIV-15)."""
    _, window = retry_window(ctx)
    with contextlib.suppress(TimeoutError):
        await asyncio.wait_for(dropper.arrived.get(), window)
    ctx.check(
        len(dropper.attempts) == allowed,
        f"the delivery was attempted {len(dropper.attempts)} times ({why})",
        expected=f"exactly {allowed} attempts (OA-DELIV-7, OA-DELIV-15)",
    )


async def accept_for(
    ctx: CaseContext, conn: RawConnection, *, receive_id: str, name: str, seconds: float
) -> list[str]:
    """Acknowledge every delivery `conn` (the callback connection `receive_id` of module
    `name`) gets within `seconds`; return their trigger ids (or types). Each read stays below
    the reply deadline, so an absence is not a late reply."""
    got: list[str] = []
    loop = asyncio.get_running_loop()
    until = loop.time() + seconds
    while (left := until - loop.time()) > 0:
        try:
            msg = await asyncio.wait_for(
                next_request(ctx, conn, receive_id=receive_id, name=name),
                min(left, ctx.deadline / 2),
            )
        except TimeoutError:
            continue
        got.append(wakeup_trigger_id(msg) or msg.type)
        await conn.send_message(msg.reply("RECEIVE_ACCEPT", sender=name))
    return got
