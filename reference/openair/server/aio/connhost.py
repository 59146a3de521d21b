"""What a server connection needs from the server that owns it: `ConnectionHost`, `FlowLimits`.

`ServerConnection` (`openair.server.aio.protocol`) is written against this interface, not
against the server application, so that tests can host a connection on a small fake and the
connection cannot reach into the server's state.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair.server.core.config import ServerLimits
from openair.server.core.router import Outcome

if TYPE_CHECKING:
    from openair.server.aio.protocol import ServerConnection

__all__ = ["ConnectionHost", "FlowLimits"]


@dataclass(frozen=True, slots=True, kw_only=True)
class FlowLimits:
    """Write-buffer marks of one connection (bytes), and the idle time before KEEPALIVE (s)."""

    high_water: int = 1 << 20
    low_water: int = 1 << 18
    hard_cap: int = 96 << 20
    keepalive_s: float = 60.0  # OA-KEEP-1
    linger_s: float = 2.0


class ConnectionHost(Protocol):
    """What a connection needs from the server that owns it."""

    limits: ServerLimits
    flow: FlowLimits

    def connection_opened(self, conn: ServerConnection) -> int:
        """Register a new inbound connection and return its id."""

    def handle(
        self, conn: ServerConnection, msg: Message, *, tag: FrameTag, received_ns: int
    ) -> Outcome:
        """Hand one request to the router and act on everything but the replies."""

    def handle_binary(self, conn: ServerConnection, chunk: bytes, *, received_ns: int) -> Outcome:
        """Hand a BinaryM frame's chunk to the router (OA-STREAM-11); act as `handle` does."""

    def http_takeover(self, conn: ServerConnection, data: bytes) -> bool:
        """Give a connection that starts with an HTTP method to the monitor; False: keep it."""

    def callback_opened(self, conn: ServerConnection, module: str) -> None:
        """Note that `conn` became the callback connection of `module` (OA-SESS-7)."""

    def connection_lost(self, conn: ServerConnection) -> None:
        """Forget a closed connection."""
