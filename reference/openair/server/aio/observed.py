"""The server as its attached applications see it: an `openair.observing.ObservedServer`.

`Server` hands an `ObservedView` of itself to each application it attaches (entry point group
`openair.server.attachments`): the view answers what the observer interface names — where the
server listens, its extensions, whiteboards and counters, a whiteboard's stored posts, a bound
module's session, a registration — and forwards `observe` and `inject`. Nothing else of the
server (its router, queues, connections) is reachable through it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from openair.observing import AttachOptions, BoundModule, Injected, ServerObserver, StoredBoard
from openair.protocol.content import Registration
from openair.protocol.message import Message

if TYPE_CHECKING:
    from openair.server.aio.app import Server

__all__ = ["ObservedView"]


class ObservedView:
    """Read-only look at one server, plus `observe` and `inject` (openair.observing)."""

    __slots__ = ("_server",)

    def __init__(self, server: Server) -> None:
        self._server = server

    @property
    def host(self) -> str:
        return self._server.host

    @property
    def port(self) -> int:
        return self._server.port

    @property
    def extensions(self) -> frozenset[str]:
        return self._server.extensions

    @property
    def whiteboards(self) -> tuple[str, ...]:
        return self._server.whiteboards

    @property
    def options(self) -> AttachOptions:
        return self._server.options

    @property
    def system_name(self) -> str:
        return self._server.config.name

    @property
    def server_name(self) -> str:
        return self._server.router.server_name

    @property
    def started_ns(self) -> int | None:
        return self._server.router.started_ns

    def counters(self) -> dict[str, object]:
        return self._server.counters()

    def rate_counters(self) -> dict[str, dict[str, int]]:
        return self._server.rate_counters()

    def whiteboard(self, name: str) -> StoredBoard | None:
        return self._server.router.whiteboard(name)

    def module(self, name: str) -> BoundModule | None:
        return self._server.router.module(name)

    def registration(self, name: str) -> Registration | None:
        return self._server.router.registration(name)

    def observe(self, observer: ServerObserver) -> Callable[[], None]:
        return self._server.observe(observer)

    def inject(self, msg: Message, *, received_ns: int) -> Injected:
        return self._server.inject(msg, received_ns=received_ns)
