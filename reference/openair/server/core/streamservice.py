"""The streams of the server, behind the router: media commands, waits and push (spec 11).

Sans-I/O like the router: every method takes the times it needs and returns what the adapter
must do — replies now, a reply deferred until a sample arrives or a timeout passes (`wait`),
deferred replies that are ready (`resolved`), samples to push to subscribers (`pushes`) and
alarms the router posts on a whiteboard (`alarms`). The ring buffers themselves are
`openair.server.core.streams.Stream`.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from openair.protocol.content import Registration
from openair.protocol.datasample import DataSample, decode_chunk
from openair.protocol.errors import (
    ContentInvalidError,
    LimitExceededError,
    LockUnknownError,
    MessageInvalidError,
    OpenAIRError,
    SampleInvalidError,
    SampleUnknownError,
)
from openair.protocol.matching import ascii_fold, matches
from openair.protocol.message import Message
from openair.protocol.objects import (
    attr,
    element,
    encode_time,
    parse_content,
    parse_integer,
    serialize,
)
from openair.protocol.times import AirTime
from openair.protocol.types import validate_pattern
from openair.protocol.xmlsafe import local_name
from openair.server.core import commands as cmd
from openair.server.core.config import StreamConfig
from openair.server.core.sessions import ConnId
from openair.server.core.streams import Stream
from openair.server.core.streamspec import Alarm, StoredSample, StreamSpec
from openair.server.core.streamwire import (
    id_range,
    integer_content,
    sample_reply,
    sample_search,
    samples_of,
    samples_reply,
    stream_config,
    time_ms,
    time_pair,
)

__all__ = [
    "PendingWait",
    "SamplePush",
    "StreamOutcome",
    "StreamService",
    "WaitReply",
    "is_media_command",
]

_NS_PER_MS = 1_000_000
_READS = frozenset(
    {
        "GET_SAMPLE_BY_ID",
        "GET_SAMPLE_BY_TIME",
        "GET_SAMPLES_BY_TIME",
        "GET_NEWEST_DATASAMPLE",
        "GET_OLDEST_DATASAMPLE",
        "GET_NEWEST_TIMESTAMP",
        "GET_OLDEST_TIMESTAMP",
        "GET_COUNT",
        "GET_SIZE",
        "GET_NAME",
        "GET_INFO",
    }
)
_WAITS = frozenset(
    {
        "WAIT_FOR_FIRST_SAMPLE",
        "WAIT_FOR_LAST_SAMPLE",
        "WAIT_FOR_FIRST_AFTERID",
        "WAIT_FOR_LAST_AFTERID",
    }
)
_WRITES = frozenset({"ADD_SAMPLE", "ADD_SAMPLES"})
_TYPED = frozenset({"LOCK_SAMPLES", "UNLOCK_SAMPLES", "SEARCH_SAMPLES"})
_CORE = _READS | _WAITS | _WRITES


def is_media_command(type_: str) -> bool:
    """Return whether `type_` is a media command of spec 11 (a WAIT_FOR_* with its timeout)."""
    return type_.split(" ", 1)[0] in _CORE or type_ in _TYPED


@dataclass(frozen=True, slots=True, kw_only=True)
class PendingWait:
    """A WAIT_FOR_* whose reply is deferred: the adapter times it out at `deadline_ns`."""

    ticket: int
    deadline_ns: int


@dataclass(frozen=True, slots=True, kw_only=True)
class WaitReply:
    """A deferred reply that is ready: send it on `conn`, which may take requests again."""

    conn: ConnId
    ticket: int
    reply: Message


@dataclass(frozen=True, slots=True, kw_only=True)
class SamplePush:
    """A new sample for the push connections `conns` and the subscribed `modules` (11.6)."""

    stream: str
    sample: StoredSample
    conns: tuple[ConnId, ...] = ()
    modules: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True, kw_only=True)
class StreamOutcome:
    """What one stream event asks of the router and the adapter."""

    replies: tuple[Message, ...] = ()
    wait: PendingWait | None = None
    resolved: tuple[WaitReply, ...] = ()
    pushes: tuple[SamplePush, ...] = ()
    alarms: tuple[Alarm, ...] = ()


@dataclass(slots=True)
class _Wait:
    ticket: int
    conn: ConnId
    request: Message
    stream: str
    kind: str  # the command without its timeout
    after_id: int = 0
    after_ms: int = 0


@dataclass(slots=True)
class _StreamState:
    stream: Stream
    push_conns: list[ConnId] = field(default_factory=list)
    waits: list[_Wait] = field(default_factory=list)
    modules: tuple[str, ...] = ()  # registration subscribers (OA-STREAM-14)


class StreamService:
    """Every stream of one server (spec 11)."""

    def __init__(
        self,
        specs: Iterable[StreamSpec],
        *,
        typed: bool,
        noreply: bool,
        max_wait_ms: int,
        reserved: Mapping[str, object] | None = None,
        max_created: int = 0,
        max_created_bytes: int = 0,
    ) -> None:
        self.typed = typed  # OA-XSTREAM-*: the typed-streams extension is advertised
        # OA-LIM-17: streams created at run time, how many and how large (0: unbounded)
        self._max_created = max_created
        self._max_created_bytes = max_created_bytes
        self._created = 0
        self._noreply = noreply
        self._max_wait_ms = max_wait_ms
        self._states: dict[str, _StreamState] = {}
        self._by_type: dict[str, str] = {}  # folded type -> name (OA-XSTREAM-1)
        self._current: dict[ConnId, str] = {}  # a connection's current stream (OA-STREAM-11)
        self._push_of: dict[ConnId, str] = {}
        self._waits: dict[int, _Wait] = {}
        self._tickets = itertools.count(1)
        self._sources: dict[str, tuple[str, ...]] = {}  # module -> inputstream sources
        for spec in specs:
            self._add(spec)

    # --- the streams ------------------------------------------------------------------------

    @property
    def streams(self) -> dict[str, Stream]:
        """The streams by name, in configuration order."""
        return {name: state.stream for name, state in self._states.items()}

    def names(self) -> frozenset[str]:
        """Return the stream names (they share the name space of CNS, OA-SESS-30)."""
        return frozenset(self._states)

    def resolve(self, to: str) -> str | None:
        """Return the name of the stream `to` addresses: a name, else (typed) a type."""
        if to in self._states:
            return to
        if self.typed and to:
            return self._by_type.get(ascii_fold(to))  # OA-XSTREAM-1: a name takes precedence
        return None

    def create(
        self, content: str, *, whiteboards: Iterable[str], taken: Callable[[str], bool]
    ) -> str:
        """Create a stream at run time (OA-XSTREAM-10); return its name.

        `taken(name)` says whether a name is already used by another component.
        Raises ContentInvalidError.
        """
        roots = parse_content(content, ContentInvalidError)
        if len(roots) != 1 or local_name(roots[0]) != "stream":
            raise ContentInvalidError("content must be one <stream name whiteboard …/> element")
        el = roots[0]
        name = (attr(el, "name") or "").strip()
        board = (attr(el, "whiteboard") or "").strip()
        if not name:
            raise ContentInvalidError("<stream> needs a name")
        if taken(name) or name in self._states:
            raise ContentInvalidError(f"the name {name!r} is already in use")
        boards = list(whiteboards)
        if board not in boards:
            raise ContentInvalidError(f"<stream whiteboard={board!r}> names no whiteboard")
        cfg = stream_config(el, name)
        self._check_created(cfg)
        spec = StreamSpec.from_config(cfg, board, typed_streams=self.typed, whiteboards=boards)
        if spec.type is not None and ascii_fold(spec.type) in self._by_type:
            raise ContentInvalidError(f"the stream type {spec.type!r} is already in use")
        self._add(spec)
        self._created += 1
        return name

    def _check_created(self, cfg: StreamConfig) -> None:
        """Refuse a run-time stream past OA-LIM-17 (LIMIT_EXCEEDED, a clear reason)."""
        if self._max_created and self._created >= self._max_created:
            raise LimitExceededError(
                f"{self._created} streams were created at run time; max-created-streams is"
                f" {self._max_created}"
            )
        size = cfg.maxsize * 1024 * 1024
        if self._max_created_bytes and size > self._max_created_bytes:
            raise LimitExceededError(
                f"<stream maxsize={cfg.maxsize:g}> is {size:.0f} bytes; max-created-stream-bytes"
                f" is {self._max_created_bytes}"
            )

    def _add(self, spec: StreamSpec) -> None:
        self._states[spec.name] = _StreamState(stream=Stream(spec))
        if spec.type is not None:
            self._by_type[ascii_fold(spec.type)] = spec.name
        for module, sources in self._sources.items():
            if self._source_matches(sources, spec):
                state = self._states[spec.name]
                state.modules = (*state.modules, module)

    # --- requests ---------------------------------------------------------------------------

    def request(
        self, conn: ConnId, msg: Message, *, received_ns: int, now_ns: int
    ) -> StreamOutcome:
        """Answer a request whose `to` resolved to a stream (spec 11.3-11.7)."""
        name = self.resolve(msg.to)
        assert name is not None, "the router checks resolve() first"
        state = self._states[name]
        base = msg.type.split(" ", 1)[0]
        if base in _CORE or (self.typed and msg.type in _TYPED):
            self._current[conn] = name  # OA-STREAM-11: the connection's current stream
        try:
            if base in _WRITES and base == msg.type:
                return self._write(conn, state, msg, received_ns, now_ns)
            if base in _WAITS:
                return self._wait(conn, state, msg, now_ns)
            if msg.type in _READS:
                return StreamOutcome(replies=(self._read(state.stream, msg, now_ns),))
            if self.typed and msg.type in _TYPED:
                return StreamOutcome(replies=(self._typed(conn, state.stream, msg, now_ns),))
        except OpenAIRError as err:
            return StreamOutcome(replies=(cmd.error_reply(msg, err, sender=name, now_ns=now_ns),))
        return StreamOutcome(replies=(cmd.unknown_command(msg, sender=name, now_ns=now_ns),))

    def binary(
        self, conn: ConnId, chunk: bytes, *, received_ns: int, now_ns: int
    ) -> StreamOutcome | None:
        """Add the sample of a BinaryM frame to the connection's current stream (OA-STREAM-11).

        Returns None when the connection has no current stream.
        """
        name = self._current.get(conn)
        if name is None or name not in self._states:
            return None
        state = self._states[name]
        request = Message.trusted(type="ADD_SAMPLE", id="", sender="", to=name)
        try:
            sample = decode_chunk(chunk)  # OA-STREAM-10
            return self._added(state, request, (sample,), f"conn:{conn}", received_ns, now_ns)
        except SampleInvalidError as err:  # OA-STREAM-5
            reply = cmd.error_reply(request, err, sender=name, now_ns=now_ns)
            return StreamOutcome(replies=(reply,))

    def subscribe_push(self, conn: ConnId, msg: Message) -> str | None:
        """Make `conn` a push connection of the stream `msg.to` names (11.6); None: unknown."""
        name = self.resolve(msg.to)
        if name is None:
            return None
        self._states[name].push_conns.append(conn)
        self._push_of[conn] = name
        return name

    def connection_closed(self, conn: ConnId) -> None:
        """Forget a connection: its current stream, waits, push subscription and locks."""
        self._current.pop(conn, None)
        name = self._push_of.pop(conn, None)
        if name is not None:
            self._states[name].push_conns.remove(conn)
        for state in self._states.values():
            if state.waits:
                state.waits = [w for w in state.waits if w.conn != conn]
            state.stream.release(conn)  # OA-XSTREAM-5: locks end with their connection
        for ticket in [t for t, w in self._waits.items() if w.conn == conn]:
            del self._waits[ticket]

    def wait_expired(self, ticket: int, now_ns: int) -> WaitReply | None:
        """Answer a wait whose timeout passed with SAMPLE_UNKNOWN (OA-STREAM-7); None if done."""
        wait = self._waits.pop(ticket, None)
        if wait is None:
            return None
        state = self._states[wait.stream]
        state.waits = [w for w in state.waits if w.ticket != ticket]
        err = SampleUnknownError(f"no sample arrived before the timeout of {wait.request.type}")
        reply = cmd.error_reply(wait.request, err, sender=wait.stream, now_ns=now_ns)
        return WaitReply(conn=wait.conn, ticket=ticket, reply=reply)

    def tick(self, now_ns: int) -> tuple[Alarm, ...]:
        """Return the Idle alarms that fell due (OA-XSTREAM-7)."""
        alarms = []
        for state in self._states.values():
            due = state.stream.idle_due_ns()
            if due is not None and due <= now_ns:
                alarm = state.stream.tick(now_ns)
                if alarm is not None:
                    alarms.append(alarm)
        return tuple(alarms)

    def next_tick_ns(self) -> int | None:
        """Return when the next Idle alarm falls due, if any stream has one armed."""
        dues = [d for s in self._states.values() if (d := s.stream.idle_due_ns()) is not None]
        return min(dues) if dues else None

    # --- module subscriptions (OA-STREAM-14) -------------------------------------------------

    def set_registration(self, module: str, reg: Registration | None) -> None:
        """Subscribe `module` to the streams its registration's phase names as inputs."""
        phase = reg.active_phase if reg is not None else None
        sources = tuple(
            s.source
            for s in (phase.streams if phase is not None else ())
            if s.kind != "outputstream" and s.source
        )
        if sources:
            self._sources[module] = sources
        else:
            self._sources.pop(module, None)
        for state in self._states.values():
            wanted = bool(sources) and self._source_matches(sources, state.stream.spec)
            kept = tuple(m for m in state.modules if m != module)
            state.modules = (*kept, module) if wanted else kept

    def _source_matches(self, sources: Sequence[str], spec: StreamSpec) -> bool:
        for source in sources:
            if source == spec.name:
                return True
            if self.typed and spec.type is not None and _type_matches(source, spec.type):
                return True
        return False

    def subscribers(self, name: str) -> int:
        """Count the push connections and module subscriptions of a stream."""
        state = self._states[name]
        return len(state.push_conns) + len(state.modules)

    # --- listing (OA-STREAM-16) ---------------------------------------------------------------

    def info(self, name: str) -> str:
        """Return the `<streaminfo>` of a stream."""
        state = self._states[name]
        attrs = state.stream.info()
        attrs["subscribers"] = str(self.subscribers(name))
        attrs["writers"] = str(len(state.stream.writers))
        return serialize(element("streaminfo", attrs.items()))

    def listing(self) -> str:
        """Return `<streams>` with every stream's `<streaminfo>` (the STREAMS reply)."""
        return "<streams>" + "".join(self.info(n) for n in self._states) + "</streams>"

    # --- writing ------------------------------------------------------------------------------

    def _write(
        self, conn: ConnId, state: _StreamState, msg: Message, received_ns: int, now_ns: int
    ) -> StreamOutcome:
        name = state.stream.name
        try:
            samples = samples_of(msg)
        except SampleInvalidError as err:  # OA-STREAM-5: nothing added
            return StreamOutcome(replies=(cmd.error_reply(msg, err, sender=name, now_ns=now_ns),))
        writer = msg.sender or f"conn:{conn}"
        try:
            return self._added(state, msg, samples, writer, received_ns, now_ns)
        except SampleInvalidError as err:
            return StreamOutcome(replies=(cmd.error_reply(msg, err, sender=name, now_ns=now_ns),))

    def _added(
        self,
        state: _StreamState,
        msg: Message,
        samples: Sequence[DataSample],
        writer: str,
        received_ns: int,
        now_ns: int,
    ) -> StreamOutcome:
        """Add samples (all or nothing), then answer the waits they satisfy and push them."""
        stream = state.stream
        result = stream.add(samples, writer=writer, received_ns=received_ns)  # may raise
        ids = [s.id for s in result.stored]
        if msg.type == "ADD_SAMPLES":
            entries = "".join(f"<entry>{i}</entry>" for i in ids)
            content, xml = f"<collection>{entries}</collection>", True
        else:
            content, xml = str(ids[0]), False
        replies: tuple[Message, ...] = ()
        if not (msg.noreply and self._noreply):  # OA-MSG-15
            ack = cmd.reply(
                msg, "DATA_ACCEPTED", sender=stream.name, now_ns=now_ns, content=content, xml=xml
            )
            replies = (ack,)
        pushes = tuple(
            SamplePush(
                stream=stream.name,
                sample=stored,
                conns=tuple(state.push_conns),
                modules=state.modules,
            )
            for stored in result.stored
            if state.push_conns or state.modules
        )
        return StreamOutcome(
            replies=replies,
            resolved=self._satisfy(state, now_ns),
            pushes=pushes,
            alarms=result.alarms,
        )

    # --- reading ------------------------------------------------------------------------------

    def _read(self, stream: Stream, msg: Message, now_ns: int) -> Message:
        kind = msg.type
        name = stream.name
        if kind == "GET_COUNT":
            return cmd.reply(msg, "COUNT", sender=name, now_ns=now_ns, content=str(stream.count))
        if kind == "GET_SIZE":
            return cmd.reply(msg, "SIZE", sender=name, now_ns=now_ns, content=str(stream.size))
        if kind == "GET_NAME":
            return cmd.reply(msg, "NAME", sender=name, now_ns=now_ns, content=name)
        if kind == "GET_INFO":
            return cmd.reply(
                msg, "INFO", sender=name, now_ns=now_ns, content=self.info(name), xml=True
            )
        if kind in ("GET_NEWEST_TIMESTAMP", "GET_OLDEST_TIMESTAMP"):
            found = stream.newest() if kind == "GET_NEWEST_TIMESTAMP" else stream.oldest()
            if found is None:
                raise SampleUnknownError(f"stream {name!r} holds no sample")
            time = encode_time("time", AirTime.from_ms(found.timestamp_ms))
            return cmd.reply(msg, "TIMESTAMP", sender=name, now_ns=now_ns, content=time, xml=True)
        if kind == "GET_SAMPLES_BY_TIME":
            low, high = time_pair(msg.content)
            return samples_reply(msg, stream.between(low, high), sender=name, now_ns=now_ns)
        return sample_reply(msg, _one(stream, msg), sender=name, now_ns=now_ns)

    def _typed(self, conn: ConnId, stream: Stream, msg: Message, now_ns: int) -> Message:
        name = stream.name
        if msg.type == "SEARCH_SAMPLES":
            after, until, params, latest, payload = sample_search(msg.content)
            found = stream.search(
                after_ms=after, until_ms=until, params=params, latest=latest, payload=payload
            )
            return samples_reply(msg, found, sender=name, now_ns=now_ns)  # OA-XSTREAM-9
        if msg.type == "LOCK_SAMPLES":
            first, last = id_range(msg.content)
            lock_id = stream.lock(first, last, conn)  # OA-XSTREAM-5
            return cmd.reply(msg, "LOCKED", sender=name, now_ns=now_ns, content=str(lock_id))
        lock_id = integer_content(msg.content, "lock id")
        if not stream.unlock(lock_id, conn):
            raise LockUnknownError(f"no lock {lock_id} of this connection on {name!r}")
        return cmd.reply(msg, "RECEIVE_ACCEPT", sender=name, now_ns=now_ns)

    # --- waiting (OA-STREAM-7) ------------------------------------------------------------

    def _wait(self, conn: ConnId, state: _StreamState, msg: Message, now_ns: int) -> StreamOutcome:
        kind, _, suffix = msg.type.partition(" ")
        timeout = parse_integer(suffix) if suffix.strip() == suffix and suffix else None
        if timeout is None or timeout < 0:
            raise MessageInvalidError(
                f"{kind} needs a timeout in ms after one space, not {suffix!r}"
            )
        wait = _Wait(
            ticket=next(self._tickets), conn=conn, request=msg, stream=state.stream.name, kind=kind
        )
        if kind.endswith("AFTERID"):
            wait.after_id = integer_content(msg.content, "sample id")
        else:
            wait.after_ms = time_ms(msg.content)
        found = _satisfying(state.stream, wait)
        if found is not None:
            return StreamOutcome(
                replies=(sample_reply(msg, found, sender=wait.stream, now_ns=now_ns),)
            )
        timeout = min(timeout, self._max_wait_ms)
        state.waits.append(wait)
        self._waits[wait.ticket] = wait
        return StreamOutcome(
            wait=PendingWait(ticket=wait.ticket, deadline_ns=now_ns + timeout * _NS_PER_MS)
        )

    def _satisfy(self, state: _StreamState, now_ns: int) -> tuple[WaitReply, ...]:
        """Answer the waits that the samples just added satisfy."""
        if not state.waits:
            return ()
        ready: list[WaitReply] = []
        pending: list[_Wait] = []
        for wait in state.waits:
            found = _satisfying(state.stream, wait)
            if found is None:
                pending.append(wait)
                continue
            del self._waits[wait.ticket]
            reply = sample_reply(wait.request, found, sender=wait.stream, now_ns=now_ns)
            ready.append(WaitReply(conn=wait.conn, ticket=wait.ticket, reply=reply))
        state.waits = pending
        return tuple(ready)


def _one(stream: Stream, msg: Message) -> StoredSample:
    """Find the one sample a GET_SAMPLE_BY_* / GET_*_DATASAMPLE asks for (OA-STREAM-6)."""
    kind = msg.type
    if kind == "GET_SAMPLE_BY_ID":
        found = stream.by_id(integer_content(msg.content, "sample id"))
    elif kind == "GET_SAMPLE_BY_TIME":
        found = stream.at_or_before(time_ms(msg.content))
    elif kind == "GET_NEWEST_DATASAMPLE":
        found = stream.newest()
    else:
        found = stream.oldest()
    if found is None:
        raise SampleUnknownError(
            f"no sample of {stream.name!r} matches {kind} {msg.content[:40]!r}"
        )
    return found


def _satisfying(stream: Stream, wait: _Wait) -> StoredSample | None:
    if wait.kind == "WAIT_FOR_FIRST_AFTERID":
        return stream.first_after_id(wait.after_id)
    if wait.kind == "WAIT_FOR_LAST_AFTERID":
        return stream.last_after_id(wait.after_id)
    if wait.kind == "WAIT_FOR_FIRST_SAMPLE":
        return stream.first_at_or_after(wait.after_ms)
    return stream.last_at_or_after(wait.after_ms)


def _type_matches(source: str, stream_type: str) -> bool:
    """Match a registration's source against a stream type: equal, or a pattern (OA-STREAM-14)."""
    if ascii_fold(source) == ascii_fold(stream_type):
        return True
    try:
        validate_pattern(source)
    except OpenAIRError:
        return False
    return matches(source, stream_type)
