"""The state `Router` keeps, declared once for the parts of it in other modules (issue #17).

`Router` is one class assembled from mixins: `router_commands.ComponentCommands` (the system
components' commands), `router_streams.StreamRouting` (requests to streams, alarms) and
`router_registrations.Registrations` (registrations, phases, the trigger index). Each mixin
subclasses `RouterState`, which declares for the type checker only the attributes `Router`
sets and the methods the parts call on each other; at run time it is empty, so no declaration
can shadow the method that implements it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from openair.protocol.content import Phase, Registration

if TYPE_CHECKING:
    from openair.protocol.errors import OpenAIRError
    from openair.protocol.matching import PatternIndex
    from openair.protocol.message import Message
    from openair.protocol.wakeup import EncodedCopies
    from openair.server.core.auth import AuthGate
    from openair.server.core.config import ServerConfig, ServerLimits
    from openair.server.core.contexts import Contexts
    from openair.server.core.outcome import Delivery, Handler, Outcome
    from openair.server.core.sessions import ModuleInfo, Sessions
    from openair.server.core.store import HistoryStore
    from openair.server.core.streamservice import StreamService
    from openair.server.core.whiteboard import Whiteboard

__all__ = ["IndexedTriggers", "ModuleCounters", "RouterState", "urgent_enough"]


@dataclass(slots=True)
class IndexedTriggers:
    """The indexed triggers of one module's registration in force."""

    registration: Registration
    # Per trigger: its pattern, its whiteboard folded ("" = any, OA-TRIG-2), its after (ms).
    entries: tuple[tuple[str, str, int], ...]
    allow_self: bool
    phase: Phase | None  # the registration's phase in force (OA-REG-10)
    # PhaseSpec XML of the phase in force, by lasttrigger (the registration never changes here).
    phase_xml: dict[str, str] = field(default_factory=dict)


@dataclass(slots=True)
class ModuleCounters:
    requests: int = 0  # requests whose `from` named the module while it was bound
    queued: int = 0  # deliveries the router decided for it
    delivered: int = 0  # note_delivered()
    dropped: int = 0  # note_dropped()


class RouterState:
    """What every part of `Router` may use (declarations for the type checker only)."""

    if TYPE_CHECKING:
        config: ServerConfig
        _auth: AuthGate | None
        server_name: str
        status_extra: Callable[[], Mapping[str, object]] | None
        queued_bytes: Callable[[], int] | None
        observer: Callable[[str, Message, tuple[Delivery, ...]], None] | None
        defer_large_replies: bool
        defer_store_replies: bool
        defer_large_wakeups: bool
        address: str
        port: int
        limits: ServerLimits
        extensions: frozenset[str]
        server_id: str
        started_ns: int | None
        _store: HistoryStore
        _noreply: bool
        _qos: bool
        _shutting_down: bool
        _whiteboards: dict[str, Whiteboard]
        streams: StreamService
        _configured: dict[str, Registration | None]
        _sessions: Sessions
        _modules: dict[str, ModuleInfo]
        _subscribed: dict[str, Registration]
        _index: PatternIndex[tuple[str, int]]
        _triggers: dict[str, IndexedTriggers]
        _index_changes: int
        _valid_types: set[str]
        _counters: dict[str, ModuleCounters]
        _gone: dict[str, int]
        _lost_notices: int
        _copies: EncodedCopies
        _contexts: Contexts | None
        _internal: set[str]
        _components: dict[str, dict[str, Handler]]

        # router.py
        def _error(self, msg: Message, err: OpenAIRError, sender: str, now_ns: int) -> Message: ...
        def _module_counters(self, name: str) -> ModuleCounters: ...
        def _notice(self, type_: str, now_ns: int) -> tuple[Delivery, ...]: ...
        def _post(
            self, board: Whiteboard, msg: Message, received_ns: int, now_ns: int
        ) -> Outcome: ...
        def _refuse_shutting_down(self, msg: Message, now_ns: int) -> Outcome: ...

        # router_routes.py
        def _decide(
            self, board: Whiteboard, stored: Message, now_ns: int
        ) -> tuple[Delivery, ...]: ...

        # router_registrations.py
        def registration(self, name: str) -> Registration | None: ...
        def _phase_in_force(self, name: str, reg: Registration | None) -> Phase | None: ...
        def _phase_update(self, name: str, now_ns: int) -> tuple[Delivery, ...]: ...
        def _reindex(self, name: str) -> None: ...

        # router_commands.py
        def _session_reply(self, msg: Message, sender: str, now_ns: int) -> Outcome: ...
        def _reserved(self, name: str) -> bool: ...


def urgent_enough(triggers: IndexedTriggers, i: int, stored: Message) -> bool:
    """Whether trigger i (an alarm trigger or not) accepts the message's priority (OA-TRIG-5)."""
    phase = triggers.phase
    limit = phase.triggers[i].max_priority if phase is not None else None
    return limit is None or stored.effective_priority <= limit
