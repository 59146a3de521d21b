"""A hypothesis state machine: Stream against a plain-list model (add, locks, every lookup)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, precondition, rule

from openair.protocol.datasample import DataSample
from openair.protocol.errors import SampleInvalidError
from openair.server.core.streams import Stream
from openair.server.core.streamspec import StoredSample, StreamSpec

MS = 1_000_000
# The retrieve globs the search rule uses, and what each means for a tag (OA-RET-8).
GLOBS: dict[str, Callable[[str], bool]] = {
    "a": "a".__eq__,
    "*": lambda tag: True,
    "b*": lambda tag: tag.startswith("b"),
    "c": "c".__eq__,
}


@dataclass
class Item:
    id: int
    ts: int
    size: int
    tag: str


class StreamMachine(RuleBasedStateMachine):
    """The model keeps the held samples in a list and re-derives every answer by brute force."""

    def __init__(self) -> None:
        super().__init__()
        self.model: list[Item] = []
        self.locks: dict[int, tuple[int, int, int]] = {}  # lock id -> (owner, first, last)
        self.next_id = 1
        self.next_lock = 1
        self.clock_ms = 0
        self.soft_was_dropping = False
        self.stream = Stream(StreamSpec(name="S", whiteboard="W", hardsize=1))
        self.spec = self.stream.spec  # replaced by setup()

    @initialize(
        typed=st.booleans(),
        hardsize=st.integers(8, 60),
        hardcount=st.integers(0, 10),
        soft=st.tuples(st.integers(0, 60), st.integers(0, 10)),
    )
    def setup(self, typed: bool, hardsize: int, hardcount: int, soft: tuple[int, int]) -> None:
        softsize = min(soft[0], hardsize)
        softcount = min(soft[1], hardcount) if hardcount else soft[1]
        self.spec = StreamSpec(
            name="S",
            whiteboard="W",
            type="T.S" if typed else None,
            hardsize=hardsize,
            hardcount=hardcount,
            softsize=softsize if typed else None,
            softcount=softcount if typed else None,
        )
        self.stream = Stream(self.spec)

    # -- model helpers -----------------------------------------------------------------------

    def locked(self, ident: int) -> bool:
        return any(first <= ident <= last for _, first, last in self.locks.values())

    def over(self, size: int, count: int) -> bool:
        total = sum(i.size for i in self.model)
        return total > size or (count > 0 and len(self.model) > count)

    def soft_enforce(self) -> int:
        dropped = 0
        while self.over(self.spec.soft_size, self.spec.soft_count):
            candidates = [i for i, it in enumerate(self.model[:-1]) if not self.locked(it.id)]
            if not candidates:
                break
            del self.model[candidates[0]]
            dropped += 1
        return dropped

    def hard_enforce(self) -> int:
        dropped = 0
        while self.model and self.over(self.spec.hardsize, self.spec.hardcount):
            del self.model[0]
            dropped += 1
        return dropped

    # -- rules ---------------------------------------------------------------------------------

    @rule(
        batch=st.lists(
            st.tuples(
                st.one_of(st.integers(0, 6), st.integers(0, 70)),
                st.one_of(st.none(), st.integers(0, 30)),
                st.sampled_from("ab"),
            ),
            min_size=1,
            max_size=4,
        ),
        advance=st.integers(0, 3),
    )
    def add(self, batch: list[tuple[int, int | None, str]], advance: int) -> None:
        self.clock_ms += advance
        samples = []
        for size, ts, tag in batch:
            params = [("tag", tag)] + ([("builtin:timestamp", str(ts))] if ts is not None else [])
            samples.append(DataSample(payload=bytes(size), params=tuple(params)))
        if any(size > self.spec.hardsize for size, _, _ in batch):
            try:
                self.stream.add(samples, writer="w", received_ns=self.clock_ms * MS)
            except SampleInvalidError:
                return
            raise AssertionError("an oversized sample was accepted")
        result = self.stream.add(samples, writer="w", received_ns=self.clock_ms * MS)
        new = []
        for size, ts, tag in batch:
            new.append(Item(self.next_id, self.clock_ms if ts is None else ts, size, tag))
            self.next_id += 1
        self.model.extend(new)
        soft = self.soft_enforce() if self.spec.typed else 0
        hard = self.hard_enforce()
        assert [s.id for s in result.stored] == [i.id for i in new]
        assert [s.timestamp_ms for s in result.stored] == [i.ts for i in new]
        assert result.dropped == soft + hard
        kinds = [a.kind for a in result.alarms if a.kind in ("SoftLimit", "HardLimit")]
        expected = []
        if self.spec.typed:
            if soft and not self.soft_was_dropping:
                expected.append("SoftLimit")
            if hard:
                expected.append("HardLimit")
            self.soft_was_dropping = soft > 0
        assert kinds == expected

    @rule(data=st.data(), span=st.integers(-1, 6), owner=st.integers(1, 3))
    def lock(self, data: st.DataObject, span: int, owner: int) -> None:
        # Mostly around the held ids, so that locks matter.
        first = data.draw(st.integers(max(0, self.next_id - 8), self.next_id + 1))
        last = first + span
        lock_id = self.stream.lock(first, last, owner)
        assert lock_id == self.next_lock
        self.next_lock += 1
        self.locks[lock_id] = (owner, first, min(last, self.next_id - 1))

    @precondition(lambda self: bool(self.locks))
    @rule(data=st.data(), right_owner=st.booleans())
    def unlock(self, data: st.DataObject, right_owner: bool) -> None:
        lock_id = data.draw(st.sampled_from(sorted(self.locks)))
        owner = self.locks[lock_id][0]
        if right_owner:
            assert self.stream.unlock(lock_id, owner)
            del self.locks[lock_id]
        else:
            assert not self.stream.unlock(lock_id, owner + 10)
        assert not self.stream.unlock(self.next_lock + 5, owner)

    @rule(owner=st.integers(1, 3))
    def release(self, owner: int) -> None:
        mine = [k for k, v in self.locks.items() if v[0] == owner]
        assert self.stream.release(owner) == len(mine)
        for k in mine:
            del self.locks[k]

    # -- lookups against brute force -----------------------------------------------------------

    def ids(self, found: list[StoredSample]) -> list[int]:
        return [s.id for s in found]

    @rule(data=st.data())
    def id_lookups(self, data: st.DataObject) -> None:
        ident = data.draw(st.integers(-1, self.next_id + 1))
        held = {i.id for i in self.model}
        got = self.stream.by_id(ident)
        assert (got.id if got else None) == (ident if ident in held else None)
        after = [i.id for i in self.model if i.id > ident]
        first = self.stream.first_after_id(ident)
        last = self.stream.last_after_id(ident)
        assert (first.id if first else None) == (after[0] if after else None)
        assert (last.id if last else None) == (after[-1] if after else None)
        assert self.stream.is_locked(ident) == self.locked(ident)

    @rule(ms=st.integers(-1, 35), until=st.integers(-1, 35))
    def time_lookups(self, ms: int, until: int) -> None:
        s = self.stream
        at_or_before = [i for i in self.model if i.ts <= ms]
        best = max(at_or_before, key=lambda i: (i.ts, i.id)) if at_or_before else None
        got = s.at_or_before(ms)
        assert (got.id if got else None) == (best.id if best else None)
        assert self.ids(s.between(ms, until)) == [i.id for i in self.model if ms <= i.ts <= until]
        at_or_after = [i.id for i in self.model if i.ts >= ms]
        first, last = s.first_at_or_after(ms), s.last_at_or_after(ms)
        assert (first.id if first else None) == (at_or_after[0] if at_or_after else None)
        assert (last.id if last else None) == (at_or_after[-1] if at_or_after else None)

    @rule(
        after=st.one_of(st.none(), st.integers(0, 30)),
        until=st.one_of(st.none(), st.integers(0, 30)),
        glob=st.sampled_from([None, *GLOBS]),
        latest=st.integers(0, 3),
    )
    def search(self, after: int | None, until: int | None, glob: str | None, latest: int) -> None:
        params = [] if glob is None else [("tag", glob)]
        got = self.stream.search(after_ms=after, until_ms=until, params=params, latest=latest)
        want = [
            i.id
            for i in self.model
            if (after is None or i.ts >= after)
            and (until is None or i.ts <= until)
            and (glob is None or GLOBS[glob](i.tag))
        ]
        assert self.ids(got) == (want[-latest:] if latest else want)

    @invariant()
    def counters(self) -> None:
        s = self.stream
        assert s.count == len(self.model)
        assert s.size == sum(i.size for i in self.model)
        newest, oldest = s.newest(), s.oldest()
        assert (newest.id if newest else None) == (self.model[-1].id if self.model else None)
        assert (oldest.id if oldest else None) == (self.model[0].id if self.model else None)
        assert s.locked == sum(1 for i in self.model if self.locked(i.id))
        assert s.size <= self.spec.hardsize
        assert not self.spec.hardcount or s.count <= self.spec.hardcount


StreamMachine.TestCase.settings = settings(max_examples=60, stateful_step_count=30, deadline=None)
test_stream_state_machine = StreamMachine.TestCase
