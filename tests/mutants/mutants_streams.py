"""Mutants of streams (spec section 11): the ring, ids, time lookups, waits, BinaryM, push, and
the typed-streams limits, locks and alarms.

Ring, id, lookup, lock and alarm mutants wrap methods of the sans-I/O `Stream`
(`openair.server.core.streams`); wait and BinaryM mutants wrap `StreamService`; the push mutant
replaces `push_message` where the pusher and the module delivery import it. The suite's own
chunk reader (`cases/_streams.py`) shares none of these.
"""

from __future__ import annotations

from dataclasses import fields, replace
from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.protocol.datasample import chunk_parts
from openair.protocol.message import Message
from openair.server.aio import delivery, pusher
from openair.server.core import streamservice, streamwire
from openair.server.core.samplebuffer import SampleBuffer
from openair.server.core.streams import Stream
from openair.server.core.streamservice import StreamService
from openair.server.core.streamspec import AddResult, Alarm, StoredSample

# --- the ring and its ids (11.1) -----------------------------------------------------------------


@mutant(
    "stream-ring-keeps-one-more",
    "a stream above its limits keeps one sample more than they allow",
    "OA-STREAM-9",
)
def _ring_keeps_one_more(mp: pytest.MonkeyPatch) -> None:
    def _enforce_hard(self: Stream) -> int:
        size_limit, count_limit = self.spec.hardsize, self.spec.hardcount
        dropped = 0
        while len(self._items) > 1:
            oldest = self._items[0]
            size_after, count_after = self.size - oldest.size, len(self._items) - 1
            if size_after <= size_limit and (count_limit <= 0 or count_after <= count_limit):
                break  # dropping the oldest would be enough: keep it all the same
            self._popleft()
            dropped += 1
        return dropped

    mp.setattr(Stream, "_enforce_hard", _enforce_hard)


@mutant(
    "stream-ring-drops-one-more",
    "a stream that drops samples for its limits drops one more than needed",
    "OA-STREAM-9",
)
def _ring_drops_one_more(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _enforce_hard(self: Stream) -> int:
            dropped: int = original(self)
            if dropped and len(self._items) > 1:
                self._popleft()
                dropped += 1
            return dropped

        return _enforce_hard

    wrap(mp, Stream, "_enforce_hard", make)


@mutant("stream-ids-skip", "each add leaves one id out before the next add's ids", "OA-STREAM-4")
def _ids_skip(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _prepare(self: Stream, *args: Any) -> list[StoredSample]:
            out: list[StoredSample] = original(self, *args)
            self._next_id += 1
            return out

        return _prepare

    wrap(mp, Stream, "_prepare", make)


@mutant(
    "stream-writer-id-kept",
    "a writer's builtin:id stays in the stored sample instead of the stream's id",
    "OA-STREAM-4",
)
def _writer_id_kept(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _prepare(self: Stream, samples: Any, received_ns: int) -> list[StoredSample]:
            out: list[StoredSample] = original(self, samples, received_ns)
            kept = []
            for written, st in zip(samples, out, strict=True):
                given = written.param("builtin:id")
                if given is None:
                    kept.append(st)
                    continue
                sample = st.sample.with_params({"builtin:id": given})
                parts = chunk_parts(sample)
                changes: dict[str, Any] = {"sample": sample, "parts": parts}
                if any(f.name == "wire" for f in fields(st)):  # the joined chunk, when kept
                    changes["wire"] = b"".join(parts)
                kept.append(replace(st, **changes))
            return kept

        return _prepare

    wrap(mp, Stream, "_prepare", make)


@mutant(
    "stream-chunk-nul-optional",
    "a datasample chunk whose last byte is not NUL is read as if the NUL were there",
    "OA-STREAM-10",
)
def _chunk_nul_optional(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def decode_chunk(chunk: bytes | memoryview, **kwargs: Any) -> Any:
            data = bytes(chunk)
            return original(data if data.endswith(b"\0") else data + b"\0", **kwargs)

        return decode_chunk

    wrap(mp, streamservice, "decode_chunk", make)  # BinaryM samples
    wrap(mp, streamwire, "decode_chunk", make)  # ADD_SAMPLE(S)


# --- reading and waiting (11.4, 11.5) ---------------------------------------------------------


@mutant(
    "stream-time-nearest",
    "GET_SAMPLE_BY_TIME answers the nearest sample, not the last one at or before the time",
    "OA-STREAM-6",
)
def _time_nearest(mp: pytest.MonkeyPatch) -> None:
    def at_or_before(self: Stream, ms: int) -> StoredSample | None:
        items = list(self._items)
        return min(items, key=lambda st: abs(st.timestamp_ms - ms)) if items else None

    mp.setattr(Stream, "at_or_before", at_or_before)


@mutant(
    "stream-range-exclusive",
    "GET_SAMPLES_BY_TIME leaves out the samples stamped exactly at its ends",
    "OA-STREAM-6",
)
def _range_exclusive(mp: pytest.MonkeyPatch) -> None:
    def between(self: Stream, from_ms: int, until_ms: int) -> list[StoredSample]:
        return [st for st in self._items if from_ms < st.timestamp_ms < until_ms]

    mp.setattr(Stream, "between", between)


@mutant(
    "stream-wait-at-once",
    "WAIT_FOR_* with no sample to answer times out at once, whatever its timeout",
    "OA-STREAM-7",
)
def _wait_at_once(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _wait(self: StreamService, conn: Any, state: Any, msg: Message, now_ns: int) -> Any:
            kind, _, suffix = msg.type.partition(" ")
            if suffix.isdigit():
                msg = replace(msg, type=f"{kind} 0")
            return original(self, conn, state, msg, now_ns)

        return _wait

    wrap(mp, StreamService, "_wait", make)


# --- BinaryM and push (11.3, 11.6) ------------------------------------------------------------


@mutant(
    "stream-binarym-ignored",
    "a BinaryM frame is UNKNOWN_COMMAND BinaryOnly even after a media command",
    "OA-STREAM-11",
)
def _binarym_ignored(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(StreamService, "binary", lambda self, *args, **kwargs: None)


@mutant(
    "stream-push-dropped-unsaid",
    "a slow subscriber loses samples without a dropped slot on the next DATASAMPLE",
    "OA-STREAM-8",
)
def _push_dropped_unsaid(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def push_message(sample: StoredSample, **kwargs: Any) -> Message:
            kwargs["dropped"] = 0
            result: Message = original(sample, **kwargs)
            return result

        return push_message

    wrap(mp, pusher, "push_message", make)
    wrap(mp, delivery, "push_message", make)


@mutant(
    "stream-push-newest-first",
    "a subscriber that fell behind gets its buffered samples newest first",
    "OA-STREAM-8",
)
def _push_newest_first(mp: pytest.MonkeyPatch) -> None:
    def take(self: SampleBuffer) -> tuple[StoredSample, int] | None:
        if not self._items:
            return None
        dropped, self._dropped = self._dropped, 0
        return self._items.pop(), dropped

    mp.setattr(SampleBuffer, "take", take)


# --- typed streams: limits, locks, alarms (11.7) ----------------------------------------------


@mutant(
    "stream-lock-ignored",
    "locks are granted but protect nothing: the soft limit drops locked samples",
    "OA-XSTREAM-2",
    "OA-XSTREAM-5",
)
def _lock_ignored(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(Stream, "is_locked", lambda self, ident: False)


@mutant(
    "stream-soft-limit-is-hard",
    "a typed stream enforces its soft limits as hard ones: locked samples go at the soft limit",
    "OA-XSTREAM-2",
    "OA-XSTREAM-3",
)
def _soft_is_hard(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _enforce_hard(self: Stream) -> int:
            spec = self.spec
            if not spec.typed:
                result: int = original(self)
                return result
            dropped = 0
            while self._items and self._over(spec.soft_size, spec.soft_count):
                self._popleft()
                dropped += 1
            return dropped

        return _enforce_hard

    wrap(mp, Stream, "_enforce_hard", make)


def _alarm_filter(mp: pytest.MonkeyPatch, keep: Fn) -> None:
    """Drop the alarms of `Stream.add` for which `keep(alarm)` is false."""

    def make(original: Fn) -> Fn:
        def add(self: Stream, *args: Any, **kwargs: Any) -> AddResult:
            result: AddResult = original(self, *args, **kwargs)
            return replace(result, alarms=tuple(a for a in result.alarms if keep(a)))

        return add

    wrap(mp, Stream, "add", make)


@mutant("stream-hardlimit-unposted", "HardLimit alarms are never posted", "OA-XSTREAM-3")
def _hardlimit_unposted(mp: pytest.MonkeyPatch) -> None:
    _alarm_filter(mp, lambda alarm: alarm.kind != "HardLimit")


@mutant("stream-gap-unposted", "Gap alarms are never posted", "OA-XSTREAM-8")
def _gap_unposted(mp: pytest.MonkeyPatch) -> None:
    _alarm_filter(mp, lambda alarm: alarm.kind != "Gap")


@mutant(
    "stream-softlimit-every-add",
    "SoftLimit is posted for every add that drops samples, not once per crossing",
    "OA-XSTREAM-2",
)
def _softlimit_every_add(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _limit_alarms(self: Stream, soft: int, hard: int, now_ms: int) -> list[Alarm]:
            self._soft_dropping = False  # as if the previous add had dropped nothing
            result: list[Alarm] = original(self, soft, hard, now_ms)
            return result

        return _limit_alarms

    wrap(mp, Stream, "_limit_alarms", make)


@mutant("stream-idle-never", "the Idle alarm is never posted", "OA-XSTREAM-7")
def _idle_never(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(Stream, "tick", lambda self, now_ns: None)


@mutant(
    "stream-oversize-accepted",
    "a sample larger than the byte limit is accepted (and the ring then drops everything)",
    "OA-STREAM-13",
    "OA-XSTREAM-4",
)
def _oversize_accepted(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _prepare(self: Stream, *args: Any) -> list[StoredSample]:
            spec = self.spec
            self.spec = replace(spec, hardsize=2**62)  # no sample is too large now
            try:
                result: list[StoredSample] = original(self, *args)
            finally:
                self.spec = spec
            return result

        return _prepare

    wrap(mp, Stream, "_prepare", make)


@mutant(
    "stream-type-case-sensitive",
    "a stream's type addresses it only in the exact case it was declared in",
    "OA-XSTREAM-1",
)
def _type_case_sensitive(mp: pytest.MonkeyPatch) -> None:
    def resolve(self: StreamService, to: str) -> str | None:
        if to in self._states:
            return to
        if not (self.typed and to):
            return None
        return next((n for n, st in self._states.items() if st.stream.spec.type == to), None)

    mp.setattr(StreamService, "resolve", resolve)


@mutant(
    "stream-inputstream-ignored",
    "registrations subscribe to no stream: inputstream and stream sources are ignored",
    "OA-STREAM-14",
)
def _inputstream_ignored(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(StreamService, "set_registration", lambda self, module, reg: None)


@mutant(
    "stream-search-latest-oldest",
    "SEARCH_SAMPLES with latest n returns the oldest n matches instead of the newest",
    "OA-XSTREAM-9",
)
def _search_latest_oldest(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def search(self: Stream, *, latest: int = 0, **kwargs: Any) -> list[StoredSample]:
            found: list[StoredSample] = original(self, latest=0, **kwargs)
            return found[:latest] if latest > 0 else found

        return search

    wrap(mp, Stream, "search", make)
