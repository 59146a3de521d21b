"""The sans-I/O router of the reference server: sessions, whiteboards, registrations, wakeups.

`Router.handle()` takes one decoded request and returns an `Outcome`: the replies to send on
that connection (in order, OA-SESS-2), the deliveries to queue per module, and connections to
close. No sockets, no clock reads: the adapter passes `received_ns` (when the frame arrived,
OA-TIME-3) and `now_ns` (for replies' postedTime). Every component lives on the main port and
is addressed by `to` (OA-SESS-9, OA-SESS-26).

The post path is lean: one dict lookup to find the whiteboard, one cached type check, one store
append, one `PatternIndex.match` over the triggers of every registration, and a wakeup per
woken module (OA-WAKE-5).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace

from openair.protocol.auth import AUTH_ACCEPT, AUTH_NONCE
from openair.protocol.content import ANY_WHITEBOARD, Dictionary, Phase, Registration, TcpLocation
from openair.protocol.errors import (
    BindRefusedError,
    LimitExceededError,
    MessageInvalidError,
    OpenAIRError,
    ShuttingDownError,
    StoreFailedError,
    StreamUnknownError,
    TypeInvalidError,
)
from openair.protocol.framing import FrameTag
from openair.protocol.matching import PatternIndex, ascii_fold
from openair.protocol.message import Message
from openair.protocol.objects import encode_dictionary, encode_tcplocation
from openair.protocol.registration import parse_registration
from openair.protocol.times import AirTime
from openair.protocol.types import validate_type
from openair.protocol.wakeup import (
    EncodedCopies,
    assemble_wakeup,
    attach_wakeup,
    build_wakeup,
    collection_xml,
    fit_attachments,
    phase_spec_xml,
)
from openair.server.core import commands as cmd
from openair.server.core.auth import AuthGate
from openair.server.core.config import (
    AIRCENTRAL,
    DEFAULT_WB_PRIORITY,
    SYSTEM_COMPONENTS,
    ConfigError,
    ServerConfig,
    ServerLimits,
)
from openair.server.core.contexts import PHASE_CHANGE, Contexts, context_of
from openair.server.core.queues import item_bytes
from openair.server.core.retrieve import RETRIEVE, RETRIEVES, prepare_retrieve, registration_results
from openair.server.core.sessions import ConnId, ModuleInfo, Sessions
from openair.server.core.store import HistoryStore
from openair.server.core.streams import Alarm, StreamSpec
from openair.server.core.streamservice import (
    PendingWait,
    SamplePush,
    StreamOutcome,
    StreamService,
    WaitReply,
    is_media_command,
)
from openair.server.core.whiteboard import Whiteboard, derive

__all__ = [
    "ConnId",
    "Delivery",
    "ModuleInfo",
    "Outcome",
    "PendingWait",
    "Router",
    "SamplePush",
    "WaitReply",
]

_NS_PER_MS = 1_000_000
_TYPE_CACHE_SIZE = 4096
_PHASE_CACHE_SIZE = 256  # PhaseSpec texts kept per registration (one per lasttrigger)
_SYSTEM = "Psyclone"  # the sender of lifecycle notices (OA-SESS-15, OA-SESS-31)
_PHASE_SENDER = "ContextsAndPhases"  # the sender of phase updates (OA-WAKE-9)


@dataclass(frozen=True, slots=True, kw_only=True)
class Delivery:
    """A message to queue for one module (6.6): due at `due_ns`, ordered by priority (10)."""

    module: str
    message: Message
    due_ns: int
    priority: float  # the carried message's effective priority (OA-PRIO-1)
    wb_priority: float  # the sending whiteboard's priority (OA-PRIO-2)
    # The Message frame of `message` when the router already wrote it (a wakeup), else None.
    wire: bytes | None = field(default=None, compare=False, repr=False)
    expires_ns: int = 0  # OA-DELIV-14: dropped when still unsent at this time (0: never)
    # A wakeup's stored trigger message, for internal modules (OA-CONF-8: no XML to parse).
    trigger: Message | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True, slots=True, kw_only=True)
class Outcome:
    """What the adapter does after one event.

    `discard_queues` names modules whose session ended (OA-SESS-15): drop their queued
    deliveries.
    """

    replies: tuple[Message, ...] = ()
    deliveries: tuple[Delivery, ...] = ()
    close_conns: tuple[ConnId, ...] = ()
    close_this: bool = False
    discard_queues: tuple[str, ...] = ()
    # Streams (spec 11): this request's reply is deferred (a WAIT_FOR_*, OA-STREAM-7); deferred
    # replies now ready, on any connection; samples to push (OA-STREAM-8, OA-STREAM-14); and the
    # stream this connection now receives pushes from (its Receive frame, 11.6).
    wait: PendingWait | None = None
    resolved: tuple[WaitReply, ...] = ()
    pushes: tuple[SamplePush, ...] = ()
    push_stream: str = ""
    # A reply too large to write on the event loop (issue #19, item 6): instead of `replies`,
    # a function that builds it and its frame on any thread. Only with `defer_large_replies`.
    later: Callable[[], tuple[Message, bytes | None]] | None = None


#: STATUS with counters of at least this many module names is written off the loop (issue #19).
_LARGE_STATUS = 2048


@dataclass(slots=True)
class _Triggers:
    """The indexed triggers of one module's registration in force."""

    registration: Registration
    # Per trigger: its pattern, its whiteboard folded ("" = any, OA-TRIG-2), its after (ms).
    entries: tuple[tuple[str, str, int], ...]
    allow_self: bool
    phase: Phase | None  # the registration's phase in force (OA-REG-10)
    # PhaseSpec XML of the phase in force, by lasttrigger (the registration never changes here).
    phase_xml: dict[str, str] = field(default_factory=dict)


@dataclass(slots=True)
class _ModuleCounters:
    requests: int = 0  # requests whose `from` named the module while it was bound
    queued: int = 0  # deliveries the router decided for it
    delivered: int = 0  # note_delivered()
    dropped: int = 0  # note_dropped()


Handler = Callable[[ConnId, Message, int, int], Outcome]


class Router:
    """The whole server behind the sockets (spec sections 6–10, 15)."""

    def __init__(
        self,
        config: ServerConfig,
        store: HistoryStore,
        *,
        server_name: str,
        address: str,
        port: int,
        limits: ServerLimits,
        extensions: frozenset[str],
        port_allocator: Callable[[int], int] | None = None,
        auth: AuthGate | None = None,
    ) -> None:
        self.config = config
        self._auth = auth  # secure mode (14.3); None: legacy
        self.server_name = server_name
        #: Extra counters (the adapter's queues) that STATUS reports beside the router's own.
        self.status_extra: Callable[[], Mapping[str, object]] | None = None
        #: The bytes the adapter's delivery queues hold, for the held-bytes budget (OA-LIM-14).
        self.queued_bytes: Callable[[], int] | None = None
        #: Called with (whiteboard, stored message, its deliveries) after every stored post; the
        #: web monitor's tap. It must do O(1) work and never raise (routing waits for it).
        self.observer: Callable[[str, Message, tuple[Delivery, ...]], None] | None = None
        # The adapter writes large replies on a worker thread (Outcome.later, issue #19).
        self.defer_large_replies = False
        self.address = address
        self.port = port
        self.limits = limits
        self.extensions = extensions
        self.server_id = cmd.fresh_id()  # OA-SESS-14: stays the same for the server's lifetime
        self.started_ns: int | None = None
        self._store = store
        self._noreply = "noreply" in extensions
        self._qos = "qos" in extensions  # OA-DELIV-14, OA-TRIG-5
        self._shutting_down = False
        self._whiteboards = {
            wb.name: Whiteboard.from_config(wb, store, max_bytes=limits.max_history_bytes)
            for wb in config.whiteboards
        }
        typed = "typed-streams" in extensions
        self.streams = StreamService(
            _stream_specs(config, typed=typed),
            typed=typed,
            noreply=self._noreply,
            max_wait_ms=limits.max_wait_ms,
            max_created=limits.max_created_streams,  # OA-LIM-17
            max_created_bytes=limits.max_created_stream_bytes,
        )
        self._configured = {m.name: m.registration for m in config.modules}  # OA-CONF-5
        self._sessions = Sessions(reserved=self._reserved, port_allocator=port_allocator)
        self._modules = self._sessions.modules  # the same dict: bound modules by name
        self._subscribed: dict[str, Registration] = {}  # AIR.Subscribe wins over the config
        self._index: PatternIndex[tuple[str, int]] = PatternIndex()
        self._triggers: dict[str, _Triggers] = {}
        self._valid_types: set[str] = set()
        self._counters: dict[str, _ModuleCounters] = {}
        self._gone: dict[str, int] = {}  # unbound names with counters -> when they were seen gone
        self._lost_notices = 0
        self._copies = EncodedCopies()
        # Spec 8.9: the active contexts and phase sequencing; None without the extension.
        self._contexts = Contexts() if "contexts" in extensions else None
        self._internal: set[str] = set()  # names held by internal modules (OA-CONF-8)
        for name in self._configured:
            self._reindex(name)
        self._components = self._component_tables()

    # --- public API -----------------------------------------------------------------------

    def start(self, now_ns: int) -> Outcome:
        """Post `Psyclone.Context:Psyclone.System.Ready` to AIRCentral (OA-SESS-31), once.

        The adapter calls it when listening; otherwise the first event does.
        """
        if self.started_ns is not None:
            return Outcome()
        self.started_ns = now_ns
        return Outcome(deliveries=self._notice("Psyclone.Context:Psyclone.System.Ready", now_ns))

    def connection_opened(self, conn: ConnId, *, address: str) -> None:
        """Note the peer address of a connection (the module's address, OA-DELIV-1, OA-SESS-4)."""
        self._sessions.opened(conn, address)

    def handle(
        self, conn: ConnId, msg: Message, *, tag: FrameTag, received_ns: int, now_ns: int
    ) -> Outcome:
        """Answer one request (spec 6–9, 15); `tag` RECEIVE marks a callback (OA-SESS-7)."""
        started = self.start(now_ns) if self.started_ns is None else None
        outcome = self._dispatch(conn, msg, tag, received_ns, now_ns)
        if started is not None and started.deliveries:
            outcome = replace(outcome, deliveries=started.deliveries + outcome.deliveries)
        if msg.noreply and self._noreply and (outcome.replies or outcome.later):
            outcome = replace(outcome, replies=(), later=None)  # OA-MSG-15, OA-WB-8: no reply
        return outcome

    def connection_closed(self, conn: ConnId, *, now_ns: int) -> Outcome:
        """Forget a connection; a primary one loses its modules (OA-SESS-15)."""
        self.streams.connection_closed(conn)  # its waits, push subscription and locks end
        if self._auth is not None:
            self._auth.closed(conn)  # OA-AUTH-4: proofs end with the connection
        names, close = self._sessions.closed(conn)  # their callbacks are closed too
        if not names:
            return Outcome()
        for name in names:
            if self._subscribed.pop(name, None) is not None:  # OA-SESS-15: registration removed
                self._reindex(name)  # the configured one, if any, is in force again (OA-CONF-5)
        deliveries: list[Delivery] = []
        if not self._shutting_down:
            for name in names:
                deliveries.extend(self._notice(f"Psyclone.Module.Lost.{name}", now_ns))
        return Outcome(deliveries=tuple(deliveries), close_conns=close, discard_queues=tuple(names))

    def forget_gone(self, now_ns: int, retention_ns: int) -> int:
        """Forget the counters of modules unbound for `retention_ns` or more (OA-LIM-15).

        Call it now and then: a name is seen gone at the first call that finds it unbound, and
        forgotten at the first call `retention_ns` after that. Return how many were forgotten.
        """
        forgotten = 0
        for name in [n for n in self._counters if n not in self._modules]:
            since = self._gone.setdefault(name, now_ns)
            if now_ns - since >= retention_ns:
                del self._counters[name]
                del self._gone[name]
                forgotten += 1
        for name in [n for n in self._gone if n in self._modules]:
            del self._gone[name]  # bound again: its counters count on
        return forgotten

    def hold(self, name: str) -> None:
        """Refuse every later BIND of `name`: an internal module is bound to it (OA-CONF-8)."""
        self._internal.add(name)

    def module(self, name: str) -> ModuleInfo | None:
        """Return the bound module `name` (exact case), or None."""
        return self._modules.get(name)

    def whiteboard(self, name: str) -> Whiteboard | None:
        """Return the whiteboard `name` (exact case, OA-WB-10), or None."""
        return self._whiteboards.get(name)

    def registration(self, name: str) -> Registration | None:
        """Return the registration in force for `name`: subscribed, else configured."""
        return self._subscribed.get(name) or self._configured.get(name)

    def note_delivered(self, module: str) -> None:
        """Count one delivery the adapter completed for `module`."""
        self._module_counters(module).delivered += 1

    def note_dropped(self, module: str, n: int = 1) -> None:
        """Count deliveries the adapter dropped for `module` (OA-DELIV-7, OA-DELIV-9)."""
        self._module_counters(module).dropped += n

    def counters(self) -> dict[str, object]:
        """Return counters per whiteboard and per module, and a registration summary."""
        boards = {
            wb.name: {
                "received": wb.received,
                "stored": wb.stored,
                "dispatched": wb.dispatched,
                "evicted": wb.evicted,
                "count": len(wb),
                "next_wbid": wb.next_wbid,
            }
            for wb in self._whiteboards.values()
        }
        modules = {
            name: {
                "bound": name in self._modules,
                "requests": c.requests,
                "queued": c.queued,
                "delivered": c.delivered,
                "dropped": c.dropped,
            }
            for name, c in sorted(self._counters.items())
        }
        registrations = {
            name: {"triggers": len(t.entries), "retrieves": len(t.registration.retrieves)}
            for name, t in sorted(self._triggers.items())
        }
        streams = {
            name: {
                **stream.info(),
                "added": stream.added_total,
                "dropped": stream.dropped_total,
                "subscribers": self.streams.subscribers(name),
            }
            for name, stream in self.streams.streams.items()
        }
        return {
            "whiteboards": boards,
            "streams": streams,
            "modules": modules,
            "registrations": registrations,
            "bound": len(self._modules),
            "triggers": len(self._index),
            "notices_failed": self._lost_notices,
        }

    def shutting_down(self) -> None:
        """Refuse every later request with SHUTTING_DOWN and close its connection (OA-SESS-24)."""
        self._shutting_down = True

    # --- dispatch -------------------------------------------------------------------------

    def _dispatch(
        self, conn: ConnId, msg: Message, tag: FrameTag, received_ns: int, now_ns: int
    ) -> Outcome:
        if self._shutting_down:  # OA-SESS-24
            return self._refuse_shutting_down(msg, now_ns)
        if self._auth is not None:
            refused = self._auth_screen(conn, msg, tag, now_ns)  # OA-AUTH-5, -6, -8
            if refused is not None:
                return refused
        if tag is FrameTag.RECEIVE:
            return self._receive_frame(conn, msg, now_ns)
        if msg.sender in self._modules:
            self._module_counters(msg.sender).requests += 1
        board = self._whiteboards.get(msg.to)
        if board is not None:
            return self._to_whiteboard(board, msg, received_ns, now_ns)
        table = self._components.get(msg.to or "CNS")  # OA-SESS-26: empty `to` is CNS
        if table is not None:
            handler = table.get(msg.type)
            if handler is None:  # OA-SESS-20, OA-SESS-29
                sender = msg.to or "CNS"
                return Outcome(replies=(cmd.unknown_command(msg, sender=sender, now_ns=now_ns),))
            return handler(conn, msg, received_ns, now_ns)
        if msg.to in self._modules:
            return self._forward(msg, received_ns, now_ns)
        if self.streams.resolve(msg.to) is not None:
            return self._to_stream(conn, msg, received_ns, now_ns)
        if is_media_command(msg.type):  # OA-STREAM-3: not FORWARD_FAILED
            return self._no_stream(msg, now_ns)
        return Outcome(replies=(cmd.forward_failed(msg, now_ns=now_ns),))  # OA-SESS-21

    def _refuse_shutting_down(self, msg: Message, now_ns: int) -> Outcome:
        """Answer SHUTTING_DOWN and close the connection (OA-SESS-24)."""
        err = ShuttingDownError("the server is shutting down")
        return Outcome(replies=(self._error(msg, err, "CNS", now_ns),), close_this=True)

    def _component_tables(self) -> dict[str, dict[str, Handler]]:
        """Return each system component's commands (spec 6.2)."""
        session = {"PING": self._ping, "KEEPALIVE": self._keepalive}  # OA-SESS-10, OA-KEEP-2
        cns: dict[str, Handler] = {
            **session,
            "BIND": self._bind,
            "BIND_NOLISTEN": self._bind,
            "RECEIVE_NAME_NOTIFICATION": self._notification_in_message,
            "RESOLVE_REQUEST": self._resolve,
            "GET_STREAMS": self._get_streams,
            "STATUS": self._status,
            "GET_CAPABILITIES": self._capabilities,
        }
        if "gettime" in self.extensions:
            cns["GET_TIME"] = self._time  # OA-EXT-2 (only when advertised, OA-CAP-3)
        if self._auth is not None:  # OA-AUTH-2, OA-AUTH-3; legacy: UNKNOWN_COMMAND
            cns["AUTH_CHALLENGE"] = self._auth_challenge
            cns["AUTH_RESPONSE"] = self._auth_response
        return {
            "CNS": cns,
            "Config": {**session, "GET_ENTRY": self._entry},
            "Psyclone": {
                **session,
                "Psyclone.Module.Request.CurrentPhase": self._current_phase,
                **(
                    {"Psyclone.System.Create.Stream": self._create_stream}
                    if self.streams.typed
                    else {}
                ),
            },
            "AIRServer": {
                **session,
                "GET_ID": self._get_id,
                "GET_NAME": self._get_name,
                "System.PerfStat": self._perfstat,
            },
            "ContextsAndPhases": dict(session),
        }

    def _to_whiteboard(
        self, board: Whiteboard, msg: Message, received_ns: int, now_ns: int
    ) -> Outcome:
        """Serve a whiteboard command or take a post (OA-WB-2)."""
        kind = msg.type
        if kind == "AIR.Subscribe":
            return self._subscribe(board, msg, now_ns)
        if kind in (RETRIEVE, RETRIEVES):
            caught_up = self._adopted(board, board.sync(), now_ns)  # OA-CLU-3
            prepared = prepare_retrieve(
                msg,
                board,
                self._whiteboards,
                now_ns=now_ns,
                max_xml=self.limits.max_frame_xml,
                max_binary=self.limits.max_frame_binary,  # OA-RET-15, OA-RET-19
            )
            if self.defer_large_replies and prepared.large:  # written off the loop (issue #19)
                return Outcome(later=prepared.build, deliveries=caught_up)
            answer = prepared.build()[0]
            return Outcome(replies=(answer,), deliveries=caught_up)
        if kind == "PING" or kind == "KEEPALIVE":
            return self._session_reply(msg, board.name, now_ns)
        return self._post(board, msg, received_ns, now_ns)

    # --- posts and wakeups ----------------------------------------------------------------

    def _post(self, board: Whiteboard, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Store a post, decide its wakeups, then acknowledge it (spec 7.3, OA-WB-3)."""
        board.received += 1
        if msg.type not in self._valid_types:
            try:
                self._check_type(msg.type)  # OA-TYPE-3, OA-TYPE-4
            except TypeInvalidError as err:
                return Outcome(replies=(self._error(msg, err, board.name, now_ns),))
        over = self._over_budget(board, msg)
        if over is not None:  # OA-LIM-14: refused before it is stored, so never acknowledged
            return Outcome(replies=(self._error(msg, over, board.name, now_ns),))
        try:
            if msg.noreply and self._noreply and board.sequenced:
                board.post_later(msg, received_ns)  # OA-CLU-5: routed when it comes back
                return Outcome()
            stored = board.store_post(msg, received_ns)  # OA-TIME-3, OA-WB-4, OA-WB-5
        except StoreFailedError as err:  # OA-WB-3: not stored, so not acknowledged
            return Outcome(replies=(self._error(msg, err, board.name, now_ns),))
        deliveries = self._adopted(board, board.adopted, now_ns)  # OA-CLU-4: earlier posts
        deliveries += self._stored(board, stored, now_ns)
        if msg.noreply and self._noreply:  # OA-MSG-15, OA-WB-8: handle() would drop the ack
            return Outcome(deliveries=deliveries)
        ack = cmd.reply(msg, "RECEIVE_ACCEPT", sender=board.name, now_ns=now_ns)  # OA-WB-3
        return Outcome(replies=(ack,), deliveries=deliveries)

    def _stored(self, board: Whiteboard, stored: Message, now_ns: int) -> tuple[Delivery, ...]:
        """Decide the wakeups of one stored copy and show it to the observer."""
        if self._contexts is not None and (
            stored.type == PHASE_CHANGE or stored.type.startswith("Psyclone.Context:")
        ):  # OA-REG-18: the change comes first, then the post's own wakeups
            deliveries = self._context_post(board, stored, now_ns)
        else:
            deliveries = self._decide(board, stored, now_ns)
        if self.observer is not None:
            self.observer(board.name, stored, deliveries)
        return deliveries

    def _adopted(
        self, board: Whiteboard, copies: list[Message], now_ns: int
    ) -> tuple[Delivery, ...]:
        """Decide the wakeups of copies other servers of a cluster stored (OA-CLU-4)."""
        if not copies:
            return ()
        board.adopted = []
        deliveries: tuple[Delivery, ...] = ()
        for stored in copies:
            deliveries += self._stored(board, stored, now_ns)
        return deliveries

    def adopt_stored(self, now_ns: int) -> Outcome:
        """Take the posts other servers of a cluster stored, with their wakeups (OA-CLU-4)."""
        deliveries: tuple[Delivery, ...] = ()
        for board in self._whiteboards.values():
            deliveries += self._adopted(board, board.adopt(), now_ns)
        return Outcome(deliveries=deliveries) if deliveries else Outcome()

    def bound_names(self) -> tuple[str, ...]:
        """The names of the modules bound to this server now (a cluster node announces them)."""
        return tuple(self._modules)

    def others_lost(self, names: Iterable[str], now_ns: int) -> tuple[Outcome, list[str]]:
        """Post `Psyclone.Module.Lost.<name>` for modules of a dead cluster node (OA-CLU-7).

        Returns the outcome and the names whose notice could not be stored (to try again).
        """
        deliveries: list[Delivery] = []
        failed: list[str] = []
        for name in names:
            if name in self._modules:
                continue  # bound here again: not lost
            before = self._lost_notices
            deliveries.extend(self._notice(f"Psyclone.Module.Lost.{name}", now_ns))
            if self._lost_notices != before:
                failed.append(name)
        return (Outcome(deliveries=tuple(deliveries)) if deliveries else Outcome()), failed

    def _over_budget(self, board: Whiteboard, msg: Message) -> LimitExceededError | None:
        """Refuse a post that would take the bytes held past `max-held-bytes` (OA-LIM-14).

        Held: every whiteboard's stored copies and every delivery queue; what storing the post
        evicts from its own whiteboard (OA-LIM-10) is counted as freed.
        """
        size = item_bytes(msg, None)
        held = sum(b.bytes for b in self._whiteboards.values())
        if self.queued_bytes is not None:
            held += self.queued_bytes()
        if board.max_bytes:
            held -= max(0, min(board.bytes, board.bytes + size - board.max_bytes))
        limit = self.limits.max_held_bytes
        if held + size <= limit:
            return None
        return LimitExceededError(
            f"the server holds {held} bytes; storing {size} more would pass max-held-bytes"
            f" ({limit}); try again later"
        )

    def _check_type(self, type_: str) -> None:
        limits = self.limits
        validate_type(type_, max_bytes=limits.max_type_bytes, max_segments=limits.max_type_segments)
        if len(self._valid_types) < _TYPE_CACHE_SIZE:
            self._valid_types.add(type_)

    def _decide(self, board: Whiteboard, stored: Message, now_ns: int) -> tuple[Delivery, ...]:
        """Decide the wakeups of a stored message (spec 8.6) against the registrations now."""
        chosen = self._woken(board, stored)
        if not chosen:
            return ()
        base_ns = board.last_received_ns  # the receivedTime stamped on `stored`
        posted = cmd.ms_time(now_ns)
        trigger_xml = self._copies.xml(stored)  # the stored copy is written once per post
        attached, limits = bool(stored.binary), self.limits  # OA-WB-13: its attachments
        deliveries: list[Delivery] = []
        for name in sorted(chosen) if len(chosen) > 1 else chosen:
            after, pattern = chosen[name]
            reg = self.registration(name)
            triggers = self._triggers.get(name)
            if triggers is not None and triggers.registration is reg:
                phase = triggers.phase
            else:
                phase = self._phase_in_force(name, reg)
            retrieved: Sequence[Message] = (
                registration_results(
                    phase.retrieves,
                    board,
                    self._whiteboards,
                    now_ns=now_ns,
                    max_count=limits.max_wakeup_results,  # OA-LIM-9
                    max_bytes=limits.max_wakeup_result_bytes,
                )
                if phase is not None and phase.retrieves
                else ()
            )  # OA-WAKE-7
            omitted, chunked = 0, attached or any(m.binary for m in retrieved)
            if chunked:  # OA-WAKE-11: leave retrieved messages out until the chunks fit
                retrieved, omitted = fit_attachments(stored, retrieved, limits.max_frame_binary)
            wakeup, wire = assemble_wakeup(
                trigger_xml=trigger_xml,
                retrieved_xml=collection_xml(retrieved, self._copies),
                # OA-WAKE-4: an empty phase without a registration
                phase_xml=self._phase_xml(name, reg, phase, pattern),
                whiteboard=board.name,
                module=name,
                id=cmd.fresh_id(),
                posted=posted,
            )
            if chunked:
                wakeup = attach_wakeup(wakeup, stored, retrieved, omitted)  # OA-WAKE-10
                wire = None  # the spliced frame has no chunks: the sender writes it
            deliveries.append(
                Delivery(
                    module=name,
                    message=wakeup,
                    due_ns=base_ns + after * _NS_PER_MS,  # OA-TRIG-3
                    priority=stored.effective_priority,  # OA-PRIO-1
                    wb_priority=board.priority,  # OA-PRIO-2
                    wire=wire,
                    expires_ns=self._expiry(stored, base_ns),  # OA-DELIV-14
                    trigger=stored,
                )
            )
            self._module_counters(name).queued += 1
        board.dispatched += len(deliveries)
        return tuple(deliveries)

    def _expiry(self, msg: Message, received_ns: int) -> int:
        """Return when a delivery of `msg` expires under `qos` (OA-DELIV-14); 0 means never."""
        ttl = msg.timetolive
        if not self._qos or ttl is None or not ttl > 0:
            return 0
        return received_ns + round(ttl * _NS_PER_MS)

    def _phase_xml(
        self, name: str, reg: Registration | None, phase: Phase | None, lasttrigger: str
    ) -> str:
        """Return the PhaseSpec of a wakeup, cached per registration in force and lasttrigger."""
        triggers = self._triggers.get(name)
        if triggers is None or triggers.registration is not reg:
            return phase_spec_xml(phase, module=name, lasttrigger=lasttrigger)
        xml = triggers.phase_xml.get(lasttrigger)
        if xml is None:
            xml = phase_spec_xml(phase, module=name, lasttrigger=lasttrigger)
            if len(triggers.phase_xml) < _PHASE_CACHE_SIZE:
                triggers.phase_xml[lasttrigger] = xml
        return xml

    def _woken(self, board: Whiteboard, stored: Message) -> dict[str, tuple[int, str]]:
        """Return each bound module to wake with (after ms, lasttrigger) (OA-WAKE-5/6)."""
        modules = self._modules
        folded_board = ascii_fold(board.name)
        sender = stored.sender
        best: dict[str, tuple[int, int]] = {}
        for name, i in self._index.match(stored.type):  # OA-WB-7: registrations current now
            if name not in modules:
                continue  # only a bound module can receive a delivery
            triggers = self._triggers[name]
            _, whiteboard, after = triggers.entries[i]
            if whiteboard and whiteboard != folded_board:
                continue  # OA-TRIG-2: case-insensitive; "" is any whiteboard
            if sender == name and not triggers.allow_self:
                continue  # OA-TRIG-4, OA-REG-6
            if self._qos and not _urgent_enough(triggers, i, stored):
                continue  # OA-TRIG-5: an alarm trigger wants time-critical messages only
            current = best.get(name)
            if current is None or (after, i) < current:
                best[name] = (after, i)  # OA-WAKE-6: smallest after, first on a tie
        chosen = {
            name: (after, self._triggers[name].entries[i][0]) for name, (after, i) in best.items()
        }
        if stored.cc:
            for name in stored.cc_names:  # OA-CC-1
                if name in modules and name not in chosen:
                    chosen[name] = (0, "")  # OA-CC-2, OA-CC-4; OA-CC-3: others skipped
        return chosen

    def _notice(self, type_: str, now_ns: int) -> tuple[Delivery, ...]:
        """Post a lifecycle notice from Psyclone to AIRCentral (OA-SESS-6/15/31)."""
        board = self._whiteboards[AIRCENTRAL]
        msg = Message(type=type_, sender=_SYSTEM, to=AIRCENTRAL, posted=AirTime.from_ns(now_ns))
        try:
            validate_type(type_, max_bytes=None, max_segments=None)
            stored = board.store_post(msg, now_ns)
        except (TypeInvalidError, StoreFailedError):
            self._lost_notices += 1  # a name that makes no valid type, or a failing store
            return ()
        board.received += 1
        deliveries = self._adopted(board, board.adopted, now_ns)  # OA-CLU-4
        deliveries += self._decide(board, stored, now_ns)
        if self.observer is not None:
            self.observer(board.name, stored, deliveries)
        return deliveries

    def _forward(self, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Queue a message for a bound module, unchanged, and acknowledge it (OA-SESS-22)."""
        delivery = Delivery(
            module=msg.to,
            message=msg,
            due_ns=received_ns,
            priority=msg.effective_priority,
            wb_priority=DEFAULT_WB_PRIORITY,
            expires_ns=self._expiry(msg, received_ns),  # OA-DELIV-14
        )
        self._module_counters(msg.to).queued += 1
        ack = cmd.reply(msg, "RECEIVE_ACCEPT", sender=msg.to, now_ns=now_ns)
        return Outcome(replies=(ack,), deliveries=(delivery,))

    def _to_stream(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Answer a request to a stream: PING, KEEPALIVE and the media commands (spec 11)."""
        if msg.type in ("PING", "KEEPALIVE"):
            return self._session_reply(msg, msg.to, now_ns)
        result = self.streams.request(conn, msg, received_ns=received_ns, now_ns=now_ns)
        return self._stream_outcome(result, now_ns)

    def handle_binary(
        self, conn: ConnId, chunk: bytes, *, received_ns: int, now_ns: int
    ) -> Outcome:
        """Answer a BinaryM frame: a sample for the connection's current stream (OA-STREAM-11)."""
        request = Message(type="BinaryOnly", id="")  # what Psyclone calls a bare BinaryM
        if self._shutting_down:  # OA-SESS-24
            return self._refuse_shutting_down(request, now_ns)
        result = self.streams.binary(conn, chunk, received_ns=received_ns, now_ns=now_ns)
        if result is None:
            return Outcome(replies=(cmd.unknown_command(request, sender="CNS", now_ns=now_ns),))
        return self._stream_outcome(result, now_ns)

    def wait_expired(self, ticket: int, now_ns: int) -> Outcome:
        """Answer a WAIT_FOR_* whose timeout passed (OA-STREAM-7)."""
        ready = self.streams.wait_expired(ticket, now_ns)
        return Outcome(resolved=(ready,)) if ready is not None else Outcome()

    def tick(self, now_ns: int) -> Outcome:
        """Post the Idle alarms that fell due (OA-XSTREAM-7); the adapter calls it on a timer."""
        alarms = self.streams.tick(now_ns)
        return Outcome(deliveries=self._post_alarms(alarms, now_ns)) if alarms else Outcome()

    def _stream_outcome(self, result: StreamOutcome, now_ns: int) -> Outcome:
        deliveries = self._post_alarms(result.alarms, now_ns) if result.alarms else ()
        return Outcome(
            replies=result.replies,
            deliveries=deliveries,
            wait=result.wait,
            resolved=result.resolved,
            pushes=result.pushes,
        )

    def _post_alarms(self, alarms: tuple[Alarm, ...], now_ns: int) -> tuple[Delivery, ...]:
        """Post stream alarms as ordinary posts on their whiteboard (OA-XSTREAM-6)."""
        deliveries: list[Delivery] = []
        for alarm in alarms:
            board = self._whiteboards.get(alarm.whiteboard)
            if board is None:
                continue
            post = Message(
                type=alarm.type,
                sender=alarm.stream,
                to=board.name,
                content=encode_dictionary(Dictionary(entries=alarm.entries)),
                content_is_xml=True,
                language="xml",
            )
            deliveries.extend(self._post(board, post, now_ns, now_ns).deliveries)
        return tuple(deliveries)

    def _no_stream(self, msg: Message, now_ns: int) -> Outcome:
        """Answer a media command: this server offers no streams (OA-GEN-4, OA-STREAM-3)."""
        err = StreamUnknownError(f"no stream named {msg.to!r}")
        return Outcome(replies=(self._error(msg, err, msg.to or "CNS", now_ns),))

    # --- registrations --------------------------------------------------------------------

    def _subscribe(self, board: Whiteboard, msg: Message, now_ns: int) -> Outcome:
        """Replace the sender's whole registration (OA-REG-1, OA-REG-7, OA-REG-8)."""
        try:
            reg = parse_registration(msg.sender, msg.content, max_triggers=self.limits.max_triggers)
        except OpenAIRError as err:  # OA-REG-8: the previous registration stays in force
            return Outcome(replies=(self._error(msg, err, board.name, now_ns),))
        self._subscribed[msg.sender] = reg
        if self._contexts is not None:
            self._contexts.forget(msg.sender)  # OA-REG-17: a new registration starts afresh
        self._reindex(msg.sender)
        ack = cmd.reply(msg, "RECEIVE_ACCEPT", sender=board.name, now_ns=now_ns)
        return Outcome(replies=(ack,), deliveries=self._phase_update(msg.sender, now_ns))

    def _phase_update(self, name: str, now_ns: int) -> tuple[Delivery, ...]:
        """Tell a bound module its phase in force after a registration (OA-WAKE-9)."""
        if name not in self._modules:
            return ()
        reg = self.registration(name)
        update = build_wakeup(
            stored=None,
            whiteboard=_PHASE_SENDER,
            module=name,
            phase=self._phase_in_force(name, reg),
        )
        self._module_counters(name).queued += 1
        message = derive(update, posted=cmd.ms_time(now_ns))
        return (
            Delivery(
                module=name,
                message=message,
                due_ns=now_ns,
                priority=message.effective_priority,
                wb_priority=DEFAULT_WB_PRIORITY,
            ),
        )

    def _phase_in_force(self, name: str, reg: Registration | None) -> Phase | None:
        """Return the phase in force: by contexts (OA-REG-14), else Ready's first (OA-REG-10)."""
        if self._contexts is not None:
            return self._contexts.phase(name, reg)
        return reg.active_phase if reg is not None else None

    def _context_post(
        self, board: Whiteboard, stored: Message, now_ns: int
    ) -> tuple[Delivery, ...]:
        """Apply a context or phase change, then decide the post's wakeups (OA-REG-13..18)."""
        assert self._contexts is not None
        if stored.type == PHASE_CHANGE:  # OA-REG-17: the poster's own phase advances
            reg = self.registration(stored.sender)
            self._contexts.advance(stored.sender, reg)
            names = [stored.sender] if reg is not None else []
        else:
            context = context_of(stored.type)
            changed = context is not None and self._contexts.activate(context)
            names = list(self._triggers) if changed else []
        updates: list[Delivery] = []
        for name in names:
            old = self._triggers.get(name)
            self._reindex(name)
            new = self._triggers.get(name)
            if (old.phase if old else None) is not (new.phase if new else None):
                updates.extend(self._phase_update(name, now_ns))  # OA-REG-15
        return (*updates, *self._decide(board, stored, now_ns))

    def _reindex(self, name: str) -> None:
        """Put the triggers of `name`'s registration in force into the index (OA-REG-1)."""
        old = self._triggers.pop(name, None)
        if old is not None:
            for i, (pattern, _, _) in enumerate(old.entries):
                self._index.remove(pattern, (name, i))
        reg = self.registration(name)
        self.streams.set_registration(name, reg)  # OA-STREAM-14: inputstream sources
        if reg is None:
            self._sessions.set_registration(name, None)
            return
        phase = self._phase_in_force(name, reg)
        entries = tuple(
            (t.pattern, _folded_board(t.whiteboard), t.after_ms)
            for t in (phase.triggers if phase is not None else ())
        )  # OA-REG-10, OA-REG-14: the triggers of the phase in force
        for i, (pattern, _, _) in enumerate(entries):
            self._index.add(pattern, (name, i))
        self._triggers[name] = _Triggers(
            registration=reg,
            entries=entries,
            allow_self=reg.allow_self_triggering,
            phase=phase,
        )
        self._sessions.set_registration(name, reg)

    # --- session commands -----------------------------------------------------------------

    def _bind(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Bind a module name to this connection (OA-SESS-3..6, OA-SESS-19, OA-SESS-30)."""
        try:
            bound = self._sessions.bind(conn, msg, self.registration(msg.sender))
        except BindRefusedError as err:
            return Outcome(replies=(self._error(msg, err, "CNS", now_ns),))
        deliveries: tuple[Delivery, ...] = ()
        if bound.took_over:  # OA-SESS-6: registration and queue kept, no Lost notice
            deliveries = self._notice(f"Psyclone.Module.Restored.{msg.sender}", now_ns)
        content = str(bound.port)
        accept = cmd.reply(msg, "BIND_ACCEPT", sender="CNS", now_ns=now_ns, content=content)
        return Outcome(replies=(accept,), deliveries=deliveries, close_conns=bound.close)

    def _reserved(self, name: str) -> bool:
        """Return whether `name` belongs to a whiteboard, stream or component (OA-SESS-30)."""
        return (
            name in self._whiteboards
            or name in self.streams.names()
            or name in SYSTEM_COMPONENTS
            or name in self._internal  # OA-CONF-8: an internal module's name
        )

    def _receive_frame(self, conn: ConnId, msg: Message, now_ns: int) -> Outcome:
        """Make `conn` the callback connection of `from` (OA-SESS-7); no reply."""
        if msg.type != "RECEIVE_NAME_NOTIFICATION":
            err = MessageInvalidError("a Receive frame must carry RECEIVE_NAME_NOTIFICATION")
            return Outcome(replies=(self._error(msg, err, "CNS", now_ns),))
        if msg.to and msg.to not in SYSTEM_COMPONENTS and msg.to not in self._whiteboards:
            stream = self.streams.subscribe_push(conn, msg)  # 11.6: a push connection
            if stream is not None:
                return Outcome(push_stream=stream)
            err2 = StreamUnknownError(f"no stream {msg.to!r} to receive samples from")
            return Outcome(replies=(self._error(msg, err2, "CNS", now_ns),))
        close = self._sessions.notify(conn, msg)
        if close is None:
            return Outcome(close_this=True)  # no module can ever bind that name
        return Outcome(close_conns=close)

    def _auth_screen(
        self, conn: ConnId, msg: Message, tag: FrameTag, now_ns: int
    ) -> Outcome | None:
        """Refuse what this connection may not do in secure mode (OA-AUTH-5, -6, -8)."""
        assert self._auth is not None
        to = msg.to or "CNS"
        board = to in self._whiteboards
        post = board or (to not in self._components and to in self._modules)
        refusal = self._auth.screen(
            conn, msg, receive=tag is FrameTag.RECEIVE, cns=to == "CNS", post=post
        )
        if refusal is None:
            return None
        sender = to if board or to in self._components else "CNS"
        answer = cmd.error_reply(
            msg, refusal.error, sender=sender, now_ns=now_ns, type_=refusal.reply_type
        )
        return Outcome(replies=(answer,), close_this=refusal.close)

    def _auth_challenge(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Answer a fresh nonce for this connection (OA-AUTH-2)."""
        assert self._auth is not None
        nonce = self._auth.challenge(conn)
        return Outcome(
            replies=(cmd.reply(msg, AUTH_NONCE, sender="CNS", now_ns=now_ns, content=nonce),)
        )

    def _auth_response(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Prove `from` on this connection, or answer AUTH_FAILED (OA-AUTH-3)."""
        assert self._auth is not None
        try:
            self._auth.respond(conn, msg.sender, msg.content)
        except OpenAIRError as err:
            return Outcome(replies=(self._error(msg, err, "CNS", now_ns),))
        return Outcome(replies=(cmd.reply(msg, AUTH_ACCEPT, sender="CNS", now_ns=now_ns),))

    def _notification_in_message(
        self, conn: ConnId, msg: Message, received_ns: int, now_ns: int
    ) -> Outcome:
        """Refuse RECEIVE_NAME_NOTIFICATION outside a Receive frame: it would need no reply."""
        err = MessageInvalidError("RECEIVE_NAME_NOTIFICATION must come in a Receive frame")
        return Outcome(replies=(self._error(msg, err, "CNS", now_ns),))

    def _resolve(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Resolve a name to the main port (OA-SESS-8, OA-SESS-9)."""
        name = msg.content.strip()
        known = (
            name in SYSTEM_COMPONENTS
            or name in self._whiteboards
            or self.streams.resolve(name) is not None  # OA-XSTREAM-1: a type resolves too
            or name in self._modules  # forwarded through the main port (OA-SESS-22)
        )
        if not known:  # NAME_UNRESOLVED: RESOLVE_FAILED keeps its legacy empty content (OA-ERR-6)
            return Outcome(replies=(cmd.reply(msg, "RESOLVE_FAILED", sender="CNS", now_ns=now_ns),))
        location = encode_tcplocation(TcpLocation(address=self.address, port=self.port, name=name))
        answer = cmd.reply(
            msg, "RESOLVE_SUCCESS", sender="CNS", now_ns=now_ns, content=location, xml=True
        )
        return Outcome(replies=(answer,))

    def _session_reply(self, msg: Message, sender: str, now_ns: int) -> Outcome:
        kind = "PING_SUCCESS" if msg.type == "PING" else "KEEPALIVESUCCESS"
        return Outcome(replies=(cmd.reply(msg, kind, sender=sender, now_ns=now_ns),))

    def _ping(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        return self._session_reply(msg, msg.to or "CNS", now_ns)  # OA-SESS-10

    def _keepalive(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        return self._session_reply(msg, msg.to or "CNS", now_ns)  # OA-KEEP-2

    def _status(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        started = self.started_ns if self.started_ns is not None else now_ns
        modules = len(self._modules)
        counters = dict(self.counters())
        if self.status_extra is not None:
            counters.update(self.status_extra())
        if self._qos:  # OA-DELIV-14: the adapter counts expired deliveries among its drops
            dropped = counters.get("dropped")
            expired = dropped.get("EXPIRED", 0) if isinstance(dropped, Mapping) else 0
            counters["Deliveries"] = {"Expired": expired}
        if self.defer_large_replies and len(self._counters) >= _LARGE_STATUS:
            # Thousands of names take a second to write: on a worker (issue #19, item 7). The
            # counters are a copy taken now, so the reply is still of this moment.
            def later() -> tuple[Message, bytes | None]:
                reply = cmd.status_reply(
                    msg, started_ns=started, now_ns=now_ns, modules=modules, counters=counters
                )
                return reply, None

            return Outcome(later=later)
        answer = cmd.status_reply(
            msg, started_ns=started, now_ns=now_ns, modules=modules, counters=counters
        )
        return Outcome(replies=(answer,))  # OA-SESS-25

    def _capabilities(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        answer = cmd.capabilities_reply(
            msg,
            server=self.server_name,
            extensions=self.extensions,
            limits=self.limits,
            now_ns=now_ns,
        )
        return Outcome(replies=(answer,))  # OA-SESS-23, OA-CAP-1

    def _time(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Answer GET_TIME; with usec when the requester declared it (OA-EXT-2, OA-TIME-5)."""
        declared = self._sessions.extensions_of(conn, msg.sender)
        usec = "usec" in declared and "usec" in self.extensions
        return Outcome(replies=(cmd.time_reply(msg, usec=usec, now_ns=now_ns),))

    def _entry(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        return Outcome(replies=(cmd.entry_reply(msg, self.config, now_ns=now_ns),))  # OA-SESS-12

    def _get_streams(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """List the streams (OA-STREAM-16)."""
        listing = self.streams.listing()
        answer = cmd.reply(msg, "STREAMS", sender="CNS", now_ns=now_ns, content=listing, xml=True)
        return Outcome(replies=(answer,))

    def _create_stream(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Create a stream at run time (OA-XSTREAM-10)."""
        try:
            self.streams.create(
                msg.content,
                whiteboards=self._whiteboards,
                taken=lambda name: self._reserved(name) or name in self._modules,
            )
        except OpenAIRError as err:
            return Outcome(replies=(self._error(msg, err, "Psyclone", now_ns),))
        return Outcome(
            replies=(cmd.reply(msg, "RECEIVE_ACCEPT", sender="Psyclone", now_ns=now_ns),)
        )

    def _current_phase(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        reg = self.registration(msg.sender)
        phase = self._phase_in_force(msg.sender, reg)  # OA-REG-14 under `contexts`
        return Outcome(replies=(cmd.current_phase_reply(msg, phase, now_ns=now_ns),))  # OA-SESS-13

    def _get_id(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        answer = cmd.reply(msg, "ID", sender="AIRServer", now_ns=now_ns, content=self.server_id)
        return Outcome(replies=(answer,))  # OA-SESS-14

    def _get_name(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        answer = cmd.reply(msg, "NAME", sender="AIRServer", now_ns=now_ns, content=self.config.name)
        return Outcome(replies=(answer,))  # OA-SESS-14

    def _perfstat(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        answer = cmd.reply(msg, "RECEIVE_ACCEPT", sender="AIRServer", now_ns=now_ns)
        return Outcome(replies=(answer,))  # OA-SESS-14: the content may be ignored

    # --- helpers --------------------------------------------------------------------------

    def _error(self, msg: Message, err: OpenAIRError, sender: str, now_ns: int) -> Message:
        return cmd.error_reply(msg, err, sender=sender, now_ns=now_ns)  # OA-ERR-2, OA-ERR-6

    def _module_counters(self, name: str) -> _ModuleCounters:
        counters = self._counters.get(name)
        if counters is None:
            counters = self._counters[name] = _ModuleCounters()
        return counters


def _urgent_enough(triggers: _Triggers, i: int, stored: Message) -> bool:
    """Whether trigger i (an alarm trigger or not) accepts the message's priority (OA-TRIG-5)."""
    phase = triggers.phase
    limit = phase.triggers[i].max_priority if phase is not None else None
    return limit is None or stored.effective_priority <= limit


def _folded_board(whiteboard: str) -> str:
    """Fold a trigger's `from` for comparison; any / * / empty mean every board (OA-TRIG-2)."""
    folded = ascii_fold(whiteboard.strip())
    return ANY_WHITEBOARD if folded in ("", "any", "*") else folded


def _stream_specs(config: ServerConfig, *, typed: bool) -> list[StreamSpec]:
    """Read the configured streams (spec 11.1, 11.7); ConfigError for values that cannot hold."""
    boards = [wb.name for wb in config.whiteboards]
    specs: list[StreamSpec] = []
    types: set[str] = set()
    for wb in config.whiteboards:
        for s in wb.streams:
            try:
                spec = StreamSpec.from_config(s, wb.name, typed_streams=typed, whiteboards=boards)
            except OpenAIRError as err:
                raise ConfigError(
                    f"{config.source or 'psySpec'}: stream {s.name!r}: {err.detail}"
                ) from None
            if spec.type is not None:
                folded = ascii_fold(spec.type)
                if folded in types:  # OA-XSTREAM-1: unique ignoring case
                    raise ConfigError(f"stream {s.name!r}: the type {spec.type!r} is used twice")
                types.add(folded)
            specs.append(spec)
    return specs
