"""Streams: ring buffers of data samples with limits, locks, search and alarms (spec 11).

Sans-I/O: no sockets and no clock; every time comes in as an argument (`received_ns`,
`now_ns`, nanoseconds since the epoch). The router owns the streams, replies, pushes the
samples that `Stream.add` stored and posts the `Alarm` values it returns.

A stream holds its samples in a deque in id order. Ids only grow, so by-id lookups bisect on
ids, and are O(1) while the held ids are contiguous (always, except when soft enforcement
dropped an unlocked sample from behind a locked one). Timestamps come from writers and may go
backwards; the stream counts the adjacent pairs that are out of order and bisects on
timestamps while there are none, falling back to a linear scan otherwise. Payloads are never
copied: a stored sample keeps the memoryview its chunk was decoded into.
"""

from __future__ import annotations

import math
from bisect import bisect_left, bisect_right
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from itertools import islice

from openair.protocol.datasample import BUILTIN_ID, BUILTIN_TIMESTAMP, DataSample, chunk_parts
from openair.protocol.errors import (
    SampleInvalidError,
)
from openair.server.core.streamspec import (
    AddResult,
    Alarm,
    StoredSample,
    StreamSpec,
)
from openair.server.core.whiteboard import content_glob

__all__ = ["Stream"]

_NS_PER_MS = 1_000_000
# Larger writer timestamps are treated as absent: no implementation could hold them as int64 ms.
_MAX_TIMESTAMP_MS = 2**63 - 1

SCAN_LIMIT = 65_536  # OA-XSTREAM-11: payload bytes a SEARCH_SAMPLES <payload> looks at


@dataclass(frozen=True, slots=True)
class _Lock:
    lock_id: int
    owner: int
    first: int
    last: int  # clipped to the newest id held when locked: later samples are not locked


def _sample_id(s: StoredSample) -> int:
    return s.id


def _sample_ts(s: StoredSample) -> int:
    return s.timestamp_ms


class Stream:
    """One stream: samples, limits, locks, lookups and alarm decisions (spec 11, STREAMS.md)."""

    def __init__(self, spec: StreamSpec) -> None:
        self.spec = spec
        self._items: deque[StoredSample] = deque()
        self.size = 0
        self.added_total = 0
        self.dropped_total = 0
        self.last_add_ns: int | None = None
        self.writers: set[str] = set()
        self._next_id = 1
        self._descents = 0  # adjacent held pairs whose timestamps go backwards
        self._locks: list[_Lock] = []
        self._next_lock = 1
        self._writer_seq: dict[str, int] = {}
        self._soft_dropping = False  # the previous add's soft enforcement dropped samples
        self._started = False
        self._idle = False  # an Idle alarm went out and no sample came since

    def __repr__(self) -> str:
        return f"<Stream {self.name!r} count={self.count} size={self.size}>"

    @property
    def name(self) -> str:
        """Return the stream's name."""
        return self.spec.name

    @property
    def count(self) -> int:
        """Return the number of samples held."""
        return len(self._items)

    # -- adding ---------------------------------------------------------------------------

    def add(self, samples: Sequence[DataSample], *, writer: str, received_ns: int) -> AddResult:
        """Add `samples` (all or none) and apply the limits; return what was stored and raised.

        Raises SampleInvalidError, before changing anything, when a payload alone exceeds
        the hard size limit (OA-STREAM-13, OA-XSTREAM-4).
        """
        if not samples:
            return AddResult(stored=())
        stored = self._prepare(samples, received_ns)
        typed = self.spec.typed
        now_ms = received_ns // _NS_PER_MS
        alarms: list[Alarm] = []
        if not self._started or self._idle:  # OA-XSTREAM-7
            self._started, self._idle = True, False
            if typed:
                alarms.append(self._alarm("Started", now_ms))
        for st in stored:
            self._append(st)
            if typed:
                gap = self._check_seq(writer, st, now_ms)
                if gap is not None:
                    alarms.append(gap)
        self.writers.add(writer)
        self.added_total += len(stored)
        self.last_add_ns = received_ns
        soft = self._enforce_soft() if typed else 0
        hard = self._enforce_hard()
        if typed:
            alarms.extend(self._limit_alarms(soft, hard, now_ms))
        self.dropped_total += soft + hard
        return AddResult(stored=tuple(stored), alarms=tuple(alarms), dropped=soft + hard)

    def _prepare(self, samples: Sequence[DataSample], received_ns: int) -> list[StoredSample]:
        """Return the samples as they will be stored; raise before any state changes."""
        hardsize = self.spec.hardsize
        for i, s in enumerate(samples):
            if len(s.payload) > hardsize:  # OA-STREAM-13, OA-XSTREAM-4
                raise SampleInvalidError(
                    f"sample {i + 1} of {len(samples)}: payload of {len(s.payload)} bytes"
                    f" exceeds the stream's limit of {hardsize} bytes"
                )
        now_ms = received_ns // _NS_PER_MS
        out: list[StoredSample] = []
        ident = self._next_id
        for s in samples:
            ts = s.timestamp_ms
            if ts is None or not 0 <= ts <= _MAX_TIMESTAMP_MS:  # OA-STREAM-4
                ts = now_ms
            # OA-STREAM-4: the writer's builtin:id is replaced by the stream's.
            kept = s.with_params({BUILTIN_ID: str(ident), BUILTIN_TIMESTAMP: str(ts)})
            head, _, tail = chunk_parts(kept)
            size = len(s.payload)
            # One copy per sample, here; the writer's frame buffer is released with it.
            wire = b"".join((head, kept.payload, tail))
            payload = memoryview(wire)[len(head) : len(head) + size]
            kept = DataSample(payload=payload, params=kept.params)
            parts = (head, payload, tail)
            out.append(
                StoredSample(
                    id=ident,
                    timestamp_ms=ts,
                    received_ns=received_ns,
                    sample=kept,
                    size=size,
                    parts=parts,
                    wire=wire,
                )
            )
            ident += 1
        self._next_id = ident
        return out

    def _append(self, st: StoredSample) -> None:
        items = self._items
        if items and items[-1].timestamp_ms > st.timestamp_ms:
            self._descents += 1
        items.append(st)
        self.size += st.size

    def _popleft(self) -> None:
        items = self._items
        st = items.popleft()
        self.size -= st.size
        if items and st.timestamp_ms > items[0].timestamp_ms:
            self._descents -= 1

    def _remove_at(self, i: int) -> None:
        """Remove the sample at index `i` >= 1, keeping the timestamp order count right."""
        items = self._items
        prev, st = items[i - 1], items[i]
        nxt = items[i + 1] if i + 1 < len(items) else None
        self._descents -= prev.timestamp_ms > st.timestamp_ms
        if nxt is not None:
            self._descents -= st.timestamp_ms > nxt.timestamp_ms
            self._descents += prev.timestamp_ms > nxt.timestamp_ms
        del items[i]
        self.size -= st.size

    def _over(self, size_limit: int, count_limit: int) -> bool:
        return self.size > size_limit or (count_limit > 0 and len(self._items) > count_limit)

    def _enforce_soft(self) -> int:
        """Drop the oldest unlocked samples until the soft limits hold (OA-XSTREAM-2).

        The newest sample is never a candidate: otherwise, with every older sample locked, a
        new sample would be dropped on arrival and the hard limit could never take over
        (OA-XSTREAM-3).
        """
        size_limit, count_limit = self.spec.soft_size, self.spec.soft_count
        items = self._items
        dropped = 0
        while len(items) > 1 and self._over(size_limit, count_limit):
            if self._locks and self.is_locked(items[0].id):
                return dropped + self._drop_unlocked_inside(size_limit, count_limit)
            self._popleft()
            dropped += 1
        return dropped

    def _drop_unlocked_inside(self, size_limit: int, count_limit: int) -> int:
        """Drop the oldest unlocked samples behind a locked oldest one, as few as needed."""
        items = self._items
        excess_size = self.size - size_limit
        excess_count = len(items) - count_limit if count_limit > 0 else 0
        chosen: list[int] = []
        for i, st in enumerate(islice(items, len(items) - 1)):
            if excess_size <= 0 and excess_count <= 0:
                break
            if not self.is_locked(st.id):
                chosen.append(i)
                excess_size -= st.size
                excess_count -= 1
        for i in reversed(chosen):  # from the right, so that the indexes stay valid
            self._remove_at(i)  # i >= 1: the oldest sample is locked
        return len(chosen)

    def _enforce_hard(self) -> int:
        """Drop the oldest samples, locked or not, until the hard limits hold (OA-STREAM-9,
        OA-XSTREAM-3)."""
        size_limit, count_limit = self.spec.hardsize, self.spec.hardcount
        dropped = 0
        while self._items and self._over(size_limit, count_limit):
            self._popleft()
            dropped += 1
        return dropped

    # -- alarms ---------------------------------------------------------------------------

    def _alarm(self, kind: str, time_ms: int, **extra: int | str) -> Alarm:
        spec = self.spec
        entries = (("stream", spec.name), ("streamtype", spec.type or ""), ("time", str(time_ms)))
        more = tuple((k, str(v)) for k, v in extra.items())
        return Alarm(
            kind=kind, stream=spec.name, whiteboard=spec.alarm_whiteboard, entries=entries + more
        )

    def _check_seq(self, writer: str, st: StoredSample, now_ms: int) -> Alarm | None:
        """Return a Gap alarm when `writer`'s builtin:seq does not follow its previous one."""
        seq = st.sample.seq
        if seq is None:
            return None
        previous = self._writer_seq.get(writer)
        self._writer_seq[writer] = seq
        if previous is None or seq == previous + 1:
            return None
        # OA-XSTREAM-8
        return self._alarm("Gap", now_ms, writer=writer, expected=previous + 1, received=seq)

    def _limit_alarms(self, soft: int, hard: int, now_ms: int) -> list[Alarm]:
        out: list[Alarm] = []
        if soft and not self._soft_dropping:  # OA-XSTREAM-2: once per crossing, not per add
            alarm = self._alarm("SoftLimit", now_ms, size=self.size, count=self.count, dropped=soft)
            out.append(alarm)
        self._soft_dropping = soft > 0
        if hard:  # OA-XSTREAM-3
            out.append(self._alarm("HardLimit", now_ms, dropped=hard))
        return out

    def idle_due_ns(self) -> int | None:
        """Return when the Idle alarm falls due, or None when none can (OA-XSTREAM-7)."""
        spec = self.spec
        if not spec.typed or spec.idle_ms <= 0 or self.last_add_ns is None or self._idle:
            return None
        return self.last_add_ns + spec.idle_ms * _NS_PER_MS

    def tick(self, now_ns: int) -> Alarm | None:
        """Return the Idle alarm when it is due at `now_ns`, once per idle period.

        Its `idle` entry is the stream's configured idle time in ms.
        """
        due = self.idle_due_ns()
        if due is None or now_ns < due:
            return None
        self._idle = True
        return self._alarm("Idle", now_ns // _NS_PER_MS, idle=self.spec.idle_ms)

    # -- lookups --------------------------------------------------------------------------

    def _contiguous(self) -> bool:
        items = self._items
        return items[-1].id - items[0].id == len(items) - 1

    def _ordered(self) -> bool:
        return self._descents == 0

    def newest(self) -> StoredSample | None:
        """Return the newest sample, or None."""
        return self._items[-1] if self._items else None

    def oldest(self) -> StoredSample | None:
        """Return the oldest sample, or None."""
        return self._items[0] if self._items else None

    def by_id(self, ident: int) -> StoredSample | None:
        """Return the sample with id `ident`, or None when it is not held."""
        items = self._items
        if not items or not items[0].id <= ident <= items[-1].id:
            return None
        if self._contiguous():
            return items[ident - items[0].id]
        st = items[bisect_left(items, ident, key=_sample_id)]
        return st if st.id == ident else None

    def first_after_id(self, ident: int) -> StoredSample | None:
        """Return the oldest sample whose id is greater than `ident` (WAIT_FOR_FIRST_AFTERID)."""
        items = self._items
        if not items or items[-1].id <= ident:
            return None
        if items[0].id > ident:
            return items[0]
        if self._contiguous():
            return items[ident - items[0].id + 1]
        return items[bisect_right(items, ident, key=_sample_id)]

    def last_after_id(self, ident: int) -> StoredSample | None:
        """Return the newest sample when its id is greater than `ident` (WAIT_FOR_LAST_AFTERID)."""
        items = self._items
        return items[-1] if items and items[-1].id > ident else None

    def at_or_before(self, ms: int) -> StoredSample | None:
        """Return the sample with the greatest timestamp <= `ms`, the newest on ties."""
        items = self._items
        if self._ordered():
            i = bisect_right(items, ms, key=_sample_ts) - 1
            return items[i] if i >= 0 else None
        best: StoredSample | None = None
        for st in items:
            if st.timestamp_ms <= ms and (best is None or st.timestamp_ms >= best.timestamp_ms):
                best = st
        return best

    def between(self, from_ms: int, until_ms: int) -> list[StoredSample]:
        """Return the samples with from_ms <= timestamp <= until_ms, oldest (by id) first."""
        if from_ms > until_ms:
            return []
        if self._ordered():
            return list(self._slice(*self._time_range(from_ms, until_ms)))
        return [st for st in self._items if from_ms <= st.timestamp_ms <= until_ms]

    def first_at_or_after(self, ms: int) -> StoredSample | None:
        """Return the oldest sample whose timestamp is >= `ms` (WAIT_FOR_FIRST_SAMPLE)."""
        items = self._items
        if self._ordered():
            i = bisect_left(items, ms, key=_sample_ts)
            return items[i] if i < len(items) else None
        return next((st for st in items if st.timestamp_ms >= ms), None)

    def last_at_or_after(self, ms: int) -> StoredSample | None:
        """Return the newest sample whose timestamp is >= `ms` (WAIT_FOR_LAST_SAMPLE)."""
        items = self._items
        if self._ordered():
            return items[-1] if items and items[-1].timestamp_ms >= ms else None
        return next((st for st in reversed(items) if st.timestamp_ms >= ms), None)

    def _time_range(self, from_ms: int | None, until_ms: int | None) -> tuple[int, int]:
        """Return the index range of the time bounds; only valid while timestamps are ordered."""
        items = self._items
        lo = 0 if from_ms is None else bisect_left(items, from_ms, key=_sample_ts)
        hi = len(items) if until_ms is None else bisect_right(items, until_ms, key=_sample_ts)
        return lo, max(lo, hi)

    def _slice(self, lo: int, hi: int) -> Iterator[StoredSample]:
        """Iterate over items[lo:hi], starting from the nearer end of the deque."""
        items = self._items
        n = len(items)
        if lo <= n - hi:
            return islice(items, lo, hi)
        return reversed(list(islice(reversed(items), n - hi, n - lo)))

    def search(
        self,
        *,
        after_ms: int | None = None,
        until_ms: int | None = None,
        params: Sequence[tuple[str, str]] = (),
        latest: int = 0,
        payload: bytes = b"",
        scan_limit: int = SCAN_LIMIT,
    ) -> list[StoredSample]:
        """Return the samples within the inclusive time bounds whose params match, oldest first.

        Each (key, glob) needs a parameter of that key whose value matches the retrieve
        content glob (OA-RET-8); a missing parameter does not match. `latest` > 0 keeps the newest
        `latest` of them (OA-XSTREAM-9). A non-empty `payload` also needs that byte sequence
        entirely within the first `scan_limit` bytes of the sample's payload (OA-XSTREAM-11).
        """
        matchers: list[tuple[str, Callable[[str], bool]]] = [
            (key, content_glob(glob)) for key, glob in params
        ]
        lo_ms = -math.inf if after_ms is None else after_ms
        hi_ms = math.inf if until_ms is None else until_ms
        n = len(self._items)
        lo, hi = self._time_range(after_ms, until_ms) if self._ordered() else (0, n)
        found: list[StoredSample] = []
        for st in islice(reversed(self._items), n - hi, n - lo):
            if lo_ms <= st.timestamp_ms <= hi_ms and _params_match(st.sample, matchers):
                if payload and _find(st.sample.payload, payload, scan_limit) < 0:
                    continue  # OA-XSTREAM-11: bounded by the scan limit
                found.append(st)
                if len(found) == latest:
                    break
        found.reverse()
        return found

    # -- locks ----------------------------------------------------------------------------

    def lock(self, first: int, last: int, owner: int) -> int:
        """Lock the held samples with ids first..last for `owner`; return the lock id.

        Samples added later are not locked, even when their ids fall in the range; an empty
        range still gets a lock id (OA-XSTREAM-5).
        """
        lock_id = self._next_lock
        self._next_lock += 1
        self._locks.append(_Lock(lock_id, owner, first, min(last, self._next_id - 1)))
        return lock_id

    def unlock(self, lock_id: int, owner: int) -> bool:
        """Remove lock `lock_id` of `owner`; False when unknown or another owner's."""
        for i, lk in enumerate(self._locks):
            if lk.lock_id == lock_id:
                if lk.owner != owner:
                    return False
                del self._locks[i]
                return True
        return False

    def release(self, owner: int) -> int:
        """Remove every lock of `owner` (its connection closed); return how many."""
        kept = [lk for lk in self._locks if lk.owner != owner]
        released = len(self._locks) - len(kept)
        self._locks = kept
        return released

    def is_locked(self, ident: int) -> bool:
        """Return whether a lock covers id `ident`."""
        return any(lk.first <= ident <= lk.last for lk in self._locks)

    @property
    def locked(self) -> int:
        """Return the number of held samples that a lock covers."""
        ranges = sorted((lk.first, lk.last) for lk in self._locks if lk.first <= lk.last)
        items = self._items
        total = 0
        end = -1  # ids up to `end` are counted already
        for first, last in ranges:
            first = max(first, end + 1)
            if first > last:
                continue
            total += bisect_right(items, last, key=_sample_id)
            total -= bisect_left(items, first, key=_sample_id)
            end = last
        return total

    # -- info -----------------------------------------------------------------------------

    def info(self) -> dict[str, str]:
        """Return the `<streaminfo>` attributes but `subscribers`, which the router adds."""
        spec = self.spec
        out = {"name": spec.name, "whiteboard": spec.whiteboard}
        if spec.type is not None:
            out["type"] = spec.type
        out["count"] = str(self.count)
        out["size"] = str(self.size)
        if self._items:
            out["oldest"] = str(self._items[0].id)
            out["newest"] = str(self._items[-1].id)
        out["maxsize"] = str(spec.hardsize if spec.maxsize is None else spec.maxsize)
        out["maxcount"] = str(spec.hardcount if spec.maxcount is None else spec.maxcount)
        if spec.typed:
            out["softsize"] = str(spec.soft_size)
            out["softcount"] = str(spec.soft_count)
            out["hardsize"] = str(spec.hardsize)
            out["hardcount"] = str(spec.hardcount)
        out["writers"] = str(len(self.writers))
        if spec.typed:
            out["idle"] = str(spec.idle_ms)
        out["locked"] = str(self.locked)
        return out


def _find(data: bytes | memoryview, pattern: bytes, scan_limit: int) -> int:
    """Return where `pattern` starts within the first `scan_limit` bytes of `data`, or -1."""
    return bytes(data[:scan_limit]).find(pattern)


def _params_match(sample: DataSample, matchers: list[tuple[str, Callable[[str], bool]]]) -> bool:
    """Return whether, for each matcher, the sample has a parameter of its key that matches."""
    params = sample.params
    return all(any(k == key and match(v) for k, v in params) for key, match in matchers)
