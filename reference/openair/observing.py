"""What a server shows the applications attached to it: the observer interface (issue #17).

The reference server exports this interface so that the applications beside the protocol core
(apps/: the web monitor `openair_monitor`, ...) watch it without importing any of its modules.
An application is named in the entry point group `openair.server.attachments`; the server calls
it once when it starts, with itself as an `ObservedServer`, and closes what it returns.

- `ServerObserver`, attached with `ObservedServer.observe`, sees each stored post with the
  deliveries it caused (`Delivered`) and each delivery a module acknowledged (`Acknowledged`).
  Both are read-only views; the server's own records (router `Delivery`, queue `QueueItem`)
  satisfy them. Observers run inside the post path: they must do O(1) work and never raise.
- `ObservedServer` is what else an application may read: where the server listens, its
  extensions, whiteboards and counters, and look-ups by name (a whiteboard's stored posts as a
  `StoredBoard`, a bound module's session as a `BoundModule`, a registration); and `inject`,
  which routes a post that came from no connection (the monitor's post form).
- `message_bytes` is the size estimate the server and its observers share for a message they
  hold (issue #19).

The reference server hands its applications an `ObservedView` of itself (server/aio/observed.py),
nothing more: mypy checks that it is an `ObservedServer` in tests/layering/test_layering_apps.py,
which also keeps the applications off the server's modules.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Protocol, runtime_checkable

from openair.protocol.content import Registration
from openair.protocol.framing import Wire
from openair.protocol.message import Message

__all__ = [
    "ENVELOPE_BYTES",
    "Acknowledged",
    "AttachOptions",
    "BoundModule",
    "Delivered",
    "Injected",
    "ObservedServer",
    "ServerObserver",
    "StoredBoard",
    "held_bytes",
    "message_bytes",
]

#: What a message's envelope takes besides its text slots and chunks, as an estimate.
ENVELOPE_BYTES = 512


class Delivered(Protocol):
    """One delivery a stored post caused: to `module`, due at `due_ns` (6.6, 8.7)."""

    @property
    def module(self) -> str: ...

    @property
    def message(self) -> Message: ...

    @property
    def due_ns(self) -> int: ...

    @property
    def priority(self) -> float: ...

    @property
    def wire(self) -> Wire | None: ...


class Acknowledged(Protocol):
    """A delivery the module acknowledged: what was sent, and when it was due (0: at once)."""

    @property
    def message(self) -> Message: ...

    @property
    def due_ns(self) -> int: ...


class ServerObserver(Protocol):
    """What `Server.observe` attaches."""

    def observe(self, whiteboard: str, stored: Message, deliveries: tuple[Delivered, ...]) -> None:
        """A post was stored on `whiteboard` and caused `deliveries`."""

    def delivered(self, module: str, item: Acknowledged) -> None:
        """`module` acknowledged the delivery `item`."""


# -- what an attached application may read of the server (issue #17) -----------------------


class StoredBoard(Protocol):
    """A whiteboard as an observer reads it: its limits, its numbering, its stored posts."""

    @property
    def maxcount(self) -> int: ...

    @property
    def priority(self) -> float: ...

    @property
    def next_wbid(self) -> int:
        """The wbid the next stored post gets (OA-WB-5)."""

    def __len__(self) -> int: ...

    def newest_first(self) -> Iterator[Message]:
        """The stored posts, newest first (a snapshot iterator; never blocks routing)."""


class BoundModule(Protocol):
    """A bound module's session (spec 6): its connections, port, address and extensions."""

    @property
    def conn(self) -> int | None: ...

    @property
    def callback(self) -> int | None: ...

    @property
    def port(self) -> int: ...

    @property
    def address(self) -> str: ...

    @property
    def extensions(self) -> frozenset[str]: ...


class Injected(Protocol):
    """What `ObservedServer.inject` returns: the replies to the injected post."""

    @property
    def replies(self) -> tuple[Message, ...]: ...


class AttachOptions(Protocol):
    """The server's options an attached monitor reads (`openair serve` flags, spec 15.2)."""

    @property
    def host(self) -> str: ...

    @property
    def http_port(self) -> int | None: ...

    @property
    def monitor_post(self) -> bool: ...

    @property
    def monitor_hosts(self) -> tuple[str, ...]: ...


@runtime_checkable
class ObservedServer(Protocol):
    """What an application attached to a server (entry point group `openair.server.attachments`)
    may use: it is called with the server as this, once, when the server starts."""

    @property
    def host(self) -> str: ...

    @property
    def port(self) -> int: ...

    @property
    def extensions(self) -> frozenset[str]: ...

    @property
    def whiteboards(self) -> tuple[str, ...]: ...

    @property
    def options(self) -> AttachOptions: ...

    @property
    def system_name(self) -> str:
        """The psySpec's `name` (spec 12)."""

    @property
    def server_name(self) -> str:
        """The implementation and version (OA-CAP-1)."""

    @property
    def started_ns(self) -> int | None: ...

    def whiteboard(self, name: str) -> StoredBoard | None:
        """The whiteboard `name` (exact case), None when the server has none of that name."""

    def module(self, name: str) -> BoundModule | None:
        """The session of module `name` when it is bound, else None."""

    def registration(self, name: str) -> Registration | None:
        """The registration in force for module `name`, if any."""

    def counters(self) -> dict[str, object]:
        """Nested counters: `whiteboards`, `modules`, `queues`, `streams` tables and totals."""

    def rate_counters(self) -> dict[str, dict[str, int]]:
        """What to sample for rates, flat: `whiteboards` (`wb:NAME` received), `modules`
        (`out:NAME` requests and `in:NAME` delivered of the modules bound now), `streams`
        (`stream:NAME` samples added). Costs what is live, not every name kept."""

    def observe(self, observer: ServerObserver) -> Callable[[], None]:
        """Attach `observer`; return the function that detaches it."""

    def inject(self, msg: Message, *, received_ns: int) -> Injected:
        """Route `msg` as a post that came from no connection (the monitor's post form)."""


def message_bytes(message: Message, wire: Wire | None) -> int:
    """Return the bytes of a message as it travels: its frame, or an estimate from its slots.

    What OA-LIM-8 bounds (a delivery's size). A holder that keeps the message's text as well as
    its frame holds more: `held_bytes` counts both.
    """
    if isinstance(wire, bytes):
        return len(wire)
    if wire is not None:
        return sum(len(part) for part in wire)
    size = ENVELOPE_BYTES + len(message.content) + len(message.history) + len(message.comment)
    return size + sum(len(chunk) for chunk in message.binary)


def held_bytes(message: Message, wire: Wire | None) -> int:
    """Return the memory a message held with its frame takes: its text and its frame.

    The frame is an encoded copy of the text: a wakeup of a megabyte is a megabyte of content
    and a megabyte of frame (the monitor's ring, counting the frame alone, held twice its
    budget; issue #19). Binary chunks are counted once: a frame's parts are the message's own.
    """
    if wire is None:
        return message_bytes(message, None)
    text = ENVELOPE_BYTES + len(message.content) + len(message.history) + len(message.comment)
    return text + message_bytes(message, wire)
