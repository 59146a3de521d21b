"""Mutants of issue #15: one-line faults a new implementer writes, which the suite once passed.

Each is a fault of the reference server at a boundary the old examples never touched: the
count of delivery retries (OA-DELIV-7, OA-DELIV-15), a time window measured from the newest
message rather than from "now" (OA-RET-5), slots of the stored copy that are rare on the wire
(OA-WB-4), letter case in ids (OA-RET-3), fractional priorities and deep queues (section 10),
and commands every component must answer (OA-SESS-10, OA-KEEP-2).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap, wrap_select

from openair.protocol.content import RetrieveSpec
from openair.protocol.message import Message
from openair.server.aio.dispatcher import Dispatcher
from openair.server.core import commands, whiteboard
from openair.server.core.queues import QueueItem
from openair.server.core.router import Outcome, Router
from openair.server.core.whiteboard import Whiteboard

# --- retries of a failed delivery (6.6) ---


def _retries(mp: pytest.MonkeyPatch, change: int) -> None:
    """Retry `change` more (or fewer) times than the server advertises."""

    def make(original: Fn) -> Fn:
        def init(self: Dispatcher, *args: Any, **kwargs: Any) -> None:
            original(self, *args, **kwargs)
            self.options = replace(self.options, retries=self.options.retries + change)

        return init

    wrap(mp, Dispatcher, "__init__", make)


@mutant(
    "retry-never",
    "a delivery whose connection closes unanswered is abandoned at once (no retry)",
    "OA-DELIV-7",
    "OA-DELIV-15",
)
def _retry_never(mp: pytest.MonkeyPatch) -> None:
    _retries(mp, -2)


@mutant(
    "retry-one-short",
    "a failed delivery is retried once, though delivery-retries 2 is advertised",
    "OA-DELIV-7",
    "OA-DELIV-15",
)
def _retry_one_short(mp: pytest.MonkeyPatch) -> None:
    _retries(mp, -1)


@mutant(
    "retry-one-more",
    "a failed delivery is retried three times, though delivery-retries 2 is advertised",
    "OA-DELIV-7",
    "OA-DELIV-15",
)
def _retry_one_more(mp: pytest.MonkeyPatch) -> None:
    _retries(mp, 1)


@mutant(
    "retries-fixed",
    "failed deliveries are retried twice whatever delivery-retries the server advertises",
    "OA-DELIV-15",
    limits={"delivery_retries": 1, "retry_deadline_ms": 200},
)
def _retries_fixed(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def init(self: Dispatcher, *args: Any, **kwargs: Any) -> None:
            original(self, *args, **kwargs)
            self.options = replace(self.options, retries=2)

        return init

    wrap(mp, Dispatcher, "__init__", make)


@mutant(
    "queue-ring-8192",
    "a module's queue is a ring of 8192 whatever max-queue says (fine until the default 10 000)",
    "OA-DELIV-8",
    cases=("DELIV-014",),
)
def _queue_ring_8192(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def init(self: Dispatcher, *args: Any, **kwargs: Any) -> None:
            original(self, *args, **kwargs)
            self.capacity = min(self.capacity, 8192)

        return init

    wrap(mp, Dispatcher, "__init__", make)


# --- time windows (9.2) ---


@mutant(
    "lastmsec-from-newest",
    "lastmsec counts back from the newest stored message, not from the whiteboard's now",
    "OA-RET-5",
)
def _lastmsec_from_newest(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def select(messages: Any, spec: Any, *, now_ns: int, **kwargs: Any) -> Any:
            newest = messages[-1].received if messages else None
            newest_ns = newest.ms * 1_000_000 if newest is not None else now_ns
            return original(messages, spec, now_ns=newest_ns, **kwargs)

        return select

    wrap_select(mp, make)


@mutant(
    "until-ignored",
    "untilTime is read but never applied (unnoticed while every receivedTime is equal)",
    "OA-RET-9",
)
def _until_ignored(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def select(messages: Any, spec: RetrieveSpec, **kwargs: Any) -> Any:
            return original(messages, replace(spec, until_time=None), **kwargs)

        return select

    wrap_select(mp, make)


# --- slots of the stored copy that are rare on the wire (7.4) ---


def _stored_message_patch(mp: pytest.MonkeyPatch, change: Callable[[Message], Message]) -> None:
    """Let `change` rewrite the posted message as `Whiteboard.store_post` derives its copy."""

    def make(original: Fn) -> Fn:
        def derive(msg: Message, **changes: Any) -> Message:
            if "wbid" in changes:  # only store_post derives with a wbid
                msg = change(msg)
            result: Message = original(msg, **changes)
            return result

        return derive

    wrap(mp, whiteboard, "derive", make)


@mutant("content-trimmed", "the stored copy's content is stripped of its edge spaces", "OA-WB-4")
def _content_trimmed(mp: pytest.MonkeyPatch) -> None:
    _stored_message_patch(mp, lambda m: replace(m, content=m.content.strip()))


@mutant("timetolive-dropped", "the stored copy loses timetolive", "OA-WB-4", "OA-MSG-7")
def _timetolive_dropped(mp: pytest.MonkeyPatch) -> None:
    _stored_message_patch(mp, lambda m: replace(m, timetolive=None))


@mutant("language-folded", "the stored copy's language is lower-cased", "OA-WB-4")
def _language_folded(mp: pytest.MonkeyPatch) -> None:
    _stored_message_patch(mp, lambda m: replace(m, language=m.language.lower()))


@mutant(
    "received-from-posted",
    "a post's receivedTime is its postedTime when it has one (a far client clock wins)",
    "OA-WB-4",
    "OA-TIME-4",
)
def _received_from_posted(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def store_post(self: Whiteboard, msg: Message, received_ns: int) -> Message:
            posted = msg.posted.ms * 1_000_000 if msg.posted is not None else received_ns
            result: Message = original(self, msg, posted)
            return result

        return store_post

    wrap(mp, Whiteboard, "store_post", make)


# --- letter case in ids (9.2) ---


@mutant("id-case-insensitive", "a retrieve's id matches in any letter case", "OA-RET-3")
def _id_case_insensitive(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def criteria(spec: RetrieveSpec) -> Callable[[Message], bool]:
            if not spec.id:
                result: Callable[[Message], bool] = original(spec)
                return result
            rest = original(replace(spec, id=""))
            wanted = spec.id.casefold()
            return lambda m: m.id.casefold() == wanted and rest(m)

        return criteria

    wrap(mp, whiteboard, "_criteria", make)


# --- deep queues and fractional priorities (10) ---


@mutant(
    "priority-truncated",
    "the queue orders by the integer part of the priority (1.75 and 1.1 tie, FIFO)",
    "OA-PRIO-1",
)
def _priority_truncated(mp: pytest.MonkeyPatch) -> None:
    def order(self: QueueItem) -> tuple[float, float, int]:
        return (float(math.floor(self.priority)), self.wb_priority, self.seq)

    mp.setattr(QueueItem, "order", property(order))


# --- commands every component answers (6.7) ---


@mutant(
    "keepalive-only-cns",
    "KEEPALIVE to a component other than CNS is answered RECEIVE_ACCEPT",
    "OA-KEEP-2",
)
def _keepalive_only_cns(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def session_reply(self: Router, msg: Message, sender: str, now_ns: int) -> Outcome:
            if msg.type == "KEEPALIVE" and msg.to not in ("", "CNS"):
                reply = commands.reply(msg, "RECEIVE_ACCEPT", sender=sender, now_ns=now_ns)
                return Outcome(replies=(reply,))
            result: Outcome = original(self, msg, sender, now_ns)
            return result

        return session_reply

    wrap(mp, Router, "_session_reply", make)
