"""Push subscribers for the stream cases (spec 11.6): `PushReader` and `push_ready`.

`PushReader` plays a push subscriber on a raw connection: a `Receive` frame with
RECEIVE_NAME_NOTIFICATION to the stream, then it reads the pushed `DATASAMPLE` requests in the
background and acknowledges them at once, or holds the acknowledgements while paused (a slow
subscriber). PING and KEEPALIVE are always answered.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from openair.protocol.connection import ANSWER_FOR
from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._streams import Sample, StreamClient, marker, read_chunk
from openair_conformance.harness import CaseContext, RawConnection
from openair_conformance.harness.conn import ConnectionLost, DecodeProblem

__all__ = ["PushReader", "Pushed", "push_ready"]


@dataclass(slots=True)
class Pushed:
    """One DATASAMPLE the server pushed: the message, its sample, its `dropped` slot."""

    message: Message
    sample: Sample | None
    dropped: int
    problem: str = ""


@dataclass(slots=True)
class _PushState:
    pushed: list[Pushed] = field(default_factory=list)
    held: list[Message] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    arrived: asyncio.Event = field(default_factory=asyncio.Event)
    paused: bool = False


class PushReader:
    """A push subscriber (11.6): RECEIVE_NAME_NOTIFICATION in a Receive frame, then DATASAMPLEs.

    Deliveries are acknowledged with RECEIVE_ACCEPT at once, or held while `paused`; PING and
    KEEPALIVE are always answered. Use as an async context manager (the reading task stops).
    """

    def __init__(self, ctx: CaseContext, raw: RawConnection, *, name: str, to: str) -> None:
        self.ctx = ctx
        self.raw = raw
        self.name = name
        self.to = to
        self.notice_id = ""
        self._state = _PushState()
        self._task: asyncio.Task[None] | None = None

    @classmethod
    async def subscribe(
        cls, ctx: CaseContext, to: str, suffix: str, *, paused: bool = False
    ) -> PushReader:
        """Open a connection and subscribe the reader `ctx.name(suffix)` to `to`."""
        raw = await ctx.raw(suffix, component=to)  # the stream's own port, if it has one
        reader = cls(ctx, raw, name=ctx.name(suffix), to=to)
        reader._state.paused = paused
        notice = Message(type="RECEIVE_NAME_NOTIFICATION", sender=reader.name, to=to)
        sent = await raw.send_message(notice, FrameTag.RECEIVE)
        reader.notice_id = sent.id
        reader._task = asyncio.create_task(reader._serve(), name=f"push reader {reader.name}")
        return reader

    async def __aenter__(self) -> PushReader:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()

    async def stop(self) -> None:
        """Stop reading and close the connection."""
        await self.raw.close()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._task

    @property
    def pushed(self) -> list[Pushed]:
        """Every DATASAMPLE received so far, in arrival order."""
        return self._state.pushed

    async def resume(self) -> None:
        """Send the held acknowledgements, in order, and acknowledge at once again."""
        self._state.paused = False
        held, self._state.held = self._state.held, []
        for msg in held:
            await self._accept(msg)

    async def _accept(self, msg: Message) -> None:
        with contextlib.suppress(ConnectionLost):
            await self.raw.stream.send_message(msg.reply("RECEIVE_ACCEPT", sender=self.name))

    async def _serve(self) -> None:
        state = self._state
        try:
            while True:
                frame = await self.raw.stream.read_frame()
                try:
                    msg = self.raw.stream.decode(frame)
                except DecodeProblem as exc:
                    state.problems.append(f"the server pushed an undecodable message: {exc}")
                    state.arrived.set()
                    continue
                await self._handle(msg)
                state.arrived.set()
        except ConnectionLost as exc:
            state.problems.append(f"the push connection ended: {exc}")
            state.arrived.set()

    async def _handle(self, msg: Message) -> None:
        state = self._state
        if msg.type in ANSWER_FOR:
            await self.raw.stream.send_message(msg.reply(ANSWER_FOR[msg.type], sender=self.name))
            return
        if msg.type != "DATASAMPLE" or msg.isresponse:
            state.problems.append(
                f"the server sent {msg.type} {msg.content[:200]!r} (isresponse "
                f"{msg.isresponse!r}) on the push connection"
            )
            return
        state.pushed.append(_pushed(msg))
        if state.paused:
            state.held.append(msg)
        else:
            await self._accept(msg)

    async def first_push(self) -> None:
        """Return once a push (or a problem) has arrived; no deadline (the caller bounds it)."""
        while not self._state.pushed and not self._state.problems:
            self._state.arrived.clear()
            await self._state.arrived.wait()

    async def until(
        self, predicate: Callable[[list[Pushed]], bool], *, what: str, timeout: float | None = None
    ) -> list[Pushed]:
        """Wait until `predicate(pushed)` holds; Fail on a problem first.

        The deadline policy applies to each push, not to the whole sequence: pushes go one at
        a time, and on a shared stream other cases' samples come in between.
        """
        state = self._state
        while True:
            if state.problems:
                self.ctx.fail(
                    state.problems[0],
                    expected="only DATASAMPLE requests on a push connection (OA-STREAM-8)",
                )
            if predicate(state.pushed):
                return state.pushed
            seen = len(state.pushed)
            await self.ctx.wait(
                self._more_than(seen),
                what=f"{what} (push {seen + 1} to {self.name})",
                timeout=timeout,
                expected="DATASAMPLE pushes (OA-STREAM-8)",
            )

    async def _more_than(self, seen: int) -> None:
        state = self._state
        while len(state.pushed) <= seen and not state.problems:
            state.arrived.clear()
            await state.arrived.wait()


def _pushed(msg: Message) -> Pushed:
    slot = msg.extra("dropped")
    text = slot.value.strip() if slot is not None else "0"
    problem = "" if text.isdigit() else f"the dropped slot holds {text!r}"
    sample: Sample | None = None
    if len(msg.binary) == 1:
        try:
            sample = read_chunk(msg.binary[0])
        except ValueError as exc:
            problem = problem or f"the pushed chunk is not a datasample: {exc}"
    else:
        problem = problem or f"the DATASAMPLE carries {len(msg.binary)} chunks"
    return Pushed(
        message=msg, sample=sample, dropped=int(text) if text.isdigit() else 0, problem=problem
    )


async def push_ready(ctx: CaseContext, writer: StreamClient, readers: Sequence[PushReader]) -> int:
    """Add probe samples until every reader has had a push; return the last probe's id.

    A subscription sent on one connection and a sample added on another race in the server;
    the first push a reader gets shows that its subscription is in force (OA-STREAM-8).
    """
    mark = marker(ctx)
    # A round trip first: the server has then most likely read the notifications sent before.
    await writer.raw.request(Message(type="PING", sender=writer.sender, to="CNS"))
    probe_id = 0
    for attempt in range(3):
        probe_id = await writer.add(b"probe", [mark, ("conf:probe", str(attempt))])
        if all(r.pushed for r in readers):
            return probe_id
        if attempt < 2:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(_all_pushed(readers), ctx.deadline / 2)
            if all(r.pushed for r in readers):
                return probe_id
    for reader in readers:
        await reader.until(bool, what=f"first push to {reader.name}")
    return probe_id


async def _all_pushed(readers: Sequence[PushReader]) -> None:
    for reader in readers:
        await reader.first_push()
