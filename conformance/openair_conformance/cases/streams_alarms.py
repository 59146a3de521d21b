"""Cases of the `typed-streams` extension (spec 11.7) about limits, locks and alarms: soft and
hard limits with locks, LOCK_SAMPLES / UNLOCK_SAMPLES, and the alarms Started, SoftLimit,
HardLimit, Gap and Idle as posts on the alarms whiteboard.

Each case creates a typed stream of its own with small limits (Psyclone.System.Create.Stream)
and watches its alarms with a module registered for `AIR.Stream.Alarm.*` on the alarms
whiteboard (alarms of other cases' streams are told apart by `from`, the stream's name). To
show that an alarm came only once, the case ends with a `Gap` (a writer's `builtin:seq` that
skips): alarms of one stream are posts on one whiteboard, delivered in order (OA-PRIO-1), so
every alarm posted before the Gap has been delivered when the Gap arrives.
"""

from __future__ import annotations

import time

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    check_error,
    esc,
    retrieved,
    setup_subscribe,
    triggers_xml,
)
from openair_conformance.cases._streams import StreamClient, create_stream, holds_exactly
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    attributes,
    content_object,
    wakeup_view,
)
from openair_conformance.registry import case

_TYPED = ("typed-streams",)
_ALARM = "AIR.Stream.Alarm."
_SENTINEL = "1000000"


class AlarmWatch:
    """A module woken by every alarm on a whiteboard; it picks those of one stream."""

    def __init__(self, ctx: CaseContext, module: TestModule, stream: str, board: str) -> None:
        self.ctx = ctx
        self.module = module
        self.stream = stream
        self.board = board

    @classmethod
    async def open(cls, ctx: CaseContext, stream: str, board: str = "WB1") -> AlarmWatch:
        """Register a module for `AIR.Stream.Alarm.*` on `board` (before the stream is used)."""
        module = await ctx.module("Alarms")
        await setup_subscribe(module, triggers_xml(_ALARM + "*", wb=board))
        return cls(ctx, module, stream, board)

    def _trigger(self, wakeup: Message) -> Message | None:
        try:
            trigger = wakeup_view(wakeup).trigger
        except WakeupUnreadable:
            return None
        if trigger is None or trigger.sender != self.stream:
            return None
        return trigger if trigger.type.startswith(_ALARM) else None

    async def next(
        self, kind: str, *, timeout: float | None = None, **where: str
    ) -> dict[str, str]:
        """Return the entries of this stream's next alarm of `kind` whose entries include
        `where` (Fail if none comes)."""

        def wanted(wakeup: Message) -> bool:
            trigger = self._trigger(wakeup)
            if trigger is None or trigger.type != _ALARM + kind:
                return False
            found = _entries(trigger)
            return all(found.get(k) == v for k, v in where.items())

        wakeup = await self.module.expect_wakeup(
            wanted, timeout=timeout, what=f"{_ALARM}{kind} alarm of {self.stream}"
        )
        trigger = self._trigger(wakeup)
        assert trigger is not None
        return self.entries(trigger)

    def entries(self, alarm: Message) -> dict[str, str]:
        """Read an alarm's `<dictionary>`; Fail unless it has stream, streamtype and time."""
        want = "<dictionary> with the entries stream, streamtype and time (OA-XSTREAM-6)"
        try:
            content_object(alarm, "dictionary")
        except WakeupUnreadable as exc:
            self.ctx.fail(f"{alarm.type} content: {exc}", expected=want)
        found = _entries(alarm)
        self.ctx.check(
            found.get("stream") == self.stream
            and bool(found.get("streamtype"))
            and found.get("time", "").isdigit()
            and alarm.language == "xml",
            f"{alarm.type} has the entries {found} (content language {alarm.language!r})",
            expected=want + ", language xml",
        )
        return found

    def kinds_seen(self) -> list[str]:
        """Return the kinds of this stream's alarms delivered so far, in order, up to and with
        the closing Gap of `_gap_sentinel` when it came (later alarms are not compared)."""
        kinds = []
        for wakeup in self.module.wakeups_seen:
            trigger = self._trigger(wakeup)
            if trigger is not None:
                kinds.append(trigger.type.removeprefix(_ALARM))
                if _entries(trigger).get("received") == _SENTINEL:
                    break
        return kinds

    async def stored_kinds(self) -> list[str]:
        """Retrieve this stream's alarms from the alarms whiteboard, oldest first (OA-RET-6)."""
        spec = (
            f'<retrieve from="{esc(self.board)}" type="{_ALARM}*" sender="{esc(self.stream)}">'
            "<latest>0</latest></retrieve>"
        )
        stored = await retrieved(self.ctx, self.module, spec, req="OA-XSTREAM-6")
        return [m.type.removeprefix(_ALARM) for m in reversed(stored)]


def _entries(alarm: Message) -> dict[str, str]:
    """Return the `<entry name>` texts of an alarm's `<dictionary>` ({} when unreadable)."""
    try:
        root = content_object(alarm, "dictionary")
    except WakeupUnreadable:
        return {}
    return {
        attributes(el).get("name", ""): (el.text or "").strip()
        for el in root
        if isinstance(el.tag, str) and str(el.tag).lower() == "entry"
    }


async def _gap_sentinel(ctx: CaseContext, writer: StreamClient, watch: AlarmWatch) -> None:
    """Add a sample whose builtin:seq skips, and wait for its Gap alarm (see the module doc)."""
    await writer.add(b"sentinel", [("builtin:seq", _SENTINEL)], req="OA-XSTREAM-8")
    await watch.next("Gap", received=_SENTINEL)


async def _lock(ctx: CaseContext, client: StreamClient, text: str) -> str:
    reply = await client.request("LOCK_SAMPLES", text)
    ctx.check(
        reply.type == "LOCKED" and reply.content.strip().isdigit(),
        f"LOCK_SAMPLES {text} was answered {reply.type} {reply.content!r}",
        expected="LOCKED with a decimal lock id (OA-XSTREAM-5)",
    )
    return reply.content.strip()


async def _unlock(ctx: CaseContext, client: StreamClient, lock_id: str, *, known: bool) -> None:
    reply = await client.request("UNLOCK_SAMPLES", lock_id)
    what = f"UNLOCK_SAMPLES {lock_id} on {client.sender}"
    if known:
        ctx.check(
            reply.type == "RECEIVE_ACCEPT",
            f"{what} was answered {reply.type} {reply.content!r}",
            expected="RECEIVE_ACCEPT (OA-XSTREAM-5)",
        )
    else:
        check_error(ctx, reply, names=("LOCK_UNKNOWN",), what=what, req="OA-XSTREAM-5")


async def _holds(ctx: CaseContext, client: StreamClient, held: list[int], gone: list[int]) -> None:
    """Fail unless the stream holds exactly the ids `held` (and none of `gone`)."""
    why = " (OA-XSTREAM-2, OA-XSTREAM-3)"
    await holds_exactly(
        ctx,
        client,
        held,
        gone,
        count_req="OA-XSTREAM-2",
        req="OA-XSTREAM-2",
        why=why,
        subject="the stream",
    )


async def _add_seq(client: StreamClient, seq: int, size: int = 10) -> int:
    return await client.add(bytes(size), [("builtin:seq", str(seq))], req="OA-XSTREAM-2")


@case(
    id="XSTREAM-005",
    title="Above the soft limit the oldest unlocked samples go, with one SoftLimit alarm",
    section="11.7",
    requirements=("OA-XSTREAM-2", "OA-XSTREAM-5", "OA-XSTREAM-6"),
    needs=_TYPED,
    allowed=(
        "softcount 3: with 1–2 locked, adding 4 drops 3 and adding 5 drops 4; after the unlock "
        "adding 6 drops 1; one SoftLimit alarm (size 30, count 3, dropped 1) for the crossing",
    ),
)
async def soft_limit(ctx: CaseContext) -> None:
    """Create a stream with softcount 3 and hardcount 6; add 1–3, lock 1-2, add 4 and 5,
    unlock, add 6; check the samples held after each step. A Gap then closes the alarms: one
    SoftLimit in all, and it is stored on the whiteboard.

    Catches: locks ignored, the soft limit enforced like the hard one, SoftLimit posted for
    every add above the limit (or never).
    """
    raw = await ctx.raw("Creator")
    name = ctx.name("Soft")
    watch = await AlarmWatch.open(ctx, name)
    await create_stream(ctx, raw, "Soft", type=ctx.type("Soft"), softcount=3, hardcount=6, idle=0)
    client = await StreamClient.open(ctx, name)
    for seq in (1, 2, 3):
        await _add_seq(client, seq)
    lock_id = await _lock(ctx, client, "1-2")
    await _add_seq(client, 4)
    await _holds(ctx, client, [1, 2, 4], gone=[3])
    entries = await watch.next("SoftLimit")
    ctx.check(
        (entries.get("count"), entries.get("size"), entries.get("dropped")) == ("3", "30", "1"),
        f"the SoftLimit alarm has the entries {entries}",
        expected="count 3, size 30, dropped 1: the state after the add (OA-XSTREAM-2)",
    )
    await _add_seq(client, 5)
    await _holds(ctx, client, [1, 2, 5], gone=[4])
    await _unlock(ctx, client, lock_id, known=True)
    await _add_seq(client, 6)
    await _holds(ctx, client, [2, 5, 6], gone=[1])
    await _gap_sentinel(ctx, client, watch)
    seen = watch.kinds_seen()
    ctx.check(
        seen == ["Started", "SoftLimit", "Gap"],
        f"the stream's alarms were {seen}, for four adds that dropped samples in a row",
        expected="Started, SoftLimit, Gap: one SoftLimit each time the stream goes above a soft "
        "limit (OA-XSTREAM-2)",
    )
    stored = await watch.stored_kinds()
    ctx.check(
        stored.count("SoftLimit") == 1 and "Started" in stored,
        f"the alarms stored on WB1 are {stored}",
        expected="the alarms as ordinary, retrievable posts (OA-XSTREAM-6)",
    )


@case(
    id="XSTREAM-006",
    title="Above the hard limit locked samples go too, with a HardLimit alarm counting them",
    section="11.7",
    requirements=("OA-XSTREAM-3", "OA-XSTREAM-5", "OA-XSTREAM-6"),
    needs=_TYPED,
    allowed=(
        "softcount 2, hardcount 3, all held samples locked: 1–3 held; adding 4 drops 1 and "
        "posts HardLimit with dropped 1",
    ),
)
async def hard_limit(ctx: CaseContext) -> None:
    """Create a stream with softcount 2 and hardcount 3; add 1 and 2, lock 1-2, add 3 (only
    the newest sample is unlocked, so nothing goes), lock 3-3, add 4 with a builtin:seq that
    skips (a Gap in the same add).

    Catches: locked samples dropped at the soft limit, more than hardcount samples kept,
    HardLimit never posted or without the number dropped.
    """
    raw = await ctx.raw("Creator")
    name = ctx.name("Hard")
    watch = await AlarmWatch.open(ctx, name)
    await create_stream(ctx, raw, "Hard", type=ctx.type("Hard"), softcount=2, hardcount=3, idle=0)
    client = await StreamClient.open(ctx, name)
    await _add_seq(client, 1)
    await _add_seq(client, 2)
    await _lock(ctx, client, "1-2")
    await _add_seq(client, 3)
    await _holds(ctx, client, [1, 2, 3], gone=[])
    await _lock(ctx, client, "3-3")
    await _add_seq(client, 10)
    await _holds(ctx, client, [2, 3, 4], gone=[1])
    entries = await watch.next("HardLimit")
    ctx.check(
        entries.get("dropped") == "1",
        f"the HardLimit alarm has the entries {entries}",
        expected="dropped = 1, the number of samples the hard limit dropped (OA-XSTREAM-3)",
    )
    await _gap_sentinel(ctx, client, watch)
    seen = watch.kinds_seen()
    ctx.check(
        seen == ["Started", "Gap", "HardLimit", "Gap"],
        f"the stream's alarms were {seen}",
        expected="Started, then Gap and HardLimit for the fourth add (in that order within an "
        "add), then the closing Gap (OA-XSTREAM-3, OA-XSTREAM-6)",
    )


@case(
    id="XSTREAM-008",
    title="Locks: LOCKED ids, LOCK_UNKNOWN for unknown or foreign ids, released on close",
    section="11.7",
    requirements=("OA-XSTREAM-5",),
    needs=_TYPED,
    allowed=(
        "LOCKED with distinct decimal ids (also for a range that holds nothing); RECEIVE_ACCEPT "
        "for the owner's unlock; RECEIVE_ERROR LOCK_UNKNOWN for another connection's, an unknown "
        "or a released id; CONTENT_INVALID for a range that is no range; the locks gone with "
        "the connection",
    ),
)
async def locks(ctx: CaseContext) -> None:
    """Create a stream with softcount 2. Connection A adds 1 and 2, locks 1-2 and 50-60;
    connection B tries to unlock A's lock; A unlocks an unknown id and the empty-range lock
    twice, and sends the ranges `abc` and `5-2` and the lock id `x`. A adds 3 and 4 (3 goes,
    1 and 2 stay). A closes; once GET_INFO shows no locked sample, B adds 5 and the soft limit
    drops 1 and 2.

    Catches: locks shared between connections, never released, or ids that are not unique.
    """
    raw = await ctx.raw("Creator")
    name = await create_stream(
        ctx, raw, "Locks", type=ctx.type("Locks"), softcount=2, hardcount=10, idle=0
    )
    owner = await StreamClient.open(ctx, name, "Owner")
    other = await StreamClient.open(ctx, name, "Other")
    await _add_seq(owner, 1)
    await _add_seq(owner, 2)
    held = await _lock(ctx, owner, "1-2")
    empty = await _lock(ctx, owner, "50-60")
    ctx.check(held != empty, f"two locks got the id {held}", expected="unique ids (OA-XSTREAM-5)")
    await _unlock(ctx, other, held, known=False)
    await _unlock(ctx, owner, "999999", known=False)
    await _unlock(ctx, owner, empty, known=True)
    await _unlock(ctx, owner, empty, known=False)
    for type, content in (
        ("LOCK_SAMPLES", "abc"),
        ("LOCK_SAMPLES", "5-2"),
        ("UNLOCK_SAMPLES", "x"),
    ):
        reply = await owner.request(type, content)
        what = f"{type} {content}"
        check_error(ctx, reply, names=("CONTENT_INVALID",), what=what, req="OA-XSTREAM-5")
    await _add_seq(owner, 3)
    await _add_seq(owner, 4)
    await _holds(ctx, owner, [1, 2, 4], gone=[3])
    await owner.raw.close()
    await ctx.wait(_unlocked(other), what="GET_INFO locked=0 after the owner closed")
    await _add_seq(other, 5)
    await _holds(ctx, other, [4, 5], gone=[1, 2])


async def _unlocked(client: StreamClient) -> None:
    """Ask GET_INFO until no sample is locked (the server learns of a close asynchronously)."""
    while (await client.info(req="OA-XSTREAM-5")).get("locked") != "0":
        pass


@case(
    id="XSTREAM-009",
    title="Alarms are posts on the alarms whiteboard: Started once, Gap per writer's sequence",
    section="11.7",
    requirements=("OA-XSTREAM-6", "OA-XSTREAM-7", "OA-XSTREAM-8"),
    needs=_TYPED,
    allowed=(
        "AIR.Stream.Alarm.Started for the first sample; AIR.Stream.Alarm.Gap with writer, "
        "expected 3, received 4 and expected 6, received 5 for writer W; none for writer V; "
        "all from the stream, on WB2 (its alarms whiteboard), retrievable; every sample added",
    ),
)
async def started_and_gaps(ctx: CaseContext) -> None:
    """Create a typed stream with `alarms="WB2"`; writer W adds seq 1, 2, 4, writer V seq 1,
    W seq 5 and 5 again. Then retrieve the stream's alarms from WB2.

    Catches: Gap missing, Gap across writers, the gapped sample refused, alarms on the wrong
    whiteboard or not stored, entries missing.
    """
    raw = await ctx.raw("Creator")
    name = ctx.name("Alarmed")
    watch = await AlarmWatch.open(ctx, name, "WB2")
    await create_stream(ctx, raw, "Alarmed", type=ctx.type("Alarmed"), idle=0, alarms="WB2")
    w = await StreamClient.open(ctx, name, "W")
    v = await StreamClient.open(ctx, name, "V")
    await _add_seq(w, 1)
    started = await watch.next("Started")
    ctx.check(bool(started), "Started has no entries", expected="OA-XSTREAM-7")
    for client, seq in ((w, 2), (w, 4), (v, 1), (w, 5), (w, 5)):
        await _add_seq(client, seq)
    gaps = [await watch.next("Gap"), await watch.next("Gap")]
    found = [(g.get("writer"), g.get("expected"), g.get("received")) for g in gaps]
    ctx.check(
        found == [(w.sender, "3", "4"), (w.sender, "6", "5")],
        f"the Gap alarms have (writer, expected, received) {found}",
        expected=f"{[(w.sender, '3', '4'), (w.sender, '6', '5')]} (OA-XSTREAM-8)",
    )
    count = await w.number("GET_COUNT", "COUNT", req="OA-XSTREAM-8")
    ctx.check(count == 6, f"the stream holds {count} samples", expected="6: gaps are added too")
    stored = await watch.stored_kinds()
    ctx.check(
        stored == ["Started", "Gap", "Gap"] and watch.kinds_seen() == stored,
        f"WB2 stores the alarms {stored}; the watcher was woken by {watch.kinds_seen()}",
        expected="Started, Gap, Gap stored on the alarms whiteboard (OA-XSTREAM-6)",
    )


@case(
    id="XSTREAM-010",
    title="Idle comes idle ms after the last sample, and the next sample is Started again",
    section="11.7",
    requirements=("OA-XSTREAM-7", "OA-XSTREAM-6"),
    needs=_TYPED,
    allowed=(
        "AIR.Stream.Alarm.Idle (entry idle 300) no sooner than 300 ms after the sample was "
        "sent and within the deadline after 400 ms, its time entry 300 ms or more after the "
        "Started alarm's; then Started for the next sample",
    ),
)
async def idle_alarm(ctx: CaseContext) -> None:
    """Create a typed stream with `idle="300"`; add a sample (Started); time the Idle alarm
    from the moment the sample was sent; add another sample (Started again, then Idle again).

    Catches: Idle never posted, posted too early, or Started not repeated after an Idle.
    """
    raw = await ctx.raw("Creator")
    name = ctx.name("Idle")
    watch = await AlarmWatch.open(ctx, name)
    await create_stream(ctx, raw, "Idle", type=ctx.type("Idle"), idle=300)
    client = await StreamClient.open(ctx, name)
    sent = time.monotonic()
    await _add_seq(client, 1)
    started = await watch.next("Started")
    entries = await watch.next("Idle", timeout=ctx.deadline + 0.4)
    elapsed = time.monotonic() - sent
    ctx.check(
        elapsed >= 0.3 and entries.get("idle") == "300",
        f"Idle came {elapsed * 1000:.0f} ms after the sample with the entries {entries}",
        expected="not before 300 ms, with the entry idle = 300 (OA-XSTREAM-7)",
    )
    # Both times are ms since the epoch on the server's clock (OA-XSTREAM-6): Idle's is 300 ms
    # or more after Started's, and not much later than the case waited for it.
    gap_ms = int(entries["time"]) - int(started["time"])
    ctx.check(
        300 <= gap_ms <= (elapsed + ctx.deadline) * 1000,
        f"the Idle alarm's time is {gap_ms} ms after the Started alarm's ({started['time']})",
        expected="300 ms or more, and within the time the case waited: both in ms since the "
        "epoch (OA-XSTREAM-6)",
    )
    await _add_seq(client, 2)
    await watch.next("Started")
    # The second Idle ends the stream's alarms: none is left to surprise later cases.
    await watch.next("Idle", timeout=ctx.deadline + 0.4)
    ctx.check(
        watch.kinds_seen() == ["Started", "Idle", "Started", "Idle"],
        f"the alarms came in the order {watch.kinds_seen()}",
        expected="Started, Idle, Started, Idle (OA-XSTREAM-7)",
    )
