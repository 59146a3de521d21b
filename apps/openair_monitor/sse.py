"""Live updates as server-sent events (text/event-stream), sent in batches on a timer.

Nothing is sent from the post path. While at least one stream is open, a timer runs every
`tick_s`: for each stream it looks at the events the tap recorded since the stream's cursor
(newest first, at most `scan` of them), keeps at most `batch` that pass the stream's filter,
and writes them as one `messages` event; events it did not look at are reported in a `gap`
event (`{"skipped": n}`), so a page knows its list may be incomplete. A message is formatted
once per tick however many streams show it. Every `overview_s` the overview, every `graph_s`
the type graph, is built once and sent to the streams that asked for it; a stream that got
nothing for `heartbeat_s` gets a comment line.

A stream whose peer does not read (more than `max_buffer` bytes unsent) has its batches
dropped and counted (`dropped`, reported in the next `gap` event); after `stall_s` without
room it is closed.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from openair.protocol.message import Message
from openair_monitor.http import HttpConnection
from openair_monitor.messages import MessageFilter, summary

if TYPE_CHECKING:
    from openair_monitor.core import Monitor

__all__ = ["TOPICS", "Broadcaster", "Stream"]

#: What a stream may ask for (`topics=`): stored messages, the overview, the type graph.
TOPICS = frozenset({"messages", "overview", "graph"})


@dataclass(slots=True, eq=False, kw_only=True)
class Stream:
    """One open event stream and where it is in the tap's events."""

    conn: HttpConnection
    topics: frozenset[str]
    flt: MessageFilter
    accept: Callable[[Message], bool]
    cursor: int  # the seq of the next event to look at
    last_write: float
    stalled_since: float | None = None
    sent: int = 0  # message events written
    skipped: int = 0  # events not looked at (too many since the last tick, or ring wrapped)
    dropped: int = 0  # message events dropped because the peer was not reading
    unreported: int = 0  # skipped + dropped not yet told to the peer
    batch: int = 0  # message events in this tick's `messages` event (0: none)


def _dumps(obj: object) -> str:
    return json.dumps(obj, separators=(",", ":"), ensure_ascii=False)


def _event(name: str, data: str) -> str:
    return f"event: {name}\ndata: {data}\n\n"  # JSON has no raw newlines: one data line


class Broadcaster:
    """The open event streams and the timer that feeds them."""

    def __init__(self, mon: Monitor) -> None:
        self.mon = mon
        self.options = mon.options
        self.streams: set[Stream] = set()
        self._loop = asyncio.get_running_loop()
        self._timer: asyncio.TimerHandle | None = None
        self._next_overview = 0.0
        self._next_graph = 0.0
        self.ticks = 0

    def open(
        self,
        conn: HttpConnection,
        topics: frozenset[str],
        flt: MessageFilter,
        since: int | None = None,
    ) -> None:
        """Start a stream on `conn` (its response head is written): hello, then live events.

        `since` is the seq to start from (the `seq` of a list the page just fetched, so that
        nothing posted in between is missed); the default is "from now".
        """
        now = self._loop.time()
        count = self.mon.tap.count
        stream = Stream(
            conn=conn,
            topics=topics,
            flt=flt,
            accept=flt.compile(),
            cursor=count if since is None else max(0, min(since, count)),
            last_write=now,
        )
        self.streams.add(stream)
        conn.on_close = lambda: self.streams.discard(stream)
        hello = {"seq": stream.cursor, "topics": sorted(topics), "tick_s": self.options.tick_s}
        parts = [f"retry: {self.options.retry_ms}\n", _event("hello", _dumps(hello))]
        if "overview" in topics:
            parts.append(_event("overview", _dumps(self.mon.overview())))
        if "graph" in topics:
            parts.append(_event("graph", _dumps(self.mon.graph())))
        conn.write("".join(parts).encode())
        if self._timer is None:
            self._timer = self._loop.call_later(self.options.tick_s, self._tick)

    def close(self) -> None:
        """Stop the timer and close every stream."""
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        for stream in list(self.streams):
            stream.conn.close()
        self.streams.clear()

    # -- the timer --------------------------------------------------------------------------

    def _tick(self) -> None:
        self._timer = None
        if not self.streams:
            return  # nobody is watching: no timer, no formatting
        self.ticks += 1
        now = self._loop.time()
        overview = graph = None
        if now >= self._next_overview and any("overview" in s.topics for s in self.streams):
            overview = _event("overview", _dumps(self.mon.overview()))
            self._next_overview = now + self.options.overview_s
        if now >= self._next_graph and any("graph" in s.topics for s in self.streams):
            graph = _event("graph", _dumps(self.mon.graph()))
            self._next_graph = now + self.options.graph_s
        formatted: dict[int, str] = {}
        for stream in list(self.streams):
            parts = self._messages(stream, formatted) if "messages" in stream.topics else []
            if overview is not None and "overview" in stream.topics:
                parts.append(overview)
            if graph is not None and "graph" in stream.topics:
                parts.append(graph)
            self._send(stream, parts, now)
        self._timer = self._loop.call_later(self.options.tick_s, self._tick)

    def _messages(self, stream: Stream, formatted: dict[int, str]) -> list[str]:
        """Return the `messages` (and `gap`) events of one stream for this tick."""
        tap, opts = self.mon.tap, self.options
        count = tap.count
        if stream.cursor >= count:
            return []
        start = max(stream.cursor, tap.oldest, count - opts.scan)
        skipped = start - stream.cursor
        chosen: list[int] = []
        for seq, (msg, _) in tap.newest_first(stop=start):
            if stream.accept(msg):
                chosen.append(seq)
                if len(chosen) >= opts.batch:
                    skipped += seq - start  # the older ones were not looked at
                    break
        stream.cursor = count
        stream.skipped += skipped
        stream.unreported += skipped
        if not chosen:
            return []
        items = []
        for seq in reversed(chosen):
            text = formatted.get(seq)
            if text is None:
                msg, deliveries = tap.ring[seq - tap.oldest]
                text = formatted[seq] = _dumps(summary(msg, deliveries, seq))
            items.append(text)
        stream.batch = len(items)
        return [_event("messages", "[" + ",".join(items) + "]")]

    def _send(self, stream: Stream, parts: list[str], now: float) -> None:
        """Write a stream's events, a gap notice first; drop them if the peer is not reading."""
        conn = stream.conn
        batch, stream.batch = stream.batch, 0
        if conn.buffered > self.options.max_buffer:
            stream.dropped += batch
            stream.unreported += batch
            if stream.stalled_since is None:
                stream.stalled_since = now
            elif now - stream.stalled_since > self.options.stall_s:
                conn.close()  # on_close forgets the stream
            return
        stream.stalled_since = None
        if stream.unreported:
            gap = {"skipped": stream.skipped, "dropped": stream.dropped, "new": stream.unreported}
            parts.insert(0, _event("gap", _dumps(gap)))
            stream.unreported = 0
        if not parts:
            if now - stream.last_write < self.options.heartbeat_s:
                return
            parts = [": keepalive\n\n"]  # a comment: keeps proxies and the peer's timer happy
        conn.write("".join(parts).encode())
        stream.sent += batch
        stream.last_write = now
