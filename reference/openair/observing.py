"""What a server shows the applications attached to it: the observer interface.

The reference server exports this interface (`Server.observe`, server/aio/app.py) so that the
applications beside the protocol core (the web monitor, a recorder) watch it without reaching
into its modules: they see each stored post with the deliveries it caused (`Delivered`), and
each delivery a module acknowledged (`Acknowledged`). Both are read-only views; the server's
own records (router `Delivery`, queue `QueueItem`) satisfy them. `message_bytes` is the size
estimate the server and its observers share for a message they hold (issue #19).

Observers run inside the post path: they must do O(1) work and never raise.
"""

from __future__ import annotations

from typing import Protocol

from openair.protocol.message import Message

__all__ = ["ENVELOPE_BYTES", "Acknowledged", "Delivered", "ServerObserver", "message_bytes"]

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
    def wire(self) -> bytes | None: ...


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


def message_bytes(message: Message, wire: bytes | tuple[bytes, ...] | None) -> int:
    """Return the bytes a held message takes: its frame, or an estimate from its slots."""
    if isinstance(wire, bytes):
        return len(wire)
    if wire is not None:
        return sum(len(part) for part in wire)
    size = ENVELOPE_BYTES + len(message.content) + len(message.history) + len(message.comment)
    return size + sum(len(chunk) for chunk in message.binary)
