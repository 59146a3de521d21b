"""The sans-I/O router of the reference server: sessions, whiteboards, registrations, wakeups.

`Router.handle()` takes one decoded request and returns an `Outcome`: the replies to send on
that connection (in order, OA-SESS-2), the deliveries to queue per module, and connections to
close. No sockets, no clock reads: the adapter passes `received_ns` (when the frame arrived,
OA-TIME-3) and `now_ns` (for replies' postedTime). Every component lives on the main port and
is addressed by `to` (OA-SESS-9, OA-SESS-26).

The post path is lean: one dict lookup to find the whiteboard, one cached type check, one store
append, the route cache's answer (`router_routes`: a `PatternIndex.match` over the triggers of
every registration when it misses), and a wakeup per woken module (OA-WAKE-5).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import replace
from functools import partial
from typing import TYPE_CHECKING

from openair.protocol.content import Registration
from openair.protocol.errors import (
    LimitExceededError,
    OpenAIRError,
    ShuttingDownError,
    StoreFailedError,
    TypeInvalidError,
)
from openair.protocol.framing import FrameTag
from openair.protocol.matching import PatternIndex
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.types import validate_type
from openair.protocol.wakeup import EncodedCopies, PeekedCopies
from openair.server.core import commands as cmd
from openair.server.core.auth import AuthGate
from openair.server.core.config import (
    AIRCENTRAL,
    DEFAULT_WB_PRIORITY,
    ServerConfig,
    ServerLimits,
)
from openair.server.core.contexts import PHASE_CHANGE, Contexts
from openair.server.core.outcome import AwaitedReply, Delivery, Outcome
from openair.server.core.queues import item_bytes
from openair.server.core.retrieve import RETRIEVE, RETRIEVES, prepare_retrieve
from openair.server.core.router_commands import ComponentCommands
from openair.server.core.router_registrations import Registrations
from openair.server.core.router_routes import Routes
from openair.server.core.router_state import IndexedTriggers, ModuleCounters
from openair.server.core.router_streams import StreamRouting, stream_specs
from openair.server.core.sessions import ConnId, ModuleInfo, Sessions
from openair.server.core.store import HistoryStore
from openair.server.core.streamservice import (
    PendingWait,
    SamplePush,
    StreamService,
    WaitReply,
    is_media_command,
)
from openair.server.core.whiteboard import Whiteboard

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

_TYPE_CACHE_SIZE = 4096
_SYSTEM = "Psyclone"  # the sender of lifecycle notices (OA-SESS-15, OA-SESS-31)

if TYPE_CHECKING:
    import concurrent.futures


class Router(ComponentCommands, StreamRouting, Registrations, Routes):
    """The whole server behind the sockets (spec sections 6–10, 15).

    Assembled from parts (`router_state` says how): the component commands, stream requests,
    registrations and wakeups live in `router_commands`, `router_streams`,
    `router_registrations` and `router_routes`; here are the dispatch and the posts.
    """

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
        # The adapter writes large replies on a worker thread (Outcome.later, issue #19), and
        # sends a reply's frame, not its text (a large retrieve's text is then never joined).
        self.defer_large_replies = False
        self.frames_only = False
        # The adapter waits for a cluster's store without blocking (Outcome.awaited, spec 17).
        self.defer_store_replies = False
        # The adapter writes large wakeups on a worker thread (Delivery.build, issue #19).
        self.defer_large_wakeups = False
        #: A cluster node's sending to another node's module (OA-CLU-8); None: not a node.
        self.elsewhere: Callable[[Message], concurrent.futures.Future[int] | None] | None = None
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
            stream_specs(config, typed=typed),
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
        self._triggers: dict[str, IndexedTriggers] = {}
        self._index_changes = 0  # the route cache's key (router_routes)
        self._routes, self._routes_at = {}, (-1, -1)
        self._valid_types: set[str] = set()
        self._counters: dict[str, ModuleCounters] = {}
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

    def pause_builds(self, pause: Callable[[], None]) -> None:
        """Have a large wakeup written on another thread call `pause` before each copy (#19)."""
        self._copies.pause = pause

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
        if msg.noreply and self._noreply and (outcome.replies or outcome.later or outcome.awaited):
            outcome = replace(outcome, replies=(), later=None, awaited=None)  # OA-MSG-15, OA-WB-8
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

    def note_delivered(self, module: str) -> None:
        """Count one delivery the adapter completed for `module`."""
        self._module_counters(module).delivered += 1

    def note_dropped(self, module: str, n: int = 1) -> None:
        """Count deliveries the adapter dropped for `module` (OA-DELIV-7, OA-DELIV-9)."""
        self._module_counters(module).dropped += n

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
        sent = self.elsewhere(msg) if self.elsewhere is not None else None
        if sent is not None:  # OA-CLU-8: bound to another node
            return Outcome(awaited=AwaitedReply(sent, cmd.reply_when_forwarded(msg)))
        return Outcome(replies=(cmd.forward_failed(msg, now_ns=now_ns),))  # OA-SESS-21

    def _refuse_shutting_down(self, msg: Message, now_ns: int) -> Outcome:
        """Answer SHUTTING_DOWN and close the connection (OA-SESS-24)."""
        err = ShuttingDownError("the server is shutting down")
        return Outcome(replies=(self._error(msg, err, "CNS", now_ns),), close_this=True)

    def _to_whiteboard(
        self, board: Whiteboard, msg: Message, received_ns: int, now_ns: int
    ) -> Outcome:
        """Serve a whiteboard command or take a post (OA-WB-2)."""
        kind = msg.type
        if kind == "AIR.Subscribe":
            return self._subscribe(board, msg, now_ns)
        if kind in (RETRIEVE, RETRIEVES):
            caught_up: tuple[Delivery, ...] = ()

            def synced(read: Whiteboard) -> None:  # OA-CLU-3: each whiteboard it reads
                nonlocal caught_up
                caught_up += self._adopted(read, read.sync(), now_ns)

            prepared = prepare_retrieve(
                msg,
                board,
                self._whiteboards,
                now_ns=now_ns,
                max_xml=self.limits.max_frame_xml,
                max_binary=self.limits.max_frame_binary,  # OA-RET-15, OA-RET-19
                before_read=synced,
            )
            if self.defer_large_replies and prepared.large:  # written off the loop (issue #19)
                # Through the cache the worker reads (and pauses at) as a large wakeup's build.
                prepared = replace(prepared, copies=PeekedCopies(self._copies))
                build = partial(prepared.build, text=not self.frames_only)  # sent: the frame
                return Outcome(later=build, deliveries=caught_up)
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
            if self.defer_store_replies and board.sequenced:  # OA-CLU-2: routed when it is back
                done = board.post_soon(msg, received_ns)
                return Outcome(awaited=AwaitedReply(done, cmd.reply_when_stored(msg, board.name)))
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

    def forwarded(self, msg: Message, now_ns: int) -> Outcome | None:
        """Queue a message another node sent to a module bound here (OA-CLU-8); None: not here."""
        if msg.to not in self._modules:
            return None
        return replace(self._forward(msg, now_ns, now_ns), replies=())

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

    # --- registrations --------------------------------------------------------------------

    # --- helpers --------------------------------------------------------------------------

    def _error(self, msg: Message, err: OpenAIRError, sender: str, now_ns: int) -> Message:
        return cmd.error_reply(msg, err, sender=sender, now_ns=now_ns)  # OA-ERR-2, OA-ERR-6

    def _module_counters(self, name: str) -> ModuleCounters:
        counters = self._counters.get(name)
        if counters is None:
            counters = self._counters[name] = ModuleCounters()
        return counters
