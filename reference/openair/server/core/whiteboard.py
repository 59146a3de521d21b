"""One whiteboard: its stored copies, their wbid sequence, eviction and retrieve (spec 7, 9).

Sans-I/O: time comes in as nanoseconds. The stored copies live in a deque in arrival order;
retrieves scan it from the newest end and stop as soon as `latest` is reached or the received
times fall below the lower time bound, so `latest=1` on a full board costs one step.

Besides `maxcount`, the copies kept are bounded by `max_bytes` (`max-history-bytes`, OA-LIM-10):
the oldest go first, as with maxcount; the newest copy is always kept.
"""

from __future__ import annotations

import contextlib
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any

from openair.protocol.content import ContentMatch, RetrieveSpec
from openair.protocol.contentmatch import canonical_xml_text, content_glob, text_of
from openair.protocol.errors import StoreFailedError
from openair.protocol.matching import matcher
from openair.protocol.message import Message
from openair.server.core.commands import ms_time
from openair.server.core.config import DEFAULT_MAXCOUNT, DEFAULT_WB_PRIORITY, WhiteboardConfig
from openair.server.core.queues import item_bytes
from openair.server.core.store import HistoryStore, SequencedStore

if TYPE_CHECKING:
    import concurrent.futures

__all__ = [
    "Whiteboard",
    "content_glob",
    "derive",
    "select",
    "text_bytes",
    "text_of",
    "xml_text_of",
]

_NS_PER_MS = 1_000_000
# Evict from the store in batches: memory is exact (OA-WB-6), the store may lag a little, and
# a reload trims to maxcount again.
_MAX_EVICT_BATCH = 256


def derive(msg: Message, **changes: Any) -> Message:
    """Return `msg` with `changes`, like `dataclasses.replace` but many times cheaper.

    It skips `__post_init__`: use it only for slots the server sets to values it knows valid
    (stored, receivedTime, wbid, postedTime).
    """
    return msg.trusted_replace(**changes)


def text_bytes(msg: Message) -> int:
    """Return a lower bound of the XML bytes `msg` takes in a collection: its text slots."""
    return len(msg.content) + len(msg.history) + len(msg.comment)


def xml_text_of(msg: Message) -> str:
    """Return what a `contentmatch="xml"` glob sees: the canonical XML text (OA-RET-17)."""
    return canonical_xml_text(msg.content) if msg.content_is_xml else msg.content


class Whiteboard:
    """A named store of messages with maxcount eviction and retrieve (spec 7, 9)."""

    def __init__(
        self,
        name: str,
        *,
        maxcount: int = DEFAULT_MAXCOUNT,
        priority: float = DEFAULT_WB_PRIORITY,
        store: HistoryStore | None = None,
        max_bytes: int = 0,
    ) -> None:
        if maxcount < 1:
            raise ValueError(f"maxcount must be at least 1, not {maxcount}")
        self.name = name
        self.maxcount = maxcount
        self.max_bytes = max_bytes  # OA-LIM-10: 0 = no byte bound
        self.bytes = 0  # what the stored copies hold
        self.priority = priority
        self.received = 0  # posts addressed to it, stored or not (counted by the router)
        self.stored = 0  # posts stored since start
        self.dispatched = 0  # wakeups decided for its posts (counted by the router)
        self.evicted = 0
        self.evict_errors = 0
        self._store = store
        # A cluster's store numbers the posts (spec 17): wbid is the stream's sequence.
        self._sequenced = store if isinstance(store, SequencedStore) else None
        #: Copies other servers stored, adopted by the last store_post or adopt(): the router
        #: decides their wakeups (OA-CLU-4) before those of the post that adopted them.
        self.adopted: list[Message] = []
        self._messages: deque[Message] = deque()
        self._next_wbid = 1  # OA-WB-5: starts at 1
        self._last_ns = 0
        self._store_evicted_through = 0
        self._batch = max(1, min(_MAX_EVICT_BATCH, maxcount // 8))
        # The store lags by at most a batch of copies, and by at most this many bytes of them
        # (an in-memory store holds what it has not evicted yet: OA-LIM-10).
        self._lag_bytes = 0
        self._batch_bytes = max(1 << 20, max_bytes // 16) if max_bytes else 0
        if store is not None:
            self._reload(store.load(name))

    @classmethod
    def from_config(
        cls, config: WhiteboardConfig, store: HistoryStore | None, *, max_bytes: int = 0
    ) -> Whiteboard:
        """Build the whiteboard a `<whiteboard>` declares (OA-CONF-2)."""
        return cls(
            config.name,
            maxcount=config.maxcount,
            priority=config.priority,
            store=store,
            max_bytes=max_bytes,
        )

    def __repr__(self) -> str:
        return f"<Whiteboard {self.name}: {len(self._messages)} of {self.maxcount} messages>"

    def __len__(self) -> int:
        return len(self._messages)

    @property
    def next_wbid(self) -> int:
        """The wbid the next stored message will get."""
        return self._next_wbid

    @property
    def last_received_ns(self) -> int:
        """The receipt time (ns) stamped on the newest post (OA-TIME-3, OA-WB-12)."""
        return self._last_ns

    def newest_first(self) -> Iterator[Message]:
        """Iterate the stored copies, newest first (OA-RET-6)."""
        return reversed(self._messages)

    def stamp(self, received_ns: int) -> int:
        """Return the receipt time to stamp, never earlier than the previous one (OA-WB-12)."""
        if received_ns < self._last_ns:
            received_ns = self._last_ns  # a clock step back must not reorder receivedTime
        self._last_ns = received_ns
        return received_ns

    def store_post(self, msg: Message, received_ns: int) -> Message:
        """Store a post and return its stored copy (OA-WB-4); raise StoreFailedError (OA-WB-3).

        The copy gets `stored` = this whiteboard, `receivedTime` and the next `wbid` (OA-WB-5);
        every other slot is kept. The store is written first: nothing is kept in memory when
        it fails, and the wbid is not used up.
        """
        copy = derive(
            msg,
            stored=self.name,
            received=ms_time(self.stamp(received_ns)),  # OA-TIME-3
            wbid=self._next_wbid,
        )
        if self._sequenced is not None:
            return self._store_sequenced(self._sequenced, copy)
        if self._store is not None:
            try:
                self._store.append(self.name, copy)  # OA-WB-3, OA-WB-9: durable before the ack
            except Exception as exc:
                raise StoreFailedError(f"{self.name}: {exc}") from exc
        self._next_wbid += 1
        self._messages.append(copy)
        self.bytes += item_bytes(copy, None)
        self.stored += 1
        if len(self._messages) > self.maxcount or (self.max_bytes and self.bytes > self.max_bytes):
            self._evict()
        return copy

    def _store_sequenced(self, store: SequencedStore, copy: Message) -> Message:
        """Store a post in a cluster's store (OA-CLU-2): the store's wbid, in the store's order.

        Copies other servers stored before it are adopted first (into `adopted`), so that every
        server holds the whiteboard in one wbid order (OA-CLU-1).
        """
        try:
            wbid = store.publish(self.name, copy)  # OA-WB-3, OA-CLU-2: stored and replicated
        except Exception as exc:
            raise StoreFailedError(f"{self.name}: {exc}") from exc
        earlier = store.take(self.name, wbid)
        self.adopted = [kept for kept in map(self._adopt, earlier) if kept is not None]
        own = self._adopt(derive(copy, wbid=wbid))
        return own if own is not None else derive(copy, wbid=wbid)

    @property
    def sequenced(self) -> bool:
        """Whether a cluster's store numbers the posts (spec 17)."""
        return self._sequenced is not None

    def post_soon(self, msg: Message, received_ns: int) -> concurrent.futures.Future[int]:
        """Send a post to the cluster's store; the future says when it is stored (OA-CLU-2).

        It is adopted, and its wakeups decided, when it comes back from the store in order,
        as a noreply post is; its acknowledgement waits for the future, the server's loop
        does not.
        """
        assert self._sequenced is not None
        try:
            return self._sequenced.publish_soon(self.name, self._unnumbered(msg, received_ns))
        except Exception as exc:
            raise StoreFailedError(f"{self.name}: {exc}") from exc

    def post_later(self, msg: Message, received_ns: int) -> None:
        """Send a noreply post to the cluster's store without waiting (OA-CLU-5).

        It is adopted, and its wakeups decided, when it comes back from the store in order.
        """
        assert self._sequenced is not None
        try:
            self._sequenced.publish_later(self.name, self._unnumbered(msg, received_ns))
        except Exception as exc:
            raise StoreFailedError(f"{self.name}: {exc}") from exc

    def _unnumbered(self, msg: Message, received_ns: int) -> Message:
        """The stored copy of a post before the cluster's store numbers it (OA-WB-4)."""
        return derive(msg, stored=self.name, received=ms_time(self.stamp(received_ns)))

    def adopt(self) -> list[Message]:
        """Adopt the copies other servers stored since the last call (OA-CLU-4); return them."""
        if self._sequenced is None:
            return []
        return [kept for kept in map(self._adopt, self._sequenced.take(self.name)) if kept]

    def sync(self) -> list[Message]:
        """Adopt every copy stored anywhere before this call (OA-CLU-3); return them."""
        if self._sequenced is None:
            return []
        # The store unreachable: answer from what this server holds.
        with contextlib.suppress(Exception):
            self._sequenced.sync(self.name)
        return self.adopt()

    def _adopt(self, copy: Message) -> Message | None:
        """Keep a copy stored under its own wbid, after every copy held (OA-CLU-1).

        A wbid already held (a repeat) is skipped. The receipt time never falls with the wbid
        (OA-WB-12): a copy stamped earlier than the newest held takes the newest's time.
        """
        wbid = copy.wbid or 0
        if wbid < self._next_wbid:
            return self._adopt_late(copy, wbid)
        received = copy.received
        if received is not None and received.ms < self._last_ns // _NS_PER_MS:
            copy = derive(copy, received=ms_time(self._last_ns))
        elif received is not None:
            self._last_ns = max(self._last_ns, received.ms * _NS_PER_MS)
        self._next_wbid = wbid + 1
        self._messages.append(copy)
        self.bytes += item_bytes(copy, None)
        self.stored += 1
        if len(self._messages) > self.maxcount or (self.max_bytes and self.bytes > self.max_bytes):
            self._evict()
        return copy

    def _adopt_late(self, copy: Message, wbid: int) -> Message | None:
        """Keep a copy that arrives after a later one (the store was slow to hand it over).

        It goes into its place by wbid; a repeat, or a copy older than all held, is skipped.
        """
        messages = self._messages
        pos = len(messages)
        while pos and (messages[pos - 1].wbid or 0) > wbid:
            pos -= 1
        if pos == 0 or messages[pos - 1].wbid == wbid:
            return None  # older than every copy held (evicted already), or held already
        neighbour = messages[pos - 1].received
        if neighbour is not None and (copy.received is None or copy.received.ms < neighbour.ms):
            copy = derive(copy, received=neighbour)  # OA-WB-12 among its neighbours
        messages.insert(pos, copy)
        self.bytes += item_bytes(copy, None)
        self.stored += 1
        if len(messages) > self.maxcount or (self.max_bytes and self.bytes > self.max_bytes):
            self._evict()
        return copy

    def retrieve(
        self, spec: RetrieveSpec, *, now_ns: int, limit: int = 0, max_bytes: int = 0
    ) -> list[Message]:
        """Return the stored copies `spec` selects, newest first (OA-RET-3..9, OA-RET-6).

        The spec's `whiteboard` is not looked at: the caller chose this whiteboard (OA-RET-2).
        `limit` caps the results below `latest`; with `max_bytes` the scan stops at the first
        result that takes their `text_bytes` past it (that one included: the caller sees it).
        """
        return select(self._messages, spec, now_ns=now_ns, limit=limit, max_bytes=max_bytes)

    def snapshot(self) -> tuple[Message, ...]:
        """The stored copies now, oldest first: `select` reads them on any thread (issue #19)."""
        return tuple(self._messages)

    def _reload(self, history: list[Message]) -> None:
        """Take over the store's history: keep the newest maxcount, continue wbid (OA-WB-9)."""
        if not history:
            return
        last = max(m.wbid or 0 for m in history)
        self._next_wbid = last + 1  # OA-WB-5: the sequence continues after a restart
        kept = history[-self.maxcount :]
        if len(kept) < len(history):
            through = kept[0].wbid or 0
            self._evict_store(through - 1)
        self._messages.extend(kept)
        self.bytes = sum(item_bytes(m, None) for m in kept)
        if self.max_bytes and self.bytes > self.max_bytes:
            self._evict()
        newest = kept[-1].received
        self._last_ns = newest.ms * _NS_PER_MS if newest is not None else 0

    def _evict(self) -> None:
        """Drop the oldest copies beyond maxcount (OA-WB-6) or max_bytes (OA-LIM-10).

        From the store in batches.
        """
        while len(self._messages) > self.maxcount or (
            self.max_bytes and self.bytes > self.max_bytes and len(self._messages) > 1
        ):
            size = item_bytes(self._messages.popleft(), None)
            self.bytes -= size
            self._lag_bytes += size
            self.evicted += 1
        oldest_kept = self._messages[0].wbid or 0
        if oldest_kept - 1 - self._store_evicted_through >= self._batch or (
            self._batch_bytes and self._lag_bytes >= self._batch_bytes
        ):
            self._evict_store(oldest_kept - 1)

    def _evict_store(self, through: int) -> None:
        if self._store is None:
            return
        try:
            self._store.evict(self.name, through)
        except Exception:  # the post is stored; a failed eviction is retried with the next batch
            self.evict_errors += 1
            return
        self._store_evicted_through = through
        self._lag_bytes = 0


#: Copies `select` reads between two calls of its `pause` (some 0.1-0.3 ms of the scan).
PAUSE_EVERY = 256


def select(
    messages: Sequence[Message],
    spec: RetrieveSpec,
    *,
    now_ns: int,
    limit: int = 0,
    max_bytes: int = 0,
    pause: Callable[[], None] | None = None,
) -> list[Message]:
    """Return the copies of `messages` (oldest first) that `spec` selects, newest first.

    What `Whiteboard.retrieve` does, on a snapshot as well as on the live history. `pause`,
    when given, is called every `PAUSE_EVERY` copies read (a worker thread lets the event loop
    have the interpreter lock there, issue #19).
    """
    accept = _criteria(spec)
    lower_us = _lower_bound_us(spec, now_ns)
    upper_us = spec.until_time.us if spec.until_time is not None else None
    latest = spec.latest  # OA-RET-4: 0 = no limit
    limit = min(latest, limit) if latest and limit else latest or limit
    size = 0
    found: list[Message] = []
    timed = lower_us is not None or upper_us is not None
    unpaused = 0
    for msg in reversed(messages):
        if pause is not None:
            unpaused += 1
            if unpaused == PAUSE_EVERY:
                pause()
                unpaused = 0
        if timed:  # (most retrieves name no time: a wakeup's scan of thousands skips this)
            received_us = msg.received.us if msg.received is not None else 0
            if lower_us is not None and received_us < lower_us:
                break  # receivedTime falls with wbid (OA-WB-12): nothing older can qualify
            if upper_us is not None and received_us > upper_us:
                continue  # OA-RET-9: untilTime is an inclusive upper bound
        if accept(msg):
            found.append(msg)
            if len(found) == limit:
                break
            if max_bytes:
                size += text_bytes(msg)
                if size > max_bytes:
                    break
    return found


def _lower_bound_us(spec: RetrieveSpec, now_ns: int) -> int | None:
    """Return the inclusive lower bound on receivedTime in µs (OA-RET-5, OA-RET-9), if any."""
    bounds: list[int] = []
    if spec.lastmsec:  # OA-RET-5: 0 or absent sets no window
        bounds.append((now_ns // _NS_PER_MS - spec.lastmsec) * 1000)
    if spec.after_time is not None:
        bounds.append(spec.after_time.us)
    return max(bounds) if bounds else None


def _criteria(spec: RetrieveSpec) -> Callable[[Message], bool]:
    """Return the AND of the spec's per-message criteria (OA-RET-3)."""
    checks: list[Callable[[Message], bool]] = []
    if spec.pattern and spec.pattern != "*":
        match = matcher(spec.pattern)  # OA-MATCH-8: compiled once per retrieve
        seen: dict[str, bool] = {}  # types repeat: match each distinct type once

        def type_ok(msg: Message) -> bool:
            hit = seen.get(msg.type)
            if hit is None:
                hit = seen[msg.type] = match(msg.type)
            return hit

        checks.append(type_ok)
    if spec.id:
        wanted_id = spec.id
        checks.append(lambda m: m.id == wanted_id)
    if spec.sender:
        wanted_sender = spec.sender
        checks.append(lambda m: m.sender == wanted_sender)  # case-sensitive (OA-RET-3)
    if spec.content:
        glob = content_glob(spec.content)  # OA-RET-8
        if spec.contentmatch is ContentMatch.XML:
            checks.append(lambda m: glob(xml_text_of(m)))  # OA-RET-13, OA-RET-17
        else:
            checks.append(lambda m: glob(text_of(m)))  # OA-RET-18
    if not checks:
        return lambda m: True
    if len(checks) == 1:
        return checks[0]
    return lambda m: all(check(m) for check in checks)
