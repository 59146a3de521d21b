"""Content objects carried in `<content language="xml">` (spec sections 6–9).

Value types only; their XML readers and writers live in `objects.py` (content objects in
general), `registration.py` (AIR.Subscribe forms) and `wakeup.py` (building wakeups). Every type
is a frozen dataclass so it can be compared, hashed and printed as valid Python.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from openair.protocol.times import AirTime

ANY_WHITEBOARD = ""  # trigger `from` absent, "any" or "*" (OA-TRIG-2) is normalised to this
DEFAULT_CONTEXT = "Psyclone.System.Ready"  # OA-REG-10


@dataclass(frozen=True, slots=True, kw_only=True)
class TcpLocation:
    """`<tcplocation address port name …/>` (RESOLVE_SUCCESS, BIND with a port, OA-SESS-4/8)."""

    address: str = ""
    port: int = 0
    name: str = ""
    extra: tuple[tuple[str, str], ...] = ()  # other attributes (procid, auth, …) kept in order


@dataclass(frozen=True, slots=True, kw_only=True)
class Dictionary:
    """`<dictionary><entry name="k">v</entry>…</dictionary>`: ordered text entries."""

    entries: tuple[tuple[str, str], ...] = ()

    def get(self, key: str, default: str = "") -> str:
        """Return the value of the first entry called `key`."""
        return next((v for k, v in self.entries if k == key), default)


@dataclass(frozen=True, slots=True, kw_only=True)
class Trigger:
    """One `<trigger type from after alias/>` (OA-TRIG-1..3).

    `whiteboard` is `ANY_WHITEBOARD` for any whiteboard; otherwise the name as written (it is
    compared case-insensitively, OA-TRIG-2). `after_ms` is the wakeup delay.
    """

    pattern: str
    whiteboard: str = ANY_WHITEBOARD
    after_ms: int = 0
    alias: str = ""
    # OA-TRIG-5 (extension `qos`): an alarm trigger fires only for priorities at most this.
    max_priority: float | None = None


class ContentMatch(enum.Enum):
    """What a retrieve's `content` glob is matched against (OA-RET-8, OA-RET-13)."""

    TEXT = "text"
    XML = "xml"


@dataclass(frozen=True, slots=True, kw_only=True)
class RetrieveSpec:
    """One `<retrieve>` (OA-RET-3..9). Empty strings and `None` mean "criterion absent".

    `whiteboard` is `from` (exact case, OA-RET-2); "" means the default. `latest` defaults to 1
    and 0 means no limit (OA-RET-4). Times bound `receivedTime` inclusively (OA-RET-9).
    """

    whiteboard: str = ""
    pattern: str = ""
    id: str = ""
    sender: str = ""
    content: str = ""
    contentmatch: ContentMatch = ContentMatch.TEXT
    latest: int = 1
    lastmsec: int | None = None
    after_time: AirTime | None = None
    until_time: AirTime | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class StreamRef:
    """A stream named in a phase: `<inputstream|outputstream alias source/>` or `<stream …/>`."""

    kind: str  # "inputstream" | "outputstream" | "stream"
    alias: str = ""
    source: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class Phase:
    """One phase of a registration: the triggers and retrieves in force together."""

    name: str = "Default Phase"
    context: str = DEFAULT_CONTEXT
    triggers: tuple[Trigger, ...] = ()
    retrieves: tuple[RetrieveSpec, ...] = ()
    streams: tuple[StreamRef, ...] = ()
    priority: float = 1.0


class RegistrationForm(enum.Enum):
    """Which AIR.Subscribe form a registration arrived in (OA-REG-2..4)."""

    BARE = "bare"  # <triggers>…</triggers>[<retrieves>…</retrieves>]
    MODULE = "module"  # <module name><trigger…/>…</module>
    SPEC = "spec"  # <module><spec><context><phase>…
    PHASE = "phase"  # root <phase> (accepted; Psyclone ignores it)
    CONFIG = "config"  # from the psySpec <module> element


@dataclass(frozen=True, slots=True, kw_only=True)
class Registration:
    """A module's whole registration; AIR.Subscribe replaces it (OA-REG-1).

    Core semantics use the phases whose context is `DEFAULT_CONTEXT` (OA-REG-10); other phases
    are kept so they can be echoed and used when the `contexts` capability exists.
    """

    module: str
    form: RegistrationForm
    phases: tuple[Phase, ...] = ()
    allow_self_triggering: bool = False  # OA-REG-6

    @property
    def active_phase(self) -> Phase | None:
        """The phase in force: the first phase in the default context, if any."""
        return next((p for p in self.phases if p.context == DEFAULT_CONTEXT), None)

    @property
    def triggers(self) -> tuple[Trigger, ...]:
        """The triggers in force (those of the active phase)."""
        phase = self.active_phase
        return phase.triggers if phase else ()

    @property
    def retrieves(self) -> tuple[RetrieveSpec, ...]:
        """The retrieves in force (those of the active phase)."""
        phase = self.active_phase
        return phase.retrieves if phase else ()
