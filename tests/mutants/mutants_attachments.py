"""Mutants of issue #21: attachments, the content version, bare stream registrations, `qos`
(timetolive and alarm triggers) and the bounded payload search (spec 1.0-draft.6).

Each is a one-line fault in the reference server: a helper the router, the whiteboard, the
retrieve module or the streams use is replaced for the duration of the block.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.protocol import registration
from openair.protocol.message import Message
from openair.server.aio import delivery
from openair.server.core import retrieve, router, router_routes, streams, whiteboard
from openair.server.core.queues import QueueItem


@mutant(
    "wakeup-without-attachments",
    "wakeups carry the nested copies' binarysizes but not the chunks",
    "OA-WAKE-10",
)
def _wakeup_without_attachments(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(router_routes, "attach_wakeup", lambda wakeup, *rest: wakeup)


@mutant(
    "retrieve-without-attachments",
    "retrieve replies carry no chunks",
    "OA-RET-19",
)
def _retrieve_without_attachments(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(retrieve, "chunks_of", lambda messages: ())


@mutant(
    "retrieve-attachments-reversed",
    "retrieve replies lay the results' chunks out oldest result first",
    "OA-RET-19",
)
def _retrieve_attachments_reversed(mp: pytest.MonkeyPatch) -> None:
    def reversed_chunks(messages: Sequence[Message]) -> tuple[bytes, ...]:
        return tuple(chunk for msg in reversed(messages) for chunk in msg.binary)

    mp.setattr(retrieve, "chunks_of", reversed_chunks)


def _stored_copy(mp: pytest.MonkeyPatch, **lost: Any) -> None:
    """Make `Whiteboard.store_post` lose the given fields of the stored copy."""

    def make(original: Fn) -> Fn:
        def derive(msg: Message, **changes: Any) -> Message:
            if "wbid" in changes:  # only store_post derives with a wbid
                changes.update(lost)
            result: Message = original(msg, **changes)
            return result

        return derive

    wrap(mp, whiteboard, "derive", make)


@mutant("store-drops-attachments", "the stored copy loses the post's chunks", "OA-WB-13")
def _store_drops_attachments(mp: pytest.MonkeyPatch) -> None:
    _stored_copy(mp, binary=())


@mutant("content-version-dropped", "the stored copy loses the content's version", "OA-MSG-22")
def _content_version_dropped(mp: pytest.MonkeyPatch) -> None:
    _stored_copy(mp, content_version="")


@mutant("ttl-ignored", "timetolive never expires a delivery", "OA-DELIV-14")
def _ttl_ignored(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(router.Router, "_expiry", lambda self, msg, received_ns: 0)


@mutant("ttl-uncounted", "expired deliveries are dropped but not counted in STATUS", "OA-DELIV-14")
def _ttl_uncounted(mp: pytest.MonkeyPatch) -> None:
    def expire(self: delivery.ModuleDelivery, item: QueueItem) -> None:
        self.counters.expired += 1  # the module's figure only: Deliveries.Expired stays 0

    mp.setattr(delivery.ModuleDelivery, "_expire_unsent", expire)


@mutant("alarm-trigger-ignored", "maxpriority is read but every priority fires", "OA-TRIG-5")
def _alarm_trigger_ignored(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(router_routes, "urgent_enough", lambda triggers, i, stored: True)


@mutant("bare-streams-refused", "stream elements outside <module> are refused", "OA-REG-16")
def _bare_streams_refused(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(registration, "_FORM5_STREAMS", frozenset())


@mutant("payload-search-unbounded", "the payload search ignores the scan limit", "OA-XSTREAM-11")
def _payload_search_unbounded(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(streams, "_find", lambda data, pattern, limit: bytes(data).find(pattern))


@mutant("payload-search-ignored", "SEARCH_SAMPLES ignores <payload>", "OA-XSTREAM-11")
def _payload_search_ignored(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(streams, "_find", lambda data, pattern, limit: 0)


@mutant(
    "wakeup-attachments-unbounded",
    "a wakeup keeps every retrieved message, whatever its chunks add up to",
    "OA-WAKE-11",
    limits={"max_frame_binary": 4096},
    cases=("ATT-005",),
)
def _wakeup_attachments_unbounded(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(router_routes, "fit_attachments", lambda stored, retrieved, limit: (retrieved, 0))
