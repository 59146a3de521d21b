"""Mutants of issue #15 that the mutation campaign made survive in the streams module
(`openair.server.core.streams`).

Each was a one-line change the suite once passed with every case green, and a fault a third-party
implementer could make: a binary search over rising timestamps that answers the sample after
the time, a stream that takes its timestamps for ordered again once a drop took the sample
before a falling one (OA-STREAM-6), soft enforcement that never goes below two samples
(OA-XSTREAM-2), a lock that also covers the samples added after it, a `locked` count of
GET_INFO that stays 0 (OA-XSTREAM-5, OA-STREAM-6) and a payload search over the whole stored
chunk (OA-XSTREAM-11). The shared stream of the core cases never has rising timestamps, and no
case locked a range past the newest sample, stopped soft enforcement at one sample or searched
for bytes of the parameters. The cases that now catch them are XSTREAM-030 to XSTREAM-033
(cases/streams_ring.py).
"""

from __future__ import annotations

from bisect import bisect_right
from dataclasses import replace
from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.protocol.datasample import DataSample
from openair.server.core import streams
from openair.server.core.streams import Stream
from openair.server.core.streamspec import StoredSample


@mutant(
    "stream-time-after",
    "while a stream's timestamps rise, GET_SAMPLE_BY_TIME answers the first sample after the "
    "time instead of the last one at or before it",
    "OA-STREAM-6",
)
def _time_after(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def at_or_before(self: Stream, ms: int) -> StoredSample | None:
            if not self._ordered():
                result: StoredSample | None = original(self, ms)
                return result
            items = self._items
            i = bisect_right(items, ms, key=lambda st: st.timestamp_ms)
            return items[i] if i < len(items) else None

        return at_or_before

    wrap(mp, Stream, "at_or_before", make)


@mutant(
    "stream-order-stale-after-drop",
    "dropping the oldest sample forgets a falling timestamp whenever the next one differs, so "
    "the stream bisects over timestamps that are not in order",
    "OA-STREAM-6",
    "OA-STREAM-9",
)
def _order_stale_after_drop(mp: pytest.MonkeyPatch) -> None:
    def _popleft(self: Stream) -> None:
        items = self._items
        st = items.popleft()
        self.size -= st.size
        if items and st.timestamp_ms != items[0].timestamp_ms:
            self._descents -= 1

    mp.setattr(Stream, "_popleft", _popleft)


@mutant(
    "stream-soft-keeps-two",
    "soft enforcement stops at two samples: a stream with softcount 1 keeps two",
    "OA-XSTREAM-2",
)
def _soft_keeps_two(mp: pytest.MonkeyPatch) -> None:
    def _enforce_soft(self: Stream) -> int:
        items = self._items
        size_limit, count_limit = self.spec.soft_size, self.spec.soft_count
        dropped = 0
        while len(items) > 2 and self._over(size_limit, count_limit):
            if self._locks and self.is_locked(items[0].id):
                return dropped + self._drop_unlocked_inside(size_limit, count_limit)
            self._popleft()
            dropped += 1
        return dropped

    mp.setattr(Stream, "_enforce_soft", _enforce_soft)


@mutant(
    "stream-lock-covers-later",
    "a lock covers its whole range, so samples added after it whose ids fall in the range are "
    "locked too",
    "OA-XSTREAM-5",
    "OA-XSTREAM-2",
)
def _lock_covers_later(mp: pytest.MonkeyPatch) -> None:
    def lock(self: Stream, first: int, last: int, owner: int) -> int:
        lock_id = self._next_lock
        self._next_lock += 1
        self._locks.append(streams._Lock(lock_id, owner, first, last))
        return lock_id

    mp.setattr(Stream, "lock", lock)


@mutant(
    "stream-info-locked-zero",
    "GET_INFO's `locked` is always 0, whatever the locks cover",
    "OA-STREAM-6",
    "OA-XSTREAM-5",
)
def _info_locked_zero(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(Stream, "locked", property(lambda self: 0))


@mutant(
    "payload-search-chunk",
    "SEARCH_SAMPLES <payload> scans the whole stored chunk: the parameter string and the NUL "
    "after the payload too",
    "OA-XSTREAM-11",
)
def _payload_search_chunk(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _prepare(self: Stream, *args: Any) -> list[StoredSample]:
            out: list[StoredSample] = original(self, *args)
            return [
                replace(
                    st,
                    sample=DataSample(
                        payload=memoryview(st.wire)[len(st.parts[0]) :], params=st.sample.params
                    ),
                )
                for st in out
            ]

        return _prepare

    wrap(mp, Stream, "_prepare", make)
