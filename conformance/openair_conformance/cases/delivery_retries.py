"""Conformance cases for retrying a failed delivery (6.6, OA-DELIV-7, OA-DELIV-15).

The module here listens on a port of the case's own (`_Dropper`) and closes the connection on
each of the first N deliveries before acknowledging it: to the server that is a delivery that
failed, and each retry opens a new connection to the port. The suite counts the attempts. The
bound that makes the count final is advertised: a retry starts within `retry-deadline-ms` of
the failure it follows (OA-DELIV-15), so no attempt later than that plus the deadline can come.
"""

from __future__ import annotations

import asyncio
import contextlib
import time

from openair.protocol.connection import ANSWER_FOR
from openair.protocol.message import Message
from openair_conformance.cases._common import triggers_xml
from openair_conformance.harness import CaseContext, RawConnection, TestModule
from openair_conformance.harness.checks import is_phase_update, wakeup_trigger_id
from openair_conformance.harness.conn import ConnectionLost, DecodeProblem, FramedStream
from openair_conformance.model import Inconclusive, NotApplicable
from openair_conformance.registry import case


class _Dropper:
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


def _retry_window(ctx: CaseContext) -> tuple[int, float]:
    """Return the advertised retries and the longest wait for one retry (OA-DELIV-15)."""
    retries = ctx.server.limit("delivery-retries", 2)
    return retries, ctx.server.limit("retry-deadline-ms", 1000) / 1000 + ctx.deadline


async def _setup(ctx: CaseContext, drops: int) -> tuple[_Dropper, TestModule, RawConnection]:
    """Bind a dropping module on its own port, registered for the case's Go type."""
    name = ctx.name("D")
    primary = await ctx.raw("D/primary")
    dropper = _Dropper(ctx, name=name, drops=drops)
    port = await dropper.listen(primary.stream.local_host)
    location = f'<tcplocation port="{port}"/>'
    bind = Message(type="BIND", sender=name, to="CNS", content=location, content_is_xml=True)
    reply = await primary.request(bind)
    if reply.type != "BIND_ACCEPT":
        raise Inconclusive(f"setup: BIND was answered {reply.type} {reply.content!r}")
    subscribe = Message(
        type="AIR.Subscribe",
        sender=name,
        to="AIRCentral",
        content=triggers_xml(ctx.type("Go")),
        content_is_xml=True,
        language="xml",
    )
    reply = await primary.request(subscribe)
    if reply.type != "RECEIVE_ACCEPT":
        raise Inconclusive(f"setup: AIR.Subscribe was answered {reply.type} {reply.content!r}")
    poster = await ctx.module("P")
    return dropper, poster, primary


async def _attempts(ctx: CaseContext, dropper: _Dropper, trigger: str, count: int) -> None:
    """Wait for `count` attempts of the wakeup for `trigger`, each within the retry window."""
    retries, window = _retry_window(ctx)
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


async def _no_more(ctx: CaseContext, dropper: _Dropper, allowed: int, why: str) -> None:
    """Fail if another attempt comes within the retry window (OA-DELIV-7, OA-DELIV-15)."""
    _, window = _retry_window(ctx)
    with contextlib.suppress(TimeoutError):
        await asyncio.wait_for(dropper.arrived.get(), window)
    ctx.check(
        len(dropper.attempts) == allowed,
        f"the delivery was attempted {len(dropper.attempts)} times ({why})",
        expected=f"exactly {allowed} attempts (OA-DELIV-7, OA-DELIV-15)",
    )


@case(
    id="DELIV-012",
    title="A delivery whose connection closes unanswered is retried, and once acknowledged no more",
    section="6.6",
    requirements=("OA-DELIV-7", "OA-DELIV-15"),
    allowed=("the same wakeup on a new connection to the port, then nothing more",),
)
async def dropped_delivery_is_retried_once(ctx: CaseContext) -> None:
    """Drop the first attempt of a wakeup; the retry must come, and be the last attempt.

    Catches: a server that never retries (OA-DELIV-7 "at most twice" let it pass), retries
    late, or sends an acknowledged delivery again.
    """
    retries, _ = _retry_window(ctx)
    if retries < 1:
        raise Inconclusive("the server advertises delivery-retries 0: nothing to retry")
    dropper, poster, _ = await _setup(ctx, drops=1)
    try:
        await poster.post("WB1", ctx.type("Go"), "once")
        assert poster.last_sent is not None
        await _attempts(ctx, dropper, poster.last_sent.id, 2)
        await _no_more(ctx, dropper, 2, "the second attempt was acknowledged")
    finally:
        await dropper.close()


@case(
    id="DELIV-013",
    title="A delivery that keeps failing is attempted exactly delivery-retries + 1 times",
    section="6.6",
    requirements=("OA-DELIV-7", "OA-DELIV-15", "OA-ERR-5"),
    allowed=(
        "the advertised delivery-retries (default 2) retries, then the delivery abandoned",
        "the module's next delivery arrives once the failed one is abandoned",
    ),
)
async def failing_delivery_is_retried_exactly(ctx: CaseContext) -> None:
    """Drop every attempt of a wakeup; count the attempts within the advertised retry window;
    then post again: that wakeup must arrive (the module answers it).

    Catches: too few retries, too many, or retries spaced beyond `retry-deadline-ms`; and an
    abandoned delivery that is never let go (retried for ever in the background, holding the
    module's one delivery slot, so that it gets nothing more, OA-DELIV-7, OA-ERR-5).
    """
    retries, _ = _retry_window(ctx)
    dropper, poster, _ = await _setup(ctx, drops=retries + 1)
    try:
        await poster.post("WB1", ctx.type("Go"), "always")
        assert poster.last_sent is not None
        await _attempts(ctx, dropper, poster.last_sent.id, retries + 1)
        await _no_more(ctx, dropper, retries + 1, "every attempt was dropped")
        await poster.post("WB1", ctx.type("Go"), "after")
        assert poster.last_sent is not None
        after = await ctx.wait(
            dropper.arrived.get(),
            what="delivery after the abandoned one",
            expected="the abandoned delivery lets go of the module: its next one is sent "
            "(OA-DELIV-7, OA-ERR-5)",
        )
        ctx.check(
            wakeup_trigger_id(after) == poster.last_sent.id,
            f"after the abandoned delivery came {after.type} for {wakeup_trigger_id(after)!r}",
            expected=f"the wakeup for the next post, {poster.last_sent.id} (OA-DELIV-7)",
        )
    finally:
        await dropper.close()


#: The longest acknowledgement deadline DELIV-018 waits out (the default is 10 000 ms).
_MAX_ACK_DEADLINE_MS = 3_000


@case(
    id="DELIV-018",
    title="A delivery left unanswered for ack-deadline-ms has failed: its connection is closed "
    "and it is retried",
    section="6.6",
    requirements=("OA-DELIV-11", "OA-DELIV-7", "OA-DELIV-15"),
    allowed=(
        "the server closes the connection that carries the unanswered delivery no sooner than "
        "ack-deadline-ms after sending it and within it plus the case's deadline, then sends "
        "the same wakeup again on a new connection within retry-deadline-ms",
    ),
)
async def unanswered_delivery_times_out(ctx: CaseContext) -> None:
    """Leave the first attempt of a wakeup unanswered with its connection open; the server must
    close that connection once `ack-deadline-ms` has passed, not before, and retry the delivery.

    Catches: a server that never gives up on an unanswered delivery (the module then gets
    nothing more), gives up before its advertised deadline, retries on the connection it
    should have closed, or closes without retrying.
    """
    deadline_ms = ctx.server.limit("ack-deadline-ms", 10_000)
    if deadline_ms > _MAX_ACK_DEADLINE_MS:
        raise NotApplicable(
            f"ack-deadline-ms is {deadline_ms}; run against a server advertising at most "
            f"{_MAX_ACK_DEADLINE_MS} (openair serve --ack-deadline-ms 500)"
        )
    retries, window = _retry_window(ctx)
    if retries < 1:
        raise Inconclusive("the server advertises delivery-retries 0: nothing to retry")
    deadline = deadline_ms / 1000
    dropper, poster, _ = await _setup(ctx, drops=0)
    dropper.silent = 1
    try:
        await poster.post("WB1", ctx.type("Go"), "unanswered")
        assert poster.last_sent is not None
        trigger = poster.last_sent.id
        first = await ctx.wait(
            dropper.arrived.get(), what="the delivery", expected="the wakeup (OA-TRIG-1)"
        )
        sent = dropper.attempts[0][0]
        again = await ctx.wait(
            dropper.arrived.get(),
            what="the retry of the unanswered delivery",
            timeout=deadline + window + ctx.deadline,
            expected=f"the delivery failed after ack-deadline-ms ({deadline_ms} ms) and retried "
            "(OA-DELIV-11, OA-DELIV-7)",
        )
        closed = dropper.closed_at[0] if dropper.closed_at else None
        ctx.check(
            closed is not None,
            "the retry came while the connection of the unanswered delivery was still open",
            expected="that connection closed before the retry (OA-DELIV-11)",
        )
        assert closed is not None
        waited = closed - sent
        ctx.check(
            waited >= deadline - 0.05,
            f"the connection was closed {waited * 1000:.0f} ms after the delivery",
            expected=f"no sooner than ack-deadline-ms, {deadline_ms} ms (OA-DELIV-11)",
        )
        ctx.check(
            waited <= deadline + ctx.deadline,
            f"the connection was closed {waited * 1000:.0f} ms after the delivery",
            expected=f"within ack-deadline-ms ({deadline_ms} ms) and the case's deadline "
            "(OA-DELIV-11)",
        )
        ctx.check(
            wakeup_trigger_id(first) == trigger and wakeup_trigger_id(again) == trigger,
            f"the attempts were for {wakeup_trigger_id(first)!r} and {wakeup_trigger_id(again)!r}",
            expected=f"the same wakeup twice, for {trigger} (OA-DELIV-7)",
        )
    finally:
        await dropper.close()
