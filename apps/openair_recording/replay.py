"""Replay a recording into a server: messages re-posted, samples re-added, original spacing.

The plan is pure: `plan()` filters the records (time window, type pattern), puts them in replay
order and gives each the delay to wait before it; `Replayer` sends them, sleeping with the
injected `sleep` (tests pass a fake one and inspect the delays).

Replay order: the records of one whiteboard in `wbid` order and of one stream in sample-id order
(exact), the lanes merged by their time (the whiteboard's receivedTime, the stream's timestamp),
ties in file order. A re-posted message gets a new id and postedTime; its original postedTime is
kept in the unknown slot `originalPostedTime`, which the whiteboard keeps with the stored copy
(OA-MSG-5, OA-WB-4). A re-added sample gets a new id and timestamp; its original timestamp is
the parameter `originalTimestamp`.
"""

from __future__ import annotations

import asyncio
import heapq
from collections.abc import Awaitable, Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace

from openair.client.module import FailedReplyError, Module
from openair.protocol.datasample import BUILTIN_ID, BUILTIN_SEQ, BUILTIN_TIMESTAMP, DataSample
from openair.protocol.errors import OpenAIRError
from openair.protocol.matching import matches
from openair.protocol.message import Message, new_id
from openair_recording.fileformat import Header, MessageRecord, Record, SampleRecord

__all__ = [
    "ORIGINAL_POSTED_SLOT",
    "ORIGINAL_TIMESTAMP_PARAM",
    "ReplayOptions",
    "Replayer",
    "Step",
    "plan",
    "replay_message",
    "replay_sample",
]

ORIGINAL_POSTED_SLOT = "originalPostedTime"
ORIGINAL_TIMESTAMP_PARAM = "originalTimestamp"
_STREAM_CREATE = "Psyclone.System.Create.Stream"  # OA-XSTREAM-10


@dataclass(frozen=True, slots=True, kw_only=True)
class ReplayOptions:
    """Speed (0: no waiting), window in µs since the epoch (inclusive), and a type pattern."""

    speed: float = 1.0
    from_us: int | None = None
    until_us: int | None = None
    types: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class Step:
    """One record to send after waiting `delay` seconds (from the previous step)."""

    delay: float
    record: Record


def _lane(record: Record) -> tuple[str, str]:
    if isinstance(record, MessageRecord):
        return "wb", record.message.stored
    return "stream", record.stream


def _seq(record: Record, position: int) -> int:
    if isinstance(record, MessageRecord):
        wbid = record.message.wbid
        return wbid if wbid is not None else position
    ident = record.sample.id
    return ident if ident is not None else position


def replay_order(records: Sequence[Record]) -> list[Record]:
    """Order records: each lane by its sequence number, lanes merged by time then file order."""
    lanes: dict[tuple[str, str], list[tuple[int, int, Record]]] = {}
    for position, record in enumerate(records):
        lanes.setdefault(_lane(record), []).append((_seq(record, position), position, record))
    streams = []
    for items in lanes.values():
        items.sort(key=lambda item: (item[0], item[1]))
        streams.append([(r.time_us, pos, r) for _, pos, r in items])
    return [r for _, _, r in heapq.merge(*streams, key=lambda item: (item[0], item[1]))]


def _selected(record: Record, options: ReplayOptions) -> bool:
    t = record.time_us
    if options.from_us is not None and t < options.from_us:
        return False
    if options.until_us is not None and t > options.until_us:
        return False
    if options.types and isinstance(record, MessageRecord):
        return matches(options.types, record.message.type)  # the trigger matcher (OA-MATCH-8)
    return True


def plan(records: Iterable[Record], options: ReplayOptions) -> list[Step]:
    """Return the steps of a replay: the selected records in order, each with its delay.

    The delay is the time since the previous selected record divided by `speed` (0 when
    `speed` is 0, and never negative: a clock that went back does not stall the replay).
    """
    chosen = [r for r in replay_order(list(records)) if _selected(r, options)]
    steps: list[Step] = []
    previous: int | None = None
    for record in chosen:
        gap = 0 if previous is None else max(0, record.time_us - previous)
        delay = gap / 1e6 / options.speed if options.speed > 0 else 0.0
        steps.append(Step(delay=delay, record=record))
        previous = record.time_us
    return steps


def replay_message(msg: Message) -> Message:
    """Return the post that replays a stored copy: same slots, new id, original time kept."""
    extras = tuple(s for s in msg.extras if s.name.casefold() != ORIGINAL_POSTED_SLOT.casefold())
    post = replace(
        msg, id=new_id(), to=msg.stored or msg.to, stored="", received=None, posted=None,
        wbid=None, isresponse="", extras=extras, noreply=False,
    )  # fmt: skip
    if msg.posted is not None:
        post = post.with_extra(ORIGINAL_POSTED_SLOT, str(msg.posted))  # OA-MSG-5, OA-WB-4
    return post


def replay_sample(sample: DataSample) -> DataSample:
    """Return the sample to re-add: the stream stamps id and time; the original time is kept."""
    drop = {BUILTIN_ID, BUILTIN_TIMESTAMP, BUILTIN_SEQ}
    params = [(k, v) for k, v in sample.params if k not in drop and k != ORIGINAL_TIMESTAMP_PARAM]
    if (ts := sample.timestamp_ms) is not None:
        params.append((ORIGINAL_TIMESTAMP_PARAM, str(ts)))
    return DataSample(payload=bytes(sample.payload), params=tuple(params))


@dataclass(slots=True)
class Replayer:
    """Send the steps of a plan to a connected module; count what was sent and skipped."""

    module: Module
    header: Header
    sleep: Callable[[float], Awaitable[None]] = asyncio.sleep
    posted: int = 0
    added: int = 0
    notes: list[str] = field(default_factory=list)
    _streams: dict[str, bool] = field(default_factory=dict)  # stream name -> usable

    async def prepare_streams(self, names: Iterable[str]) -> None:
        """Find the recorded streams on the server, creating missing ones (OA-XSTREAM-10)."""
        wanted = sorted(set(names))
        if not wanted:
            return
        try:
            present = {i.name for i in await self.module.list_streams()}
        except OpenAIRError as exc:
            present = set()
            self.notes.append(f"GET_STREAMS failed ({exc})")
        caps = self.module.capabilities  # what the server advertises (OA-CAP-1)
        can_create = caps is not None and "typed-streams" in caps.extensions
        for name in wanted:
            if name in present:
                self._streams[name] = True
            elif not can_create:
                self._streams[name] = False
                self.notes.append(
                    f"stream {name!r}: not on the server, which cannot create streams "
                    "(no typed-streams, OA-XSTREAM-10): its samples are skipped"
                )
            else:
                self._streams[name] = await self._create(name)

    async def _create(self, name: str) -> bool:
        spec = next((s for s in self.header.streams if s.get("name") == name), {"name": name})
        attrs = {k: spec.get(k, "") for k in ("name", "whiteboard", "type", "maxsize")}
        attrs["maxsize"] = _mib(attrs["maxsize"])
        if not attrs["whiteboard"]:
            attrs["whiteboard"] = self.header.whiteboards[0] if self.header.whiteboards else "WB1"
        content = (
            "<stream "
            + " ".join(f'{k}="{_attr(v)}"' for k, v in attrs.items() if v and v != "0")
            + "/>"
        )
        msg = Message(
            type=_STREAM_CREATE, sender=self.module.name, to="Psyclone", content=content,
            content_is_xml=True, language="xml",
        )  # fmt: skip
        reply = await self.module.request(msg)
        if reply.type == "RECEIVE_ACCEPT":
            self.notes.append(f"stream {name!r}: created on the server")
            return True
        self.notes.append(f"stream {name!r}: could not be created ({reply.content}): skipped")
        return False

    async def run(self, steps: Sequence[Step]) -> None:
        """Send every step after its delay, in order."""
        await self.prepare_streams(
            s.record.stream for s in steps if isinstance(s.record, SampleRecord)
        )
        for step in steps:
            if step.delay > 0:
                await self.sleep(step.delay)
            if isinstance(step.record, MessageRecord):
                await self._post(step.record.message)
            elif self._streams.get(step.record.stream):
                await self._add(step.record)

    async def _post(self, msg: Message) -> None:
        post = replay_message(msg)
        try:
            reply = await self.module.request(post)
        except OpenAIRError as exc:
            self.notes.append(f"{msg.type} to {post.to}: not posted ({exc})")
            return
        if reply.type != "RECEIVE_ACCEPT":
            self.notes.append(f"{msg.type} to {post.to}: {FailedReplyError(post, reply)}")
            return
        self.posted += 1

    async def _add(self, record: SampleRecord) -> None:
        stream = self.module.stream(record.stream)
        await stream.add(replay_sample(record.sample))
        self.added += 1


def _attr(value: str) -> str:
    return value.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")


def _mib(maxsize_bytes: str) -> str:
    """Turn the byte size GET_STREAMS reported into the MiB units of `<stream maxsize>`.

    GET_STREAMS and `<streaminfo>` give sizes in bytes; run-time creation reads `maxsize` in units
    of 1 048 576 bytes (OA-STREAM-9), so a recorded 10485760 is created as maxsize="10".
    """
    try:
        size = int(maxsize_bytes)
    except ValueError:
        return ""
    if size <= 0:
        return ""
    return f"{size / 1_048_576:.6f}".rstrip("0").rstrip(".")
